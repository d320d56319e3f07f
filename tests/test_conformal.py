"""ConformalRegressor and the interval metrics: behaviour, invariants, errors."""

import joblib
import numpy as np
import pandas as pd
import pytest
from scipy.stats import norm
from sklearn.base import clone
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.model_selection import GridSearchCV, GroupKFold, TimeSeriesSplit
from sklearn.neighbors import KNeighborsRegressor
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import ConformalRegressor, RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.conformal import (
    conformal_quantile,
    extrapolation_variance,
    knn_distance,
    plus_interval,
    run_quantile_scores,
)
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.metrics import (
    get_scorer,
    interval_coverage,
    interval_score,
    mean_interval_width,
)


def _heteroscedastic(seed, n_runs=20, per_run=60):
    """Runs whose noise grows with |x|; x drawn per run from a run-specific range."""
    rng = np.random.RandomState(seed)
    centre = rng.uniform(-2, 2, size=n_runs)
    x = (centre[:, None] + rng.uniform(-0.5, 0.5, size=(n_runs, per_run))).ravel()
    noise = (0.05 + 0.3 * np.abs(x)) * rng.normal(size=x.size)
    y = 1.5 * x + noise
    runs = np.repeat(np.arange(n_runs), per_run)
    return x[:, None], y, runs


# -- numerics ------------------------------------------------------------------------------


def test_conformal_quantile_rank():
    scores = np.arange(1.0, 10.0)  # 9 scores
    # ceil(10 * 0.9) = 9: the largest
    assert conformal_quantile(scores, 0.9) == 9.0
    # ceil(10 * 0.5) = 5
    assert conformal_quantile(scores, 0.5) == 5.0
    # More than n needed: the largest is returned.
    assert conformal_quantile(scores[:3], 0.99) == 3.0


def test_run_quantile_scores_one_per_group_in_order():
    labels, group_scores = run_quantile_scores(
        [5.0, 1.0, 2.0, 3.0, 9.0], ["b", "a", "a", "a", "b"], 1.0
    )
    assert labels.tolist() == ["b", "a"]
    assert group_scores.tolist() == [9.0, 3.0]


def test_plus_interval_brackets_every_fold_prediction_with_zero_scores():
    predictions = np.array([[0.0, 1.0], [2.0, 3.0]])
    bounds = plus_interval(predictions, np.ones(2), np.zeros(2), np.array([0, 1]), 0.9)
    np.testing.assert_allclose(bounds, [[0.0, 2.0], [1.0, 3.0]])


# -- the estimator -------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["plus", "base", "minmax"])
def test_bounds_ordered_and_contain_prediction(method):
    X, y, runs = _heteroscedastic(0)
    model = ConformalRegressor(LinearRegression(), method=method).fit(X, y, groups=runs)
    bounds = model.predict_interval(X)
    assert bounds.shape == (X.shape[0], 2)
    assert np.all(bounds[:, 0] <= bounds[:, 1])
    if method != "plus":  # CV+ centres on the fold models, not the full model
        prediction = model.predict(X)
        assert np.all((bounds[:, 0] <= prediction) & (prediction <= bounds[:, 1]))


def _sparse_tails(seed, n_runs=20, per_run=60):
    """Runs whose x is normal (the data thin out in the tails) and whose noise grows with |x|."""
    rng = np.random.RandomState(seed)
    x = rng.normal(size=n_runs * per_run)
    y = 1.5 * x + (0.05 + 0.3 * np.abs(x)) * rng.normal(size=x.size)
    return x[:, None], y, np.repeat(np.arange(n_runs), per_run)


def _adaptive_widths(seed):
    """The adaptive and the flat band's widths at x = 0, 2.5 and 5 on `_sparse_tails(seed)`."""
    X, y, runs = _sparse_tails(seed)
    grid = np.array([[0.0], [2.5], [5.0]])
    widths = []
    for adaptive in (True, False):
        model = ConformalRegressor(LinearRegression(), adaptive=adaptive).fit(X, y, groups=runs)
        widths.append(np.diff(model.predict_interval(grid), axis=1).ravel())
    return widths


def test_adaptive_band_is_wider_away_from_the_calibrated_conditions():
    """The difficulty grows with the distance to the nearest calibration rows (sparse in the
    tails, where the noise is larger); the band follows its square root, so the ratios are
    damped but clear, and it keeps growing outside the calibrated range. The flat band does
    not move.

    Measured on 570 seeds (0-29 + 1000 k, k = 0-18): the band at 2.5 is wider than at 0 by
    more than 1.15x on 97.7 % (at most 3 of any 30; the least ratio 1.103, seed 4007),
    wider at 5 than at 2.5 by 1.58x or more on all, the flat band within 6 % of its width
    at 0 on all. The earlier check (1.15x on each of seeds 0-4) failed on seed 16002
    (width 1.124 at 2.5 against 0.989 at 0: 1.137x). Asserted on seeds 0-29: 1.15x on at
    least 90 %, and on every seed a ratio above 1.05, growth to 5 and a flat band within
    10 %.
    """
    ratios = []
    for seed in range(30):
        width, flat_width = _adaptive_widths(seed)
        assert width[1] > 1.05 * width[0], seed
        assert width[2] > width[1], seed
        np.testing.assert_allclose(flat_width, flat_width[0], rtol=0.1)
        ratios.append(width[1] / width[0])
    assert np.mean(np.array(ratios) > 1.15) >= 0.9


def test_extrapolation_variance_is_the_jackknife_excess():
    predictions = np.array([[1.0, 0.0, 2.0], [1.0, 2.0, -2.0], [1.0, 1.0, 0.0]])
    # variances over the folds: 0, 2/3, 8/3; jackknife factor K - 1 = 2
    np.testing.assert_allclose(
        extrapolation_variance(predictions, 0.0), [0.0, 4.0 / 3.0, 16.0 / 3.0]
    )
    np.testing.assert_allclose(extrapolation_variance(predictions, 1.0), [0.0, 0.0, 10.0 / 3.0])


def _band_parts(seed):
    """Fit on 12 runs of a line on [0, 1] (seed `seed`); check the band's composition at
    x = 0.5, 4 and 8 exactly and return the jackknife excess variance there."""
    rng = np.random.RandomState(seed)
    x = rng.uniform(0.0, 1.0, size=(12, 50))
    y = (2.0 * x + 0.1 * rng.normal(size=x.shape) + 0.05 * rng.normal(size=(12, 1))).ravel()
    X, runs = x.reshape(-1, 1), np.repeat(np.arange(12), 50)
    model = ConformalRegressor(LinearRegression(), cv=4).fit(X, y, groups=runs)
    on_calibration = np.stack([m.predict(X) for m in model.estimators_])
    assert model.fold_variance_reference_ == pytest.approx(
        np.quantile(on_calibration.var(axis=0), 0.95), rel=1e-12
    )
    grid = np.array([[0.5], [4.0], [8.0]])
    predictions = np.stack([m.predict(grid) for m in model.estimators_])
    extra = extrapolation_variance(predictions, model.fold_variance_reference_)
    cv_plus = plus_interval(
        predictions, model._scale(grid), model.group_scores_, model.group_fold_, 0.6
    )
    half = np.sqrt((np.diff(cv_plus, axis=1).ravel() / 2) ** 2 + norm.ppf(0.95) ** 2 * extra)
    middle = cv_plus.mean(axis=1)
    bounds = model.predict_interval(grid)
    np.testing.assert_allclose(bounds, np.column_stack([middle - half, middle + half]))
    # another coverage re-reads the scores and the normal quantile of that coverage
    wide = model.predict_interval(grid, coverage=0.99)
    assert np.all(np.diff(wide, axis=1) > np.diff(bounds, axis=1))
    return extra, bounds[0], cv_plus[0]


def test_band_widens_where_the_fold_models_part():
    """Out of the calibrated range the fold models' jackknife variance joins the band in
    quadrature; inside it, where they agree as on the calibration rows, the band is the
    CV+ band alone.

    The composition holds exactly on every seed. Whether the fold models part at x = 4 is
    a property of the draw: four fold lines that come out nearly parallel (their spread
    set by the runs' offsets, not their slopes) agree at 4 as well as on the calibration
    rows, and the excess is rightly 0 there (seed 23: fold variance 5.5e-5 at 4 against a
    reference of 2.6e-4; 7.6e-4 at 8). Measured on 950 seeds (0-49 + 1000 k, k = 0-18):
    the composition and excess 0 at 0.5 on all, 0 < excess(4) < excess(8) on 95.6 % (at
    most 5 of any 50 fail, as on 8000-8049; excess(4) > excess(8) on none). The earlier
    check on seeds 0-2 alone failed on 11001. Asserted on seeds 0-49: on at least 90 %.
    """
    parted = []
    for seed in range(50):
        extra, inside, cv_plus_inside = _band_parts(seed)
        assert extra[0] == 0.0, seed
        np.testing.assert_allclose(inside, cv_plus_inside)
        parted.append(0.0 < extra[1] < extra[2])
    assert np.mean(parted) >= 0.9


def test_knn_distance_values_and_cross_fitting():
    reference = np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 8.0]])
    # nearest 2 of (0,0): itself (0) and (3,4) (5): mean 2.5
    np.testing.assert_allclose(knn_distance(reference, reference[:1], n_neighbors=2), [2.5])
    # more neighbours than rows: all rows
    np.testing.assert_allclose(knn_distance(reference, [[0.0, 0.0]], n_neighbors=10), [5.0])
    # A calibration row's distance is to the rows of the fold model that predicted it (one
    # fold per run here), never to its own run's rows.
    X, y, runs = _sparse_tails(0, n_runs=6)
    model = ConformalRegressor(LinearRegression()).fit(X, y, groups=runs)
    features = (X - X.mean(axis=0)) / X.std(axis=0)
    np.testing.assert_allclose(model.calibration_features_, features)
    crossed = np.empty(X.shape[0])
    for run in np.unique(runs):
        crossed[runs == run] = knn_distance(features[runs != run], features[runs == run])
    assert model.distance_scale_ == pytest.approx(np.std(crossed), rel=1e-12)
    assert model.distance_scale_ != pytest.approx(np.std(knn_distance(features, features)))


def _held_out_coverage(seed):
    """Coverage of 10 new runs of `_heteroscedastic(seed)` by a band fit on 20 others."""
    X, y, runs = _heteroscedastic(seed, n_runs=30)
    train = runs < 20
    model = ConformalRegressor(LinearRegression(), cv=5).fit(
        X[train], y[train], groups=runs[train]
    )
    return interval_coverage(y[~train], model.predict_interval(X[~train]))


def test_held_out_run_coverage_over_seeds():
    """New runs from the same process: pooled coverage near nominal (0.9), and a seed far
    below it rare.

    Measured on 950 seeds (0-49 + 1000 k, k = 0-18): mean 0.896 (0.878-0.906 per set of
    50); a seed below 0.75 at 1.2 % (at most 2 of any 50; the worst 0.632, in 1000-1049).
    The earlier check (each of seeds 0-9 at 0.7 or more) failed on 5000-5009 (0.667) and
    11000-11009 (0.690). Asserted on seeds 0-49: mean at least 0.87, at least 0.75 on 94 %.
    """
    coverages = np.array([_held_out_coverage(seed) for seed in range(50)])
    assert np.mean(coverages) >= 0.87
    assert np.mean(coverages >= 0.75) >= 0.94


def _runs_with_offsets(rng, n_runs, per_run=40):
    """Exchangeable runs: each has its own constant offset (a turn-on bias) plus noise."""
    x = rng.uniform(-1, 1, size=(n_runs, per_run))
    offset = rng.normal(scale=0.3, size=(n_runs, 1))
    y = 2 * x + offset + rng.normal(scale=0.2, size=x.shape)
    return x.reshape(-1, 1), y.ravel(), np.repeat(np.arange(n_runs), per_run)


@pytest.mark.parametrize("run_probability", [0.6, 0.9])
def test_run_level_guarantee_on_exchangeable_runs(run_probability):
    """A new run holds its drift at least `coverage` of its time with probability about
    `run_probability` (the conformal rank over 10 calibration runs: ceil(11 p) / 11), averaged
    over 40 seeds of 10 calibration and 20 new runs (Monte Carlo sd of the mean ~0.03)."""
    fractions = []
    for seed in range(40):
        rng = np.random.RandomState(seed)
        X, y, runs = _runs_with_offsets(rng, 10)
        X_new, y_new, runs_new = _runs_with_offsets(rng, 20)
        model = ConformalRegressor(
            LinearRegression(), adaptive=False, run_probability=run_probability
        )
        bounds = model.fit(X, y, groups=runs).predict_interval(X_new)
        per_run = [
            interval_coverage(y_new[runs_new == run], bounds[runs_new == run]) for run in range(20)
        ]
        fractions.append(np.mean(np.array(per_run) >= 0.9))
    guaranteed = np.ceil(11 * run_probability) / 11
    assert guaranteed - 0.1 <= np.mean(fractions) <= guaranteed + 1 / 11 + 0.1


def test_run_column_of_a_dataframe_is_the_default_group():
    X, y, runs = _heteroscedastic(1)
    frame = pd.DataFrame({"x": X[:, 0], "run": runs})
    pipe = make_pipeline(StandardScaler(), LinearRegression())
    by_column = ConformalRegressor(pipe, cv=4).fit(frame, y)
    by_groups = ConformalRegressor(pipe, cv=4).fit(frame, y, groups=runs)
    np.testing.assert_array_equal(by_column.groups_, by_groups.groups_)
    np.testing.assert_allclose(
        by_column.predict_interval(frame), by_groups.predict_interval(frame)
    )
    assert by_column.groups_.shape == (20,)


def test_default_cv_is_one_fold_per_run():
    X, y, runs = _heteroscedastic(2, n_runs=6)
    model = ConformalRegressor(LinearRegression()).fit(X, y, groups=runs)
    assert len(model.estimators_) == 6
    assert sorted(model.group_fold_.tolist()) == list(range(6))


def test_compensation_pipeline_on_a_campaign():
    X, y = make_thermal_campaign(
        n_units=1,
        n_runs=2,
        azimuths=(0.0, 90.0, 180.0),
        sampling_period=300.0,
        random_state=0,
        return_X_y=True,
    )
    model = ConformalRegressor(make_compensation_pipeline(Ridge()), cv=3).fit(X, y)
    bounds = model.predict_interval(X)
    assert bounds.shape == (len(y), 2)
    assert np.all(bounds[:, 1] > bounds[:, 0])
    assert model.groups_.size == X["run"].nunique()


def test_clone_params_gridsearch_and_joblib(tmp_path):
    x, y, runs = _heteroscedastic(3)
    # The run travels inside X (GridSearchCV does not route groups to fit).
    X = pd.DataFrame({"x": x[:, 0], "run": runs})
    model = ConformalRegressor(make_pipeline(StandardScaler(), Ridge()), cv=GroupKFold(4))
    params = model.get_params()
    assert "estimator__ridge__alpha" in params
    assert clone(model).get_params()["coverage"] == 0.9
    search = GridSearchCV(
        model,
        {"estimator__ridge__alpha": [0.1, 10.0]},
        cv=GroupKFold(3),
        scoring="neg_mean_squared_error",
    ).fit(X, y, groups=runs)
    assert search.best_params_["estimator__ridge__alpha"] in (0.1, 10.0)
    fitted = model.fit(X, y, groups=runs)
    path = tmp_path / "model.joblib"
    joblib.dump(fitted, path)
    np.testing.assert_array_equal(
        joblib.load(path).predict_interval(X), fitted.predict_interval(X)
    )


@pytest.mark.parametrize("coverage", [0.0, 1.0, 1.5, -0.1])
def test_bad_coverage(coverage):
    X, y, runs = _heteroscedastic(0)
    with pytest.raises(ValueError, match="coverage"):
        ConformalRegressor(LinearRegression(), coverage=coverage).fit(X, y, groups=runs)


@pytest.mark.parametrize("run_probability", [0.0, 1.0, 1.5, "0.6"])
def test_bad_run_probability_is_named(run_probability):
    X, y, runs = _heteroscedastic(0)
    model = ConformalRegressor(LinearRegression(), run_probability=run_probability)
    with pytest.raises(ValueError, match="The 'run_probability' parameter of ConformalRegressor"):
        model.fit(X, y, groups=runs)


def test_the_two_levels_are_coverage_and_run_probability():
    """`coverage` is the level within a run (MAPIE's confidence_level), `run_probability` the
    one over runs; the old name `confidence` is gone (no release had it)."""
    params = ConformalRegressor(LinearRegression()).get_params()
    assert (params["coverage"], params["run_probability"]) == (0.9, 0.6)
    assert "confidence" not in params
    with pytest.raises(TypeError, match="confidence"):
        ConformalRegressor(LinearRegression(), confidence=0.6)
    X, y, runs = _heteroscedastic(0)
    low, high = (
        ConformalRegressor(LinearRegression(), adaptive=False, run_probability=level)
        .fit(X, y, groups=runs)
        .quantile_
        for level in (0.5, 0.95)
    )
    assert low < high  # a higher run_probability widens the band


def test_bad_groups():
    X, y, runs = _heteroscedastic(0)
    with pytest.raises(ValueError, match="at least two groups"):
        ConformalRegressor(LinearRegression()).fit(X, y, groups=np.zeros(len(y)))
    with pytest.raises(ValueError, match="one label per row"):
        ConformalRegressor(LinearRegression()).fit(X, y, groups=runs[:-1])
    with pytest.raises(ValueError, match="no 'run' column"):
        ConformalRegressor(LinearRegression()).fit(X, y)
    with pytest.raises(ValueError, match="out of every test fold"):
        ConformalRegressor(LinearRegression(), cv=TimeSeriesSplit(3)).fit(X, y, groups=runs)


def test_scorers():
    X, y, runs = _heteroscedastic(4)
    model = ConformalRegressor(LinearRegression(), cv=4).fit(X, y, groups=runs)
    bounds = model.predict_interval(X)
    assert get_scorer("interval_coverage")(model, X, y) == interval_coverage(y, bounds)
    assert get_scorer("neg_mean_interval_width")(model, X, y) == -mean_interval_width(bounds)
    assert get_scorer("neg_interval_score")(model, X, y) == -interval_score(
        y, bounds, coverage=0.9
    )


# -- metrics -------------------------------------------------------------------------------


def test_interval_metrics_values():
    y = np.array([0.0, 1.0, 4.0, -3.0])
    bounds = np.array([[-1.0, 1.0], [1.0, 2.0], [0.0, 2.0], [-2.0, 0.0]])
    assert interval_coverage(y, bounds) == 0.5
    assert mean_interval_width(bounds) == 1.75
    # misses: y=4 above 2 by 2, y=-3 below -2 by 1; alpha = 0.2 -> penalty 10 per unit
    assert interval_score(y, bounds, coverage=0.8) == pytest.approx(1.75 + (20 + 10) / 4)


def test_interval_score_is_minimised_by_the_true_quantiles():
    rng = np.random.RandomState(0)
    y = rng.normal(size=200_000)
    true = np.tile([-1.6449, 1.6449], (y.size, 1))
    assert interval_score(y, true) < interval_score(y, 0.8 * true)
    assert interval_score(y, true) < interval_score(y, 1.25 * true)


def test_interval_metric_errors():
    with pytest.raises(ValueError, match=r"shape \(n_samples, 2\)"):
        interval_coverage([0.0, 1.0], [0.0, 1.0])
    with pytest.raises(ValueError, match="rows"):
        interval_coverage([0.0, 1.0], [[0.0, 1.0]])
    with pytest.raises(ValueError, match="coverage"):
        interval_score([0.0], [[0.0, 1.0]], coverage=1.0)


def test_compare_regressors_reports_coverage_and_width():
    """Coverage, worst fold and width per model; none for a model without intervals.

    The coverage bound held with ``_heteroscedastic`` seeds 0-9 in place of 5 (checked once).
    """
    from sklearn_ifog.comparison import compare_regressors

    x, y, runs = _heteroscedastic(5, n_runs=12)
    X = pd.DataFrame({"x": x[:, 0], "run": runs})
    pipe = make_pipeline(StandardScaler(), LinearRegression())
    summary, folds = compare_regressors(
        X,
        y,
        regressors={"plain": pipe, "conformal": ConformalRegressor(pipe, cv=4)},
        cv=3,
        return_folds=True,
    )
    assert np.isnan(summary.loc["plain", "coverage"])
    row = summary.loc["conformal"]
    conformal_folds = folds[folds["model"] == "conformal"]
    assert row["coverage"] == pytest.approx(conformal_folds["coverage"].mean())
    assert row["worst_fold_coverage"] == conformal_folds["coverage"].min()
    assert 0.5 < row["coverage"] <= 1.0
    assert row["width"] > 0
    assert row["interval_score"] >= row["width"]


def test_report_table_has_per_run_coverage(tmp_path):
    pytest.importorskip("matplotlib")
    from sklearn_ifog.report import RunColumns, compensation_report

    time = np.tile(np.arange(0.0, 600.0, 1.0), 2)
    run = np.repeat(["a", "b"], 600)
    drift = 0.01 * time
    reference = 15.0
    rate = reference + drift
    # run a: band always holds the drift; run b: band misses the second half
    interval = np.column_stack([drift - 1.0, drift + 1.0])
    interval[900:] += 5.0
    columns = RunColumns(
        rate=rate,
        drift=drift,
        reference=reference,
        temperature=20.0 + 0 * time,
        time=time,
        run=run,
    )
    result = compensation_report(tmp_path, columns, interval=interval)
    table = result.table
    assert table.loc["a", "coverage"] == 1.0
    assert table.loc["b", "coverage"] == 0.5
    assert table.loc["(all runs)", "coverage"] == 0.75
    assert table.loc["a", "width"] == pytest.approx(2.0)
    with pytest.raises(ValueError, match="interval has shape"):
        compensation_report(tmp_path, columns, interval=interval[:10])


def test_streaming_carries_the_interval():
    from sklearn_ifog.streaming import StreamingCompensator

    X, y = make_thermal_campaign(
        n_units=1,
        n_runs=2,
        azimuths=(0.0, 90.0, 180.0),
        sampling_period=300.0,
        random_state=2,
        return_X_y=True,
    )
    model = ConformalRegressor(make_compensation_pipeline(Ridge()), cv=3).fit(X, y)
    first = X[X["run"] == X["run"].iloc[0]]
    batch = model.predict_interval(first)
    compensator = StreamingCompensator(model)
    chunks = []
    for start in range(0, len(first), 7):
        compensator.update(first.iloc[start : start + 7])
        chunks.append(compensator.last_interval)
    np.testing.assert_allclose(np.concatenate(chunks), batch, rtol=1e-9, atol=1e-9)
    compensator.reset()
    row = first.iloc[0]
    compensator.step(row["time"], row["temperature"], run=row["run"])
    np.testing.assert_allclose(compensator.last_interval, batch[:1], rtol=1e-9, atol=1e-9)
    plain = StreamingCompensator(model.estimator_)
    plain.update(first)
    assert plain.last_interval is None


@pytest.mark.parametrize(
    ("regressor", "compiled"),
    [
        (Ridge(), True),
        (RBFNetRegressor(n_centers=8, tail="linear", random_state=0), True),
        (KNeighborsRegressor(n_neighbors=5), False),
    ],
    ids=["ridge", "rbf", "knn-not-compiled"],
)
@pytest.mark.parametrize("method", ["plus", "base", "minmax"])
def test_streaming_interval_step_by_step_and_in_chunks(regressor, compiled, method):
    # The compiled fast path (issue 13) and the band (issue 14) together: every sample's
    # band, given step by step or in chunks, is the batch predict_interval's.
    from sklearn_ifog.streaming import StreamingCompensator

    X, y = make_thermal_campaign(
        n_units=1,
        n_runs=2,
        azimuths=(0.0, 90.0, 180.0),
        sampling_period=300.0,
        random_state=3,
        return_X_y=True,
    )
    model = ConformalRegressor(make_compensation_pipeline(regressor), cv=3, method=method)
    model.fit(X, y)
    first = X[X["run"] == X["run"].iloc[0]]
    batch = model.predict_interval(first)
    drift = model.predict(first)
    assert np.all(batch[:, 1] > batch[:, 0])

    stepper = StreamingCompensator(model)
    assert stepper.compiled is compiled
    assert (stepper._fold_compiled is not None) is compiled  # the fold models too
    bands, drifts = [], []
    rows = zip(first["time"], first["temperature"], first["run"], strict=True)
    for time, temperature, run in rows:
        drifts.append(stepper.step(time, temperature, run=run)[1])
        assert stepper.last_interval.shape == (1, 2)
        bands.append(stepper.last_interval)
    np.testing.assert_allclose(drifts, drift, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(np.concatenate(bands), batch, rtol=1e-9, atol=1e-9)

    chunker = StreamingCompensator(model)
    bands = []
    for start in range(0, len(first), 11):
        chunker.update(first.iloc[start : start + 11])
        bands.append(chunker.last_interval)
    np.testing.assert_allclose(np.concatenate(bands), batch, rtol=1e-9, atol=1e-9)

    # Restored mid-run from a saved state, the band continues as in batch.
    half = len(first) // 2
    saved = StreamingCompensator(model)
    saved.update(first.iloc[:half])
    restored = StreamingCompensator(model).set_state(saved.get_state())
    restored.update(first.iloc[half:])
    np.testing.assert_allclose(restored.last_interval, batch[half:], rtol=1e-9, atol=1e-9)

    # A call that raises leaves the last band as it was.
    before = restored.last_interval.copy()
    with pytest.raises(ValueError, match="temperature"):
        restored.step(first["time"].iloc[-1] + 300.0, np.nan)
    np.testing.assert_array_equal(restored.last_interval, before)


@pytest.mark.parametrize("adapt", ["bias", "output"])
def test_streaming_refuses_adaptation_of_a_conformal_regressor(adapt):
    from sklearn_ifog.streaming import StreamingCompensator

    X, y = make_thermal_campaign(
        n_units=1, n_runs=1, sampling_period=300.0, random_state=0, return_X_y=True
    )
    model = ConformalRegressor(make_compensation_pipeline(Ridge()), cv=3).fit(X, y)
    with pytest.raises(ValueError, match=f"adapt='{adapt}' is not available with a Conformal"):
        StreamingCompensator(model, adapt=adapt)
    # The wrapped, fitted pipeline itself recalibrates (without a band).
    compensator = StreamingCompensator(model.estimator_, adapt=adapt)
    assert compensator.adapt == adapt
    assert compensator.last_interval is None


@pytest.mark.parametrize("adaptive", [True, False])
def test_bounds_from_predictions_is_predict_interval(adaptive):
    """The public band from predictions made elsewhere is predict_interval's, bit for bit,
    and names what it needs when given too little."""
    X, y, runs = _heteroscedastic(4)
    model = ConformalRegressor(
        make_pipeline(StandardScaler(), Ridge()), adaptive=adaptive, coverage=0.8
    ).fit(X, y, groups=runs)
    folds = np.stack([fold.predict(X) for fold in model.estimators_])
    features = model.estimator_[:-1].transform(X)
    for coverage in (None, 0.95):
        np.testing.assert_array_equal(
            model.bounds_from_predictions(model.predict(X), folds, features, coverage=coverage),
            model.predict_interval(X, coverage=coverage),
        )
    shape = rf"\({len(model.estimators_)}, {X.shape[0]}\), got \({len(folds) - 1}, "
    with pytest.raises(ValueError, match=r"fold_predictions must have shape .*" + shape):
        model.bounds_from_predictions(model.predict(X), folds[:-1], features)
    if adaptive:
        with pytest.raises(ValueError, match="difficulty_features is required"):
            model.bounds_from_predictions(model.predict(X), folds)
