"""The calibration domain: where a drift model was calibrated, and a safe answer outside it.

A thermal calibration covers some temperatures, some rates and some thermal states (lags),
and above all some *combinations* of them: a gyro switched on cold starts its lags at zero
at a temperature where the calibration only ever saw them far from zero. A flexible model
fitted on strongly correlated features (T, T², T·ΔT, lags and their products) cancels its
weights inside the calibrated combinations and can return anything outside them. A range
check per feature misses the harm, since every feature alone may lie inside its range.

:class:`CalibrationDomain` therefore measures how far a row lies outside the training rows'
box in *decorrelated* coordinates: the features are standardised, rotated onto their
principal axes (SVD), and each axis keeps the range ``[lower, upper]`` that the calibration
covered. A row's distance is the Euclidean norm of its excesses beyond those ranges, each in
units of its axis's standard deviation: 0 inside the box, 1 one standard deviation of the
calibrated spread beyond it along an axis. Along the temperature axis of a one-feature
domain the box is exactly the firmware convention ``[TMIN, TMAX]``. It follows
scikit-learn's novelty-detection convention (``fit``, ``predict`` → +1 inside / −1 outside,
``decision_function``, ``score_samples``), so it also stands alone.

The plain functions below hold the numerics (numpy in, numpy out): :func:`fit_box`,
:func:`box_distance`, :func:`project_to_box`, the held-out calibration of the threshold.
The safe answer outside lives beside it: the fallback model in :mod:`sklearn_ifog.fallback`,
the policy that hands rows to it in :mod:`sklearn_ifog.policy`;
:class:`~sklearn_ifog.pipeline.CompensationPipeline` combines the three, and the streaming
path and the C export compute the same formulas.
"""

import warnings
from numbers import Integral, Real
from typing import ClassVar, NamedTuple

import numpy as np
from sklearn.base import BaseEstimator, OutlierMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from sklearn_ifog._compat import Interval, _fit_context
from sklearn_ifog._tuning import NOVELTY_RAMP, PROJECTION_ROUNDS, RATE_WEIGHT

__all__ = [
    "CalibrationDomain",
    "OutsideCalibrationWarning",
    "SmallCalibrationWarning",
    "Where",
    "box_distance",
    "calibrated_threshold",
    "check_varies",
    "fit_box",
    "has_box",
    "held_out_distances",
    "held_out_folds",
    "locate",
    "outside_domain",
    "project_to_box",
    "pull_back_to_ranges",
    "require_box",
    "temperature_excess",
    "threshold_of",
]

# Axes whose spread is below this fraction of the widest axis's are numerically degenerate
# (an exact linear relation between features, e.g. a duplicated column); their scale is
# floored there so that round-off cannot read as a distance.
_AXIS_FLOOR = 1e-6


class OutsideCalibrationWarning(UserWarning):
    """A model was asked to predict rows outside the domain it was calibrated on.

    Given once per ``predict`` call, with the share of rows outside, the largest distance
    and the largest temperature excess in degrees; the predictions themselves follow the
    model's ``uncalibrated`` policy. The flags per row are
    :meth:`~sklearn_ifog.CompensationPipeline.outside_calibration`.

    Examples
    --------
    Silence it where the flags are read instead:

    >>> import warnings
    >>> from sklearn_ifog import OutsideCalibrationWarning
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore", OutsideCalibrationWarning)
    ...     warnings.warn("outside", OutsideCalibrationWarning)
    >>> issubclass(OutsideCalibrationWarning, UserWarning)
    True
    """


class SmallCalibrationWarning(UserWarning):
    """A calibration too small to hold part of it out: the domain keeps its ``margin``.

    :class:`CalibrationDomain` calibrates its threshold on held-out parts of the calibration
    (:func:`held_out_distances`); when the calibration has too few rows (or too few that vary)
    to hold any out, the threshold is the ``margin`` itself and this warning says so, once
    per fit.

    Examples
    --------
    >>> import warnings
    >>> import numpy as np
    >>> from sklearn_ifog.domain import CalibrationDomain, SmallCalibrationWarning
    >>> t = np.linspace(10.0, 40.0, 12)
    >>> X = np.column_stack([t, np.sin(t)])  # a temperature and its rate
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     domain = CalibrationDomain(temperature=0, rate=1).fit(X)
    >>> caught[0].category is SmallCalibrationWarning, domain.threshold_ == domain.margin
    (True, True)
    """


class Box(NamedTuple):
    """A fitted box in decorrelated coordinates (the result of :func:`fit_box`).

    Attributes
    ----------
    center : ndarray of shape (n_features,)
        Mean of every feature.
    scale : ndarray of shape (n_features,)
        Standard deviation of every feature.
    axes : ndarray of shape (n_features, n_features)
        Principal axes of the standardised features, one per row (orthonormal).
    axis_scale : ndarray of shape (n_features,)
        Standard deviation of the calibration rows along each axis (floored at
        ``1e-6`` times the largest).
    lower, upper : ndarray of shape (n_features,)
        Smallest and largest coordinate of the calibration rows along each axis.
    rate_columns : tuple of int, default=()
        Rate features whose excess beyond their calibrated range is one more term of the
        distance (:func:`box_distance`).
    rate_low, rate_high : ndarray of shape (n_rates,), default=empty
        Calibrated range of each rate feature, in its own units.
    rate_scale : ndarray of shape (n_rates,), default=empty
        The rate feature's standard deviation over the rate weight (2): its excess is divided
        by it.
    boost : float, default=0.0
        Added to the distance of a row beyond the calibrated rates or temperatures, in
        proportion to its novelty up to 1 (:func:`box_distance`; only with
        ``rate_columns``): a calibrated threshold above the margin then holds such a row
        to the margin (the held-out runs that set the threshold say nothing of rates or
        temperatures the calibration never showed).
    temperature_columns : tuple of int, default=()
        Temperature features whose excess is part of the novelty that ``boost`` weighs.
    temperature_low, temperature_high : ndarray of shape (n_temperatures,), default=empty
        The ranges their excess is measured from: the calibrated ranges, widened where
        held-out evidence says the model extrapolates well (``boost_low_``,
        ``boost_high_`` of :class:`CalibrationDomain`; the firmware rule that flags every
        temperature beyond the calibrated range is not widened).
    """

    center: np.ndarray
    scale: np.ndarray
    axes: np.ndarray
    axis_scale: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    rate_columns: tuple = ()
    rate_low: np.ndarray = np.empty(0)
    rate_high: np.ndarray = np.empty(0)
    rate_scale: np.ndarray = np.empty(0)
    boost: float = 0.0
    temperature_columns: tuple = ()
    temperature_low: np.ndarray = np.empty(0)
    temperature_high: np.ndarray = np.empty(0)


def fit_box(X, rate_columns=()):
    """Fit the decorrelated box of the rows ``X``.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        Calibration rows; every column must vary.
    rate_columns : sequence of int, default=()
        Rate features whose range is checked on its own too (see :class:`Box`).

    Returns
    -------
    box : Box
        See :class:`Box`.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 10.0, 11)
    >>> box = fit_box(np.column_stack([t, 2 * t + np.sin(t)]))
    >>> bool(np.allclose(box.axes @ box.axes.T, np.eye(2)))
    True
    """
    X = np.asarray(X, dtype=np.float64)
    center = X.mean(axis=0)
    scale = X.std(axis=0)
    Z = (X - center) / scale
    _, singular, axes = np.linalg.svd(Z, full_matrices=False)
    n_features = X.shape[1]
    if axes.shape[0] < n_features:  # fewer rows than features: complete the basis
        complement = np.linalg.svd(np.eye(n_features) - axes.T @ axes)[0]
        axes = np.vstack([axes, complement[:, : n_features - axes.shape[0]].T])
        singular = np.concatenate([singular, np.zeros(n_features - singular.shape[0])])
    axis_scale = singular / np.sqrt(X.shape[0])
    axis_scale = np.maximum(axis_scale, _AXIS_FLOOR * axis_scale.max())
    projected = Z @ axes.T
    rates = [int(column) for column in rate_columns]
    return Box(
        center,
        scale,
        axes,
        axis_scale,
        projected.min(axis=0),
        projected.max(axis=0),
        tuple(rates),
        X[:, rates].min(axis=0),
        X[:, rates].max(axis=0),
        scale[rates] / RATE_WEIGHT,
    )


def check_varies(X, names=None):
    """Raise a ValueError naming the first feature of ``X`` that is constant.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        Calibration rows.
    names : sequence of str, default=None
        Feature names for the message (positions without them).

    Raises
    ------
    ValueError
        If a column of ``X`` takes one value only.

    Examples
    --------
    >>> import numpy as np
    >>> check_varies(np.array([[1.0, 2.0], [1.0, 3.0]]), ["T", "dT"])
    Traceback (most recent call last):
    ...
    ValueError: Cannot fit a calibration domain: feature 'T' is constant (1.0) ...
    """
    constant = np.flatnonzero(_no_spread(X))
    if constant.size:
        column = int(constant[0])
        name = f"column {column}" if names is None else repr(str(names[column]))
        spread = float(np.ptp(X[:, column]))
        how = (
            f"is constant ({float(X[0, column])!r})"
            if spread == 0
            else f"varies by {spread:.3g} only, too little to standardise by"
        )
        raise ValueError(
            f"Cannot fit a calibration domain: feature {name} {how} over the {X.shape[0]} "
            "calibration rows. A calibration must cover a range of temperatures (and rates) "
            "to say where it holds; calibrate on runs that change temperature."
        )


# A spread within this many units of round-off of a column's largest value is no spread:
# standardising by it would divide by zero or by noise of the arithmetic.
_ROUND_OFF_SPREAD = 1e3


def _no_spread(X):
    """Columns of ``X`` without a spread to standardise by: constant, a standard deviation
    that underflows to 0 (values near 1e-160), or a range at the round-off of the values."""
    spread = np.ptp(X, axis=0)
    magnitude = np.abs(X).max(axis=0, initial=0.0)
    return (
        (spread == 0)
        | ~(X.std(axis=0) > 0)
        | (spread <= _ROUND_OFF_SPREAD * np.finfo(np.float64).eps * magnitude)
    )


def _coordinates(box, X):
    return ((np.asarray(X, dtype=np.float64) - box.center) / box.scale) @ box.axes.T


def box_distance(box, X):
    """Distance of every row of ``X`` outside ``box``, in decorrelated standard deviations.

    ``sqrt(sum_k (excess_k / axis_scale_k)² + g²) + boost · min(n, 1)`` with
    ``g² = sum_r (rate_excess_r / rate_scale_r)²``, ``excess_k`` the row's coordinate
    beyond ``[lower_k, upper_k]`` along axis ``k`` and ``rate_excess_r`` its rate feature
    ``r`` beyond ``[rate_low_r, rate_high_r]`` (0 inside the ranges; no rate term for a box
    without ``rate_columns``), and the novelty ``n² = (g / (2 ρ))² + sum_t
    (t_excess_t / (ρ scale_t))²`` over the ``temperature_columns`` (their excess beyond the
    calibrated range over the feature's standard deviation), ``ρ = 0.01``: the boost is
    added in full a hundredth of a standard deviation beyond the calibrated rates or
    temperatures. The distance is continuous in the row.

    Parameters
    ----------
    box : Box
        The fitted box (:func:`fit_box`).
    X : array-like of shape (n_samples, n_features)
        Feature rows.

    Returns
    -------
    distance : ndarray of shape (n_samples,)
        0 inside the box.

    Examples
    --------
    >>> import numpy as np
    >>> box = fit_box(np.linspace(0.0, 10.0, 11)[:, None])
    >>> box_distance(box, [[5.0], [10.0], [13.16227766]]).round(3).tolist()
    [0.0, 0.0, 1.0]
    """
    X = np.asarray(X, dtype=np.float64)
    P = _coordinates(box, X)
    excess = np.maximum(box.lower - P, 0.0) + np.maximum(P - box.upper, 0.0)
    squares = np.square(excess / box.axis_scale).sum(axis=1)
    if not box.rate_columns:
        return np.sqrt(squares)
    rates = X[:, list(box.rate_columns)]
    beyond = np.maximum(box.rate_low - rates, 0.0) + np.maximum(rates - box.rate_high, 0.0)
    rate_squares = np.square(beyond / box.rate_scale).sum(axis=1)
    distance = np.sqrt(squares + rate_squares)
    if box.boost:
        # In standard deviations of each feature over the ramp (rate_scale is the rate's
        # standard deviation over RATE_WEIGHT).
        novelty = rate_squares / (RATE_WEIGHT * NOVELTY_RAMP) ** 2
        if box.temperature_columns:
            columns = list(box.temperature_columns)
            values = X[:, columns]
            excess = np.maximum(box.temperature_low - values, 0.0) + np.maximum(
                values - box.temperature_high, 0.0
            )
            scaled = excess / (box.scale[columns] * NOVELTY_RAMP)
            novelty = novelty + np.square(scaled).sum(axis=1)
        distance += box.boost * np.minimum(np.sqrt(novelty), 1.0)
    return distance


def project_to_box(box, X, margin):
    """The nearest point of ``box`` widened by ``margin`` (the ``"clip"`` policy).

    Rows within ``margin`` of the box are returned unchanged; a row farther out moves along
    its excess towards the box until its distance is ``margin``. Only the box's axes count
    here: a rate beyond its own range (the ``rate_columns`` term of :func:`box_distance`)
    is not moved. For one feature this is
    clamping to ``[min - margin·sd, max + margin·sd]``.

    Parameters
    ----------
    box : Box
        The fitted box (:func:`fit_box`).
    X : array-like of shape (n_samples, n_features)
        Feature rows.
    margin : float
        Distance of the widened box's edge, in decorrelated standard deviations.

    Returns
    -------
    projected : ndarray of shape (n_samples, n_features)
        A copy of ``X`` with the rows beyond ``margin`` moved onto the widened box.

    Examples
    --------
    >>> import numpy as np
    >>> box = fit_box(np.linspace(0.0, 10.0, 11)[:, None])
    >>> project_to_box(box, [[5.0], [-40.0], [40.0]], 0.0).round(6).ravel().tolist()
    [5.0, 0.0, 10.0]
    """
    X = np.asarray(X, dtype=np.float64)
    P = _coordinates(box, X)
    inside = np.clip(P, box.lower, box.upper)
    distance = np.sqrt(np.square((P - inside) / box.axis_scale).sum(axis=1))
    far = distance > margin
    projected = X.copy()  # rows within the margin stay exactly as they are
    P_far = inside[far] + (P[far] - inside[far]) * (margin / distance[far])[:, None]
    projected[far] = (P_far @ box.axes) * box.scale + box.center
    return projected


def pull_back_to_ranges(box, X, columns, low, high):
    """Move every row with a column beyond its range towards the box's centre, into range.

    A row with a value of ``columns`` outside ``[low, high]`` moves along the segment to the
    box's ``center`` (the calibration's mean, inside every calibrated range) until its last
    such value reaches its range: ``center + s (x - center)`` with ``s`` the smallest
    ``(bound - center_c) / (x_c - center_c)`` over the columns ``c`` beyond, ``bound`` the
    end of the range crossed. Then those columns are clipped to their ranges, a change of a
    rounding error. Rows within every range stay as they are.

    It ends the ``"clip"`` policy (:meth:`CalibrationDomain.project`): after a last
    projection onto the widened box, the row lies within it, and the box distance only
    shrinks towards the centre (the box holds the centre), so the result lies in the box and
    in every temperature range.

    Parameters
    ----------
    box : Box
        The fitted box (:func:`fit_box`); only its ``center`` is read.
    X : array-like of shape (n_samples, n_features)
        Feature rows.
    columns : sequence of int
        The columns with a range (the temperature features).
    low, high : array-like of shape (len(columns),)
        Their ranges; each must hold the centre's value.

    Returns
    -------
    pulled : ndarray of shape (n_samples, n_features)
        A copy of ``X`` with the rows beyond a range moved into it.

    Examples
    --------
    >>> import numpy as np
    >>> box = fit_box(np.array([[0.0, 0.0], [10.0, 2.0], [4.0, 4.0]]))
    >>> pull_back_to_ranges(box, [[5.0, 1.0], [16.0, 2.0]], [0], [0.0], [10.0]).tolist()
    [[5.0, 1.0], [10.0, 2.0]]
    """
    X = np.asarray(X, dtype=np.float64)
    columns = list(columns)
    pulled = X.copy()  # rows within every range stay exactly as they are
    if not columns:
        return pulled
    low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
    values, middle = X[:, columns], box.center[columns]
    bound = np.where(values > high, high, np.where(values < low, low, np.nan))
    beyond = ~np.isnan(bound).all(axis=1)
    if not beyond.any():
        return pulled
    with np.errstate(invalid="ignore"):
        share = np.nanmin((bound[beyond] - middle) / (values[beyond] - middle), axis=1)
    pulled[beyond] = box.center + share[:, None] * (X[beyond] - box.center)
    pulled[np.ix_(beyond, columns)] = np.clip(pulled[np.ix_(beyond, columns)], low, high)
    return pulled


def temperature_excess(X, columns, low, high):
    """How far the temperature columns of ``X`` lie beyond their calibrated ranges.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        Feature rows.
    columns : sequence of int
        The temperature columns (one per sensor); empty: no temperature rule.
    low, high : ndarray of shape (n_features,)
        Calibrated range of every feature.

    Returns
    -------
    excess : ndarray of shape (n_samples,)
        The largest excess over the columns, in degrees (0 inside every range).

    Examples
    --------
    >>> import numpy as np
    >>> temperature_excess(np.array([[5.0], [12.0], [43.0]]), [0], [10.0], [40.0]).tolist()
    [5.0, 0.0, 3.0]
    """
    X = np.asarray(X, dtype=np.float64)
    columns = list(columns)
    if not columns:
        return np.zeros(X.shape[0])
    low, high = np.asarray(low)[columns], np.asarray(high)[columns]
    values = X[:, columns]
    return np.maximum(np.maximum(low - values, values - high), 0.0).max(axis=1)


def outside_domain(distance, temperature_beyond, margin):
    """The domain's rule: outside when farther than ``margin`` from the decorrelated box,
    or when a temperature lies beyond its calibrated range (by any amount: the firmware
    convention of a calibrated [TMIN, TMAX]).

    Parameters
    ----------
    distance : array-like of shape (n_samples,)
        Distance to the box (:func:`box_distance`).
    temperature_beyond : array-like of shape (n_samples,)
        Degrees beyond the calibrated temperatures (:func:`temperature_excess`).
    margin : float
        Distance that still counts as inside.

    Returns
    -------
    outside : ndarray of shape (n_samples,), dtype=bool

    Examples
    --------
    >>> outside_domain([0.0, 2.0, 0.0], [0.0, 0.0, 0.5], margin=1.0).tolist()
    [False, True, True]
    """
    return (np.asarray(distance) > margin) | (np.asarray(temperature_beyond) > 0)


class Where(NamedTuple):
    """Where feature rows lie relative to a fitted domain (the result of :func:`locate`).

    Parameters
    ----------
    distance : ndarray of shape (n_samples,)
        Distance outside the box (:func:`box_distance`; 0 inside).
    beyond : ndarray of shape (n_samples,)
        Degrees beyond the calibrated temperatures (:func:`temperature_excess`; 0 within).
    outside : ndarray of shape (n_samples,), dtype=bool
        Outside the domain (:func:`outside_domain` at the domain's ``threshold_``).

    Examples
    --------
    >>> import numpy as np
    >>> where = Where(np.array([0.0, 2.5]), np.array([0.0, 0.0]), np.array([False, True]))
    >>> distance, beyond, outside = where
    >>> outside.tolist(), where.distance.tolist()
    ([False, True], [0.0, 2.5])
    """

    distance: np.ndarray
    beyond: np.ndarray
    outside: np.ndarray


def has_box(domain):
    """Whether ``domain`` is a fitted CalibrationDomain-like box (not another detector).

    Streaming, the exports and the ``"clip"`` policy need the box
    (:func:`require_box`); the rest of the package asks any novelty detector through
    :func:`locate`.

    Parameters
    ----------
    domain : estimator
        A fitted CalibrationDomain or another novelty detector.

    Returns
    -------
    has_box : bool

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.covariance import EllipticEnvelope
    >>> rows = np.random.default_rng(0).normal(size=(50, 2))
    >>> has_box(CalibrationDomain().fit(rows)), has_box(EllipticEnvelope().fit(rows))
    (True, False)
    """
    return hasattr(domain, "box_")


def require_box(domain, what):
    """Raise a ValueError naming ``what`` unless ``domain`` is a fitted box (:func:`has_box`).

    Parameters
    ----------
    domain : estimator
        A fitted CalibrationDomain or another novelty detector.
    what : str
        What needs the box, as the message's subject (e.g. ``"uncalibrated='clip'"``).

    Raises
    ------
    ValueError
        If ``domain`` is another detector.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.covariance import EllipticEnvelope
    >>> detector = EllipticEnvelope().fit(np.random.default_rng(0).normal(size=(50, 2)))
    >>> require_box(detector, "the C export")
    Traceback (most recent call last):
    ...
    ValueError: the C export needs the pipeline's domain to be a CalibrationDomain ...
    """
    if not has_box(domain):
        raise ValueError(
            f"{what} needs the pipeline's domain to be a CalibrationDomain (its box, "
            f"threshold and calibrated temperatures); got {type(domain).__name__}. Fit the "
            "pipeline with domain=CalibrationDomain() (the default)."
        )


def threshold_of(domain):
    """The distance of :func:`locate` at which ``domain`` starts to flag a row.

    A CalibrationDomain's ``threshold_``; 0 for another novelty detector (its
    ``decision_function`` changes sign there).

    Parameters
    ----------
    domain : estimator
        A fitted CalibrationDomain or another novelty detector.

    Returns
    -------
    threshold : float

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.covariance import EllipticEnvelope
    >>> rows = np.random.default_rng(0).normal(size=(50, 2))
    >>> threshold_of(CalibrationDomain(alpha=0.5).fit(rows)) >= 1.5
    True
    >>> threshold_of(EllipticEnvelope().fit(rows))
    0.0
    """
    return float(domain.threshold_) if has_box(domain) else 0.0


def locate(domain, rows):
    """Distance, temperature excess and outside flag of feature rows for a fitted domain.

    The one place that composes them: :class:`CalibrationDomain`,
    :class:`~sklearn_ifog.pipeline.CompensationPipeline`, the conformal band and the
    streaming compensator all ask it (the per-row fast path of streaming is tested equal).

    Another fitted novelty detector (scikit-learn's shape: ``predict`` gives -1 for an
    outlier, ``decision_function`` is negative there, e.g.
    :class:`~sklearn.covariance.EllipticEnvelope`) is asked the same: its outliers are
    outside, the distance is how far its ``decision_function`` lies below 0 (its
    threshold is 0, see :func:`threshold_of`) and no temperature is beyond (a calibrated
    temperature range is the CalibrationDomain's).

    Parameters
    ----------
    domain : CalibrationDomain or novelty detector
        A fitted domain.
    rows : array-like of shape (n_samples, n_features)
        Rows of the features it was fitted on (not validated: the callers have).

    Returns
    -------
    where : Where
        ``(distance, beyond, outside)``.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(10.0, 40.0, 31)
    >>> domain = CalibrationDomain(margin=1.0, temperature=0).fit(t[:, None])
    >>> where = locate(domain, [[25.0], [41.0]])
    >>> where.distance.round(3).tolist(), where.beyond.tolist(), where.outside.tolist()
    ([0.0, 0.112], [0.0, 1.0], [False, True])
    """
    rows = np.asarray(rows, dtype=np.float64)
    if not has_box(domain):
        distance = np.maximum(-np.asarray(domain.decision_function(rows), dtype=np.float64), 0.0)
        outside = np.asarray(domain.predict(rows)) == -1
        return Where(distance, np.zeros(rows.shape[0]), outside)
    distance = box_distance(domain.box_, rows)
    beyond = temperature_excess(
        rows, domain.temperature_columns_, domain.data_min_, domain.data_max_
    )
    return Where(distance, beyond, outside_domain(distance, beyond, domain.threshold_))


# The threshold's held-out folds: whole runs with at least this many of them (at most
# _MAX_THRESHOLD_FOLDS folds, the runs dealt out in turn), else _THRESHOLD_BLOCKS
# contiguous blocks of every run; and the fewest held-out rows a quantile is taken of.
_MIN_THRESHOLD_RUNS = 3
_MAX_THRESHOLD_FOLDS = 10
_THRESHOLD_BLOCKS = 5
_MIN_HELD_OUT_ROWS = 20


def held_out_folds(n_samples, groups=None):
    """The held-out fold of every calibration row, for the threshold's distances.

    With at least 3 runs in ``groups``, whole runs: run ``k`` (in sorted order) belongs to
    fold ``k mod 10``, so a lot of hundreds of runs costs at most ten held-out boxes. With
    fewer runs (or none), contiguous blocks: fold ``k`` holds the ``k``-th fifth of every
    run's rows, in their order (time order).

    Parameters
    ----------
    n_samples : int
        Number of calibration rows.
    groups : array-like of shape (n_samples,), default=None
        The recording run of every row (None: one run).

    Returns
    -------
    folds : ndarray of shape (n_samples,), dtype=int

    Examples
    --------
    >>> held_out_folds(10).tolist()  # one run: five contiguous blocks
    [0, 0, 1, 1, 2, 2, 3, 3, 4, 4]
    >>> held_out_folds(6, ["b", "b", "a", "a", "c", "c"]).tolist()  # three runs
    [1, 1, 0, 0, 2, 2]
    """
    if groups is None:
        labels = np.zeros(n_samples, dtype=np.intp)
    else:
        groups = np.asarray(groups)
        if groups.shape != (n_samples,):
            raise ValueError(
                f"groups must hold one run label per calibration row, shape ({n_samples},); "
                f"got shape {groups.shape}."
            )
        labels = np.unique(groups, return_inverse=True)[1].ravel()
    n_runs = int(labels.max(initial=-1)) + 1
    if n_runs >= _MIN_THRESHOLD_RUNS:
        return labels % _MAX_THRESHOLD_FOLDS
    # The rank of every row within its run, from a stable sort by run.
    order = np.argsort(labels, kind="stable")
    counts = np.bincount(labels, minlength=n_runs)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rank = np.empty(n_samples, dtype=np.intp)
    rank[order] = np.arange(n_samples) - starts[labels[order]]
    return (rank * _THRESHOLD_BLOCKS) // counts[labels]


def held_out_distances(X, folds, rate_columns=(), temperature_columns=()):
    """Distances of held-out calibration rows to the box of the other rows.

    For every fold, the box (:func:`fit_box`) of the rows of the other folds, and the
    :func:`box_distance` to it of the fold's rows that lie within the other folds'
    temperatures and rates: the threshold is for new combinations (thermal states) of
    calibrated temperatures and rates, while a row beyond them is of another kind of
    novelty, held to the margin (``Box.boost``). A fold whose other rows leave a feature
    constant is skipped.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        Calibration rows.
    folds : ndarray of shape (n_samples,)
        Their held-out fold (:func:`held_out_folds`).
    rate_columns : sequence of int, default=()
        As for :func:`fit_box`.
    temperature_columns : sequence of int, default=()
        The temperature columns.

    Returns
    -------
    distances : ndarray of shape (n_held,)
        One per held-out row within the other folds' temperatures, fold by fold.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(10.0, 40.0, 100)
    >>> X = np.column_stack([t, np.sin(t)])
    >>> d = held_out_distances(X, held_out_folds(100), temperature_columns=[0])
    >>> d.size  # the coldest and the warmest fifth lie beyond the others' temperatures
    60
    """
    X = np.asarray(X, dtype=np.float64)
    temperature_columns = list(temperature_columns)
    distances = []
    for fold in np.unique(folds):
        held = folds == fold
        kept = X[~held]
        if kept.shape[0] < 2 or np.any(_no_spread(kept)):
            continue
        rows = X[held]
        ranged = temperature_columns + [int(column) for column in rate_columns]
        if ranged:
            low, high = kept[:, ranged].min(axis=0), kept[:, ranged].max(axis=0)
            values = rows[:, ranged]
            rows = rows[np.all((values >= low) & (values <= high), axis=1)]
        distances.append(box_distance(fit_box(kept, rate_columns), rows))
    return np.concatenate(distances) if distances else np.empty(0)


def calibrated_threshold(distances, alpha, floor):
    """The distance that flags a share ``alpha`` of held-out calibration rows.

    The ``1 - alpha`` quantile of the held-out distances (:func:`held_out_distances`),
    never below ``floor``: a new run of a calibrated profile then has about ``alpha`` of its
    rows beyond it (inductive conformal novelty detection: the held-out rows stand for the
    runs to come).

    Parameters
    ----------
    distances : array-like of shape (n_held,)
        Held-out distances.
    alpha : float
        Share of held-out rows flagged, in (0, 0.5].
    floor : float
        Smallest threshold (the domain's ``margin``).

    Returns
    -------
    threshold : float or None
        None with fewer than 20 held-out distances (too few for a quantile).

    Raises
    ------
    ValueError
        If a distance is not finite.

    Examples
    --------
    >>> import numpy as np
    >>> calibrated_threshold(np.linspace(0.0, 10.0, 101), alpha=0.02, floor=1.5)
    9.8
    >>> calibrated_threshold(np.zeros(100), alpha=0.02, floor=1.5)
    1.5
    >>> calibrated_threshold(np.zeros(5), alpha=0.02, floor=1.5) is None
    True
    """
    distances = np.asarray(distances, dtype=np.float64)
    if not np.all(np.isfinite(distances)):
        raise ValueError(
            "Cannot calibrate the domain's threshold (alpha): "
            f"{int(np.sum(~np.isfinite(distances)))} held-out distances are NaN or infinite; "
            "the calibration rows must be finite and every feature must vary."
        )
    if distances.size < _MIN_HELD_OUT_ROWS:
        return None
    return max(float(floor), float(np.quantile(distances, 1.0 - alpha)))


def _columns(value, name, n_features):
    """The columns a ``temperature`` or ``rate`` parameter names, checked against X.

    A bool is not a column position (``True`` would read column 1): TypeError. A column
    named twice would count its excess twice: ValueError.
    """
    if value is None:
        columns = []
    elif isinstance(value, list | tuple | np.ndarray):
        columns = list(np.asarray(value, dtype=object).ravel())
    else:
        columns = [value]
    flags = [c for c in columns if isinstance(c, bool | np.bool_)]
    if flags:
        raise TypeError(
            f"{name} must name columns of X by integer position, got the bool {flags[0]!r} "
            "(a bool is not a column index)."
        )
    bad = [c for c in columns if not isinstance(c, Integral) or not 0 <= c < n_features]
    if bad:
        raise ValueError(
            f"{name} must name columns 0 to {n_features - 1} of X by position, got {bad[0]!r}."
        )
    columns = [int(c) for c in columns]
    repeated = sorted({c for c in columns if columns.count(c) > 1})
    if repeated:
        raise ValueError(
            f"{name} must name each column once, got column {repeated[0]} "
            f"{columns.count(repeated[0])} times in {columns}."
        )
    return columns


class CalibrationDomain(OutlierMixin, BaseEstimator):
    """Where a model was calibrated: the box of its rows in decorrelated coordinates.

    The features are standardised and rotated onto their principal axes; the domain is the
    range the calibration rows cover along every axis. :meth:`score_samples` is minus a
    row's distance outside that box, in units of each axis's standard deviation (0 inside),
    so it measures *combinations* that the calibration never showed (a lag at zero while T
    is cold) as well as values beyond each feature's range, which a per-feature range check
    misses. A row is outside (:meth:`predict` gives −1) when it lies farther than
    ``threshold_`` from the box, or when a ``temperature`` column lies beyond its calibrated
    range by any amount (the firmware convention of a calibrated [TMIN, TMAX]).

    The threshold has a stated false-alarm rate (inductive conformal novelty detection):
    at :meth:`fit`, every run of the calibration (``groups``; with fewer than 3 runs, every
    fifth of each run) is held out in turn, its rows' distances to the box of the others
    are measured (those within the others' temperatures), and ``threshold_`` is the
    ``1 - alpha`` quantile of them, never below ``margin``. A new run of a calibrated
    profile then has about ``alpha`` of its rows flagged, while a row at temperatures,
    rates or thermal states the calibration never showed lies beyond it. A row beyond the
    calibrated rates or temperatures is held to ``margin`` (``boost_``): the held-out
    runs say nothing of rates or temperatures the calibration never showed. Without
    ``temperature`` or ``rate`` columns the threshold is ``margin``: a held-out run's
    distance would then mix temperatures beyond the others' (extrapolation) with the noise
    the threshold is for, or a new rate could not be held to the margin.

    Parameters
    ----------
    margin : float, default=1.5
        Smallest threshold, in decorrelated standard deviations: the distance that counts
        as inside whatever the held-out runs say (see :ref:`outside_calibration` for how it
        was chosen and measured).
    alpha : float, default=0.02
        Share of the held-out calibration rows beyond the threshold: the false-alarm rate
        promised for a new run of a calibrated profile. In (0, 0.5].
    temperature : int, list of int or None, default=None
        Column(s) holding a temperature, whose calibrated range admits no margin. None: the
        distance alone decides.
    rate : int, list of int or None, default=None
        Column(s) holding a temperature rate, whose excess beyond its calibrated range is one
        more term of the distance: in the rate's standard deviations times
        a weight of 2 (a heating-only calibration's cooling rows lie there). None: no
        rate term.

    Attributes
    ----------
    center_ : ndarray of shape (n_features_in_,)
        Mean of every feature.
    scale_ : ndarray of shape (n_features_in_,)
        Standard deviation of every feature.
    components_ : ndarray of shape (n_features_in_, n_features_in_)
        Principal axes of the standardised features, one per row.
    axis_scale_ : ndarray of shape (n_features_in_,)
        Standard deviation of the calibration rows along each axis.
    lower_, upper_ : ndarray of shape (n_features_in_,)
        Range of the calibration rows along each axis.
    data_min_, data_max_ : ndarray of shape (n_features_in_,)
        Range of every feature, in its own units (degrees, degrees per minute, ...).
    temperature_columns_ : list of int
        The temperature columns (from ``temperature``).
    rate_columns_ : list of int
        The rate columns (from ``rate``).
    boost_low_, boost_high_ : ndarray of shape (n_temperatures,)
        The temperatures beyond which a row is held to ``margin`` by ``boost_``: the
        calibrated ranges, widened by :meth:`extend` where held-out evidence says so.
    rate_low_, rate_high_ : ndarray of shape (n_rates,)
        The calibrated range of each rate column (as ``data_min_`` and ``data_max_``
        give it, widened by :meth:`extend` where held-out evidence says so).
    rate_scale_ : ndarray of shape (n_rates,)
        Standard deviation of each rate column over the rate weight (2): the unit of its
        excess in the distance.
    threshold_ : float
        Distance beyond which a row is outside: the ``1 - alpha`` quantile of the held-out
        distances, at least ``margin`` (``margin`` itself when the calibration is too
        small to hold rows out, with a :class:`SmallCalibrationWarning`).
    n_held_out_ : int
        Number of held-out distances the threshold was calibrated on.
    boost_ : float
        ``threshold_ - margin`` (0 where the threshold is the margin): added to the distance of a
        row beyond the calibrated rates or temperatures in proportion to its novelty up to
        1 (:func:`box_distance`), so that such a row is held to ``margin``, not to the
        threshold that held-out rows within both calibrated.
    offset_ : float
        ``-threshold_``: :meth:`decision_function` is ``score_samples - offset_``.
    n_features_in_ : int
        Number of features seen during fit.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of features seen during fit, when they are all strings.

    See Also
    --------
    sklearn_ifog.pipeline.CompensationPipeline : Fits a domain on its thermal features and
        applies its ``uncalibrated`` policy beyond it.
    sklearn.covariance.EllipticEnvelope : A Gaussian novelty detector (an ellipsoid, blind
        to one-sided ranges such as heating-only rates).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.domain import CalibrationDomain
    >>> t = np.linspace(10.0, 40.0, 200)
    >>> X = np.column_stack([t, t**2])
    >>> domain = CalibrationDomain(temperature=0).fit(X)
    >>> domain.predict([[25.0, 625.0], [0.0, 0.0], [25.0, 0.0], [40.5, 1640.25]]).tolist()
    [1, -1, -1, -1]
    >>> domain.temperature_excess([[40.5, 1640.25]]).tolist()  # degrees above the range
    [0.5]
    >>> domain.excess([[5.0, 25.0]]).round(1).tolist()  # degrees below the range
    [[-5.0, -75.0]]
    """

    _parameter_constraints: ClassVar[dict] = {
        "margin": [Interval(Real, 0, None, closed="left")],
        "alpha": [Interval(Real, 0, 0.5, closed="right")],
        "temperature": [Interval(Integral, 0, None, closed="left"), list, None],
        "rate": [Interval(Integral, 0, None, closed="left"), list, None],
    }

    def __init__(self, *, margin=1.5, alpha=0.02, temperature=None, rate=None):
        self.margin = margin
        self.alpha = alpha
        self.temperature = temperature
        self.rate = rate

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None, groups=None):
        """Learn the calibration domain of the rows ``X`` and calibrate its threshold.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Calibration rows (usually the thermal features of the calibration runs), each
            run's rows in time order.
        y : None
            Ignored.
        groups : array-like of shape (n_samples,), default=None
            The recording run of every row: the threshold holds out whole runs (with at
            least 3; else contiguous fifths of every run). None: one run.

        Returns
        -------
        self : CalibrationDomain
            Fitted.

        Raises
        ------
        ValueError
            If a feature is constant over the calibration (one temperature only: the
            calibration cannot say where else it holds), X holds NaN or inf, or
            ``groups`` does not hold one label per row; if ``temperature`` or ``rate``
            names a column X does not have, names a column twice, or both name one column.
        TypeError
            If ``temperature`` or ``rate`` is (or holds) a bool: a bool is not a column
            position.

        Warns
        -----
        SmallCalibrationWarning
            When the calibration is too small to hold rows out (``threshold_`` is then
            ``margin``).
        """
        X = validate_data(self, X, dtype=np.float64, ensure_min_samples=2)
        check_varies(X, getattr(self, "feature_names_in_", None))
        self.temperature_columns_ = _columns(self.temperature, "temperature", X.shape[1])
        self.rate_columns_ = _columns(self.rate, "rate", X.shape[1])
        both = sorted(set(self.temperature_columns_) & set(self.rate_columns_))
        if both:
            raise ValueError(
                f"temperature and rate must name different columns of X, got column {both[0]} "
                f"in both (temperature={self.temperature!r}, rate={self.rate!r}): a column is "
                "a temperature (its range admits no margin) or a rate (its excess is a term of "
                "the distance), not both."
            )
        box = fit_box(X, self.rate_columns_)
        self.center_, self.scale_, self.components_ = box.center, box.scale, box.axes
        self.axis_scale_, self.lower_, self.upper_ = box.axis_scale, box.lower, box.upper
        self.rate_scale_ = box.rate_scale
        self.data_min_, self.data_max_ = X.min(axis=0), X.max(axis=0)
        self.rate_low_ = self.data_min_[self.rate_columns_]
        self.rate_high_ = self.data_max_[self.rate_columns_]
        self.boost_low_ = self.data_min_[self.temperature_columns_]
        self.boost_high_ = self.data_max_[self.temperature_columns_]
        folds = held_out_folds(X.shape[0], groups)
        self.threshold_, self.boost_, self.n_held_out_ = float(self.margin), 0.0, 0
        # Only a domain that holds the rows beyond its calibrated temperatures and rates to
        # the margin (Box.boost rides on the rate term) calibrates its threshold: without
        # a temperature column a held-out run's distance would mix temperatures beyond the
        # others' with new combinations, and calibrate extrapolation as noise.
        if self.temperature_columns_ and self.rate_columns_:
            distances = held_out_distances(X, folds, self.rate_columns_, self.temperature_columns_)
            self.n_held_out_ = int(distances.size)
            threshold = calibrated_threshold(distances, self.alpha, self.margin)
            if threshold is None:
                warnings.warn(
                    f"The calibration ({X.shape[0]} rows) is too small to hold rows out and "
                    f"calibrate the domain's threshold at alpha={self.alpha!r} "
                    f"({distances.size} held-out distances, at least {_MIN_HELD_OUT_ROWS} "
                    f"needed); the threshold is the margin, {float(self.margin)!r}.",
                    SmallCalibrationWarning,
                    stacklevel=3,
                )
            else:
                self.threshold_ = threshold
                self.boost_ = threshold - float(self.margin)
        self.offset_ = -self.threshold_
        return self

    @property
    def box_(self):
        """The fitted :class:`Box` (the record the plain functions take)."""
        check_is_fitted(self)
        # A domain fitted before the rate term existed has no rate columns.
        rates = list(getattr(self, "rate_columns_", []))
        return Box(
            self.center_,
            self.scale_,
            self.components_,
            self.axis_scale_,
            self.lower_,
            self.upper_,
            tuple(rates),
            getattr(self, "rate_low_", self.data_min_[rates]),
            getattr(self, "rate_high_", self.data_max_[rates]),
            getattr(self, "rate_scale_", np.empty(0)),
            getattr(self, "boost_", 0.0),
            tuple(self.temperature_columns_),
            getattr(self, "boost_low_", self.data_min_[self.temperature_columns_]),
            getattr(self, "boost_high_", self.data_max_[self.temperature_columns_]),
        )

    def extend(
        self,
        *,
        threshold=None,
        rate_low=None,
        rate_high=None,
        temperature_low=None,
        temperature_high=None,
    ):
        """Widen the domain where held-out evidence says the model predicts well.

        A compensation pipeline calls it after fit with what its held-out runs showed
        (:mod:`sklearn_ifog._handover`): the model beat its fallback on rows that far
        beyond the other runs' domain. The threshold and the rate ranges only grow; the
        boost that holds rows beyond the calibrated rates and temperatures to ``margin``
        grows with the threshold. Without temperature and rate columns (no boost, no rate
        range) it changes nothing.

        Parameters
        ----------
        threshold : float, default=None
            A distance the threshold rises to (if larger).
        rate_low, rate_high : array-like of shape (n_rates,), default=None
            Rates the calibrated rate ranges widen to (if beyond them).
        temperature_low, temperature_high : array-like of shape (n_temperatures,), default=None
            Temperatures from which a row is held to ``margin`` (``boost_low_``,
            ``boost_high_``; if beyond them). A row beyond the calibrated temperatures is
            still outside (the firmware rule): this only lets the model keep more of its
            weight there, as far as the evidence reached.

        Returns
        -------
        self : CalibrationDomain

        Raises
        ------
        ValueError
            If the domain has temperature and rate columns and ``threshold`` is NaN, or a
            range is not of the shape above (one value per rate or temperature column) or
            holds a NaN; the domain is then left unchanged (a range of another length would
            broadcast, a NaN would become the range).

        Examples
        --------
        >>> import numpy as np
        >>> rng = np.random.default_rng(0)
        >>> t, rate = rng.uniform(10.0, 40.0, 150), rng.uniform(0.1, 0.3, 150)
        >>> domain = CalibrationDomain(temperature=0, rate=1).fit(
        ...     np.column_stack([t, rate]), groups=np.repeat([0, 1, 2], 50)
        ... )
        >>> bool(domain.predict([[25.0, 0.4]])[0] == -1)
        True
        >>> domain = domain.extend(threshold=3.0, rate_high=[0.45])
        >>> domain.threshold_, domain.boost_, domain.predict([[25.0, 0.4]]).tolist()
        (3.0, 1.5, [1])
        """
        check_is_fitted(self)
        if not (self.temperature_columns_ and self.rate_columns_):
            return self
        if threshold is not None and np.isnan(threshold):
            raise ValueError(f"threshold must be a distance, not NaN; got {threshold!r}.")
        widths = {
            "rate_low": (rate_low, len(self.rate_columns_), "rate"),
            "rate_high": (rate_high, len(self.rate_columns_), "rate"),
            "temperature_low": (temperature_low, len(self.temperature_columns_), "temperature"),
            "temperature_high": (temperature_high, len(self.temperature_columns_), "temperature"),
        }
        for name, (value, width, kind) in widths.items():
            if value is None:
                continue
            array = np.asarray(value, dtype=np.float64)
            if array.shape != (width,):
                raise ValueError(
                    f"{name} must hold one value per {kind} column of the domain: shape "
                    f"({width},), got {array.shape}."
                )
            if np.isnan(array).any():
                raise ValueError(f"{name} must not hold NaN, got {array.tolist()}.")
        if threshold is not None and threshold > self.threshold_:
            self.threshold_ = float(threshold)
            self.boost_ = self.threshold_ - float(self.margin)
            self.offset_ = -self.threshold_
        if rate_low is not None:
            self.rate_low_ = np.minimum(self.rate_low_, np.asarray(rate_low, dtype=np.float64))
        if rate_high is not None:
            self.rate_high_ = np.maximum(self.rate_high_, np.asarray(rate_high, dtype=np.float64))
        if temperature_low is not None:
            low = np.asarray(temperature_low, dtype=np.float64)
            self.boost_low_ = np.minimum(self.boost_low_, low)
        if temperature_high is not None:
            high = np.asarray(temperature_high, dtype=np.float64)
            self.boost_high_ = np.maximum(self.boost_high_, high)
        return self

    def _validated(self, X):
        check_is_fitted(self)
        return validate_data(self, X, dtype=np.float64, reset=False)

    def distance(self, X):
        """Distance of every row outside the calibrated box (0 inside).

        In decorrelated standard deviations: ``sqrt(sum_k (excess_k / axis_scale_k)²)``, plus
        under the root, for every ``rate`` column, the square of its excess beyond its
        calibrated range over ``rate_scale_`` (:func:`box_distance`).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of the features the domain was fitted on.

        Returns
        -------
        distance : ndarray of shape (n_samples,)
        """
        return box_distance(self.box_, self._validated(X))

    def temperature_excess(self, X):
        """Degrees by which the temperature columns lie beyond their calibrated ranges.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of the features the domain was fitted on.

        Returns
        -------
        excess : ndarray of shape (n_samples,)
            The largest over the ``temperature`` columns (0 inside, and without them).
        """
        return temperature_excess(
            self._validated(X), self.temperature_columns_, self.data_min_, self.data_max_
        )

    def score_samples(self, X):
        """Minus how far a row lies outside: higher is more typical.

        ``-distance`` while every temperature is inside its calibrated range; beyond it,
        ``-max(distance, threshold_ + excess / scale)`` (excess in degrees over that column's
        standard deviation), so that the row scores below every row inside.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of the features the domain was fitted on.

        Returns
        -------
        scores : ndarray of shape (n_samples,)
        """
        distance, beyond, _ = locate(self, self._validated(X))
        columns = self.temperature_columns_
        if not columns:
            return -distance
        scaled = beyond / self.scale_[columns].min()
        return -np.where(beyond > 0, np.maximum(distance, self.threshold_ + scaled), distance)

    def decision_function(self, X):
        """``score_samples + threshold_``: negative outside the domain.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of the features the domain was fitted on.

        Returns
        -------
        decision : ndarray of shape (n_samples,)
        """
        return self.score_samples(X) - self.offset_

    def predict(self, X):
        """+1 for rows inside the domain, −1 outside.

        Outside: farther than ``threshold_`` from the box, or a temperature beyond its
        calibrated range (:func:`outside_domain`).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of the features the domain was fitted on.

        Returns
        -------
        labels : ndarray of shape (n_samples,), dtype=int
        """
        return np.where(locate(self, self._validated(X)).outside, -1, 1)

    def excess(self, X):
        """How far every feature lies beyond its own calibrated range, in its units.

        Negative below the smallest calibrated value, positive above the largest, 0 inside
        (e.g. degrees below the coldest calibrated temperature). This per-feature view is for
        reading; whether a row is outside is decided by :meth:`distance`.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of the features the domain was fitted on.

        Returns
        -------
        excess : ndarray of shape (n_samples, n_features)
        """
        X = self._validated(X)
        return np.minimum(X - self.data_min_, 0.0) + np.maximum(X - self.data_max_, 0.0)

    def project(self, X):
        """The nearest point of the domain to every row (the ``"clip"`` policy).

        Onto the box widened by ``threshold_`` (:func:`project_to_box`) and every temperature
        clamped to its calibrated range, alternately (eight rounds), then onto the widened
        box once more and, where a temperature is then beyond its range, along the segment to
        the calibration's mean until it is not (:func:`pull_back_to_ranges`): the result lies
        in both, up to round-off, near the nearest such point.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of the features the domain was fitted on.

        Returns
        -------
        X_projected : ndarray of shape (n_samples, n_features)
            Rows inside unchanged; rows outside moved onto the domain's edge.
        """
        X = self._validated(X)
        columns = self.temperature_columns_
        if not columns:
            return project_to_box(self.box_, X, self.threshold_)
        low, high = self.data_min_[columns], self.data_max_[columns]
        # Alternating projections onto the widened box and the temperature ranges: both are
        # convex, so the rows converge into their intersection, but slowly where the two
        # meet at a narrow angle. A clamped temperature can leave a term it defines (a
        # gradient) far off a degenerate axis, so the rounds end on the box; the segment to
        # the mean, which the widened box holds, then brings the temperatures back into
        # range, a short way: their excess is small where the box's, on thin axes, was not.
        projected = X.copy()
        box = self.box_
        for _ in range(PROJECTION_ROUNDS):
            projected = project_to_box(box, projected, self.threshold_)
            projected[:, columns] = np.clip(projected[:, columns], low, high)
        projected = project_to_box(box, projected, self.threshold_)
        return pull_back_to_ranges(box, projected, columns, low, high)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags
