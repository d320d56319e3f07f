"""Gaussian radial-basis-function networks."""

from sklearn_ifog.rbf._network import RBFNetRegressor

__all__ = ["RBFNetRegressor"]
