"""Online (sample-by-sample or chunked) drift compensation with a fitted Pipeline.

The only stateful step of a compensation Pipeline is :class:`~sklearn_ifog.ThermalFeatures`
(smoothing and differences are causal recursions); every later step acts row by row. The
compensator therefore carries, between calls, the last smoothed temperature of each sensor, the
last time stamp and a first-row flag, computes the features of a chunk with the same plain
functions as the batch transformer, started from that state, and hands the rows to the fitted
steps after ThermalFeatures unchanged. Its output is the batch Pipeline's, whatever the
chunking.
"""

import copy

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted, validate_data

from sklearn_ifog import _table
from sklearn_ifog._contract import seconds_per_unit, sensor_keys
from sklearn_ifog.features import (
    ThermalFeatures,
    assemble_terms,
    causal_rate,
    ema_smooth,
    validate_terms,
)

__all__ = ["StreamingCompensator", "advance_features"]

STATE_SCHEMA = "sklearn-ifog-streaming-state"
STATE_VERSION = 1


def advance_features(temperature, time, state, *, terms, smoothing, seconds_per_unit):
    """ThermalFeatures of consecutive rows of one run, continued from a state.

    The batch numerics of :mod:`sklearn_ifog.features`: ``ema_smooth`` started from the carried
    smoothed value, ``causal_rate`` on the rows preceded by the carried last row, then
    ``assemble_terms``; so a run cut into chunks gives bit for bit the features of the whole
    run.

    Parameters
    ----------
    temperature : ndarray of shape (n_samples, n_sensors)
        Raw temperatures, deg C, in time order.
    time : ndarray of shape (n_samples,) or None
        Time stamps, s (``None``: per-sample differences).
    state : dict
        ``{"has_history": bool, "smoothed": list or None, "last_time": float or None}``, the
        end of the run's previous rows (``has_history=False`` for a new run). Not modified.
    terms : sequence of str
        Feature terms (see :func:`~sklearn_ifog.features.assemble_terms`).
    smoothing : float
        EMA time constant in samples (see :func:`~sklearn_ifog.features.ema_smooth`).
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
    >>> state = {"has_history": False, "smoothed": None, "last_time": None}
    >>> rows = np.array([[20.0], [20.5], [21.5]])
    >>> features, state = advance_features(
    ...     rows[:2], None, state, terms=("T", "dT"), smoothing=0.0, seconds_per_unit=None
    ... )
    >>> more, state = advance_features(
    ...     rows[2:], None, state, terms=("T", "dT"), smoothing=0.0, seconds_per_unit=None
    ... )
    >>> np.vstack([features, more])
    array([[20. ,  0. ],
           [20.5,  0.5],
           [21.5,  1. ]])
    >>> state["smoothed"], state["has_history"]
    ([21.5], True)
    """
    temperature = np.asarray(temperature, dtype=np.float64)
    n_samples = temperature.shape[0]
    if n_samples == 0:
        return assemble_terms(temperature, temperature, terms), dict(state)
    if time is not None:
        time = np.asarray(time, dtype=np.float64)
    if state["has_history"]:
        previous = np.asarray(state["smoothed"], dtype=np.float64)
        smoothed = ema_smooth(temperature, None, smoothing, initial=previous)
        # The carried last row in front: the first difference is exactly the batch one.
        extended = np.concatenate([previous[None, :], smoothed])
        extended_time = None if time is None else np.concatenate([[state["last_time"]], time])
        rate = causal_rate(extended, None, extended_time, seconds_per_unit)[1:]
    else:
        smoothed = ema_smooth(temperature, None, smoothing)
        rate = causal_rate(smoothed, None, time, seconds_per_unit)
    new_state = {
        "has_history": True,
        "smoothed": smoothed[-1].tolist(),
        "last_time": None if time is None else float(time[-1]),
    }
    return assemble_terms(temperature, rate, terms), new_state


class StreamingCompensator:
    """Compensate a gyro's thermal drift online, one sample or one chunk at a time.

    Built from a fitted Pipeline ``ThermalFeatures → ... → regressor`` (e.g. StandardScaler
    and :class:`~sklearn_ifog.RBFNetRegressor`, or a linear baseline). Its outputs equal the
    batch ``pipeline.predict`` on the same run whatever the chunking, and across
    :meth:`get_state` / :meth:`set_state`: the features bit for bit, the drift to the last
    bits (BLAS may sum a one-row product in another order than a long one).

    Runs: the compensator follows one run at a time. With a ``run`` column in the
    ThermalFeatures, a change of run id — between chunks or inside a chunk — starts a new run
    at that row (as :meth:`reset` would); the rows of a run must be contiguous, so a run id
    that already ended raises a ``ValueError`` (interleaved runs: one compensator per run).
    Without a ``run`` column, call :meth:`reset` at the start of every run. Time must
    increase strictly within a run, across chunks too.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline
        Fitted; its first step is a :class:`~sklearn_ifog.ThermalFeatures`, the later steps
        act row by row (scalers, polynomial features, regressors).

    Attributes
    ----------
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
        self._features = {
            "temperature": sensors,
            "time": features.time,
            "terms": validate_terms(features.terms, self.n_sensors),
            "smoothing": float(features.smoothing),
            "seconds_per_unit": (
                None if features.time is None else seconds_per_unit(features.rate_unit)
            ),
        }
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
            "run": None,
            "has_history": False,
            "smoothed": None,
            "last_time": None,
            "finished_runs": [],
        }
        return self

    def get_state(self):
        """The state as a plain, JSON-able dict (a copy), to save mid-run.

        Returns
        -------
        state : dict
            Keys: ``schema``, ``version``, ``n_sensors``, ``run`` (current run id),
            ``has_history`` (False before a run's first row), ``smoothed`` (last smoothed
            temperature per sensor), ``last_time``, ``finished_runs``.
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
        if not isinstance(state, dict) or set(state) != expected:
            got = sorted(state) if isinstance(state, dict) else type(state).__name__
            raise ValueError(f"state must be a dict with keys {sorted(expected)}, got {got}.")
        if state["schema"] != STATE_SCHEMA or state["version"] != STATE_VERSION:
            raise ValueError(
                f"state is of schema {state['schema']!r} version {state['version']!r}; "
                f"expected {STATE_SCHEMA!r} version {STATE_VERSION}."
            )
        if state["n_sensors"] != self.n_sensors:
            raise ValueError(
                f"state is for {state['n_sensors']} sensor(s); this model has {self.n_sensors}."
            )
        if state["has_history"]:
            smoothed = state["smoothed"]
            if smoothed is None or len(smoothed) != self.n_sensors:
                raise ValueError(f"state['smoothed'] must hold {self.n_sensors} value(s).")
            if self._features["time"] is not None and state["last_time"] is None:
                raise ValueError("state['last_time'] is missing: the model uses time.")
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
        self.state = state
        return compensated, drift

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
            "smoothed": None,
            "last_time": None,
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
