"""RBFNetRegressor (placeholder until the RBF work lands; being written now)."""

from sklearn.base import BaseEstimator, RegressorMixin


class RBFNetRegressor(RegressorMixin, BaseEstimator):
    """Placeholder."""
