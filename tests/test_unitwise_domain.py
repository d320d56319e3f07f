"""UnitwiseRegressor and the calibration domain: one domain per unit, one warning per call."""

import copy
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import RBFNetRegressor, UnitwiseRegressor, make_compensation_pipeline
from sklearn_ifog._pooling import layer_inputs
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.unitwise import POOLING

# The attributes that make up a fitted CalibrationDomain's box and ranges.
DOMAIN_ARRAYS = (
    "center_",
    "scale_",
    "components_",
    "axis_scale_",
    "lower_",
    "upper_",
    "data_min_",
    "data_max_",
)


def _unit(unit, temperature_range, seed, n_runs=1):
    """One simulated gyro, its run ids offset so that no two units share one."""
    bunch = make_thermal_campaign(
        n_units=1,
        n_runs=n_runs,
        azimuths=[0.0],
        sampling_period=300.0,
        temperature_range=temperature_range,
        physics="lumped",
        random_state=seed,
    )
    X = bunch.data.assign(unit=unit, run=bunch.data["run"] + 100 * unit)
    return X, bunch.target.to_numpy()


@pytest.fixture(scope="module")
def two_ranges():
    """Unit 0 calibrated warm (10 to 40 degC), unit 1 cold (-10 to 20 degC); one run each."""
    X_warm, y_warm = _unit(0, (10.0, 40.0), seed=0)
    X_cold, y_cold = _unit(1, (-10.0, 20.0), seed=1)
    return pd.concat([X_warm, X_cold], ignore_index=True), np.concatenate([y_warm, y_cold])


def _linear():
    return make_compensation_pipeline(LinearRegression())


def _swapped(X):
    """Every row given to the other unit (run ids kept apart from the originals)."""
    return X.assign(unit=1 - X["unit"], run=X["run"] + 1000)


def _rows_of(X, unit):
    rows = (X["unit"] == unit).to_numpy()
    return rows, X[rows].drop(columns="unit")


def _outside_warnings(caught):
    return [w for w in caught if issubclass(w.category, OutsideCalibrationWarning)]


def test_each_unit_is_calibrated_where_its_own_rows_are(two_ranges):
    X, y = two_ranges
    model = UnitwiseRegressor(_linear(), pooling="none").fit(X, y)
    temperature = X["temperature"].to_numpy()
    for unit in (0, 1):
        rows, _ = _rows_of(X, unit)
        domain = model.estimators_[unit].domain_
        column = domain.temperature_columns_[0]
        assert domain.data_min_[column] == temperature[rows].min()
        assert domain.data_max_[column] == temperature[rows].max()
    # every unit's calibration is inside its own domain ...
    assert not model.outside_calibration(X).any()
    # ... and a row of one unit beyond the other's calibrated temperatures is outside the
    # other's domain
    flags = model.outside_calibration(_swapped(X))
    for unit in (0, 1):
        rows, _ = _rows_of(X, unit)
        other = ~rows
        beyond = rows & (
            (temperature < temperature[other].min()) | (temperature > temperature[other].max())
        )
        assert beyond.sum() >= 5
        assert flags[beyond].all()


def test_full_pooling_shares_the_lots_domain(two_ranges):
    X, y = two_ranges
    model = UnitwiseRegressor(_linear(), pooling="full").fit(X, y)
    lot = model.lot_estimator_.domain_
    column = lot.temperature_columns_[0]
    assert lot.data_min_[column] == X["temperature"].min()
    assert lot.data_max_[column] == X["temperature"].max()
    assert all(model.estimators_[unit].domain_ is lot for unit in (0, 1))
    # each unit's rows given to the other unit: still inside the lot's calibration
    assert not model.outside_calibration(_swapped(X)).any()


def test_partial_pooling_keeps_the_lots_domain_and_fallback(two_ranges, monkeypatch):
    """A partially pooled unit is a copy of the lot model with new output weights: it pools
    the lot's calibration, so it keeps the lot's domain and fallback (a unit's own domain
    would send most of its rows to a one-run fallback)."""
    X, y = two_ranges
    # the far-unit rule off: it gives at least one of these unlike units its own model
    monkeypatch.setattr("sklearn_ifog.unitwise.OWN_MODEL_SPREAD", np.inf)
    partial = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    lot = partial.lot_estimator_
    for unit in (0, 1):
        assert partial.shrinkage_[unit] is not None  # the shrunk layer, not the own model
        shrunk = partial.estimators_[unit]
        assert shrunk.steps[-1][1] is not lot.steps[-1][1]
        for name in DOMAIN_ARRAYS:
            np.testing.assert_array_equal(
                getattr(shrunk.domain_, name), getattr(lot.domain_, name), err_msg=name
            )
        np.testing.assert_array_equal(shrunk.fallback_.intercept, lot.fallback_.intercept)
        np.testing.assert_array_equal(shrunk.fallback_.slope, lot.fallback_.slope)
    column = lot.domain_.temperature_columns_[0]
    assert (lot.domain_.data_min_[column], lot.domain_.data_max_[column]) == (
        X["temperature"].min(),
        X["temperature"].max(),
    )
    # each unit's rows given to the other unit: inside the lot's calibration
    assert not partial.outside_calibration(_swapped(X)).any()


def test_partial_reads_the_scaled_features_through_the_slice(two_ranges):
    """The output-layer design reads the lot model through ``model[:-1]``: a plain Pipeline
    of the feature step and the scaler, giving exactly what the regressor sees."""
    X, y = two_ranges
    model = UnitwiseRegressor(_linear(), pooling="partial").fit(X, y)
    lot = model.lot_estimator_
    X_inner = X.drop(columns="unit")
    assert type(lot[:-1]) is Pipeline
    expected = lot.named_steps["scale"].transform(lot.named_steps["features"].transform(X_inner))
    np.testing.assert_array_equal(layer_inputs(lot, X_inner), expected)


@pytest.mark.parametrize("pooling", POOLING)
def test_distance_and_flags_are_each_unit_models_own_in_input_order(two_ranges, pooling):
    X, y = two_ranges
    model = UnitwiseRegressor(_linear(), pooling=pooling).fit(X, y)
    # the swapped rows first, then the originals; every run's rows contiguous and in order
    probe = pd.concat([_swapped(X), X], ignore_index=True)
    distance = model.calibration_distance(probe)
    flags = model.outside_calibration(probe)
    assert distance.shape == flags.shape == (probe.shape[0],)
    assert flags.dtype == bool
    for unit in (0, 1):
        rows, part = _rows_of(probe, unit)
        unit_model = model.estimators_[unit]
        # "full" measures all rows in one call: products over another number of rows may
        # round differently in the last bit (1e-15 seen on a calibration row at the edge)
        np.testing.assert_allclose(
            distance[rows], unit_model.calibration_distance(part), rtol=1e-12, atol=1e-12
        )
        np.testing.assert_array_equal(flags[rows], unit_model.outside_calibration(part))
    if pooling == "none":
        assert flags[: X.shape[0]].any()
    assert not flags[X.shape[0] :].any()


def test_predict_follows_each_units_policy(two_ranges):
    X, y = two_ranges
    model = UnitwiseRegressor(_linear(), pooling="none").fit(X, y)
    probe = _swapped(X)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        prediction = model.predict(probe)
        for unit in (0, 1):
            rows, part = _rows_of(probe, unit)
            unit_model = model.estimators_[unit]
            np.testing.assert_array_equal(prediction[rows], unit_model.predict(part))
            # the same model without its policy differs exactly where the fallback has a
            # share of the prediction (farther than the margin), and nowhere else
            raw = copy.deepcopy(unit_model).set_params(uncalibrated="none").predict(part)
            blended = unit_model.calibration_distance(part) > unit_model.domain_.margin
            assert blended.sum() >= 5
            assert np.all(prediction[rows][blended] != raw[blended])
            np.testing.assert_array_equal(prediction[rows][~blended], raw[~blended])


@pytest.mark.parametrize("pooling", POOLING)
def test_one_warning_per_predict_call_names_the_units_outside(two_ranges, pooling):
    X, y = two_ranges
    model = UnitwiseRegressor(_linear(), pooling=pooling).fit(X, y)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.predict(X)
    assert _outside_warnings(caught) == []
    # unit 0's rows 40 degC colder (outside every domain), unit 1's as calibrated
    colder = X["temperature"] - 40.0 * (X["unit"] == 0)
    probe = X.assign(temperature=colder)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.predict(probe)
    (warning,) = _outside_warnings(caught)
    message = str(warning.message)
    flags = model.outside_calibration(probe)
    rows, _ = _rows_of(probe, 0)
    assert flags[rows].all()
    assert not flags[~rows].any()
    assert f"unit 0: {rows.sum()} of {rows.sum()} rows, 100.0%" in message
    assert "unit 1" not in message
    worst = model.calibration_distance(probe)[flags].max()
    assert f"largest distance {worst:.3g} decorrelated standard deviations (unit 0)" in message


def test_policy_leaves_the_partial_pooling_choice_unchanged():
    """The own model's held-out scores are those of its fit (uncalibrated="none" in the folds),
    so the choice is the same whatever the policy, and fit itself does not warn."""
    lot = make_thermal_campaign(
        n_units=3,
        n_runs=2,
        azimuths=[0.0],
        sampling_period=300.0,
        lot_spread=0.15,
        physics="lumped",
        random_state=3,
    )
    X, y = lot.data, lot.target.to_numpy()
    fits = {}
    for policy in ("blend", "none"):
        regressor = RBFNetRegressor(refine=None, tail="linear", max_samples=300, random_state=0)
        estimator = make_compensation_pipeline(regressor, uncalibrated=policy)
        with warnings.catch_warnings():
            warnings.simplefilter("error", OutsideCalibrationWarning)
            fits[policy] = UnitwiseRegressor(estimator, pooling="partial").fit(X, y)
    blend, raw = fits["blend"], fits["none"]
    assert all(np.isfinite(score) for score in blend.own_scores_.values())
    assert blend.own_scores_ == raw.own_scores_
    assert blend.shrinkage_ == raw.shrinkage_


def test_a_unit_without_a_domain_is_named_without_pooling(two_ranges):
    X, y = two_ranges
    rows, _ = _rows_of(X, 0)
    soak = X[rows].assign(unit=2, run=X["run"][rows] + 200, temperature=25.0)
    X_soak = pd.concat([X, soak], ignore_index=True)
    y_soak = np.concatenate([y, y[rows]])
    with pytest.raises(ValueError, match=r"unit 2.*constant"):
        UnitwiseRegressor(_linear(), pooling="none").fit(X_soak, y_soak)


def test_a_model_without_a_domain_has_no_domain_methods(two_ranges):
    X, y = two_ranges
    plain = make_pipeline(StandardScaler(), LinearRegression())
    model = UnitwiseRegressor(plain, pooling="none").fit(X[["unit", "temperature"]], y)
    assert not hasattr(model, "calibration_distance")
    assert not hasattr(model, "outside_calibration")
    assert model.predict(X[["unit", "temperature"]]).shape == y.shape
