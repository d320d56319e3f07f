"""ThermalFeatures (placeholder until the features work lands; being written now)."""

from sklearn.base import BaseEstimator, TransformerMixin


class ThermalFeatures(TransformerMixin, BaseEstimator):
    """Placeholder."""

    def __init__(self, temperature="temperature", time=None, run=None,
                 terms=("T", "dT", "TdT")):
        self.temperature = temperature
        self.time = time
        self.run = run
        self.terms = terms
