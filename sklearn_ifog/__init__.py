"""sklearn-ifog: temperature-drift compensation for fibre-optic gyroscopes.

Public names only: the feature transformer, the RBF network, the recommended pipeline, the
per-unit meta-estimator, the calibration domain and model persistence. The rest lives in the
submodules (``datasets``, ``metrics``, ``model_selection``, ``comparison``, ``export``, ...).
"""

from sklearn_ifog._version import __version__
from sklearn_ifog.conformal import ConformalRegressor
from sklearn_ifog.domain import CalibrationDomain, OutsideCalibrationWarning
from sklearn_ifog.features import ThermalFeatures
from sklearn_ifog.persistence import TRUSTED_TYPES, load_model, save_model
from sklearn_ifog.pipeline import CompensationPipeline, make_compensation_pipeline
from sklearn_ifog.rbf import RBFNetRegressor
from sklearn_ifog.unitwise import UnitwiseRegressor

__all__ = [
    "TRUSTED_TYPES",
    "CalibrationDomain",
    "CompensationPipeline",
    "ConformalRegressor",
    "OutsideCalibrationWarning",
    "RBFNetRegressor",
    "ThermalFeatures",
    "UnitwiseRegressor",
    "__version__",
    "load_model",
    "make_compensation_pipeline",
    "save_model",
]
