"""The package's recommended model: ThermalFeatures → StandardScaler → regressor.

:func:`make_compensation_pipeline` builds it; the command line, the demo, the paper's
experiments and :func:`~sklearn_ifog.model_selection.default_regressors` all build their
drift models with it, so the step names (``"features"``, ``"scale"``, ``"regressor"``) and
the feature defaults are the same everywhere.
"""

from sklearn.base import is_regressor
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog.features import ThermalFeatures
from sklearn_ifog.rbf import RBFNetRegressor

__all__ = ["make_compensation_pipeline"]

# The term the reference paper adds to the "traditional" model (T, ΔT) to get its "modified"
# one (T, ΔT, T·ΔT).
_INTERACTION_TERM = "TdT"


def _traditional_terms(terms):
    """``terms`` without the T·ΔT term: the reference paper's traditional model."""
    return tuple(term for term in terms if term != _INTERACTION_TERM)


def _is_regressor(estimator):
    """scikit-learn's is_regressor, False (not an error) for what is no estimator at all."""
    if not hasattr(estimator, "fit"):
        return False
    try:
        return is_regressor(estimator)
    except AttributeError:  # an object without scikit-learn's tags
        return False


def make_compensation_pipeline(
    regressor=None,
    *,
    temperature="temperature",
    time="time",
    run="run",
    terms=None,
    **feature_params,
):
    """Build the drift model ``ThermalFeatures → StandardScaler → regressor``.

    The thermal features (T, ΔT, T·ΔT by default, computed run by run) are standardised and
    fed to the regressor, which learns the drift (``rate - reference``, deg/h); the
    compensated rate is ``rate - model.predict(X)``. The steps are named ``"features"``,
    ``"scale"`` and ``"regressor"``, so e.g. ``regressor__alpha`` and ``features__terms``
    are grid-searchable parameters.

    Parameters
    ----------
    regressor : regressor, default=None
        The drift regressor, used as given (not cloned). None means
        :class:`~sklearn_ifog.RBFNetRegressor` with its default parameters (pass
        ``RBFNetRegressor(random_state=0)`` for reproducible fits).
    temperature : str, int, list or tuple, default="temperature"
        Temperature column(s) of X (:class:`~sklearn_ifog.ThermalFeatures`).
    time : str, int or None, default="time"
        Time column of X, seconds; None: ΔT is the per-sample difference.
    run : str, int or None, default="run"
        Run id column of X; None: X is one run.
    terms : list or tuple of str, default=None
        Thermal terms; None means :class:`~sklearn_ifog.ThermalFeatures`' default,
        ``"auto"``: with a time column the thermal-state set ``("T", "dT", "TdT", "T2",
        "T_lag900s", "TT_lag900s", "T_lag3600s", "TT_lag3600s")`` with ``dT`` smoothed over
        120 s, without one the paper's terms and T², ``("T", "dT", "TdT", "T2")``.
        ``("T", "dT", "TdT")`` is the paper's modified model (to reproduce the paper),
        ``("T", "dT")`` its traditional model.
    **feature_params
        Further parameters of :class:`~sklearn_ifog.ThermalFeatures` (``smoothing``,
        ``rate_unit``).

    Returns
    -------
    pipeline : sklearn.pipeline.Pipeline
        The unfitted pipeline.

    Raises
    ------
    TypeError
        If ``regressor`` is not a scikit-learn regressor
        (:func:`sklearn.base.is_regressor` is False), or ``feature_params`` holds a name
        ThermalFeatures does not take.

    See Also
    --------
    sklearn_ifog.ThermalFeatures : The feature step.
    sklearn_ifog.RBFNetRegressor : The default regressor.
    sklearn_ifog.model_selection.default_regressors : Pipelines with other regressors.

    Examples
    --------
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import make_compensation_pipeline
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> X, y = make_thermal_campaign(
    ...     n_units=1, n_runs=1, sampling_period=120.0, random_state=0, return_X_y=True
    ... )
    >>> model = make_compensation_pipeline(LinearRegression())
    >>> [name for name, _ in model.steps]
    ['features', 'scale', 'regressor']
    >>> model.named_steps["features"].terms
    'auto'
    >>> drift = model.fit(X, y).predict(X)
    >>> model.named_steps["features"].terms_  # doctest: +NORMALIZE_WHITESPACE
    ('T', 'dT', 'TdT', 'T2', 'T_lag900s', 'TT_lag900s', 'T_lag3600s', 'TT_lag3600s')
    >>> bool(((y - drift) ** 2).mean() < (y**2).mean())
    True
    >>> from sklearn.preprocessing import MinMaxScaler
    >>> make_compensation_pipeline(MinMaxScaler())
    Traceback (most recent call last):
    ...
    TypeError: regressor must be a scikit-learn regressor, got MinMaxScaler() ...
    """
    if regressor is None:
        regressor = RBFNetRegressor()
    elif not _is_regressor(regressor):
        raise TypeError(
            f"regressor must be a scikit-learn regressor, got {regressor!r} (of type "
            f"{type(regressor).__name__}); e.g. RBFNetRegressor() or LinearRegression()."
        )
    if terms is not None:
        feature_params["terms"] = terms
    features = ThermalFeatures(temperature=temperature, time=time, run=run, **feature_params)
    return Pipeline(
        [("features", features), ("scale", StandardScaler()), ("regressor", regressor)]
    )
