"""The compensator's feature state machine: ThermalFeatures of consecutive rows from a state.

The only stateful step of a compensation Pipeline is :class:`~sklearn_ifog.ThermalFeatures`
(differences, lags and the smoothing are causal recursions). Its state between rows of one
run: ``{"has_history", "temperature", "last_time", "deficit"}`` (:data:`NEW_RUN` before a
run's first row). :func:`advance_features` continues it over a block of rows with the batch
numerics; :func:`row_function` writes, for one model, a Python function of one row (the step's
hot path, and the rows of a chunk that the recalibration learns from).
"""

import math

import numpy as np

from sklearn_ifog._contract import check_needs_time, get_term, state_time_constants
from sklearn_ifog._lags import LagState, lag_deficit
from sklearn_ifog.features import assemble_terms, causal_rate

#: The feature state before a run's first row.
NEW_RUN = {"has_history": False, "temperature": None, "last_time": None, "deficit": None}


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


def sequential_features(row, temperature, time, state):
    """Features of consecutive rows of one run by the per-sample function ``row``.

    ``row``: a :func:`row_function`; ``state``: the feature state before the first row.
    Returns the features, shape ``(n_samples, n_features)``, and the feature state after the
    last row: what the step gives sample by sample, whatever the chunking.
    """
    has_history = state["has_history"]
    previous, last_time, deficit = state["temperature"], state["last_time"], state["deficit"]
    times = [None] * temperature.shape[0] if time is None else time.tolist()
    rows = []
    for temperatures, now in zip(temperature.tolist(), times, strict=True):
        values, deficit = row(temperatures, now, has_history, previous, last_time, deficit)
        rows.append(values)
        has_history, previous, last_time = True, temperatures, now
    feature_state = {
        "has_history": True,
        "temperature": previous,
        "last_time": last_time,
        "deficit": deficit,
    }
    return np.array(rows, dtype=np.float64).reshape(len(rows), -1), feature_state


def row_function(n_sensors, terms, time_constants, smoothing, seconds_per_unit, uses_time):
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
            expression = term.expression(taus)
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
    # The C names of the transition terms' steps (see sklearn_ifog._transition).
    namespace = {
        "exp": math.exp,
        "expm1": math.expm1,
        "tanh": math.tanh,
        "erf": math.erf,
        "log1p": math.log1p,
        "fabs": math.fabs,
        "fmax": max,
    }
    exec("\n".join(lines), namespace)  # generated from the term registry, as the C export
    return namespace["row"]
