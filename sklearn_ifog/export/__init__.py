"""Deployment of a fitted compensation Pipeline: self-contained C99 and JSON."""

from sklearn_ifog.export._c import to_c, to_c_units
from sklearn_ifog.export._json import to_json

__all__ = ["to_c", "to_c_units", "to_json"]
