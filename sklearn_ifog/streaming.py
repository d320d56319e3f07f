"""Online (sample-by-sample or chunked) drift compensation with a fitted Pipeline.

The only stateful step of a compensation Pipeline is :class:`~sklearn_ifog.ThermalFeatures`
(differences, lags and the smoothing are causal recursions); every later step acts row by row.
The compensator therefore carries, between calls, the last temperature of each sensor, the
last time stamp, the deficit of every first-order lag (per sensor and per time constant: the
lag terms and the smoothing, :class:`sklearn_ifog._lags.LagState`) and a first-row flag,
computes the features of a chunk with the same plain functions as the batch transformer,
started from that state, and hands the rows to the fitted steps after ThermalFeatures
unchanged. Its output is the batch Pipeline's, whatever the chunking. A
:class:`~sklearn_ifog.pipeline.CompensationPipeline` also brings its calibration domain:
the same distance of every feature row and the same ``outside`` policy as its ``predict``
(:class:`sklearn_ifog._compiled.CompiledDomain`), and a flag per row instead of a warning.
"""

import copy
import math
import numbers

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted, validate_data

from sklearn_ifog import _table
from sklearn_ifog._compiled import FastRow, compile_domain, compile_steps
from sklearn_ifog._contract import (
    check_needs_time,
    get_term,
    seconds_per_unit,
    sensor_keys,
    state_time_constants,
)
from sklearn_ifog._lags import LagState, lag_deficit
from sklearn_ifog._rls import covariance_trace, initial_factor, rls_sequence, rls_step
from sklearn_ifog.domain import fallback_weight
from sklearn_ifog.features import (
    ThermalFeatures,
    assemble_terms,
    causal_rate,
    validate_terms,
)

__all__ = ["StreamingCompensator", "advance_features"]

STATE_SCHEMA = "sklearn-ifog-streaming-state"
#: 4: the recalibration carries the covariance's square-root factor (``covariance_factor``,
#: version 3 the covariance); 3: the recalibration (``adapt``, ``rls``); 2: the lags' deficits
#: and the last raw temperature (version 1 held an EMA in samples).
STATE_VERSION = 4

#: The recalibration modes of ``StreamingCompensator(adapt=...)``.
ADAPT_MODES = (None, "bias", "output")


def advance_features(temperature, time, state, *, terms, smoothing, seconds_per_unit):
    """ThermalFeatures of consecutive rows of one run, continued from a state.

    The batch numerics of :mod:`sklearn_ifog.features`: ``causal_rate`` on the rows preceded
    by the carried last row, or, for the lag terms and the smoothing,
    :func:`sklearn_ifog._lags.lag_deficit` continued from the carried
    :class:`~sklearn_ifog._lags.LagState`; then ``assemble_terms``. A run given whole gives bit
    for bit the batch features; cut into chunks, the features without lags bit for bit and
    the lags to rounding (1e-12 relative: the batch scan groups the products differently).

    Parameters
    ----------
    temperature : ndarray of shape (n_samples, n_sensors)
        Raw temperatures, deg C, in time order.
    time : ndarray of shape (n_samples,) or None
        Time stamps, s (``None``: per-sample differences).
    state : dict
        ``{"has_history": bool, "temperature": list or None, "last_time": float or None,
        "deficit": list or None}``: the end of the run's previous rows (``has_history=False``
        for a new run): the last raw temperature per sensor, the last time and the deficit
        ``T - lag_tau(T)`` per sensor and per time constant of
        :func:`sklearn_ifog._contract.state_time_constants`. Not modified.
    terms : sequence of str
        Feature terms (see :func:`~sklearn_ifog.features.assemble_terms`).
    smoothing : float
        Smoothing time constant, s (0: none).
    seconds_per_unit : float or None
        Seconds per unit of the rate's time base (used when ``time`` is given).

    Returns
    -------
    features : ndarray of shape (n_samples, n_features_out)
        The features of the rows.
    new_state : dict
        The state after the last row.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.streaming import advance_features
    >>> state = {"has_history": False, "temperature": None, "last_time": None, "deficit": None}
    >>> rows, time = np.array([[20.0], [20.5], [21.5]]), np.array([0.0, 60.0, 120.0])
    >>> params = {"terms": ("T", "dT", "T_lag600s"), "smoothing": 0.0, "seconds_per_unit": 60.0}
    >>> features, state = advance_features(rows[:2], time[:2], state, **params)
    >>> more, state = advance_features(rows[2:], time[2:], state, **params)
    >>> np.vstack([features, more]).round(6)
    array([[20.      ,  0.      ,  0.      ],
           [20.5     ,  0.5     ,  0.475813],
           [21.5     ,  1.      ,  1.382159]])
    >>> state["temperature"], state["last_time"]
    ([21.5], 120.0)
    """
    temperature = np.asarray(temperature, dtype=np.float64)
    n_samples, n_sensors = temperature.shape
    check_needs_time(terms, smoothing, time is not None)
    taus = state_time_constants(terms, smoothing)
    if n_samples == 0:
        deficit = np.zeros((0, n_sensors, len(taus)))
        return assemble_terms(
            temperature, temperature, terms, deficit=deficit, time_constants=taus
        ), dict(state)
    if time is not None:
        time = np.asarray(time, dtype=np.float64)
    deficit = None
    if state["has_history"]:
        previous = np.asarray(state["temperature"], dtype=np.float64)
        if taus:
            initial = LagState(
                time=float(state["last_time"]),
                value=previous,
                deficit=np.asarray(state["deficit"], dtype=np.float64),
            )
            deficit = lag_deficit(temperature, time, None, np.asarray(taus), initial=initial)
        if smoothing <= 0:
            # The carried last row in front: the first difference is exactly the batch one.
            extended = np.concatenate([previous[None, :], temperature])
            extended_time = None if time is None else np.concatenate([[state["last_time"]], time])
            rate = causal_rate(extended, None, extended_time, seconds_per_unit)[1:]
    else:
        if taus:
            deficit = lag_deficit(temperature, time, None, np.asarray(taus))
        if smoothing <= 0:
            rate = causal_rate(temperature, None, time, seconds_per_unit)
    if smoothing > 0:
        rate = deficit[:, :, taus.index(float(smoothing))] / np.float64(smoothing)
        rate = rate * seconds_per_unit
    new_state = {
        "has_history": True,
        "temperature": temperature[-1].tolist(),
        "last_time": None if time is None else float(time[-1]),
        "deficit": None if deficit is None else deficit[-1].tolist(),
    }
    features = assemble_terms(temperature, rate, terms, deficit=deficit, time_constants=taus)
    return features, new_state


class StreamingCompensator:
    """Compensate a gyro's thermal drift online, one sample or one chunk at a time.

    Built from a fitted Pipeline ``ThermalFeatures → ... → regressor`` (e.g. StandardScaler
    and :class:`~sklearn_ifog.RBFNetRegressor`, or a linear baseline). Its outputs equal the
    batch ``pipeline.predict`` on the same run whatever the chunking, and across
    :meth:`get_state` / :meth:`set_state`: the features bit for bit (the lag terms and the
    smoothed rate to rounding, 1e-12 relative), the drift to the last bits (BLAS may sum a
    one-row product in another order than a long one).

    Speed: the Pipeline is checked once, here, and its fitted steps after ThermalFeatures
    are compiled into plain numpy arithmetic (:mod:`sklearn_ifog._compiled`: the scalers,
    PolynomialFeatures, a linear regressor or the RBF network); :meth:`step` computes the
    features of one sample with Python floats and returns Python floats for a single
    output, with no per-call scikit-learn validation. A Pipeline with another step (any
    other regressor or transformer) is evaluated through scikit-learn's ``predict``
    instead: same results, slower, and ``adapt="output"`` is not available for it.

    Online recalibration: with ``adapt``, a sample whose true rate is known (``reference``)
    updates, after it is compensated, a linear output layer by recursive least squares with
    exponential forgetting (:mod:`sklearn_ifog._rls`): ``"bias"`` an offset added to the
    drift; ``"output"`` every linear output weight of the final regressor (the RBF network's
    Gaussian and tail weights and intercept; a linear regressor's coefficients and
    intercept), its nonlinear parts (centres, widths, scalers) fixed. The measured drift of
    such a sample is ``rate - reference``. Samples without a reference are only compensated
    (and forgetting does not act on them). The initial covariance is diffuse along the bias
    and a common relative change of the thermal weights (what ageing changes) and tight
    elsewhere (:func:`sklearn_ifog._rls.initial_covariance`); it is carried as a square-root
    factor (``P = S Sᵀ``, Potter's update: the covariance form loses digits to rounding on
    such a prior, :mod:`sklearn_ifog._rls`). The weights and the factor are part of the state:
    same whatever the chunking (1e-12), saved and restored with it, and kept by
    :meth:`reset` (they belong to the gyro, not to the run).

    Runs: the compensator follows one run at a time. With a ``run`` column in the
    ThermalFeatures, a change of run id — between chunks or inside a chunk — starts a new run
    at that row (as :meth:`reset` would); the rows of a run must be contiguous, so a run id
    that already ended raises a ``ValueError`` (interleaved runs: one compensator per run).
    Without a ``run`` column, call :meth:`reset` at the start of every run. Time must
    increase strictly within a run, across chunks too.

    Calibration domain: built from a
    :class:`~sklearn_ifog.pipeline.CompensationPipeline` (what
    :func:`~sklearn_ifog.make_compensation_pipeline` returns, also as a ConformalRegressor's
    ``estimator_``), the compensator tests every sample against the pipeline's calibration
    domain and applies its ``outside`` policy (``"blend"``, ``"clip"`` or ``"none"``, with
    its ``margin``, both read here, at construction) exactly as the batch ``predict`` does,
    so the output stays the batch one for rows outside too. A row is outside, as in batch,
    when it lies farther than ``margin`` from the domain's decorrelated box or a
    temperature lies beyond its calibrated range; one row's test is one small
    matrix-vector product on the domain's arrays and a comparison per temperature
    (:meth:`sklearn_ifog._compiled.CompiledDomain.row_where`: the distance equal to the
    batch one to 1e-12 relative, the temperature test exact). :attr:`last_outside` and
    :attr:`last_distance` give, for the rows of the last call, whether they were outside
    and how far. No :class:`~sklearn_ifog.domain.OutsideCalibrationWarning` is emitted by
    :meth:`step` or :meth:`update`: a warning per call would flood a firmware-like loop of
    single steps, so the flag is the signal (the batch ``predict`` warns once per call). A
    plain scikit-learn Pipeline has no domain: its predictions are left alone and both
    attributes stay None.

    With ``adapt``, a sample outside the domain is compensated by the policy and does *not*
    update the recalibration even when it has a reference: its features are ones the
    calibration never covered, and an output layer taught there would move the
    compensation inside the domain too (each sample is tested as :meth:`step` tests it, so
    that which references teach is the same whatever the chunking). ``"bias"`` adds its
    offset after the policy (to the blended, clipped or raw drift); ``"output"`` applies
    the policy to the recalibrated network (``"clip"``: the recalibrated network at the
    domain's edge; ``"blend"``: the recalibrated network blended with the fallback line).

    A call that raises (bad input) leaves the state exactly as it was.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline or ConformalRegressor
        Fitted; its first step is a :class:`~sklearn_ifog.ThermalFeatures`, the later steps
        act row by row (scalers, polynomial features, regressors). A
        :class:`~sklearn_ifog.pipeline.CompensationPipeline` brings its calibration domain
        (see above). A fitted :class:`~sklearn_ifog.ConformalRegressor` around such a
        pipeline also carries the band: after every :meth:`step` or :meth:`update`,
        :attr:`last_interval` holds the drift bounds of its rows, equal to the batch
        ``predict_interval`` (each fold model with its own domain and policy, as there).
    adapt : {None, "bias", "output"}, default=None
        Online recalibration from the samples given a ``reference`` (None: none). Not with
        a :class:`~sklearn_ifog.ConformalRegressor` (a ``ValueError``): its band is
        calibrated on the out-of-fold residuals of the fitted model, and says nothing of a
        recalibrated one; recalibrate its ``estimator_`` (a plain Pipeline) instead.
    forgetting : float, default=0.999
        Forgetting factor of the recalibration, in (0, 1]: each sample with a reference
        weighs the earlier ones by this factor (memory of about ``1 / (1 - forgetting)``
        references; 1: no forgetting). Ignored without ``adapt``.

    Attributes
    ----------
    last_interval : ndarray of shape (n_samples, 2) or None
        Lower and upper drift bound (deg/h) of the rows of the last :meth:`step` (one row)
        or :meth:`update`; None when built from a plain Pipeline.
    last_outside : ndarray of shape (n_samples,), dtype=bool, or None
        Whether each row of the last :meth:`step` (one row) or :meth:`update` lay outside
        the calibration domain (farther than ``margin`` from its box, or a temperature
        beyond its calibrated range): what ``pipeline.outside_calibration`` gives for those
        rows. None before the first call, and always for a Pipeline without a domain (not a
        CompensationPipeline).
    last_distance : ndarray of shape (n_samples,) or None
        The distance of those rows outside the domain, in decorrelated standard deviations
        (0 inside the box): ``pipeline.calibration_distance``. None as ``last_outside``.
    n_sensors : int
        Temperature sensors per sample.
    n_outputs : int
        Outputs (gyro axes) the Pipeline predicts.
    compiled : bool
        Whether the steps after ThermalFeatures were compiled (else scikit-learn evaluates
        them).
    state : dict
        The current state (a copy, JSON-able, is returned by :meth:`get_state`).

    See Also
    --------
    sklearn_ifog.export.to_c : The same compensator, and the same recalibration, as C.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn_ifog import ThermalFeatures
    >>> from sklearn_ifog.streaming import StreamingCompensator
    >>> X = np.column_stack([np.arange(6.0), 20 + np.arange(6.0) ** 2 / 10])
    >>> model = make_pipeline(
    ...     ThermalFeatures(temperature=1, time=0, rate_unit="s"), LinearRegression()
    ... )
    >>> model = model.fit(X, 0.5 * X[:, 1] + 2.0)
    >>> compensator = StreamingCompensator(model)
    >>> first = compensator.update(X[:4], rate=np.full(4, 10.0))
    >>> compensated, drift = compensator.step(5.0, 22.5, rate=10.0)
    >>> bool(np.isclose(drift, model.predict(X)[5]))
    True

    Recalibration: this gyro's bias moved by +0.3 deg/h since calibration; at rest, the true
    rate (here 0) is known, and the bias is learnt from it.

    >>> adaptive = StreamingCompensator(model, adapt="bias", forgetting=1.0)
    >>> fixed = StreamingCompensator(model)
    >>> for t, temperature in X:
    ...     _ = adaptive.step(t, temperature, rate=0.5 * temperature + 2.3, reference=0.0)
    ...     _ = fixed.step(t, temperature, rate=0.5 * temperature + 2.3)
    >>> rate = 0.5 * 23.6 + 2.3  # a later sample, true rate 0, not known to the gyro
    >>> round(fixed.step(6.0, 23.6, rate)[0], 3), round(adaptive.step(6.0, 23.6, rate)[0], 3)
    (0.3, 0.0)

    Calibration domain: a model calibrated from 10 to 40 deg C, streamed on the same run
    30 deg C colder. Every row is outside; the drift is the batch ``predict``'s (its
    ``"blend"`` policy), and a flag per row replaces the batch warning.

    >>> import warnings
    >>> from sklearn_ifog import make_compensation_pipeline
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> X, y = make_thermal_campaign(
    ...     n_units=1,
    ...     n_runs=1,
    ...     sampling_period=300.0,
    ...     temperature_range=(10.0, 40.0),
    ...     random_state=0,
    ...     return_X_y=True,
    ... )
    >>> model = make_compensation_pipeline(LinearRegression()).fit(X, y)
    >>> cold = X.assign(temperature=X["temperature"] - 30.0)
    >>> compensator = StreamingCompensator(model)
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("error")  # streaming never warns
    ...     _, drift = compensator.update(cold)
    >>> bool(compensator.last_outside.all())
    True
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")  # the batch predict warns once
    ...     batch = model.predict(cold)
    >>> bool(np.allclose(drift, batch, rtol=1e-12, atol=1e-12))
    True
    """

    def __init__(self, pipeline, *, adapt=None, forgetting=0.999):
        from sklearn_ifog.conformal import ConformalRegressor

        if adapt not in ADAPT_MODES:
            raise ValueError(f"adapt must be None, 'bias' or 'output', got {adapt!r}.")
        if (
            isinstance(forgetting, bool)
            or not isinstance(forgetting, numbers.Real)
            or not (0.0 < float(forgetting) <= 1.0)
        ):
            raise ValueError(f"forgetting must be a number in (0, 1], got {forgetting!r}.")
        self.conformal = None
        self.last_interval = None
        # The last call's domain test: arrays from update, Python scalars from step (made
        # arrays when read, so that a step does not pay for them).
        self._last_where = (None, None)
        if isinstance(pipeline, ConformalRegressor):
            if adapt is not None:
                raise ValueError(
                    f"adapt={adapt!r} is not available with a ConformalRegressor: its band is "
                    "calibrated for the fitted model, not a recalibrated one. Use adapt=None, "
                    "or recalibrate its estimator_ (a plain Pipeline) without a band."
                )
            check_is_fitted(pipeline)
            self.conformal = pipeline
            for model in [pipeline.estimator_, *pipeline.estimators_]:
                if not (
                    isinstance(model, Pipeline) and type(model.steps[0][1]) is ThermalFeatures
                ):
                    raise TypeError(
                        "StreamingCompensator needs a ConformalRegressor around a Pipeline "
                        f"whose first step is ThermalFeatures, got {type(model).__name__}."
                    )
            pipeline = pipeline.estimator_
        if not isinstance(pipeline, Pipeline):
            raise TypeError(
                "StreamingCompensator needs a fitted sklearn.pipeline.Pipeline whose first "
                f"step is ThermalFeatures, got {type(pipeline).__name__}."
            )
        check_is_fitted(pipeline)
        name, features = pipeline.steps[0]
        if type(features) is not ThermalFeatures:
            raise ValueError(
                "StreamingCompensator needs ThermalFeatures as the Pipeline's first step, got "
                f"step {name!r} ({type(features).__module__}.{type(features).__qualname__})."
            )
        if len(pipeline.steps) < 2:
            raise ValueError("StreamingCompensator needs a regressor after ThermalFeatures.")
        sensors = sensor_keys(features.temperature)
        self.pipeline = pipeline
        self.adapt = adapt
        self.forgetting = float(forgetting)
        self.n_sensors = len(sensors)
        self._thermal = features
        terms, smoothing = features._resolved()
        terms = validate_terms(terms, self.n_sensors)
        check_needs_time(terms, smoothing, features.time is not None)
        self._features = {
            "temperature": sensors,
            "time": features.time,
            "terms": terms,
            "smoothing": smoothing,
            "seconds_per_unit": (
                None if features.time is None else seconds_per_unit(features.rate_unit)
            ),
        }
        self._time_constants = list(state_time_constants(terms, smoothing))
        self._uses_time = features.time is not None
        self._smoothing_index = (
            self._time_constants.index(float(smoothing)) if smoothing > 0 else None
        )
        self._row_function = _row_function(
            self.n_sensors,
            terms,
            self._time_constants,
            smoothing,
            self._features["seconds_per_unit"],
            self._uses_time,
        )
        self._rest = pipeline[1:]
        self._names_in = getattr(self._first_later_step(), "feature_names_in_", None)
        self._compiled = compile_steps(pipeline)
        self.compiled = self._compiled is not None
        # The calibration domain and outside policy (None for a plain Pipeline); each fold
        # model of a ConformalRegressor has its own, as its predict applies it.
        self._domain = compile_domain(pipeline)
        self._fold_compiled = None
        self._fold_domains = None
        if self.conformal is not None:
            self._fold_domains = [compile_domain(m) for m in self.conformal.estimators_]
        if self.conformal is not None and self.compiled:
            folds = [compile_steps(model) for model in self.conformal.estimators_]
            if all(fold is not None for fold in folds):
                self._fold_compiled = folds
        if self.compiled:
            self.n_outputs = self._compiled.final.n_outputs
            self._single_output = self._compiled.single_output
        else:
            n_features = len(features.get_feature_names_out())
            probe = np.asarray(self._rest.predict(self._frame(np.zeros((1, n_features)))))
            self._single_output = probe.ndim == 1
            self.n_outputs = 1 if probe.ndim == 1 else probe.shape[1]

        self._prior = self._initial_rls()
        self.reset(adaptation=True)

    def _initial_rls(self):
        """Initial weights, covariance and the design's kind of the recalibration."""
        if self.adapt is None:
            return None
        if self.adapt == "bias":
            weights = np.zeros((1, self.n_outputs))
            bias_index = 0
        else:
            if not self.compiled:
                regressor = self._rest.steps[-1][1]
                raise ValueError(
                    "adapt='output' needs a final regressor with a linear output layer "
                    "(RBFNetRegressor or a linear model) after known scalers; got "
                    f"{type(regressor).__module__}.{type(regressor).__qualname__} (use "
                    "adapt='bias')."
                )
            weights = self._compiled.final.weights.copy()
            bias_index = self._compiled.final.bias_index
        factor = initial_factor(weights, bias_index=bias_index)
        return {"weights": weights, "factor": factor, "trace": covariance_trace(factor)}

    @property
    def last_outside(self):
        """Whether the rows of the last call lay outside the domain (see the class)."""
        outside = self._last_where[0]
        return np.array([outside]) if isinstance(outside, bool) else outside

    @property
    def last_distance(self):
        """Distance of the rows of the last call outside the domain (see the class)."""
        distance = self._last_where[1]
        return np.array([distance]) if isinstance(distance, float) else distance

    def _first_later_step(self):
        for _, step in self._rest.steps:
            if step not in (None, "passthrough"):
                return step
        return None

    def reset(self, *, adaptation=False):
        """Start a new run: the next sample is a run's first row.

        Parameters
        ----------
        adaptation : bool, default=False
            Also return the recalibration (weights and covariance) to its start, the fitted
            model. By default it is kept: it belongs to the gyro, not to the run.

        Returns
        -------
        self : StreamingCompensator
            The compensator.
        """
        previous = getattr(self, "state", None)
        if adaptation or previous is None:
            rls = None
            if self._prior is not None:
                rls = {
                    "weights": self._prior["weights"].copy(),
                    "covariance_factor": self._prior["factor"].copy(),
                    "n_updates": 0,
                    "n_resets": 0,
                }
        else:
            rls = previous["rls"]
        self.state = {
            "schema": STATE_SCHEMA,
            "version": STATE_VERSION,
            "n_sensors": self.n_sensors,
            "time_constants": list(self._time_constants),
            "run": None,
            "has_history": False,
            "temperature": None,
            "last_time": None,
            "deficit": None,
            "finished_runs": [],
            "adapt": self.adapt,
            "rls": rls,
        }
        self._refresh_fast()
        return self

    def _refresh_fast(self):
        """The one-row evaluator, with the current output-layer weights."""
        self._fast = None
        if FastRow.supports(self._compiled):
            rls = self.state["rls"]
            weights = rls["weights"] if self.adapt == "output" else None
            self._fast = FastRow(self._compiled, weights)

    def get_state(self):
        """The state as a plain, JSON-able dict (a copy), to save mid-run.

        Returns
        -------
        state : dict
            Keys: ``schema``, ``version``, ``n_sensors``, ``time_constants`` (s, of the
            lags carried per sensor: the lag terms' and the smoothing's), ``run`` (current run
            id), ``has_history`` (False before a run's first row), ``temperature`` (last raw
            temperature per sensor), ``last_time``, ``deficit`` (per sensor, per time
            constant: ``T - lag_tau(T)`` after the last sample; None without lags),
            ``finished_runs``, ``adapt`` and ``rls`` (None without ``adapt``; else
            ``weights``, ``(n_weights, n_outputs)`` nested lists, ``covariance_factor``,
            ``(n_weights, n_weights)``, the factor ``S`` of the covariance ``P = S Sᵀ``,
            ``n_updates`` the references used (those of samples inside the calibration
            domain) and ``n_resets`` the factor's resets).
        """
        state = {key: value for key, value in self.state.items() if key != "rls"}
        state = copy.deepcopy(state)
        rls = self.state["rls"]
        state["rls"] = None
        if rls is not None:
            state["rls"] = {
                "weights": rls["weights"].tolist(),
                "covariance_factor": rls["covariance_factor"].tolist(),
                "n_updates": int(rls["n_updates"]),
                "n_resets": int(rls["n_resets"]),
            }
        return state

    def set_state(self, state):
        """Restore a state saved by :meth:`get_state` (from this model or an identical one).

        Parameters
        ----------
        state : dict
            A state from :meth:`get_state` (possibly through JSON).

        Returns
        -------
        self : StreamingCompensator
            The compensator.
        """
        expected = set(self.state)
        if isinstance(state, dict) and (
            state.get("schema", STATE_SCHEMA) != STATE_SCHEMA
            or state.get("version", STATE_VERSION) != STATE_VERSION
        ):
            # First, so that a state of an older version is named as such.
            raise ValueError(
                f"state is of schema {state.get('schema')!r} version {state.get('version')!r}; "
                f"expected {STATE_SCHEMA!r} version {STATE_VERSION}."
            )
        if not isinstance(state, dict) or set(state) != expected:
            got = sorted(state) if isinstance(state, dict) else type(state).__name__
            raise ValueError(f"state must be a dict with keys {sorted(expected)}, got {got}.")
        if state["n_sensors"] != self.n_sensors:
            raise ValueError(
                f"state is for {state['n_sensors']} sensor(s); this model has {self.n_sensors}."
            )
        time_constants = state["time_constants"]
        if not isinstance(time_constants, (list, tuple)) or list(time_constants) != (
            self._time_constants
        ):
            raise ValueError(
                f"state carries lags at time constants {time_constants} s; this "
                f"model's are {self._time_constants} s (lag terms and smoothing)."
            )
        if not isinstance(state["finished_runs"], (list, tuple)):
            raise ValueError(
                "state['finished_runs'] must be a list of run ids, got "
                f"{type(state['finished_runs']).__name__}."
            )
        history = state["has_history"]
        if not isinstance(history, (bool, np.bool_)):
            raise ValueError(f"state['has_history'] must be True or False, got {history!r}.")
        uses_lags = bool(self._time_constants)
        if history:
            _state_numbers(state["temperature"], "state['temperature']", (self.n_sensors,))
            if self._features["time"] is not None:
                if state["last_time"] is None:
                    raise ValueError("state['last_time'] is missing: the model uses time.")
                _state_numbers(state["last_time"], "state['last_time']", ())
            elif state["last_time"] is not None:
                raise ValueError(
                    "state['last_time'] must be None: the model has no time column, got "
                    f"{state['last_time']!r}."
                )
            if uses_lags:
                shape = (self.n_sensors, len(self._time_constants))
                _state_numbers(
                    state["deficit"], "state['deficit']", shape, "(sensors, time constants)"
                )
            elif state["deficit"] is not None:
                raise ValueError(
                    "state['deficit'] must be None: the model carries no lags, got "
                    f"{state['deficit']!r}."
                )
        else:
            for key in ("temperature", "last_time", "deficit"):
                if state[key] is not None:
                    raise ValueError(
                        f"state[{key!r}] must be None before a run's first row "
                        f"(has_history=False), got {state[key]!r}."
                    )
        rls = self._check_rls_state(state)
        restored = copy.deepcopy({key: value for key, value in state.items() if key != "rls"})
        restored["has_history"] = bool(history)
        restored["rls"] = rls
        self.state = restored
        self._refresh_fast()
        return self

    def _check_rls_state(self, state):
        if state["adapt"] != self.adapt:
            raise ValueError(
                f"state is of a compensator with adapt={state['adapt']!r}; this one has "
                f"adapt={self.adapt!r}."
            )
        rls = state["rls"]
        if self.adapt is None:
            if rls is not None:
                raise ValueError("state['rls'] must be None: this compensator does not adapt.")
            return None
        keys = {"weights", "covariance_factor", "n_updates", "n_resets"}
        if not isinstance(rls, dict) or set(rls) != keys:
            got = sorted(rls) if isinstance(rls, dict) else type(rls).__name__
            raise ValueError(f"state['rls'] must be a dict with keys {sorted(keys)}, got {got}.")
        shape = self._prior["weights"].shape
        weights = _state_numbers(rls["weights"], "state['rls']['weights']", shape)
        factor = _state_numbers(
            rls["covariance_factor"],
            "state['rls']['covariance_factor']",
            (shape[0], shape[0]),
            "(weights, weights)",
        )
        counts = {}
        for key in ("n_updates", "n_resets"):
            value = rls[key]
            if (
                isinstance(value, (bool, np.bool_))
                or not isinstance(value, numbers.Integral)
                or value < 0
            ):
                raise ValueError(
                    f"state['rls'][{key!r}] must be a count (an integer >= 0), got {value!r}."
                )
            counts[key] = int(value)
        return {"weights": weights, "covariance_factor": factor, **counts}

    # -- one sample ------------------------------------------------------------------------

    def step(self, time, temperature, rate=None, *, run=None, reference=None):
        """Compensate one sample (and, with ``adapt`` and a ``reference``, learn from it).

        Parameters
        ----------
        time : float or None
            Time stamp, s (ignored, and may be None, when the model has no time column).
        temperature : float or sequence of float
            The temperature (deg C) of each sensor, in the model's sensor order.
        rate : float or sequence of float, default=None
            Gyro output, deg/h (one per model output).
        run : scalar, default=None
            Run id; a change of id starts a new run. ``None``: the current run.
        reference : float or sequence of float, default=None
            The true rate of the sample, deg/h (one per output), when it is known (at rest,
            on a turntable): with ``adapt``, the recalibration learns from
            ``rate - reference`` after compensating the sample, unless the sample lies
            outside the calibration domain. Needs ``rate``.

        Returns
        -------
        compensated : float or ndarray of shape (n_outputs,) or None
            ``rate - drift`` (None when ``rate`` is None); a Python float for a single
            output.
        drift : float or ndarray of shape (n_outputs,)
            Predicted drift, deg/h (before this sample's own update; outside the
            calibration domain, under the pipeline's ``outside`` policy). Sets
            :attr:`last_outside` and :attr:`last_distance` (one row) for a pipeline with a
            domain; never warns.
        """
        if not self.compiled:
            return self._step_slow(time, temperature, rate, run, reference)
        if self.n_sensors == 1 and isinstance(temperature, float):
            temperatures = [float(temperature)]
        else:
            temperatures = _floats(temperature)
            if len(temperatures) != self.n_sensors:
                raise ValueError(
                    f"Expected {self.n_sensors} temperature value(s) per sample (sensors "
                    f"{self._features['temperature']}), got {len(temperatures)}."
                )
        for value in temperatures:
            if not math.isfinite(value):
                _table.check_finite(np.array([temperatures]), "temperature")
        single = self._single_output
        rates = None if rate is None else self._row_values(rate, "rate")
        references = None if reference is None else self._row_values(reference, "reference")
        if references is not None and rates is None:
            raise ValueError("reference needs the rate of the same sample (rate=None).")
        if self._uses_time:
            if time is None:
                raise ValueError(f"The model needs the time column {self._features['time']!r}.")
            # The float check first: the abstract-class test costs about a microsecond.
            if type(time) is not float and not _is_number(time):
                raise ValueError(f"time must be a number (s), got {_describe(time)}.")
            time = float(time)
            if not math.isfinite(time):
                _table.check_finite(np.array([time]), "time")
        else:
            time = None
        state = self.state
        if run is not None and run != state["run"]:
            state = self._start_run(state, run)
        if time is not None and state["has_history"] and not time > state["last_time"]:
            _check_increasing(np.array([time]), state, 0)
        row, feature_state = self._row_features(state, time, temperatures)
        rls = state["rls"]
        adapt = self.adapt
        fast = self._fast
        drift = self._row_drift(row, rls, fast)
        domain = self._domain
        outside = False
        if domain is not None:
            distance, outside = domain.row_where(row)
            if outside and domain.policy != "none":
                drift = self._row_policy(row, drift, distance, rls, fast)
        if adapt == "bias":
            base = drift
            bias = rls["weights"][0]
            drift = base + (float(bias[0]) if single else bias)
        if references is not None and adapt is not None and not outside:
            if adapt == "bias":
                phi = _ONE
                target = rates - references - base
            else:
                phi = self._compiled.design(np.array([row]))[0]
                target = rates - references
            weights, factor, resets = rls_step(
                rls["weights"],
                rls["covariance_factor"],
                phi,
                np.atleast_1d(np.asarray(target, dtype=np.float64)),
                self.forgetting,
                self._prior["factor"],
                self._prior["trace"],
            )
            rls = {
                "weights": weights,
                "covariance_factor": factor,
                "n_updates": rls["n_updates"] + 1,
                "n_resets": rls["n_resets"] + resets,
            }
            if adapt == "output" and fast is not None:
                fast = FastRow(self._compiled, weights)
        compensated = None if rates is None else rates - drift
        if self.conformal is not None:
            self.last_interval = self._interval(
                np.array([row], dtype=np.float64),
                drift,
                None if domain is None else np.array([distance]),
            )
        if domain is not None:
            self._last_where = (outside, distance)
        self.state = {**state, **feature_state, "rls": rls}
        self._fast = fast
        if single:
            if not isinstance(drift, float):
                drift = float(np.asarray(drift).reshape(-1)[0])
                compensated = None if rates is None else rates - drift
            return compensated, drift
        return compensated, np.asarray(drift, dtype=np.float64).reshape(self.n_outputs)

    def _row_drift(self, row, rls, fast):
        """The model's drift of one feature row (recalibrated with ``adapt="output"``).

        A float from the one-row evaluator ``fast`` when there is one, else an array of
        shape ``(n_outputs,)``; without the domain's policy and the ``"bias"`` offset.
        """
        if fast is not None:
            return fast(row)
        if self.adapt == "output":
            return self._compiled.design(np.array([row]))[0] @ rls["weights"]
        return self._compiled.predict_row(np.array(row))

    def _row_policy(self, row, drift, distance, rls, fast):
        """The drift of one row outside the domain under its policy (as ``_row_drift``)."""

        def evaluate(rows):
            return np.array([np.atleast_1d(self._row_drift(r, rls, fast)) for r in rows.tolist()])

        prediction = np.reshape(np.asarray(drift, dtype=np.float64), (1, -1))
        features = np.array([row], dtype=np.float64)
        result = self._domain.apply(
            features, prediction, np.array([distance]), np.array([True]), evaluate
        )[0]
        return float(result[0]) if isinstance(drift, float) else result

    def _row_values(self, values, label):
        """The sample's values, finite: a float for one output, else shape (n_outputs,)."""
        if self._single_output and (type(values) is float or _is_number(values)):
            values = float(values)
            if not math.isfinite(values):
                _table.check_finite(np.array([values]), label)
            return values
        values = _number_array(values, label, "deg/h").reshape(-1)
        if values.shape[0] != self.n_outputs:
            raise ValueError(
                f"{label} has {values.shape[0]} value(s) per sample; the model predicts "
                f"{self.n_outputs} (one {label} per output)."
            )
        if not np.all(np.isfinite(values)):
            _table.check_finite(values[None], label)
        return float(values[0]) if self._single_output else values

    def _row_features(self, state, time, temperatures):
        """Features of one sample (a list of floats) and the feature part of the new state.

        The arithmetic of :func:`advance_features` on Python floats, in a function written
        for this model at construction (:func:`_row_function`): one exact step of every lag
        (:func:`sklearn_ifog._lags.lag_step`), the rate, then the terms (their expressions of
        :data:`sklearn_ifog._contract.TERMS`, as the C export writes them).
        """
        row, deficit = self._row_function(
            temperatures,
            time,
            state["has_history"],
            state["temperature"],
            state["last_time"],
            state["deficit"],
        )
        feature_state = {
            "has_history": True,
            "temperature": temperatures,
            "last_time": time,
            "deficit": deficit,
        }
        return row, feature_state

    def _step_slow(self, time, temperature, rate, run, reference):
        temperature = _number_array(temperature, "temperature", "deg C").reshape(1, -1)
        times = None
        if self._uses_time and time is not None:
            if not _is_number(time):
                raise ValueError(f"time must be a number (s), got {_describe(time)}.")
            times = np.array([time], dtype=np.float64)
        runs = None if run is None else [run]
        rates = None if rate is None else _number_array(rate, "rate", "deg/h")[None]
        references = None
        if reference is not None:
            references = _reference_values(_number_array(reference, "reference", "deg/h")[None])
        compensated, drift = self._advance(temperature, times, runs, rates, references)
        if self._single_output:
            return (None if compensated is None else float(compensated[0])), float(drift[0])
        return (None if compensated is None else compensated[0]), drift[0]

    # -- chunks ----------------------------------------------------------------------------

    def update(self, X, rate=None, reference=None):
        """Compensate a chunk of consecutive samples (learning from those with a reference).

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_columns)
            Rows in time order, as ``pipeline.predict`` takes them (the columns the Pipeline
            was fitted on).
        rate : array-like of shape (n_samples,) or (n_samples, n_outputs), default=None
            Gyro output, deg/h.
        reference : array-like of shape (n_samples,) or (n_samples, n_outputs), default=None
            True rate of the samples, deg/h, where known: ``None`` entries (an object
            sequence) or masked entries (a ``numpy.ma`` array) mark the samples without one.
            With ``adapt``, every sample with a reference updates the recalibration after it
            is compensated, in order, except the samples outside the calibration domain.
            Needs ``rate``.

        Returns
        -------
        compensated : ndarray or None
            ``rate - drift`` (None when ``rate`` is None).
        drift : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Predicted drift, deg/h, as ``pipeline.predict`` gives it, its ``outside``
            policy included (each sample's before its own update). Sets
            :attr:`last_outside` and :attr:`last_distance` for a pipeline with a domain;
            never warns.
        """
        n_rows = np.shape(X)[0] if hasattr(X, "shape") else len(X)
        if n_rows == 0:
            raise ValueError(
                "X has 0 rows: update needs at least one row (one sample) per call; "
                "skip the call when a chunk is empty."
            )
        # The batch transformer's own validation and column reading: same columns, same
        # errors as ``pipeline.predict``.
        thermal = self._thermal
        X = _table.as_table(X)
        if hasattr(thermal, "n_features_in_"):
            validate_data(thermal, X, reset=False, skip_check_array=True)
        spec = self._features
        temperature, time, run, _ = _table.read_thermal_columns(
            X, temperature=spec["temperature"], time=spec["time"], run=thermal.run
        )
        rates = None if rate is None else _number_array(rate, "rate", "deg/h")
        references = None if reference is None else _reference_values(reference)
        return self._advance(temperature, time, run, rates, references)

    def _advance(self, temperature, time, run, rate, reference):
        spec = self._features
        n_samples = temperature.shape[0]
        if temperature.shape[1] != self.n_sensors:
            raise ValueError(
                f"Expected {self.n_sensors} temperature value(s) per sample (sensors "
                f"{spec['temperature']}), got {temperature.shape[1]}."
            )
        _table.check_finite(temperature, "temperature")
        if spec["time"] is not None:
            if time is None:
                raise ValueError(f"The model needs the time column {spec['time']!r}.")
            _table.check_finite(time, "time")
        else:
            time = None
        if rate is not None:
            if rate.shape[0] != n_samples:
                raise ValueError(f"rate has {rate.shape[0]} rows, the samples {n_samples}.")
            _table.check_finite(rate, "rate")
        has_reference = None
        if reference is not None:
            if rate is None:
                raise ValueError("reference needs the rate of the same samples (rate=None).")
            reference, has_reference = reference
            if reference.shape != rate.shape:
                raise ValueError(
                    f"reference has shape {reference.shape}; rate has {rate.shape} (one "
                    "reference per rate)."
                )
            has_reference = has_reference.reshape(n_samples, -1)
            if not np.all(has_reference == has_reference[:, :1]):
                raise ValueError(
                    "reference must be given for every output of a sample, or for none."
                )
            has_reference = has_reference[:, 0]
        # Work on a copy (its lists are replaced, never mutated): a chunk that fails half-way
        # leaves the state as it was.
        state = dict(self.state)
        blocks = []
        for start, stop, run_id in _table.contiguous_runs(run, n_samples):
            if run_id is not None and run_id != state["run"]:
                state = self._start_run(state, run_id)
            segment_time = None if time is None else time[start:stop]
            if segment_time is not None:
                _check_increasing(segment_time, state, start)
            if self.adapt is None:
                block, feature_state = advance_features(
                    temperature[start:stop],
                    segment_time,
                    state,
                    terms=spec["terms"],
                    smoothing=spec["smoothing"],
                    seconds_per_unit=spec["seconds_per_unit"],
                )
            else:
                # The recalibration is a sequential recursion that amplifies rounding where
                # the references barely tell its directions apart: its inputs are computed
                # sample by sample, as step computes them, so that it is the same, bit for
                # bit, whatever the chunking.
                block, feature_state = self._sequential_features(
                    temperature[start:stop], segment_time, state
                )
            state.update(feature_state)
            blocks.append(block)
        features = np.concatenate(blocks)
        domain = self._domain
        distance = outside = None
        if domain is not None and self.adapt is None:
            distance, outside = domain.where(features)
        elif domain is not None:
            # Only the rows inside teach the recalibration: each row is tested as step tests
            # it (the features are already made sample by sample here), so that which
            # references teach, and so the recursion, is the same whatever the chunking.
            tested = [domain.row_where(row) for row in features.tolist()]
            distance = np.array([row_distance for row_distance, _ in tested], dtype=np.float64)
            outside = np.array([row_outside for _, row_outside in tested], dtype=bool)
        if self.adapt == "output":
            design = self._compiled.design(features)
            if domain is not None and domain.policy == "clip" and outside.any():
                # Outside rows never update, so their design row only predicts: the
                # recalibrated network at the domain's edge, with the weights of its time.
                design[outside] = self._compiled.design(domain.project(features[outside]))
        else:
            design = np.ones((n_samples, 1)) if self.adapt == "bias" else None
            evaluate = (
                self._compiled.predict if self.compiled else self._sklearn_evaluator(self._rest)
            )
            base = evaluate(features).reshape(n_samples, -1)
            if domain is not None:
                base = domain.apply(features, base, distance, outside, evaluate)
        rls = state["rls"]
        if self.adapt is None:
            drift = base
        else:
            if has_reference is None:
                has_reference = np.zeros(n_samples, dtype=bool)
                target = np.zeros((n_samples, self.n_outputs))
            else:
                target = (rate - reference).reshape(n_samples, -1)
                if self.adapt == "bias":
                    target = target - base
            # A reference outside the domain teaches nothing: the features there were never
            # calibrated, and the policy, not the output layer, answers for them.
            learns = has_reference if outside is None else has_reference & ~outside
            prediction, weights, factor, resets = rls_sequence(
                rls["weights"],
                rls["covariance_factor"],
                design,
                target,
                learns,
                self.forgetting,
                self._prior["factor"],
            )
            if self.adapt == "output":
                drift = prediction
                if domain is not None and domain.policy == "blend":
                    drift = domain.apply(features, prediction, distance, outside)
            else:
                drift = base + prediction
            rls = {
                "weights": weights,
                "covariance_factor": factor,
                "n_updates": rls["n_updates"] + int(learns.sum()),
                "n_resets": rls["n_resets"] + resets,
            }
        if self._single_output:
            drift = drift[:, 0]
        if rate is not None and rate.shape != drift.shape:
            raise ValueError(
                f"rate has shape {rate.shape[1:]} per sample; the model predicts "
                f"{drift.shape[1:]} (one rate per output)."
            )
        compensated = None if rate is None else rate - drift
        interval = None
        if self.conformal is not None:
            interval = self._interval(features, drift, distance)
        state["rls"] = rls
        self.state = state
        self.last_interval = interval
        self._last_where = (outside, distance)
        if self.adapt == "output" and has_reference is not None and has_reference.any():
            self._refresh_fast()
        return compensated, drift

    def _interval(self, features, drift, distance=None):
        """The band of the rows with thermal ``features``, as predict_interval gives it.

        The fold models and the difficulty model's inputs (the features through the steps
        before the regressor) are evaluated compiled when every fold model compiles, else by
        scikit-learn. ``distance``: the rows' distance outside the full model's domain (None
        without one), for the band's share of the fallback where the model blends to it.
        """
        conformal = self.conformal
        n_samples = features.shape[0]
        if self._fold_compiled is not None:
            evaluators = [compiled.predict for compiled in self._fold_compiled]
        else:
            evaluators = [self._sklearn_evaluator(model[1:]) for model in conformal.estimators_]
        predictions = []
        for evaluate, fold_domain in zip(evaluators, self._fold_domains, strict=True):
            prediction = evaluate(features).reshape(n_samples, -1)
            if fold_domain is not None:
                fold_where = fold_domain.where(features)
                prediction = fold_domain.apply(features, prediction, *fold_where, evaluate)
            predictions.append(prediction[:, 0])
        predictions = np.stack(predictions)
        raw = None
        if conformal.adaptive:
            if len(self._rest.steps) == 1:
                raw = features
            elif self._fold_compiled is not None:
                raw = self._compiled.transform(features)
            else:
                raw = self._rest[:-1].transform(self._frame(features))
            raw = np.asarray(raw, dtype=float)
        centre = np.asarray(drift, dtype=float).reshape(n_samples)
        if distance is not None and getattr(conformal, "fallback_scores_", None) is not None:
            # As ConformalRegressor._fallback_share: the full model's fallback weight.
            share = fallback_weight(distance, self._domain.margin)
            return conformal._bounds(centre, predictions, raw, fallback_share=share)
        return conformal._bounds(centre, predictions, raw)

    def _sequential_features(self, temperature, time, state):
        """Features of consecutive rows of one run by the per-sample step (see _advance)."""
        has_history = state["has_history"]
        previous, last_time, deficit = state["temperature"], state["last_time"], state["deficit"]
        times = [None] * temperature.shape[0] if time is None else time.tolist()
        rows = []
        row_function = self._row_function
        for temperatures, now in zip(temperature.tolist(), times, strict=True):
            row, deficit = row_function(
                temperatures, now, has_history, previous, last_time, deficit
            )
            rows.append(row)
            has_history, previous, last_time = True, temperatures, now
        feature_state = {
            "has_history": True,
            "temperature": previous,
            "last_time": last_time,
            "deficit": deficit,
        }
        return np.array(rows, dtype=np.float64).reshape(len(rows), -1), feature_state

    def _start_run(self, state, run_id):
        if run_id in state["finished_runs"]:
            raise ValueError(
                f"Run {run_id!r} already ended earlier in the stream: the rows of one run must "
                "be contiguous (use one StreamingCompensator per run for interleaved runs)."
            )
        finished = state["finished_runs"]
        if state["run"] is not None:
            finished = [*finished, state["run"]]
        return {
            **state,
            "run": run_id,
            "has_history": False,
            "temperature": None,
            "last_time": None,
            "deficit": None,
            "finished_runs": finished,
        }

    def _sklearn_evaluator(self, rest):
        """``evaluate(features) -> (n, n_outputs)`` of the steps ``rest`` by scikit-learn."""

        def evaluate(features):
            prediction = np.asarray(rest.predict(self._frame(features)), dtype=np.float64)
            return prediction.reshape(features.shape[0], -1)

        return evaluate

    def _frame(self, features):
        if self._names_in is None:
            return features
        import pandas as pd

        return pd.DataFrame(features, columns=self._names_in)


_ONE = np.ones(1)


def _row_function(n_sensors, terms, time_constants, smoothing, seconds_per_unit, uses_time):
    """A Python function computing one sample's features from the carried state.

    ``f(temperature, time, has_history, previous, last_time, deficit) -> (row, deficit)``,
    unrolled for the model's sensors, lags and terms (what :func:`advance_features` computes
    for one row, on floats). The term expressions are those of the feature contract
    (``Term.c_expression``, valid Python too), the lag step that of
    :func:`sklearn_ifog._lags.lag_step`; compiled once per compensator.
    """
    taus = [float(tau) for tau in time_constants]
    n_lags = len(taus)
    lines = ["def row(temperature, time, has_history, previous, last_time, deficit):"]
    lines += [f"    u{s} = temperature[{s}]" for s in range(n_sensors)]
    lines.append("    if has_history:")
    if uses_time:
        lines.append("        elapsed = time - last_time")
    for k, tau in enumerate(taus):
        lines += [
            f"        x = elapsed / {tau!r}",
            f"        a{k} = exp(-x)",
            f"        g{k} = -expm1(-x) / x if x > 0 else 1.0",
        ]
    for s in range(n_sensors):
        lines.append(f"        change{s} = u{s} - previous[{s}]")
        if n_lags:
            lines.append(f"        old = deficit[{s}]")
        for k in range(n_lags):
            lines.append(f"        e{s}_{k} = a{k} * old[{k}] + g{k} * change{s}")
        if smoothing > 0:
            index = taus.index(float(smoothing))
            lines.append(
                f"        delta{s} = e{s}_{index} / {float(smoothing)!r} * {seconds_per_unit!r}"
            )
        elif uses_time:
            lines.append(f"        delta{s} = change{s} / elapsed * {seconds_per_unit!r}")
        else:
            lines.append(f"        delta{s} = change{s}")
    lines.append("    else:")
    for s in range(n_sensors):
        lines.append(f"        delta{s} = 0.0")
        lines += [f"        e{s}_{k} = 0.0" for k in range(n_lags)]
    columns = []
    for s in range(n_sensors):
        for term in map(get_term, terms):
            if s == 0 and not term.first_sensor:
                continue
            expression = term.c_expression
            if term.time_constant is not None:
                expression = expression.format(lag=taus.index(term.time_constant))
            expression = (
                expression.replace("temperature[0]", "u0")
                .replace("raw", f"u{s}")
                .replace("delta", f"delta{s}")
            )
            for k in range(n_lags):
                expression = expression.replace(f"deficit[{k}]", f"e{s}_{k}")
            columns.append(f"({expression})")
    deficit = "None"
    if n_lags:
        per_sensor = [
            "[" + ", ".join(f"e{s}_{k}" for k in range(n_lags)) + "]" for s in range(n_sensors)
        ]
        deficit = "[" + ", ".join(per_sensor) + "]"
    lines.append(f"    return [{', '.join(columns)}], {deficit}")
    namespace = {"exp": math.exp, "expm1": math.expm1}
    exec("\n".join(lines), namespace)  # generated from the term registry, as the C export
    return namespace["row"]


def _is_number(value):
    """A real number that is not a bool (True is not a rate)."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _describe(value):
    """``value`` for an error message: a string as the string, anything else by its type."""
    if isinstance(value, (str, bytes)):
        return f"the string {value!r}"
    if isinstance(value, (bool, np.bool_)):
        return f"the boolean {value!r}"
    return f"{value!r} ({type(value).__name__})"


def _number_array(values, label, unit, *, allow_none=False):
    """``values`` (a number, a sequence or an array) as float64, refusing what is not a number.

    Strings (even ``"1.0"``), booleans and other objects raise a ``ValueError`` naming
    ``label``, what was expected and the first bad entry: numpy would convert a numeric
    string, and a boolean mask passed for the values would be read as 0 and 1. With
    ``allow_none``, None entries are kept (an object array), for the caller to mark.
    """
    expected = f"{label} must hold numbers ({unit})"
    if isinstance(values, (str, bytes, bool, np.bool_)):
        raise ValueError(f"{expected}, got {_describe(values)}.")
    raw = values.to_numpy() if hasattr(values, "to_numpy") else values
    try:
        array = np.asarray(raw)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{expected}, got an array numpy cannot read ({exc}).") from None
    kind = array.dtype.kind
    if kind in "iuf":
        return array.astype(np.float64, copy=False)
    if kind == "O":
        flat = array.reshape(-1)
        for index, value in enumerate(flat.tolist()):
            if not (_is_number(value) or (allow_none and value is None)):
                row = np.unravel_index(index, array.shape)[0] if array.ndim else 0
                raise ValueError(f"{expected}, got {_describe(value)} at row {row}.")
        if allow_none:
            return array
        return array.astype(np.float64)
    what = {"U": "strings", "S": "bytes", "b": "booleans", "c": "complex numbers"}.get(
        kind, f"values of dtype {array.dtype}"
    )
    first = array.reshape(-1)[0].item() if array.size else None
    example = "" if first is None else f" (first: {first!r})"
    raise ValueError(f"{expected}, got {what}{example}.")


def _state_numbers(value, label, shape, axes=""):
    """A state entry as a finite float64 array of ``shape``; else a ``ValueError`` naming it."""
    try:
        array = None if value is None else np.asarray(value)
    except (TypeError, ValueError):
        array = None
    numeric = array is not None and array.dtype.kind in "iuf"
    if not numeric or array.shape != shape:
        got = value if not numeric else f"shape {array.shape}"
        if len(shape) == 0:
            raise ValueError(f"{label} must be a number, got {got!r}.")
        if len(shape) == 1:
            raise ValueError(f"{label} must hold {shape[0]} value(s) (numbers), got {got}.")
        axes = f" {axes}" if axes else ""
        raise ValueError(f"{label} must have shape {shape}{axes} of numbers, got {got}.")
    array = array.astype(np.float64)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{label} holds NaN or inf.")
    return array


def _floats(values):
    """A sensor reading (a number or a sequence of numbers) as a list of Python floats."""
    if _is_number(values):
        return [float(values)]
    return _number_array(values, "temperature", "deg C").reshape(-1).tolist()


def _reference_values(reference):
    """``(values, known)`` of a reference column: None or masked entries are unknown.

    Every known entry must be a number (not a string, even ``"1.0"``, nor a boolean): a
    ``ValueError`` naming ``reference`` otherwise.
    """
    if isinstance(reference, np.ma.MaskedArray):
        known = ~np.ma.getmaskarray(reference)
        data = _number_array(np.ma.getdata(reference), "reference", "deg/h")
        values = np.where(known, data, 0.0)
    else:
        raw = _number_array(reference, "reference", "deg/h", allow_none=True)
        if raw.dtype == object:
            known = np.vectorize(lambda value: value is not None, otypes=[bool])(raw)
            values = np.where(known, raw, 0.0).astype(np.float64)
        else:
            known = np.ones(raw.shape, dtype=bool)
            values = raw
    bad = known & ~np.isfinite(values)
    if bad.any():
        _table.check_finite(np.where(known, values, 0.0), "reference")
    return values, known


def _check_increasing(time, state, offset):
    """Raise unless ``time`` (rows ``offset:`` of a chunk) continues the run strictly."""
    previous = state["last_time"] if state["has_history"] else None
    violation = _table.first_time_violation(time, previous=previous)
    if violation is not None:
        where = (
            "the current run (call reset() or give the run id at the start of a new run)"
            if state["run"] is None
            else f"run {state['run']!r}"
        )
        raise ValueError(
            f"time must increase strictly within {where}: row {offset + violation[0]} of the "
            "chunk is not after the previous sample."
        )
