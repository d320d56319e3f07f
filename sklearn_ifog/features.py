"""Causal thermal features of a gyro's temperature: T, its rate dT, T·dT and lags, per run.

The estimator, :class:`ThermalFeatures`, holds the scikit-learn surface (columns, validation,
names, output containers). The numerics are plain numpy functions below it, shared with the
streaming compensator and the C exporter:

- :func:`group_rows_by_run`: a stable order that makes every run's rows contiguous;
- :func:`causal_rate`: backward difference (per sample or per unit time) that restarts at every
  run;
- :func:`sklearn_ifog._lags.lag_deficit` and :func:`~sklearn_ifog._lags.smoothed_rate`: exact
  first-order lags at time constants in seconds (the ``T_lag<tau>s`` terms and the smoothed
  ``dT``);
- :func:`assemble_terms`: the feature columns from the temperature, its rate and its lags;
- :func:`compute_thermal_features`: all of the above on rows in any run interleaving.
"""

import numbers
from typing import ClassVar

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import validate_data

from sklearn_ifog import _contract, _lags, _table, _transition
from sklearn_ifog._compat import Interval, StrOptions, _check_feature_names_in, _fit_context
from sklearn_ifog._contract import (
    SECONDS_PER_UNIT,
    VALID_TERMS,
    SensorInputs,
    check_needs_time,
    get_term,
    resolve_defaults,
    resolved_settings,
    sensor_keys,
    state_time_constants,
    valid_terms_text,
)
from sklearn_ifog._table import group_rows_by_run

__all__ = [
    "SECONDS_PER_RATE_UNIT",
    "VALID_TERMS",
    "ThermalFeatures",
    "assemble_terms",
    "causal_rate",
    "compute_thermal_features",
    "group_rows_by_run",
    "validate_terms",
]

#: Seconds in one unit of the temperature rate, by ``rate_unit`` name (the feature contract's
#: :data:`sklearn_ifog._contract.SECONDS_PER_UNIT`).
SECONDS_PER_RATE_UNIT = SECONDS_PER_UNIT


# ---------------------------------------------------------------------------------------------
# Numerics: numpy in, numpy out.
# ---------------------------------------------------------------------------------------------


def validate_terms(terms, n_sensors):
    """Check a ``terms`` sequence and return it as a tuple.

    Parameters
    ----------
    terms : sequence of str
        Term names, each one of :data:`VALID_TERMS` or a lag term ``"T_lag<tau>s"`` (see
        :data:`sklearn_ifog._contract.TERM_FAMILIES`), no duplicates, at least one.
    n_sensors : int
        Number of temperature columns; ``"gradient"`` needs at least two.

    Returns
    -------
    terms : tuple of str
        The validated terms, in the given order.

    Raises
    ------
    ValueError
        On an empty sequence, an unknown or duplicate term (two names of one time constant,
        such as ``"T_lag600s"`` and ``"T_lag600.0s"``, are duplicates), a term of a known form
        with a bad parameter (such as a transition's width of 0; the message names the term),
        or ``"gradient"`` with one sensor.

    Examples
    --------
    >>> from sklearn_ifog.features import validate_terms
    >>> validate_terms(["T", "dT", "T_lag600s"], n_sensors=1)
    ('T', 'dT', 'T_lag600s')
    """
    if isinstance(terms, str):
        raise ValueError(
            f"terms must be a list or tuple of term names, got the string {terms!r}; "
            f"did you mean ({terms!r},)?"
        )
    terms = tuple(terms)
    if not terms:
        raise ValueError(f"terms is empty; give at least one of {valid_terms_text()}.")
    definitions = {}
    unknown = []
    for term in terms:
        try:
            definitions[term] = get_term(term)
        except ValueError as exc:
            if isinstance(term, str) and str(exc).startswith(f"Term {term!r}:"):
                # A known form with a bad parameter (a width or lag <= 0): say which.
                raise ValueError(f"Bad term in terms: {exc}") from None
            unknown.append(term)
    if unknown:
        raise ValueError(
            f"Unknown term(s) {unknown} in terms; valid terms are {valid_terms_text()}."
        )
    outputs = [definitions[term].output for term in terms]
    duplicates = sorted({term for term in terms if outputs.count(definitions[term].output) > 1})
    if duplicates:
        raise ValueError(f"Duplicate term(s) {duplicates} in terms={terms!r}.")
    for term in terms:
        if not definitions[term].first_sensor and n_sensors < 2:
            raise ValueError(
                f"The {term!r} term has no column for the first sensor (for 'gradient': each "
                "sensor minus the first one), so it needs at least two temperature columns; "
                f"got {n_sensors}."
            )
    return terms


def _start_mask(n_samples, run_starts):
    if run_starts is None:
        run_starts = np.zeros(n_samples, dtype=bool)
    else:
        run_starts = np.asarray(run_starts, dtype=bool)
        if run_starts.shape != (n_samples,):
            raise ValueError(f"run_starts must have shape ({n_samples},), got {run_starts.shape}.")
    return run_starts


def causal_rate(values, run_starts=None, time=None, seconds_per_unit=60.0):
    """Backward difference of a signal, restarting at every run.

    ``dT[i] = s[i] - s[i-1]`` per sample (``time=None``, the reference paper's Eq. 22), or
    ``dT[i] = (s[i] - s[i-1]) / (t[i] - t[i-1]) * seconds_per_unit`` per unit time. The first
    row of every run has no history: ``dT = 0`` there.

    Parameters
    ----------
    values : array-like of shape (n_samples,) or (n_samples, n_sensors)
        Signal (e.g. smoothed temperature), rows of each run contiguous and in time order.
    run_starts : array-like of bool of shape (n_samples,), default=None
        True at the first row of every run; row 0 always starts one. None: one run.
    time : array-like of shape (n_samples,), default=None
        Time in seconds, strictly increasing within each run. None: per-sample difference.
    seconds_per_unit : float, default=60.0
        Seconds in the rate's time unit (60: per minute). Ignored when ``time`` is None.

    Returns
    -------
    rate : ndarray of float64, same shape as ``values``
        The causal rate; row i depends only on rows i-1 and i of its run.

    Raises
    ------
    ValueError
        If ``time`` does not increase strictly within a run.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.features import causal_rate
    >>> T = np.array([20.0, 20.5, 21.5, 30.0, 29.0])
    >>> starts = np.array([True, False, False, True, False])
    >>> causal_rate(T, starts)
    array([ 0. ,  0.5,  1. ,  0. , -1. ])
    >>> causal_rate(T, starts, time=[0.0, 30.0, 60.0, 0.0, 60.0], seconds_per_unit=60.0)
    array([ 0.,  1.,  2.,  0., -1.])
    """
    values = np.asarray(values, dtype=np.float64)
    one_d = values.ndim == 1
    values = values.reshape(values.shape[0], -1)
    n_samples = values.shape[0]
    run_starts = _start_mask(n_samples, run_starts)
    continues = ~run_starts[1:]
    rate = np.zeros_like(values)
    step = values[1:] - values[:-1]
    if time is None:
        rate[1:][continues] = step[continues]
    else:
        time = np.asarray(time, dtype=np.float64).reshape(n_samples)
        violation = _table.first_time_violation(time, run_starts=run_starts)
        if violation is not None:
            row, previous = violation
            raise ValueError(
                f"time must increase strictly within each run; row {row} has time "
                f"{time[row].item()!r} after {time[previous].item()!r} at row {previous}."
            )
        elapsed = time[1:][continues] - time[:-1][continues]
        rate[1:][continues] = step[continues] / elapsed[:, None] * seconds_per_unit
    return rate[:, 0] if one_d else rate


def assemble_terms(temperature, rate, terms, *, deficit=None, time_constants=()):
    """Feature columns from the raw temperature, its rate and its lags.

    Columns are laid out sensor by sensor (in the given order) and, within a sensor, term by
    term (in the given order). ``"gradient"`` (sensor minus the first sensor) gives no column
    for the first sensor, whose gradient would be identically zero.

    Parameters
    ----------
    temperature : array-like of shape (n_samples,) or (n_samples, n_sensors)
        Raw (unsmoothed) temperature of every sensor.
    rate : array-like, same shape as ``temperature``
        Temperature rate ``dT`` of every sensor (see :func:`causal_rate`).
    terms : sequence of str
        Any of ``"T"``, ``"dT"``, ``"TdT"`` (T·dT), ``"T2"`` (T²), ``"gradient"`` and
        ``"T_lag<tau>s"`` (the deficit ``T - lag_tau(T)``, read from ``deficit``).
    deficit : array-like of shape (n_samples, n_sensors, n_time_constants), default=None
        Deficit of every sensor's temperature behind its first-order lag at every time
        constant of ``time_constants`` (see :func:`sklearn_ifog._lags.lag_deficit`). Needed
        by the lag terms only.
    time_constants : sequence of float, default=()
        The time constants (s) of the last axis of ``deficit``.

    Returns
    -------
    features : ndarray of shape (n_samples, n_features_out), dtype float64
        The feature columns.

    Raises
    ------
    ValueError
        On bad ``terms``, or a lag term whose time constant is not in ``time_constants``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.features import assemble_terms
    >>> assemble_terms(np.array([20.0, 21.0]), np.array([0.0, 1.0]), ["T", "dT", "TdT", "T2"])
    array([[ 20.,   0.,   0., 400.],
           [ 21.,   1.,  21., 441.]])
    """
    temperature = np.asarray(temperature, dtype=np.float64)
    temperature = temperature.reshape(temperature.shape[0], -1)
    n_samples, n_sensors = temperature.shape
    rate = np.asarray(rate, dtype=np.float64).reshape(temperature.shape)
    terms = validate_terms(terms, n_sensors)
    definitions = [get_term(term) for term in terms]
    time_constants = tuple(float(tau) for tau in time_constants)
    missing = [
        term.name
        for term in definitions
        if any(tau not in time_constants for tau in term.time_constants)
    ]
    if missing:
        raise ValueError(
            f"The lag term(s) {missing} need their deficit: give deficit and time_constants "
            f"(got time constants {list(time_constants)})."
        )
    if time_constants:
        deficit = np.asarray(deficit, dtype=np.float64).reshape(
            n_samples, n_sensors, len(time_constants)
        )
    columns = []
    for sensor in range(n_sensors):
        lag = {tau: deficit[:, sensor, k] for k, tau in enumerate(time_constants)}
        inputs = SensorInputs(
            T=temperature[:, sensor], dT=rate[:, sensor], first=temperature[:, 0], lag=lag
        )
        columns += [
            term.compute(inputs) for term in definitions if sensor > 0 or term.first_sensor
        ]
    if not columns:
        return np.empty((n_samples, 0))
    return np.column_stack(columns)


def _grouped_features(temperature, time, run_starts, *, terms, smoothing, seconds_per_unit):
    """Thermal features of rows grouped by run (each run contiguous, in time order).

    ``dT`` is :func:`causal_rate` (``smoothing == 0``) or
    :func:`sklearn_ifog._lags.smoothed_rate` at ``smoothing`` seconds; the lag terms are
    :func:`sklearn_ifog._lags.lag_deficit` at their time constants; every recursion restarts
    at each run.

    Parameters
    ----------
    temperature : ndarray of shape (n_samples, n_sensors)
        Raw temperature, deg C.
    time : ndarray of shape (n_samples,) or None
        Time, s, strictly increasing within each run (checked by the caller).
    run_starts : ndarray of bool of shape (n_samples,) or None
        True at the first row of every run. None: one run.
    terms : tuple of str
        Validated terms.
    smoothing : float
        Smoothing time constant, s (0: none).
    seconds_per_unit : float
        Seconds in the rate's time unit.

    Returns
    -------
    features : ndarray of shape (n_samples, n_features_out)
        The features, rows as given.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.features import _grouped_features
    >>> T = np.array([[20.0], [21.0], [22.0]])
    >>> _grouped_features(
    ...     T,
    ...     np.array([0.0, 60.0, 120.0]),
    ...     None,
    ...     terms=("dT",),
    ...     smoothing=0.0,
    ...     seconds_per_unit=60.0,
    ... )
    array([[0.],
           [1.],
           [1.]])
    """
    check_needs_time(terms, smoothing, time is not None)
    taus = state_time_constants(terms, smoothing)
    deficit = None
    if taus:
        deficit = _lags.lag_deficit(temperature, time, run_starts, np.asarray(taus))
    if smoothing > 0:
        rate = deficit[:, :, taus.index(float(smoothing))] / np.float64(smoothing)
        rate = rate * seconds_per_unit
    else:
        rate = causal_rate(temperature, run_starts, time, seconds_per_unit)
    return assemble_terms(temperature, rate, terms, deficit=deficit, time_constants=taus)


def compute_thermal_features(
    temperature,
    *,
    time=None,
    run=None,
    terms=("T", "dT", "TdT"),
    smoothing=0.0,
    seconds_per_unit=60.0,
):
    """Thermal features of rows in any run interleaving (numpy in, numpy out).

    Groups the rows by run (stable), computes rates and lags on each run on its own, and
    returns the features in the input row order.

    Parameters
    ----------
    temperature : array-like of shape (n_samples,) or (n_samples, n_sensors)
        Raw temperature, deg C, finite.
    time : array-like of shape (n_samples,), default=None
        Time in seconds, strictly increasing within each run. None: per-sample ``dT`` (and
        neither lag terms nor smoothing).
    run : array-like of shape (n_samples,), default=None
        Run id of every row. None: all rows are one run.
    terms : sequence of str, default=("T", "dT", "TdT")
        Terms to compute (see :func:`assemble_terms`).
    smoothing : float, default=0.0
        Time constant of the rate's smoothing, s (0: none; > 0 needs ``time``), see
        :func:`sklearn_ifog._lags.smoothed_rate`.
    seconds_per_unit : float, default=60.0
        Seconds in the rate's time unit (see :func:`causal_rate`).

    Returns
    -------
    features : ndarray of shape (n_samples, n_features_out), dtype float64
        Row i depends only on rows <= i of its run.

    Raises
    ------
    ValueError
        If ``time`` does not increase strictly within a run (naming the run and the row,
        a position in the input), on bad ``terms``, or on lag terms or ``smoothing > 0``
        without ``time``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.features import compute_thermal_features
    >>> compute_thermal_features(
    ...     np.array([20.0, 30.0, 21.0, 29.0]), run=np.array([1, 2, 1, 2]), terms=["dT"]
    ... )
    array([[ 0.],
           [ 0.],
           [ 1.],
           [-1.]])
    """
    temperature = np.asarray(temperature, dtype=np.float64)
    temperature = temperature.reshape(temperature.shape[0], -1)
    terms = validate_terms(terms, temperature.shape[1])
    check_needs_time(terms, smoothing, time is not None)
    order, run_starts = group_rows_by_run(run)
    if time is not None:
        time = np.asarray(time, dtype=np.float64).reshape(temperature.shape[0])
        _table.check_time_increasing(time, run, order=order, run_starts=run_starts)
    params = {"terms": terms, "smoothing": smoothing, "seconds_per_unit": seconds_per_unit}
    if order is None:
        return _grouped_features(temperature, time, None, **params)
    grouped_time = None if time is None else time[order]
    grouped = _grouped_features(temperature[order], grouped_time, run_starts, **params)
    features = np.empty_like(grouped)
    features[order] = grouped
    return features


def _find_transition(columns, y, terms, smoothing, seconds_per_unit, search):
    """:func:`sklearn_ifog._transition.search_transition` on a table's columns.

    The first sensor's temperature carries the step (several sensors each get the found
    terms); the folds are those of the calibration domain's threshold (whole runs, or
    contiguous blocks of one run); at most ``MAX_SEARCH_ROWS`` rows are read. None when the
    calibration is too short to hold anything out.
    """
    from sklearn_ifog.domain import held_out_folds  # the domain imports this module

    temperature = columns.temperature
    n_samples = temperature.shape[0]
    Y = np.asarray(y, dtype=np.float64)
    if Y.shape[0] != n_samples:
        raise ValueError(f"y has {Y.shape[0]} rows; X has {n_samples}.")
    Y = Y.reshape(n_samples, -1)
    centres = search["centres"]
    if centres is not None:
        low, high = float(temperature[:, 0].min()), float(temperature[:, 0].max())
        if centres[0] < low or centres[1] > high:
            raise ValueError(
                f"transition['centres']={tuple(centres)!r} reaches beyond the calibrated "
                f"temperatures of the first sensor [{low:.6g}, {high:.6g}] degC: a "
                "transition there could not be confirmed by the calibration."
            )
    if not np.all(np.isfinite(Y)):
        raise ValueError(
            "transition: the search needs a finite drift target y; it holds NaN or infinite "
            f"values in {int(np.sum(~np.isfinite(Y)))} entries."
        )
    if n_samples < _transition.MIN_SEARCH_ROWS:
        return None
    base_lags = _contract.lag_time_constants(
        [term for term in terms if _contract.get_term(term).output.startswith("T_lag")]
    )
    lags = tuple(float(lag) for lag in search["lags"])
    needed = sorted(set(lags) | set(base_lags))
    probe_terms = ("T", "dT", *(f"T_lag{_contract.format_seconds(tau)}s" for tau in needed))
    probe = compute_thermal_features(
        temperature[:, 0],
        time=columns.time,
        run=columns.run,
        terms=probe_terms,
        smoothing=smoothing,
        seconds_per_unit=seconds_per_unit,
    )
    base = compute_thermal_features(
        temperature,
        time=columns.time,
        run=columns.run,
        terms=terms,
        smoothing=smoothing,
        seconds_per_unit=seconds_per_unit,
    )
    runs = None if columns.run is None else np.unique(columns.run, return_inverse=True)[1]
    rows = _transition.search_rows(runs, n_samples)
    folds = held_out_folds(n_samples, runs)[rows]
    if np.unique(folds).size < 2:
        return None
    deficit = {tau: probe[rows, 2 + k] for k, tau in enumerate(needed)}
    return _transition.search_transition(
        base[rows],
        Y[rows],
        probe[rows, 0],
        probe[rows, 1],
        deficit.__getitem__,
        folds,
        base_lags=base_lags,
        shapes=search["shapes"],
        centres=centres,
        widths=search["widths"],
        lags=lags,
    )


class ThermalFeatures(TransformerMixin, BaseEstimator):
    """Causal thermal features per run: temperature T, its rate dT, T·dT, lags and extra terms.

    The features of the paper's temperature compensation model for fibre-optic gyroscopes:
    the coil temperature T, its variation dT (the Shupe effect) and their product T·dT (the
    Shupe coefficient varies with T), plus thermal-state terms: the excess of T over its
    first-order lags at time constants in seconds, which carry the temperature distribution
    inside the coil. Everything is computed run by run and never crosses a run boundary,
    whatever the interleaving of the runs' rows; output row i is input row i.

    Parameters
    ----------
    temperature : str, int, list or tuple, default="temperature"
        Temperature column(s), deg C: a column name (DataFrame) or an integer position, or a
        list/tuple of them for several sensors.
    time : str, int or None, default=None
        Time column, in seconds, strictly increasing within each run. None: ``dT`` is the
        per-sample difference (the reference paper's Eq. 22); lag terms and ``smoothing > 0``
        then raise a ValueError (their time constants are in seconds).
    run : str, int or None, default=None
        Column with the run id of every row (numbers or strings). None: X is one run.
    terms : "auto", list or tuple of str, default="auto"
        Terms to output, any subset in any order of ``"T"`` (raw temperature), ``"dT"``,
        ``"TdT"`` (T·dT), ``"T2"`` (T²), ``"gradient"`` (this sensor minus the first
        sensor; needs several sensors), ``"T_lag<tau>s"``: ``T - lag_tau(T)``, the excess
        of the temperature over its causal first-order lag at time constant ``tau`` seconds
        (an integer or decimal number, e.g. ``"T_lag600s"``, ``"T_lag90.5s"``; needs
        ``time``), and ``"TT_lag<tau>s"``: ``T * (T - lag_tau(T))``, that excess with a
        temperature-dependent gain, as ``"TdT"`` is to ``"dT"``. ``"auto"``: with ``time``,
        the thermal-state set ``("T", "dT", "TdT", "T2", "T_lag900s", "TT_lag900s",
        "T_lag3600s", "TT_lag3600s")`` (:data:`sklearn_ifog._contract.DEFAULT_STATE_TERMS`,
        measured against the paper's set over physics presets, seeds and sample periods by
        ``python benchmarks/bench_thermal_state.py``); without ``time``, the paper's terms
        and T², ``("T", "dT", "TdT", "T2")``. Pass ``terms=("T", "dT", "TdT")`` to reproduce
        the paper (its modified model; ``("T", "dT")`` is its traditional model).
    smoothing : "auto" or float, default="auto"
        Time constant, in seconds, of the smoothing of ``dT`` (0: none, ``dT`` is the
        backward difference). With ``smoothing > 0`` (needs ``time``), ``dT`` is the rate of
        the temperature's first-order lag at that time constant,
        ``(T - lag_smoothing(T)) / smoothing`` in deg C per ``rate_unit``: exact between
        samples, the same at any sample period. ``"auto"``: 120 s
        (:data:`sklearn_ifog._contract.DEFAULT_SMOOTHING`) with ``time`` and a
        ``"T_lag<tau>s"`` term among the (resolved) terms, as measured with the default
        terms; otherwise 0, so that ``terms=("T", "dT", "TdT")`` is exactly the paper's
        backward difference. Tunable by GridSearchCV.
    rate_unit : {"s", "min", "h"} or float, default="min"
        Time unit of ``dT`` when ``time`` is given (a float is the unit in seconds).
    transition : None, "auto" or dict, default=None
        Search the calibration for a coating's transition (needs ``time`` and the drift
        target ``y`` at :meth:`fit`; experimental, see Notes). None: no search. ``"auto"``:
        the grid of :data:`sklearn_ifog._transition.DEFAULT_SEARCH` (every shape, its
        widths and lags, centres over the calibrated inner temperatures). A dict overrides
        some of its keys: ``"shapes"`` (of ``"logistic"``, ``"erf"``, ``"hinge"``),
        ``"centres"`` (a range ``(low, high)`` in degC inside the calibrated temperatures),
        ``"widths"`` (degC, > 0) and ``"lags"`` (s, > 0). The terms found are appended to
        ``terms_``.

    Attributes
    ----------
    terms_ : tuple of str
        The terms computed: ``terms`` with ``"auto"`` resolved (see ``terms``).
    smoothing_ : float
        The smoothing time constant, s: ``smoothing`` with ``"auto"`` resolved.
    transition_ : Transition or None
        With ``transition``, the best transition of the search
        (:class:`sklearn_ifog._transition.Transition`: ``shape``, ``centre``, ``width``,
        ``lag``, ``held_out_gain`` and its ``standard_error``, ``n_candidates``) and the
        ``terms`` it added (empty when it did not beat the other terms by more than one
        standard error on held-out folds, chosen on one half of them and judged on the
        other, both ways round). None without a search, or when the calibration
        is too short to hold anything out (fewer than 200 rows or a single fold).
    n_features_in_ : int
        Number of columns of X seen during :meth:`fit`.
    feature_names_in_ : ndarray of shape (`n_features_in_`,)
        Column names of X seen during :meth:`fit`, when they are all strings.

    See Also
    --------
    compute_thermal_features : The same computation on numpy arrays.
    causal_rate : The causal rate without smoothing.
    sklearn_ifog._lags.lag_deficit : The lag terms.
    sklearn_ifog._lags.smoothed_rate : The smoothed rate.
    sklearn_ifog.RBFNetRegressor : The drift model usually fed by these features.

    Notes
    -----
    **Causality.** Row i of a run depends only on rows <= i of that run (rows of a run are in
    time order). Transforming the first k rows of a run gives the first k rows of the whole
    run's result: bit for bit without lags and smoothing, to rounding (1e-12 relative) with
    them (their batch algorithm is a blocked prefix scan).

    **First row.** A run's first row has no history: its ``dT`` is 0 and its lags start in
    equilibrium (every ``T_lag<tau>s`` is 0).

    **Lags.** Per run and per sensor, ``lag_tau`` solves ``tau dy/dt = T - y`` exactly for a
    temperature linear between samples (any, irregular, time steps); the term is the deficit
    ``e = T - y``, carried from sample to sample as
    ``e1 = a e0 + g (T1 - T0)``, ``x = (t1 - t0) / tau``, ``a = exp(-x)``,
    ``g = -expm1(-x) / x`` (see :mod:`sklearn_ifog._lags`).

    **Smoothing.** With ``smoothing > 0``, ``dT = e_s / smoothing`` per second (times the
    seconds of ``rate_unit``), ``e_s`` the deficit at ``tau = smoothing``: the derivative of
    the lagged temperature, the same at any sample period. The ``"T"``, ``"TdT"``, ``"T2"``,
    ``"gradient"`` and lag terms use the raw T.

    **Units.** Without ``time``: ``dT[i] = T[i] - T[i-1]`` in deg C per sample. With ``time``
    (seconds) and no smoothing: ``dT[i] = (T[i] - T[i-1]) / (t[i] - t[i-1])`` in deg C per
    ``rate_unit``. Lag terms are in deg C.

    **Names.** One sensor: ``"T"``, ``"dT"``, ``"T_dT"``, ``"T2"``, ``"T_lag600s"``,
    ``"T_T_lag600s"`` (the time constant as an integer, or a decimal number, of seconds).
    Several sensors: each prefixed with the sensor's column name (``"x<position>"`` for
    arrays), e.g.
    ``"coil_T_dT"``, ``"coil_T_lag600s"``, sensor by sensor, term by term;
    ``"<sensor>_gradient"`` is that sensor minus the first one, which gets no gradient column.

    **Defaults.** With a time column, the default features are the thermal-state set with
    ``dT`` smoothed over 120 s: a single lagging sensor's (T, dT, T·dT) do not carry the
    temperature distribution inside a coil of several layers, its lags at 900 s and 3600 s
    do (measured by ``python benchmarks/bench_thermal_state.py``), and every one of them is
    a time constant in seconds, the same at any sample period. The drift is, to first order,
    a static bias quadratic in T plus each thermal-state term times a coefficient linear in
    T, so the set holds T² and the products with T: a linear model on it extrapolates to
    held-out conditions, where one with every square and cross product of the five
    unmultiplied terms fits slowly varying gyro noise through them. Use the paper's
    ``terms=("T", "dT", "TdT")`` to reproduce the paper's experiments or its models; without
    a time column (``time=None``) the default is the paper's set and T², unsmoothed.

    **Transitions.** A polymer coating or potting changes its stiffness over a few degC
    around its glass transition, and so the gain of the coil's thermal-stress drift. The
    transition terms ``<shape><c>C_w<w>C_lag<tau>s`` (a smooth step of the sensor's lag at
    ``tau`` seconds, the inner temperature, centred at ``c`` with width ``w``), alone and
    times ``dT`` (``..._dT``) or a lag excess (``..._T_lag<tau2>s``), can be given in
    ``terms`` by hand. ``transition="auto"`` searches shape, centre, width and lag on the
    calibration: each candidate's terms are added to a least-squares model of the other
    terms with coefficients smooth in temperature, which predicts held-out runs (or
    contiguous blocks of one run); the candidate chosen on half of those folds must beat
    the model without it on the other half by more than one standard error, both ways
    round. It is opt-in and experimental: on the simulator's glass transitions it does not
    yet find the transition temperature reliably (measured by
    ``python benchmarks/bench_transition.py``).

    **Fitting.** Nothing is learnt but the transition: :meth:`transform` works without
    :meth:`fit` (``__sklearn_is_fitted__`` is True, the ``requires_fit`` tag False),
    resolving ``"auto"`` from the parameters (and computing no transition term).
    :meth:`fit` validates X and records ``terms_``, ``smoothing_``, ``transition_``,
    ``n_features_in_`` and ``feature_names_in_``; after it, :meth:`transform` computes
    ``terms_`` with ``smoothing_`` and checks that X has the same number and names of
    columns.

    Only the temperature, time and run columns are read and validated; other columns of X
    pass untouched and unconverted.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn_ifog import ThermalFeatures
    >>> X = pd.DataFrame(
    ...     {
    ...         "run": ["a", "b", "a", "b", "a"],
    ...         "time": [0.0, 0.0, 60.0, 30.0, 120.0],
    ...         "temperature": [20.0, 30.0, 21.0, 29.0, 23.0],
    ...     }
    ... )
    >>> features = ThermalFeatures(time="time", run="run", terms=("T", "dT", "TdT"))
    >>> features.set_output(transform="pandas").fit_transform(X)
          T   dT  T_dT
    0  20.0  0.0   0.0
    1  30.0  0.0   0.0
    2  21.0  1.0  21.0
    3  29.0 -2.0 -58.0
    4  23.0  2.0  46.0
    >>> lagged = ThermalFeatures(time="time", run="run", terms=("T", "T_lag600s"))
    >>> lagged.set_output(transform="pandas").fit_transform(X).round(4)
          T  T_lag600s
    0  20.0     0.0000
    1  30.0     0.0000
    2  21.0     0.9516
    3  29.0    -0.9754
    4  23.0     2.7643
    >>> default = ThermalFeatures(time="time", run="run").fit(X)
    >>> default.terms_, default.smoothing_  # doctest: +NORMALIZE_WHITESPACE
    (('T', 'dT', 'TdT', 'T2', 'T_lag900s', 'TT_lag900s', 'T_lag3600s', 'TT_lag3600s'),
     120.0)
    >>> ThermalFeatures().fit(X[["temperature"]]).terms_
    ('T', 'dT', 'TdT', 'T2')
    """

    _parameter_constraints: ClassVar[dict] = {
        "temperature": [str, Interval(numbers.Integral, 0, None, closed="left"), list, tuple],
        "time": [str, Interval(numbers.Integral, 0, None, closed="left"), None],
        "run": [str, Interval(numbers.Integral, 0, None, closed="left"), None],
        "terms": [StrOptions({"auto"}), list, tuple],
        "smoothing": [StrOptions({"auto"}), Interval(numbers.Real, 0, None, closed="left")],
        "rate_unit": [
            StrOptions(set(SECONDS_PER_RATE_UNIT)),
            Interval(numbers.Real, 0, None, closed="neither"),
        ],
        "transition": [StrOptions({"auto"}), dict, None],
    }

    def __init__(
        self,
        *,
        temperature="temperature",
        time=None,
        run=None,
        terms="auto",
        smoothing="auto",
        rate_unit="min",
        transition=None,
    ):
        self.temperature = temperature
        self.time = time
        self.run = run
        self.terms = terms
        self.smoothing = smoothing
        self.rate_unit = rate_unit
        self.transition = transition

    # -- column handling ------------------------------------------------------------------

    def _resolved(self):
        """``(terms, smoothing)`` computed: the fitted ``terms_`` and ``smoothing_`` after
        :meth:`fit`, before it the parameters with ``"auto"`` resolved."""
        return resolved_settings(self)

    def _record_resolved(self, X=None, y=None):
        self.terms_, self.smoothing_ = resolve_defaults(
            self.terms, self.smoothing, self.time is not None
        )
        self.transition_ = None
        search = self._transition_search()
        if search is None or y is None:
            return
        columns = _table.read_thermal_columns(
            X, temperature=sensor_keys(self.temperature), time=self.time, run=self.run
        )
        validate_terms(self.terms_, columns.temperature.shape[1])
        self.transition_ = _find_transition(
            columns,
            y,
            self.terms_,
            self.smoothing_,
            _contract.seconds_per_unit(self.rate_unit),
            search,
        )
        if self.transition_ is not None:
            self.terms_ = self.terms_ + self.transition_.terms

    def _transition_search(self):
        """The search's grid, or None when no transition is searched for."""
        if self.transition is None:
            return None
        if self.time is None:
            raise ValueError(
                f"transition={self.transition!r}: a transition's inner temperature is a lag "
                "in seconds and needs a time column (time=...)."
            )
        if isinstance(self.transition, str):
            return dict(_transition.DEFAULT_SEARCH)
        return _transition.check_search(self.transition)

    def _features(self, X):
        columns = _table.read_thermal_columns(
            X, temperature=sensor_keys(self.temperature), time=self.time, run=self.run
        )
        terms, smoothing = self._resolved()
        terms = validate_terms(terms, columns.temperature.shape[1])
        try:
            return compute_thermal_features(
                columns.temperature,
                time=columns.time,
                run=columns.run,
                terms=terms,
                smoothing=smoothing,
                seconds_per_unit=_contract.seconds_per_unit(self.rate_unit),
            )
        except _table.TableError as exc:
            if columns.time_label is None or exc.previous_row is None:
                raise
            raise _table.TableError(
                f"{columns.time_label}: {exc}",
                row=exc.row,
                value=exc.value,
                previous_row=exc.previous_row,
                run=exc.run,
            ) from exc

    # -- scikit-learn surface -------------------------------------------------------------

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Validate X and record its columns; nothing is learnt.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Table with the temperature column(s) and, if named, the time and run columns.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs), default=None
            The drift target: read only by the ``transition`` search.

        Returns
        -------
        self : ThermalFeatures
            The transformer, with ``terms_``, ``smoothing_``, ``n_features_in_`` (and
            ``feature_names_in_``) set.
        """
        X = _table.as_table(X)
        validate_data(self, X, reset=True, skip_check_array=True)
        self._record_resolved(X, y)
        self._features(X)
        return self

    @_fit_context(prefer_skip_nested_validation=True)
    def fit_transform(self, X, y=None):
        """Validate X, record its columns and compute its features (one pass).

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Table with the temperature column(s) and, if named, the time and run columns.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs), default=None
            The drift target: read only by the ``transition`` search.

        Returns
        -------
        X_out : ndarray of shape (n_samples, n_features_out)
            The features, as :meth:`transform` gives them.
        """
        X = _table.as_table(X)
        validate_data(self, X, reset=True, skip_check_array=True)
        self._record_resolved(X, y)
        return self._features(X)

    def transform(self, X):
        """Compute the thermal features of every row, causally and per run.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Table with the temperature column(s) and, if named, the time and run columns.
            After :meth:`fit`, it must have the columns seen during fit.

        Returns
        -------
        X_out : ndarray of shape (n_samples, n_features_out)
            The features, row i for input row i, columns as :meth:`get_feature_names_out`.
        """
        self._validate_params()
        X = _table.as_table(X)
        if hasattr(self, "n_features_in_"):
            validate_data(self, X, reset=False, skip_check_array=True)
        return self._features(X)

    def get_feature_names_out(self, input_features=None):
        """Names of the output columns.

        Parameters
        ----------
        input_features : array-like of str, default=None
            Input column names. None: the names seen in :meth:`fit` (``"x<position>"`` for
            arrays, or before fit when temperature columns are given by position).

        Returns
        -------
        feature_names_out : ndarray of str objects
            One sensor: the term names (``"T"``, ``"dT"``, ``"T_dT"``, ...); several:
            ``"<sensor>_<term>"`` sensor by sensor.
        """
        keys = sensor_keys(self.temperature)
        terms = validate_terms(self._resolved()[0], len(keys))
        if hasattr(self, "n_features_in_"):
            input_features = _check_feature_names_in(self, input_features)
        elif input_features is not None:
            input_features = np.asarray(input_features, dtype=object)

        def sensor_name(key):
            if isinstance(key, str):
                return key
            if input_features is not None:
                if key >= len(input_features):
                    raise ValueError(
                        f"temperature position {key} is out of range for input_features of "
                        f"length {len(input_features)}."
                    )
                return str(input_features[key])
            return f"x{key}"

        names = []
        for sensor, key in enumerate(keys):
            for term in map(get_term, terms):
                if sensor > 0 or term.first_sensor:
                    names.append(
                        term.output if len(keys) == 1 else f"{sensor_name(key)}_{term.output}"
                    )
        return np.asarray(names, dtype=object)

    def __sklearn_is_fitted__(self):
        """Always True: the transformer learns nothing (fit only records the columns).

        Returns
        -------
        fitted : bool
            True.
        """
        return True

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.requires_fit = False
        tags.input_tags.allow_nan = False
        tags.transformer_tags.preserves_dtype = ["float64"]
        return tags
