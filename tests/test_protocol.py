"""The calibration protocol of the three estimators (issue 43, point 5).

``outside_calibration``, ``calibration_distance``, ``fallback_share``, ``fallback_predict``
and ``calibrated_parts``: CompensationPipeline answers for itself, UnitwiseRegressor by the
model of each row's unit, ConformalRegressor by its model fitted on every row. The report,
the conformal band, streaming and the exports ask these rather than the model's class
(``tests/test_layout.py`` checks that they no longer branch on it).
"""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression

from sklearn_ifog import (
    ConformalRegressor,
    OutsideCalibrationWarning,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.policy import fallback_weight
from sklearn_ifog.report import calibration_status


def _unit(unit, temperature_range, seed):
    bunch = make_thermal_campaign(
        n_units=1,
        n_runs=2,
        azimuths=[0.0],
        sampling_period=300.0,
        temperature_range=temperature_range,
        random_state=seed,
    )
    X = bunch.data.assign(unit=unit, run=bunch.data["run"] + 100 * unit)
    return X, bunch.target.to_numpy()


@pytest.fixture(scope="module")
def lot():
    """Unit 0 calibrated warm, unit 1 cold; rows of both, some beyond each one's range."""
    X0, y0 = _unit(0, (10.0, 40.0), seed=0)
    X1, y1 = _unit(1, (-10.0, 20.0), seed=1)
    X, y = pd.concat([X0, X1], ignore_index=True), np.concatenate([y0, y1])
    new = X.assign(temperature=X["temperature"] - 12.0, run=X["run"] + 1000)
    return X, y, new


def _quiet(function, *args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        return function(*args)


def test_the_pipeline_answers_for_itself(lot):
    X, y, new = lot
    X, new = X.drop(columns="unit"), new.drop(columns="unit")
    model = make_compensation_pipeline(LinearRegression()).fit(X, y)
    distance = model.calibration_distance(new)
    outside = model.outside_calibration(new)
    share = model.fallback_share(new)
    np.testing.assert_array_equal(share, fallback_weight(distance, model.domain_.threshold_))
    assert np.all(share[~outside] == 0.0)
    assert share.max() == 1.0
    assert np.any((share > 0.0) & (share < 1.0))
    features = np.asarray(model.steps[0][1].transform(new), dtype=float)
    np.testing.assert_array_equal(
        model.fallback_predict(new), model.fallback_.predict(features)[:, 0]
    )
    # The blend is (1 - share) * model + share * fallback, as predict computes it.
    free = _quiet(model.set_params(uncalibrated="none").predict, new)
    blended = _quiet(model.set_params(uncalibrated="blend").predict, new)
    np.testing.assert_allclose(
        blended, (1 - share) * free + share * model.fallback_predict(new), rtol=1e-12
    )
    [(part, X_part, rows)] = model.calibrated_parts(new)
    assert part is model
    assert X_part is new
    np.testing.assert_array_equal(rows, np.arange(len(new)))


@pytest.mark.parametrize("policy", ["clip", "none"])
def test_a_policy_without_a_fallback_offers_no_share(policy):
    model = make_compensation_pipeline(LinearRegression(), uncalibrated=policy)
    assert not hasattr(model, "fallback_share")
    assert not hasattr(UnitwiseRegressor(model), "fallback_share")
    assert not hasattr(ConformalRegressor(model), "fallback_share")
    model.set_params(uncalibrated="blend")
    assert hasattr(model, "fallback_share")
    # A bad name is said by fit and predict; asking for the method only answers no.
    assert not hasattr(model.set_params(uncalibrated="blend "), "fallback_share")
    assert not hasattr(model.set_params(uncalibrated=["blend"]), "fallback_share")


@pytest.mark.parametrize("pooling", ["none", "full"])
def test_unitwise_answers_by_the_model_of_each_rows_unit(lot, pooling):
    X, y, new = lot
    model = UnitwiseRegressor(make_compensation_pipeline(LinearRegression()), pooling=pooling)
    model.fit(X, y)
    parts = model.calibrated_parts(new)
    covered = np.sort(np.concatenate([rows for _, _, rows in parts]))
    np.testing.assert_array_equal(covered, np.arange(len(new)))  # each row once
    share, distance = model.fallback_share(new), model.calibration_distance(new)
    outside = model.outside_calibration(new)
    for pipeline, X_part, rows in parts:
        assert "unit" not in X_part.columns
        np.testing.assert_array_equal(share[rows], pipeline.fallback_share(X_part))
        np.testing.assert_array_equal(distance[rows], pipeline.calibration_distance(X_part))
        np.testing.assert_array_equal(outside[rows], pipeline.outside_calibration(X_part))
    assert len(parts) == (2 if pooling == "none" else 1)
    assert 0.0 < share.mean() < 1.0


def test_conformal_answers_by_its_model_fitted_on_every_row(lot):
    X, y, new = lot
    X, new = X.drop(columns="unit"), new.drop(columns="unit")
    model = ConformalRegressor(make_compensation_pipeline(LinearRegression()), coverage=0.9)
    _quiet(model.fit, X, y, X["run"])
    full = model.estimator_
    for name in ("outside_calibration", "calibration_distance", "fallback_share"):
        np.testing.assert_array_equal(getattr(model, name)(new), getattr(full, name)(new))
    [(part, _, _)] = model.calibrated_parts(new)
    assert part is full
    # The report reads the same rows through the protocol.
    status = calibration_status(model, new)
    np.testing.assert_array_equal(status.outside, full.outside_calibration(new))
    assert model.fallback_quantile_ is not None  # its band knows the fallback


def test_a_model_without_the_protocol_has_no_status(lot):
    X, y, new = lot
    plain = LinearRegression().fit(X[["temperature"]], y)
    assert calibration_status(plain, new[["temperature"]]) is None
    unfitted = make_compensation_pipeline(LinearRegression())
    assert calibration_status(unfitted, new) is None


@pytest.mark.parametrize("policy", ["blend", "clip", "none"])
@pytest.mark.parametrize("regressor", ["linear", "rbf"])
def test_adjusted_rows_are_the_rows_the_policy_changed(lot, policy, regressor):
    """The report's ``adjusted``, asked of the policy object, is what predicting again with
    ``uncalibrated="none"`` finds (the report did that before issue 43), but for round-off:
    colder, warmer, faster and slower rows than the calibration, and rows inside."""
    from sklearn_ifog import RBFNetRegressor

    X, y, new = lot
    X = X[X["unit"] == 0].drop(columns="unit")  # calibrated 10 to 40 degC, heating
    y = y[: len(X)]
    final = LinearRegression() if regressor == "linear" else RBFNetRegressor(random_state=0)
    model = make_compensation_pipeline(final, uncalibrated=policy).fit(X, y)
    warmer = X.assign(temperature=X["temperature"] + 8.0, run=X["run"] + 2000)
    colder = new[new["unit"] == 0].drop(columns="unit")
    faster = X.assign(time=X["time"] / 3.0, run=X["run"] + 3000)
    slower = X.assign(time=X["time"] * 3.0, run=X["run"] + 4000)
    rows = pd.concat([X, warmer, colder, faster, slower], ignore_index=True)
    with_policy = _quiet(model.predict, rows)
    free = _quiet(model.set_params(uncalibrated="none").predict, rows)
    model.set_params(uncalibrated=policy)
    status = calibration_status(model, rows)
    changed = with_policy != free
    assert not (status.adjusted & ~changed).any()  # never a row whose prediction stayed
    # "clip" evaluates every outside row again; one its projection left where it was can
    # differ by the round-off of another batch: not a change, and not flagged as one.
    noise = changed & ~status.adjusted
    np.testing.assert_array_less(np.abs(with_policy - free)[noise], 1e-15)
    if policy != "clip":
        assert not noise.any()
    if policy != "none":
        assert status.adjusted.sum() > 100
    assert not status.adjusted[: len(X)].any()  # the calibration itself is inside
