"""Splitters across units, azimuths and runs; compare_regressors; grid search with scorers;
the splitters import without the comparison."""

import subprocess
import sys

import numpy as np
import pandas as pd
import polars as pl
import pytest
from sklearn.base import clone
from sklearn.compose import ColumnTransformer
from sklearn.dummy import DummyRegressor
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GridSearchCV, GroupKFold, LeaveOneGroupOut, cross_validate
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import RBFNetRegressor, ThermalFeatures
from sklearn_ifog.comparison import compare_regressors, default_regressors
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.metrics import mean_squared_deviation, neg_mean_squared_deviation_scorer
from sklearn_ifog.model_selection import LeaveOneAzimuthOut, LeaveOneRunOut, LeaveOneUnitOut

# ---------------------------------------------------------------------------------------------
# Splitters
# ---------------------------------------------------------------------------------------------


def _layout_frame():
    """Unit 1: azimuths 0 and 90 (two runs each); unit 2: 0, 45, 135 (one run each); unit 3:
    one azimuth. Runs of different lengths, rows of runs interleaved in blocks."""
    layout = [
        (1, 0.0, 10, 4),
        (1, 0.0, 11, 3),
        (1, 90.0, 12, 5),
        (1, 90.0, 13, 2),
        (2, 0.0, 20, 3),
        (2, 45.0, 21, 4),
        (2, 135.0, 22, 3),
        (3, 0.0, 30, 2),
    ]
    rows = [
        {"unit": unit, "azimuth": azimuth, "run": run, "temperature": 20.0 + i}
        for unit, azimuth, run, n in layout
        for i in range(n)
    ]
    frame = pd.DataFrame(rows)
    # Shuffle whole runs so the splitters cannot rely on contiguous groups.
    order = np.random.default_rng(0).permutation(frame["run"].unique())
    return pd.concat([frame[frame["run"] == run] for run in order], ignore_index=True)


SPLITTERS = [
    LeaveOneUnitOut(),
    LeaveOneAzimuthOut(),
    LeaveOneAzimuthOut(within_unit=False),
    LeaveOneRunOut(),
    LeaveOneRunOut(within_unit=True),
]


@pytest.mark.parametrize("cv", SPLITTERS, ids=repr)
def test_runs_never_straddle_folds_and_test_sets_are_disjoint(cv):
    X = _layout_frame()
    folds = list(cv.split(X))
    assert len(folds) == cv.get_n_splits(X)
    tested = np.concatenate([test for _, test in folds])
    assert len(tested) == len(set(tested.tolist())), "a row is tested twice"
    for train, test in folds:
        assert len(train)
        assert len(test)
        train_runs = set(X["run"].iloc[train])
        test_runs = set(X["run"].iloc[test])
        assert not train_runs & test_runs
        # Whole runs: every row of a tested run is in the test set.
        assert X["run"].isin(test_runs).sum() == len(test)


def test_leave_one_unit_out_folds():
    X = _layout_frame()
    folds = list(LeaveOneUnitOut().split(X))
    assert [sorted(set(X["unit"].iloc[test])) for _, test in folds] == [[1], [2], [3]]
    for train, test in folds:
        assert sorted(np.concatenate([train, test]).tolist()) == list(range(len(X)))


def test_leave_one_azimuth_out_within_unit_trains_on_same_unit():
    X = _layout_frame()
    cv = LeaveOneAzimuthOut()
    described = []
    for train, test in cv.split(X):
        (unit,) = set(X["unit"].iloc[test])
        (azimuth,) = set(X["azimuth"].iloc[test])
        assert set(X["unit"].iloc[train]) == {unit}
        assert azimuth not in set(X["azimuth"].iloc[train])
        # All other azimuths of the unit are in the training set.
        others = X[(X["unit"] == unit) & (X["azimuth"] != azimuth)]
        assert sorted(train.tolist()) == sorted(others.index.tolist())
        described.append((unit, azimuth))
    # Unit 3 has one azimuth: no fold.
    assert described == [(1, 0.0), (1, 90.0), (2, 0.0), (2, 45.0), (2, 135.0)]


def test_leave_one_azimuth_out_pooled_trains_on_all_units():
    X = _layout_frame()
    folds = list(LeaveOneAzimuthOut(within_unit=False).split(X))
    assert [sorted(set(X["azimuth"].iloc[test])) for _, test in folds] == [
        [0.0],
        [45.0],
        [90.0],
        [135.0],
    ]
    train, _test = folds[1]
    assert set(X["unit"].iloc[train]) == {1, 2, 3}


def test_leave_one_run_out_within_unit():
    X = _layout_frame()
    pooled = list(LeaveOneRunOut().split(X))
    within = list(LeaveOneRunOut(within_unit=True).split(X))
    assert len(pooled) == 8
    # Unit 3 has a single run: nothing to train on within the unit.
    assert len(within) == 7
    for train, test in within:
        assert set(X["unit"].iloc[train]) == set(X["unit"].iloc[test])


def test_run_spanning_two_units_is_refused():
    X = _layout_frame()
    X.loc[X.index[X["run"] == 22][:1], "run"] = 10  # a unit-2 row claims unit 1's run 10
    with pytest.raises(ValueError, match=r"Run 10 spans several units \(1, 2\)"):
        list(LeaveOneUnitOut().split(X))
    with pytest.raises(ValueError, match=r"Run 10 spans several (azimuths|units)"):
        LeaveOneAzimuthOut().get_n_splits(X)


def test_run_spanning_two_azimuths_is_refused():
    X = _layout_frame()
    X.loc[X.index[X["run"] == 10][-1], "azimuth"] = 90.0
    with pytest.raises(ValueError, match=r"Run 10 spans several azimuths \(0.0, 90.0\)"):
        list(LeaveOneAzimuthOut().split(X))


def test_groups_override_the_column_and_arrays_use_positions():
    X = _layout_frame()
    by_groups = list(LeaveOneUnitOut().split(X, groups=X["azimuth"].to_numpy()))
    assert len(by_groups) == 4
    array = X[["unit", "azimuth", "run", "temperature"]].to_numpy()
    by_position = list(LeaveOneUnitOut(unit=0, run=2).split(array))
    by_name = list(LeaveOneUnitOut().split(X))
    for (train_a, test_a), (train_b, test_b) in zip(by_position, by_name, strict=True):
        np.testing.assert_array_equal(test_a, test_b)
        np.testing.assert_array_equal(train_a, train_b)


def test_polars_frames_work():
    X = _layout_frame()
    for (_, test_pl), (_, test_pd) in zip(
        LeaveOneAzimuthOut().split(pl.from_pandas(X)), LeaveOneAzimuthOut().split(X), strict=True
    ):
        np.testing.assert_array_equal(test_pl, test_pd)


@pytest.mark.parametrize(
    ("cv", "X", "match"),
    [
        (LeaveOneUnitOut(), pd.DataFrame({"run": [1, 2]}), r"no column 'unit' .*pass groups="),
        (LeaveOneRunOut(), np.zeros((3, 2)), r"no column 'run'"),
        (
            LeaveOneAzimuthOut(),
            pd.DataFrame({"azimuth": [0.0, 90.0]}),
            r"within_unit=True\) needs the unit.*within_unit=False",
        ),
        (LeaveOneUnitOut(), pd.DataFrame({"unit": [1, 1]}), r"at least 2 distinct units"),
        (
            LeaveOneAzimuthOut(),
            pd.DataFrame({"unit": [1, 2], "azimuth": [0.0, 90.0]}),
            r"at least 2 distinct azimuths within any unit",
        ),
        (LeaveOneRunOut(), pd.DataFrame({"run": [1.0, np.nan]}), r"run labels contain NaN"),
    ],
)
def test_bad_layouts_are_explained(cv, X, match):
    with pytest.raises(ValueError, match=match):
        list(cv.split(X))


def test_splitter_in_cross_validate_matches_hand_computation():
    X = _layout_frame()
    y = X["temperature"].to_numpy() * 0.1 + X["unit"].to_numpy()
    result = cross_validate(
        DummyRegressor(), X, y, cv=LeaveOneUnitOut(), scoring="neg_mean_squared_error"
    )
    expected = []
    for unit in (1, 2, 3):
        test = X["unit"].to_numpy() == unit
        expected.append(-np.mean((y[test] - y[~test].mean()) ** 2))
    np.testing.assert_allclose(result["test_score"], expected)


def test_repr_shows_parameters():
    text = " ".join(repr(LeaveOneAzimuthOut(within_unit=False)).split())
    assert text == (
        "LeaveOneAzimuthOut(azimuth='azimuth', run='run', unit='unit', within_unit=False)"
    )


def test_groupkfold_is_not_needed_but_compatible():
    # The package splitters are drop-in replacements for GroupKFold over the same labels.
    X = _layout_frame()
    ours = {tuple(test) for _, test in LeaveOneRunOut().split(X)}
    theirs = {tuple(test) for _, test in GroupKFold(n_splits=8).split(X, groups=X["run"])}
    assert {tuple(sorted(t)) for t in ours} == {tuple(sorted(t)) for t in theirs}


# ---------------------------------------------------------------------------------------------
# compare_regressors on hand-checkable models
# ---------------------------------------------------------------------------------------------


def _linear_on_temperature():
    return make_pipeline(
        ColumnTransformer([("temperature", "passthrough", ["temperature"])]), LinearRegression()
    )


@pytest.fixture
def drift_frame():
    X = _layout_frame()
    rng = np.random.default_rng(1)
    y = 0.05 * (X["temperature"].to_numpy() - 22.0) + 0.01 * rng.normal(size=len(X))
    return X, y


def test_compare_regressors_values_match_hand_computation(drift_frame):
    """The linear model's reduction above 5 held on noise seeds 1-10 (checked once)."""
    X, y = drift_frame
    regressors = {
        "raw": DummyRegressor(strategy="constant", constant=0.0),
        "bias": DummyRegressor(),
        "linear": _linear_on_temperature(),
    }
    cv = LeaveOneUnitOut()
    summary, folds = compare_regressors(X, y, regressors=regressors, cv=cv, return_folds=True)
    assert list(summary.index) == ["raw", "bias", "linear"]
    assert len(folds) == 3 * 3
    for fold, (train, test) in enumerate(cv.split(X)):
        before = np.mean(y[test] ** 2)
        for name, model in regressors.items():
            row = folds[(folds["model"] == name) & (folds["fold"] == fold)].iloc[0]
            prediction = clone(model).fit(X.iloc[train], y[train]).predict(X.iloc[test])
            after = np.mean((y[test] - prediction) ** 2)
            assert row["msd_before"] == pytest.approx(before, rel=1e-12)
            assert row["msd_after"] == pytest.approx(after, rel=1e-12)
            assert row["reduction"] == pytest.approx(before / after, rel=1e-12)
            assert row["n_test"] == len(test)
            assert row["test"].startswith(f"unit={fold + 1};")
    # The raw baseline is the uncompensated output: no reduction at all.
    assert summary.loc["raw", "reduction"] == 1.0
    mean_before = folds.groupby("model")["msd_before"].mean()
    mean_after = folds.groupby("model")["msd_after"].mean()
    for name in regressors:
        assert summary.loc[name, "msd_after"] == pytest.approx(mean_after[name])
        assert summary.loc[name, "reduction"] == pytest.approx(
            mean_before[name] / mean_after[name]
        )
    assert summary.loc["linear", "reduction"] > 5.0
    assert (summary[["fit_time", "predict_time"]] >= 0).all().all()
    assert (summary["n_folds"] == 3).all()


def test_compare_regressors_parallel_equals_serial(drift_frame):
    X, y = drift_frame
    regressors = {"bias": DummyRegressor(), "linear": _linear_on_temperature()}
    columns = ["msd_before", "msd_after", "reduction", "worst_fold_reduction"]
    serial = compare_regressors(X, y, regressors=regressors, n_jobs=1)
    parallel = compare_regressors(X, y, regressors=regressors, n_jobs=2)
    # Equal to rounding: BLAS may sum in another order in the worker processes.
    pd.testing.assert_frame_equal(
        serial[columns], parallel[columns], check_exact=False, rtol=1e-12
    )


def test_compare_regressors_default_cv_and_int_cv_keep_runs_whole(drift_frame):
    X, y = drift_frame
    regressors = {"bias": DummyRegressor()}
    # Default: leave one run out within its unit (unit 3 has one run: no fold).
    _, folds = compare_regressors(X, y, regressors=regressors, return_folds=True)
    assert len(folds) == 7
    # An int is a GroupKFold over the runs, never a KFold cutting runs in two.
    _, folds = compare_regressors(X, y, regressors=regressors, cv=4, return_folds=True)
    assert len(folds) == 4
    runs_per_fold = [set(text.split("run=")[1].split(", ")) for text in folds["test"]]
    assert sum(len(runs) for runs in runs_per_fold) == X["run"].nunique()


def test_compare_regressors_reports_progress(drift_frame, capsys):
    X, y = drift_frame
    compare_regressors(X, y, regressors={"bias": DummyRegressor()}, cv=3, verbose=1)
    err = capsys.readouterr().err
    assert "1 models x 3 folds = 3 fits" in err
    assert "bias: done (3/3 fits)" in err


def test_compare_regressors_bad_input(drift_frame):
    X, y = drift_frame
    with pytest.raises(TypeError, match="non-empty dict"):
        compare_regressors(X, y, regressors=[DummyRegressor()])
    with pytest.raises(TypeError, match=r"regressors\['scaler'\] has no fit/predict"):
        compare_regressors(X, y, regressors={"scaler": object()})
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        compare_regressors(X, y[:-1], regressors={"b": DummyRegressor()})
    with pytest.raises(ValueError, match="no 'run' column"):
        compare_regressors(X.drop(columns="run"), y, regressors={"b": DummyRegressor()}, cv=2)


# ---------------------------------------------------------------------------------------------
# The package's models: default comparison and grid search with the package's scorer
# ---------------------------------------------------------------------------------------------


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_default_comparison_on_a_small_campaign(small_campaign):
    """The default table on the session's small campaign (seed 0): every model beats the raw
    output, and the thermal models each leave at most half the MSD of the bias model.

    Checked once on campaign seeds 0-9 (holds on each): the four thermal models' reductions
    were 2.19 (seed 5) to 11.5 times the bias model's. An absolute reduction of at least 15
    (the earlier claim) fails on seeds 5 and 7 (Gaussian process 10.5 and 14.6) and 9 (all
    four, 8.1 to 9.2): the reduction a campaign allows depends on its drift against its
    noise, so the models are judged against their peer in the same run.
    """
    X, y = small_campaign.data, small_campaign.target
    summary, folds = compare_regressors(X, y, cv=LeaveOneAzimuthOut(), return_folds=True)
    assert list(summary.index) == list(default_regressors())
    assert len(folds) == len(default_regressors()) * 2
    # msd_before is the raw MSD of each test azimuth, the same for every model.
    for fold, (_, test) in enumerate(LeaveOneAzimuthOut().split(X)):
        before = folds.loc[folds["fold"] == fold, "msd_before"]
        np.testing.assert_allclose(before, np.mean(y.to_numpy()[test] ** 2), rtol=1e-12)
    assert summary.loc["raw", "reduction"] == 1.0
    # Measured on this campaign (reduction factors; layered physics, whose turn-on bias the
    # constant model removes): linear 34.6, kernel ridge 34.5, Gaussian process 29.9, RBF
    # modified 34.6, RBF traditional 32.3, bias 12.2.
    for name in ("linear", "kernel_ridge", "gaussian_process", "rbf_modified"):
        assert summary.loc[name, "msd_after"] < summary.loc["bias", "msd_after"] / 2, name
    assert (summary.drop(index="raw")["reduction"] > 1.0).all()
    assert (summary["fit_time"] > 0).all()


def test_grid_search_over_features_and_network_with_the_package_scorer():
    X, y = make_thermal_campaign(
        n_units=1, n_runs=3, azimuths=0.0, sampling_period=60.0, random_state=0, return_X_y=True
    )
    pipe = Pipeline(
        [
            ("features", ThermalFeatures(time="time", run="run")),
            ("scale", StandardScaler()),
            ("rbf", RBFNetRegressor(refine=None, random_state=0)),
        ]
    )
    grid = {
        "features__terms": [("T",), ("T", "dT", "TdT")],
        "features__smoothing": [0.0, 6000.0],
        "rbf__tail": [False, True],
    }
    search = GridSearchCV(
        pipe, grid, cv=LeaveOneGroupOut(), scoring=neg_mean_squared_deviation_scorer
    ).fit(X, y, groups=X["run"])
    # Measured: -6.60e-4 for the best, -6.96e-4 for the runner-up (no smoothing); with the
    # free tail of before issue 41 the two were swapped (-6.95e-4 and -7.06e-4).
    assert search.best_params_ == {
        "features__smoothing": 6000.0,
        "features__terms": ("T", "dT", "TdT"),
        "rbf__tail": True,
    }
    # The score of a fold is minus the MSD of that fold, recomputed by hand.
    train, test = next(LeaveOneGroupOut().split(X, y, groups=X["run"]))
    for index in (search.best_index_, 0):
        params = search.cv_results_["params"][index]
        model = clone(pipe).set_params(**params).fit(X.iloc[train], y.iloc[train])
        msd = mean_squared_deviation(y.iloc[test], model.predict(X.iloc[test]))
        assert search.cv_results_["split0_test_score"][index] == pytest.approx(-msd, rel=1e-12)
    # The package's splitter reads the run column itself: same search, same scores, fold by
    # fold (on the best and the first candidate: each score is one fold's fit, so the other
    # candidates would only repeat the check).
    folds = zip(
        LeaveOneRunOut().split(X), LeaveOneGroupOut().split(X, y, groups=X["run"]), strict=True
    )
    for (train_run, test_run), (train_group, test_group) in folds:
        np.testing.assert_array_equal(train_run, train_group)
        np.testing.assert_array_equal(test_run, test_group)
    indices = [search.best_index_, 0]
    candidates = [search.cv_results_["params"][index] for index in indices]
    by_column = GridSearchCV(
        pipe,
        [{name: [value] for name, value in params.items()} for params in candidates],
        cv=LeaveOneRunOut(),
        scoring=neg_mean_squared_deviation_scorer,
    ).fit(X, y)
    assert by_column.cv_results_["params"] == candidates
    assert by_column.n_splits_ == search.n_splits_
    for split in range(search.n_splits_):
        key = f"split{split}_test_score"
        np.testing.assert_array_equal(by_column.cv_results_[key], search.cv_results_[key][indices])


def test_run_spanning_two_units_is_refused_within_unit_run_splits():
    X = _layout_frame()
    X.loc[X.index[X["run"] == 20][:1], "run"] = 10
    with pytest.raises(ValueError, match=r"Run 10 spans several units \(1, 2\)"):
        LeaveOneRunOut(within_unit=True).get_n_splits(X)
    # Pooled leave-one-run-out keeps every run whole whatever its units.
    assert LeaveOneRunOut().get_n_splits(X) == X["run"].nunique()


@pytest.mark.parametrize(
    "splitter", [LeaveOneUnitOut, LeaveOneAzimuthOut, LeaveOneRunOut], ids=lambda c: c.__name__
)
def test_splitter_parameters_are_keyword_only(splitter):
    with pytest.raises(TypeError, match="positional"):
        splitter("unit")
    assert splitter(run="id").run == "id"


# ---------------------------------------------------------------------------------------------
# Imports
# ---------------------------------------------------------------------------------------------


def test_splitters_alone_do_not_load_the_comparison():
    """Importing the splitters leaves the baselines (MLP, SVR, GP, ...) unloaded."""
    code = (
        "import sys\n"
        "from sklearn_ifog.model_selection import LeaveOneRunOut\n"
        "print('sklearn_ifog.comparison' in sys.modules)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True
    )
    assert result.stdout.split() == ["False"]
