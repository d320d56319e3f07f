"""The fallback: what a compensation model answers where it was not calibrated.

Outside its calibration domain (:mod:`sklearn_ifog.domain`) a flexible model's
extrapolation is a guess; the fallback is the conservative model the ``"blend"`` policy
(:mod:`sklearn_ifog.policy`) hands those rows to, chosen per output by held-out evidence
from the calibration itself: a plane in T and dT where held-out runs repeat it
(:func:`held_out_runs`), else a line in T where its slope extrapolates to the calibrated
extremes (:func:`extremes_held_out`), else the calibration's mean drift; beyond a
calibrated extreme it did not extrapolate to, the plane is held at its value at the edge
(the firmware convention). :func:`fit_fallback` makes the choice; :class:`Fallback` holds
the result and predicts.
"""

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from sklearn_ifog._statistics import within_one_standard_error
from sklearn_ifog._tuning import CARRIED_SCALE, REPEATED_RATIO

__all__ = [
    "Fallback",
    "extremes_held_out",
    "fallback_name",
    "fit_fallback",
    "held_out_runs",
]

# The fallback's slope is tested by extrapolation: the rows within this share of the
# temperature span of the coldest and of the warmest are held out in turn.
_EXTRAPOLATION_FRACTION = 0.2
_MIN_FALLBACK_ROWS = 10
# A slope is real when, at each calibrated extreme, the extrapolated line leaves at most this
# share of the constant's squared error: a thermal slope explains most of the variation at
# the calibration's own extremes, while a slope fitted to noise or to a bias that drifted with
# time (and so with the temperature of a monotone run) explains little of it and
# extrapolates worse than a constant. On the shipped recording the x and y axes' ratios are
# 0.001-0.06 and the z axis's (no thermal drift) 0.47-5.8, for every half of the recording.
_REAL_SLOPE_RATIO = 0.25


class Fallback(NamedTuple):
    """The conservative model used outside the domain: a line in T (and rate), or a constant.

    For output ``k`` and a row with temperature ``t`` (column ``column``) and rate ``r``
    (column ``rate_column``)::

        intercept[k] + slope[k] * t
            - slope[k] * hold_below[k] * min(t - low, 0)
            - slope[k] * hold_above[k] * max(t - high, 0)
            + rate_slope[k] * clip(r, -rate_bound, rate_bound)

    that is a line in T that continues beyond the calibrated temperatures ``[low, high]``
    only on the side(s) where its slope extrapolated there (else it is held flat from the
    edge, the firmware convention), plus a rate term bounded to the calibrated rates' size
    (:func:`fit_fallback`). ``slope`` is 0 for the outputs whose slope did not extrapolate
    better than a constant; ``rate_slope`` is 0 unless several calibration runs repeat the
    relation. A fallback of three values ``(intercept, slope, column)`` is a plain line in T.

    Parameters
    ----------
    intercept : ndarray of shape (n_outputs,)
        Drift at T = 0 and zero rate (the mean drift where the slopes are 0).
    slope : ndarray of shape (n_outputs,)
        Drift per degree.
    column : int or None
        Column of the features that holds T (None: no temperature column, a constant).
    rate_slope : ndarray of shape (n_outputs,) or None, default=None
        Drift per unit of the rate feature (None: no rate term).
    rate_column : int or None, default=None
        Column of the features that holds the rate dT.
    rate_bound : float, default=0.0
        Largest rate magnitude the calibration showed; the rate term is clipped to it.
    low, high : float, default=-inf, inf
        The calibrated temperatures.
    hold_below, hold_above : ndarray of shape (n_outputs,) of bool or None, default=None
        Whether the line is held flat below ``low`` / above ``high`` (None: never).

    Examples
    --------
    >>> import numpy as np
    >>> fallback = Fallback(np.array([1.0]), np.array([0.5]), 0)
    >>> fallback.predict(np.array([[10.0, 3.0]])).tolist()
    [[6.0]]
    >>> held = fallback._replace(low=20.0, high=40.0, hold_below=np.array([True]))
    >>> held.predict(np.array([[10.0, 3.0], [30.0, 3.0], [50.0, 3.0]])).ravel().tolist()
    [11.0, 16.0, 26.0]
    """

    intercept: np.ndarray
    slope: np.ndarray
    column: int | None
    rate_slope: np.ndarray | None = None
    rate_column: int | None = None
    rate_bound: float = 0.0
    low: float = -np.inf
    high: float = np.inf
    hold_below: np.ndarray | None = None
    hold_above: np.ndarray | None = None

    def predict(self, features):
        """Fallback predictions.

        Parameters
        ----------
        features : array-like of shape (n_samples, n_features)
            Feature rows (T in column ``column``, the rate in ``rate_column``).

        Returns
        -------
        prediction : ndarray of shape (n_samples, n_outputs)
        """
        features = np.asarray(features, dtype=np.float64)
        if self.column is None:
            return np.broadcast_to(self.intercept, (features.shape[0], self.intercept.size))
        temperature = features[:, [self.column]]
        prediction = self.intercept + temperature * self.slope
        if self.hold_below is not None and np.any(self.hold_below):
            below = np.minimum(temperature - self.low, 0.0)
            prediction = prediction - below * (self.slope * self.hold_below)
        if self.hold_above is not None and np.any(self.hold_above):
            above = np.maximum(temperature - self.high, 0.0)
            prediction = prediction - above * (self.slope * self.hold_above)
        if self.rate_column is not None and self.rate_slope is not None:
            rate = np.clip(features[:, [self.rate_column]], -self.rate_bound, self.rate_bound)
            prediction = prediction + rate * self.rate_slope
        return prediction


def _line(temperature, Y):
    """Least-squares (intercept, slope) of each column of ``Y`` on ``temperature``."""
    t_mean = temperature.mean()
    centred = temperature - t_mean
    denominator = centred @ centred
    slope = centred @ (Y - Y.mean(axis=0)) / denominator if denominator > 0 else 0 * Y[0]
    return Y.mean(axis=0) - slope * t_mean, slope


def _plane(temperature, rate, Y):
    """Least-squares (intercept, slope, rate slope) of each column of ``Y`` on T and dT.

    Centred and scaled columns keep the solve well conditioned; a rate that does not vary
    gets a rate slope of 0 (the minimum-norm solution).
    """
    columns = np.column_stack([temperature, rate])
    centre = columns.mean(axis=0)
    scale = columns.std(axis=0)
    scale[scale == 0] = 1.0
    coef = np.linalg.lstsq((columns - centre) / scale, Y - Y.mean(axis=0), rcond=None)[0]
    coef /= scale[:, None]
    return Y.mean(axis=0) - centre @ coef, coef[0], coef[1]


def extremes_held_out(temperature, Y, rate=None):
    """Squared errors of a constant and a line in T extrapolated to the calibrated extremes.

    The rows within a fifth of the temperature span of the coldest, then of the warmest,
    are held out in turn (at least the 10 coldest or warmest, with every row at their
    temperatures); a constant (the mean) and a line in T (with ``rate``: a plane in T and
    dT) are fitted on the other rows and evaluated on the held-out ones. This is the
    evidence :func:`fit_fallback` decides the slope on. Every held-out row lies beyond every
    kept one, so the test is an extrapolation even where the calibration soaks at an extreme
    (a fifth of the rows by rank would then be part of the soak, at the temperature of kept
    rows: an interpolation).

    Parameters
    ----------
    temperature : array-like of shape (n_samples,)
        T of the calibration rows.
    Y : array-like of shape (n_samples, n_outputs)
        Their targets.
    rate : array-like of shape (n_samples,), default=None
        Their rate dT, fitted beside T when given.

    Returns
    -------
    losses : tuple of 2 ndarrays of shape (2, n_held, n_outputs), or None
        ``losses[end][model]``: the squared errors at the cold (``end=0``) and the warm
        (``end=1``) extreme of the constant (``model=0``) and of the line (``model=1``);
        ``n_held`` differs between the ends. None when fewer than 48 rows, a single
        temperature, or fewer than 10 rows kept at an end leave nothing to test.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 30.0, 100)
    >>> losses = extremes_held_out(t, (2.0 * t)[:, None])
    >>> [end.shape for end in losses]
    [(2, 20, 1), (2, 20, 1)]
    >>> bool(max(end[1].max() for end in losses) < 1e-20)  # an exact line extrapolates exactly
    True
    """
    temperature = np.asarray(temperature, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    rate = None if rate is None else np.asarray(rate, dtype=np.float64)
    n_samples = temperature.shape[0]
    span = np.ptp(temperature)
    if round(_EXTRAPOLATION_FRACTION * n_samples) < _MIN_FALLBACK_ROWS or span == 0:
        return None
    ordered = np.sort(temperature)
    cold = max(ordered[0] + _EXTRAPOLATION_FRACTION * span, ordered[_MIN_FALLBACK_ROWS - 1])
    warm = min(ordered[-1] - _EXTRAPOLATION_FRACTION * span, ordered[-_MIN_FALLBACK_ROWS])
    losses = []
    for held in (temperature <= cold, temperature >= warm):
        kept = ~held
        if kept.sum() < _MIN_FALLBACK_ROWS:
            return None
        if rate is None:
            intercept, slope = _line(temperature[kept], Y[kept])
            line = intercept + temperature[held, None] * slope
        else:
            intercept, slope, rate_slope = _plane(temperature[kept], rate[kept], Y[kept])
            line = intercept + temperature[held, None] * slope + rate[held, None] * rate_slope
        losses.append(
            np.stack([np.square(Y[held] - Y[kept].mean(axis=0)), np.square(Y[held] - line)])
        )
    return tuple(losses)


def held_out_runs(temperature, rate, Y, runs, *, return_scale=False):
    """How well a plane in T and dT carries from some calibration runs to another.

    Each run is predicted by the plane fitted on the other runs and by their mean drift; the
    result is the plane's summed squared error over the constant's, over every run. A thermal
    relation repeats from run to run (a small ratio), while a drift that moved with time
    during one run, and so with the temperature of a monotone run, does not.

    With ``return_scale``, also the factor by which the held-out runs bear out the plane:
    the least-squares ``s`` of ``y - c = s (p - c)`` over every held-out row, ``p`` the
    plane's prediction and ``c`` the constant's. Near 1 the plane's deviations from the mean
    hold on runs it did not see, in proportion, even where run-to-run noise leaves the ratio
    high; below 1 the plane overshoots them, as a slope that does not carry does.

    Parameters
    ----------
    temperature, rate : array-like of shape (n_samples,)
        T and dT of the calibration rows.
    Y : array-like of shape (n_samples, n_outputs)
        Their targets.
    runs : array-like of shape (n_samples,)
        Their recording runs.
    return_scale : bool, default=False
        Whether to return the held-out scale as well.

    Returns
    -------
    ratio : ndarray of shape (n_outputs,) or None
        None with fewer than 2 runs (nothing to carry to).
    scale : ndarray of shape (n_outputs,) or None
        With ``return_scale`` only: the held-out scale (0 where the plane predicts no
        deviation from the constant); None with fewer than 2 runs.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.tile(np.linspace(10.0, 40.0, 50), 3)
    >>> runs = np.repeat([0, 1, 2], 50)
    >>> thermal = 0.3 * t + np.random.default_rng(0).normal(scale=0.1, size=150)
    >>> held_out_runs(t, np.zeros(150), thermal[:, None], runs).round(3).tolist()
    [0.001]
    >>> held_out_runs(t, np.zeros(150), thermal[:, None], np.zeros(150)) is None
    True
    >>> ratio, scale = held_out_runs(t, np.zeros(150), thermal[:, None], runs, return_scale=True)
    >>> scale.round(2).tolist()
    [1.0]
    """
    temperature = np.asarray(temperature, dtype=np.float64)
    rate = np.asarray(rate, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    labels = np.unique(np.asarray(runs), return_inverse=True)[1].ravel()
    if labels.max(initial=0) < 1:
        return (None, None) if return_scale else None
    # Every leave-one-run-out plane from per-run sums (the totals less the held-out run's),
    # so the cost is one pass over the rows however many runs: a lot of hundreds of runs
    # would otherwise refit on nearly all rows once per run. The columns are standardised
    # once, over all rows, to keep the sums' round-off small.
    n_runs, n_outputs = labels.max() + 1, Y.shape[1]
    Z = np.column_stack([temperature, rate])
    Z = Z - Z.mean(axis=0)
    spread = Z.std(axis=0)
    Z = Z / np.where(spread > 0, spread, 1.0)
    one_hot = sp.csr_array((np.ones(labels.size), (labels, np.arange(labels.size))))
    pairs = (Z[:, :, None] * Z[:, None, :]).reshape(-1, 4)
    cross = (Z[:, :, None] * Y[:, None, :]).reshape(-1, 2 * n_outputs)
    per_run = [one_hot @ values for values in (np.ones((labels.size, 1)), Z, Y, pairs, cross)]
    count, sum_z, sum_y, sum_zz, sum_zy = (
        values.sum(axis=0) - values for values in per_run
    )  # the other runs' sums, one row per held-out run
    count = count[:, 0]
    mean_z, mean_y = sum_z / count[:, None], sum_y / count[:, None]
    gram = sum_zz.reshape(n_runs, 2, 2) - count[:, None, None] * (
        mean_z[:, :, None] * mean_z[:, None, :]
    )
    moment = sum_zy.reshape(n_runs, 2, n_outputs) - count[:, None, None] * (
        mean_z[:, :, None] * mean_y[:, None, :]
    )
    # The minimum-norm solution, as a least-squares solve gives it: a rate that does not
    # vary over the other runs gets a rate slope of 0.
    slopes = np.linalg.pinv(gram, rcond=1e-12, hermitian=True) @ moment
    intercepts = mean_y - np.einsum("rj,rjk->rk", mean_z, slopes)
    predicted = intercepts[labels] + np.einsum("nj,njk->nk", Z, slopes[labels])
    plane = np.square(Y - predicted).sum(axis=0)
    constant = np.square(Y - mean_y[labels]).sum(axis=0)
    ratio = plane / np.where(constant > 0, constant, np.inf)
    if not return_scale:
        return ratio
    deviation = predicted - mean_y[labels]
    spread = np.square(deviation).sum(axis=0)
    along = ((Y - mean_y[labels]) * deviation).sum(axis=0)
    return ratio, along / np.where(spread > 0, spread, np.inf)


def _beyond_noise(losses):
    """Whether the line's held-out loss beats the constant's by more than one standard error
    (``losses`` of shape (2, n_held, n_outputs), constant first)."""
    return np.array(
        [not within_one_standard_error(losses[:, :, k])[0] for k in range(losses.shape[2])]
    )


def fit_fallback(
    temperature,
    Y,
    column=None,
    *,
    rate=None,
    rate_column=None,
    runs=None,
    repeated_ratio=REPEATED_RATIO,
    carried_scale=CARRIED_SCALE,
):
    """Fit the fallback: a plane in T and dT where held-out runs repeat it, else a line in T
    where its slope extrapolates, else a constant (per output).

    The slope is kept for an output only when it *extrapolates* better than a constant:
    the rows within a fifth of the temperature span of the coldest and of the warmest are
    held out in turn (:func:`extremes_held_out`) and a constant and a line are fitted on the
    rest; at each held-out end the line must leave at most a quarter of the constant's mean
    squared error, and over both it must beat the constant by more
    than one standard error of the paired difference (the rule the network's selection uses,
    with chunk means since neighbouring rows are correlated). An axis with no real thermal
    slope then falls back to its mean: a line fitted to noise or to a bias that moved with
    time, not with temperature, extrapolates worse than nothing.

    With a ``rate`` and several ``runs``, the calibration can say more: when a plane in T
    and dT fitted on the other runs predicts each run with at most ``repeated_ratio`` of the
    constant's squared error (:func:`held_out_runs`), the relation is thermal, not a drift
    of one run, and the fallback is that plane: the rate term (the Shupe bias of a coil
    whose temperature changes; clipped to the largest calibrated rate magnitude) stays, and
    the line goes on beyond each calibrated extreme where the plane extrapolated there at
    least as well as a constant, beyond noise (held flat from the edge on the other side).
    A plane whose held-out ratio lies between ``repeated_ratio`` and 1 is trusted too when
    the held-out runs bear out its predictions in full (their scale, see
    :func:`held_out_runs`, at least ``carried_scale``): run-to-run noise then raises the
    ratio, not a slope that fails to carry.
    A heating-only calibration thus keeps a slope whose rate term a line in T alone would
    have confused with temperature.

    Parameters
    ----------
    temperature : ndarray of shape (n_samples,) or None
        T of the calibration rows (None: a constant fallback).
    Y : ndarray of shape (n_samples, n_outputs)
        Targets of the calibration rows.
    column : int or None
        Column of the model's features that holds T (stored in the result).
    rate : ndarray of shape (n_samples,), default=None
        The rows' rate dT (None: a line in T only).
    rate_column : int or None, default=None
        Column of the model's features that holds dT (stored in the result).
    runs : array-like of shape (n_samples,), default=None
        The rows' recording runs (None or a single run: a line in T only).
    repeated_ratio : float, default=0.75
        Largest held-out-run error ratio (:func:`held_out_runs`) at which the plane is
        trusted. The default was chosen on the tuning seeds of
        ``benchmarks/bench_extrapolation.py --tune`` (its sweep of 0.5-1.0).
    carried_scale : float, default=0.9
        Smallest held-out scale (:func:`held_out_runs`) at which a plane with a ratio
        between ``repeated_ratio`` and 1 is trusted (``np.inf``: never). The default was
        chosen on the same tuning seeds (its sweep).

    Returns
    -------
    fallback : Fallback

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> t = np.linspace(0.0, 30.0, 300)
    >>> Y = np.column_stack([2.0 * t + rng.normal(size=300), rng.normal(size=300)])
    >>> fallback = fit_fallback(t, Y, column=0)
    >>> fallback.slope.round(1).tolist()  # a real slope; none on the noise-only output
    [2.0, 0.0]

    Three heating runs, each a soak then a ramp at 0.5 degC/min, with a rate term:

    >>> t = np.tile(np.r_[np.full(40, 10.0), np.linspace(10.0, 40.0, 60)], 3)
    >>> dt = np.tile(np.r_[np.zeros(40), np.full(60, 0.5)], 3)
    >>> y = 0.1 * t + 2.0 * dt + rng.normal(scale=0.05, size=300)
    >>> plane = fit_fallback(
    ...     t, y[:, None], 0, rate=dt, rate_column=1, runs=np.repeat([0, 1, 2], 100)
    ... )
    >>> plane.slope.round(2).tolist(), plane.rate_slope.round(1).tolist()
    ([0.1], [2.0])
    """
    Y = np.asarray(Y, dtype=np.float64)
    constant = Y.mean(axis=0)
    zero = np.zeros(Y.shape[1])
    if temperature is None:
        return Fallback(constant, zero, None)
    losses = extremes_held_out(temperature, Y)
    if losses is None:
        return Fallback(constant, zero, column)
    temperature = np.asarray(temperature, dtype=np.float64)
    # The line must remove most of the error at *both* calibrated extremes...
    explains = np.all(
        [end[1].mean(axis=0) <= _REAL_SLOPE_RATIO * end[0].mean(axis=0) for end in losses],
        axis=0,
    )
    # ... and beat the constant beyond the noise of the held-out rows.
    real = explains & _beyond_noise(np.concatenate(losses, axis=1))
    intercept, slope = _line(temperature, Y)
    line = Fallback(
        np.where(real, intercept, constant),
        np.where(real, slope, 0.0),
        column,
        low=float(temperature.min()),
        high=float(temperature.max()),
    )
    if rate is None or runs is None:
        return line
    rate = np.asarray(rate, dtype=np.float64)
    ratio, scale = held_out_runs(temperature, rate, Y, runs, return_scale=True)
    if ratio is None:
        return line
    trusted = (ratio <= repeated_ratio) | ((ratio < 1.0) & (scale >= carried_scale))
    if not trusted.any():
        return line
    losses = extremes_held_out(temperature, Y, rate)
    # At each extreme apart: the plane extrapolated there at least as well as a constant.
    carries = np.array(
        [(end[1].mean(axis=0) <= end[0].mean(axis=0)) & _beyond_noise(end) for end in losses]
    )
    plane = trusted & carries.any(axis=0)
    if not plane.any():
        return line
    intercept, slope, rate_slope = _plane(temperature, rate, Y)
    return Fallback(
        np.where(plane, intercept, line.intercept),
        np.where(plane, slope, line.slope),
        column,
        rate_slope=np.where(plane, rate_slope, 0.0),
        rate_column=rate_column,
        rate_bound=float(np.abs(rate).max()),
        low=line.low,
        high=line.high,
        hold_below=plane & ~carries[0],
        hold_above=plane & ~carries[1],
    )


def fallback_name(fallback):
    """What a fallback is, in a word: ``"plane"``, ``"line"`` or ``"constant"``.

    ``"plane"``: a line in T and the rate dT (some output has a rate slope); ``"line"``: a
    line in T (some output has a slope); ``"constant"``: the calibration's mean drift.

    Parameters
    ----------
    fallback : Fallback
        A fitted fallback (``fallback_`` of a
        :class:`~sklearn_ifog.CompensationPipeline`).

    Returns
    -------
    name : str

    Examples
    --------
    >>> import numpy as np
    >>> fallback_name(Fallback(np.array([1.0]), np.array([0.0]), 0))
    'constant'
    >>> fallback_name(Fallback(np.array([1.0]), np.array([0.5]), 0))
    'line'
    """
    if fallback.rate_slope is not None and np.any(fallback.rate_slope != 0):
        return "plane"
    return "line" if np.any(fallback.slope != 0) else "constant"
