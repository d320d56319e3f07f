"""Saving and loading fitted models, with the versions they were made under.

Two formats:

- ``"joblib"`` (pickle): fast and complete, for files you made yourself or otherwise trust.
  Loading a pickle runs code chosen by whoever wrote the file; never load one from elsewhere.
- ``"skops"`` (:mod:`skops.io`): a zip of JSON and arrays that is only turned into objects of
  the types you trust. :data:`TRUSTED_TYPES` lists the types the package's models are made of
  beyond those skops trusts by default; a file holding any other type is refused.

Both wrap the model with metadata — the sklearn-ifog, scikit-learn, numpy and Python versions,
the creation time, the model's class and its input columns, plus anything the caller adds — and
are written atomically (to a temporary file in the same directory, then renamed), so a failure
never leaves a half-written model behind. Loading a model saved under another sklearn-ifog or
scikit-learn version emits a :class:`ModelVersionWarning` naming both versions.
"""

import datetime
import json
import os
import platform
import warnings
import zipfile
from pathlib import Path

import joblib
import numpy as np
import sklearn

from sklearn_ifog import _version
from sklearn_ifog._io import atomic_path

__all__ = ["TRUSTED_TYPES", "ModelVersionWarning", "load_model", "save_model"]

#: Types, beyond those :mod:`skops.io` trusts by default, that the package's models and the
#: default models of :func:`sklearn_ifog.comparison.compare_regressors` are made of, and
#: no more. Pass it as ``trusted=`` to :func:`skops.io.load` (:func:`load_model` does so by
#: default). Found with :func:`skops.io.get_untrusted_types` on the fitted models; skops
#: already trusts scikit-learn's estimators, numpy arrays and dtypes, and Python builtins.
TRUSTED_TYPES = [
    # the package's estimators
    "sklearn_ifog.conformal.ConformalRegressor",
    "sklearn_ifog.domain.CalibrationDomain",
    "sklearn_ifog.fallback.Fallback",
    "sklearn_ifog.features.ThermalFeatures",
    "sklearn_ifog.pipeline.CompensationPipeline",
    "sklearn_ifog.comparison.SubsampledRegressor",
    "sklearn_ifog.rbf._network.RBFNetRegressor",
    "sklearn_ifog.scale_factor.RateNoise",
    "sklearn_ifog._transition.Transition",
    "sklearn_ifog.unitwise.UnitwiseRegressor",
    # the kernel of compare_regressors' Gaussian process baseline (kernels are not estimators,
    # so skops does not trust them by default)
    "sklearn.gaussian_process.kernels.ConstantKernel",
    "sklearn.gaussian_process.kernels.Product",
    "sklearn.gaussian_process.kernels.RBF",
    "sklearn.gaussian_process.kernels.Sum",
    "sklearn.gaussian_process.kernels.WhiteKernel",
]

_FORMAT_NAME = "sklearn-ifog-model"
_FORMAT_VERSION = 1
_FORMATS = ("joblib", "skops")


class ModelVersionWarning(UserWarning):
    """A model file was saved under another version of sklearn-ifog or scikit-learn.

    Its predictions may differ or it may fail to load properly; refit the model under the
    current versions where you can.

    Parameters
    ----------
    message : str
        The warning text; it names each package whose version differs, with both versions.
    mismatches : dict
        ``{package: (saved_version, current_version)}`` for each package that differs.

    Examples
    --------
    >>> from sklearn_ifog.persistence import ModelVersionWarning
    >>> warning = ModelVersionWarning("differs", {"sklearn-ifog": ("0.1.0", "0.2.0")})
    >>> warning.mismatches["sklearn-ifog"]
    ('0.1.0', '0.2.0')
    """

    def __init__(self, message, mismatches):
        super().__init__(message)
        self.mismatches = dict(mismatches)


def _package_version():
    return _version.__version__


def _feature_columns(model):
    names = getattr(model, "feature_names_in_", None)
    return None if names is None else [str(name) for name in names]


def _check_json_like(metadata):
    """Reject metadata that neither skops nor a reader could hold as plain data."""
    try:
        return json.loads(json.dumps(metadata, allow_nan=False))
    except (TypeError, ValueError) as error:
        raise TypeError(
            "metadata must be plain data (dict of str keys to str, int, float, bool, None, "
            f"lists and dicts of them): {error}"
        ) from error


def _resolve_format(path, format):
    if format is None:
        return "skops" if Path(path).suffix.lower() == ".skops" else "joblib"
    if format not in _FORMATS:
        raise ValueError(f"format must be one of {_FORMATS} or None, got {format!r}.")
    return format


def _import_skops():
    try:
        import skops.io
    except ImportError as error:  # pragma: no cover - depends on the installation
        raise ImportError(
            "The skops format needs the skops package: pip install 'sklearn-ifog[skops]'."
        ) from error
    return skops.io


def save_model(model, path, *, format=None, metadata=None):
    """Save a fitted model with its versions and metadata, atomically.

    Parameters
    ----------
    model : estimator
        A fitted estimator or Pipeline.
    path : str or path-like
        The file to write. Its directory must exist. An existing file is replaced only once
        the new one is complete.
    format : {"joblib", "skops"} or None, default=None
        ``"joblib"`` (pickle; for trusted files) or ``"skops"`` (safe to load from elsewhere
        with :data:`TRUSTED_TYPES`). None picks ``"skops"`` for a ``.skops`` suffix and
        ``"joblib"`` otherwise.
    metadata : dict or None, default=None
        Extra plain data (str keys; str, numbers, bool, None, lists and dicts) stored with
        the model, returned by ``load_model(..., return_metadata=True)`` under ``"extra"``.

    Returns
    -------
    metadata : dict
        What was stored next to the model: ``format``, ``format_version``,
        ``sklearn_ifog_version``, ``sklearn_version``, ``numpy_version``,
        ``python_version``, ``created`` (UTC, ISO 8601), ``model_class``,
        ``feature_columns`` (the model's ``feature_names_in_``, or None) and ``extra``.

    Raises
    ------
    ValueError
        If ``format`` is unknown.
    TypeError
        If ``metadata`` is not plain data.

    See Also
    --------
    load_model : Read the file back.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog.persistence import load_model, save_model
    >>> model = LinearRegression().fit([[0.0], [1.0]], [1.0, 3.0])
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     path = pathlib.Path(directory) / "model.joblib"
    ...     stored = save_model(model, path, metadata={"rate": "rate"})
    ...     loaded, read = load_model(path, return_metadata=True)
    >>> float(loaded.predict([[2.0]])[0])
    5.0
    >>> read["extra"], read["model_class"]
    ({'rate': 'rate'}, 'sklearn.linear_model._base.LinearRegression')
    """
    format = _resolve_format(path, format)
    extra = _check_json_like({} if metadata is None else dict(metadata))
    stored = {
        "format": _FORMAT_NAME,
        "format_version": _FORMAT_VERSION,
        "sklearn_ifog_version": _package_version(),
        "sklearn_version": sklearn.__version__,
        "numpy_version": np.__version__,
        "python_version": platform.python_version(),
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "model_class": f"{type(model).__module__}.{type(model).__qualname__}",
        "feature_columns": _feature_columns(model),
        "extra": extra,
    }
    payload = {"metadata": stored, "model": model}
    with atomic_path(path) as temporary:
        if format == "skops":
            _import_skops().dump(payload, temporary)
        else:
            joblib.dump(payload, temporary)
    return stored


def _warn_on_version_mismatch(metadata, path):
    current = {
        "sklearn-ifog": _package_version(),
        "scikit-learn": sklearn.__version__,
    }
    saved = {
        "sklearn-ifog": metadata.get("sklearn_ifog_version"),
        "scikit-learn": metadata.get("sklearn_version"),
    }
    mismatches = {
        package: (saved[package], current[package])
        for package in current
        if saved[package] != current[package]
    }
    if mismatches:
        described = "; ".join(
            f"{package} {old} (this is {package} {new})"
            for package, (old, new) in mismatches.items()
        )
        warnings.warn(
            ModelVersionWarning(
                f"The model in {os.fspath(path)!r} was saved with {described}. Its predictions "
                "may differ; refit it under the current versions where you can.",
                mismatches,
            ),
            stacklevel=3,
        )


def load_model(path, *, trusted=None, return_metadata=False):
    """Load a model written by :func:`save_model`.

    The format is read from the file itself (a skops file is a zip archive).

    Parameters
    ----------
    path : str or path-like
        The model file.
    trusted : list of str or None, default=None
        skops files only: the types, beyond skops' defaults, that may be built from the
        file. None means :data:`TRUSTED_TYPES`. Pass ``TRUSTED_TYPES + [...]`` to allow more
        of your own types after checking them with :func:`skops.io.get_untrusted_types`.
    return_metadata : bool, default=False
        Also return the metadata dict stored with the model.

    Returns
    -------
    model : estimator
        The fitted model.
    metadata : dict
        Only with ``return_metadata=True``; see :func:`save_model`.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    skops.io.exceptions.UntrustedTypesFoundException
        If a skops file holds a type that is neither trusted by skops nor in ``trusted``.
    ValueError
        If the file was not written by :func:`save_model`.

    Warns
    -----
    ModelVersionWarning
        If the file was saved under another sklearn-ifog or scikit-learn version.

    Notes
    -----
    A joblib file is a pickle: loading it can run arbitrary code. Only load joblib files you
    trust; exchange models as skops files.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from sklearn.preprocessing import StandardScaler
    >>> from sklearn_ifog.persistence import load_model, save_model
    >>> scaler = StandardScaler().fit([[1.0], [3.0]])
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     path = pathlib.Path(directory) / "scaler.skops"
    ...     _ = save_model(scaler, path)
    ...     loaded = load_model(path)
    >>> loaded.transform([[5.0]]).tolist()
    [[3.0]]
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"No model file at {os.fspath(path)!r}.")
    if zipfile.is_zipfile(path):
        skops_io = _import_skops()
        payload = skops_io.load(path, trusted=list(TRUSTED_TYPES if trusted is None else trusted))
    else:
        payload = joblib.load(path)
    if (
        not isinstance(payload, dict)
        or not isinstance(payload.get("metadata"), dict)
        or payload["metadata"].get("format") != _FORMAT_NAME
        or "model" not in payload
    ):
        raise ValueError(
            f"{os.fspath(path)!r} is not a model file written by sklearn_ifog.save_model."
        )
    metadata = payload["metadata"]
    _warn_on_version_mismatch(metadata, path)
    if return_metadata:
        return payload["model"], metadata
    return payload["model"]
