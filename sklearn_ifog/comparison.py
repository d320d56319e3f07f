"""Cross-validated comparison of drift models against baselines, in one table.

A thermal model is only worth its keep if it beats the simple answers on runs it has never
seen: no compensation, a turn-on bias, a linear or polynomial thermal model, the usual
machine-learning regressors. :func:`compare_regressors` cross-validates any set of models
(every (model, fold) pair an independent joblib task) and returns one table of mean squared
deviations (MSD) before and after compensation, per model or per model and unit;
:func:`default_regressors` gives the baselines and the package's models it compares by
default, as a dict to edit. The splitters it uses by default are those of
:mod:`sklearn_ifog.model_selection`. :class:`SubsampledRegressor` fits a regressor on a
random subsample of the rows: it makes the exact kernel methods (Gaussian processes, kernel
ridge, SVR), whose cost grows with the square or the cube of the number of rows, usable as
baselines on thermal tests of tens of thousands of samples; :func:`default_regressors` wraps
its kernel baselines in it. It wraps any regressor.

Running on a Dask cluster
-------------------------
Every fit goes through joblib, so a Dask cluster takes the work without code changes:
connect a :class:`distributed.Client` and wrap the call in joblib's ``"dask"`` backend::

    import joblib
    from distributed import Client

    client = Client("tcp://scheduler:8786")  # or Client(LocalCluster()) on one machine
    with joblib.parallel_backend("dask"):
        table = compare_regressors(X, y, cv=LeaveOneUnitOut(), n_jobs=-1)

The workers need ``sklearn-ifog`` installed (same version as the client). The results are
the same as with the default backend: each fit is seeded by ``random_state``, not by where it
runs, and the table keeps the models and folds in their given order.
"""

import numbers
import sys
import time
from typing import ClassVar

import numpy as np
from sklearn.base import BaseEstimator, MetaEstimatorMixin, RegressorMixin, clone
from sklearn.compose import TransformedTargetRegressor
from sklearn.dummy import DummyRegressor
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.kernel_ridge import KernelRidge
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.model_selection import GroupKFold
from sklearn.neural_network import MLPRegressor
from sklearn.preprocessing import PolynomialFeatures, StandardScaler
from sklearn.svm import SVR
from sklearn.utils import check_random_state, get_tags
from sklearn.utils.parallel import Parallel, delayed
from sklearn.utils.validation import check_consistent_length, check_is_fitted, validate_data

from sklearn_ifog import _table
from sklearn_ifog._compat import HasMethods, Interval, _fit_context, _safe_indexing
from sklearn_ifog._contract import DEFAULT_TERMS, resolved_settings, traditional_terms
from sklearn_ifog.features import ThermalFeatures
from sklearn_ifog.metrics import (
    interval_coverage,
    interval_score,
    mean_interval_width,
    mean_squared_deviation,
)
from sklearn_ifog.model_selection import LeaveOneRunOut
from sklearn_ifog.pipeline import make_compensation_pipeline
from sklearn_ifog.rbf import RBFNetRegressor

__all__ = ["SubsampledRegressor", "compare_regressors", "default_regressors"]


def _column_values(X, key):
    """Values of column ``key`` (name or position) of ``X``, or None if X has no such column."""
    position = _table.find_column(X, key)
    return None if position is None else np.asarray(_table.column_at(X, position))


def default_regressors(*, features=None, max_kernel_samples=600, random_state=0):
    """The models :func:`compare_regressors` compares by default, as an editable dict.

    Every model but the baselines is a :class:`~sklearn.pipeline.Pipeline`
    ``ThermalFeatures → StandardScaler → regressor``. Regressors sensitive to the target's
    scale (MLP, SVR, kernel ridge) see a standardised target through
    :class:`~sklearn.compose.TransformedTargetRegressor`; the exact kernel methods are fitted
    on at most ``max_kernel_samples`` rows
    (:class:`~sklearn_ifog.comparison.SubsampledRegressor`).

    ============================  ==========================================================
    name                          model
    ============================  ==========================================================
    ``"raw"``                     no compensation: predicts zero drift
    ``"bias"``                    constant: the training mean (turn-on bias calibration)
    ``"linear"``                  linear thermal model on T, ΔT, T·ΔT (IEEE Std 952 style)
    ``"poly2_ridge"``             degree-2 polynomial of the features, ridge
    ``"poly3_ridge"``             degree-3 polynomial of the features, ridge
    ``"mlp"``                     MLPRegressor, one hidden layer (the "BP network")
    ``"svr"``                     SVR, RBF kernel
    ``"kernel_ridge"``            KernelRidge, RBF kernel
    ``"gaussian_process"``        GaussianProcessRegressor, anisotropic RBF + white noise
    ``"rbf_traditional"``         RBFNetRegressor on (T, ΔT)
    ``"rbf_modified"``            RBFNetRegressor on (T, ΔT, T·ΔT)
    ``"rbf"``                     RBFNetRegressor on ThermalFeatures' default terms: the
                                  package's default pipeline
    ============================  ==========================================================

    Every model but ``"rbf"`` reads the paper's features (those of ``features``); ``"rbf"``
    reads the same step with ``terms="auto"``, with a time column the thermal-state set
    (T, ΔT, T·ΔT, T², T's excess over its lags at 900 s and 3600 s and those excesses times
    T, ΔT smoothed over 120 s), so ``"rbf_modified"`` against ``"rbf"`` shows what the
    thermal-state terms add.

    Parameters
    ----------
    features : ThermalFeatures, default=None
        Feature step, cloned into every pipeline. None means
        ``ThermalFeatures(temperature="temperature", time="time", run="run",
        terms=("T", "dT", "TdT"))``, the paper's features on the layout of
        :func:`~sklearn_ifog.datasets.make_thermal_campaign`. The traditional RBF model
        uses the same step without the ``"TdT"`` term, ``"rbf"`` with ``terms="auto"``.
    max_kernel_samples : int, default=600
        Largest training subsample of SVR and kernel ridge; the Gaussian process, whose fit
        also tunes its kernel (each step cubic in the rows), gets half as many.
    random_state : int, RandomState instance or None, default=0
        Seeds the MLP, the RBF networks and the subsamples.

    Returns
    -------
    regressors : dict of str to estimator
        Unfitted estimators, in the order of the table above.

    Examples
    --------
    >>> from sklearn_ifog.comparison import default_regressors
    >>> models = default_regressors()
    >>> list(models)[:3]
    ['raw', 'bias', 'linear']
    >>> models["rbf_traditional"][0].terms
    ('T', 'dT')
    >>> models["rbf_modified"][0].terms, models["rbf"][0].terms
    (('T', 'dT', 'TdT'), 'auto')
    """
    if features is None:
        features = ThermalFeatures(
            temperature="temperature", time="time", run="run", terms=DEFAULT_TERMS
        )
    rng = check_random_state(random_state)
    seeds = rng.randint(np.iinfo(np.int32).max, size=6)

    feature_params = clone(features).get_params(deep=False)

    def pipeline(regressor, *, terms=None, extra=()):
        params = feature_params if terms is None else {**feature_params, "terms": terms}
        model = make_compensation_pipeline(regressor, **params)
        # extra steps (a polynomial expansion) go between the scaler and the regressor
        model.steps[2:2] = list(extra)
        return model

    def scaled_target(regressor):
        return TransformedTargetRegressor(regressor=regressor, transformer=StandardScaler())

    resolved_terms = resolved_settings(clone(features))[0]
    n_features = len(features.get_feature_names_out())
    gp_kernel = ConstantKernel(1.0) * RBF(length_scale=np.ones(n_features)) + WhiteKernel(0.1)
    return {
        "raw": DummyRegressor(strategy="constant", constant=0.0),
        "bias": DummyRegressor(strategy="mean"),
        "linear": pipeline(LinearRegression()),
        "poly2_ridge": pipeline(
            Ridge(alpha=1e-3), extra=[("poly", PolynomialFeatures(2, include_bias=False))]
        ),
        "poly3_ridge": pipeline(
            Ridge(alpha=1e-3), extra=[("poly", PolynomialFeatures(3, include_bias=False))]
        ),
        "mlp": pipeline(
            scaled_target(
                MLPRegressor(
                    hidden_layer_sizes=(20,),
                    solver="lbfgs",
                    alpha=1e-3,
                    max_iter=500,
                    random_state=seeds[0],
                )
            )
        ),
        "svr": pipeline(
            SubsampledRegressor(
                scaled_target(SVR(C=10.0, epsilon=0.01, gamma="scale")),
                max_samples=max_kernel_samples,
                random_state=seeds[1],
            )
        ),
        "kernel_ridge": pipeline(
            SubsampledRegressor(
                scaled_target(KernelRidge(kernel="rbf", alpha=0.1, gamma=0.05)),
                max_samples=max_kernel_samples,
                random_state=seeds[2],
            )
        ),
        "gaussian_process": pipeline(
            SubsampledRegressor(
                GaussianProcessRegressor(gp_kernel, normalize_y=True, random_state=seeds[3]),
                max_samples=max(1, max_kernel_samples // 2),
                random_state=seeds[3],
            )
        ),
        "rbf_traditional": pipeline(
            RBFNetRegressor(random_state=seeds[4]), terms=traditional_terms(resolved_terms)
        ),
        "rbf_modified": pipeline(RBFNetRegressor(random_state=seeds[5])),
        "rbf": pipeline(RBFNetRegressor(random_state=seeds[5]), terms="auto"),
    }


def _describe_fold(X, test):
    """Short text naming the units, azimuths and runs of a test fold, from X's columns."""
    parts = []
    for column in ("unit", "azimuth", "run"):
        values = _column_values(X, column)
        if values is None:
            continue
        found = np.unique(values[test])
        shown = ", ".join(
            f"{value:g}" if isinstance(value, float) else str(value)
            for value in found.tolist()[:6]
        )
        if found.size > 6:
            shown += f", ... ({found.size})"
        parts.append(f"{column}={shown}")
    return "; ".join(parts) if parts else f"{test.size} rows"


def _fit_and_evaluate(name, estimator, X, y, train, test, fold, by=None):
    """Fit a clone on ``train``, predict ``test``: the rows of the per-fold table (one, or
    one per value of ``by`` among the test rows)."""
    X_train, X_test = _safe_indexing(X, train), _safe_indexing(X, test)
    y_train, y_test = _safe_indexing(y, train), _safe_indexing(y, test)
    model = clone(estimator)
    start = time.perf_counter()
    model.fit(X_train, y_train)
    fit_time = time.perf_counter() - start
    start = time.perf_counter()
    y_pred = np.asarray(model.predict(X_test), dtype=np.float64)
    predict_time = time.perf_counter() - start
    y_test = np.asarray(y_test, dtype=np.float64)
    parts = [(None, np.ones(len(test), dtype=bool))]
    if by is not None:
        labels = by[test]
        parts = [(label, labels == label) for label in np.unique(labels)]
    bounds = model.predict_interval(X_test) if hasattr(model, "predict_interval") else None
    rows = []
    for label, mask in parts:
        msd_before = mean_squared_deviation(y_test[mask], np.zeros_like(y_test[mask]))
        msd_after = mean_squared_deviation(y_test[mask], y_pred[mask])
        row = {"model": name}
        if by is not None:
            row["group"] = label.item() if isinstance(label, np.generic) else label
        row.update(
            {
                "fold": fold,
                "test": _describe_fold(X, test[mask]),
                "n_train": len(train),
                "n_test": int(mask.sum()),
                "msd_before": float(msd_before),
                "msd_after": float(msd_after),
                "reduction": float(msd_before / msd_after) if msd_after > 0 else np.inf,
                "fit_time": fit_time,
                "predict_time": predict_time,
            }
        )
        if bounds is not None:
            row.update(
                {
                    "coverage": interval_coverage(y_test[mask], bounds[mask]),
                    "width": mean_interval_width(bounds[mask]),
                    "interval_score": interval_score(
                        y_test[mask], bounds[mask], coverage=getattr(model, "coverage", 0.9)
                    ),
                }
            )
        rows.append(row)
    return rows


def _summarize(folds, names, by=None):
    """Per-model (per model and group with ``by``) summary of the per-fold table."""
    keys = ["model"] if by is None else ["model", "group"]
    grouped = folds.groupby(keys, sort=False)
    summary = grouped.agg(
        msd_before=("msd_before", "mean"),
        msd_after=("msd_after", "mean"),
        msd_after_std=("msd_after", "std"),
        worst_fold_reduction=("reduction", "min"),
        fit_time=("fit_time", "mean"),
        predict_time=("predict_time", "mean"),
        n_folds=("fold", "count"),
    )
    summary.insert(3, "reduction", summary["msd_before"] / summary["msd_after"])
    if "coverage" in folds.columns:
        intervals = grouped.agg(
            coverage=("coverage", "mean"),
            worst_fold_coverage=("coverage", "min"),
            width=("width", "mean"),
            interval_score=("interval_score", "mean"),
        )
        summary = summary.join(intervals)
    if by is None:
        return summary.reindex(names)
    summary.index = summary.index.set_names(["model", by])
    order = {name: position for position, name in enumerate(names)}
    return summary.sort_index(
        level=[0, 1], key=lambda index: index.map(order) if index.name == "model" else index
    )


def compare_regressors(
    X,
    y,
    *,
    regressors=None,
    cv=None,
    groups=None,
    features=None,
    n_jobs=None,
    verbose=0,
    return_folds=False,
    random_state=0,
    by=None,
):
    """Cross-validate drift models against baselines, in one call.

    Every (model, fold) pair is an independent joblib task, so ``n_jobs`` spreads the whole
    comparison over cores (or a Dask cluster, see the module notes). For each fold the
    model is fitted on the training rows and its prediction subtracted from the test target:

    - ``msd_before``: the MSD with no compensation, ``mean(y_test²)``. With the target
      ``rate - reference`` (:func:`~sklearn_ifog.compensation.drift_target`) this is the
      reference paper's MSD of the raw output, ``MSE(d - A)``. It is the same for all models
      of a fold; the ``"raw"`` baseline (zero drift) reproduces it.
    - ``msd_after``: ``mean((y_test - y_pred)²)``, the MSD of the compensated output.
      The ``"bias"`` baseline (the training mean) is the usual turn-on bias calibration;
      a thermal model must beat it to be worth its keep.
    - ``reduction``: ``msd_before / msd_after`` (> 1 is an improvement).

    Parameters
    ----------
    X : DataFrame of shape (n_samples, n_columns)
        Thermal-test table: the columns the feature step reads (temperature, time, run) and
        those the splitter reads (unit, azimuth, run). Rows of a run in time order.
    y : array-like of shape (n_samples,)
        Drift target (deg/h), e.g. ``rate - reference``.
    regressors : dict of str to estimator, default=None
        Models to compare; None means :func:`default_regressors` (``features``,
        ``random_state``).
    cv : int, cross-validation generator or iterable, default=None
        Splitter. None means :class:`~sklearn_ifog.model_selection.LeaveOneRunOut`
        ``(within_unit=True)``: each run is compensated by a model trained on its unit's
        other runs. An int ``k`` means :class:`~sklearn.model_selection.GroupKFold` ``(k)``
        over the runs (never a plain KFold, which would cut runs in two).
    groups : array-like of shape (n_samples,), default=None
        Group labels passed to ``cv.split`` (the splitters of
        :mod:`sklearn_ifog.model_selection` read them from ``X`` when None; an int ``cv``
        uses the ``run`` column when None).
    features : ThermalFeatures, default=None
        Feature step of the default models (ignored when ``regressors`` is given).
    n_jobs : int, default=None
        Parallel jobs over (model, fold) pairs; -1 uses all cores.
    verbose : int, default=0
        0 is silent; 1 prints the plan and a line per finished model; more also prints
        joblib's progress.
    return_folds : bool, default=False
        Whether to also return the per-fold table.
    random_state : int, RandomState instance or None, default=0
        Seeds the default models (ignored when ``regressors`` is given).
    by : str or None, default=None
        A column of X (e.g. ``"unit"``): every fold's test rows are scored separately for
        each of its values, and the summary has one row per (model, value): the results of
        every gyro of a lot, e.g. of a :class:`~sklearn_ifog.UnitwiseRegressor`.

    Returns
    -------
    summary : pandas.DataFrame
        One row per model (index ``model``, in the order given; with ``by``, a two-level
        index ``(model, by)``, one row per model and value of the column): ``msd_before``,
        ``msd_after`` (means over folds), ``msd_after_std``, ``reduction`` (ratio of the two
        means), ``worst_fold_reduction``, ``fit_time`` and ``predict_time`` (mean seconds
        per fold), ``n_folds``. When a model has ``predict_interval`` (e.g.
        :class:`~sklearn_ifog.ConformalRegressor`) also ``coverage`` (mean over folds of
        :func:`~sklearn_ifog.metrics.interval_coverage`), ``worst_fold_coverage``,
        ``width`` (mean :func:`~sklearn_ifog.metrics.mean_interval_width`) and
        ``interval_score`` (:func:`~sklearn_ifog.metrics.interval_score`); NaN for the
        models without intervals.
    folds : pandas.DataFrame
        Only with ``return_folds=True``: one row per (model, fold) (per model, fold and
        value of ``by`` with ``by``, in a column ``group``) with ``model``, ``fold``,
        ``test`` (the units, azimuths and runs tested), ``n_train``, ``n_test``,
        ``msd_before``, ``msd_after``, ``reduction``, ``fit_time``, ``predict_time`` (and
        ``coverage``, ``width``, ``interval_score`` for models with intervals).

    Examples
    --------
    >>> import numpy as np
    >>> import pandas as pd
    >>> from sklearn.dummy import DummyRegressor
    >>> from sklearn_ifog.comparison import compare_regressors
    >>> X = pd.DataFrame({"run": np.repeat([0, 1, 2], 4), "temperature": 20.0})
    >>> y = np.tile([0.1, 0.3, 0.1, 0.3], 3)
    >>> summary = compare_regressors(
    ...     X,
    ...     y,
    ...     regressors={
    ...         "raw": DummyRegressor(strategy="constant", constant=0.0),
    ...         "bias": DummyRegressor(),
    ...     },
    ... )
    >>> summary[["msd_before", "msd_after", "reduction"]].round(3)
          msd_before  msd_after  reduction
    model
    raw         0.05       0.05        1.0
    bias        0.05       0.01        5.0
    >>> X["unit"] = np.repeat([7, 7, 8], 4)
    >>> by_unit = compare_regressors(X, y, regressors={"bias": DummyRegressor()}, cv=3, by="unit")
    >>> by_unit["n_folds"].to_dict()
    {('bias', 7): 2, ('bias', 8): 1}
    """
    import pandas as pd

    check_consistent_length(X, y)
    if regressors is None:
        regressors = default_regressors(features=features, random_state=random_state)
    if not isinstance(regressors, dict) or not regressors:
        raise TypeError(
            "regressors must be a non-empty dict of name -> estimator, got "
            f"{type(regressors).__name__}."
        )
    for name, estimator in regressors.items():
        if not (hasattr(estimator, "fit") and hasattr(estimator, "predict")):
            raise TypeError(f"regressors[{name!r}] has no fit/predict: {estimator!r}.")
    if cv is None:
        cv = LeaveOneRunOut(within_unit=_column_values(X, "unit") is not None)
    elif isinstance(cv, numbers.Integral):
        if groups is None:
            groups = _column_values(X, "run")
            if groups is None:
                raise ValueError(
                    f"cv={cv} splits runs with GroupKFold, but X has no 'run' column and "
                    "groups is None; pass groups= (the run of each row)."
                )
        cv = GroupKFold(n_splits=cv)
    by_values = None
    if by is not None:
        by_values = _column_values(X, by)
        if by_values is None:
            raise ValueError(f"by={by!r} names no column of X; pass the column of the groups.")
    splits = list(cv.split(X, y, groups)) if hasattr(cv, "split") else list(cv)
    names = list(regressors)
    if verbose:
        print(
            f"[compare_regressors] {len(names)} models x {len(splits)} folds = "
            f"{len(names) * len(splits)} fits on {len(y)} rows",
            file=sys.stderr,
            flush=True,
        )
    tasks = (
        delayed(_fit_and_evaluate)(name, regressors[name], X, y, train, test, fold, by_values)
        for name in names
        for fold, (train, test) in enumerate(splits)
    )
    parallel = Parallel(n_jobs=n_jobs, verbose=max(0, verbose - 1), return_as="generator")
    rows = []
    done = dict.fromkeys(names, 0)
    for fold_rows in parallel(tasks):
        rows.extend(fold_rows)
        row = fold_rows[0]
        done[row["model"]] += 1
        if verbose and done[row["model"]] == len(splits):
            print(
                f"[compare_regressors] {row['model']}: done ({sum(done.values())}/"
                f"{len(names) * len(splits)} fits)",
                file=sys.stderr,
                flush=True,
            )
    folds = pd.DataFrame(rows)
    summary = _summarize(folds, names, by)
    if return_folds:
        return summary, folds
    return summary


class SubsampledRegressor(MetaEstimatorMixin, RegressorMixin, BaseEstimator):
    """Fit a regressor on a random subsample of at most ``max_samples`` rows.

    Exact kernel methods (Gaussian processes, kernel ridge, SVR) cost O(n²) memory and up to
    O(n³) time; a thermal test logs tens of thousands of samples. This wrapper fits a clone
    of ``estimator`` on a uniform random subsample without replacement (rows kept in their
    original order) and predicts with it. Put it *after* the feature step of a pipeline:
    ΔT needs consecutive rows.

    Parameters
    ----------
    estimator : estimator object, default=None
        The regressor to fit. None means
        :class:`~sklearn.gaussian_process.GaussianProcessRegressor`.
    max_samples : int, default=1000
        Largest number of rows the estimator is fitted on; all rows when there are fewer.
    random_state : int, RandomState instance or None, default=None
        Draws the subsample. Pass an int for reproducible results.

    Attributes
    ----------
    estimator_ : estimator
        The fitted clone of ``estimator``.
    sample_indices_ : ndarray of shape (n_fitted,)
        Rows of the training data the estimator was fitted on, increasing.
    n_features_in_ : int
        Number of features seen during fit.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of features seen during fit, when X has string column names.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog.comparison import SubsampledRegressor
    >>> X = np.arange(100.0).reshape(-1, 1)
    >>> model = SubsampledRegressor(LinearRegression(), max_samples=10, random_state=0)
    >>> model.fit(X, 2 * X[:, 0]).sample_indices_.shape
    (10,)
    >>> model.predict([[200.0]]).round(6)
    array([400.])
    """

    _parameter_constraints: ClassVar[dict] = {
        "estimator": [HasMethods(["fit", "predict"]), None],
        "max_samples": [Interval(numbers.Integral, 1, None, closed="left")],
        "random_state": ["random_state"],
    }

    def __init__(self, estimator=None, *, max_samples=1000, random_state=None):
        self.estimator = estimator
        self.max_samples = max_samples
        self.random_state = random_state

    def _base_estimator(self):
        return GaussianProcessRegressor() if self.estimator is None else self.estimator

    @_fit_context(
        # The wrapped estimator validates its own parameters.
        prefer_skip_nested_validation=False
    )
    def fit(self, X, y):
        """Fit the estimator on a random subsample of the rows.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Training data.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Target values.

        Returns
        -------
        self : object
            Fitted estimator.
        """
        X, y = validate_data(self, X, y, y_numeric=True, multi_output=True)
        n_samples = X.shape[0]
        if n_samples > self.max_samples:
            rng = check_random_state(self.random_state)
            indices = np.sort(rng.choice(n_samples, size=self.max_samples, replace=False))
        else:
            indices = np.arange(n_samples)
        self.sample_indices_ = indices
        self.estimator_ = clone(self._base_estimator()).fit(X[indices], y[indices])
        return self

    def predict(self, X):
        """Predict with the estimator fitted on the subsample.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Samples.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Predicted values.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        return self.estimator_.predict(X)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        inner = get_tags(self._base_estimator())
        tags.target_tags.multi_output = inner.target_tags.multi_output
        tags.non_deterministic = inner.non_deterministic
        return tags
