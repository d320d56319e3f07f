"""The scale factor (issue 44, point 2): ``CompensationPipeline(input_rate=...)``.

The rows are a static thermal campaign put on a rate table: every few samples the input
rate steps through 0, ±1, ±10, ±100 and ±300 deg/s, and the output gains ``Ω s(T)`` with a
known scale-factor error ``s`` (a few ppm/degC), so the truth of both parts is known.
"""

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import clone
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.neural_network import MLPRegressor

from sklearn_ifog import (
    ConformalRegressor,
    RBFNetRegressor,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog import scale_factor as sf
from sklearn_ifog.compensation import compensate
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.persistence import load_model, save_model

RATES = np.array([0, 1, -1, 10, -10, 100, -100, 300, -300]) * 3600.0


def _rate_table(seed, *, asymmetry=0.0, n_runs=4, hold=2):
    """X (with ``reference``, deg/h), y, the true ``s`` and the true noise-free bias."""
    frame = make_thermal_campaign(
        n_units=1,
        n_runs=n_runs,
        azimuths=[0.0],
        profile="cycle",
        sampling_period=60.0,
        temperature_range=(-40.0, 70.0),
        random_state=seed,
    ).frame
    rng = np.random.default_rng(seed)
    order = np.concatenate([rng.permutation(RATES.size) for _ in range(len(frame) // 9 + 1)])
    omega = RATES[order[np.arange(len(frame)) // hold % order.size]]
    temperature = frame["temperature"].to_numpy()
    true_s = 1e-6 * (4.0 * (temperature - 15.0) + 0.02 * (temperature - 15.0) ** 2)
    y = (frame["rate"] - frame["reference"]).to_numpy() + omega * true_s
    y = y + asymmetry * np.abs(omega)
    X = frame[["unit", "run", "time", "temperature"]].assign(reference=omega)
    return X, y, true_s, frame["drift"].to_numpy()


@pytest.fixture(scope="module")
def table():
    return _rate_table(1)


def _split(X, y):
    runs = X["run"].to_numpy()
    train = runs != runs.max()
    return train, ~train


@pytest.mark.filterwarnings("ignore::sklearn_ifog.domain.OutsideCalibrationWarning")
@pytest.mark.parametrize(
    ("regressor", "ppm"), [(LinearRegression(), 0.05), (RBFNetRegressor(random_state=0), 0.5)]
)
def test_the_scale_factor_and_the_input_rate_are_recovered(table, regressor, ppm):
    X, y, true_s, _ = table
    train, test = _split(X, y)
    model = make_compensation_pipeline(regressor, input_rate="reference").fit(X[train], y[train])
    pair = model._policed(X[test])
    assert pair.shape == (test.sum(), 2)
    # The scale factor, held out: within `ppm` of the truth that spans hundreds of ppm.
    assert np.ptp(true_s) * 1e6 > 300
    assert np.sqrt(np.mean((pair[:, 1] - true_s[test]) ** 2)) * 1e6 < ppm
    # The drift at the input rate is b + Ω s, and the input rate comes back from the output.
    omega = X["reference"].to_numpy()[test]
    np.testing.assert_allclose(
        model.predict(X[test]),
        pair[:, 0] + omega * pair[:, 1] + model.asymmetry_ * np.abs(omega),
        rtol=1e-12,
    )
    assert abs(model.asymmetry_) < 0.05e-6  # none was simulated
    output = omega + y[test]
    estimate = model.compensate(X[test].drop(columns="reference"), output)
    raw_error = np.sqrt(np.mean((output - omega) ** 2))
    error = np.sqrt(np.mean((estimate - omega) ** 2))
    assert error < 0.01 * raw_error
    assert error < 3 * np.std(y[test] - model.predict(X[test])) + 1e-12


def test_compensate_inverts_predict(table):
    """rate = Ω + b + Ω s gives back Ω exactly: (rate - b) / (1 + s) = Ω."""
    X, y, _, _ = table
    model = make_compensation_pipeline(LinearRegression(), input_rate="reference").fit(X, y)
    omega = X["reference"].to_numpy()
    rate = omega + model.predict(X)
    np.testing.assert_allclose(model.compensate(X, rate), omega, rtol=1e-12, atol=1e-8)
    # compensation.compensate gives the same input rate (a Series on the index).
    series = compensate(model, X, pd.Series(rate, index=X.index))
    assert series.name == "rate_compensated"
    np.testing.assert_allclose(series.to_numpy(), omega, rtol=1e-12, atol=1e-8)


@settings(max_examples=25, deadline=None)
@given(
    bias=st.floats(-50.0, 50.0),
    ppm=st.floats(-2000.0, 2000.0),
    omega=st.floats(-1.1e6, 1.1e6),
)
def test_input_rate_estimate_inverts_drift_of(bias, ppm, omega):
    pair = np.array([[bias, ppm * 1e-6]])
    rate = omega + sf.drift_of(pair, np.array([omega]))
    np.testing.assert_allclose(sf.input_rate_estimate(pair, rate), [omega], rtol=1e-12, atol=1e-7)


def test_rows_without_the_column_in_every_layout(table):
    X, y, _, _ = table
    model = make_compensation_pipeline(LinearRegression(), input_rate="reference").fit(X, y)
    rate = X["reference"].to_numpy() + y
    expected = model.compensate(X, rate)
    np.testing.assert_array_equal(model.compensate(X.drop(columns="reference"), rate), expected)
    pl = pytest.importorskip("polars")
    polars_rows = pl.from_pandas(X.drop(columns="reference"))
    np.testing.assert_array_equal(model.compensate(polars_rows, rate), expected)
    # An array: the input rate is a column position.
    array_model = make_compensation_pipeline(
        LinearRegression(), temperature=3, time=2, run=1, input_rate=4
    ).fit(X.to_numpy(), y)
    np.testing.assert_allclose(
        array_model.compensate(X.to_numpy()[:, :4], rate), expected, rtol=1e-10
    )


def test_the_calibration_is_never_flagged_and_faster_rates_are(table):
    X, y, _, _ = table
    model = make_compensation_pipeline(LinearRegression(), input_rate="reference").fit(X, y)
    assert model.input_rate_range_ == (RATES.min(), RATES.max())
    with warnings.catch_warnings():
        warnings.simplefilter("error", OutsideCalibrationWarning)
        model.predict(X)
        model.compensate(X, X["reference"].to_numpy() + y)
    assert not model.outside_calibration(X).any()
    faster = X.assign(reference=X["reference"] * 1.5)
    flags = model.outside_calibration(faster)
    np.testing.assert_array_equal(flags, np.abs(faster["reference"]) > 1.05 * RATES.max())
    with pytest.warns(OutsideCalibrationWarning, match="input rates beyond the calibrated"):
        model.predict(faster)
    with pytest.warns(OutsideCalibrationWarning, match="input rates beyond the calibrated"):
        model.compensate(X, faster["reference"].to_numpy())
    # Within the slack (5 % of the largest calibrated rate) nothing is flagged.
    assert not model.outside_calibration(X.assign(reference=X["reference"] * 1.04)).any()


def test_the_fallback_knows_the_scale_factor(table):
    X, y, true_s, _ = table
    model = make_compensation_pipeline(LinearRegression(), input_rate="reference").fit(X, y)
    thermal = model.named_steps["features"]
    pair = model.fallback_.predict(np.asarray(thermal.transform(X), dtype=float))
    assert pair.shape == (len(X), 2)
    omega = X["reference"].to_numpy()
    np.testing.assert_allclose(
        model.fallback_predict(X),
        pair[:, 0] + omega * pair[:, 1] + model.asymmetry_ * np.abs(omega),
        rtol=1e-12,
    )
    # Its scale factor follows the calibrated one (a line in T, or a constant: never zero).
    assert np.corrcoef(pair[:, 1], true_s)[0, 1] > 0.9
    # Far colder than calibrated, the blend hands [b, s] to the fallback: the scale factor
    # stays the fallback's, never the regressor's extrapolation.
    cold = X.assign(temperature=X["temperature"] - 200.0)
    with pytest.warns(OutsideCalibrationWarning):
        far = model._policed(cold)
    np.testing.assert_allclose(
        far, model.fallback_.predict(np.asarray(thermal.transform(cold), dtype=float))
    )


def test_the_bias_at_zero_input_is_not_pulled_by_a_rate_asymmetry():
    """An error even in the input rate (``a |Ω|``, which no b + Ω s holds) must not leak into
    the bias: a 20 ppm asymmetry at ±300 deg/s would move a bias fitted on every row by
    several deg/h. It is learnt (``asymmetry_``), and the bias at zero input stays as good
    as a bias-only model fitted on the zero-rate rows."""
    for seed in (2, 3, 4):
        X, y, _, _ = _rate_table(seed, asymmetry=20e-6)
        train, test = _split(X, y)
        model = make_compensation_pipeline(LinearRegression(), input_rate="reference")
        model.fit(X[train], y[train])
        zero = X["reference"].to_numpy() == 0
        bias_only = make_compensation_pipeline(LinearRegression())
        bias_only.fit(X[train & zero], y[train & zero])
        rows = test & zero
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OutsideCalibrationWarning)
            ours = np.sqrt(np.mean((y[rows] - model.predict(X[rows])) ** 2))
            theirs = np.sqrt(np.mean((y[rows] - bias_only.predict(X[rows])) ** 2))
        assert ours < 1.1 * theirs
        assert model.asymmetry_ * 1e6 == pytest.approx(20.0, abs=0.2)


def test_rate_noise_and_weights():
    noise = sf.RateNoise(sigma0=0.01, kappa=1e-6)
    weights = noise.weights(np.array([0.0, 1e4, 1e6]))
    assert weights.mean() == pytest.approx(1.0)
    expected = 1.0 / (0.01**2 + (1e-6 * np.array([0.0, 1e4, 1e6])) ** 2)
    np.testing.assert_allclose(weights, expected / expected.mean())


def test_grid_search_and_clone_keep_the_input_rate(table):
    X, y, _, _ = table
    model = make_compensation_pipeline(Ridge(), input_rate="reference")
    assert model.get_params()["input_rate"] == "reference"
    assert clone(model).input_rate == "reference"
    search = GridSearchCV(model, {"regressor__alpha": [1e-3, 1.0]}, cv=GroupKFold(2))
    search.fit(X, y, groups=X["run"])
    assert search.best_estimator_.input_rate == "reference"
    assert search.best_estimator_.predict(X).shape == (len(X),)


def test_a_lot_fits_a_scale_factor_per_unit(table):
    X, y, _, _ = table
    lot = pd.concat([X, X.assign(unit=1, run=X["run"] + 100)], ignore_index=True)
    target = np.concatenate([y, 1.001 * y])
    model = make_compensation_pipeline(LinearRegression(), input_rate="reference")
    fitted = UnitwiseRegressor(model, pooling="none").fit(lot, target)
    pairs = [est._policed(X.drop(columns="unit")) for est in fitted.estimators_.values()]
    # y' = 1.001 (b + Ω s): the second unit's scale factor is 1.001 s, fitted on its own.
    np.testing.assert_allclose(pairs[1], pairs[0] * 1.001, rtol=1e-6, atol=1e-12)
    with pytest.raises(ValueError, match=r"pooling='partial'.*input_rate='reference'"):
        UnitwiseRegressor(model, pooling="partial").fit(lot, target)


def test_bad_input_is_named(table):
    X, y, _, _ = table
    model = make_compensation_pipeline(LinearRegression(), input_rate="reference")
    with pytest.raises(ValueError, match=r"Column 'omega' \(input_rate\) not found"):
        clone(model).set_params(input_rate="omega").fit(X, y)
    with pytest.raises(TypeError, match="input_rate"):
        model.fit(X.assign(reference="fast"), y)
    with pytest.raises(ValueError, match="input_rate"):
        model.fit(X.assign(reference=np.where(X.index == 3, np.nan, X["reference"])), y)
    # rad/s where deg/h is expected: the output is 206,265 times the input, never guessed.
    radians = X.assign(reference=np.deg2rad(X["reference"] / 3600.0))
    with pytest.raises(ValueError, match=r"unit, deg/h.*rad/s"):
        model.fit(radians, radians["reference"] * (206264.8 - 1.0) + y)
    # deg/s likewise.
    degrees = X.assign(reference=X["reference"] / 3600.0)
    with pytest.raises(ValueError, match=r"not in|unit, deg/h"):
        model.fit(degrees, degrees["reference"] * 3599.0 + y)
    # A static campaign: the Earth rate alone does not show a scale factor.
    static = X.assign(reference=10.6)
    with pytest.raises(ValueError, match=r"not observable.*input_rate=None"):
        model.fit(static, y)
    with pytest.raises(TypeError, match=r"linear output layer.*MLPRegressor"):
        make_compensation_pipeline(MLPRegressor(), input_rate="reference").fit(X, y)
    with pytest.raises(ValueError, match="handover"):
        make_compensation_pipeline(LinearRegression(), input_rate="reference", handover=True).fit(
            X, y
        )
    with pytest.raises(ValueError, match=r"ConformalRegressor does not take.*input_rate"):
        ConformalRegressor(model).fit(X, y)
    with pytest.raises(ValueError, match="one drift target"):
        model.fit(X, np.column_stack([y, y]))
    fitted = clone(model).fit(X, y)
    with pytest.raises(ValueError, match=r"'reference' \(input_rate\) not found"):
        fitted.predict(X.drop(columns="reference"))
    with pytest.raises(ValueError, match="one finite gyro output per row"):
        fitted.compensate(X, y[:-1])


@pytest.mark.parametrize("fmt", ["joblib", "skops"])
def test_a_scale_factor_model_saves_and_loads(table, tmp_path, fmt):
    X, y, _, _ = table
    model = make_compensation_pipeline(RBFNetRegressor(random_state=0), input_rate="reference")
    model.fit(X, y)
    path = tmp_path / f"model.{fmt}"
    save_model(model, path)
    loaded = load_model(path)
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    assert loaded.rate_noise_ == model.rate_noise_
    assert loaded.asymmetry_ == model.asymmetry_
    rate = X["reference"].to_numpy() + y
    np.testing.assert_array_equal(loaded.compensate(X, rate), model.compensate(X, rate))


def test_without_input_rate_nothing_changes(table):
    X, y, _, _ = table
    plain = make_compensation_pipeline(RBFNetRegressor(random_state=0)).fit(X, y)
    explicit = make_compensation_pipeline(RBFNetRegressor(random_state=0), input_rate=None)
    np.testing.assert_array_equal(explicit.fit(X, y).predict(X), plain.predict(X))
    assert plain.input_rate_range_ is None
    assert plain.rate_noise_ is None
    rate = X["reference"].to_numpy() + y
    np.testing.assert_array_equal(plain.compensate(X, rate), rate - plain.predict(X))


def test_compensate_of_a_bias_only_model_of_several_outputs(table):
    X, y, _, _ = table
    Y = np.column_stack([y, -y])
    model = make_compensation_pipeline(LinearRegression()).fit(X, Y)
    rate = X[["reference"]].to_numpy() + Y
    np.testing.assert_array_equal(model.compensate(X, rate), rate - model.predict(X))
    with pytest.raises(ValueError, match="the model predicts"):
        model.compensate(X, rate[:, 0])
    scale = make_compensation_pipeline(LinearRegression(), input_rate="reference").fit(X, y)
    with pytest.raises(ValueError, match="1-D for a scale-factor model"):
        scale.compensate(X, rate)
