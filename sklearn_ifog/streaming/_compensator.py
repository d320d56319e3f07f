"""StreamingCompensator: the online compensator (see :mod:`sklearn_ifog.streaming`).

Its parts live beside it: the feature state machine (:mod:`._features`), the state's schema
and checks (:mod:`._state`), the recalibration (:mod:`._recalibration`), the conformal band
(:mod:`._band`) and the input checks (:mod:`._inputs`).
"""

import math

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted, validate_data

from sklearn_ifog import _table
from sklearn_ifog._compiled import FastRow, compile_domain, compile_steps
from sklearn_ifog._contract import (
    check_needs_time,
    resolved_settings,
    seconds_per_unit,
    sensor_keys,
    state_time_constants,
)
from sklearn_ifog.features import ThermalFeatures, validate_terms
from sklearn_ifog.streaming._band import ConformalBand, as_frame, sklearn_evaluator
from sklearn_ifog.streaming._features import (
    advance_features,
    row_function,
    sequential_features,
)
from sklearn_ifog.streaming._inputs import (
    check_chunk,
    check_increasing,
    describe_value,
    is_number,
    number_array,
    reference_values,
    sensor_floats,
)
from sklearn_ifog.streaming._recalibration import (
    RecalibrationState,
    check_adaptation,
    recalibration_prior,
)
from sklearn_ifog.streaming._scale_factor import input_rates_of
from sklearn_ifog.streaming._state import new_state, restored_state, saved_state, start_run

_ONE = np.ones(1)


def _unwrap(pipeline, adapt):
    """``(conformal, pipeline)``: a ConformalRegressor's full model and the regressor itself
    (None for a Pipeline), checked; the Pipeline is then checked by :func:`_thermal_step`."""
    if not hasattr(pipeline, "bounds_from_predictions"):  # no conformal band around it
        return None, pipeline
    if adapt is not None:
        raise ValueError(
            f"adapt={adapt!r} is not available with a ConformalRegressor: its band is "
            "calibrated for the fitted model, not a recalibrated one. Use adapt=None, "
            "or recalibrate its estimator_ (a plain Pipeline) without a band."
        )
    check_is_fitted(pipeline)
    for model in [pipeline.estimator_, *pipeline.estimators_]:
        if not (isinstance(model, Pipeline) and type(model.steps[0][1]) is ThermalFeatures):
            raise TypeError(
                "StreamingCompensator needs a ConformalRegressor around a Pipeline "
                f"whose first step is ThermalFeatures, got {type(model).__name__}."
            )
    return pipeline, pipeline.estimator_


def _thermal_step(pipeline):
    """The fitted Pipeline's ThermalFeatures, after checking the Pipeline's form."""
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
    return features


def _feature_spec(features):
    """What the stream needs of a fitted ThermalFeatures: columns, terms, time base."""
    sensors = sensor_keys(features.temperature)
    terms, smoothing = resolved_settings(features)
    terms = validate_terms(terms, len(sensors))
    check_needs_time(terms, smoothing, features.time is not None)
    return {
        "temperature": sensors,
        "time": features.time,
        "terms": terms,
        "smoothing": smoothing,
        "seconds_per_unit": (
            None if features.time is None else seconds_per_unit(features.rate_unit)
        ),
    }


def _first_step(steps):
    """The first step of the Pipeline ``steps`` that is not None or "passthrough"."""
    for _, step in steps.steps:
        if step not in (None, "passthrough"):
            return step
    return None


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
    domain and applies its ``uncalibrated`` policy (``"blend"``, ``"clip"`` or ``"none"``, with
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

    Scale factor: built from a pipeline fitted with ``input_rate`` (issue 44: it predicts the
    bias ``b`` and the scale-factor error ``s`` of every sample,
    :mod:`sklearn_ifog.scale_factor`), the compensator takes one gyro output per sample and its
    ``compensated`` output is the input rate that output stands for, ``(rate - b) / (1 + s ±
    a)`` (``a`` the pipeline's ``asymmetry_``, with the sign of ``rate - b``), equal to the
    batch ``pipeline.compensate(X, rate)`` (1e-12 relative), the domain's policy applied to the
    pair ``[b, s]`` as there; ``drift`` is ``rate - compensated``. :attr:`last_outside` also
    flags a sample whose output lies beyond the calibrated input rates (the output standing in
    for the input rate, as in ``compensate``). :meth:`update` without ``rate``, on rows holding
    the input-rate column, gives ``pipeline.predict``'s drift ``b + Ω s + a |Ω|`` at that input
    rate (and its flags); rows with ``rate`` need no input-rate column. :meth:`step` needs
    ``rate``. ``adapt`` is not available with a scale factor (a ``ValueError`` naming
    ``adapt`` and ``input_rate``): the recalibration learns ``rate - reference`` as a
    bias-only drift (and a ConformalRegressor refuses a scale-factor model at its fit).

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
        a pipeline fitted with ``input_rate`` (a ``ValueError``, see above), nor with
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
        Outputs (gyro axes) the Pipeline predicts (1 with a scale factor: one gyro output in,
        its input rate out).
    compiled : bool
        Whether the steps after ThermalFeatures were compiled (else scikit-learn evaluates
        them).
    state : dict
        The current state (a copy, JSON-able, is returned by :meth:`get_state`); its
        ``"rls"`` entry is a
        :class:`~sklearn_ifog.streaming._recalibration.RecalibrationState` (None without
        ``adapt``).

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

    Scale factor: a model calibrated on a rate table (the input rates, deg/h, in a column
    ``reference``; here a scale-factor error of 200 ppm) turns each gyro output into its
    input rate, as the batch ``compensate`` does, from rows without that column.

    >>> table = X.assign(reference=3.6e5 * (np.arange(len(X)) % 3 - 1.0))
    >>> output = table["reference"] * (1 + 2e-4) + y
    >>> model = make_compensation_pipeline(LinearRegression(), input_rate="reference")
    >>> model = model.fit(table, output - table["reference"])
    >>> estimate, drift = StreamingCompensator(model).update(X, rate=output)
    >>> bool(np.allclose(estimate, model.compensate(X, output), rtol=1e-12, atol=0))
    True
    >>> error = output - table["reference"]  # the output's error at 100 deg/s, deg/h
    >>> round(float(error[2]), 1), round(float(estimate[2] - table["reference"][2]), 2)
    (72.1, -0.01)
    """

    def __init__(self, pipeline, *, adapt=None, forgetting=0.999):
        check_adaptation(adapt, forgetting)
        self.last_interval = None
        # The last call's domain test: arrays from update, Python scalars from step (made
        # arrays when read, so that a step does not pay for them).
        self._last_where = (None, None)
        self.conformal, pipeline = _unwrap(pipeline, adapt)
        features = _thermal_step(pipeline)
        # A scale factor (input_rate): the pair [b, s] made the input rate (None: the bias).
        self._scale = input_rates_of(pipeline, adapt)
        spec = _feature_spec(features)
        self.pipeline = pipeline
        self.adapt = adapt
        self.forgetting = float(forgetting)
        self.n_sensors = len(spec["temperature"])
        self._thermal = features
        self._features = spec
        self._time_constants = list(state_time_constants(spec["terms"], spec["smoothing"]))
        self._uses_time = features.time is not None
        self._row_function = row_function(
            self.n_sensors,
            spec["terms"],
            self._time_constants,
            spec["smoothing"],
            spec["seconds_per_unit"],
            self._uses_time,
        )
        self._rest = pipeline[1:]
        self._names_in = getattr(_first_step(self._rest), "feature_names_in_", None)
        self._compiled = compile_steps(pipeline)
        self.compiled = self._compiled is not None
        # The calibration domain and its policy (None for a plain Pipeline); each fold
        # model of a ConformalRegressor has its own, as its predict applies it.
        self._domain = compile_domain(pipeline)
        self._band = None
        if self.conformal is not None:
            self._band = ConformalBand(self.conformal, self._compiled, self._names_in)
        # Whether the fold models are compiled (tests read it).
        self._fold_compiled = None if self._band is None else self._band.fold_compiled
        self._set_outputs(len(features.get_feature_names_out()))
        self._prior = recalibration_prior(
            adapt, self._compiled, self.n_outputs, self._rest.steps[-1][1]
        )
        self.reset(adaptation=True)

    def _set_outputs(self, n_features):
        """``n_outputs`` and whether the model predicts a 1-D array."""
        if self.compiled:
            self.n_outputs = self._compiled.final.n_outputs
            self._single_output = self._compiled.single_output
        else:
            probe = np.asarray(self._rest.predict(self._frame(np.zeros((1, n_features)))))
            self._single_output = probe.ndim == 1
            self.n_outputs = 1 if probe.ndim == 1 else probe.shape[1]
        if self._scale is not None:  # one gyro output in, its input rate out
            self.n_outputs, self._single_output = 1, True

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
            rls = None if self._prior is None else RecalibrationState.start(self._prior)
        else:
            rls = previous["rls"]
        self.state = new_state(self.n_sensors, self._time_constants, self.adapt, rls)
        self._refresh_fast()
        return self

    def _refresh_fast(self):
        """The one-row evaluator, with the current output-layer weights."""
        self._fast = None
        if FastRow.supports(self._compiled):
            weights = self.state["rls"].weights if self.adapt == "output" else None
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
        return saved_state(self.state)

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
        self.state = restored_state(
            state,
            n_sensors=self.n_sensors,
            time_constants=self._time_constants,
            uses_time=self._features["time"] is not None,
            adapt=self.adapt,
            weights_shape=None if self._prior is None else self._prior.weights.shape,
        )
        self._refresh_fast()
        return self

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
            output. With a scale factor, the input rate ``(rate - b) / (1 + s ± a)`` (``rate``
            is needed: a ``ValueError`` without it) and ``drift`` is ``rate -
            compensated``.
        drift : float or ndarray of shape (n_outputs,)
            Predicted drift, deg/h (before this sample's own update; outside the
            calibration domain, under the pipeline's ``uncalibrated`` policy). Sets
            :attr:`last_outside` and :attr:`last_distance` (one row) for a pipeline with a
            domain; never warns.
        """
        if not self.compiled:
            return self._step_slow(time, temperature, rate, run, reference)
        if self.n_sensors == 1 and isinstance(temperature, float):
            temperatures = [float(temperature)]
        else:
            temperatures = sensor_floats(temperature)
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
            if type(time) is not float and not is_number(time):
                raise ValueError(f"time must be a number (s), got {describe_value(time)}.")
            time = float(time)
            if not math.isfinite(time):
                _table.check_finite(np.array([time]), "time")
        else:
            time = None
        state = self.state
        if run is not None and run != state["run"]:
            state = start_run(state, run)
        if time is not None and state["has_history"] and not time > state["last_time"]:
            check_increasing(np.array([time]), state, 0)
        row, feature_state = self._row_features(state, time, temperatures)
        rls = state["rls"]
        adapt = self.adapt
        fast = self._fast
        drift = self._row_drift(row, rls, fast)
        domain = self._domain
        outside = False
        if domain is not None:
            distance, outside = domain.row_where(row)
            if outside and not domain.policy.keeps_model:
                drift = self._row_policy(row, drift, distance, rls, fast)
        if self._scale is not None:  # drift: the pair [b, s]
            compensated, drift, beyond = self._scale.row(drift, rates)
            self._last_where = (outside or beyond, distance)
            self.state = {**state, **feature_state, "rls": rls}
            return compensated, drift
        if adapt == "bias":
            base = drift
            bias = rls.weights[0]
            drift = base + (float(bias[0]) if single else bias)
        if references is not None and adapt is not None and not outside:
            if adapt == "bias":
                phi = _ONE
                target = rates - references - base
            else:
                phi = self._compiled.design(np.array([row]))[0]
                target = rates - references
            rls = rls.learn_row(phi, target, self.forgetting, self._prior)
            if adapt == "output" and fast is not None:
                fast = FastRow(self._compiled, rls.weights)
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
            return self._compiled.design(np.array([row]))[0] @ rls.weights
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
        if self._single_output and (type(values) is float or is_number(values)):
            values = float(values)
            if not math.isfinite(values):
                _table.check_finite(np.array([values]), label)
            return values
        values = number_array(values, label, "deg/h").reshape(-1)
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
        temperature = number_array(temperature, "temperature", "deg C").reshape(1, -1)
        times = None
        if self._uses_time and time is not None:
            if not is_number(time):
                raise ValueError(f"time must be a number (s), got {describe_value(time)}.")
            times = np.array([time], dtype=np.float64)
        runs = None if run is None else [run]
        rates = None if rate is None else number_array(rate, "rate", "deg/h")[None]
        references = None
        if reference is not None:
            references = reference_values(number_array(reference, "reference", "deg/h")[None])
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
            ``rate - drift`` (None when ``rate`` is None). With a scale factor, the input rate
            ``(rate - b) / (1 + s ± a)``, as ``pipeline.compensate(X, rate)`` (``X`` needs no
            input-rate column), and ``drift`` is ``rate - compensated``; without ``rate``,
            ``X`` holds the input-rate column and ``drift`` is ``pipeline.predict(X)``'s
            ``b + Ω s + a |Ω|``.
        drift : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Predicted drift, deg/h, as ``pipeline.predict`` gives it, its
            ``uncalibrated`` policy included (each sample's before its own update). Sets
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
        omega = None
        if self._scale is not None:  # X with the input-rate column, or its input rates
            X, rate, omega = self._scale.table(X, rate, thermal)
        if hasattr(thermal, "n_features_in_"):
            validate_data(thermal, X, reset=False, skip_check_array=True)
        spec = self._features
        temperature, time, run, _ = _table.read_thermal_columns(
            X, temperature=spec["temperature"], time=spec["time"], run=thermal.run
        )
        rates = None if rate is None else number_array(rate, "rate", "deg/h")
        references = None if reference is None else reference_values(reference)
        return self._advance(temperature, time, run, rates, references, omega)

    def _advance(self, temperature, time, run, rate, reference, omega=None):
        spec = self._features
        n_samples = temperature.shape[0]
        time, reference, has_reference = check_chunk(
            temperature,
            time,
            rate,
            reference,
            n_sensors=self.n_sensors,
            sensors=spec["temperature"],
            time_column=spec["time"],
        )
        # Work on a copy (its lists are replaced, never mutated): a chunk that fails half-way
        # leaves the state as it was.
        state, features = self._chunk_features(dict(self.state), temperature, time, run)
        domain = self._domain
        distance, outside = self._where(features)
        if self.adapt == "output":
            design = self._compiled.design(features)
            if domain is not None and domain.policy.moves_rows and outside.any():
                # Outside rows never update, so their design row only predicts: the
                # recalibrated network at the domain's edge, with the weights of its time.
                design[outside] = self._compiled.design(domain.project(features[outside]))
        else:
            design = np.ones((n_samples, 1)) if self.adapt == "bias" else None
            evaluate = (
                self._compiled.predict
                if self.compiled
                else sklearn_evaluator(self._rest, self._names_in)
            )
            base = evaluate(features).reshape(n_samples, -1)
            if domain is not None:
                base = domain.apply(features, base, distance, outside, evaluate)
        rls = state["rls"]
        if self._scale is not None:  # base: the pairs [b, s] (no adapt, no band)
            compensated, drift, beyond = self._scale.rows(base, rate, omega)
            self.state, self.last_interval = state, None
            self._last_where = (outside | beyond, distance)
            return compensated, drift
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
            prediction, rls = rls.learn_rows(design, target, learns, self.forgetting, self._prior)
            if self.adapt == "output":
                drift = prediction
                if domain is not None and not domain.policy.moves_rows:
                    # (A policy that moves rows had them moved in the design above.)
                    drift = domain.apply(features, prediction, distance, outside)
            else:
                drift = base + prediction
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

    def _chunk_features(self, state, temperature, time, run):
        """``(state, features)``: the features of a chunk's rows, run by run, and the state
        after them (``state``: a copy of the compensator's, updated)."""
        spec = self._features
        blocks = []
        for start, stop, run_id in _table.contiguous_runs(run, temperature.shape[0]):
            if run_id is not None and run_id != state["run"]:
                state = start_run(state, run_id)
            segment_time = None if time is None else time[start:stop]
            if segment_time is not None:
                check_increasing(segment_time, state, start)
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
                block, feature_state = sequential_features(
                    self._row_function, temperature[start:stop], segment_time, state
                )
            state.update(feature_state)
            blocks.append(block)
        return state, np.concatenate(blocks)

    def _where(self, features):
        """``(distance, outside)`` of feature rows (both None without a domain)."""
        domain = self._domain
        if domain is None:
            return None, None
        if self.adapt is None:
            return domain.where(features)
        # Only the rows inside teach the recalibration: each row is tested as step tests
        # it (the features are already made sample by sample here), so that which
        # references teach, and so the recursion, is the same whatever the chunking.
        tested = [domain.row_where(row) for row in features.tolist()]
        distance = np.array([row_distance for row_distance, _ in tested], dtype=np.float64)
        outside = np.array([row_outside for _, row_outside in tested], dtype=bool)
        return distance, outside

    def _interval(self, features, drift, distance=None):
        """The band of the rows with thermal ``features`` (see ``ConformalBand.interval``)."""
        margin = None if self._domain is None else self._domain.margin
        return self._band.interval(features, drift, distance, margin)

    def _frame(self, features):
        return as_frame(features, self._names_in)
