"""Data sets: the thermal-test simulator and shipped recordings."""

from sklearn_ifog.datasets._simulator import make_thermal_campaign

__all__ = ["make_thermal_campaign"]
