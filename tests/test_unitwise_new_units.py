"""A unit the lot was not fitted on: predicted by the lot's model, or added without a refit."""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression

from sklearn_ifog import RBFNetRegressor, UnitwiseRegressor, make_compensation_pipeline
from sklearn_ifog import _shrinkage as shrinkage
from sklearn_ifog._output_layer import layer_design, layer_weights
from sklearn_ifog._pooling import layer_inputs
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.unitwise import OWN_MODEL_SPREAD


@pytest.fixture(scope="module")
def lot():
    """Five similar units, three runs each, coarse sampling (fast)."""
    return make_thermal_campaign(
        n_units=5,
        n_runs=3,
        azimuths=[0.0],
        sampling_period=300.0,
        lot_spread=0.15,
        random_state=4,
    )


def _linear():
    return make_compensation_pipeline(LinearRegression())


def _rbf():
    return make_compensation_pipeline(
        RBFNetRegressor(refine=None, tail="linear", max_samples=400, random_state=0)
    )


def _split(lot, new_units=(4,), runs=None):
    """(X, y of the fitted units; X, y of the new units, only their first ``runs`` runs)."""
    X, y = lot.data, lot.target.to_numpy()
    new = X["unit"].isin(new_units).to_numpy()
    keep = new.copy()
    if runs is not None:
        first = {u: sorted(X.loc[X["unit"] == u, "run"].unique())[:runs] for u in new_units}
        keep = new & np.array(
            [run in first.get(unit, ()) for unit, run in zip(X["unit"], X["run"], strict=True)]
        )
    return X[~new], y[~new], X[keep], y[keep]


def _quiet(function, *args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return function(*args)


# -- handle_unknown ---------------------------------------------------------------------------


@pytest.mark.parametrize("pooling", ["partial", "full"])
def test_an_unknown_unit_is_predicted_by_the_lot_model(lot, pooling):
    X_fit, y_fit, X_new, _ = _split(lot)
    model = UnitwiseRegressor(_linear(), pooling=pooling, handle_unknown="lot")
    model.fit(X_fit, y_fit)
    expected = _quiet(model.lot_estimator_.predict, X_new.drop(columns="unit"))
    np.testing.assert_array_equal(_quiet(model.predict, X_new), expected)
    # rows of known and unknown units together: each by its own model (to the last bits, which
    # a matrix product of another number of rows may sum in another order)
    both = X_fit.iloc[:50]
    mixed = _quiet(model.predict, pd.concat([both, X_new.iloc[:30]]))
    np.testing.assert_allclose(mixed[:50], _quiet(model.predict, both), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(mixed[50:], expected[:30], rtol=1e-12, atol=1e-15)
    flags = model.outside_calibration(X_new)
    np.testing.assert_array_equal(
        flags, model.lot_estimator_.outside_calibration(X_new.drop(columns="unit"))
    )


def test_an_unknown_unit_is_an_error_naming_the_ways_out(lot):
    X_fit, y_fit, X_new, _ = _split(lot)
    model = UnitwiseRegressor(_linear()).fit(X_fit, y_fit)
    with pytest.raises(ValueError, match=r"unit 4 \(column 'unit' of X\).*add_units.*'lot'"):
        model.predict(X_new)


def test_handle_unknown_lot_needs_a_lot_model(lot):
    X_fit, y_fit, _, _ = _split(lot)
    model = UnitwiseRegressor(_linear(), pooling="none", handle_unknown="lot")
    with pytest.raises(ValueError, match=r"handle_unknown='lot'.*pooling='none'"):
        model.fit(X_fit, y_fit)


# -- add_units ------------------------------------------------------------------------------


def test_add_units_partial_shrinks_the_new_unit_towards_the_unrefitted_lot(lot):
    X_fit, y_fit, X_new, y_new = _split(lot)
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X_fit, y_fit)
    lot_model = model.lot_estimator_
    before = {unit: model.estimators_[unit] for unit in range(4)}
    assert model.add_units(X_new, y_new) is model
    assert model.lot_estimator_ is lot_model
    assert model.units_.tolist() == [0, 1, 2, 3, 4]
    assert all(model.estimators_[unit] is before[unit] for unit in range(4))
    # the new unit's weights: the ridge towards the lot's layer, strength by its evidence
    final = lot_model.steps[-1][1]
    inner = X_new.drop(columns="unit")
    Phi = layer_design(final, layer_inputs(lot_model, inner))
    prior = layer_weights(final)
    evidence = shrinkage.log_evidence(
        Phi, y_new[:, None], prior, model.shrinkage_scale_, model.shrinkage_grid_
    )
    np.testing.assert_allclose(model.shrinkage_evidence_[4], evidence)
    strength = shrinkage.pick_strength(-evidence, model.shrinkage_grid_)
    assert model.shrinkage_[4] == strength
    (weights,) = shrinkage.solve_shrunk(
        Phi, y_new[:, None], prior, model.shrinkage_scale_, [strength]
    )
    added = model.estimators_[4].steps[-1][1]
    np.testing.assert_allclose(np.r_[added.coef_, added.intercept_], weights[:, 0])
    assert model.n_folds_[4] == 3
    assert model.shrinkage_scores_[4].shape == model.shrinkage_grid_.shape


def test_a_single_run_new_unit_shares_the_lot_single_run_evidence(lot):
    """A lot calibrated on one run a unit: the new single-run unit's strength comes from its
    log-likelihood summed with the lot's single-run units' (theirs is not changed)."""
    X, y = lot.data, lot.target.to_numpy()
    first = X["run"].isin(X.groupby("unit")["run"].min()).to_numpy()
    new = (X["unit"] == 4).to_numpy()
    model = UnitwiseRegressor(_linear()).fit(X[first & ~new], y[first & ~new])
    strengths = dict(model.shrinkage_)
    model.add_units(X[first & new], y[first & new])
    total = sum(model.shrinkage_evidence_[unit] for unit in range(5))
    assert model.shrinkage_[4] == shrinkage.pick_strength(-total, model.shrinkage_grid_)
    assert {unit: model.shrinkage_[unit] for unit in range(4)} == strengths
    assert model.n_folds_[4] == 0


def test_add_units_none_and_full(lot):
    X_fit, y_fit, X_new, y_new = _split(lot)
    none = UnitwiseRegressor(_linear(), pooling="none").fit(X_fit, y_fit)
    none.add_units(X_new, y_new)
    alone = _linear().fit(X_new.drop(columns="unit"), y_new)
    np.testing.assert_allclose(none.estimators_[4].steps[-1][1].coef_, alone[-1].coef_)
    full = UnitwiseRegressor(_linear(), pooling="full").fit(X_fit, y_fit)
    full.add_units(X_new, y_new)
    assert full.estimators_[4] is full.lot_estimator_


def test_add_units_with_the_network_follows_the_lot_choice_of_own_models(lot):
    X_fit, y_fit, X_new, y_new = _split(lot)
    model = _quiet(UnitwiseRegressor(_rbf(), pooling="partial").fit, X_fit, y_fit)
    _quiet(model.add_units, X_new, y_new)
    lam = shrinkage.pick_strength(-model.shrinkage_evidence_[4], model.shrinkage_grid_)
    keeps_own = model.own_wins_ or X_new.shape[0] * lam <= OWN_MODEL_SPREAD**-2
    assert (model.shrinkage_[4] is None) == keeps_own
    final = model.estimators_[4].steps[-1][1]
    if keeps_own:
        alone = _quiet(_rbf().fit, X_new.drop(columns="unit"), y_new)
        np.testing.assert_array_equal(final.centers_, alone[-1].centers_)
    else:
        np.testing.assert_array_equal(final.centers_, model.lot_estimator_[-1].centers_)


def test_add_units_refuses_a_fitted_unit_and_leaves_the_model_as_it_was(lot):
    X_fit, y_fit, X_new, y_new = _split(lot)
    model = UnitwiseRegressor(_linear()).fit(X_fit, y_fit)
    units, shrink = model.units_.copy(), dict(model.shrinkage_)
    both = pd.concat([X_new, X_fit[X_fit["unit"] == 2]])
    y_both = np.r_[y_new, y_fit[(X_fit["unit"] == 2).to_numpy()]]
    with pytest.raises(ValueError, match=r"unit\(s\) \[2\] \(column 'unit' of X\).*already"):
        model.add_units(both, y_both)
    np.testing.assert_array_equal(model.units_, units)
    assert model.shrinkage_ == shrink
    assert 4 not in model.estimators_
    assert 4 not in model.shrinkage_evidence_
    with pytest.raises(TypeError, match="column 'unit'"):
        model.add_units(X_new.assign(unit="four"), y_new)
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        model.add_units(X_new, y_new[:-1])
    assert 4 not in model.estimators_


def test_add_units_before_fit_is_not_fitted(lot):
    from sklearn.exceptions import NotFittedError

    _, _, X_new, y_new = _split(lot)
    with pytest.raises(NotFittedError):
        UnitwiseRegressor(_linear()).add_units(X_new, y_new)


def test_a_lot_fitted_from_files_one_unit_in_memory_at_a_time(lot, tmp_path):
    """The recipe for a lot larger than memory: fit on the first unit's file, then add the
    others from their files one at a time; with pooling "none" this is the fit of the
    whole table, model for model."""
    frame = lot.data.assign(drift=lot.target.to_numpy())
    paths = []
    for unit, rows in frame.groupby("unit"):
        paths.append(tmp_path / f"unit_{unit}.csv")
        rows.to_csv(paths[-1], index=False)
    first = pd.read_csv(paths[0])
    model = UnitwiseRegressor(_linear(), pooling="none")
    model.fit(first.drop(columns="drift"), first["drift"])
    for path in paths[1:]:
        table = pd.read_csv(path)  # one unit's table in memory at a time
        model.add_units(table.drop(columns="drift"), table["drift"])
    whole = UnitwiseRegressor(_linear(), pooling="none").fit(lot.data, lot.target)
    assert model.units_.tolist() == whole.units_.tolist() == [0, 1, 2, 3, 4]
    np.testing.assert_allclose(
        _quiet(model.predict, lot.data), _quiet(whole.predict, lot.data), rtol=0, atol=1e-12
    )
