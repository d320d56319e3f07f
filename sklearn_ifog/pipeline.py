"""The package's recommended model: ThermalFeatures → StandardScaler → regressor.

:func:`make_compensation_pipeline` builds it; the command line, the demo, the paper's
experiments and :func:`~sklearn_ifog.comparison.default_regressors` all build their
drift models with it, so the step names (``"features"``, ``"scale"``, ``"regressor"``) and
the feature defaults are the same everywhere. It is a :class:`CompensationPipeline`: a
scikit-learn Pipeline that also learns its calibration domain and stays safe outside it.
"""

import numbers
import warnings
from typing import ClassVar

import numpy as np
from sklearn.base import clone, is_regressor
from sklearn.metrics import r2_score
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.metaestimators import available_if
from sklearn.utils.validation import check_is_fitted, has_fit_parameter

from sklearn_ifog import _handover, scale_factor
from sklearn_ifog._compat import (
    HasMethods,
    StrOptions,
    _fit_context,
    _routing_enabled,
    _safe_indexing,
)
from sklearn_ifog._contract import get_term, sensor_keys
from sklearn_ifog._output_layer import (
    final_step,
    layer_design,
    layer_kind,
    supported_names,
    write_weights,
)
from sklearn_ifog._table import as_float_rows, as_table, label_column
from sklearn_ifog._tuning import HANDOVER_FOLDS, ROUNDOFF_SHARE
from sklearn_ifog.domain import (
    CalibrationDomain,
    OutsideCalibrationWarning,
    check_varies,
    locate,
    threshold_of,
)
from sklearn_ifog.fallback import fit_fallback
from sklearn_ifog.features import ThermalFeatures
from sklearn_ifog.policy import POLICY_NAMES, policy_for
from sklearn_ifog.rbf._network import RBFNetRegressor

__all__ = ["CompensationPipeline", "make_compensation_pipeline"]


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
    uncalibrated="blend",
    margin=1.5,
    alpha=0.02,
    handover=False,
    input_rate=None,
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
    uncalibrated : {"blend", "clip", "none"}, default="blend"
        What the model predicts where it was not calibrated, for rows outside its
        calibration domain (:class:`CompensationPipeline`): ``"blend"`` moves smoothly to
        its fallback (a plane in T and dT, a line in T or a constant,
        :func:`~sklearn_ifog.fallback.fit_fallback`) as the row lies farther out;
        ``"clip"`` predicts at the domain's edge; ``"none"`` leaves the regressor's
        extrapolation alone.
    margin : float, default=1.5
        Smallest distance outside the calibrated box, in decorrelated standard deviations,
        that still counts as inside: the pipeline's ``domain`` is
        ``CalibrationDomain(margin=margin, alpha=alpha)``, so ``domain__margin`` and
        ``domain__alpha`` are its parameters in a grid search (another detector:
        ``set_params(domain=...)``, see :class:`CompensationPipeline`).
    alpha : float, default=0.02
        Share of the rows of a new run of a calibrated profile that the domain flags: its
        threshold is calibrated at fit on runs of the calibration held out in turn
        (:class:`~sklearn_ifog.domain.CalibrationDomain`).
    handover : bool, default=False
        Whether the domain also widens where held-out runs show the model beating its
        fallback, per kind of novelty (:class:`CompensationPipeline`).
    input_rate : str, int or None, default=None
        Column of X holding the true input rate (deg/h, the output's unit) of rate-table
        calibration data: the model then learns the drift as bias plus scale-factor error,
        ``b(x) + Ω s(x)`` (:mod:`sklearn_ifog.scale_factor`), and
        :meth:`CompensationPipeline.compensate` returns the input rate. None: the bias alone
        (a static calibration).
    **feature_params
        Further parameters of :class:`~sklearn_ifog.ThermalFeatures` (``smoothing``,
        ``rate_unit``).

    Returns
    -------
    pipeline : CompensationPipeline
        The unfitted pipeline (a :class:`sklearn.pipeline.Pipeline`).

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
    sklearn_ifog.comparison.default_regressors : Pipelines with other regressors.

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
    >>> model.get_params()["domain__margin"], model.get_params()["domain__alpha"]
    (1.5, 0.02)
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
    scale = StandardScaler()
    if _routing_enabled():
        # With metadata routing a sample_weight meant for the regressor must not stop at the
        # scaler, which would otherwise have to say whether it wants it: it does not.
        scale.set_fit_request(sample_weight=False)
    return CompensationPipeline(
        [("features", features), ("scale", scale), ("regressor", regressor)],
        domain=CalibrationDomain(margin=margin, alpha=alpha),
        uncalibrated=uncalibrated,
        handover=handover,
        input_rate=input_rate,
    )


def _sensor_columns(features, term):
    """Columns of every sensor's ``term`` among a fitted ThermalFeatures' outputs (first
    sensor first); empty for another first step or without that term."""
    if not isinstance(features, ThermalFeatures) or term not in features.terms_:
        return []
    terms = list(features.terms_)
    first_sensor_terms = [name for name in terms if get_term(name).first_sensor]
    n_sensors = len(sensor_keys(features.temperature))
    later = len(first_sensor_terms) + terms.index(term)
    return [first_sensor_terms.index(term)] + [
        later + sensor * len(terms) for sensor in range(n_sensors - 1)
    ]


def _run_labels(features, X):
    """The run of every row of ``X`` (None for another first step or without a run column)."""
    if not isinstance(features, ThermalFeatures) or features.run is None:
        return None
    return label_column(X, features.run, param="run")


def _in_run_order(features, X, y, params):
    """``X``, ``y`` and the per-row fit ``params`` with the runs in the order of their labels
    (each run's rows in their own order), so that a fit does not depend on the order in
    which the runs were passed: a network's held-out blocks and subsamples are drawn by row
    position. Unchanged (the same objects) when the runs are already in that order or the
    first step names no run column."""
    runs = _run_labels(features, X)
    if runs is None:
        return X, y, params
    codes = np.unique(runs, return_inverse=True)[1].ravel()
    order = np.argsort(codes, kind="stable")
    if np.array_equal(order, np.arange(codes.size)):
        return X, y, params
    return (
        _safe_indexing(X, order),
        _safe_indexing(y, order),
        _params_of_rows(params, order, codes.size),
    )


def _params_of_rows(params, rows, n_samples):
    """The fit ``params`` for the rows ``rows`` (positions among ``n_samples``): every value
    with one entry per row (sample weights, run groups) indexed by them, the others (a
    string, a scalar) as they are."""
    return {
        name: _safe_indexing(value, rows)
        if hasattr(value, "__len__") and not isinstance(value, str) and len(value) == n_samples
        else value
        for name, value in params.items()
    }


def _takes_fallback(uncalibrated):
    """Whether the policy ``uncalibrated`` names takes a fallback (False for a bad name:
    ``hasattr`` must not raise; fit and predict name the bad value)."""
    return uncalibrated in POLICY_NAMES and policy_for(uncalibrated).uses_fallback


def _is_domain_default_or_box(domain):
    """Whether ``domain`` (the parameter) is None or a CalibrationDomain-like box."""
    return domain is None or hasattr(domain, "extend")


def _fit_detector(domain, raw, temperature, rate, runs):
    """The fitted clone of the ``domain`` parameter (None: a CalibrationDomain).

    A detector with ``temperature`` / ``rate`` parameters left at None is given the feature
    step's T and dT columns; one whose ``fit`` takes ``groups`` is given the runs.
    """
    detector = CalibrationDomain() if domain is None else clone(domain)
    given = detector.get_params(deep=False)
    columns = {"temperature": temperature, "rate": rate}
    detector.set_params(
        **{key: value for key, value in columns.items() if key in given and given[key] is None}
    )
    if has_fit_parameter(detector, "groups"):
        return detector.fit(raw, groups=runs)
    return detector.fit(raw)


def _like(template, values):
    """``values`` in the container of ``template`` (a pandas DataFrame keeps its columns)."""
    if type(template).__module__.startswith("pandas"):
        import pandas as pd

        return pd.DataFrame(values, columns=template.columns)
    return values


class CompensationPipeline(Pipeline):
    """A compensation Pipeline that knows where it was calibrated and stays safe outside.

    A :class:`sklearn.pipeline.Pipeline` (same steps, names, parameters and methods) whose
    first step computes the thermal features. At :meth:`fit` it also learns, from those
    features, its calibration domain (:class:`~sklearn_ifog.domain.CalibrationDomain`: the
    temperatures, rates and thermal states, and their combinations, that the calibration
    covered) and a conservative fallback (a line in the first sensor's T where its slope
    extrapolates, else the calibration's mean drift: :func:`~sklearn_ifog.fallback.fit_fallback`).
    At :meth:`predict`, rows inside the domain get the regressor's prediction unchanged;
    rows outside (farther than its threshold from the domain's decorrelated box, or with a
    temperature beyond its calibrated range) follow the policy ``uncalibrated``, and an
    :class:`~sklearn_ifog.domain.OutsideCalibrationWarning` says how many there were and how
    far out. :func:`make_compensation_pipeline` builds one.

    The detector is a parameter, ``domain``, cloned at :meth:`fit` (as
    :class:`~sklearn.compose.TransformedTargetRegressor` clones its ``transformer``): its
    parameters are ``domain__margin``, ``domain__alpha``, ... for a grid search, and any
    novelty detector in scikit-learn's shape (``fit``, ``predict`` giving -1 for an
    outlier, ``decision_function``; e.g. :class:`~sklearn.covariance.EllipticEnvelope` or
    ``LocalOutlierFactor(novelty=True)``) may take its place, fitted on the thermal
    features. Only a CalibrationDomain knows the calibrated temperatures, can project a
    row (``uncalibrated="clip"``), widen with ``handover`` and be streamed or exported.

    Parameters
    ----------
    steps : list of (str, estimator)
        As for :class:`~sklearn.pipeline.Pipeline`; the first step is the feature step
        (usually :class:`~sklearn_ifog.ThermalFeatures`), the last a regressor.
    domain : estimator, default=None
        The calibration domain's detector, cloned and fitted on the first step's output at
        :meth:`fit` (``domain_``). None: ``CalibrationDomain()`` with its defaults.
        A CalibrationDomain whose ``temperature`` or ``rate`` is None is given the feature
        step's T and dT columns. Another novelty detector: its outliers are outside, and
        the blend's distance is how far its ``decision_function`` lies below 0
        (:func:`~sklearn_ifog.domain.locate`).
    uncalibrated : {"blend", "clip", "none"}, default="blend"
        What the model predicts where it was not calibrated (rows outside the domain; one
        object of :mod:`sklearn_ifog.policy` per name, :func:`~sklearn_ifog.policy.policy_for`).
        ``"blend"`` (:class:`~sklearn_ifog.policy.BlendWithFallback`): ``(1 - w) * model + w *
        fallback`` with ``w`` rising smoothly from 0 at the threshold to 1 at the threshold
        plus the blend's width (:func:`~sklearn_ifog.policy.fallback_weight`), so far outside
        the model gives way to the fallback (no step anywhere). ``"clip"``
        (:class:`~sklearn_ifog.policy.ClipToDomain`): the model at the nearest point of the
        domain (the box widened by the threshold, every temperature clamped to its calibrated
        range: the firmware convention of clamping T to [TMIN, TMAX]). ``"none"``
        (:class:`~sklearn_ifog.policy.KeepModel`): the regressor's own extrapolation (the
        behaviour before the domain existed). The
        default is the policy that ``benchmarks/bench_extrapolation.py`` measures as never
        worse than uncompensated.
    handover : bool, default=False
        Whether the model keeps the kinds of novel rows on which held-out runs show it
        beating its fallback. With at least 3 runs, :meth:`fit` refits the steps on two
        thirds of the runs three times (2.28 to 3.80 times the fit time of the default network
        on the 9-run campaigns of ``python benchmarks/bench_extrapolation.py --tune --n-jobs
        2`` rows "layered_glass s5" and "lumped s3" column "fit time", whose "With
        handover=True" table measures what it buys), predicts the held-out runs, and judges
        their rows
        beyond that fit's domain per kind (temperatures below or above, rates below or
        above, thermal state): where the model beat the fallback by more than one standard
        error, ``domain_`` widens as far as the evidence reached
        (:meth:`~sklearn_ifog.domain.CalibrationDomain.extend`). Where the held-out runs show
        no such rows, nothing changes. Off by default: its fit cost is not yet paid back on
        the benchmark's tuning campaigns. Needs a CalibrationDomain as ``domain``.
    input_rate : str, int or None, default=None
        Column of X holding the true input rate, in the gyro output's unit (deg/h), of
        rate-table calibration data. The drift target ``y = rate - Ω`` is then learnt as
        bias plus scale-factor error, ``b(x) + Ω s(x) + a |Ω|``, ``b`` and ``s`` functions
        of the same thermal features and ``a`` a constant asymmetry between positive and
        negative rates: the final regressor (an :class:`~sklearn_ifog.RBFNetRegressor` or a
        linear model) predicts the two outputs ``[b(x), s(x)]``, its units placed by a fit
        on per-row estimates of both and its output layer solved on the product basis
        ``[Φ(x), Ω Φ(x), |Ω|]`` by least squares, each row weighed by its rate noise
        (:mod:`sklearn_ifog.scale_factor`). :meth:`predict` needs the column and returns
        the drift at that input rate; :meth:`compensate` takes rows without it and returns
        the input rate ``(rate - b) / (1 + s ± a)``. Input rates beyond the calibrated ones are
        outside the calibration too. None: the bias alone (a static calibration; nothing
        else changes).
    transform_input, memory, verbose
        As for :class:`~sklearn.pipeline.Pipeline`.

    Attributes
    ----------
    domain_ : CalibrationDomain or novelty detector
        The fitted clone of ``domain``, fitted on the first step's output (the thermal
        features). Its threshold and false-alarm rate are learnt at :meth:`fit`: changing
        ``domain__margin`` or ``domain__alpha`` takes a refit (``outside`` takes effect at
        once).
    fallback_ : Fallback
        The conservative model outside the domain: ``intercept``, ``slope`` (0 where the
        slope did not extrapolate better than a constant) and ``column`` (of T).
    feature_names_out_ : ndarray of str
        Names of the first step's output columns (the domain's features).
    input_rate_range_ : tuple of float or None
        With ``input_rate``: the lowest and highest calibrated input rates, deg/h (rows
        beyond them by more than 5 % of the larger are outside the calibration).
    rate_noise_ : RateNoise or None
        With ``input_rate``: the rows' noise model ``σ₀² + (κ Ω)²`` the product basis was
        weighted by (:func:`~sklearn_ifog.scale_factor.rate_noise`).
    asymmetry_ : float or None
        With ``input_rate``: the constant asymmetry ``a`` between positive and negative
        input rates (dimensionless): the drift is ``b(x) + Ω s(x) + a |Ω|``.
    handover_ : dict or None
        With ``handover``: per kind of novelty, the held-out ``rows``, the ``model``'s and
        the ``fallback``'s mean squared errors on them, whether the model ``keeps`` the kind
        and the ``extent`` the evidence reached (None without ``handover``, with fewer than
        3 runs, or without temperature and rate features).

    See Also
    --------
    make_compensation_pipeline : Builds the recommended CompensationPipeline.
    sklearn_ifog.domain.CalibrationDomain : The domain, usable alone.

    Examples
    --------
    >>> import warnings
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import make_compensation_pipeline
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> X, y = make_thermal_campaign(
    ...     n_units=1,
    ...     n_runs=2,
    ...     azimuths=[0.0],
    ...     sampling_period=120.0,
    ...     temperature_range=(10.0, 40.0),
    ...     random_state=0,
    ...     return_X_y=True,
    ... )
    >>> model = make_compensation_pipeline(LinearRegression()).fit(X, y)
    >>> bool(model.outside_calibration(X).any())  # the calibration itself is inside
    False
    >>> cold = X.assign(temperature=X["temperature"] - 30.0)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     drift = model.predict(cold)
    >>> caught[0].category.__name__
    'OutsideCalibrationWarning'
    >>> float(model.outside_calibration(cold).mean())
    1.0
    """

    _parameter_constraints: ClassVar[dict] = {
        **Pipeline._parameter_constraints,
        "domain": [HasMethods(["fit", "predict", "decision_function"]), None],
        "uncalibrated": [StrOptions(set(POLICY_NAMES))],
        "handover": ["boolean"],
        "input_rate": [str, numbers.Integral, None],
    }

    def __init__(
        self,
        steps,
        *,
        domain=None,
        uncalibrated="blend",
        handover=False,
        input_rate=None,
        transform_input=None,
        memory=None,
        verbose=False,
    ):
        super().__init__(steps, transform_input=transform_input, memory=memory, verbose=verbose)
        self.domain = domain
        self.uncalibrated = uncalibrated
        self.handover = handover
        self.input_rate = input_rate

    @_fit_context(
        # Pipeline's steps are validated when each is fitted.
        prefer_skip_nested_validation=False
    )
    def fit(self, X, y=None, **params):
        """Fit the steps, then the calibration domain and the fallback.

        With a run column (the first step's ``run``), the rows are fitted run by run in the
        order of the run labels, each run's rows in the order given: the same runs passed in
        another order give the same model, bit for bit.

        Parameters
        ----------
        X : iterable
            Training data, in the first step's layout.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Drift target.
        **params : dict
            As for :meth:`sklearn.pipeline.Pipeline.fit`.

        Returns
        -------
        self : CompensationPipeline
            Fitted.

        Raises
        ------
        ValueError
            As the steps raise; also when a thermal feature is constant over the calibration
            (a single temperature), which leaves no domain to learn.
        """
        if y is None:
            raise ValueError(
                "CompensationPipeline.fit needs the drift target y (rate - reference); got None."
            )
        X, y, params = _in_run_order(self.steps[0][1], X, y, params)
        if hasattr(self.domain, "_validate_params"):
            # A bad domain__alpha fails here, not after the steps' (long) fit.
            clone(self.domain)._validate_params()
        if self.handover and not _is_domain_default_or_box(self.domain):
            raise ValueError(
                "handover=True widens a CalibrationDomain; the pipeline's domain is "
                f"{type(self.domain).__name__}. Use handover=False with another detector."
            )
        if self.input_rate is None:
            super().fit(X, y, **params)
            self.rate_noise_ = self.asymmetry_ = None
        else:
            self._fit_product_basis(X, y, params)
        self.fit_domain(X, y)
        self.handover_ = self._weigh_handover(X, y, params) if self.handover else None
        return self

    def _fit_product_basis(self, X, y, params):
        """Fit the steps for ``b(x) + Ω s(x) + a |Ω|`` (:mod:`sklearn_ifog.scale_factor`).

        A first bias and scale factor, linear in the features, give per-row targets of
        both; the steps are fitted on them (the regressor with two outputs, which places
        its units); its output layer is then solved on the product basis, each row weighed
        by its rate noise (re-learnt from every solve's residuals until it settles).
        """
        final = final_step(self)
        if layer_kind(final) is None:
            raise TypeError(
                "input_rate needs a final regressor with a linear output layer ("
                f"{supported_names()}), got {type(final).__name__}."
            )
        if self.handover or params:
            raise ValueError(
                "input_rate does not take handover=True or fit parameters "
                f"({sorted(params)}); fit the scale factor without them."
            )
        omega = scale_factor.input_rate_of(X, self.input_rate)
        target = np.asarray(y, dtype=np.float64)
        if target.ndim == 2 and target.shape[1] == 1:
            target = target[:, 0]
        if target.ndim != 1:
            raise ValueError(f"input_rate learns one drift target; y has shape {target.shape}.")
        scale_factor.check_input_rate(omega, target, self.input_rate)
        transformers = Pipeline([(name, clone(step)) for name, step in self.steps[:-1]])
        first = as_float_rows(transformers.fit_transform(X))
        first_fit = scale_factor.preliminary_fit(first, target, omega)
        super().fit(X, scale_factor.proxy_targets(target, omega, first_fit))
        Phi = layer_design(final, as_float_rows(self[:-1].transform(X)))
        fit = scale_factor.fit_product_layer(Phi, target, omega, scale_factor.layer_penalty(final))
        write_weights(final, fit.weights)
        self.asymmetry_ = fit.asymmetry
        self.rate_noise_ = fit.noise

    def _weigh_handover(self, X, y, params):
        """Held-out evidence per kind of novelty (:mod:`sklearn_ifog._handover`): the
        pipeline refitted on two thirds of the runs predicts the others, the rows beyond
        that fit's domain are judged per kind, and the domain widens where the model beat
        its fallback there. None (nothing changes) with fewer than 3 runs or without
        temperature and rate columns."""
        runs = _run_labels(self.steps[0][1], X)
        domain = self.domain_
        if runs is None or not (domain.temperature_columns_ and domain.rate_columns_):
            return None
        labels = np.unique(runs, return_inverse=True)[1].ravel()
        if labels.max() + 1 < HANDOVER_FOLDS:
            return None
        folds = labels % HANDOVER_FOLDS
        Y = np.asarray(y, dtype=np.float64).reshape(labels.size, -1)
        evidence = {kind: [] for kind in _handover.KINDS}
        for fold in range(HANDOVER_FOLDS):
            kept, held = np.flatnonzero(folds != fold), np.flatnonzero(folds == fold)
            model = clone(self)
            rows = _params_of_rows(params, kept, labels.size)
            X_kept, X_held = _safe_indexing(X, kept), _safe_indexing(X, held)
            with warnings.catch_warnings():
                # The main fit has already said what its steps warn of.
                warnings.simplefilter("ignore")
                Pipeline.fit(model, X_kept, _safe_indexing(y, kept), **rows)
                model.fit_domain(X_kept, _safe_indexing(y, kept))
            features = model.steps[0][1].transform(X_held)
            raw = as_float_rows(features)
            network = model._predict_features(features).reshape(held.size, -1)
            found = _handover.collect(
                raw, Y[held], network, model.fallback_.predict(raw), model.domain_
            )
            for kind, part in found.items():
                evidence[kind].append(part)
        decision = _handover.decide(evidence)

        def reach(kind):
            return decision[kind]["extent"] if decision[kind]["keeps"] else None

        def widened(bound, kind, sign):
            extent = reach(kind)
            return None if extent is None else bound + sign * extent

        domain.extend(
            threshold=reach("thermal state"),
            rate_low=widened(domain.rate_low_, "rates below", -1.0),
            rate_high=widened(domain.rate_high_, "rates above", 1.0),
            temperature_low=widened(domain.boost_low_, "temperatures below", -1.0),
            temperature_high=widened(domain.boost_high_, "temperatures above", 1.0),
        )
        return decision

    def fit_domain(self, X, y):
        """(Re)learn the calibration domain and the fallback from the rows ``X``, ``y``.

        :meth:`fit` calls it after fitting the steps. Call it alone to give a fitted
        pipeline the domain of other calibration rows (partial pooling gives each unit's
        copy of the lot's model the domain of that unit's rows); the steps are not refitted.

        Parameters
        ----------
        X : iterable
            Calibration rows, in the first step's layout.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Their drift.

        Returns
        -------
        self : CompensationPipeline
            With ``domain_``, ``fallback_`` and ``feature_names_out_`` learnt from them.

        Raises
        ------
        ValueError
            With fewer than 2 rows, or a thermal feature constant over them.
        """
        features = self.steps[0][1]
        raw = as_float_rows(features.transform(X))
        names = np.asarray(features.get_feature_names_out(), dtype=object)
        if raw.shape[0] < 2:
            raise ValueError(
                "CompensationPipeline needs at least 2 calibration rows to learn its "
                f"calibration domain, got n_samples={raw.shape[0]}."
            )
        check_varies(raw, names)
        columns = _sensor_columns(features, "T")
        rates = _sensor_columns(features, "dT")
        self.feature_names_out_ = names
        runs = _run_labels(features, X)
        self.domain_ = _fit_detector(self.domain, raw, columns, rates, runs)
        column = columns[0] if columns else None
        rate_column = rates[0] if rates else None
        Y = np.asarray(y, dtype=np.float64).reshape(raw.shape[0], -1)
        self.input_rate_range_ = None
        if self.input_rate is not None:
            # The fallback of [b, s]: the bias the rows show once the model's scale factor
            # and asymmetry are taken out, and the model's scale factor, each a line in T
            # where held-out runs confirm it (a firmware's scale-factor line in T, at worst
            # a constant).
            omega = scale_factor.input_rate_of(X, self.input_rate)
            modelled = self._predict_features(features.transform(X)).reshape(-1, 2)
            shown = Y[:, 0] - omega * modelled[:, 1] - self.asymmetry_ * np.abs(omega)
            # Where the input rate's noise exceeds the bias noise the row does not show the
            # bias (what the scale factor's model leaves there would decide the fallback):
            # it gives the model's bias instead, as the network's proxy targets do.
            noise = self.rate_noise_
            low = np.abs(noise.kappa * omega) <= noise.sigma0
            Y = np.column_stack([np.where(low, shown, modelled[:, 0]), modelled[:, 1]])
            self.input_rate_range_ = (float(omega.min()), float(omega.max()))
        self.fallback_ = fit_fallback(
            None if column is None else raw[:, column],
            Y,
            column,
            rate=None if rate_column is None else raw[:, rate_column],
            rate_column=rate_column,
            runs=runs,
        )
        return self

    def _where(self, rows):
        """Distance to the box, degrees beyond the calibrated temperatures, outside flag."""
        return locate(self.domain_, rows)

    def _where_of(self, X):
        """:meth:`_where` of the rows ``X`` through the feature step."""
        return self._where(as_float_rows(self._transform_features(X)))

    def _transform_features(self, X):
        check_is_fitted(self, "domain_")
        return self.steps[0][1].transform(X)

    def _predict_features(self, features, **params):
        """The regressor's prediction from the first step's output."""
        Xt = features
        for _, step in self.steps[1:-1]:
            if step not in (None, "passthrough"):
                Xt = step.transform(Xt)
        return np.asarray(self.steps[-1][1].predict(Xt, **params), dtype=np.float64)

    def calibration_distance(self, X):
        """Distance of every row outside the calibration domain's box (0 inside it).

        In decorrelated standard deviations
        (:meth:`~sklearn_ifog.domain.CalibrationDomain.distance`); a row is outside when
        this exceeds ``domain_.threshold_`` or when a temperature lies beyond its calibrated range
        (:meth:`outside_calibration`).

        Parameters
        ----------
        X : iterable
            Rows in the layout of :meth:`fit` (the features are computed run by run).

        Returns
        -------
        distance : ndarray of shape (n_samples,)
        """
        return self._where_of(X).distance

    def outside_calibration(self, X):
        """Whether every row lies outside the calibration domain.

        Outside: farther than ``domain_.threshold_`` from the decorrelated box, or a
        temperature beyond its calibrated range (:func:`~sklearn_ifog.domain.outside_domain`).

        Parameters
        ----------
        X : iterable
            Rows in the layout of :meth:`fit`.

        Returns
        -------
        outside : ndarray of shape (n_samples,), dtype=bool
            With ``input_rate``, also where the row's input rate (its column of ``X``)
            lies beyond the calibrated input rates.
        """
        outside = self._where_of(X).outside
        if self.input_rate is None:
            return outside
        return outside | self._beyond_input_rates(scale_factor.input_rate_of(X, self.input_rate))

    @available_if(lambda self: _takes_fallback(self.uncalibrated))
    def fallback_share(self, X):
        """The fallback's share of every row's prediction (0 inside the domain).

        The weight ``w`` of ``(1 - w) * model + w * fallback``
        (:meth:`~sklearn_ifog.policy.UncalibratedPolicy.fallback_share`). Available when
        ``uncalibrated`` takes a fallback (``"blend"``). Part of the calibration protocol
        that :class:`~sklearn_ifog.UnitwiseRegressor` and
        :class:`~sklearn_ifog.ConformalRegressor` follow too (with
        :meth:`outside_calibration`, :meth:`calibration_distance`,
        :meth:`fallback_predict` and :meth:`calibrated_parts`): the report, the conformal
        band and the exports ask it rather than the model's class.

        Parameters
        ----------
        X : iterable
            Rows in the layout of :meth:`fit`.

        Returns
        -------
        share : ndarray of shape (n_samples,)
            In [0, 1].
        """
        where = self._where_of(X)
        policy = policy_for(self.uncalibrated)
        return policy.fallback_share(where.distance, threshold_of(self.domain_))

    def fallback_predict(self, X):
        """What the fallback (``fallback_``) predicts for every row, in the shape of predict.

        Parameters
        ----------
        X : iterable
            Rows in the layout of :meth:`fit`.

        Returns
        -------
        y_fallback : ndarray of shape (n_samples,) or (n_samples, n_outputs)
        """
        rows = as_float_rows(self._transform_features(X))
        predicted = self.fallback_.predict(rows)
        if self.input_rate is not None:
            # The fallback of [b, s], at each row's input rate.
            omega = scale_factor.input_rate_of(X, self.input_rate)
            return scale_factor.drift_of(predicted, omega, self.asymmetry_)
        return predicted[:, 0] if predicted.shape[1] == 1 else predicted

    def calibrated_parts(self, X):
        """Which fitted pipeline, with its calibration domain, predicts which rows of ``X``.

        For a pipeline, itself with every row; :meth:`UnitwiseRegressor.calibrated_parts
        <sklearn_ifog.UnitwiseRegressor.calibrated_parts>` gives each unit's pipeline its
        rows. The report reads each part's domain and fallback.

        Parameters
        ----------
        X : iterable
            Rows in the layout of :meth:`fit`.

        Returns
        -------
        parts : list of tuple (pipeline, X_part, rows)
            ``rows``: the positions of ``X_part``'s rows in ``X`` (int ndarray).
        """
        check_is_fitted(self, "domain_")
        return [(self, X, np.arange(as_table(X).shape[0]))]

    def predict(self, X, **params):
        """Predict the drift, following ``uncalibrated`` for rows outside the domain.

        Parameters
        ----------
        X : iterable
            Rows in the layout of :meth:`fit`.
        **params : dict
            Passed to the final step's ``predict``.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)

        Warns
        -----
        OutsideCalibrationWarning
            Once per call when rows lie outside the domain.
        """
        if self.input_rate is None:
            return self._policed(X, **params)
        omega = scale_factor.input_rate_of(X, self.input_rate)
        prediction = self._policed(X, **params)
        self._warn_input_rates(omega)
        return scale_factor.drift_of(prediction, omega, self.asymmetry_)

    def _policed(self, X, **params):
        """The regressor's prediction with ``uncalibrated`` applied: the drift, or with
        ``input_rate`` the ``[b, s]`` pair (n_samples, 2)."""
        features = self._transform_features(X)
        rows = as_float_rows(features)
        prediction = self._predict_features(features, **params)
        distance, beyond, outside = self._where(rows)
        if not outside.any():
            return prediction
        self._warn_outside(distance, beyond, outside, rows)

        def evaluate(projected):
            predicted = self._predict_features(_like(features, projected), **params)
            return predicted.reshape(projected.shape[0], -1)

        policed = policy_for(self.uncalibrated).apply(
            prediction.reshape(rows.shape[0], -1),
            rows,
            distance,
            outside,
            domain=self.domain_,
            fallback=self.fallback_,
            evaluate=evaluate,
        )
        return policed.reshape(prediction.shape)

    def _beyond_input_rates(self, omega):
        """Rows whose input rate lies beyond the calibrated ones (by more than 5 % of the
        larger calibrated magnitude; all False without ``input_rate``)."""
        if self.input_rate_range_ is None:
            return np.zeros(np.shape(omega), dtype=bool)
        return scale_factor.beyond_input_rates(omega, *self.input_rate_range_)

    def _warn_input_rates(self, omega):
        beyond = self._beyond_input_rates(omega)
        if beyond.any():
            low, high = self.input_rate_range_
            warnings.warn(
                f"{beyond.sum()} of {beyond.size} rows ({beyond.mean():.1%}) have input rates "
                f"beyond the calibrated {low:.6g} to {high:.6g} deg/h (up to "
                f"{np.abs(omega[beyond]).max():.6g}): the scale factor there is the "
                "calibrated one, its change with the input rate unknown.",
                OutsideCalibrationWarning,
                stacklevel=3,
            )

    def compensate(self, X, rate):
        """The input rate every gyro output stands for, the drift taken out.

        Without ``input_rate``: ``rate - predict(X)``. With it: ``(rate - b(x)) / (1 +
        s(x) + a sign(rate - b(x)))``
        (:func:`~sklearn_ifog.scale_factor.input_rate_estimate`), the bias and the
        scale-factor error at each row's thermal features; ``X`` needs no input-rate
        column, and the output's size stands in for the input rate in the calibration
        check. ``uncalibrated`` applies as in :meth:`predict`.

        Parameters
        ----------
        X : iterable
            Rows in the layout of :meth:`fit` (the input-rate column may be absent).
        rate : array-like of shape (n_samples,) or (n_samples, n_outputs)
            The gyro output, deg/h (one column per output of a bias-only model that
            predicts several, e.g. gyro axes).

        Returns
        -------
        compensated : ndarray of the shape of ``rate``
            The estimated input rate, deg/h.

        Raises
        ------
        ValueError
            If ``rate`` is not one finite value per row of ``X`` (and output).
        """
        values = np.asarray(rate, dtype=np.float64)
        n_samples = as_table(X).shape[0]
        if values.shape[:1] != (n_samples,) or not np.isfinite(values).all():
            raise ValueError(
                f"rate must hold one finite gyro output per row of X ({n_samples}), got "
                f"shape {values.shape}."
            )
        if self.input_rate is None:
            prediction = self._policed(X)
            if prediction.size != values.size:
                raise ValueError(
                    f"rate has shape {values.shape}, the model predicts "
                    f"{prediction.shape}: give one gyro output per row and output."
                )
            return values - prediction.reshape(values.shape)
        if values.ndim != 1:
            raise ValueError(
                f"rate must be 1-D for a scale-factor model (one gyro output per row), got "
                f"shape {values.shape}."
            )
        first = self.steps[0][1]
        X = scale_factor.with_input_rate(
            X,
            self.input_rate,
            values,
            getattr(first, "feature_names_in_", None),
            first.n_features_in_,
        )
        prediction = self._policed(X)
        self._warn_input_rates(values)
        return scale_factor.input_rate_estimate(prediction, values, self.asymmetry_)

    def _warn_outside(self, distance, beyond, outside, rows):
        message = (
            f"{outside.sum()} of {outside.size} rows ({outside.mean():.1%}) lie outside the "
            f"calibration domain (largest distance {distance.max():.3g} decorrelated "
            "standard deviations"
        )
        if beyond.max() > 0:  # only a CalibrationDomain measures it
            column = self.domain_.temperature_columns_[0]
            low, high = self.domain_.data_min_[column], self.domain_.data_max_[column]
            message += (
                f"; up to {beyond.max():.3g} degC beyond the calibrated temperatures "
                f"{low:.4g} to {high:.4g} degC"
            )
        rates = list(getattr(self.domain_, "rate_columns_", []))
        if rates:
            # The first sensor's rate, in the rate feature's own unit (degC per minute by
            # default), as the temperatures are read in degC.
            column = rates[0]
            low, high = self.domain_.data_min_[column], self.domain_.data_max_[column]
            rate = rows[outside, column]
            excess = float(np.max(np.maximum(low - rate, 0.0) + np.maximum(rate - high, 0.0)))
            if excess > ROUNDOFF_SHARE * (high - low):  # beyond round-off (the CLI's rule)
                message += (
                    f"; rates up to {excess:.3g} beyond the calibrated "
                    f"{self.feature_names_out_[column]} {low:.3g} to {high:.3g}"
                )
        message += f"); their predictions follow uncalibrated={self.uncalibrated!r}."
        warnings.warn(message, OutsideCalibrationWarning, stacklevel=4)

    def score(self, X, y=None, sample_weight=None, **params):
        """R² of :meth:`predict` (the ``uncalibrated`` policy included).

        Parameters
        ----------
        X : iterable
            Rows in the layout of :meth:`fit`.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            True drift.
        sample_weight : array-like of shape (n_samples,), default=None
            Sample weights.
        **params : dict
            Passed to the final step's ``predict``.

        Returns
        -------
        score : float
        """
        return r2_score(y, self.predict(X, **params), sample_weight=sample_weight)

    def __getitem__(self, ind):
        """A step, or for a slice a plain :class:`~sklearn.pipeline.Pipeline` of the steps.

        A slice has no calibration domain of its own (it is usually the transformers only,
        e.g. ``model[:-1].transform(X)``).
        """
        if isinstance(ind, slice):
            if ind.step not in (1, None):
                raise ValueError("Pipeline slicing only supports a step of 1")
            return Pipeline(self.steps[ind], memory=self.memory, verbose=self.verbose)
        return super().__getitem__(ind)
