"""Tests of the thermal-test simulator, sklearn_ifog.datasets.make_thermal_campaign."""

import numpy as np
import pandas as pd
import pytest
from pandas.testing import assert_frame_equal

from sklearn_ifog._compat import InvalidParameterError
from sklearn_ifog.datasets import make_thermal_campaign, noise_floor
from sklearn_ifog.datasets._layered import (
    LAYERED_COMPONENT_COLUMNS,
    glass_stiffness,
    layered_drift,
    shupe_weights,
    simulate_layered_run,
)
from sklearn_ifog.datasets._simulator import (
    COMPONENT_COLUMNS,
    OUTPUT_ANGLE_QUANTUM,
    first_order_lag,
    shupe_coefficient,
    static_bias,
)
from sklearn_ifog.datasets._thermal import (
    block_average,
    conduction_network,
    modal_response,
    simulate_network,
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
# The tests of the lumped model's own equations (k0, tau_outer, the two-lag steady state) name
# physics="lumped"; the layered presets, the default, have tests of their own below.
SMALL = {"n_units": 2, "n_runs": 2, "azimuths": [0.0, 90.0], "physics": "lumped"}


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
    """Checked once on the fixture's campaign seeds 7-16 (holds on each)."""
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
    """Checked once on the fixture's campaign seeds 7-16 (holds on each)."""
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
        physics="lumped",
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
    """Checked once on campaign seeds 11-20 (holds on each)."""
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
    """Checked once on campaign seeds 0-9 (holds on each)."""
    bunch = make_thermal_campaign(physics="lumped", random_state=0)
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


# ------------------------------------------------------------------------------------------
# physics="layered" and "layered_glass"
# ------------------------------------------------------------------------------------------

LAYERED = {"n_units": 2, "n_runs": 1, "azimuths": [0.0, 90.0], "profile": "cycle"}


@pytest.fixture(scope="module")
def layered():
    return make_thermal_campaign(**LAYERED, physics="layered", noise=False, random_state=3)


def _unit_network(params):
    A, b, capacity = conduction_network(
        params["n_layers"],
        params["tau_housing"],
        params["tau_contact"],
        params["tau_diffusion"],
        params["coil_capacity_ratio"],
    )
    return A, b, capacity


def test_layered_is_the_default_physics_and_lumped_keeps_its_columns():
    settings = {key: value for key, value in SMALL.items() if key != "physics"}
    default = make_thermal_campaign(**settings, profile="mix", random_state=7)
    named = make_thermal_campaign(**settings, profile="mix", physics="layered", random_state=7)
    assert_frame_equal(default.frame, named.frame, check_exact=True)
    assert_frame_equal(default.components, named.components, check_exact=True)
    lumped = make_thermal_campaign(**SMALL, profile="mix", random_state=7)
    assert list(lumped.components.columns) == list(COMPONENT_COLUMNS)


@pytest.mark.parametrize("physics", ["layered", "layered_glass"])
def test_layered_campaign_is_deterministic_and_keeps_the_contract(physics):
    first = make_thermal_campaign(**LAYERED, physics=physics, random_state=5)
    again = make_thermal_campaign(**LAYERED, physics=physics, random_state=5)
    assert_frame_equal(first.frame, again.frame, check_exact=True)
    assert_frame_equal(first.components, again.components, check_exact=True)
    assert first.unit_params == again.unit_params
    assert list(first.frame.columns) == FRAME_COLUMNS
    assert list(first.components.columns) == list(LAYERED_COMPONENT_COLUMNS)
    other = make_thermal_campaign(**LAYERED, physics=physics, random_state=6)
    assert other.unit_params[0]["shupe_gradient"] != first.unit_params[0]["shupe_gradient"]
    noise = ["turn_on_bias", "bias_instability", "angle_random_walk", "quantisation"]
    np.testing.assert_allclose(
        first.target - first.frame["drift"],
        first.components[noise].sum(axis=1),
        rtol=0,
        atol=1e-9,
    )
    parts = first.components
    np.testing.assert_allclose(
        first.frame["drift"],
        parts["static_bias"] + parts["shupe"] + parts["stress"],
        rtol=0,
        atol=1e-12,
    )


def test_network_conserves_heat_and_settles_at_the_chamber_temperature():
    A, b, capacity = conduction_network(5, 1500.0, 1200.0, 300.0, 0.3)
    taus, weights = modal_response(A, b, capacity)
    assert np.all(taus > 0)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    step = 5.0
    time = np.arange(0.0, 20 * taus.max(), step)
    chamber = np.where(time < 600.0, 0.0, np.minimum(30.0, (time - 600.0) / 60.0))
    temperatures, rates = simulate_network(chamber, step, taus, weights)
    # the state equation holds at every sample: dx/dt = A x + b u
    np.testing.assert_allclose(rates, A @ temperatures + b[:, None] * chamber, atol=1e-12)
    # heat balance: the stored heat changes only through the housing's air conductance
    stored_rate = capacity @ rates
    np.testing.assert_allclose(stored_rate, b[0] * (chamber - temperatures[0]), atol=1e-12)
    # maximum principle, and a long soak brings every node to the chamber temperature
    assert temperatures.min() >= -1e-9
    assert temperatures.max() <= 30.0 + 1e-9
    np.testing.assert_allclose(temperatures[:, -1], 30.0, rtol=0, atol=1e-6)


def test_a_long_soak_leaves_only_the_static_bias():
    campaign = make_thermal_campaign(n_units=1, physics="layered", random_state=0)
    params = campaign.unit_params[0]
    times = np.array([0.0, 3600.0, 3600.0 + 30.0 * 60.0, 30.0 * 3600.0])
    levels = np.array([0.0, 0.0, 30.0, 30.0])
    period = 60.0
    n_samples = int(times[-1] // period) + 1
    parts = simulate_layered_run(
        params,
        times,
        levels,
        np.zeros(n_samples),
        period,
        False,
        False,
        np.random.RandomState(0),
    )
    layers = np.vstack([parts[f"layer_{index}"] for index in range(params["n_layers"])])
    np.testing.assert_allclose(layers[:, -1], 30.0, rtol=0, atol=1e-6)
    assert abs(parts["shupe"][-1]) < 1e-8
    assert abs(parts["stress"][-1]) < 1e-8
    bias = np.polynomial.polynomial.polyval(30.0 - 15.0, params["bias_coefficients"])
    np.testing.assert_allclose(parts["drift"][-1], bias, rtol=0, atol=1e-8)
    # during the ramp, the Shupe and stress terms are not negligible
    assert np.abs(parts["shupe"]).max() > 1e-3
    assert np.abs(parts["stress"]).max() > 1e-3


def test_outer_layers_lead_the_inner_ones_and_the_sensor_follows_the_housing(layered):
    frame, parts = layered.frame, layered.components
    params = layered.unit_params[0]
    # from equilibrium, a ramp up and (after a long soak) a ramp down
    times = np.array([0.0, 3600.0, 3600.0 + 3600.0, 12 * 3600.0, 13 * 3600.0, 20 * 3600.0])
    levels = np.array([0.0, 0.0, 30.0, 30.0, 0.0, 0.0])
    period = 60.0
    n_samples = int(times[-1] // period) + 1
    run = simulate_layered_run(
        params, times, levels, np.zeros(n_samples), period, False, False, np.random.RandomState(0)
    )
    order = np.vstack([run["housing"]] + [run[f"layer_{index}"] for index in range(5)])
    for ramp_start, ramp_end, sign in ((3600.0, 7200.0, 1.0), (12 * 3600.0, 13 * 3600.0, -1.0)):
        ramp = (np.arange(n_samples) * period > ramp_start + 600.0) & (
            np.arange(n_samples) * period <= ramp_end
        )
        # heating: housing > outer > ... > inner; cooling: the reverse
        assert np.all(sign * np.diff(order[:, ramp], axis=0) < 0)
        # the sensor on the housing lags it
        assert np.all(sign * (run["housing"][ramp] - run["sensor"][ramp]) > 0)
    # the sensor is a first-order lag of the housing (tau_sensor), not of the coil
    for _, rows in frame.groupby("run"):
        params = layered.unit_params[int(rows["unit"].iloc[0])]
        housing = parts.loc[rows.index, "housing"].to_numpy()
        lagged = first_order_lag(housing, 60.0, params["tau_sensor"], housing[0])
        sensor = parts.loc[rows.index, "sensor"].to_numpy()
        assert np.abs(lagged - sensor).max() < 0.01
        assert np.abs(parts.loc[rows.index, "coil_mean"].to_numpy() - sensor).max() > 0.5
    # the reading is the sensor plus the unit's offset, quantised to 0.01 degC
    offsets = frame["unit"].map(lambda unit: layered.unit_params[unit]["sensor_offset"])
    error = frame["temperature"] - parts["sensor"] - offsets
    assert np.abs(error).max() <= 0.005 + 1e-9


def test_layer_temperatures_stay_within_the_chamber_history(layered):
    frame, parts = layered.frame, layered.components
    layers = parts[[f"layer_{index}" for index in range(5)]]
    for _, rows in frame.groupby("run"):
        chamber = rows["chamber_temperature"]
        block = layers.loc[rows.index].to_numpy()
        assert block.min() >= chamber.min() - 1e-9
        assert block.max() <= chamber.max() + 1e-9


def test_shupe_drift_integrates_to_the_change_of_the_layer_potential(layered):
    # sum_i w_i k(T_i) dT_i/dt is an exact time derivative: its integral over a run is the
    # change of sum_i w_i F(T_i), F(T) = (T - T0) + k1 (T - T0)² / 2; a cycle that comes back
    # to its start leaves (almost) no net Shupe drift.
    frame, parts = layered.frame, layered.components
    for _, rows in frame.groupby("run"):
        params = layered.unit_params[int(rows["unit"].iloc[0])]
        weights = shupe_weights(5, params["shupe_gradient"], params["shupe_asymmetry"])
        np.testing.assert_allclose(weights.sum(), params["shupe_asymmetry"], rtol=1e-12)
        layers = parts.loc[rows.index, [f"layer_{index}" for index in range(5)]].to_numpy()
        delta = layers - 15.0
        potential = (delta + 0.5 * params["k1"] * delta**2) @ weights
        period = 60.0  # the default sampling period; shupe is in deg/h per (degC/min)
        integral = parts.loc[rows.index[1:], "shupe"].sum() * period / 60.0
        np.testing.assert_allclose(integral, potential[-1] - potential[0], rtol=1e-9, atol=1e-12)


def test_gyro_samples_are_means_over_the_sample_period():
    common = {
        "n_units": 1,
        "n_runs": 1,
        "azimuths": [0.0],
        "physics": "layered_glass",
        "random_state": 2,
    }
    fine = make_thermal_campaign(**common, sampling_period=1.0, noise=False)
    coarse = make_thermal_campaign(**common, sampling_period=60.0, noise=False)
    n = len(coarse.frame) - 1
    rate = fine.frame["rate"].to_numpy()[1 : 1 + 60 * n].reshape(n, 60).mean(axis=1)
    np.testing.assert_allclose(coarse.frame["rate"].to_numpy()[1:], rate, rtol=0, atol=1e-12)
    # temperatures are instantaneous: equal at coincident times
    for name in ["temperature", "chamber_temperature"]:
        np.testing.assert_array_equal(
            coarse.frame[name].to_numpy(), fine.frame[name].to_numpy()[::60][: n + 1]
        )


def test_the_same_seed_gives_the_same_thermal_history_at_every_sample_period():
    common = {"n_units": 2, "n_runs": 2, "azimuths": [0.0], "physics": "layered"}
    runs = {}
    for period in (10.0, 60.0):
        runs[period] = make_thermal_campaign(**common, sampling_period=period, random_state=9)
    ten, sixty = runs[10.0], runs[60.0]
    assert ten.unit_params == sixty.unit_params
    for run in range(4):
        a = ten.frame[ten.frame["run"] == run]
        b = sixty.frame[sixty.frame["run"] == run]
        np.testing.assert_array_equal(
            b["temperature"].to_numpy(), a["temperature"].to_numpy()[::6]
        )
        np.testing.assert_allclose(
            b["chamber_temperature"].to_numpy(),
            a["chamber_temperature"].to_numpy()[::6],
            rtol=0,
            atol=1e-12,
        )


def test_angle_random_walk_per_sample_scales_as_one_over_the_sample_period():
    for period in (1.0, 10.0, 60.0):
        n_runs = {1.0: 1, 10.0: 2, 60.0: 10}[period]
        bunch = make_thermal_campaign(
            n_units=1,
            n_runs=n_runs,
            azimuths=[0.0],
            physics="layered",
            sampling_period=period,
            random_state=4,
        )
        white = bunch.components["angle_random_walk"].to_numpy()
        assert white.size > 2500
        expected = bunch.unit_params[0]["angle_random_walk"] * 60.0 / np.sqrt(period)
        # std of a sample std: 1 / sqrt(2 n) < 1.5 %; 6 % is four of those
        np.testing.assert_allclose(white.std(), expected, rtol=0.06)


def test_glass_transition_bends_the_stress_term_and_the_bias_around_tg():
    common = {**LAYERED, "noise": False, "random_state": 3, "sampling_period": 10.0}
    plain = make_thermal_campaign(**common, physics="layered")
    glass = make_thermal_campaign(**common, physics="layered_glass")
    # same units, same runs, same temperatures; only the potting's stiffness differs
    assert plain.unit_params == glass.unit_params
    for name in ["coil_mean", "shupe", "layer_0", "layer_4"]:
        np.testing.assert_array_equal(plain.components[name], glass.components[name])
    for unit, params in enumerate(glass.unit_params):
        rows = (glass.frame["unit"] == unit).to_numpy()
        coil = glass.components.loc[rows, "coil_mean"].to_numpy()
        stiffness = glass_stiffness(
            coil, params["glass_temperature"], params["glass_width"], params["rubbery_ratio"]
        )
        stress_plain = plain.components.loc[rows, "stress"].to_numpy()
        stress_glass = glass.components.loc[rows, "stress"].to_numpy()
        large = np.abs(stress_plain) > 1e-3
        assert large.sum() > 20
        # stress ratio = stiffness (to the sample-averaging error)
        np.testing.assert_allclose(
            stress_glass[large] / stress_plain[large], stiffness[large], rtol=0, atol=0.02
        )
        # the bias gains a slope change glass_bias_slope across Tg
        tg, width = params["glass_temperature"], params["glass_width"]
        temperatures = np.array([tg - 6 * width, tg - 5 * width, tg + 5 * width, tg + 6 * width])
        layers = np.tile(temperatures, (5, 1))
        bias_plain, _ = layered_drift(params, layers, temperatures, glass=False)
        bias_glass, _ = layered_drift(params, layers, temperatures, glass=True)
        bend = bias_glass - bias_plain
        slope_below = (bend[1] - bend[0]) / width
        slope_above = (bend[3] - bend[2]) / width
        np.testing.assert_allclose(slope_below, 0.0, atol=0.01 * abs(params["glass_bias_slope"]))
        np.testing.assert_allclose(slope_above, params["glass_bias_slope"], rtol=0.01)
    assert np.all(stiffness <= 1.0)
    assert all(10.0 <= p["glass_temperature"] <= 25.0 for p in glass.unit_params)


def test_layered_magnitudes_are_those_of_a_navigation_grade_gyro():
    """Checked once on campaign seeds 0-9 (holds on each)."""
    bunch = make_thermal_campaign(physics="layered", sampling_period=60.0, random_state=0)
    frame, parts = bunch.frame, bunch.components
    thermal = (parts["shupe"] + parts["stress"]).abs().groupby(frame["run"]).max()
    assert thermal.max() < 1.0
    assert thermal.median() > 0.005
    assert frame["drift"].abs().max() < 1.0
    assert (parts["coil_outer"] - parts["coil_inner"]).abs().max() < 10.0
    for params in bunch.unit_params:
        taus, _ = modal_response(*_unit_network(params))
        assert 10 * 60 <= taus.max() <= 90 * 60  # slowest thermal mode: tens of minutes
        assert 0.001 <= params["angle_random_walk"] <= 0.005


def test_noise_floor_is_the_mean_squared_noise():
    bunch = make_thermal_campaign(**LAYERED, physics="layered", random_state=1)
    parts = bunch.components
    noise = parts[["turn_on_bias", "bias_instability", "angle_random_walk", "quantisation"]]
    squared = noise.sum(axis=1).to_numpy() ** 2
    np.testing.assert_allclose(noise_floor(bunch.frame), squared.mean(), rtol=1e-9)
    rows = (bunch.frame["run"] == 1).to_numpy()
    np.testing.assert_allclose(noise_floor(bunch.frame, rows), squared[rows].mean(), rtol=1e-9)
    np.testing.assert_allclose(
        noise_floor(bunch.frame, np.flatnonzero(rows)), squared[rows].mean(), rtol=1e-9
    )
    quiet = make_thermal_campaign(**LAYERED, physics="layered", noise=False, random_state=1)
    assert noise_floor(quiet.frame) < 1e-25
    with pytest.raises(ValueError, match="drift"):
        noise_floor(bunch.frame.drop(columns="drift"))
    with pytest.raises(ValueError, match="rows"):
        noise_floor(bunch.frame, np.zeros(len(bunch.frame), dtype=bool))


def test_block_average_nests_and_rejects_a_ragged_grid():
    values = np.random.RandomState(0).standard_normal(6 * 10 + 1)
    fine = block_average(values, 6)
    coarse = block_average(values, 30)
    np.testing.assert_allclose(coarse, fine.reshape(2, 5).mean(axis=1), rtol=0, atol=1e-14)
    with pytest.raises(ValueError, match="per_block"):
        block_average(values[:-1], 6)


def test_unknown_physics_raises_an_error_naming_the_parameter():
    with pytest.raises(ValueError, match="physics"):
        make_thermal_campaign(physics="distributed")


# -- a production lot: lot_spread ------------------------------------------------------------


@pytest.mark.parametrize("physics", ["lumped", "layered", "layered_glass"])
def test_lot_units_scatter_around_the_design(physics):
    """Checked once on lot seeds 5-14 for each physics (holds on each)."""

    def campaign(spread):
        return make_thermal_campaign(
            n_units=6,
            n_runs=1,
            azimuths=[0.0],
            sampling_period=600.0,
            physics=physics,
            lot_spread=spread,
            random_state=5,
        )

    identical = campaign(0.0)
    design = identical.design_params
    for params in identical.unit_params:
        assert {**params, "unit": None} == design
    scattered = campaign(0.2)
    numeric = [
        key
        for key, value in scattered.design_params.items()
        if isinstance(value, float) and key != "reference_temperature"
    ]
    for params in scattered.unit_params:
        for key in numeric:
            ratio = params[key] / scattered.design_params[key]
            assert ratio > 0  # the design's sign is kept
    log_ratios = np.log(
        [[p[key] / scattered.design_params[key] for key in numeric] for p in scattered.unit_params]
    )
    # a lognormal scatter of about the asked spread (6 units x many coefficients)
    assert 0.1 < log_ratios.std() < 0.3
    assert (
        scattered.unit_params[0]["turn_on_bias_repeatability"]
        == (design["turn_on_bias_repeatability"])
    )


def test_lot_is_closer_than_independent_units():
    """Checked once on campaign seeds 0-9 (holds on each)."""
    kwargs = {
        "n_units": 5,
        "n_runs": 1,
        "azimuths": [0.0],
        "sampling_period": 600.0,
        "physics": "lumped",
    }
    independent = make_thermal_campaign(**kwargs, random_state=0)
    lot = make_thermal_campaign(**kwargs, lot_spread=0.05, random_state=0)
    assert independent.design_params is None

    def spread(params):
        k0 = np.array([p["k0"] for p in params])
        return k0.std() / np.abs(k0.mean())

    assert spread(lot.unit_params) < 0.5 * spread(independent.unit_params)


def test_lot_spread_must_be_non_negative():
    with pytest.raises(InvalidParameterError, match="lot_spread"):
        make_thermal_campaign(n_units=1, n_runs=1, lot_spread=-0.1)
