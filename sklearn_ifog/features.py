"""Causal thermal features of a gyro's temperature: T, its rate dT and T·dT, per run.

The estimator, :class:`ThermalFeatures`, holds the scikit-learn surface (columns, validation,
names, output containers). The numerics are plain numpy functions below it, shared with the
streaming compensator and the C exporter:

- :func:`group_rows_by_run`: a stable order that makes every run's rows contiguous;
- :func:`ema_smooth`: causal exponential smoothing that restarts at every run;
- :func:`causal_rate`: backward difference (per sample or per unit time) that restarts at every
  run;
- :func:`assemble_terms`: the feature columns from the temperature and its rate;
- :func:`compute_thermal_features`: all of the above on rows in any run interleaving.
"""

import numbers
from typing import ClassVar

import numpy as np
from scipy.signal import lfilter
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import validate_data

from sklearn_ifog import _contract, _table
from sklearn_ifog._compat import Interval, StrOptions, _check_feature_names_in, _fit_context
from sklearn_ifog._contract import (
    SECONDS_PER_UNIT,
    VALID_TERMS,
    SensorInputs,
    get_term,
    sensor_keys,
)
from sklearn_ifog._table import group_rows_by_run

__all__ = [
    "SECONDS_PER_RATE_UNIT",
    "VALID_TERMS",
    "ThermalFeatures",
    "assemble_terms",
    "causal_rate",
    "compute_thermal_features",
    "ema_smooth",
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
        Term names, each one of :data:`VALID_TERMS`, no duplicates, at least one.
    n_sensors : int
        Number of temperature columns; ``"gradient"`` needs at least two.

    Returns
    -------
    terms : tuple of str
        The validated terms, in the given order.

    Raises
    ------
    ValueError
        On an empty sequence, an unknown or duplicate term, or ``"gradient"`` with one sensor.

    Examples
    --------
    >>> from sklearn_ifog.features import validate_terms
    >>> validate_terms(["T", "dT"], n_sensors=1)
    ('T', 'dT')
    """
    if isinstance(terms, str):
        raise ValueError(
            f"terms must be a list or tuple of term names, got the string {terms!r}; "
            f"did you mean ({terms!r},)?"
        )
    terms = tuple(terms)
    if not terms:
        raise ValueError(f"terms is empty; give at least one of {list(VALID_TERMS)}.")
    unknown = [term for term in terms if term not in VALID_TERMS]
    if unknown:
        raise ValueError(
            f"Unknown term(s) {unknown} in terms; valid terms are {list(VALID_TERMS)}."
        )
    duplicates = sorted({term for term in terms if terms.count(term) > 1})
    if duplicates:
        raise ValueError(f"Duplicate term(s) {duplicates} in terms={terms!r}.")
    for term in terms:
        if not get_term(term).first_sensor and n_sensors < 2:
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


def ema_smooth(temperature, run_starts=None, smoothing=0.0, *, initial=None):
    """Causal exponential moving average that restarts at every run.

    ``s[0] = T[0]`` at the first row of a run, then ``s[i] = a*T[i] + (1 - a)*s[i-1]``
    (the same as ``s[i-1] + a*(T[i] - s[i-1])``) with ``a = 1 / (1 + smoothing)``, computed
    with :func:`scipy.signal.lfilter`.

    Parameters
    ----------
    temperature : array-like of shape (n_samples,) or (n_samples, n_sensors)
        Temperatures, rows of each run contiguous and in time order (see
        :func:`group_rows_by_run`). Each sensor (column) is smoothed on its own.
    run_starts : array-like of bool of shape (n_samples,), default=None
        True at the first row of every run. None: one run (or the continuation of one, see
        ``initial``).
    smoothing : float, default=0.0
        Time constant in samples (>= 0); 0 returns the temperature unchanged.
    initial : float or array-like of shape (n_sensors,), default=None
        Smoothed value just before row 0, to continue a run across chunks (streaming): row 0
        then follows the recursion instead of restarting, unless ``run_starts[0]`` is True.
        None: row 0 starts a run.

    Returns
    -------
    smoothed : ndarray of float64, same shape as ``temperature``
        The smoothed temperature. Row i depends only on rows <= i of its run.

    Notes
    -----
    Runs are filtered together as the rows of 2-D blocks (one block per power-of-two class of
    run length, so padding at most doubles the memory and the loop runs at most
    ``log2(n_samples) + 1`` times), so every run's result is bit for bit the result of that run
    alone, and of any prefix of it. A sample-by-sample implementation (streaming, C) matches
    it bit for bit with ``alpha = 1 / (1 + smoothing)``, ``keep = 1 - alpha`` and
    ``s = alpha * T + keep * s`` (no fused multiply-add).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.features import ema_smooth
    >>> T = np.array([20.0, 22.0, 22.0, 30.0, 34.0])
    >>> ema_smooth(T, run_starts=[True, False, False, True, False], smoothing=1.0)
    array([20. , 21. , 21.5, 30. , 32. ])
    """
    values = np.asarray(temperature, dtype=np.float64)
    one_d = values.ndim == 1
    values = values.reshape(values.shape[0], -1)
    n_samples, n_sensors = values.shape
    run_starts = _start_mask(n_samples, run_starts)
    if smoothing < 0:
        raise ValueError(f"smoothing must be >= 0, got {smoothing}.")
    smoothed = values.copy()
    if smoothing == 0 or n_samples == 0:
        return smoothed[:, 0] if one_d else smoothed

    alpha = 1.0 / (1.0 + smoothing)
    keep = 1.0 - alpha
    continues = initial is not None and not run_starts[0]
    segment_starts = np.flatnonzero(run_starts)
    if segment_starts.size == 0 or segment_starts[0] != 0:
        segment_starts = np.concatenate(([0], segment_starts))
    lengths = np.diff(np.append(segment_starts, n_samples))
    # Each segment's first row is the filter's initial state: s[start] = T[start] exactly, or
    # the streaming state carried in ``initial``.
    first_state = values[segment_starts].copy()
    if continues:
        initial = np.broadcast_to(np.asarray(initial, dtype=np.float64), (n_sensors,))
        first_state[0] = keep * initial + alpha * values[0]
        smoothed[0] = first_state[0]
    length_class = np.ceil(np.log2(lengths)).astype(np.intp)
    for cls in np.unique(length_class):
        in_class = np.flatnonzero(length_class == cls)
        starts = segment_starts[in_class]
        width = int(lengths[in_class].max())
        if width < 2:
            continue
        offsets = np.arange(1, width)
        rows = starts[:, None] + offsets[None, :]
        valid = offsets[None, :] < lengths[in_class][:, None]
        block = values[np.minimum(rows, n_samples - 1)]  # (n_runs, width - 1, n_sensors)
        zi = keep * first_state[in_class][:, None, :]
        filtered, _ = lfilter([alpha, 0.0], [1.0, -keep], block, axis=1, zi=zi)
        smoothed[rows[valid]] = filtered[valid]
    return smoothed[:, 0] if one_d else smoothed


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


def assemble_terms(temperature, rate, terms):
    """Feature columns from the raw temperature and its rate.

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
        Any of ``"T"``, ``"dT"``, ``"TdT"`` (T·dT), ``"T2"`` (T²) and ``"gradient"``.

    Returns
    -------
    features : ndarray of shape (n_samples, n_features_out), dtype float64
        The feature columns.

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
    rate = np.asarray(rate, dtype=np.float64).reshape(temperature.shape)
    terms = validate_terms(terms, temperature.shape[1])
    definitions = [get_term(term) for term in terms]
    columns = []
    for sensor in range(temperature.shape[1]):
        inputs = SensorInputs(
            T=temperature[:, sensor], dT=rate[:, sensor], first=temperature[:, 0]
        )
        columns += [
            term.compute(inputs) for term in definitions if sensor > 0 or term.first_sensor
        ]
    if not columns:
        return np.empty((temperature.shape[0], 0))
    return np.column_stack(columns)


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

    Groups the rows by run (stable), smooths and differentiates each run on its own, and
    returns the features in the input row order.

    Parameters
    ----------
    temperature : array-like of shape (n_samples,) or (n_samples, n_sensors)
        Raw temperature, deg C, finite.
    time : array-like of shape (n_samples,), default=None
        Time in seconds, strictly increasing within each run. None: per-sample ``dT``.
    run : array-like of shape (n_samples,), default=None
        Run id of every row. None: all rows are one run.
    terms : sequence of str, default=("T", "dT", "TdT")
        Terms to compute (see :func:`assemble_terms`).
    smoothing : float, default=0.0
        EMA time constant in samples (see :func:`ema_smooth`).
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
        a position in the input), or on bad ``terms``.

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
    order, run_starts = group_rows_by_run(run)
    if time is not None:
        time = np.asarray(time, dtype=np.float64).reshape(temperature.shape[0])
        _table.check_time_increasing(time, run, order=order, run_starts=run_starts)
    if order is None:
        smoothed = ema_smooth(temperature, None, smoothing)
        rate = causal_rate(smoothed, None, time, seconds_per_unit)
    else:
        smoothed = ema_smooth(temperature[order], run_starts, smoothing)
        grouped_time = None if time is None else time[order]
        rate = np.empty_like(temperature)
        rate[order] = causal_rate(smoothed, run_starts, grouped_time, seconds_per_unit)
    return assemble_terms(temperature, rate, terms)


class ThermalFeatures(TransformerMixin, BaseEstimator):
    """Causal thermal features per run: temperature T, its rate dT, T·dT and extra terms.

    The features of the paper's temperature compensation model for fibre-optic gyroscopes:
    the coil temperature T, its variation dT (the Shupe effect) and their product T·dT (the
    Shupe coefficient varies with T). ``dT`` is computed run by run and never crosses a run
    boundary, whatever the interleaving of the runs' rows; output row i is input row i.

    Parameters
    ----------
    temperature : str, int, list or tuple, default="temperature"
        Temperature column(s), deg C: a column name (DataFrame) or an integer position, or a
        list/tuple of them for several sensors.
    time : str, int or None, default=None
        Time column, in seconds, strictly increasing within each run. None: ``dT`` is the
        per-sample difference (the reference paper's Eq. 22).
    run : str, int or None, default=None
        Column with the run id of every row (numbers or strings). None: X is one run.
    terms : list or tuple of str, default=("T", "dT", "TdT")
        Terms to output, any subset in any order of ``"T"`` (raw temperature), ``"dT"``,
        ``"TdT"`` (T·dT), ``"T2"`` (T²) and ``"gradient"`` (this sensor minus the first
        sensor; needs several sensors). ``("T", "dT")`` is the paper's traditional model.
    smoothing : float, default=0.0
        Time constant, in samples, of a causal exponential moving average of the temperature
        applied before differencing (0: none). Tunable by GridSearchCV.
    rate_unit : {"s", "min", "h"} or float, default="min"
        Time unit of ``dT`` when ``time`` is given (a float is the unit in seconds).

    Attributes
    ----------
    n_features_in_ : int
        Number of columns of X seen during :meth:`fit`.
    feature_names_in_ : ndarray of shape (`n_features_in_`,)
        Column names of X seen during :meth:`fit`, when they are all strings.

    See Also
    --------
    compute_thermal_features : The same computation on numpy arrays.
    ema_smooth : The causal smoothing.
    causal_rate : The causal rate.
    sklearn_ifog.RBFNetRegressor : The drift model usually fed by these features.

    Notes
    -----
    **Causality.** Row i of a run depends only on rows <= i of that run (rows of a run are in
    time order); transforming the first k rows of a run gives the first k rows of the whole
    run's result, bit for bit.

    **First row.** A run's first row has no history: its ``dT`` is 0 (and its smoothed value
    is its temperature).

    **Smoothing.** Per run and per sensor, ``s[0] = T[0]`` and
    ``s[i] = s[i-1] + a (T[i] - s[i-1])`` with ``a = 1 / (1 + smoothing)``. ``dT`` is computed
    from ``s``; the ``"T"``, ``"TdT"``, ``"T2"`` and ``"gradient"`` terms use the raw T.

    **Units.** Without ``time``: ``dT[i] = s[i] - s[i-1]`` in deg C per sample. With ``time``
    (seconds): ``dT[i] = (s[i] - s[i-1]) / (t[i] - t[i-1])`` in deg C per ``rate_unit``.

    **Names.** One sensor: ``"T"``, ``"dT"``, ``"T_dT"``, ``"T2"``. Several sensors: each
    prefixed with the sensor's column name (``"x<position>"`` for arrays), e.g.
    ``"coil_T_dT"``, sensor by sensor, term by term; ``"<sensor>_gradient"`` is that sensor
    minus the first one, which gets no gradient column.

    **Fitting.** Nothing is learnt: :meth:`transform` works without :meth:`fit`
    (``__sklearn_is_fitted__`` is True, the ``requires_fit`` tag False). :meth:`fit`
    validates X and records ``n_features_in_`` and ``feature_names_in_``; after it,
    :meth:`transform` checks that X has the same number and names of columns.

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
    >>> features = ThermalFeatures(time="time", run="run").set_output(transform="pandas")
    >>> features.fit_transform(X)
          T   dT  T_dT
    0  20.0  0.0   0.0
    1  30.0  0.0   0.0
    2  21.0  1.0  21.0
    3  29.0 -2.0 -58.0
    4  23.0  2.0  46.0
    """

    _parameter_constraints: ClassVar[dict] = {
        "temperature": [str, Interval(numbers.Integral, 0, None, closed="left"), list, tuple],
        "time": [str, Interval(numbers.Integral, 0, None, closed="left"), None],
        "run": [str, Interval(numbers.Integral, 0, None, closed="left"), None],
        "terms": [list, tuple],
        "smoothing": [Interval(numbers.Real, 0, None, closed="left")],
        "rate_unit": [
            StrOptions(set(SECONDS_PER_RATE_UNIT)),
            Interval(numbers.Real, 0, None, closed="neither"),
        ],
    }

    def __init__(
        self,
        *,
        temperature="temperature",
        time=None,
        run=None,
        terms=("T", "dT", "TdT"),
        smoothing=0.0,
        rate_unit="min",
    ):
        self.temperature = temperature
        self.time = time
        self.run = run
        self.terms = terms
        self.smoothing = smoothing
        self.rate_unit = rate_unit

    # -- column handling ------------------------------------------------------------------

    def _features(self, X):
        columns = _table.read_thermal_columns(
            X, temperature=sensor_keys(self.temperature), time=self.time, run=self.run
        )
        terms = validate_terms(self.terms, columns.temperature.shape[1])
        try:
            return compute_thermal_features(
                columns.temperature,
                time=columns.time,
                run=columns.run,
                terms=terms,
                smoothing=self.smoothing,
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
        y : None
            Ignored.

        Returns
        -------
        self : ThermalFeatures
            The transformer, with ``n_features_in_`` (and ``feature_names_in_``) set.
        """
        X = _table.as_table(X)
        validate_data(self, X, reset=True, skip_check_array=True)
        self._features(X)
        return self

    @_fit_context(prefer_skip_nested_validation=True)
    def fit_transform(self, X, y=None):
        """Validate X, record its columns and compute its features (one pass).

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Table with the temperature column(s) and, if named, the time and run columns.
        y : None
            Ignored.

        Returns
        -------
        X_out : ndarray of shape (n_samples, n_features_out)
            The features, as :meth:`transform` gives them.
        """
        X = _table.as_table(X)
        validate_data(self, X, reset=True, skip_check_array=True)
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
        terms = validate_terms(self.terms, len(keys))
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
