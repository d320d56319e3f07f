"""The numerics of the conformal bands (numpy in, numpy out), under
:class:`~sklearn_ifog.conformal.ConformalRegressor`.

Quantiles of conformity scores with the run as the unit of exchangeability
(:func:`conformal_quantile`, :func:`run_quantile_scores`), the CV+ interval
(:func:`plus_interval`), the difficulty's input (:func:`knn_distance`), the fold models'
disagreement (:func:`extrapolation_variance`) and the drift's slope in T that the band
carries beyond the calibrated temperatures (:func:`thermal_slope`). The public ones are
re-exported by :mod:`sklearn_ifog.conformal`, their documented home.
"""

import numbers

import numpy as np
from scipy.stats import norm
from sklearn.neighbors import NearestNeighbors

from sklearn_ifog import _table

__all__ = [
    "conformal_quantile",
    "extrapolation_variance",
    "knn_distance",
    "plus_interval",
    "run_quantile_scores",
    "thermal_slope",
]

# Neighbours averaged in the distance from the calibrated conditions.
_DIFFICULTY_NEIGHBORS = 10


def _as_numbers(values, name):
    """``values`` as a float array, or a TypeError naming ``name`` (text, objects)."""
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError) as error:
        raise TypeError(
            f"{name} must be an array of numbers; got {type(values).__name__}."
        ) from error


def _check_values(values, name, shape, what="finite", *, low=-np.inf, high=np.inf):
    """``values`` as a float array of ``shape``, finite and within [low, high].

    Otherwise a ValueError naming ``name``, the shape or the values it expected (``what``)
    and the first offending entry: a wrong length must not broadcast, a NaN must not pass
    into the bounds, nor a value out of range widen them silently.
    """
    array = _as_numbers(values, name)
    if array.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {array.shape}.")
    bad = ~np.isfinite(array) | (array < low) | (array > high)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        index = where[0] if len(where) == 1 else where
        raise ValueError(
            f"{name} must be {what}; got {float(array[where])!r} at index {index} "
            f"({int(bad.sum())} of {array.size} values)."
        )
    return array


def _check_level(level, name="level", *, closed=False):
    """A level in (0, 1) ([0, 1] if ``closed``) as a float; a ValueError naming ``name``."""
    interval = "[0, 1]" if closed else "(0, 1)"
    if isinstance(level, bool | np.bool_) or not isinstance(level, numbers.Real):
        raise TypeError(f"{name} must be a real number in {interval}, got {level!r}.")
    inside = 0.0 <= level <= 1.0 if closed else 0.0 < level < 1.0
    if not inside:  # NaN included
        raise ValueError(f"{name} must be a real number in {interval}, got {level!r}.")
    return float(level)


# --------------------------------------------------------------------------------------------
# Numerics (numpy in, numpy out)
# --------------------------------------------------------------------------------------------


def conformal_quantile(scores, level):
    """The conformal quantile of ``scores``: the ``ceil((n + 1) * level)``-th smallest.

    With ``n`` exchangeable scores and a new one exchangeable with them, the new score is
    at most this value with probability at least ``level`` (Vovk et al., 2005). When
    ``ceil((n + 1) * level) > n`` the guarantee needs more scores than there are; the
    largest score is returned (the guarantee is then approximate).

    Parameters
    ----------
    scores : array-like of shape (n_scores,) or (n_scores, n_samples)
        Scores, along the first axis.
    level : float
        Level in (0, 1).

    Returns
    -------
    quantile : float or ndarray of shape (n_samples,)
        The quantile along the first axis.

    Raises
    ------
    ValueError
        If ``scores`` is empty or holds a NaN or an infinity (a NaN would sort last and
        silently drop out of the quantile), or ``level`` is not in (0, 1).
    TypeError
        If ``level`` is not a real number.

    Examples
    --------
    >>> from sklearn_ifog.conformal import conformal_quantile
    >>> float(conformal_quantile([1.0, 2.0, 3.0, 4.0], 0.5))
    3.0
    """
    level = _check_level(level)
    scores = np.asarray(scores, dtype=float)
    if scores.ndim == 0 or scores.shape[0] == 0:
        raise ValueError(f"scores must hold at least one score, got shape {scores.shape}.")
    scores = _check_values(scores, "scores", scores.shape)
    n_scores = scores.shape[0]
    rank = min(int(np.ceil((n_scores + 1) * level)), n_scores)
    rank = max(rank, 1)
    return np.partition(scores, rank - 1, axis=0)[rank - 1]


def run_quantile_scores(scores, groups, level):
    """Each group's ``level`` quantile of its scores (one score per group).

    Parameters
    ----------
    scores : array-like of shape (n_samples,)
        Conformity scores of the rows.
    groups : array-like of shape (n_samples,)
        Group (run) of every row.
    level : float
        Quantile level in (0, 1) (linear interpolation within a group).

    Returns
    -------
    labels : ndarray of shape (n_groups,)
        The groups, in order of first appearance.
    group_scores : ndarray of shape (n_groups,)
        The quantile of each group's scores.

    Raises
    ------
    ValueError
        If ``groups`` does not hold one label per score, or ``level`` is not in [0, 1].

    Examples
    --------
    >>> from sklearn_ifog.conformal import run_quantile_scores
    >>> labels, q = run_quantile_scores([1.0, 2.0, 3.0, 10.0, 20.0], [0, 0, 0, 1, 1], 0.5)
    >>> labels.tolist(), q.tolist()
    ([0, 1], [2.0, 15.0])
    """
    level = _check_level(level, closed=True)
    scores = np.asarray(scores, dtype=float)
    groups = np.asarray(groups)
    if scores.ndim != 1 or groups.shape != scores.shape:
        raise ValueError(
            "groups must hold one label per score: scores and groups of shape (n_samples,), "
            f"got {scores.shape} and {groups.shape}."
        )
    segments = _table.run_segments(groups, scores.shape[0])
    labels = np.array([label for label, _ in segments])
    group_scores = np.array([np.quantile(scores[rows], level) for _, rows in segments])
    return labels, group_scores


def plus_interval(predictions, scale, group_scores, group_fold, level):
    """CV+ bounds with one score per calibration group (Barber et al., 2021, by group).

    For every calibration group ``g`` (out of fold ``k(g)``) and every test row ``x`` the
    candidates are ``pred_k(g)(x) -/+ scale(x) * s_g``; the lower bound is the conformal
    ``1 - level`` quantile of the lower candidates (taken as minus the conformal ``level``
    quantile of their negatives), the upper bound the conformal ``level`` quantile of the
    upper ones.

    Parameters
    ----------
    predictions : ndarray of shape (n_folds, n_samples)
        Prediction of each fold's model.
    scale : ndarray of shape (n_samples,)
        Difficulty estimate of each test row (1 for an absolute score).
    group_scores : ndarray of shape (n_groups,)
        Score of each calibration group.
    group_fold : ndarray of int of shape (n_groups,)
        Fold whose model did not see each group.
    level : float
        Level in (0, 1) of the conformal quantile over the groups.

    Returns
    -------
    bounds : ndarray of shape (n_samples, 2)
        Lower and upper bound of every row.

    Raises
    ------
    ValueError
        If ``scale`` does not hold one value per row of ``predictions``, ``group_fold`` one
        fold per group score, or a fold that ``predictions`` does not have.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.conformal import plus_interval
    >>> plus_interval(
    ...     np.array([[0.0], [1.0]]), np.ones(1), np.array([1.0, 2.0]), np.array([0, 1]), 0.5
    ... )
    array([[-1.,  3.]])
    """
    predictions = np.asarray(predictions, dtype=float)
    if predictions.ndim != 2:
        raise ValueError(
            f"predictions must have shape (n_folds, n_samples), got {predictions.shape}."
        )
    scale = np.asarray(scale, dtype=float)
    group_scores = np.asarray(group_scores, dtype=float)
    group_fold = np.asarray(group_fold)
    if scale.shape != predictions.shape[1:]:
        raise ValueError(
            f"scale must hold one value per row: shape ({predictions.shape[1]},), got "
            f"{scale.shape}."
        )
    if group_scores.ndim != 1 or group_fold.shape != group_scores.shape:
        raise ValueError(
            "group_fold must hold one fold per group score: group_scores and group_fold of "
            f"shape (n_groups,), got {group_scores.shape} and {group_fold.shape}."
        )
    n_folds = predictions.shape[0]
    if group_fold.dtype.kind not in "iu" or np.any((group_fold < 0) | (group_fold >= n_folds)):
        raise ValueError(
            f"group_fold must hold fold indices in [0, {n_folds}) (one per row of "
            f"predictions), got {group_fold.tolist()}."
        )
    centre = predictions[group_fold]  # (n_groups, n_samples)
    spread = group_scores[:, None] * scale[None, :]
    lower = -conformal_quantile(-(centre - spread), level)
    upper = conformal_quantile(centre + spread, level)
    return np.column_stack([lower, upper])


def knn_distance(reference, query, n_neighbors=_DIFFICULTY_NEIGHBORS):
    """Mean Euclidean distance from each query row to its nearest reference rows.

    The difficulty model's input: how far a row lies from the conditions a model was fitted
    on (a colder temperature, a faster ramp, a thermal history no calibration run had).

    Parameters
    ----------
    reference : ndarray of shape (n_reference, n_features)
        Rows the model was fitted on.
    query : ndarray of shape (n_queries, n_features)
        Rows to measure.
    n_neighbors : int, default=10
        Number of nearest reference rows averaged (at most ``n_reference``).

    Returns
    -------
    distance : ndarray of shape (n_queries,)
        Mean distance to the ``n_neighbors`` nearest reference rows.

    Raises
    ------
    ValueError
        If ``query`` has not as many columns as ``reference``, or ``n_neighbors`` is below 1.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.conformal import knn_distance
    >>> reference = np.array([[0.0], [1.0], [2.0]])
    >>> knn_distance(reference, np.array([[0.0], [5.0]]), n_neighbors=2).tolist()
    [0.5, 3.5]
    """
    reference = np.asarray(reference, dtype=float)
    query = np.asarray(query, dtype=float)
    if reference.ndim != 2 or query.ndim != 2 or query.shape[1] != reference.shape[1]:
        raise ValueError(
            "reference and query must be 2-D with the same number of columns "
            f"(n_features), got shapes {reference.shape} and {query.shape}."
        )
    if isinstance(n_neighbors, bool) or not isinstance(n_neighbors, numbers.Integral):
        raise TypeError(f"n_neighbors must be an integer >= 1, got {n_neighbors!r}.")
    if n_neighbors < 1:
        raise ValueError(f"n_neighbors must be an integer >= 1, got {n_neighbors!r}.")
    n_neighbors = min(int(n_neighbors), reference.shape[0])
    tree = NearestNeighbors(n_neighbors=n_neighbors).fit(reference)
    return tree.kneighbors(query, return_distance=True)[0].mean(axis=1)


def extrapolation_variance(predictions, reference):
    """The jackknife variance of the prediction beyond its level on the calibrated conditions.

    With ``K`` fold models, each fitted without one part of the calibration runs, the
    delete-a-group jackknife estimates the variance of the full model's prediction at ``x``
    as ``(K - 1)`` times the variance of the fold predictions there (Efron & Stein, 1981).
    Under the calibrated conditions the out-of-fold residuals hold that variance already, so
    only its excess over ``reference`` is returned: zero where the fold models agree as they
    do on the calibration rows, large where they part (a colder run, a faster ramp: the
    models extrapolate, each its own way).

    Parameters
    ----------
    predictions : ndarray of shape (n_folds, n_samples)
        Prediction of each fold's model.
    reference : float
        The fold-prediction variance regarded as calibrated (the estimator takes a high
        quantile of it over the calibration rows).

    Returns
    -------
    variance : ndarray of shape (n_samples,)
        ``(K - 1) * max(0, var_k(predictions) - reference)``.

    Raises
    ------
    ValueError
        If ``reference`` is negative or not finite (a negative one would widen every band,
        a NaN one give NaN variances).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.conformal import extrapolation_variance
    >>> predictions = np.array([[0.0, 1.0], [0.0, -1.0], [0.0, 0.0]])
    >>> extrapolation_variance(predictions, reference=0.5).round(3).tolist()
    [0.0, 0.333]
    """
    _check_values(reference, "reference", (), "a finite variance >= 0", low=0.0)
    predictions = np.asarray(predictions, dtype=float)
    n_folds = predictions.shape[0]
    excess = np.maximum(predictions.var(axis=0) - reference, 0.0)
    return (n_folds - 1) * excess


def _widen(bounds, variance, coverage):
    """``bounds`` widened about their middle by ``variance`` in quadrature, at the normal
    quantile of ``coverage`` (unchanged where ``variance`` is zero)."""
    if not np.any(variance > 0):
        return bounds
    middle = bounds.mean(axis=1)
    half = np.sqrt(
        np.square((bounds[:, 1] - bounds[:, 0]) / 2) + norm.ppf((1 + coverage) / 2) ** 2 * variance
    )
    return np.column_stack([middle - half, middle + half])


def thermal_slope(temperature, y):
    """Least-squares slope of ``y`` on ``temperature`` (0 for a single temperature).

    The drift per degree of a line in T through the calibration rows. Beyond the calibrated
    temperatures the drift may go on at its slope or stop (the firmware's hold at the
    edge), and the calibration cannot tell which, so :class:`ConformalRegressor` widens its
    band there by a slope times the degrees beyond: its fallback's slope in T, or this one
    when the fallback is a constant.

    Parameters
    ----------
    temperature : array-like of shape (n_samples,)
        T of the calibration rows.
    y : array-like of shape (n_samples,)
        Their targets.

    Returns
    -------
    slope : float

    Raises
    ------
    ValueError
        If ``temperature`` and ``y`` differ in length.

    Examples
    --------
    >>> thermal_slope([10.0, 20.0, 30.0], [1.0, 3.0, 5.0])
    0.2
    >>> thermal_slope([25.0, 25.0], [1.0, 2.0])
    0.0
    """
    temperature = np.asarray(temperature, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if y.shape != temperature.shape:
        raise ValueError(
            "temperature and y must hold one value per calibration row each, got "
            f"{temperature.shape[0]} and {y.shape[0]} values."
        )
    centred = temperature - temperature.mean()
    spread = float(centred @ centred)
    if spread == 0.0:
        return 0.0
    return float(centred @ (y - y.mean()) / spread)


def _cover_both(bounds, centre, extrapolation):
    """``bounds`` stretched to hold the band moved onto ``extrapolation`` as well.

    Outside the calibration domain the prediction (``centre``) is the regressor's
    extrapolation moved towards the fallback; which of the two holds out there the
    calibration cannot say, so the band spans both: its hull with itself shifted by
    ``extrapolation - centre`` (unchanged where they are equal, e.g. inside the domain).
    """
    shift = np.asarray(extrapolation, dtype=float).reshape(centre.shape) - centre
    return np.column_stack(
        [bounds[:, 0] + np.minimum(shift, 0.0), bounds[:, 1] + np.maximum(shift, 0.0)]
    )
