"""The compensator's state: its schema, a run's start, and the checks of a saved state.

The state is a dict (:func:`new_state`): the schema's name and version, the model's sensors
and lag time constants (what a saved state must match), the current run and the runs that
ended, the feature state of :mod:`sklearn_ifog.streaming._features`, the recalibration mode
and its :class:`~sklearn_ifog.streaming._recalibration.RecalibrationState` (None without
one). :func:`saved_state` writes it as plain JSON-able values, :func:`restored_state` reads
that back after checking every entry.
"""

import copy

import numpy as np

from sklearn_ifog.streaming._features import NEW_RUN
from sklearn_ifog.streaming._inputs import state_numbers
from sklearn_ifog.streaming._recalibration import RecalibrationState

STATE_SCHEMA = "sklearn-ifog-streaming-state"
#: 4: the recalibration carries the covariance's square-root factor (``covariance_factor``,
#: version 3 the covariance); 3: the recalibration (``adapt``, ``rls``); 2: the lags' deficits
#: and the last raw temperature (version 1 held an EMA in samples).
STATE_VERSION = 4


def new_state(n_sensors, time_constants, adapt, rls):
    """The state before the first row of a stream (``rls``: the recalibration, or None)."""
    return {
        "schema": STATE_SCHEMA,
        "version": STATE_VERSION,
        "n_sensors": n_sensors,
        "time_constants": list(time_constants),
        "run": None,
        **NEW_RUN,
        "finished_runs": [],
        "adapt": adapt,
        "rls": rls,
    }


def start_run(state, run_id):
    """The state at the start of run ``run_id`` (a new dict; the current run has ended)."""
    if run_id in state["finished_runs"]:
        raise ValueError(
            f"Run {run_id!r} already ended earlier in the stream: the rows of one run must "
            "be contiguous (use one StreamingCompensator per run for interleaved runs)."
        )
    finished = state["finished_runs"]
    if state["run"] is not None:
        finished = [*finished, state["run"]]
    return {**state, "run": run_id, **NEW_RUN, "finished_runs": finished}


def saved_state(state):
    """The state as a plain, JSON-able dict (a deep copy)."""
    saved = copy.deepcopy({key: value for key, value in state.items() if key != "rls"})
    rls = state["rls"]
    saved["rls"] = None if rls is None else rls.to_dict()
    return saved


def restored_state(saved, *, n_sensors, time_constants, uses_time, adapt, weights_shape):
    """The state that ``saved`` (from :func:`saved_state`) restores, after checking it.

    The model's ``n_sensors``, lag ``time_constants`` (a list), whether it ``uses_time``,
    its ``adapt`` and the recalibration's ``weights_shape`` (None without one) are what
    ``saved`` must match. A ``ValueError`` names the first entry that does not fit.
    """
    expected = set(new_state(n_sensors, time_constants, adapt, None))
    if isinstance(saved, dict) and (
        saved.get("schema", STATE_SCHEMA) != STATE_SCHEMA
        or saved.get("version", STATE_VERSION) != STATE_VERSION
    ):
        # First, so that a state of an older version is named as such.
        raise ValueError(
            f"state is of schema {saved.get('schema')!r} version {saved.get('version')!r}; "
            f"expected {STATE_SCHEMA!r} version {STATE_VERSION}."
        )
    if not isinstance(saved, dict) or set(saved) != expected:
        got = sorted(saved) if isinstance(saved, dict) else type(saved).__name__
        raise ValueError(f"state must be a dict with keys {sorted(expected)}, got {got}.")
    if saved["n_sensors"] != n_sensors:
        raise ValueError(
            f"state is for {saved['n_sensors']} sensor(s); this model has {n_sensors}."
        )
    saved_constants = saved["time_constants"]
    if not isinstance(saved_constants, (list, tuple)) or list(saved_constants) != (time_constants):
        raise ValueError(
            f"state carries lags at time constants {saved_constants} s; this "
            f"model's are {time_constants} s (lag terms and smoothing)."
        )
    if not isinstance(saved["finished_runs"], (list, tuple)):
        raise ValueError(
            "state['finished_runs'] must be a list of run ids, got "
            f"{type(saved['finished_runs']).__name__}."
        )
    history = saved["has_history"]
    if not isinstance(history, (bool, np.bool_)):
        raise ValueError(f"state['has_history'] must be True or False, got {history!r}.")
    _check_feature_state(saved, n_sensors, time_constants, uses_time)
    rls = _restored_recalibration(saved, adapt, weights_shape)
    restored = copy.deepcopy({key: value for key, value in saved.items() if key != "rls"})
    restored["has_history"] = bool(history)
    restored["rls"] = rls
    return restored


def _check_feature_state(saved, n_sensors, time_constants, uses_time):
    """Raise unless the feature entries of ``saved`` fit its ``has_history``."""
    if not saved["has_history"]:
        for key in ("temperature", "last_time", "deficit"):
            if saved[key] is not None:
                raise ValueError(
                    f"state[{key!r}] must be None before a run's first row "
                    f"(has_history=False), got {saved[key]!r}."
                )
        return
    state_numbers(saved["temperature"], "state['temperature']", (n_sensors,))
    if uses_time:
        if saved["last_time"] is None:
            raise ValueError("state['last_time'] is missing: the model uses time.")
        state_numbers(saved["last_time"], "state['last_time']", ())
    elif saved["last_time"] is not None:
        raise ValueError(
            "state['last_time'] must be None: the model has no time column, got "
            f"{saved['last_time']!r}."
        )
    if time_constants:
        shape = (n_sensors, len(time_constants))
        state_numbers(saved["deficit"], "state['deficit']", shape, "(sensors, time constants)")
    elif saved["deficit"] is not None:
        raise ValueError(
            f"state['deficit'] must be None: the model carries no lags, got {saved['deficit']!r}."
        )


def _restored_recalibration(saved, adapt, weights_shape):
    """The :class:`RecalibrationState` of ``saved`` (None without ``adapt``), checked."""
    if saved["adapt"] != adapt:
        raise ValueError(
            f"state is of a compensator with adapt={saved['adapt']!r}; this one has "
            f"adapt={adapt!r}."
        )
    if adapt is None:
        if saved["rls"] is not None:
            raise ValueError("state['rls'] must be None: this compensator does not adapt.")
        return None
    return RecalibrationState.from_dict(saved["rls"], weights_shape)
