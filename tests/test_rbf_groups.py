"""RBFNetRegressor.fit(groups=...): whole runs held out; and the refinement guard."""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.rbf._select import cv_folds, group_codes, split_rows

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from rbf_run_folds_check import refine_split

sys.path.pop(0)


def test_group_codes_number_groups_by_first_appearance():
    assert group_codes(np.array([7, 7, 3, 9, 3]), 5).tolist() == [0, 0, 1, 2, 1]
    assert group_codes(["b", "a", "b"], 3).tolist() == [0, 1, 0]
    mixed = np.array([1, "a", 2, "b", 1], dtype=object)  # hashed, no order needed
    assert group_codes(mixed, 5).tolist() == [0, 1, 2, 3, 0]


@pytest.mark.parametrize(
    ("groups", "match"),
    [
        (np.zeros(4), r"one label per row of X, of shape \(5,\); got shape \(4,\)"),
        (np.zeros((5, 1)), r"got shape \(5, 1\)"),
        (np.array([0.0, 1.0, np.nan, 1.0, 0.0]), r"groups: missing run id \(NaN\) at row 2"),
        (
            np.array(["a", None, "b", np.nan, "a"], dtype=object),
            r"groups: Missing run id \(None or NaN\) at row 1",
        ),
    ],
)
def test_bad_groups_are_a_value_error_naming_them(groups, match):
    X = np.linspace(0, 1, 5)[:, None]
    with pytest.raises(ValueError, match=match):
        RBFNetRegressor(refine=None).fit(X, X[:, 0], groups=groups)


@pytest.mark.parametrize("n_groups", [2, 3, 9, 10, 25])
def test_cv_folds_hold_out_whole_groups_and_partition_the_rows(n_groups):
    rng = np.random.default_rng(n_groups)
    sizes = rng.integers(3, 30, size=n_groups)
    codes = np.repeat(np.arange(n_groups), sizes)
    folds = cv_folds(codes.size, 0.2, codes)
    assert len(folds) == min(n_groups, 10)
    held = np.concatenate([out for _, out in folds])
    assert np.array_equal(np.sort(held), np.arange(codes.size))  # every row held out once
    for rows_in, rows_out in folds:
        assert np.intersect1d(codes[rows_in], codes[rows_out]).size == 0
        assert np.array_equal(np.sort(np.concatenate([rows_in, rows_out])), np.arange(codes.size))
    if n_groups <= 10:  # one group per fold
        assert sorted(np.unique(codes[out]).size for _, out in folds) == [1] * n_groups


def test_cv_folds_without_groups_or_with_one_are_contiguous_blocks():
    for groups in (None, np.zeros(50, dtype=int)):
        folds = cv_folds(50, 0.2, groups)
        assert [out.tolist() for _, out in folds] == [
            list(range(k * 10, k * 10 + 10)) for k in range(5)
        ]


@pytest.mark.parametrize(("n_groups", "n_held"), [(2, 1), (4, 1), (9, 2), (20, 4)])
def test_split_rows_holds_out_whole_groups(n_groups, n_held):
    codes = np.repeat(np.arange(n_groups), 40)
    train, val = split_rows(np.ones(codes.size), 0.2, needs_blocks=True, groups=codes)
    held = np.unique(codes[val])
    assert held.size == n_held
    assert np.intersect1d(codes[train], held).size == 0
    assert train.size + val.size == codes.size


def test_a_single_group_fits_as_without_groups():
    X, y = make_thermal_campaign(
        n_units=1,
        n_runs=1,
        azimuths=(0.0,),
        sampling_period=120.0,
        random_state=1,
        return_X_y=True,
    )
    plain = make_compensation_pipeline(RBFNetRegressor(random_state=0)).fit(X, y)
    grouped = make_compensation_pipeline(RBFNetRegressor(random_state=0)).fit(
        X, y, regressor__groups=X["run"].to_numpy()
    )
    assert X["run"].nunique() == 1
    np.testing.assert_array_equal(plain.predict(X), grouped.predict(X))


def test_fit_with_groups_holds_out_whole_runs_in_selection_and_refinement(monkeypatch):
    from sklearn_ifog.rbf import _fit, _select

    seen = {"folds": [], "split": []}
    real_folds, real_split = _select.cv_folds, _fit.split_rows

    def recording_folds(*args, **kwargs):
        folds = real_folds(*args, **kwargs)
        seen["folds"].append(folds)
        return folds

    def recording_split(*args, **kwargs):
        rows = real_split(*args, **kwargs)
        seen["split"].append(rows)
        return rows

    monkeypatch.setattr(_select, "cv_folds", recording_folds)
    monkeypatch.setattr(_fit, "split_rows", recording_split)
    X, y = make_thermal_campaign(
        n_units=1, n_runs=2, sampling_period=300.0, random_state=0, return_X_y=True
    )
    runs = X["run"].to_numpy()
    make_compensation_pipeline(RBFNetRegressor(random_state=0)).fit(X, y, regressor__groups=runs)
    (folds,) = seen["folds"]
    assert len(folds) == np.unique(runs).size == 8  # one run per fold
    for rows_in, rows_out in folds:
        assert np.unique(runs[rows_out]).size == 1
        assert np.intersect1d(runs[rows_in], runs[rows_out]).size == 0
    ((train, val),) = seen["split"]
    assert np.unique(runs[val]).size == 2  # round(0.2 * 8) whole runs for the refinement
    assert np.intersect1d(runs[train], runs[val]).size == 0


def test_refine_rejected_is_recorded_and_keeps_the_unrefined_network():
    # The layered cases of tests/test_refine_holdout.py, on their training runs: the guard
    # rejects a refinement in three of them with row blocks (varpro on seeds 0 and 3, gd on
    # seed 2: the "*" of python benchmarks/rbf_run_folds_check.py's refinement table), with
    # the free tail those cases were measured with (tests/test_refine_holdout.py says why).
    found = 0
    for seed in range(5):
        X, y, _, _ = refine_split("layered", seed)
        for mode in ("varpro", "lm", "gd"):
            kwargs = {"n_centers": 10, "criterion": None, "tail_alpha": 0.0, "random_state": seed}
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                refined = make_compensation_pipeline(RBFNetRegressor(refine=mode, **kwargs))
                refined.fit(X, y)
                ols = make_compensation_pipeline(RBFNetRegressor(refine=None, **kwargs))
                ols.fit(X, y)
            path = refined[-1].selection_path_
            assert isinstance(path["refine_rejected"], bool)
            if path["refine_rejected"]:
                found += 1
                assert path["refined"] is False
                np.testing.assert_array_equal(refined[-1].centers_, ols[-1].centers_)
                np.testing.assert_array_equal(refined[-1].widths_, ols[-1].widths_)
                np.testing.assert_allclose(refined.predict(X), ols.predict(X), rtol=1e-12)
    assert found == 3
