"""Tests of the thermal-test simulator, sklearn_ifog.datasets.make_thermal_campaign."""

import numpy as np
import pandas as pd
import pytest
from pandas.testing import assert_frame_equal

from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.datasets._simulator import (
    OUTPUT_ANGLE_QUANTUM,
    first_order_lag,
    shupe_coefficient,
    static_bias,
)

FRAME_COLUMNS = [
    "unit",
    "run",
    "azimuth",
    "time",
    "temperature",
    "rate",
    "reference",
    "drift",
    "chamber_temperature",
]
DATA_COLUMNS = ["unit", "run", "azimuth", "time", "temperature"]
SMALL = {"n_units": 2, "n_runs": 2, "azimuths": [0.0, 90.0]}


@pytest.fixture(scope="module")
def campaign():
    return make_thermal_campaign(**SMALL, profile="mix", random_state=7)


def test_same_seed_gives_identical_campaign_bit_for_bit(campaign):
    again = make_thermal_campaign(**SMALL, profile="mix", random_state=7)
    assert_frame_equal(campaign.frame, again.frame, check_exact=True)
    assert_frame_equal(campaign.components, again.components, check_exact=True)
    assert campaign.unit_params == again.unit_params


def test_different_seed_gives_different_campaign(campaign):
    other = make_thermal_campaign(**SMALL, profile="mix", random_state=8)
    assert other.unit_params[0]["k0"] != campaign.unit_params[0]["k0"]
    n = min(len(other.frame), len(campaign.frame))
    assert not np.array_equal(other.frame["rate"][:n], campaign.frame["rate"][:n])


def test_reference_is_the_earth_rate_formula_exactly():
    latitude, azimuths = 31.7, [0.0, 45.0, 90.0, 200.0]
    frame = make_thermal_campaign(
        n_units=1, n_runs=1, azimuths=azimuths, latitude=latitude, random_state=0
    ).frame
    expected = 15.041067 * np.cos(np.deg2rad(latitude)) * np.cos(np.deg2rad(frame["azimuth"]))
    np.testing.assert_array_equal(frame["reference"].to_numpy(), expected.to_numpy())
    assert set(frame["azimuth"]) == set(azimuths)


def test_columns_dtypes_and_target_follow_the_contract(campaign):
    frame = campaign.frame
    assert list(frame.columns) == FRAME_COLUMNS
    assert frame["unit"].dtype == np.int64
    assert frame["run"].dtype == np.int64
    for name in FRAME_COLUMNS[2:]:
        assert frame[name].dtype == np.float64, name
    assert campaign.feature_names == DATA_COLUMNS
    assert campaign.target_names == ["drift_measured"]
    assert_frame_equal(campaign.data, frame[DATA_COLUMNS], check_exact=True)
    assert campaign.target.name == "drift_measured"
    np.testing.assert_array_equal(campaign.target, frame["rate"] - frame["reference"])
    assert list(frame["unit"].unique()) == [0, 1]
    assert list(campaign.components.index) == list(frame.index)
    assert "Shupe" in campaign.DESCR


def test_runs_are_contiguous_unique_and_time_ordered(campaign):
    frame = campaign.frame
    run = frame["run"].to_numpy()
    # contiguous blocks, numbered 0, 1, 2, ... in order
    starts = np.flatnonzero(np.diff(run, prepend=-1) != 0)
    np.testing.assert_array_equal(run[starts], np.arange(len(starts)))
    assert len(starts) == 2 * 2 * 2
    for _, rows in frame.groupby("run"):
        assert rows["unit"].nunique() == 1
        assert rows["azimuth"].nunique() == 1
        time = rows["time"].to_numpy()
        assert time[0] == 0.0
        np.testing.assert_allclose(np.diff(time), 60.0)  # the default sampling period
    counts = frame.groupby(["unit", "azimuth"])["run"].nunique()
    assert (counts == 2).all()


def test_temperature_reading_has_a_resolution_of_0_01_degc(campaign):
    hundredths = campaign.frame["temperature"].to_numpy() * 100.0
    np.testing.assert_allclose(hundredths, np.round(hundredths), rtol=0, atol=1e-8)
    # the reading is the lagged outer layer plus the unit's offset, to within the lag error
    frame, outer = campaign.frame, campaign.components["coil_outer"]
    offsets = frame["unit"].map(lambda unit: campaign.unit_params[unit]["sensor_offset"])
    assert np.abs(frame["temperature"] - offsets - outer).max() < 2.0


def test_profiles_stay_in_range_and_runs_reach_different_temperatures(campaign):
    runs = campaign.run_params
    assert set(runs["profile"]) <= {"paper", "cycle", "staircase"}
    assert runs["min_setpoint"].min() >= -10.0
    assert runs["max_setpoint"].max() <= 40.0
    chamber = campaign.frame["chamber_temperature"]
    assert chamber.min() > -10.5
    assert chamber.max() < 40.5
    # held-out runs may go beyond the others: the levels differ from run to run
    assert runs["max_setpoint"].max() - runs["max_setpoint"].min() > 1.0
    assert runs["ramp_rate"].between(0.1, 2.0).all()
    assert runs["ramp_rate"].nunique() == len(runs)
    only_cycles = make_thermal_campaign(n_units=1, n_runs=3, profile=["cycle"], random_state=0)
    assert set(only_cycles.run_params["profile"]) == {"cycle"}


def test_paper_profile_soaks_low_ramps_up_and_soaks_high():
    runs = make_thermal_campaign(n_units=1, n_runs=4, azimuths=[0.0], random_state=3).run_params
    for _, run in runs.iterrows():
        times, levels = run["breakpoint_times"], run["breakpoint_temperatures"]
        assert levels.shape == (4,)
        assert levels[0] == levels[1] < levels[2] == levels[3]
        assert -10.0 <= levels[0] <= 10.0
        assert 25.0 <= levels[2] <= 40.0
        assert 45 * 60 <= times[1] <= 75 * 60  # first soak about 1 h
        assert 100 * 60 <= times[3] - times[2] <= 140 * 60  # last soak about 2 h
        ramp_minutes = (times[2] - times[1]) / 60.0
        np.testing.assert_allclose((levels[2] - levels[1]) / ramp_minutes, run["ramp_rate"])


def test_drift_follows_the_coil_temperature_rate(campaign):
    frame, components = campaign.frame, campaign.components
    for unit, params in enumerate(campaign.unit_params):
        shupe_rows, coil_rates, layer_rates = [], [], []
        for _, rows in frame[frame["unit"] == unit].groupby("run"):
            parts = components.loc[rows.index]
            time = rows["time"].to_numpy()
            coil = parts["coil_mean"].to_numpy()
            k = shupe_coefficient(coil, params["k0"], params["k1"])
            # the drift minus its static part, against rates differentiated numerically here
            shupe_rows.append(rows["drift"] - static_bias(coil, params["bias_coefficients"]))
            coil_rates.append(np.gradient(coil, time) * 60.0)
            layer_rates.append(
                k[:, None]
                * np.column_stack(
                    [
                        np.gradient(parts[name].to_numpy(), time) * 60.0
                        for name in ("coil_outer", "coil_inner")
                    ]
                )
            )
        shupe = np.concatenate(shupe_rows)
        assert np.corrcoef(shupe, np.concatenate(coil_rates))[0, 1] > 0.95
        weights, *_ = np.linalg.lstsq(np.vstack(layer_rates), shupe, rcond=None)
        gamma = params["gradient_weight"]
        np.testing.assert_allclose(weights, [0.5 + gamma, 0.5 - gamma], atol=0.01)


def test_drift_at_a_steady_ramp_is_k_of_t_times_the_ramp_rate():
    bunch = make_thermal_campaign(
        n_units=2,
        n_runs=1,
        azimuths=[0.0],
        profile="cycle",
        ramp_rate=0.1,
        noise=False,
        random_state=5,
    )
    frame = bunch.frame
    checked = 0
    for _, run in bunch.run_params.iterrows():
        params = bunch.unit_params[run["unit"]]
        rows = frame[frame["run"] == run["run"]]
        times, levels = run["breakpoint_times"], run["breakpoint_temperatures"]
        for start in np.flatnonzero(np.diff(levels) != 0):
            # last sample of the ramp: hours after its start, the lags have settled
            time = rows["time"].to_numpy()
            sample = np.flatnonzero(time <= times[start + 1])[-1]
            assert time[sample] - times[start] > 4 * 3600
            rate = np.sign(levels[start + 1] - levels[start]) * 0.1  # degC/min
            setpoint = np.interp(time[sample], times, levels)
            # steady state of the two lags in series: the coil mean trails the set-point by
            # (tau_outer + tau_inner / 2) times the ramp rate
            lag = (params["tau_outer"] + params["tau_inner"] / 2) / 60.0 * rate
            coil = setpoint - lag
            expected = shupe_coefficient(coil, params["k0"], params["k1"]) * rate
            expected += static_bias(coil, params["bias_coefficients"])
            np.testing.assert_allclose(rows["drift"].iloc[sample], expected, rtol=1e-4)
            checked += 1
    assert checked >= 4


def test_noise_components_add_up_and_have_the_stated_statistics():
    sampling_period = 10.0
    bunch = make_thermal_campaign(
        n_units=2, n_runs=3, azimuths=[0.0], sampling_period=sampling_period, random_state=11
    )
    frame, parts = bunch.frame, bunch.components
    noise = ["turn_on_bias", "bias_instability", "angle_random_walk", "quantisation"]
    np.testing.assert_allclose(
        bunch.target - frame["drift"], parts[noise].sum(axis=1), rtol=0, atol=1e-9
    )
    for unit, params in enumerate(bunch.unit_params):
        rows = (frame["unit"] == unit).to_numpy()
        white = parts.loc[rows, "angle_random_walk"].to_numpy()
        expected_std = params["angle_random_walk"] * 60.0 / np.sqrt(sampling_period)
        np.testing.assert_allclose(white.std(), expected_std, rtol=0.03)
        assert abs(np.corrcoef(white[1:], white[:-1])[0, 1]) < 0.03
        drift_noise = parts.loc[rows, "bias_instability"].to_numpy()
        lag_one = np.corrcoef(drift_noise[1:], drift_noise[:-1])[0, 1]
        np.testing.assert_allclose(
            lag_one, np.exp(-sampling_period / params["bias_correlation_time"]), atol=0.01
        )
    # counting whole angle quanta: the output angle never strays more than one quantum
    for _, rows in parts.groupby(frame["run"]):
        angle_error = np.cumsum(rows["quantisation"]) * sampling_period / 3600.0
        assert np.abs(angle_error).max() <= OUTPUT_ANGLE_QUANTUM * (1 + 1e-6)


def test_without_noise_the_output_is_reference_plus_drift():
    bunch = make_thermal_campaign(n_units=1, n_runs=1, noise=False, random_state=0)
    np.testing.assert_allclose(bunch.target, bunch.frame["drift"], rtol=0, atol=1e-12)
    assert (bunch.components["angle_random_walk"] == 0).all()


def test_magnitudes_are_those_of_a_navigation_grade_gyro():
    bunch = make_thermal_campaign(random_state=0)
    frame, parts = bunch.frame, bunch.components
    assert 10_000 <= len(frame) <= 30_000
    peak_shupe = parts["shupe"].abs().groupby(frame["run"]).max()
    assert peak_shupe.min() > 0.005
    assert peak_shupe.max() < 0.8
    assert parts["coil_rate"].abs().max() < 2.0
    for params in bunch.unit_params:
        assert 0.001 <= params["angle_random_walk"] <= 0.005
        assert 0.1 <= params["k0"] <= 0.3


def test_return_x_y_and_numpy_forms(campaign):
    X, y = make_thermal_campaign(**SMALL, profile="mix", random_state=7, return_X_y=True)
    assert_frame_equal(X, campaign.data, check_exact=True)
    pd.testing.assert_series_equal(y, campaign.target, check_exact=True)

    arrays = make_thermal_campaign(**SMALL, profile="mix", random_state=7, as_frame=False)
    assert arrays.frame is None
    assert arrays.data.dtype == np.float64
    np.testing.assert_array_equal(arrays.data, campaign.data.to_numpy(dtype=np.float64))
    np.testing.assert_array_equal(arrays.target, campaign.target.to_numpy())
    X, y = make_thermal_campaign(
        **SMALL, profile="mix", random_state=7, as_frame=False, return_X_y=True
    )
    assert isinstance(X, np.ndarray)
    assert X.shape == (len(campaign.frame), 5)
    assert y.shape == (len(campaign.frame),)


def test_first_order_lag_tracks_a_ramp_with_the_analytic_solution():
    dt, tau = 10.0, 600.0
    time = np.arange(0, 7200.0, dt)
    ramp = 0.01 * time  # degC/s from equilibrium at 0
    lagged = first_order_lag(ramp, dt, tau, 0.0)
    analytic = 0.01 * (time - tau * (1.0 - np.exp(-time / tau)))
    np.testing.assert_allclose(lagged, analytic, rtol=0, atol=1e-10)


@pytest.mark.parametrize(
    ("params", "name"),
    [
        ({"n_units": 0}, "n_units"),
        ({"n_runs": 1.5}, "n_runs"),
        ({"latitude": 91.0}, "latitude"),
        ({"sampling_period": 0.0}, "sampling_period"),
        ({"profile": "ramp"}, "profile"),
        ({"profile": ["paper", "sine"]}, "profile"),
        ({"profile": []}, "profile"),
        ({"azimuths": []}, "azimuths"),
        ({"azimuths": [0.0, np.nan]}, "azimuths"),
        ({"azimuths": ["north"]}, "azimuths"),
        ({"ramp_rate": -1.0}, "ramp_rate"),
        ({"ramp_rate": (2.0, 0.5)}, "ramp_rate"),
        ({"ramp_rate": (0.0, 0.5)}, "ramp_rate"),
        ({"temperature_range": (40.0, -10.0)}, "temperature_range"),
        ({"temperature_range": (0.0, 10.0, 20.0)}, "temperature_range"),
        ({"noise": "yes"}, "noise"),
        ({"random_state": "seed"}, "random_state"),
    ],
)
def test_bad_parameters_raise_an_error_naming_the_parameter(params, name):
    with pytest.raises(ValueError, match=name):
        make_thermal_campaign(**params)
