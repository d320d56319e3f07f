"""sklearn-ifog: temperature-drift compensation for fibre-optic gyroscopes.

Public names only; see DESIGN.md for the contract.
"""

__version__ = "0.1.0.dev0"

from sklearn_ifog.features import ThermalFeatures
from sklearn_ifog.persistence import TRUSTED_TYPES, load_model, save_model
from sklearn_ifog.rbf import RBFNetRegressor

__all__ = [
    "TRUSTED_TYPES",
    "RBFNetRegressor",
    "ThermalFeatures",
    "__version__",
    "load_model",
    "save_model",
]
