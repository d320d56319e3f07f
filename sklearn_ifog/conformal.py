"""Prediction intervals that hold run by run: adaptive, run-wise cross-conformal regression.

:class:`ConformalRegressor` wraps a drift model and gives every prediction an interval
``[lower, upper]`` meant to hold the true drift ``coverage`` of the time *on each run*, not
only on average over all rows. Three things differ from row-wise conformal prediction (MAPIE's
``CrossConformalRegressor`` with ``KFold``):

1. **The run is the unit of exchangeability.** Rows of one thermal-test run are strongly
   correlated (the residual of a model is a slow function of the thermal history), so rows
   are not exchangeable, runs are. The out-of-fold scores of each calibration run are reduced
   to one number, the run's ``coverage`` quantile, and the conformal quantile (level
   ``run_probability``) is then taken over runs: a new run like the calibration runs holds
   its drift at least ``coverage`` of its time with probability at least
   ``run_probability``. (``coverage`` is the analogue of MAPIE's ``confidence_level``, per
   run's time; ``run_probability`` has no MAPIE analogue.)
2. **The band is adaptive.** The score of a row is its absolute out-of-fold residual divided
   by a difficulty estimate ``sigma(x)``, computed causally from the model's own features
   (for the compensation pipeline: T, dT, T·dT and the temperature lags, standardised):
   ``sigma(x)^2`` is a linear model of the squared residual on the mean distance from ``x``
   to its 10 nearest rows of the data the predicting model was fitted on
   (:func:`knn_distance`), cross-fitted over the same folds so that a calibration row is
   never measured against its own run nor normalised by a model of its own residual. A run
   unlike the calibration runs (colder, faster ramps, a thermal history none of them had)
   lies far from them and gets a wider band, not a silently wrong one.
3. **The band widens where the fold models part.** Where the drift model extrapolates, the
   fold models (each fitted without part of the runs) disagree; their delete-a-group
   jackknife variance beyond its level on the calibration rows
   (:func:`extrapolation_variance`) is added to the band in quadrature. Under the calibrated
   conditions the out-of-fold residuals hold that variance already, and the band is the
   CV+ band alone.
4. **Outside the calibration domain the band holds the fallback, the slope and the
   extrapolation.** Around a :class:`~sklearn_ifog.pipeline.CompensationPipeline` the fold
   models are clones with its ``uncalibrated`` policy, so their out-of-fold residuals measure the
   model as it predicts. With ``uncalibrated="blend"`` the prediction moves, beyond the domain, to
   a fallback (a plane in T and dT, a line in T or a constant) that every fold model shares,
   so the fold models agree there and the jackknife term sees nothing. Three terms replace
   it, all zero inside the domain: the fallback's own out-of-fold error quantile (each fold
   model's fallback on the runs it did not see, calibrated run-wise like the scores), times
   the fallback's share of the prediction, joins the band in quadrature; beyond the
   calibrated temperatures, the drift may go on at its calibrated slope or stop (the
   firmware's hold, a potting's glass transition), which the calibration cannot tell apart,
   so the slope (``thermal_slope_``) times the degrees beyond joins in quadrature too; and
   since the calibration cannot say whether the fallback or the regressor's own
   extrapolation holds out there, the band is stretched to hold both (``_cover_both``).
   ``python benchmarks/bench_conformal.py --quick`` (one campaign;
   ``benchmarks/results/conformal_quick.md``) covers 0.938-0.995 of the rows outside the
   domain on its four splits, calibrate-warm / predict-cold included (0.956, at 2.45 times
   the width inside; ``conformal_quick.md`` rows "lumped seed 0 | * | ours" columns
   "coverage outside" and "width outside / inside"). The constant band (``adaptive=False``,
   without them) and MAPIE's cover 0.405-0.947 of the same rows (``conformal_quick.md`` rows
   "lumped seed 0 | * | ours_flat", "lumped seed 0 | * | mapie_rows" and "lumped seed 0 | * |
   mapie_runs" column "coverage outside").
   Without the slope term that split was covered 0.674 (``conformal.md`` row "lumped seed 0
   | warm->cold | ours" at commit a3eca12).

Why this difficulty. On the nine campaigns of ``benchmarks/bench_conformal.py`` it was
chosen on (three physics presets x seeds 0-2, 36 held-out folds; that benchmark also runs
seeds 4211-4213, held out from every choice) and on seeds 4281-4282 that were not looked at
while choosing, ``nice -n 10 python benchmarks/conformal_difficulty_check.py``
(``benchmarks/results/conformal_difficulty.md``) compares it, on the same out-of-fold
residuals, with a constant band, with the first build's ridge model of ``|r|`` on the
features and their magnitudes, and with the distance model without the jackknife widening.
The check's variants leave out the band's terms outside the calibration domain (above), so
none of them alone holds the runs calibrated warm and tested 7 to 14 degC colder on the glass
transition: the default difficulty's lowest coverage there is 0.653 and 0.702 on the two
seed sets, and 0.644 and 0.685 without the widening (``conformal_difficulty.md`` rows
"distance" and "distance, no jackknife" column "out-of-range coverage"). Its mean width is
1.14 and 1.12 times the oracle's (``conformal_difficulty.md`` row "distance" column "width /
oracle (mean)"; the user guide has the table). With those terms the estimator covers that
split at least 0.942 on seeds 0-2 (``python benchmarks/bench_conformal.py`` row "ours" column
"out-of-range coverage" under "seed(s) 0, 1, 2"). The held-out folds that still fall below
``0.85`` (2 of 36, and 6 of 24 on seeds 4281-4282, ``conformal_difficulty.md`` row
"distance" column "folds below") are whole runs, or a whole heading's runs, offset by about
one calibration r.m.s. error (a turn-on bias, a thermal history the model fits badly):
nothing visible at prediction time ranks them (the same script's fold-level correlations),
so no difficulty model can widen the band for them alone; only a wider band everywhere (a
higher ``run_probability``) covers them, at a cost in width that the script also measures.

Why not MAPIE: MAPIE 1.x takes the conformal quantile over rows (there is no per-group
aggregation of scores before the quantile), and its adaptive score
(``ResidualNormalisedScore``) is documented for split and prefit conformal only, not for the
cross-conformal (CV+) methods. The calibration here is a few lines of numpy
(:func:`run_quantile_scores`, :func:`conformal_quantile`, :func:`plus_interval`), so the
estimator needs only scikit-learn; MAPIE is used in ``benchmarks/bench_conformal.py`` as the
peer it is measured against.
"""

import numbers
import warnings
from typing import ClassVar

import numpy as np
import scipy.sparse as sp
from scipy.stats import norm
from sklearn.base import BaseEstimator, MetaEstimatorMixin, RegressorMixin, clone
from sklearn.linear_model import Ridge
from sklearn.model_selection import GroupKFold, KFold, LeaveOneGroupOut, check_cv
from sklearn.pipeline import Pipeline
from sklearn.utils import check_array
from sklearn.utils.metadata_routing import MetadataRouter, MethodMapping, process_routing
from sklearn.utils.metaestimators import available_if
from sklearn.utils.parallel import Parallel, delayed
from sklearn.utils.validation import (
    check_consistent_length,
    check_is_fitted,
    column_or_1d,
    validate_data,
)

from sklearn_ifog import _table
from sklearn_ifog._compat import (
    HasMethods,
    Interval,
    StrOptions,
    _check_method_params,
    _fit_context,
    _routing_enabled,
    _safe_indexing,
)
from sklearn_ifog._conformal_numerics import (
    _as_numbers,
    _check_values,
    _cover_both,
    _widen,
    conformal_quantile,
    extrapolation_variance,
    knn_distance,
    plus_interval,
    run_quantile_scores,
    thermal_slope,
)
from sklearn_ifog.domain import OutsideCalibrationWarning, locate, threshold_of
from sklearn_ifog.policy import fallback_weight

__all__ = [
    "ConformalRegressor",
    "conformal_quantile",
    "extrapolation_variance",
    "knn_distance",
    "plus_interval",
    "run_quantile_scores",
    "thermal_slope",
]

# The difficulty model (why this one: the module notes and
# ``python benchmarks/conformal_difficulty_check.py``): sigma(x)^2 is a linear model of the
# squared out-of-fold residual on one input, the mean distance from x to its
# _DIFFICULTY_NEIGHBORS nearest rows of the data the predicting model was fitted on (in the
# standardised features). Floor of sigma^2, as a fraction of the mean squared residual: a
# linear model can reach zero or below; a zero difficulty would give a zero-width band.
_DIFFICULTY_FLOOR = 0.5
# The difficulty enters the score as (sigma / mean sigma) ** _DIFFICULTY_POWER: the square root
# keeps the band adaptive while damping the extrapolation of a model fitted on a few runs
# (power 1 gave wider bands for the same worst-fold coverage on the benchmark's campaigns).
_DIFFICULTY_POWER = 0.5
# Ridge penalty of the difficulty model (its input is standardised).
_DIFFICULTY_ALPHA = 1.0
# The fold models' disagreement widens the band only where it exceeds this quantile of its
# values on the calibration rows (see ``extrapolation_variance``): the out-of-fold residuals
# already hold the model's variance under the calibrated conditions, so rows like the
# calibration rows keep the CV+ band. ``benchmarks/conformal_difficulty_check.py`` measures
# it against the median (wider bands everywhere) and the maximum (less widening out of
# range).
_EXTRAPOLATION_REFERENCE = 0.95


def _blends(model):
    """Whether ``model`` moves to a fallback outside its calibration domain."""
    # The calibration protocol: a model whose policy takes a fallback offers its share.
    return hasattr(model, "fallback_share") and hasattr(model, "fallback_predict")


def _fallback_features(model, X):
    """X through the feature step of a fitted CompensationPipeline, as an array."""
    features = model.steps[0][1].transform(X)
    if hasattr(features, "to_numpy"):
        features = features.to_numpy()
    return np.asarray(features, dtype=float)


def _fallback_prediction(model, X):
    """The fallback's prediction (first output) of a fitted CompensationPipeline for X."""
    predicted = np.asarray(model.fallback_predict(X), dtype=np.float64)
    return predicted if predicted.ndim == 1 else predicted[:, 0]


def _fit_fold(estimator, X, y, train, test, predict_all, params):
    """One fold of :meth:`ConformalRegressor.fit` (a joblib task).

    Returns (the clone fitted on the ``train`` rows, its prediction of the ``test`` rows,
    its fallback's prediction of them (None without the ``"blend"`` policy), and its
    prediction of every row if ``predict_all``, else None). ``train=None``: the clone fitted
    on all rows, and nothing else. ``params``: the fit parameters of the ``train`` rows.
    """
    if train is None:
        return clone(estimator).fit(X, y, **params), None, None, None
    with warnings.catch_warnings():
        # A held-out run outside its fold model's calibration domain is expected: its
        # residual then measures the model's uncalibrated policy, as a new run would.
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        model = clone(estimator).fit(_safe_indexing(X, train), y[train], **params)
        held_out = _safe_indexing(X, test)
        prediction = np.asarray(model.predict(held_out), dtype=float)
        fallback = _fallback_prediction(model, held_out) if _blends(model) else None
        on_rows = np.asarray(model.predict(X), dtype=float) if predict_all else None
    return model, prediction, fallback, on_rows


def _reissue(caught, skip=()):
    """Warn again, once each, the recorded warnings not of a ``skip`` category."""
    seen = set()
    for record in caught:
        key = (record.category, str(record.message))
        if issubclass(record.category, skip) or key in seen:
            continue
        seen.add(key)
        warnings.warn(record.message, stacklevel=3)


def _fit_difficulty(distance, sq_residual):
    """A linear model of the squared residual on the distance; returns (model, floor)."""
    model = Ridge(alpha=_DIFFICULTY_ALPHA).fit(distance[:, None], sq_residual)
    floor = _DIFFICULTY_FLOOR * float(np.mean(sq_residual))
    return model, max(floor, np.finfo(float).tiny)


def _predict_difficulty(model, floor, distance):
    """sigma(x): the square root of the floored variance model."""
    return np.sqrt(np.maximum(model.predict(distance[:, None]), floor))


def _soften(sigma, mean):
    """The difficulty as it scales the scores: (sigma / mean) ** _DIFFICULTY_POWER."""
    return (sigma / mean) ** _DIFFICULTY_POWER


# --------------------------------------------------------------------------------------------
# The estimator
# --------------------------------------------------------------------------------------------


def _check_input(estimator, X, *, reset):
    """X checked: column count and names; a DataFrame is kept as given (it carries the run
    column), anything else becomes a 2-D array (values are the estimator's to check)."""
    if sp.issparse(X):
        raise TypeError(
            "ConformalRegressor does not support sparse input; pass a dense array or a DataFrame."
        )
    if not _table.frame_kind(X):
        X = check_array(
            X, dtype=None, ensure_all_finite=False, ensure_min_samples=2 if reset else 1
        )
    validate_data(estimator, X, skip_check_array=True, reset=reset)
    return X


def _test_fold_of_rows(splits, n_samples):
    """The test fold of every row: ``splits`` must put each row in exactly one test fold."""
    fold_of = np.full(n_samples, -1)
    for k, (_, test) in enumerate(splits):
        if np.any(fold_of[test] >= 0):
            raise ValueError(f"cv puts row(s) in two test folds (fold {k}); use a partition.")
        fold_of[test] = k
    if np.any(fold_of < 0):
        raise ValueError(
            f"cv leaves {int(np.sum(fold_of < 0))} row(s) out of every test fold; every "
            "row must be in exactly one test fold (e.g. GroupKFold, LeaveOneGroupOut)."
        )
    return fold_of


class ConformalRegressor(MetaEstimatorMixin, RegressorMixin, BaseEstimator):
    """Adaptive prediction intervals calibrated run by run (cross-conformal, CV+).

    ``fit`` cross-validates ``estimator`` with the run (or the given group) as the unit:
    each fold's model predicts the runs it did not see, giving out-of-fold residuals. A
    difficulty model ``sigma(x)`` (a linear model of the squared residual on the distance
    from ``x`` to the rows the predicting model was fitted on, cross-fitted) normalises
    them; each run keeps the ``coverage`` quantile of its normalised scores, and the bands
    are the conformal quantile of those per-run scores (``method="plus"``: the CV+
    construction, each fold's model carrying the scores of the runs it did not see). Where
    the fold models disagree more than they do on the calibration rows (the model
    extrapolates), their jackknife variance widens the band in quadrature (``adaptive``
    only). ``predict`` is the prediction of ``estimator`` refitted on all rows.

    Around a :class:`~sklearn_ifog.pipeline.CompensationPipeline` with ``uncalibrated="blend"``
    (``adaptive`` only), rows outside the full model's calibration domain get a wider band:
    the fallback's out-of-fold error quantile (``fallback_quantile_``) times its share of
    the prediction joins in quadrature, so does the calibrated drift per degree
    (``thermal_slope_``) times the degrees beyond the calibrated temperatures, and the band
    is stretched to hold the regressor's own extrapolation as well as the prediction.
    Inside the domain the band is unchanged.

    See the module notes (:mod:`sklearn_ifog.conformal`) for why the run and not the row,
    why this is not MAPIE, and the band outside the calibration domain.

    Parameters
    ----------
    estimator : regressor
        The drift model (e.g. :func:`~sklearn_ifog.make_compensation_pipeline`). Cloned.
        When it is a :class:`~sklearn.pipeline.Pipeline`, the difficulty model reads the
        output of its steps before the last (the thermal features, scaled); otherwise it
        reads the numeric columns of X.
    coverage : float, default=0.9
        Like MAPIE's ``confidence_level``, per run's time: the nominal fraction, in (0, 1),
        of a run's time its drift should lie inside the band (see ``run_probability`` for
        the probability over runs that a run meets it).
    cv : int, cross-validation generator or iterable, default=None
        How the calibration runs are split. None: one fold per group (run), i.e.
        :class:`~sklearn.model_selection.LeaveOneGroupOut`. An int ``k``:
        :class:`~sklearn.model_selection.GroupKFold` ``(k)`` over the groups (a plain
        :class:`~sklearn.model_selection.KFold` when there are no groups). Any scikit-learn
        splitter, called with the groups; every row must be in exactly one test fold.
    method : {"plus", "base", "minmax"}, default="plus"
        ``"plus"``: CV+ (each calibration run's score around the prediction of the model
        that did not see it); ``"base"``: the full model's prediction plus/minus
        ``sigma(x) * q``; ``"minmax"``: from the lowest to the highest fold prediction,
        widened by ``sigma(x) * q`` (conservative).
    run_probability : float, default=0.6
        The probability, in (0, 1), that a new run like the calibration runs meets
        ``coverage`` (holds its drift inside the band at least ``coverage`` of its time).
        It is the level of the conformal quantile taken over the runs' scores, and the band
        widens as it grows; MAPIE has no such level (its ``confidence_level`` is
        ``coverage``). With ``coverage=0.9``, ``run_probability=0.6`` gives mean held-out
        coverages of 0.900-0.948 on the campaigns it was chosen on (seeds 0-2) and
        0.877-0.949 on held-out ones (seeds 8-10) in ``python benchmarks/bench_conformal.py``
        (``benchmarks/results/conformal.md`` rows "ours" column "mean coverage").
    adaptive : bool, default=True
        Whether scores are normalised by the difficulty model and the band widened where
        the fold models part and outside the calibration domain; False gives a band of the
        same width everywhere (absolute residual scores).
    n_jobs : int, default=None
        Number of fold models (and the model on all rows) fitted at once, through
        :class:`sklearn.utils.parallel.Parallel`: ``None`` one at a time unless in a
        :func:`joblib.parallel_config` context, ``-1`` all cores. The results do not depend
        on it; with ``joblib.parallel_config(backend="dask")`` the fits go to a Dask cluster.

    Attributes
    ----------
    estimator_ : estimator
        ``estimator`` fitted on all rows (gives ``predict``).
    estimators_ : list of estimator
        One fitted clone per fold.
    groups_ : ndarray of shape (n_groups,)
        The calibration groups (runs), in order of first appearance.
    group_scores_ : ndarray of shape (n_groups,)
        Each group's ``coverage`` quantile of its normalised out-of-fold scores.
    group_fold_ : ndarray of shape (n_groups,)
        The fold that held each group out.
    quantile_ : float
        The conformal quantile of ``group_scores_`` (used by ``"base"`` and ``"minmax"``).
    oof_prediction_ : ndarray of shape (n_samples,)
        Out-of-fold prediction of every training row.
    scores_ : ndarray of shape (n_samples,)
        Normalised out-of-fold score of every training row (``|y - oof| / sigma``).
    score_groups_ : ndarray of shape (n_samples,)
        Group of every training row (the row number when there are no groups).
    feature_mean_, feature_scale_ : ndarray of shape (n_difficulty_features,)
        Mean and standard deviation (1 where zero) of the difficulty model's inputs over the
        training rows (only when ``adaptive``).
    calibration_features_ : ndarray of shape (n_samples, n_difficulty_features)
        The difficulty model's inputs of the training rows, standardised (only when
        ``adaptive``): the distance from the calibrated conditions is measured to these.
    distance_scale_ : float
        Standard deviation of the calibration rows' cross-fitted distances (only when
        ``adaptive``); distances are divided by it.
    difficulty_ : Ridge
        The variance model ``sigma(x)^2`` on the scaled distance (only when ``adaptive``).
    fallback_scores_ : ndarray of shape (n_samples,) or None
        Absolute out-of-fold error of the fold models' fallbacks (each on the runs it did
        not see), when ``estimator`` is a CompensationPipeline with ``uncalibrated="blend"``
        and ``adaptive``; None otherwise.
    fallback_quantile_ : float
        The conformal quantile (level ``run_probability``) of the runs' ``coverage`` quantiles of
        ``fallback_scores_`` (0 without them): the fallback's error band, which widens the
        band in proportion to the fallback's share of a prediction outside the domain.
    thermal_slope_ : float
        The calibration's drift per degree, with ``fallback_scores_`` (0 otherwise): the
        temperature slope of the full model's fallback (a line or a plane in T and dT), or,
        for a constant fallback, :func:`thermal_slope` of the target on the temperature.
        Beyond the calibrated temperatures the band widens, in quadrature, by this slope
        times the degrees beyond (at the coverage of fit; in proportion at another).
    fold_variance_reference_ : float
        The ``0.95`` quantile, over the calibration rows, of the variance of the fold models'
        predictions (only when ``adaptive``): where the fold models part by more, the
        band widens by their jackknife variance (:func:`extrapolation_variance`).
    n_features_in_ : int
        Number of columns of X seen during fit.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Column names of X, when X has string column names.

    Raises
    ------
    ValueError
        If ``coverage`` is outside (0, 1); if there are fewer than two groups to calibrate
        on; if ``groups`` does not have one label per row; if X has no ``run`` column, no
        ``groups`` are given and ``cv`` is None; if ``cv`` leaves a row out of every test
        fold or puts it in two.

    See Also
    --------
    sklearn_ifog.metrics.interval_coverage : Fraction of the truth inside the band.
    sklearn_ifog.metrics.mean_interval_width : Mean width of the band.
    sklearn_ifog.metrics.interval_score : Winkler score of the band.

    References
    ----------
    R. F. Barber, E. J. Candès, A. Ramdas, R. J. Tibshirani, "Predictive inference with the
    jackknife+", Annals of Statistics 49(1), 2021. J. Lei, M. G'Sell, A. Rinaldo,
    R. J. Tibshirani, L. Wasserman, "Distribution-free predictive inference for regression",
    JASA 113(523), 2018 (normalised scores).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import ConformalRegressor
    >>> rng = np.random.RandomState(0)
    >>> X = rng.uniform(-1, 1, size=(600, 1))
    >>> y = 2 * X[:, 0] + rng.normal(scale=0.1, size=600)
    >>> runs = np.repeat(np.arange(12), 50)
    >>> model = ConformalRegressor(LinearRegression(), coverage=0.9).fit(X, y, groups=runs)
    >>> bounds = model.predict_interval(X)
    >>> bounds.shape
    (600, 2)
    >>> bool(np.all(bounds[:, 0] <= model.predict(X)))
    True
    >>> ConformalRegressor(LinearRegression()).fit(X, y, groups=np.zeros(600))
    Traceback (most recent call last):
    ...
    ValueError: ConformalRegressor needs at least two groups (runs) to calibrate on, got 1.
    """

    _parameter_constraints: ClassVar[dict] = {
        "estimator": [HasMethods(["fit", "predict"])],
        "coverage": [Interval(numbers.Real, 0, 1, closed="neither")],
        "cv": ["cv_object", None],
        "method": [StrOptions({"plus", "base", "minmax"})],
        "run_probability": [Interval(numbers.Real, 0, 1, closed="neither")],
        "adaptive": ["boolean"],
        "n_jobs": [numbers.Integral, None],
    }

    # the calibration folds follow the groups: always consumed by fit itself
    __metadata_request__fit: ClassVar[dict] = {"groups": True}

    def __init__(
        self,
        estimator,
        *,
        coverage=0.9,
        cv=None,
        method="plus",
        run_probability=0.6,
        adaptive=True,
        n_jobs=None,
    ):
        self.estimator = estimator
        self.coverage = coverage
        self.cv = cv
        self.method = method
        self.run_probability = run_probability
        self.adaptive = adaptive
        self.n_jobs = n_jobs

    # -- helpers ------------------------------------------------------------------------------

    def _groups(self, X, groups, n_samples):
        if groups is not None:
            groups = np.asarray(groups)
            if groups.ndim != 1 or groups.shape[0] != n_samples:
                raise ValueError(
                    f"groups must have one label per row of X: shape ({n_samples},), got "
                    f"{groups.shape}."
                )
            return groups
        position = _table.find_column(X, "run") if _table.frame_kind(X) else None
        if position is not None:
            return np.asarray(_table.column_at(X, position))
        if self.cv is None:
            raise ValueError(
                "ConformalRegressor calibrates run by run: X has no 'run' column and groups "
                "is None; pass groups= (the run of every row), or an explicit cv."
            )
        return None

    def _splits(self, X, y, groups):
        if self.cv is None:
            cv = LeaveOneGroupOut()
        elif isinstance(self.cv, numbers.Integral):
            cv = GroupKFold(n_splits=self.cv) if groups is not None else KFold(self.cv)
        else:
            cv = check_cv(self.cv)
        return list(cv.split(X, y, groups))

    # -- fit / predict -------------------------------------------------------------------------

    @_fit_context(
        # The wrapped estimator validates its own parameters.
        prefer_skip_nested_validation=False
    )
    def fit(self, X, y, groups=None, **fit_params):
        """Fit the model on all rows and calibrate the bands on out-of-fold residuals.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_columns)
            Training data, as ``estimator`` takes it (for the compensation pipeline a
            thermal-test table with a ``run`` column).
        y : array-like of shape (n_samples,)
            Target (the drift, deg/h).
        groups : array-like of shape (n_samples,), default=None
            Group (run) of every row; None reads X's ``run`` column.
        **fit_params : dict
            Passed to ``estimator.fit`` (each fold model's with its training rows: arrays
            of one value per row are cut). With
            ``sklearn.set_config(enable_metadata_routing=True)`` only what ``estimator``
            requests is routed to it, ``groups`` included (e.g.
            ``RBFNetRegressor().set_fit_request(groups=True)``), and anything else is
            scikit-learn's error.

        Returns
        -------
        self : object
            Fitted estimator.

        Raises
        ------
        ValueError
            If ``estimator`` is a scale-factor model (``input_rate`` set): its band would
            be read from the bias and scale-factor pair its regressor predicts, which no
            band here is calibrated for.
        """
        if getattr(self.estimator, "input_rate", None) is not None:
            raise ValueError(
                "ConformalRegressor does not take a scale-factor model (input_rate="
                f"{self.estimator.input_rate!r}): its regressor predicts the bias and the "
                "scale-factor error, not the drift the band is calibrated on. Fit the model "
                "alone, or a bias-only model (input_rate=None) for intervals."
            )
        X, y, groups, unit = self._fit_input(X, y, groups)
        n_samples = y.shape[0]
        splits = self._splits(X, y, groups)
        if _routing_enabled():
            routed = {} if groups is None else {"groups": groups}
            params = process_routing(self, "fit", **routed, **fit_params).estimator.fit
        else:
            params = fit_params
        fold_of = _test_fold_of_rows(splits, n_samples)
        oof, oof_fallback, on_calibration = self._fit_folds(X, y, splits, params)
        self.oof_prediction_ = oof
        residual = np.abs(y - oof)
        if self.adaptive:
            sigma = self._calibrate_difficulty(X, splits, fold_of, residual, on_calibration)
        else:
            sigma = np.ones(n_samples)
        scores = residual / sigma
        self.scores_ = scores
        self.score_groups_ = unit
        self._fit_fallback_band(X, y, oof_fallback)
        labels, group_scores = run_quantile_scores(scores, unit, self.coverage)
        first_row = {label: rows[0] for label, rows in _table.run_segments(unit, n_samples)}
        self.groups_ = labels
        self.group_scores_ = group_scores
        self.group_fold_ = np.array([fold_of[first_row[label]] for label in labels])
        self.quantile_ = float(conformal_quantile(group_scores, self.run_probability))
        return self

    def _fit_input(self, X, y, groups):
        """``(X, y, groups, unit)`` checked: finite ``y`` of X's length, at least two
        groups (``unit``: the groups, or one per row without them)."""
        X = _check_input(self, X, reset=True)
        y = column_or_1d(np.asarray(y), warn=True).astype(float, copy=False)
        check_consistent_length(X, y)
        n_samples = y.shape[0]
        if not np.all(np.isfinite(y)):
            raise ValueError("Input y contains NaN or infinity.")
        groups = self._groups(X, groups, n_samples)
        unit = groups if groups is not None else np.arange(n_samples)
        n_groups = np.unique(unit).shape[0]
        if n_groups < 2:
            raise ValueError(
                "ConformalRegressor needs at least two groups (runs) to calibrate on, got "
                f"{n_groups}."
            )
        return X, y, groups, unit

    def _fit_folds(self, X, y, splits, params):
        """Fit one model per fold and one on all rows (``estimators_``, ``estimator_``).

        Returns the out-of-fold predictions, the fold models' fallback on their test rows
        (NaN where a fold model has none) and, when ``adaptive``, every fold model's
        prediction of every row (stacked), else None.
        """
        # One task per fold and one for the model on all rows, fitted n_jobs at once.
        fitted = Parallel(n_jobs=self.n_jobs)(
            [
                *(
                    delayed(_fit_fold)(
                        self.estimator,
                        X,
                        y,
                        train,
                        test,
                        self.adaptive,
                        _check_method_params(X, params, train),
                    )
                    for train, test in splits
                ),
                delayed(_fit_fold)(self.estimator, X, y, None, None, False, params),
            ]
        )
        self.estimator_ = fitted.pop()[0]
        self.estimators_ = [model for model, _, _, _ in fitted]
        oof = np.empty(y.shape[0])
        oof_fallback = np.full(y.shape[0], np.nan)
        for (_, test), (_, held_out, fallback, _) in zip(splits, fitted, strict=True):
            oof[test] = held_out
            if fallback is not None:
                oof_fallback[test] = fallback
        on_calibration = (
            np.stack([on_rows for _, _, _, on_rows in fitted]) if self.adaptive else None
        )
        return oof, oof_fallback, on_calibration

    def _calibrate_difficulty(self, X, splits, fold_of, residual, on_calibration):
        """The difficulty ``sigma`` of every calibration row (``adaptive``), cross-fitted.

        Sets the reference of the fold models' spread, the feature standardisation, the
        distance scale, the difficulty model and its mean.
        """
        self.fold_variance_reference_ = float(
            np.quantile(on_calibration.var(axis=0), _EXTRAPOLATION_REFERENCE)
        )
        raw = self._raw_features(X)
        self.feature_mean_ = raw.mean(axis=0)
        scale = raw.std(axis=0)
        self.feature_scale_ = np.where(scale > 0, scale, 1.0)
        features = (raw - self.feature_mean_) / self.feature_scale_
        # Cross-fitted: a calibration row's distance is to the rows of the fold model
        # that predicted it, and its difficulty comes from a model of the other folds.
        distance = np.empty(residual.shape[0])
        for k, (_, test) in enumerate(splits):
            distance[test] = knn_distance(features[fold_of != k], features[test])
        spread = float(np.std(distance))
        self.distance_scale_ = spread if spread > 0 else 1.0
        distance = distance / self.distance_scale_
        squared = residual**2
        sigma = np.empty(residual.shape[0])
        for k, (_, test) in enumerate(splits):
            inside = fold_of != k
            model, floor = _fit_difficulty(distance[inside], squared[inside])
            sigma[test] = _predict_difficulty(model, floor, distance[test])
        self.difficulty_, self.difficulty_floor_ = _fit_difficulty(distance, squared)
        self.calibration_features_ = features
        self.difficulty_mean_ = float(np.mean(sigma))
        return _soften(sigma, self.difficulty_mean_)

    def _fit_fallback_band(self, X, y, oof_fallback):
        """The band where the full model's prediction is its fallback's: the fallback's
        own out-of-fold errors (each fold model's fallback on the runs it did not see),
        their quantile, and the slope the fallback extrapolates."""
        self.fallback_scores_ = None
        if self.adaptive and _blends(self.estimator_) and not np.isnan(oof_fallback).any():
            self.fallback_scores_ = np.abs(y - oof_fallback)
        self.fallback_quantile_ = self._fallback_quantile(self.coverage)
        self.thermal_slope_ = 0.0
        fallback = self.estimator_.fallback_ if self.fallback_scores_ is not None else None
        if fallback is not None and fallback.column is not None:
            # The slope the fallback extrapolates (of T alone, a plane's rate term apart);
            # a constant fallback, unsure whether a slope carries, gets the line's.
            slope = float(np.ravel(fallback.slope)[0])
            if slope == 0.0:
                slope = thermal_slope(self._thermal_rows(X)[:, fallback.column], y)
            self.thermal_slope_ = slope

    @available_if(lambda self: hasattr(self.estimator, "outside_calibration"))
    def outside_calibration(self, X):
        """Whether every row lies outside the calibration domain of ``estimator_``.

        The calibration protocol, delegated to the model fitted on every calibration row
        (:meth:`CompensationPipeline.outside_calibration
        <sklearn_ifog.pipeline.CompensationPipeline.outside_calibration>`); available when
        ``estimator`` has the method.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_columns)
            Rows in the layout of :meth:`fit`.

        Returns
        -------
        outside : ndarray of shape (n_samples,), dtype=bool
        """
        check_is_fitted(self)
        return self.estimator_.outside_calibration(X)

    @available_if(lambda self: hasattr(self.estimator, "calibration_distance"))
    def calibration_distance(self, X):
        """Distance of every row outside the calibration domain of ``estimator_``.

        The calibration protocol, delegated to the model fitted on every calibration row
        (:meth:`CompensationPipeline.calibration_distance
        <sklearn_ifog.pipeline.CompensationPipeline.calibration_distance>`); available when
        ``estimator`` has the method.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_columns)
            Rows in the layout of :meth:`fit`.

        Returns
        -------
        distance : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        return self.estimator_.calibration_distance(X)

    @available_if(lambda self: hasattr(self.estimator, "fallback_share"))
    def fallback_share(self, X):
        """The fallback's share of every row's prediction by ``estimator_``.

        The calibration protocol, delegated to the model fitted on every calibration row
        (:meth:`CompensationPipeline.fallback_share
        <sklearn_ifog.pipeline.CompensationPipeline.fallback_share>`); available when
        ``estimator`` has the method.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_columns)
            Rows in the layout of :meth:`fit`.

        Returns
        -------
        share : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        return self.estimator_.fallback_share(X)

    @available_if(lambda self: hasattr(self.estimator, "calibrated_parts"))
    def calibrated_parts(self, X):
        """Which fitted pipeline behind ``estimator_`` predicts which rows of ``X``.

        The calibration protocol, delegated to the model fitted on every calibration row
        (:meth:`CompensationPipeline.calibrated_parts
        <sklearn_ifog.pipeline.CompensationPipeline.calibrated_parts>`); available when
        ``estimator`` has the method.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_columns)
            Rows in the layout of :meth:`fit`.

        Returns
        -------
        parts : list of tuple (pipeline, X_part, rows)
        """
        check_is_fitted(self)
        return self.estimator_.calibrated_parts(X)

    def get_metadata_routing(self):
        """The metadata routing of this object: ``fit`` parameters go to ``estimator.fit``.

        ``groups`` is consumed by the calibration folds as well, and routed to
        ``estimator.fit`` when it requests it. See scikit-learn's metadata routing user
        guide.

        Returns
        -------
        routing : MetadataRouter
            What ``fit`` consumes and routes to ``estimator``.
        """
        return (
            MetadataRouter(owner=self)
            .add_self_request(self)
            .add(
                estimator=self.estimator,
                method_mapping=MethodMapping().add(caller="fit", callee="fit"),
            )
        )

    def _fallback_quantile(self, coverage):
        """The conformal quantile of the fallback's run-wise out-of-fold errors (or 0)."""
        if getattr(self, "fallback_scores_", None) is None:  # None, or fitted before them
            return 0.0
        _, group_scores = run_quantile_scores(self.fallback_scores_, self.score_groups_, coverage)
        return float(conformal_quantile(group_scores, self.run_probability))

    def _outside_terms(self, X):
        """(fallback share, degrees beyond the calibrated temperatures) of every row, or
        (None, None) without the terms outside the domain.

        The share is :func:`~sklearn_ifog.policy.fallback_weight` of the row's distance
        outside the full model's calibration domain (the fallback's share of the
        prediction); both come from one pass of the rows through the feature step.
        """
        if getattr(self, "fallback_scores_", None) is None:
            return None, None
        domain = self.estimator_.domain_
        rows = self._thermal_rows(X)
        where = locate(domain, rows)
        return fallback_weight(where.distance, threshold_of(domain)), where.beyond

    def _thermal_rows(self, X):
        """The rows through the full model's feature step (degrees, not standardised)."""
        return _fallback_features(self.estimator_, X)

    def _raw_features(self, X):
        model = self.estimator_
        if isinstance(model, Pipeline) and len(model.steps) > 1:
            raw = model[:-1].transform(X)
        else:
            raw = _table.as_table(X) if _table.frame_kind(X) else X
        raw = np.asarray(raw, dtype=float)
        return raw[:, None] if raw.ndim == 1 else raw

    def _scale(self, raw):
        """The difficulty of rows with difficulty inputs ``raw`` (None when not adaptive)."""
        if not self.adaptive:
            return None
        features = (raw - self.feature_mean_) / self.feature_scale_
        distance = knn_distance(self.calibration_features_, features) / self.distance_scale_
        sigma = _predict_difficulty(self.difficulty_, self.difficulty_floor_, distance)
        return _soften(sigma, self.difficulty_mean_)

    def predict(self, X):
        """Predict with the estimator fitted on all rows.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_columns)
            Samples.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
            Predicted target.
        """
        check_is_fitted(self)
        X = _check_input(self, X, reset=False)
        return np.asarray(self.estimator_.predict(X), dtype=float)

    def predict_interval(self, X, *, coverage=None):
        """Lower and upper bound of the band of every row.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_columns)
            Samples.
        coverage : float, default=None
            Nominal coverage in (0, 1) of this band; None uses the ``coverage`` the model
            was fitted with. Another value re-reads the stored out-of-fold scores (no refit).

        Returns
        -------
        bounds : ndarray of shape (n_samples, 2)
            Column 0 the lower bound, column 1 the upper bound (deg/h for a drift).

        Warns
        -----
        OutsideCalibrationWarning
            At most once per call: the full model's, when rows lie outside its calibration
            domain (the fold models' own warnings are not repeated).
        """
        check_is_fitted(self)
        X = _check_input(self, X, reset=False)
        raw = self._raw_features(X) if self.adaptive else None
        # The fold models, each calibrated on fewer runs, would each warn of their own
        # domain; the band is for the full model's prediction, so only its warning (at
        # most one) reaches the user.
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            predictions = np.stack(
                [np.asarray(model.predict(X), dtype=float) for model in self.estimators_]
            )
        centre = self.predict(X)
        _reissue(caught, skip=(OutsideCalibrationWarning,))
        share, beyond = self._outside_terms(X)
        return self.bounds_from_predictions(
            centre,
            predictions,
            raw,
            coverage=coverage,
            fallback_share=share,
            temperature_beyond=beyond,
        )

    def bounds_from_predictions(
        self,
        centre,
        fold_predictions,
        difficulty_features=None,
        *,
        coverage=None,
        fallback_share=None,
        temperature_beyond=None,
    ):
        """The band from predictions already made: the full model's and the fold models'.

        What :meth:`predict_interval` does once it has predicted, for a caller that predicts
        by other means (the compiled fast path of
        :class:`~sklearn_ifog.streaming.StreamingCompensator`, or a firmware replay):
        the same bounds, bit for bit, from the same numbers.

        Parameters
        ----------
        centre : array-like of shape (n_samples,)
            The full model's predictions (:meth:`predict`).
        fold_predictions : array-like of shape (n_folds, n_samples)
            Each fold model's predictions (``estimators_``, in order).
        difficulty_features : array-like of shape (n_samples, n_features), default=None
            The difficulty model's input: the rows through every step of ``estimator_``
            before the regressor (``n_features`` the width of ``feature_mean_``). Needed
            when ``adaptive=True``; ignored otherwise.
        coverage : float, default=None
            Nominal coverage in (0, 1); None uses the ``coverage`` of fit.
        fallback_share : array-like of shape (n_samples,), default=None
            The full model's ``"blend"`` weight of every row on its fallback, in [0, 1] (0
            inside its calibration domain); None leaves the terms outside the domain out.
            Checked, then not used, when the model has no such terms (``fallback_scores_``
            is None: ``adaptive=False``, or an estimator that does not blend).
        temperature_beyond : array-like of shape (n_samples,), default=None
            Degrees beyond the full model's calibrated temperatures of every row, >= 0
            (:func:`~sklearn_ifog.domain.temperature_excess` of its feature rows; 0 within
            them), used with ``fallback_share``: the band widens there by
            ``thermal_slope_`` per degree. None leaves that term out.

        Returns
        -------
        bounds : ndarray of shape (n_samples, 2)
            Column 0 the lower bound, column 1 the upper bound.

        Raises
        ------
        ValueError
            If an argument is not of the shape given above (one value per row of
            ``centre``; ``n_folds`` rows of ``fold_predictions``; as many columns of
            ``difficulty_features`` as the difficulty model was fitted on), or holds a NaN
            or an infinity; if ``fallback_share`` is outside [0, 1] or
            ``temperature_beyond`` negative (either would widen the band silently); if
            ``temperature_beyond`` is given without ``fallback_share`` (it would be
            dropped); if ``difficulty_features`` is None with ``adaptive=True``; if
            ``coverage`` is not in (0, 1).
        TypeError
            If an argument holds something other than numbers.
        """
        check_is_fitted(self)
        centre = _as_numbers(centre, "centre").ravel()
        n_samples = centre.shape[0]
        centre = _check_values(
            centre, "centre", (n_samples,), "finite (the full model's prediction of every row)"
        )
        predictions = _as_numbers(fold_predictions, "fold_predictions")
        if predictions.shape != (len(self.estimators_), n_samples):
            raise ValueError(
                f"fold_predictions must have shape (n_folds, n_samples) = "
                f"({len(self.estimators_)}, {n_samples}), got {predictions.shape}."
            )
        predictions = _check_values(predictions, "fold_predictions", predictions.shape)
        raw, fallback_share, temperature_beyond = self._checked_terms(
            n_samples, difficulty_features, fallback_share, temperature_beyond
        )
        extrapolation = None
        if fallback_share is not None and getattr(self, "fallback_scores_", None) is not None:
            # What the regressor itself extrapolates to, before the policy set it aside.
            regressor = self.estimator_[-1]
            extrapolation = np.asarray(regressor.predict(raw), dtype=float).reshape(centre.shape)
        else:
            fallback_share = None
        group_scores, quantile = self.group_scores_, self.quantile_
        fallback_quantile = getattr(self, "fallback_quantile_", 0.0)
        if coverage is not None:
            if not (isinstance(coverage, numbers.Real) and 0.0 < coverage < 1.0):
                raise ValueError(f"coverage must be a float in (0, 1), got {coverage!r}.")
            _, group_scores = run_quantile_scores(self.scores_, self.score_groups_, coverage)
            quantile = float(conformal_quantile(group_scores, self.run_probability))
            fallback_quantile = self._fallback_quantile(coverage)
        scale = self._scale(raw)
        if scale is None:
            scale = np.ones(centre.shape[0])
        if self.method == "base":
            half = scale * quantile
            bounds = np.column_stack([centre - half, centre + half])
        elif self.method == "minmax":
            half = scale * quantile
            bounds = np.column_stack(
                [predictions.min(axis=0) - half, predictions.max(axis=0) + half]
            )
        else:
            bounds = plus_interval(
                predictions, scale, group_scores, self.group_fold_, self.run_probability
            )
        if not self.adaptive:
            return bounds
        # Where the fold models part, the model extrapolates: its jackknife variance beyond
        # the calibrated level joins the band in quadrature, at the normal quantile of the
        # coverage (the residuals say nothing of conditions no calibration run had).
        level = self.coverage if coverage is None else coverage
        extra = extrapolation_variance(predictions, self.fold_variance_reference_)
        if fallback_share is not None:
            # Outside the domain the prediction moves to the fallback, which the fold
            # models share (so they agree there, and the jackknife sees nothing): the
            # fallback's own out-of-fold error quantile, times its share of the prediction,
            # joins the band in quadrature too (as a variance at the same normal quantile).
            z = norm.ppf((1 + level) / 2)
            extra = extra + np.square(np.asarray(fallback_share) * fallback_quantile / z)
            # Beyond the calibrated temperatures the drift may go on at its calibrated slope
            # or stop there (the firmware's hold); the calibration cannot say which, so the
            # band spans the two: the slope times the degrees beyond, in quadrature at the
            # coverage of fit (a standard deviation there, so another coverage scales it).
            slope = getattr(self, "thermal_slope_", 0.0)
            if slope != 0.0 and temperature_beyond is not None:
                beyond = temperature_beyond
                z_fit = norm.ppf((1 + self.coverage) / 2)
                extra = extra + np.square(slope * beyond / z_fit)
        bounds = _widen(bounds, extra, level)
        if extrapolation is not None:
            bounds = _cover_both(bounds, centre, extrapolation)
        return bounds

    def _checked_terms(self, n_samples, difficulty_features, fallback_share, temperature_beyond):
        """:meth:`bounds_from_predictions`'s optional inputs checked for ``n_samples`` rows:
        ``(raw, fallback_share, temperature_beyond)`` (``raw``: the difficulty features,
        None unless ``adaptive``)."""
        raw = None
        if self.adaptive:
            if difficulty_features is None:
                raise ValueError(
                    "difficulty_features is required when adaptive=True: the rows through "
                    "the steps of estimator_ before its regressor."
                )
            raw = _check_values(
                difficulty_features,
                "difficulty_features",
                (n_samples, self.feature_mean_.shape[0]),
                "finite (the rows through the steps of estimator_ before its regressor)",
            )
        if fallback_share is not None:
            fallback_share = _check_values(
                fallback_share,
                "fallback_share",
                (n_samples,),
                "a weight in [0, 1] for every row",
                low=0.0,
                high=1.0,
            )
        if temperature_beyond is not None:
            if fallback_share is None:
                raise ValueError(
                    "temperature_beyond is used only with fallback_share (its slope term is "
                    "one of the terms outside the domain); pass fallback_share too, or leave "
                    "temperature_beyond None."
                )
            temperature_beyond = _check_values(
                temperature_beyond,
                "temperature_beyond",
                (n_samples,),
                "a number of degrees >= 0 for every row",
                low=0.0,
            )
        return raw, fallback_share, temperature_beyond

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.single_output = True
        tags.target_tags.multi_output = False
        return tags
