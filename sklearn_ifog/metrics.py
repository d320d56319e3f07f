"""Gyro metrics: mean squared deviation, Earth rate, Allan deviation, bias stability, scorers,
and the scale factor of rate-table data (ppm per temperature bin, its peak-to-peak,
linearity, asymmetry, the residual at each input rate).

Rates are in deg/h, times in seconds. The Allan-curve readings follow IEEE Std 952-1997
(Annex C, "Allan variance method of data reduction").
"""

import copy
from numbers import Real

import numpy as np
from sklearn.metrics import get_scorer as _sklearn_get_scorer
from sklearn.metrics import get_scorer_names as _sklearn_get_scorer_names
from sklearn.metrics import make_scorer, mean_squared_error
from sklearn.utils import check_array

from sklearn_ifog import _table
from sklearn_ifog._compat import Interval, StrOptions, _check_sample_weight, validate_params
from sklearn_ifog._per_run import ALL_RUNS, compensation_arrays, sample_period
from sklearn_ifog._scale_factor_metrics import (
    residual_by_input_rate,
    scale_factor_asymmetry,
    scale_factor_error,
    scale_factor_linearity,
    scale_factor_peak_to_peak,
)

__all__ = [
    "EARTH_ROTATION_RATE",
    "allan_deviation",
    "angle_random_walk",
    "bias_instability",
    "bias_stability",
    "earth_rate",
    "get_scorer",
    "get_scorer_names",
    "interval_coverage",
    "interval_coverage_scorer",
    "interval_score",
    "mean_interval_width",
    "mean_squared_deviation",
    "neg_interval_score_scorer",
    "neg_mean_interval_width_scorer",
    "neg_mean_squared_deviation_scorer",
    "per_run_metrics",
    "residual_by_input_rate",
    "scale_factor_asymmetry",
    "scale_factor_error",
    "scale_factor_linearity",
    "scale_factor_peak_to_peak",
]

#: Earth's sidereal rotation rate in deg/h (7.2921150e-5 rad/s, IERS / WGS 84).
EARTH_ROTATION_RATE = 15.041067

# Flat part of the Allan curve of bias instability (flicker) noise: sigma = B * sqrt(2 ln 2 / pi),
# IEEE Std 952-1997, Annex C, Eq. (C.19).
_BIAS_INSTABILITY_FACTOR = np.sqrt(2.0 * np.log(2.0) / np.pi)
_SECONDS_PER_SQRT_HOUR = 60.0


@validate_params(
    {
        "y_true": ["array-like"],
        "y_pred": ["array-like"],
        "sample_weight": ["array-like", None],
        "multioutput": [StrOptions({"raw_values", "uniform_average"}), "array-like"],
    },
    prefer_skip_nested_validation=True,
)
def mean_squared_deviation(y_true, y_pred, *, sample_weight=None, multioutput="uniform_average"):
    """Mean squared deviation (MSD) of a compensated gyro rate from its reference.

    The figure of merit of the reference paper (Eq. 24)::

        MSD = mean((compensated - reference) ** 2)

    in (deg/h)^2. Because ``compensated = rate - predicted_drift`` and the measured drift is
    ``rate - reference``, the MSD of the compensated rate against the reference equals the
    mean squared error of the predicted drift against the measured drift::

        mean_squared_deviation(reference, rate - predicted_drift)
            == mean_squared_deviation(rate - reference, predicted_drift)

    so a drift regressor is scored directly on its predictions (this is what
    :data:`neg_mean_squared_deviation_scorer` does), and the raw, uncompensated MSD is
    ``mean_squared_deviation(reference, rate)``.

    Inputs are validated as by :func:`sklearn.metrics.mean_squared_error`.

    Parameters
    ----------
    y_true : array-like of shape (n_samples,) or (n_samples, n_outputs)
        Reference rate (or measured drift), deg/h.
    y_pred : array-like of shape (n_samples,) or (n_samples, n_outputs)
        Compensated rate (or predicted drift), deg/h.
    sample_weight : array-like of shape (n_samples,), default=None
        Sample weights.
    multioutput : {"raw_values", "uniform_average"} or array-like of shape (n_outputs,), \
            default="uniform_average"
        How to combine several outputs (e.g. gyro axes): ``"raw_values"`` returns one MSD per
        output, ``"uniform_average"`` their mean, an array their weighted mean.

    Returns
    -------
    msd : float or ndarray of shape (n_outputs,)
        Mean squared deviation, (deg/h)^2.

    See Also
    --------
    sklearn.metrics.mean_squared_error : The same computation under its generic name.

    Examples
    --------
    >>> from sklearn_ifog.metrics import mean_squared_deviation
    >>> reference = [10.0, 10.0, 10.0, 10.0]
    >>> rate = [10.5, 10.3, 9.9, 10.1]
    >>> predicted_drift = [0.4, 0.3, -0.1, 0.0]
    >>> compensated = [r - d for r, d in zip(rate, predicted_drift)]
    >>> float(mean_squared_deviation(reference, rate))  # before compensation
    0.09
    >>> float(mean_squared_deviation(reference, compensated))  # after
    0.005
    """
    # Checked here first so that a NaN or inf is reported under the argument's name.
    y_true = check_array(y_true, ensure_2d=False, dtype="numeric", input_name="y_true")
    y_pred = check_array(y_pred, ensure_2d=False, dtype="numeric", input_name="y_pred")
    if y_true.shape[0] != y_pred.shape[0]:
        raise ValueError(
            f"y_true and y_pred must have the same number of samples, got {y_true.shape[0]} "
            f"and {y_pred.shape[0]}."
        )
    if sample_weight is not None:
        sample_weight = _check_sample_weight(sample_weight, y_true)
    return mean_squared_error(y_true, y_pred, sample_weight=sample_weight, multioutput=multioutput)


@validate_params(
    {"latitude": ["array-like", Real], "azimuth": ["array-like", Real]},
    prefer_skip_nested_validation=True,
)
def earth_rate(latitude, azimuth=0.0):
    """Earth-rate component sensed by a level gyro: Ω_e·cos(latitude)·cos(azimuth).

    The reference input of a static thermal test: a gyro whose sensitive axis is horizontal
    and points ``azimuth`` degrees east of true north senses the horizontal (north) component
    of the Earth's rotation, projected on its axis. Ω_e is :data:`EARTH_ROTATION_RATE`
    (15.041067 deg/h, sidereal).

    Parameters
    ----------
    latitude : float or array-like
        Geodetic latitude, degrees, in [-90, 90].
    azimuth : float or array-like, default=0.0
        Azimuth of the sensitive axis from true north, degrees. Broadcast against
        ``latitude``.

    Returns
    -------
    rate : float or ndarray
        Earth-rate component, deg/h (a float when both inputs are scalars).

    Examples
    --------
    >>> from sklearn_ifog.metrics import earth_rate
    >>> round(earth_rate(0.0), 6)
    15.041067
    >>> earth_rate(60.0, [0.0, 90.0, 180.0]).round(4)
    array([ 7.5205,  0.    , -7.5205])
    """
    latitude_array = _finite_float_array(latitude, "latitude")
    azimuth_array = _finite_float_array(azimuth, "azimuth")
    if np.any(np.abs(latitude_array) > 90.0):
        bad = float(latitude_array[np.abs(latitude_array) > 90.0].flat[0])
        raise ValueError(f"latitude must be in [-90, 90] degrees, got {bad!r}.")
    rate = (
        EARTH_ROTATION_RATE
        * np.cos(np.deg2rad(latitude_array))
        * np.cos(np.deg2rad(azimuth_array))
    )
    if rate.ndim == 0:
        return float(rate)
    return rate


def _finite_float_array(value, name):
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a number or an array of numbers, got {value!r}.") from exc
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite (no NaN or inf).")
    return array


def _check_rate(rate, name="rate", min_samples=1):
    """Validate a rate series: 1-D (one series) or 2-D (one series per column), finite."""
    rate = check_array(
        rate,
        ensure_2d=False,
        dtype=np.float64,
        ensure_all_finite=True,
        input_name=name,
        ensure_min_samples=min_samples,
    )
    if rate.ndim not in (1, 2):
        raise ValueError(
            f"{name} must be 1-D (one series) or 2-D (one series per column), "
            f"got an array with shape {rate.shape}."
        )
    if rate.shape[0] < min_samples:
        raise ValueError(f"{name} needs at least {min_samples} samples, got {rate.shape[0]}.")
    return rate


def _averaging_factors(taus, n_samples, sample_period, overlapping):
    """Averaging factors m (tau = m * sample_period) and their number of Allan terms."""

    def n_terms(m):
        # Number of second differences of the (n_samples + 1)-long integrated series, as in
        # allantools' calc_adev_phase: len(phase[2m::stride]).
        stride = 1 if overlapping else m
        return np.maximum(-(-(n_samples + 1 - 2 * m) // stride), 0)

    if isinstance(taus, str):
        # allantools.tau_generator on the (n_samples + 1)-long phase series, keeping, like its
        # remove_small_ns, only factors with at least two terms.
        n_phase = n_samples + 1
        if taus == "octave":
            factors = 2 ** np.arange(int(np.floor(np.log2(n_phase))) + 1)
        else:  # "decade": 1, 2, 4, 10, 20, 40, ...
            decades = 10 ** np.arange(int(np.floor(np.log10(n_phase))) + 1)
            factors = np.unique(np.outer(decades, [1, 2, 4]).ravel())
        factors = factors[(factors < n_phase) & (n_terms(factors) > 1)].astype(np.int64)
        if factors.size == 0:
            raise ValueError(
                f"rate has {n_samples} samples: too few for an Allan deviation "
                "(at least 3 are needed)."
            )
        return factors, n_terms(factors)

    requested = check_array(
        taus, ensure_2d=False, dtype=np.float64, input_name="taus", ensure_all_finite=True
    )
    if requested.ndim != 1:
        raise ValueError(f"taus must be 1-D, got an array with shape {requested.shape}.")
    factors = np.rint(requested / sample_period).astype(np.int64)
    too_short = factors < 1
    if np.any(too_short):
        raise ValueError(
            f"taus must be at least half the sample_period ({sample_period} s); got "
            f"{float(requested[too_short][0])!r} s."
        )
    counts = n_terms(factors)
    too_long = counts < 2
    if np.any(too_long):
        largest = (n_samples - 1) // 2 if overlapping else n_samples // 3
        raise ValueError(
            f"tau={float(requested[too_long][0])!r} s is too long for {n_samples} samples: the "
            f"{'overlapping ' if overlapping else ''}Allan deviation needs at least two terms, "
            f"so tau <= {largest * sample_period!r} s."
        )
    return factors, counts


@validate_params(
    {
        "rate": ["array-like"],
        "sample_period": [Interval(Real, 0, None, closed="neither")],
        "taus": [StrOptions({"octave", "decade"}), "array-like"],
        "overlapping": ["boolean"],
        "return_error": ["boolean"],
    },
    prefer_skip_nested_validation=True,
)
def allan_deviation(
    rate, *, sample_period=1.0, taus="octave", overlapping=True, return_error=False
):
    """Allan deviation of a gyro rate series (overlapping by default).

    For the averaging time τ = m·τ0 (τ0 the sample period), with ``S`` the cumulative sum of
    the rate (less its mean) and ``S[0] = 0``::

        sigma^2(tau) = 1 / (2 m^2 n) * sum_k (S[k + 2m] - 2 S[k + m] + S[k]) ** 2

    over the ``n`` available second differences: every k (overlapping, NIST SP 1065 Eq. 11)
    or every m-th (non-overlapping, Eq. 7). This is the Allan deviation of IEEE Std 952
    (Annex C) and equals, to rounding, ``allantools.oadev(rate, rate=1 / sample_period,
    data_type="freq", taus=taus)`` (``allantools.adev`` when ``overlapping=False``),
    including its choice of taus for ``"octave"`` and ``"decade"``. Computed from cumulative
    sums: O(n_samples) per tau.

    Parameters
    ----------
    rate : array-like of shape (n_samples,) or (n_samples, n_series)
        Rate, deg/h, sampled every ``sample_period`` seconds without gaps. A 2-D array holds
        one series per column (e.g. three gyro axes); no NaN or inf.
    sample_period : float, default=1.0
        Time between samples, seconds.
    taus : {"octave", "decade"} or array-like of shape (n_taus,), default="octave"
        Averaging times. ``"octave"``: τ0·(1, 2, 4, 8, ...); ``"decade"``: τ0·(1, 2, 4, 10,
        20, 40, ...); in both cases up to the longest τ with at least two terms. An array
        gives times in seconds, each rounded to the nearest multiple of ``sample_period``
        (the returned ``taus`` are the rounded values, in the given order); a τ that rounds
        to zero or is too long for the series raises a ValueError.
    overlapping : bool, default=True
        Overlapping (all k) or non-overlapping (k a multiple of m) estimator.
    return_error : bool, default=False
        Also return the 1-sigma uncertainty of each deviation and its number of terms.

    Returns
    -------
    taus : ndarray of shape (n_taus,)
        Averaging times, seconds.
    adev : ndarray of shape (n_taus,) or (n_taus, n_series)
        Allan deviation, deg/h.
    adev_error : ndarray, same shape as ``adev``
        Only when ``return_error=True``: IEEE Std 952 Annex C's 1-sigma uncertainty,
        ``adev / sqrt(2 * (n_samples // m - 1))`` (from the number of independent clusters;
        infinite when there is a single cluster).
    n_terms : ndarray of shape (n_taus,)
        Only when ``return_error=True``: number of second differences averaged per tau.

    See Also
    --------
    angle_random_walk : Read the angle random walk from the curve.
    bias_instability : Read the bias instability from the curve.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.metrics import allan_deviation
    >>> rng = np.random.default_rng(0)
    >>> rate = 0.1 * rng.standard_normal(4096)  # white noise, deg/h, 1 s samples
    >>> taus, adev = allan_deviation(rate)
    >>> taus[:4]
    array([1., 2., 4., 8.])
    >>> ratios = adev * np.sqrt(taus) / 0.1  # close to 1 for white noise
    >>> bool(np.all(np.abs(ratios[:6] - 1.0) < 0.1))
    True
    """
    rate = _check_rate(rate, min_samples=1)
    one_series = rate.ndim == 1
    series = rate.reshape(rate.shape[0], -1)
    n_samples = series.shape[0]
    factors, counts = _averaging_factors(taus, n_samples, sample_period, overlapping)

    # Removing the mean before summing keeps the cumulative sum small (as allantools does);
    # it cancels exactly in every second difference.
    cumulative = np.zeros((n_samples + 1, series.shape[1]))
    np.cumsum(series - series.mean(axis=0), axis=0, out=cumulative[1:])

    adev = np.empty((factors.size, series.shape[1]))
    for i, (m, n) in enumerate(zip(factors.tolist(), counts.tolist(), strict=True)):
        stride = 1 if overlapping else m
        second_difference = (
            cumulative[2 * m :: stride][:n]
            - 2.0 * cumulative[m::stride][:n]
            + cumulative[::stride][:n]
        )
        adev[i] = np.sqrt(np.einsum("ij,ij->j", second_difference, second_difference) / (2 * n))
        adev[i] /= m
    if one_series:
        adev = adev[:, 0]
    tau_values = factors * float(sample_period)
    if not return_error:
        return tau_values, adev
    clusters = n_samples // factors - 1
    with np.errstate(divide="ignore"):
        relative_error = 1.0 / np.sqrt(2.0 * clusters)
    relative_error = relative_error.reshape((-1,) + (1,) * (adev.ndim - 1))
    return tau_values, adev, adev * relative_error, counts


def _check_allan_curve(taus, adev):
    taus = check_array(taus, ensure_2d=False, dtype=np.float64, input_name="taus")
    adev = check_array(adev, ensure_2d=False, dtype=np.float64, input_name="adev")
    if taus.ndim != 1:
        raise ValueError(f"taus must be 1-D, got shape {taus.shape}.")
    if adev.shape[0] != taus.shape[0] or adev.ndim > 2:
        raise ValueError(
            f"adev must have shape (n_taus,) or (n_taus, n_series) with n_taus={taus.shape[0]} "
            f"(the length of taus), got shape {adev.shape}."
        )
    if taus.shape[0] < 2:
        raise ValueError(f"An Allan curve of at least 2 points is needed, got {taus.shape[0]}.")
    if np.any(taus <= 0) or np.any(np.diff(taus) <= 0):
        raise ValueError("taus must be positive and strictly increasing.")
    if np.any(adev <= 0):
        raise ValueError("adev must be positive (a constant series has no Allan curve).")
    return taus, adev


@validate_params(
    {"taus": ["array-like"], "adev": ["array-like"]},
    prefer_skip_nested_validation=True,
)
def angle_random_walk(taus, adev):
    """Angle random walk (ARW) read from an Allan curve, deg/√h.

    White rate noise gives σ(τ) = N / sqrt(τ) (slope −1/2 in log-log). Following IEEE Std
    952 Annex C, a line of slope −1/2 is laid on the curve where its local slope is closest
    to −1/2 (least squares through the two ends of that segment) and read at τ = 1 h. For
    rates in deg/h and τ in seconds that reading is ``σ(τ)·sqrt(τ) / 60`` deg/√h.

    Parameters
    ----------
    taus : array-like of shape (n_taus,)
        Averaging times, seconds, strictly increasing (as returned by
        :func:`allan_deviation`).
    adev : array-like of shape (n_taus,) or (n_taus, n_series)
        Allan deviation, deg/h, positive.

    Returns
    -------
    arw : float or ndarray of shape (n_series,)
        Angle random walk, deg/√h.

    See Also
    --------
    allan_deviation : Compute the curve.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.metrics import angle_random_walk
    >>> taus = np.array([1.0, 2.0, 4.0, 8.0])
    >>> adev = 0.6 / np.sqrt(taus)  # pure white noise: 0.6 deg/h at 1 s
    >>> round(angle_random_walk(taus, adev), 6)  # 0.6 / 60
    0.01
    """
    taus, adev = _check_allan_curve(taus, adev)
    curve = adev.reshape(adev.shape[0], -1)
    log_tau = np.log10(taus)[:, np.newaxis]
    log_adev = np.log10(curve)
    slopes = np.diff(log_adev, axis=0) / np.diff(log_tau, axis=0)
    segment = np.argmin(np.abs(slopes + 0.5), axis=0)
    # log10(sigma * sqrt(tau)) at both ends of the chosen segment, averaged.
    intercept = log_adev + 0.5 * log_tau
    columns = np.arange(curve.shape[1])
    level = 0.5 * (intercept[segment, columns] + intercept[segment + 1, columns])
    arw = 10.0**level / _SECONDS_PER_SQRT_HOUR
    return float(arw[0]) if adev.ndim == 1 else arw


@validate_params(
    {"taus": ["array-like"], "adev": ["array-like"]},
    prefer_skip_nested_validation=True,
)
def bias_instability(taus, adev):
    """Bias instability read from an Allan curve, deg/h.

    Flicker rate noise gives a flat Allan curve at σ = B·sqrt(2·ln 2 / π) ≈ 0.664·B (IEEE
    Std 952 Annex C). B is read at the curve's minimum, the usual practice: an upper bound
    when other noises still add at that τ.

    Parameters
    ----------
    taus : array-like of shape (n_taus,)
        Averaging times, seconds, strictly increasing (as returned by
        :func:`allan_deviation`).
    adev : array-like of shape (n_taus,) or (n_taus, n_series)
        Allan deviation, deg/h, positive.

    Returns
    -------
    bias_instability : float or ndarray of shape (n_series,)
        Bias instability B, deg/h.

    See Also
    --------
    allan_deviation : Compute the curve.

    Examples
    --------
    >>> from sklearn_ifog.metrics import bias_instability
    >>> round(bias_instability([1.0, 10.0, 100.0, 1000.0], [0.05, 0.02, 0.00664, 0.01]), 4)
    0.01
    """
    _, adev = _check_allan_curve(taus, adev)
    instability = adev.min(axis=0) / _BIAS_INSTABILITY_FACTOR
    return float(instability) if adev.ndim == 1 else instability


@validate_params(
    {
        "rate": ["array-like"],
        "sample_period": [Interval(Real, 0, None, closed="neither")],
        "window": [Interval(Real, 0, None, closed="neither")],
    },
    prefer_skip_nested_validation=True,
)
def bias_stability(rate, *, sample_period=1.0, window=100.0):
    """Bias stability: standard deviation of the rate averaged over fixed windows.

    IEEE Std 952 practice: average the rate over consecutive, non-overlapping windows of
    ``window`` seconds (100 s is customary; quote it with the result), then take the sample
    standard deviation (ddof=1) of those averages. Trailing samples that do not fill a whole
    window are not used (at most ``window`` seconds at the end of the series).

    Parameters
    ----------
    rate : array-like of shape (n_samples,) or (n_samples, n_series)
        Rate, deg/h, sampled every ``sample_period`` seconds without gaps; a 2-D array holds
        one series per column. No NaN or inf.
    sample_period : float, default=1.0
        Time between samples, seconds.
    window : float, default=100.0
        Averaging time, seconds: a whole multiple of ``sample_period``.

    Returns
    -------
    stability : float or ndarray of shape (n_series,)
        Bias stability (1 sigma), deg/h.

    Examples
    --------
    >>> from sklearn_ifog.metrics import bias_stability
    >>> rate = [1.0, 3.0, 2.0, 2.0, 4.0, 6.0]  # window means: 2, 2, 5
    >>> round(bias_stability(rate, sample_period=0.5, window=1.0), 6)
    1.732051
    """
    rate = _check_rate(rate, min_samples=1)
    ratio = window / sample_period
    window_samples = round(ratio)
    if window_samples < 1 or abs(window_samples - ratio) > 1e-9 * max(ratio, 1.0):
        raise ValueError(
            f"window ({window!r} s) must be a whole multiple of sample_period "
            f"({sample_period!r} s)."
        )
    n_samples = rate.shape[0]
    n_windows = n_samples // window_samples
    if n_windows < 2:
        raise ValueError(
            f"rate has {n_samples} samples ({n_samples * sample_period!r} s): bias_stability "
            f"needs at least two full windows of {window!r} s ({2 * window_samples} samples)."
        )
    used = rate[: n_windows * window_samples]
    window_means = used.reshape((n_windows, window_samples, *rate.shape[1:])).mean(axis=1)
    stability = window_means.std(axis=0, ddof=1)
    return float(stability) if rate.ndim == 1 else stability


# -- prediction intervals ----------------------------------------------------------------------


def _check_bounds(y_true, y_interval):
    """y_true as a float vector and the bounds as an (n_samples, 2) float array."""
    y_true = np.asarray(y_true, dtype=float)
    y_interval = np.asarray(y_interval, dtype=float)
    if y_true.ndim != 1:
        raise ValueError(f"y_true must be 1-D, got shape {y_true.shape}.")
    if y_interval.ndim != 2 or y_interval.shape[1] != 2:
        raise ValueError(
            "y_interval must have shape (n_samples, 2) (lower, upper bound), got "
            f"{y_interval.shape}."
        )
    if y_interval.shape[0] != y_true.shape[0]:
        raise ValueError(
            f"y_interval has {y_interval.shape[0]} rows, y_true has {y_true.shape[0]}."
        )
    if y_true.shape[0] == 0:
        raise ValueError("y_true is empty; an interval metric needs at least one sample.")
    return y_true, y_interval


@validate_params(
    {"y_true": ["array-like"], "y_interval": ["array-like"]},
    prefer_skip_nested_validation=True,
)
def interval_coverage(y_true, y_interval):
    """Fraction of the samples whose true value lies inside its interval (bounds included).

    Parameters
    ----------
    y_true : array-like of shape (n_samples,)
        True values.
    y_interval : array-like of shape (n_samples, 2)
        Lower and upper bound of each sample's interval, as
        :meth:`~sklearn_ifog.ConformalRegressor.predict_interval` returns them.

    Returns
    -------
    coverage : float
        In [0, 1].

    See Also
    --------
    mean_interval_width : How wide the intervals are.
    interval_score : Width and misses in one number.

    Examples
    --------
    >>> from sklearn_ifog.metrics import interval_coverage
    >>> interval_coverage([0.0, 1.0, 5.0], [[-1, 1], [0, 2], [0, 2]])
    0.666...
    """
    y_true, y_interval = _check_bounds(y_true, y_interval)
    inside = (y_interval[:, 0] <= y_true) & (y_true <= y_interval[:, 1])
    return float(np.mean(inside))


@validate_params({"y_interval": ["array-like"]}, prefer_skip_nested_validation=True)
def mean_interval_width(y_interval):
    """Mean width ``upper - lower`` of the intervals.

    Parameters
    ----------
    y_interval : array-like of shape (n_samples, 2)
        Lower and upper bound of each sample's interval.

    Returns
    -------
    width : float
        In the unit of the target (deg/h for a drift).

    Examples
    --------
    >>> from sklearn_ifog.metrics import mean_interval_width
    >>> mean_interval_width([[-1.0, 1.0], [0.0, 4.0]])
    3.0
    """
    y_interval = np.asarray(y_interval, dtype=float)
    _check_bounds(np.zeros(y_interval.shape[0] if y_interval.ndim else 0), y_interval)
    return float(np.mean(y_interval[:, 1] - y_interval[:, 0]))


@validate_params(
    {
        "y_true": ["array-like"],
        "y_interval": ["array-like"],
        "coverage": [Interval(Real, 0, 1, closed="neither")],
    },
    prefer_skip_nested_validation=True,
)
def interval_score(y_true, y_interval, *, coverage=0.9):
    """Mean interval (Winkler) score: the width plus a penalty for every miss; lower is better.

    For nominal coverage ``1 - alpha`` and bounds ``[l, u]`` (Gneiting & Raftery, 2007,
    Eq. 43; Winkler, 1972)::

        S = (u - l) + (2 / alpha) * (l - y) * [y < l] + (2 / alpha) * (y - u) * [y > u]

    A proper scoring rule: in expectation it is smallest for the true ``alpha / 2`` and
    ``1 - alpha / 2`` quantiles, so it rewards a band that is both narrow and right.

    Parameters
    ----------
    y_true : array-like of shape (n_samples,)
        True values.
    y_interval : array-like of shape (n_samples, 2)
        Lower and upper bound of each sample's interval.
    coverage : float, default=0.9
        Nominal coverage ``1 - alpha`` of the intervals, in (0, 1).

    Returns
    -------
    score : float
        Mean score, in the unit of the target.

    References
    ----------
    T. Gneiting, A. E. Raftery, "Strictly proper scoring rules, prediction, and estimation",
    JASA 102(477), 2007.

    Examples
    --------
    >>> from sklearn_ifog.metrics import interval_score
    >>> interval_score([0.0, 3.0], [[-1.0, 1.0], [0.0, 2.0]], coverage=0.8)
    7.0
    """
    y_true, y_interval = _check_bounds(y_true, y_interval)
    alpha = 1.0 - coverage
    lower, upper = y_interval[:, 0], y_interval[:, 1]
    penalty = (2.0 / alpha) * (np.maximum(lower - y_true, 0.0) + np.maximum(y_true - upper, 0.0))
    return float(np.mean(upper - lower + penalty))


def interval_coverage_scorer(estimator, X, y_true):
    """The coverage of ``estimator.predict_interval(X)``: a scorer, to *report* coverage.

    Greater is closer to 1; do not select models with it alone (an infinitely wide band
    maximises it): use ``"neg_interval_score"``.

    Parameters
    ----------
    estimator : estimator with ``predict_interval``
        E.g. a fitted :class:`~sklearn_ifog.ConformalRegressor`.
    X : array-like
        Samples.
    y_true : array-like of shape (n_samples,)
        True values.

    Returns
    -------
    coverage : float
        ``interval_coverage(y_true, estimator.predict_interval(X))``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import ConformalRegressor
    >>> from sklearn_ifog.metrics import get_scorer
    >>> X = np.arange(40.0)[:, None]
    >>> y = X[:, 0] + np.tile([0.5, -0.5], 20)
    >>> model = ConformalRegressor(LinearRegression()).fit(X, y, groups=X[:, 0] // 10)
    >>> 0.0 <= get_scorer("interval_coverage")(model, X, y) <= 1.0
    True
    """
    return interval_coverage(y_true, estimator.predict_interval(X))


def neg_mean_interval_width_scorer(estimator, X, y_true):
    """Minus the mean width of ``estimator.predict_interval(X)``: a scorer.

    Parameters
    ----------
    estimator : estimator with ``predict_interval``
        E.g. a fitted :class:`~sklearn_ifog.ConformalRegressor`.
    X : array-like
        Samples.
    y_true : array-like of shape (n_samples,)
        True values (unused; scorers take them).

    Returns
    -------
    score : float
        ``-mean_interval_width(estimator.predict_interval(X))``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import ConformalRegressor
    >>> from sklearn_ifog.metrics import get_scorer
    >>> X = np.arange(40.0)[:, None]
    >>> y = X[:, 0] + np.tile([0.5, -0.5], 20)
    >>> model = ConformalRegressor(LinearRegression()).fit(X, y, groups=X[:, 0] // 10)
    >>> bool(get_scorer("neg_mean_interval_width")(model, X, y) < 0)
    True
    """
    return -mean_interval_width(estimator.predict_interval(X))


def neg_interval_score_scorer(estimator, X, y_true):
    """Minus the interval (Winkler) score of ``estimator.predict_interval(X)``.

    The nominal coverage is the estimator's ``coverage`` parameter (0.9 if it has none).

    Parameters
    ----------
    estimator : estimator with ``predict_interval``
        E.g. a fitted :class:`~sklearn_ifog.ConformalRegressor`.
    X : array-like
        Samples.
    y_true : array-like of shape (n_samples,)
        True values.

    Returns
    -------
    score : float
        ``-interval_score(y_true, estimator.predict_interval(X), coverage=...)``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import ConformalRegressor
    >>> from sklearn_ifog.metrics import get_scorer
    >>> X = np.arange(40.0)[:, None]
    >>> y = X[:, 0] + np.tile([0.5, -0.5], 20)
    >>> model = ConformalRegressor(LinearRegression()).fit(X, y, groups=X[:, 0] // 10)
    >>> bool(get_scorer("neg_interval_score")(model, X, y) < 0)
    True
    """
    coverage = getattr(estimator, "coverage", 0.9)
    return -interval_score(y_true, estimator.predict_interval(X), coverage=coverage)


#: Scorer: minus the mean squared deviation (greater is better, as model selection expects).
#: For a drift regressor fitted on the measured drift (``rate - reference``) it equals minus
#: the MSD of the compensated rate from the reference (see :func:`mean_squared_deviation`).
neg_mean_squared_deviation_scorer = make_scorer(mean_squared_deviation, greater_is_better=False)
_SCORERS = {
    "neg_mean_squared_deviation": neg_mean_squared_deviation_scorer,
    "interval_coverage": interval_coverage_scorer,
    "neg_mean_interval_width": neg_mean_interval_width_scorer,
    "neg_interval_score": neg_interval_score_scorer,
}


@validate_params(
    {"scoring": [str, callable, None]},
    prefer_skip_nested_validation=True,
)
def get_scorer(scoring):
    """Get a scorer by name: the package's scorers, then scikit-learn's.

    Parameters
    ----------
    scoring : str, callable or None
        ``"neg_mean_squared_deviation"``, ``"interval_coverage"``,
        ``"neg_mean_interval_width"``, ``"neg_interval_score"`` (the last three call the
        estimator's ``predict_interval``), any name of
        :func:`sklearn.metrics.get_scorer_names`, or a scorer (returned as is).

    Returns
    -------
    scorer : callable
        A scorer ``scorer(estimator, X, y)`` (a copy for names).

    See Also
    --------
    get_scorer_names : The accepted names.

    Examples
    --------
    >>> from sklearn_ifog.metrics import get_scorer
    >>> get_scorer("neg_mean_squared_deviation")
    make_scorer(mean_squared_deviation, greater_is_better=False, response_method='predict')
    """
    if isinstance(scoring, str) and scoring in _SCORERS:
        return copy.deepcopy(_SCORERS[scoring])
    return _sklearn_get_scorer(scoring)


def get_scorer_names():
    """Names accepted by :func:`get_scorer`.

    Returns
    -------
    names : list of str
        The package's scorer names followed by scikit-learn's, sorted within each group.

    Examples
    --------
    >>> from sklearn_ifog.metrics import get_scorer_names
    >>> get_scorer_names()[:2]
    ['interval_coverage', 'neg_interval_score']
    """
    return sorted(_SCORERS) + [
        name for name in _sklearn_get_scorer_names() if name not in _SCORERS
    ]


# -- per-run table ---------------------------------------------------------------------------


def _safe_bias_stability(values, period, uniform, window):
    """Bias stability, or NaN where the run is too short or not uniformly sampled."""
    if not uniform or window < period or values.size * period < 2 * window:
        return np.nan
    window = round(window / period) * period
    return bias_stability(values, sample_period=period, window=window)


def per_run_metrics(
    *, rate, drift, reference, temperature, time=None, run=None, bias_window=100.0
):
    """Measure a compensation run by run: MSD and bias stability, before and after.

    For every run (in order of first appearance): its number of samples, duration,
    temperature range, the MSD of the raw output ``rate`` and of the compensated output
    ``rate - drift`` from the reference (the reference paper's Eq. 24), their ratio, and
    the bias stability of the error before and after (:func:`bias_stability` of
    ``bias_window``-second averages; NaN where the run is shorter than two windows or not
    uniformly sampled). With ``run``, a last row ``"(all runs)"`` measures all rows
    together (its bias stabilities are NaN).

    Parameters
    ----------
    rate : array-like of shape (n_samples,)
        Gyro output, deg/h.
    drift : array-like of shape (n_samples,)
        Predicted drift, deg/h; the compensated output is ``rate - drift``.
    reference : float or array-like of shape (n_samples,)
        True input rate, deg/h.
    temperature : array-like of shape (n_samples,)
        Coil temperature, deg C.
    time : array-like of shape (n_samples,), default=None
        Time, seconds; None numbers the samples (an assumed 1 s period).
    run : array-like of shape (n_samples,), default=None
        Run label of each row; None means one run. Rows of a run are in time order; runs
        may be interleaved.
    bias_window : float, default=100.0
        Averaging window of the bias stability, seconds.

    Returns
    -------
    table : pandas.DataFrame
        Indexed by ``run``, with columns ``samples``, ``hours``, ``T_min``, ``T_max``,
        ``msd_before``, ``msd_after``, ``reduction``, ``bias_stab_before``,
        ``bias_stab_after``. Without ``run``, one row ``"(all runs)"``.

    See Also
    --------
    mean_squared_deviation : The MSD of one output.
    bias_stability : The bias stability of one run.
    sklearn_ifog.report.compensation_report : This table, figures and a report.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.metrics import per_run_metrics
    >>> time = np.tile(np.arange(0.0, 600.0, 1.0), 2)
    >>> run = np.repeat(["a", "b"], 600)
    >>> temperature = 20.0 + np.where(run == "a", 0.01, -0.01) * time
    >>> drift = 0.1 * (temperature - 20.0)
    >>> rate = 15.0 + drift + np.where(run == "a", 0.001, -0.001)
    >>> table = per_run_metrics(
    ...     rate=rate, drift=drift, reference=15.0, temperature=temperature, time=time, run=run
    ... )
    >>> table[["samples", "msd_after"]]
                samples  msd_after
    run
    a               600   1.00e-06
    b               600   1.00e-06
    (all runs)     1200   1.00e-06
    >>> bool((table["reduction"] > 1000).all())
    True
    """
    import pandas as pd

    rate, drift, reference, temperature, time_values = compensation_arrays(
        rate, drift, reference, temperature, time
    )
    n_samples = rate.shape[0]
    compensated = rate - drift
    rows = []
    for label, rows_of_run in _table.run_segments(run, n_samples):
        period, uniform = sample_period(time_values[rows_of_run])
        error_before = rate[rows_of_run] - reference[rows_of_run]
        error_after = compensated[rows_of_run] - reference[rows_of_run]
        msd_before = float(mean_squared_deviation(reference[rows_of_run], rate[rows_of_run]))
        msd_after = float(mean_squared_deviation(reference[rows_of_run], compensated[rows_of_run]))
        rows.append(
            {
                "run": ALL_RUNS if label is None else label,
                "samples": int(rows_of_run.size),
                "hours": float(np.ptp(time_values[rows_of_run]) / 3600.0),
                "T_min": float(temperature[rows_of_run].min()),
                "T_max": float(temperature[rows_of_run].max()),
                "msd_before": msd_before,
                "msd_after": msd_after,
                "reduction": msd_before / msd_after if msd_after > 0 else np.inf,
                "bias_stab_before": _safe_bias_stability(
                    error_before, period, uniform, bias_window
                ),
                "bias_stab_after": _safe_bias_stability(error_after, period, uniform, bias_window),
            }
        )
    table = pd.DataFrame(rows).set_index("run")
    if run is not None:
        overall_before = float(mean_squared_deviation(reference, rate))
        overall_after = float(mean_squared_deviation(reference, compensated))
        table.loc[ALL_RUNS] = {
            "samples": n_samples,
            "hours": float(table["hours"].sum()),
            "T_min": float(temperature.min()),
            "T_max": float(temperature.max()),
            "msd_before": overall_before,
            "msd_after": overall_after,
            "reduction": overall_before / overall_after if overall_after > 0 else np.inf,
            "bias_stab_before": np.nan,
            "bias_stab_after": np.nan,
        }
    table["samples"] = table["samples"].astype(int)
    return table
