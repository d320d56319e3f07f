"""Online (sample-by-sample or chunked) drift compensation with a fitted Pipeline.

The only stateful step of a compensation Pipeline is :class:`~sklearn_ifog.ThermalFeatures`
(differences, lags and the smoothing are causal recursions); every later step acts row by row.
The compensator therefore carries, between calls, the last temperature of each sensor, the
last time stamp, the deficit of every first-order lag (per sensor and per time constant: the
lag terms and the smoothing, :class:`sklearn_ifog._lags.LagState`) and a first-row flag,
computes the features of a chunk with the same plain functions as the batch transformer,
started from that state, and hands the rows to the fitted steps after ThermalFeatures
unchanged. Its output is the batch Pipeline's, whatever the chunking.
"""

import copy

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted, validate_data

from sklearn_ifog import _table
from sklearn_ifog._contract import (
    check_needs_time,
    seconds_per_unit,
    sensor_keys,
    state_time_constants,
)
from sklearn_ifog._lags import LagState, lag_deficit
from sklearn_ifog.features import (
    ThermalFeatures,
    assemble_terms,
    causal_rate,
    validate_terms,
)

__all__ = ["StreamingCompensator", "advance_features"]

STATE_SCHEMA = "sklearn-ifog-streaming-state"
#: 2: the lags' deficits and the last raw temperature (version 1 held an EMA in samples).
STATE_VERSION = 2


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

    Runs: the compensator follows one run at a time. With a ``run`` column in the
    ThermalFeatures, a change of run id — between chunks or inside a chunk — starts a new run
    at that row (as :meth:`reset` would); the rows of a run must be contiguous, so a run id
    that already ended raises a ``ValueError`` (interleaved runs: one compensator per run).
    Without a ``run`` column, call :meth:`reset` at the start of every run. Time must
    increase strictly within a run, across chunks too.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline or ConformalRegressor
        Fitted; its first step is a :class:`~sklearn_ifog.ThermalFeatures`, the later steps
        act row by row (scalers, polynomial features, regressors). A fitted
        :class:`~sklearn_ifog.ConformalRegressor` around such a pipeline also carries the
        band: after every :meth:`step` or :meth:`update`, :attr:`last_interval` holds the
        drift bounds of its rows, equal to the batch ``predict_interval``.

    Attributes
    ----------
    last_interval : ndarray of shape (n_samples, 2) or None
        Lower and upper drift bound (deg/h) of the rows of the last :meth:`step` (one row)
        or :meth:`update`; None when built from a plain Pipeline.
    n_sensors : int
        Temperature sensors per sample.
    state : dict
        The current state (a copy is returned by :meth:`get_state`).

    See Also
    --------
    sklearn_ifog.export.to_c : The same compensator as self-contained C.

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
    """

    def __init__(self, pipeline):
        from sklearn_ifog.conformal import ConformalRegressor

        self.conformal = None
        self.last_interval = None
        if isinstance(pipeline, ConformalRegressor):
            check_is_fitted(pipeline)
            self.conformal = pipeline
            for model in [pipeline.estimator_, *pipeline.estimators_]:
                if not (isinstance(model, Pipeline) and model.steps[0][1] is not None):
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
        self._rest = pipeline[1:]
        self._names_in = getattr(self._first_later_step(), "feature_names_in_", None)
        self.reset()

    def _first_later_step(self):
        for _, step in self._rest.steps:
            if step not in (None, "passthrough"):
                return step
        return None

    def reset(self):
        """Forget everything: the next sample starts a new run.

        Returns
        -------
        self : StreamingCompensator
            The compensator.
        """
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
        }
        return self

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
            ``finished_runs``.
        """
        return copy.deepcopy(self.state)

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
        if list(state["time_constants"]) != self._time_constants:
            raise ValueError(
                f"state carries lags at time constants {state['time_constants']} s; this "
                f"model's are {self._time_constants} s (lag terms and smoothing)."
            )
        if state["has_history"]:
            temperature = state["temperature"]
            if temperature is None or len(temperature) != self.n_sensors:
                raise ValueError(f"state['temperature'] must hold {self.n_sensors} value(s).")
            if self._features["time"] is not None and state["last_time"] is None:
                raise ValueError("state['last_time'] is missing: the model uses time.")
            expected = (self.n_sensors, len(self._time_constants))
            if self._time_constants and np.shape(state["deficit"]) != expected:
                raise ValueError(
                    f"state['deficit'] must have shape {expected} (sensors, time constants), "
                    f"got {np.shape(state['deficit'])}."
                )
        self.state = copy.deepcopy(state)
        return self

    def step(self, time, temperature, rate=None, *, run=None):
        """Compensate one sample.

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

        Returns
        -------
        compensated : float or ndarray of shape (n_outputs,) or None
            ``rate - drift`` (None when ``rate`` is None).
        drift : float or ndarray of shape (n_outputs,)
            Predicted drift, deg/h.
        """
        temperature = np.asarray(temperature, dtype=np.float64).reshape(1, -1)
        times = None if time is None else np.array([time], dtype=np.float64)
        runs = None if run is None else [run]
        rates = None if rate is None else np.asarray(rate, dtype=np.float64)[None]
        compensated, drift = self._advance(temperature, times, runs, rates)
        return (None if compensated is None else compensated[0]), drift[0]

    def update(self, X, rate=None):
        """Compensate a chunk of consecutive samples.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_columns)
            Rows in time order, as ``pipeline.predict`` takes them (the columns the Pipeline
            was fitted on).
        rate : array-like of shape (n_samples,) or (n_samples, n_outputs), default=None
            Gyro output, deg/h.

        Returns
        -------
        compensated : ndarray or None
            ``rate - drift`` (None when ``rate`` is None).
        drift : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Predicted drift, deg/h, as ``pipeline.predict`` gives it.
        """
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
        rates = None if rate is None else np.asarray(rate, dtype=np.float64)
        return self._advance(temperature, time, run, rates)

    def _advance(self, temperature, time, run, rate):
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
        if rate is not None and rate.shape[0] != n_samples:
            raise ValueError(f"rate has {rate.shape[0]} rows, the samples {n_samples}.")
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
            block, feature_state = advance_features(
                temperature[start:stop],
                segment_time,
                state,
                terms=spec["terms"],
                smoothing=spec["smoothing"],
                seconds_per_unit=spec["seconds_per_unit"],
            )
            state.update(feature_state)
            blocks.append(block)
        features = np.concatenate(blocks)
        drift = self._rest.predict(self._frame(features))
        if rate is not None and rate.shape != drift.shape:
            raise ValueError(
                f"rate has shape {rate.shape[1:]} per sample; the model predicts "
                f"{drift.shape[1:]} (one rate per output)."
            )
        compensated = None if rate is None else rate - drift
        interval = None if self.conformal is None else self._interval(features, drift)
        self.state = state
        self.last_interval = interval
        return compensated, drift

    def _interval(self, features, drift):
        """The band of the rows with thermal ``features``, as predict_interval gives it."""
        conformal = self.conformal
        frame = self._frame(features)
        predictions = np.stack(
            [np.asarray(model[1:].predict(frame), dtype=float) for model in conformal.estimators_]
        )
        raw = None
        if conformal.adaptive:
            raw = self._rest[:-1].transform(frame) if len(self._rest.steps) > 1 else features
            raw = np.asarray(raw, dtype=float)
        return conformal._bounds(np.asarray(drift, dtype=float), predictions, raw)

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

    def _frame(self, features):
        if self._names_in is None:
            return features
        import pandas as pd

        return pd.DataFrame(features, columns=self._names_in)


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
