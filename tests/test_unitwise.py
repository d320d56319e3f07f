"""UnitwiseRegressor and the partial-pooling numerics."""

import numpy as np
import pandas as pd
import polars as pl
import pytest
from sklearn.base import clone
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.tree import DecisionTreeRegressor

from sklearn_ifog import (
    RBFNetRegressor,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog import _shrinkage as shrinkage
from sklearn_ifog._compat import InvalidParameterError
from sklearn_ifog._output_layer import layer_design, layer_weights, with_weights
from sklearn_ifog._pooling import layer_inputs, own_score
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.unitwise import OWN_MODEL_SPREAD


@pytest.fixture(scope="module")
def lot():
    """Four similar units, three runs each, coarse sampling (fast)."""
    return make_thermal_campaign(
        n_units=4,
        n_runs=3,
        azimuths=[0.0],
        sampling_period=300.0,
        lot_spread=0.15,
        random_state=3,
    )


def _linear():
    return make_compensation_pipeline(LinearRegression())


def _rbf():
    return make_compensation_pipeline(
        RBFNetRegressor(refine=None, tail="linear", max_samples=400, random_state=0)
    )


def _unit_rows(lot, unit):
    return (lot.data["unit"] == unit).to_numpy()


# -- pooling "none" and "full" ---------------------------------------------------------------


def test_none_fits_each_unit_alone(lot):
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling="none").fit(X, y)
    assert model.lot_estimator_ is None
    assert model.shrinkage_ is None
    prediction = model.predict(X)
    for unit in range(4):
        rows = _unit_rows(lot, unit)
        alone = _linear().fit(X[rows].drop(columns="unit"), y[rows])
        np.testing.assert_array_equal(
            prediction[rows], alone.predict(X[rows].drop(columns="unit"))
        )


def test_full_is_one_model_for_the_lot(lot):
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling="full").fit(X, y)
    single = _linear().fit(X.drop(columns="unit"), y)
    np.testing.assert_array_equal(model.predict(X), single.predict(X.drop(columns="unit")))
    assert all(estimator is model.lot_estimator_ for estimator in model.estimators_.values())


def test_unit_column_is_removed_before_the_estimator(lot):
    X, y = lot.data, lot.target.to_numpy()
    for pooling in ("none", "full", "partial"):
        model = UnitwiseRegressor(_linear(), pooling=pooling).fit(X, y)
        for estimator in model.estimators_.values():
            assert "unit" not in estimator.feature_names_in_.tolist()
        assert model.feature_names_in_.tolist() == list(X.columns)


def test_rows_of_interleaved_units_keep_their_order(lot):
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    expected = model.predict(X)
    # the same rows with the units in reverse order: each row keeps its own prediction
    order = np.concatenate([np.flatnonzero(_unit_rows(lot, unit)) for unit in (3, 2, 1, 0)])
    np.testing.assert_array_equal(model.predict(X.iloc[order]), expected[order])


# -- pooling "partial" ----------------------------------------------------------------------


def _first_runs(lot):
    """Every unit's first run only: single-run units."""
    first = (lot.frame.groupby("unit")["run"].transform("min") == lot.frame["run"]).to_numpy()
    return lot.data[first], lot.target.to_numpy()[first]


def _lot_layer(model, X):
    """The lot model's output-layer design on X (with the unit column), weights, scales."""
    lot_final = model.lot_estimator_.steps[-1][1]
    Phi = layer_design(lot_final, layer_inputs(model.lot_estimator_, X.drop(columns="unit")))
    return Phi, layer_weights(lot_final), shrinkage.design_scale(Phi)


@pytest.mark.parametrize("make", [_linear, _rbf], ids=["linear", "rbf"])
def test_partial_keeps_the_lot_basis_and_solves_the_shrunk_weights(lot, make):
    X, y = _first_runs(lot)  # single-run units of one design: near the lot
    model = UnitwiseRegressor(make(), pooling="partial").fit(X, y)
    lot_final = model.lot_estimator_.steps[-1][1]
    Phi, prior, scale = _lot_layer(model, X)
    prediction = model.predict(X)
    for unit in range(4):
        rows = (X["unit"] == unit).to_numpy()
        final = model.estimators_[unit].steps[-1][1]
        if isinstance(final, RBFNetRegressor):
            np.testing.assert_array_equal(final.centers_, lot_final.centers_)
            np.testing.assert_array_equal(final.widths_, lot_final.widths_)
            np.testing.assert_array_equal(final.x_mean_, lot_final.x_mean_)
        lam = model.shrinkage_[unit]
        assert lam in model.shrinkage_grid_
        (expected,) = shrinkage.solve_shrunk(Phi[rows], y[rows, None], prior, scale, [lam])
        np.testing.assert_allclose(layer_weights(final), expected, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(prediction[rows], Phi[rows] @ expected[:, 0], atol=1e-9)
    # the lot model is left untouched by the per-unit copies
    assert model.lot_estimator_.steps[-1][1] is lot_final


def test_strength_maximises_each_units_evidence(lot):
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    Phi, prior, scale = _lot_layer(model, X)
    grid = model.shrinkage_grid_
    for unit in range(4):
        rows = _unit_rows(lot, unit)
        evidence = shrinkage.log_evidence(Phi[rows], y[rows, None], prior, scale, grid)
        np.testing.assert_allclose(model.shrinkage_evidence_[unit], evidence, rtol=1e-9)
        assert evidence[0] == -np.inf  # strength 0: a flat prior, never chosen
        best = np.flatnonzero(evidence >= evidence.max() - 1e-12 * abs(evidence.max()))[-1]
        if rows.sum() * grid[best] <= OWN_MODEL_SPREAD**-2:
            assert model.shrinkage_[unit] is None  # far from the lot: its own model
        else:
            assert model.shrinkage_[unit] == grid[best]
        assert model.n_folds_[unit] == 3  # one held-out run at a time
        assert model.shrinkage_scores_[unit].shape == grid.shape
        assert model.own_scores_[unit] is None  # a linear model's own fit is strength 0


def test_strength_zero_is_the_units_own_linear_fit_and_inf_the_lots(lot):
    """On a linear pipeline the lot's basis spans the unit's own model's."""
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    none = UnitwiseRegressor(_linear(), pooling="none").fit(X, y)
    Phi, prior, scale = _lot_layer(model, X)
    for unit in range(4):
        rows = _unit_rows(lot, unit)
        own, pooled = shrinkage.solve_shrunk(Phi[rows], y[rows, None], prior, scale, [0.0, np.inf])
        inner = X[rows].drop(columns="unit")
        np.testing.assert_allclose(
            with_weights(model.lot_estimator_, own).predict(inner),
            none.estimators_[unit].predict(inner),
            rtol=1e-6,
            atol=1e-9,
        )
        np.testing.assert_array_equal(
            with_weights(model.lot_estimator_, pooled).predict(inner),
            model.lot_estimator_.predict(inner),
        )


def test_log_evidence_is_the_gaussian_marginal_likelihood():
    """Against the dense covariance of the targets, the noise variance at its maximum."""
    rng = np.random.default_rng(4)
    n_samples = 40
    Phi = np.column_stack([rng.normal(size=(n_samples, 3)), np.ones(n_samples)])
    prior = rng.normal(size=(4, 1))
    Y = Phi @ (prior + rng.normal(0, 0.3, (4, 1))) + rng.normal(0, 0.2, (n_samples, 1))
    scale = np.array([0.5, 1.0, 2.0, 1.0])
    strengths = np.array([1e-3, 1e-1, 10.0, np.inf])
    residual = (Y - Phi @ prior)[:, 0]
    dense = []
    for lam in strengths:
        spread = 0.0 if np.isinf(lam) else 1.0 / (n_samples * lam)
        C = np.eye(n_samples) + spread * (Phi / scale**2) @ Phi.T
        sigma2 = residual @ np.linalg.solve(C, residual) / n_samples
        dense.append(-0.5 * (n_samples * np.log(sigma2) + np.linalg.slogdet(C)[1]))
    found = shrinkage.log_evidence(Phi, Y, prior, scale, strengths)
    # equal up to one constant
    np.testing.assert_allclose(found - found[0], np.array(dense) - dense[0], atol=1e-8)
    assert shrinkage.log_evidence(Phi, Y, prior, scale, [0.0])[0] == -np.inf


def test_own_models_are_chosen_for_the_lot_on_held_out_errors(lot):
    """RBF network: every multi-run unit keeps its own model, or only those the evidence
    puts far from the lot do, as the summed held-out errors say."""
    X, y = lot.data, lot.target.to_numpy().copy()
    odd = _unit_rows(lot, 1)
    y[odd] = -5.0 * y[odd] + 0.3
    model = UnitwiseRegressor(_rbf(), pooling="partial").fit(X, y)
    grid = model.shrinkage_grid_
    own_total = shrunk_total = 0.0
    far = []
    for unit in range(4):
        size = _unit_rows(lot, unit).sum()
        own_total += model.own_scores_[unit] * size
        # the chosen strength is the evidence's, whether or not the own model was kept
        lam = shrinkage.pick_strength(-model.shrinkage_evidence_[unit], grid)
        shrunk_total += model.shrinkage_scores_[unit][grid == lam][0] * size
        if size * lam <= OWN_MODEL_SPREAD**-2:
            far.append(unit)
    owners = [unit for unit in range(4) if model.shrinkage_[unit] is None]
    assert owners == ([0, 1, 2, 3] if own_total < shrunk_total else far)
    lot_final = model.lot_estimator_.steps[-1][1]
    for unit in range(4):
        final = model.estimators_[unit].steps[-1][1]
        rows = _unit_rows(lot, unit)
        if unit in owners:
            alone = _rbf().fit(X[rows].drop(columns="unit"), y[rows])
            np.testing.assert_array_equal(final.coef_, alone.steps[-1][1].coef_)
        else:
            np.testing.assert_array_equal(final.centers_, lot_final.centers_)


def test_own_wins_follows_the_summed_errors():
    """The lot-level choice itself, on given scores: the sums decide, weighted by rows."""
    model = UnitwiseRegressor(_rbf())
    grid = shrinkage.SHRINKAGE_GRID
    rows = {"a": np.arange(10), "b": np.arange(30)}
    model.shrinkage_ = {"a": grid[3], "b": grid[5]}
    model.shrinkage_scores_ = {"a": np.full(grid.size, 1.0), "b": np.full(grid.size, 1.0)}
    model.own_scores_ = {"a": 1.2, "b": 0.9}
    # rows weigh: 10 * 1.2 + 30 * 0.9 = 39 < 40
    assert model._own_wins({"a": 2, "b": 2}, rows, grid)
    model.own_scores_ = {"a": 1.2, "b": 0.95}  # 12 + 28.5 = 40.5 > 40
    assert not model._own_wins({"a": 2, "b": 2}, rows, grid)
    # the sum decides, not each unit: one unit far better alone carries the other
    model.own_scores_ = {"a": 3.0, "b": 0.2}
    assert model._own_wins({"a": 3, "b": 3}, rows, grid)
    # no unit with several runs, or a model without an own score: never
    assert not model._own_wins({}, rows, grid)
    model.own_scores_ = {"a": None, "b": 0.2}
    assert not model._own_wins({"a": 3, "b": 3}, rows, grid)


def test_own_score_refits_the_output_layer_without_each_held_out_run(lot):
    """The own model's held-out error: its basis kept, its output layer re-solved on the
    other runs as the network solves it (ridge alpha per row on the Gaussian weights, the
    tail's penalty of its shape on the tail, the intercept free), the held-out run predicted
    (checked by lstsq on the augmented system)."""
    rows = _unit_rows(lot, 0)
    X, y = lot.data[rows].drop(columns="unit"), lot.target.to_numpy()[rows]
    model = make_compensation_pipeline(
        RBFNetRegressor(
            n_centers=6, criterion=None, refine=None, alpha=1e-3, max_samples=400, random_state=0
        )
    ).fit(X, y)
    final = model.steps[-1][1]
    assert final.centers_.shape[0] == 6
    runs = X["run"].to_numpy()
    folds = shrinkage.cv_folds(runs)
    assert len(folds) == 3
    Phi = layer_design(final, layer_inputs(model, X))
    # The default tail penalty, "spread": tail_alpha * ||M^-1 w||^2 on the tail weights w.
    tail_alpha = final.selection_path_["tail_alpha"]
    M = final.selection_path_["tail_transform"]
    assert tail_alpha > 0
    assert M is not None
    n_tail = M.shape[0]
    sse = 0.0
    for test in folds:
        n_train = np.count_nonzero(~test)
        ridge = np.zeros((6 + n_tail, Phi.shape[1]))
        ridge[:6, :6] = np.sqrt(n_train * 1e-3) * np.eye(6)
        ridge[6:, 6 : 6 + n_tail] = np.sqrt(n_train * tail_alpha) * np.linalg.inv(M)
        A = np.vstack([Phi[~test], ridge])
        b = np.r_[y[~test], np.zeros(6 + n_tail)]
        weights = np.linalg.lstsq(A, b, rcond=None)[0]
        sse += float(np.sum(np.square(y[test] - Phi[test] @ weights)))
    score = own_score(model, X, y[:, None], folds)
    np.testing.assert_allclose(score, sse / y.size, rtol=1e-6)
    # a fold leaving fewer rows than output weights cannot score the model
    assert own_score(model, X.iloc[:3], y[:3, None], [np.array([True, False, False])]) == np.inf
    assert own_score(None, X, y[:, None], folds) == np.inf


def test_partial_with_identical_units_gives_the_lot_model(lot):
    """Units that are the same recordings: the lot knows them all; partial = full."""
    rows = _unit_rows(lot, 0)
    X0, y0 = lot.data[rows], lot.target.to_numpy()[rows]
    X = pd.concat(
        [X0.assign(unit=unit, run=X0["run"] + 100 * k) for k, unit in enumerate("abc")],
        ignore_index=True,
    )
    y = np.tile(y0, 3)
    partial = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    full = UnitwiseRegressor(_linear(), pooling="full").fit(X, y)
    np.testing.assert_allclose(partial.predict(X), full.predict(X), rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("seed", range(25))
def test_partial_lets_a_unit_unlike_the_lot_keep_its_own_weights(seed):
    """One unit's drift reversed: the lot's weights are wrong for it, its own are right.

    On every lot seed of 0-24 (the fixture's lot shape, seed 3 among them): partial pooling
    leaves the reversed unit within 10 % of its own model's error and that under a tenth of
    the lot's. The unit keeps its own model altogether (``shrinkage_`` None) on every seed
    but 21 (asserted), where the evidence picks the strength 0.001 and the error is within
    0.2 % of its own model's (0.001418 against 0.001416): a threshold of the evidence, not a
    unit pulled towards the lot. Checked once on lot seeds 0-49 (the same: all but 21).
    """
    lot = make_thermal_campaign(
        n_units=4,
        n_runs=3,
        azimuths=[0.0],
        sampling_period=300.0,
        lot_spread=0.15,
        random_state=seed,
    )
    X, y = lot.data, lot.target.to_numpy().copy()
    odd = _unit_rows(lot, 2)
    y[odd] = -3.0 * y[odd]
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    none = UnitwiseRegressor(_linear(), pooling="none").fit(X, y)
    full = UnitwiseRegressor(_linear(), pooling="full").fit(X, y)
    msd = {
        name: np.mean((y[odd] - m.predict(X[odd])) ** 2)
        for name, m in (("partial", model), ("none", none), ("full", full))
    }
    assert msd["partial"] <= 1.1 * msd["none"] < 0.1 * msd["full"]
    if seed == 21:
        assert model.shrinkage_[2] == pytest.approx(0.001)
        return
    # the evidence puts it far from the lot: its own model altogether
    assert model.shrinkage_[2] is None
    np.testing.assert_array_equal(model.predict(X[odd]), none.predict(X[odd]))


@pytest.mark.parametrize("reversed_unit", [False, True], ids=["similar", "one-reversed"])
def test_the_own_model_rule_follows_the_evidence_unit_by_unit(lot, reversed_unit):
    """A unit of several runs keeps its own model exactly when n lam <= 1 / spread², and a
    unit whose drift is reversed does.

    The rule counts the distance from the lot in noise standard deviations, not in design:
    at lot_spread=0.15 (the fixture's lot, without the reversal) units of this lot shape do
    keep their own models on lot seeds 0, 2, 4, 6, 8, 11, 16 and 17 (of 0-19, checked once),
    none on the fixture's 3, so no count of kept units is asserted here (a lot of one design
    without scatter keeps none: the next test). The reversed unit is kept on every lot seed
    of 0-19 (checked once; the other units may be too, as the reversed unit pulls the
    lot's model away from them all).
    """
    X, y = lot.data, lot.target.to_numpy().copy()
    if reversed_unit:
        y[_unit_rows(lot, 1)] *= -1.0
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    grid = model.shrinkage_grid_
    kept = set()
    for unit in range(4):
        rows = _unit_rows(lot, unit)
        strength = shrinkage.pick_strength(-model.shrinkage_evidence_[unit], grid)
        far = rows.sum() * strength <= OWN_MODEL_SPREAD**-2
        assert (model.shrinkage_[unit] is None) == far, unit
        if far:
            kept.add(unit)
            inner = X[rows].drop(columns="unit")
            own = clone(_linear()).fit(inner, y[rows])
            np.testing.assert_array_equal(
                model.estimators_[unit].predict(inner), own.predict(inner)
            )
    if reversed_unit:
        assert 1 in kept


@pytest.mark.parametrize("seed", [4, 6])
def test_units_of_one_design_keep_no_own_model_and_a_reversed_one_does(seed):
    """Units of one design without scatter (lot_spread=0: they differ by their noise and
    their runs only): the evidence puts none of them ``OWN_MODEL_SPREAD`` (3) noise standard
    deviations from the lot, so none keeps its own model; with unit 1's drift reversed, unit
    1 does.

    Both hold on lot seeds 0-19 (checked once); seeds 4 and 6, the two whose smallest
    ``n lam`` lies closest above the threshold 1 / OWN_MODEL_SPREAD², run here.
    """
    lot = make_thermal_campaign(
        n_units=4,
        n_runs=3,
        azimuths=[0.0],
        sampling_period=300.0,
        lot_spread=0.0,
        random_state=seed,
    )
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    assert all(model.shrinkage_[unit] is not None for unit in range(4))
    reversed_y = np.where(_unit_rows(lot, 1), -y, y)
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, reversed_y)
    assert model.shrinkage_[1] is None


def test_single_run_units_share_one_strength(lot):
    X, y = _first_runs(lot)
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    assert len(set(model.shrinkage_.values())) == 1
    assert set(model.n_folds_.values()) == {0}
    assert all(model.shrinkage_scores_[unit] is None for unit in range(4))
    total = sum(model.shrinkage_evidence_[unit] for unit in range(4))
    assert model.shrinkage_[0] == shrinkage.pick_strength(-total, model.shrinkage_grid_)
    # run=None: every unit is one run too, whatever the estimator reads
    no_run = UnitwiseRegressor(_linear(), pooling="partial", run=None).fit(lot.data, lot.target)
    assert set(no_run.n_folds_.values()) == {0}
    assert len(set(no_run.shrinkage_.values())) == 1


def _single_run_units(offsets, slopes, seed=0):
    """One run per unit: a drift of its own slope in T plus an offset, noise 0.02 deg/h."""
    rng = np.random.default_rng(seed)
    frames, targets = [], []
    for unit, (offset, slope) in enumerate(zip(offsets, slopes, strict=True)):
        t = np.r_[np.full(20, 10.0), np.linspace(10.0, 40.0, 40), np.full(20, 40.0)]
        t = t + rng.normal(scale=0.01, size=t.size)
        frames.append(
            pd.DataFrame({"unit": unit, "run": unit, "time": 60.0 * np.arange(t.size)}).assign(
                temperature=t
            )
        )
        targets.append(offset + slope * (t - 25.0) + rng.normal(scale=0.02, size=t.size))
    return pd.concat(frames, ignore_index=True), np.concatenate(targets)


@pytest.mark.parametrize(
    ("offsets", "slopes", "far"),
    [
        ((0.0, 1.0, -1.0, 0.5), (0.1, -0.3, 0.5, -0.7), True),
        ((0.0, 0.002, -0.002, 0.001), (0.1, 0.1001, 0.0999, 0.1), False),
    ],
    ids=["unlike", "alike"],
)
def test_single_run_units_far_from_the_lot_keep_their_own_models(offsets, slopes, far):
    """The far-unit rule holds for single-run units too, from their shared strength: units
    unlike each other (offsets and slopes of both signs, tens of noise deviations apart) keep
    their own models, equal to pooling "none"; units of one design (apart by a tenth of the
    noise) keep the shrunk weights."""
    X, y = _single_run_units(offsets, slopes)
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    total = sum(model.shrinkage_evidence_[unit] for unit in range(4))
    shared = shrinkage.pick_strength(-total, model.shrinkage_grid_)
    none = UnitwiseRegressor(_linear(), pooling="none").fit(X, y)
    for unit in range(4):
        rows = (X["unit"] == unit).to_numpy()
        assert (rows.sum() * shared <= OWN_MODEL_SPREAD**-2) == far
        if far:
            assert model.shrinkage_[unit] is None
            np.testing.assert_allclose(
                model.predict(X[rows]), none.predict(X[rows]), rtol=1e-12, atol=1e-12
            )
        else:
            assert model.shrinkage_[unit] == shared
            final = model.estimators_[unit].steps[-1][1]
            Phi, prior, scale = _lot_layer(model, X)
            (expected,) = shrinkage.solve_shrunk(Phi[rows], y[rows, None], prior, scale, [shared])
            np.testing.assert_allclose(layer_weights(final), expected, rtol=1e-9, atol=1e-12)


def test_partial_accepts_a_bare_linear_model_and_two_outputs():
    rng = np.random.default_rng(0)
    X = pd.DataFrame({"unit": np.repeat([0, 1], 60)}).assign(
        a=rng.normal(size=120), b=rng.normal(size=120)
    )
    Y = np.column_stack([X["a"] * (1 + X["unit"]), X["b"] - X["unit"]])
    model = UnitwiseRegressor(Ridge(alpha=1e-6), pooling="partial", run=None).fit(X, Y)
    prediction = model.predict(X)
    assert prediction.shape == (120, 2)
    np.testing.assert_allclose(prediction, Y, atol=1e-3)


# -- tables ----------------------------------------------------------------------------------


def test_arrays_and_polars_give_the_pandas_result(lot):
    X, y = lot.data, lot.target.to_numpy()
    expected = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y).predict(X)
    on_polars = UnitwiseRegressor(_linear(), pooling="partial").fit(pl.from_pandas(X), y)
    np.testing.assert_allclose(on_polars.predict(pl.from_pandas(X)), expected, rtol=1e-12)
    # an array: the unit at position 0; the estimator's positions count without it
    # (data columns: unit, run, azimuth, time, temperature)
    inner = make_compensation_pipeline(LinearRegression(), temperature=3, time=2, run=0)
    on_array = UnitwiseRegressor(inner, unit=0, run=1, pooling="partial")
    on_array.fit(X.to_numpy(), y)
    np.testing.assert_allclose(on_array.predict(X.to_numpy()), expected, rtol=1e-9)


# -- errors ----------------------------------------------------------------------------------


def test_missing_unit_column_is_named(lot):
    X, y = lot.data.drop(columns="unit"), lot.target
    with pytest.raises(ValueError, match=r"Column 'unit' \(unit\) not found"):
        UnitwiseRegressor(_linear()).fit(X, y)
    model = UnitwiseRegressor(_linear(), pooling="none").fit(lot.data, y)
    with pytest.raises(ValueError, match="unit"):
        model.predict(X)


def test_unknown_unit_at_predict_is_named(lot):
    model = UnitwiseRegressor(_linear(), pooling="full").fit(lot.data, lot.target)
    X = lot.data.copy()
    X.loc[X.index[5:], "unit"] = 42
    with pytest.raises(ValueError, match=r"unit 42 .*not seen in fit.*\[0, 1, 2, 3\]"):
        model.predict(X)


@pytest.mark.parametrize("missing", [np.nan, None])
@pytest.mark.parametrize("pooling", ["none", "partial", "full"])
def test_a_missing_unit_id_is_named_with_its_row(lot, pooling, missing):
    """A NaN (or None) in the unit column is a missing unit id: a ValueError naming the
    column and the first such row, at fit and at predict; a fitted model stays as it was."""
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling=pooling).fit(X, y)
    state, expected = _fitted_state(model), model.predict(X)
    holed = X.astype({"unit": object})
    holed.loc[holed.index[7], "unit"] = missing
    message = r"unit column 'unit' has missing unit ids \(first at row 7\)"
    with pytest.raises(ValueError, match=message):
        model.fit(holed, y)
    _assert_unchanged(model, state, X, expected)
    with pytest.raises(ValueError, match=message):
        model.predict(holed)


@pytest.mark.parametrize("pooling", ["none", "partial", "full"])
def test_a_unit_at_one_temperature_is_named(lot, pooling):
    """A unit whose temperature never changes (a stuck sensor, or a unit calibrated at one
    temperature) says nothing of its thermal drift: a ValueError naming the unit, the
    feature and the value, whatever the pooling; a fitted model stays as it was."""
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling=pooling).fit(X, y)
    state, expected = _fitted_state(model), model.predict(X)
    stuck = X.copy()
    stuck.loc[_unit_rows(lot, 2), "temperature"] = 21.5
    n_rows = int(_unit_rows(lot, 2).sum())
    message = (
        rf"unit 2 \(column 'unit'.*'T'.* is constant \(21\.5\) over the "
        rf"{n_rows} calibration rows"
        if pooling == "none"
        else rf"unit 2 \(column 'unit' of X\): its temperature \(feature 'T'\) is constant "
        rf"\(21\.5\) over its {n_rows} calibration rows"
    )
    with pytest.raises(ValueError, match=message):
        model.fit(stuck, y)
    _assert_unchanged(model, state, X, expected)


def test_add_units_names_a_new_unit_at_one_temperature(lot):
    X, y = lot.data, lot.target.to_numpy()
    fitted = ~_unit_rows(lot, 3)
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X[fitted], y[fitted])
    new = X[~fitted].copy()
    new["temperature"] = 30.0
    with pytest.raises(ValueError, match=r"unit 3 \(column 'unit' of X\): .*constant \(30\.0\)"):
        model.add_units(new, y[~fitted])
    assert 3 not in model.estimators_
    model.add_units(X[~fitted], y[~fitted])  # the same unit with its real temperatures
    assert 3 in model.estimators_


def test_unknown_pooling_is_rejected(lot):
    with pytest.raises(InvalidParameterError, match="pooling"):
        UnitwiseRegressor(_linear(), pooling="some").fit(lot.data, lot.target)


def test_partial_needs_a_linear_output_layer(lot):
    estimator = make_compensation_pipeline(DecisionTreeRegressor())
    with pytest.raises(ValueError, match="DecisionTreeRegressor has none"):
        UnitwiseRegressor(estimator, pooling="partial").fit(lot.data, lot.target)
    # the other poolings take any regressor
    UnitwiseRegressor(estimator, pooling="none").fit(lot.data, lot.target)


def test_partial_names_a_missing_run_column(lot):
    X = lot.data.rename(columns={"run": "recording"})
    estimator = make_compensation_pipeline(LinearRegression(), run="recording")
    with pytest.raises(ValueError, match=r"Column 'run' \(run\) not found.*run=None"):
        UnitwiseRegressor(estimator, pooling="partial").fit(X, lot.target)
    model = UnitwiseRegressor(estimator, pooling="partial", run="recording").fit(X, lot.target)
    assert set(model.n_folds_.values()) == {3}


def test_a_failing_unit_is_named(lot):
    X = lot.data.copy()
    rows = _unit_rows(lot, 2)
    X.loc[rows, "time"] = X.loc[rows, "time"].to_numpy()[::-1]  # time running backwards
    with pytest.raises(ValueError, match=r"unit 2 \(column 'unit'\): time column 'time'"):
        UnitwiseRegressor(_linear(), pooling="none").fit(X, lot.target)


def _fitted_state(model):
    return {key: value for key, value in vars(model).items() if key.endswith("_")}


def _assert_unchanged(model, state, X, expected):
    after = _fitted_state(model)
    assert after.keys() == state.keys()
    assert all(after[key] is state[key] for key in state)
    np.testing.assert_array_equal(model.predict(X), expected)


@pytest.mark.parametrize(
    ("final", "n_rows", "needed"),
    [
        (LinearRegression(), 1, "at least 2"),
        (DecisionTreeRegressor(random_state=0), 1, "at least 2"),
        # 8 default features and the intercept: 9 output-layer weights
        (LinearRegression(), 5, r"at least 9 here \(LinearRegression with 9 output-layer"),
    ],
    ids=["one-row-linear", "one-row-tree", "five-rows-linear"],
)
def test_none_refuses_a_unit_too_small_for_its_own_model(lot, final, n_rows, needed):
    """pooling="none" fits each unit alone: a unit with fewer rows than its model needs is a
    ValueError naming it, and a fitted model stays as it was; "partial" borrows from the
    lot and takes the unit."""
    estimator = make_compensation_pipeline(final)
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(estimator, pooling="none").fit(X, y)
    state, expected = _fitted_state(model), model.predict(X)
    small = X.copy()
    small.loc[small.index[-n_rows:], "unit"] = 9
    message = rf"unit 9 \(column 'unit' of X\) has {n_rows} rows?; .*{needed}"
    with pytest.raises(ValueError, match=message):
        model.fit(small, y)
    _assert_unchanged(model, state, X, expected)
    partial = UnitwiseRegressor(_linear(), pooling="partial").fit(small, y)
    assert partial.shrinkage_[9] in partial.shrinkage_grid_  # the lot's shrunk weights


def test_a_unit_too_small_for_its_own_model_keeps_the_shrunk_weights(lot):
    """With "partial", a unit of several runs that the far-unit rule would give its own
    model, but whose rows cannot determine it (two runs of three rows, nine weights), keeps
    the lot's shrunk weights instead of an underdetermined fit."""
    X, y = lot.data, lot.target.to_numpy().copy()
    runs = lot.frame["run"].to_numpy()
    small = np.zeros(len(X), dtype=bool)
    for run in np.unique(runs[_unit_rows(lot, 0)])[:2]:
        small[np.flatnonzero(runs == run)[:3]] = True
    keep = small | ~_unit_rows(lot, 0)
    X, y = X[keep], y[keep]
    y[X["unit"].to_numpy() == 0] += 1.0  # a bias of 1 deg/h: far from the lot
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    strength = shrinkage.pick_strength(-model.shrinkage_evidence_[0], model.shrinkage_grid_)
    assert 6 * strength <= OWN_MODEL_SPREAD**-2  # the rule would keep its own model
    assert model.shrinkage_[0] == strength
    assert model.n_folds_[0] == 2


def test_unit_ids_of_mixed_types_are_a_type_error_naming_the_column(lot):
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    state, expected = _fitted_state(model), model.predict(X)
    mixed = X.astype({"unit": object})
    mixed.loc[mixed.index[-1], "unit"] = "0"  # a string "0" among the integers 0 to 3
    message = (
        r"unit column 'unit' of X mixes unit ids of different types: numbers \(e\.g\. 0\) "
        r"and strings \(e\.g\. '0'\)\. Expected unit ids of one kind"
    )
    with pytest.raises(TypeError, match=message):
        model.fit(mixed, y)
    _assert_unchanged(model, state, X, expected)
    with pytest.raises(TypeError, match=message):
        model.predict(mixed)
    # the run column that "partial" reads, likewise
    runs = X.astype({"run": object})
    runs.loc[runs.index[-1], "run"] = "11"
    with pytest.raises(TypeError, match=r"run column 'run' of X mixes run ids"):
        model.fit(runs, y)
    _assert_unchanged(model, state, X, expected)
    # ids of one kind are fine: all strings
    on_strings = UnitwiseRegressor(_linear(), pooling="none").fit(X.astype({"unit": str}), y)
    assert on_strings.units_.tolist() == ["0", "1", "2", "3"]


def test_clone_and_params():
    model = UnitwiseRegressor(_linear(), unit="gyro", pooling="none", run=None)
    copy = clone(model)
    assert copy.get_params()["unit"] == "gyro"
    assert copy.pooling == "none"
    assert copy.run is None


# -- numerics ---------------------------------------------------------------------------------


def test_solve_shrunk_limits_and_monotone_distance():
    rng = np.random.default_rng(1)
    Phi = np.column_stack([rng.normal(size=(50, 3)), np.ones(50)])
    Y = Phi @ rng.normal(size=(4, 1)) + rng.normal(0, 0.1, (50, 1))
    prior = rng.normal(size=(4, 1))
    scale = shrinkage.design_scale(Phi)
    W = shrinkage.solve_shrunk(Phi, Y, prior, scale, shrinkage.SHRINKAGE_GRID)
    own = np.linalg.lstsq(Phi, Y, rcond=None)[0]
    np.testing.assert_allclose(W[0], own, rtol=1e-6)
    np.testing.assert_array_equal(W[-1], prior)
    distance = np.abs((W - prior)[:, :, 0] * scale).sum(axis=1)
    assert np.all(np.diff(distance) <= 1e-12)


def test_fold_prior_is_the_prior_when_nothing_is_held_out():
    rng = np.random.default_rng(2)
    Phi = np.column_stack([rng.normal(size=(30, 2)), np.ones(30)])
    Y = rng.normal(size=(30, 1))
    prior = rng.normal(size=(3, 1))
    scale = shrinkage.design_scale(Phi)
    statistics = shrinkage.lot_statistics(Phi, Y, prior)
    np.testing.assert_allclose(
        shrinkage.fold_prior(prior, scale, statistics, Phi[:0], Y[:0]), prior, atol=1e-12
    )
    # holding rows out moves the prior towards the least-squares fit of the other rows
    moved = shrinkage.fold_prior(prior, scale, statistics, Phi[:10], Y[:10])
    rest = np.linalg.lstsq(Phi[10:], Y[10:], rcond=None)[0]
    full = np.linalg.lstsq(Phi, Y, rcond=None)[0]
    np.testing.assert_allclose(moved - prior, rest - full, atol=1e-3)


def test_cv_folds_cover_every_row_once():
    for runs in (np.repeat([4, 7, 9], [3, 5, 2]), np.zeros(13, dtype=int)):
        folds = shrinkage.cv_folds(runs)
        np.testing.assert_array_equal(np.sum(folds, axis=0), np.ones(runs.size))


@pytest.mark.parametrize("suffix", [".joblib", ".skops"])
def test_save_and_load_give_the_same_predictions(lot, tmp_path, suffix):
    from sklearn_ifog import load_model, save_model

    model = UnitwiseRegressor(_rbf(), pooling="partial").fit(lot.data, lot.target)
    path = tmp_path / f"lot{suffix}"
    save_model(model, path)
    loaded = load_model(path)
    np.testing.assert_array_equal(loaded.predict(lot.data), model.predict(lot.data))
    assert loaded.shrinkage_ == model.shrinkage_


def test_compare_regressors_by_unit_scores_each_unit(lot):
    from sklearn_ifog.comparison import compare_regressors
    from sklearn_ifog.model_selection import LeaveOneRunOut

    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling="none")
    summary, folds = compare_regressors(
        X,
        y,
        regressors={"none": model},
        cv=LeaveOneRunOut(within_unit=True),
        by="unit",
        return_folds=True,
    )
    assert summary.index.names == ["model", "unit"]
    assert summary.loc[("none", 2), "n_folds"] == 3
    # unit 2's mean over its folds, computed by hand
    errors = []
    for run in lot.frame.loc[lot.frame.unit == 2, "run"].unique():
        test = (lot.frame.run == run).to_numpy()
        fitted = clone(model).fit(X[~test], y[~test])
        errors.append(np.mean((y[test] - fitted.predict(X[test])) ** 2))
    np.testing.assert_allclose(summary.loc[("none", 2), "msd_after"], np.mean(errors))
    assert set(folds["group"]) == {0, 1, 2, 3}


def test_a_refit_with_another_pooling_leaves_no_partial_attribute(lot):
    """After set_params(pooling=...) and a refit, nothing of the earlier partial fit stays."""
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(lot.data, lot.target)
    assert set(model.shrinkage_evidence_) == {0, 1, 2, 3}
    for pooling in ("none", "full"):
        model.set_params(pooling=pooling).fit(lot.data, lot.target)
        for name in (
            "shrinkage_",
            "shrinkage_evidence_",
            "shrinkage_scores_",
            "own_scores_",
            "shrinkage_grid_",
            "n_folds_",
        ):
            assert getattr(model, name) is None, name


@pytest.mark.parametrize("pooling", ["none", "full"])
def test_unit_models_is_the_split_predict_makes(lot, pooling):
    X, y = lot.data, lot.target.to_numpy()
    model = UnitwiseRegressor(_linear(), pooling=pooling).fit(X, y)
    # unit 3's rows before unit 1's: parts come in sorted units, rows keep their positions
    rows = np.concatenate([np.flatnonzero(_unit_rows(lot, unit)) for unit in (3, 1)])
    parts = model.unit_models(X.iloc[rows])
    # "full": the lot's model once, with every row; "none": each unit's own, units sorted.
    expected = (
        [model.lot_estimator_] if pooling == "full" else [model.estimators_[u] for u in (1, 3)]
    )
    assert [part[0] for part in parts] == expected
    covered = np.sort(np.concatenate([index for _, _, index in parts]))
    np.testing.assert_array_equal(covered, np.arange(rows.size))
    prediction = np.empty(rows.size)
    for unit_model, X_part, index in parts:
        assert "unit" not in X_part.columns
        prediction[index] = unit_model.predict(X_part)
    np.testing.assert_array_equal(prediction, model.predict(X.iloc[rows]))
    with pytest.raises(ValueError, match=r"unit 42 .*not seen in fit"):
        model.unit_models(X.assign(unit=42))
