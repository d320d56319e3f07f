"""Tests of the simulator's glass-transition presets beyond the logistic (issue 45, point 4)."""

import numpy as np
import pytest

from sklearn_ifog.datasets import make_rate_table_campaign, make_thermal_campaign
from sklearn_ifog.datasets._layered import glass_stiffness, layered_drift
from sklearn_ifog.datasets._simulator import PHYSICS
from sklearn_ifog.datasets._transitions import (
    TRANSITION_PRESETS,
    asymmetric_stiffness,
    draw_transition_params,
    hysteresis_state,
    transition_state,
    two_step_stiffness,
)

EXTRA_KEYS = {
    "glass_exponent",
    "glass_temperature_2",
    "glass_width_2",
    "rubbery_ratio_2",
    "glass_hysteresis",
    "glass_memory",
}
SETTINGS = {"n_units": 3, "n_runs": 1, "azimuths": [0.0], "profile": "cycle"}
SETTINGS = {**SETTINGS, "sampling_period": 30.0, "random_state": 5}


@pytest.fixture(scope="module")
def campaigns():
    """One noise-free campaign per layered preset, all from the same seed."""
    names = ["layered", "layered_glass", *TRANSITION_PRESETS]
    return {name: make_thermal_campaign(**SETTINGS, physics=name, noise=False) for name in names}


def _unit_rows(campaign, unit):
    return (campaign.frame["unit"] == unit).to_numpy()


# ---------------------------------------------------------------------------------------
# the shapes
# ---------------------------------------------------------------------------------------


def test_asymmetric_step_is_the_logistic_at_exponent_one_and_lopsided_otherwise():
    temperature = np.linspace(-10.0, 40.0, 501)
    np.testing.assert_allclose(
        asymmetric_stiffness(temperature, 15.0, 2.5, 0.2, 1.0),
        glass_stiffness(temperature, 15.0, 2.5, 0.2),
        rtol=0,
        atol=1e-14,
    )
    fine = np.linspace(-60.0, 90.0, 150001)
    for exponent in (0.2, 0.5, 2.0, 5.0):
        stiffness = asymmetric_stiffness(fine, 15.0, 2.5, 0.2, exponent)
        done = (1.0 - stiffness) / 0.8
        # half the drop at Tg, whatever the exponent
        np.testing.assert_allclose(np.interp(15.0, fine, done), 0.5, atol=1e-6)
        # not symmetric about Tg: from 10 % to half the drop and from half to 90 % take
        # different spans (a logistic's are equal, 2.2 widths each)
        t10, t90 = np.interp([0.1, 0.9], done, fine)
        ratio = (t90 - 15.0) / (15.0 - t10)
        assert ratio > 1.2 if exponent > 1 else ratio < 0.8
    sharp_onset = asymmetric_stiffness([10.0, 20.0], 15.0, 2.5, 0.2, 4.0)
    slow_onset = asymmetric_stiffness([10.0, 20.0], 15.0, 2.5, 0.2, 0.25)
    logistic = glass_stiffness([10.0, 20.0], 15.0, 2.5, 0.2)
    # exponent > 1: little of the drop done below Tg; < 1: much of it
    assert 1.0 - sharp_onset[0] < 0.5 * (1.0 - logistic[0]) < 1.0 - slow_onset[0]


def test_two_transitions_give_two_drops_at_their_own_temperatures():
    p = {
        "glass_temperature": 22.0,
        "glass_width": 2.0,
        "rubbery_ratio": 0.25,
        "glass_temperature_2": 2.0,
        "glass_width_2": 1.5,
        "rubbery_ratio_2": 0.6,
    }
    temperature = np.linspace(-10.0, 40.0, 2001)
    stiffness = two_step_stiffness(temperature, p)
    slope = -np.gradient(stiffness, temperature)
    peaks = [
        i for i in range(1, len(slope) - 1) if slope[i] > slope[i - 1] and slope[i] >= slope[i + 1]
    ]
    np.testing.assert_allclose(temperature[peaks], [2.0, 22.0], atol=0.2)
    # plateaus: 1 below both, the second ratio between, the product above both
    np.testing.assert_allclose(
        two_step_stiffness([-10.0, 12.0, 40.0], p), [1, 0.6, 0.15], atol=4e-3
    )


def test_drawn_second_transition_is_apart_and_inside_the_range(campaigns):
    for params in campaigns["layered_glass_two"].unit_params:
        gap = abs(params["glass_temperature_2"] - params["glass_temperature"])
        assert gap >= 4.0 * max(params["glass_width"], params["glass_width_2"])
        assert -5.0 <= params["glass_temperature_2"] <= 35.0
        assert 0.4 <= params["rubbery_ratio_2"] <= 0.8
    rng = np.random.RandomState(0)
    for _ in range(200):
        base = {"glass_temperature": rng.uniform(10, 25), "glass_width": rng.uniform(1.5, 4)}
        extra = draw_transition_params({**base, "k1": rng.uniform()})
        assert abs(extra["glass_temperature_2"] - base["glass_temperature"]) >= 4.0 * max(
            base["glass_width"], extra["glass_width_2"]
        )
        assert -5.0 <= extra["glass_temperature_2"] <= 35.0
        assert 2.0 <= extra["glass_hysteresis"] <= 6.0
        assert min(extra["glass_exponent"], 1 / extra["glass_exponent"]) <= 0.5


def test_hysteresis_state_follows_the_rate_sign_and_a_soak_keeps_the_last():
    step = 1.0
    up = np.linspace(0.0, 30.0, 1801)  # 1 degC/min
    soak = np.full(3600, 30.0)
    down = np.linspace(30.0, 0.0, 1801)
    history = np.concatenate([up, soak, down, np.full(600, 0.0)])
    state = hysteresis_state(history, step, memory=1.0)
    # started at 0 degC after cooling from the laboratory's 20 degC
    np.testing.assert_allclose(state[0], -(1.0 - np.exp(-20.0)), rtol=1e-12)
    heated = state[len(up) - 1]
    assert heated > 0.99
    # the soak keeps the heating state, bit for bit
    np.testing.assert_array_equal(state[len(up) : len(up) + len(soak)], heated)
    assert state[len(up) + len(soak) + len(down) - 1] < -0.99
    np.testing.assert_array_equal(state[-600:], state[-600])
    # it switches over about `memory` degC of travel, not at once
    first_cooling = state[len(up) + len(soak) + 30]  # 0.5 degC into the cooling ramp
    assert -0.5 < first_cooling < 0.5


def test_hysteresis_heating_and_cooling_rows_differ_at_the_same_coil_temperature(campaigns):
    campaign = campaigns["layered_glass_hysteresis"]
    found = 0
    for unit, params in enumerate(campaign.unit_params):
        rows = _unit_rows(campaign, unit)
        comp = campaign.components[rows]
        coil = comp["coil_mean"].to_numpy()
        rate = comp["coil_rate"].to_numpy()
        stiffness = comp["stiffness"].to_numpy()
        tg, dh = params["glass_temperature"], params["glass_hysteresis"]
        effective = comp["glass_temperature"].to_numpy()
        assert np.all(np.abs(effective - tg) <= 0.5 * dh + 1e-12)
        heating = np.flatnonzero((rate > 0.1) & (np.abs(coil - tg) < params["glass_width"]))
        cooling = np.flatnonzero((rate < -0.1) & (np.abs(coil - tg) < params["glass_width"]))
        for i in heating:
            j = cooling[np.argmin(np.abs(coil[cooling] - coil[i]))] if cooling.size else None
            if j is None or abs(coil[j] - coil[i]) > 0.05:
                continue
            found += 1
            # the transition lies higher on heating: the coating is still stiffer there
            assert effective[i] - effective[j] > 0.8 * dh
            assert stiffness[i] - stiffness[j] > 0.05
    assert found >= 5


def test_hysteresis_soak_keeps_the_last_state_with_noise():
    campaign = make_thermal_campaign(
        **{**SETTINGS, "n_units": 2}, physics="layered_glass_hysteresis", noise=True
    )
    for run in campaign.run_params.itertuples():
        rows = (campaign.frame["run"] == run.run).to_numpy()
        params = campaign.unit_params[run.unit]
        tg, dh = params["glass_temperature"], params["glass_hysteresis"]
        effective = campaign.components.loc[rows, "glass_temperature"].to_numpy()
        chamber = campaign.frame.loc[rows, "chamber_temperature"].to_numpy()
        time = campaign.frame.loc[rows, "time"].to_numpy()
        # the end of the soak at the top of the first cycle: heated, and kept so
        top = run.breakpoint_temperatures.argmax()
        start, end = run.breakpoint_times[top], run.breakpoint_times[top + 1]
        soak = (time > start + 0.5 * (end - start)) & (time <= end)
        assert np.all(np.abs(chamber[soak] - run.max_setpoint) < 0.5)
        assert np.all(effective[soak] > tg + 0.4 * dh)


# ---------------------------------------------------------------------------------------
# the same units and runs as "layered"; noise-free identities
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("physics", list(TRANSITION_PRESETS))
def test_presets_share_every_unit_and_run_with_layered(campaigns, physics):
    plain, new = campaigns["layered"], campaigns[physics]
    for a, b in zip(plain.unit_params, new.unit_params, strict=True):
        assert set(b) - set(a) == EXTRA_KEYS
        assert {key: b[key] for key in a} == a
    assert plain.run_params.drop(columns=["breakpoint_times", "breakpoint_temperatures"]).equals(
        new.run_params.drop(columns=["breakpoint_times", "breakpoint_temperatures"])
    )
    for name in ["temperature", "chamber_temperature", "time", "reference"]:
        np.testing.assert_array_equal(plain.frame[name], new.frame[name])
    for name in ["coil_mean", "coil_rate", "shupe", "housing", "layer_0", "layer_4"]:
        np.testing.assert_array_equal(plain.components[name], new.components[name])
    assert not np.array_equal(plain.frame["drift"], new.frame["drift"])


@pytest.mark.parametrize("physics", list(TRANSITION_PRESETS))
def test_noise_free_identities(campaigns, physics):
    plain, new = campaigns["layered"], campaigns[physics]
    frame, comp = new.frame, new.components
    np.testing.assert_array_equal(frame["rate"], frame["reference"] + frame["drift"])
    np.testing.assert_allclose(
        frame["drift"], comp["static_bias"] + comp["shupe"] + comp["stress"], rtol=0, atol=1e-12
    )
    kind = TRANSITION_PRESETS[physics]
    for unit, params in enumerate(new.unit_params):
        rows = _unit_rows(new, unit)
        coil = comp.loc[rows, "coil_mean"].to_numpy()
        if kind == "asymmetric":
            expected = asymmetric_stiffness(
                coil,
                params["glass_temperature"],
                params["glass_width"],
                params["rubbery_ratio"],
                params["glass_exponent"],
            )
        elif kind == "two":
            expected = two_step_stiffness(coil, params)
        else:
            expected = glass_stiffness(
                coil,
                comp.loc[rows, "glass_temperature"].to_numpy(),
                params["glass_width"],
                params["rubbery_ratio"],
            )
        stiffness = comp.loc[rows, "stiffness"].to_numpy()
        np.testing.assert_allclose(stiffness, expected, rtol=1e-12, atol=0)
        # the stress is the plain one times the stiffness (to the sample-averaging error)
        stress_plain = plain.components.loc[rows, "stress"].to_numpy()
        stress = comp.loc[rows, "stress"].to_numpy()
        large = np.abs(stress_plain) > 1e-3
        assert large.sum() > 20
        np.testing.assert_allclose(
            stress[large] / stress_plain[large], stiffness[large], atol=0.02
        )


def test_layered_drift_bends_the_bias_at_the_effective_transition_temperature():
    params = make_thermal_campaign(n_units=1, n_runs=1, random_state=0).unit_params[0]
    params = {**params, **draw_transition_params(params)}
    temperature = np.linspace(-10.0, 40.0, 101)
    layers = np.tile(temperature, (5, 1))
    state = transition_state(params, temperature, "asymmetric", 1.0)
    with_state = layered_drift(params, layers, temperature, True, state)
    logistic = layered_drift(params, layers, temperature, True)
    np.testing.assert_array_equal(with_state[0], logistic[0])  # same Tg: same bias
    moved = {**state, "glass_temperature": state["glass_temperature"] + 3.0}
    shifted = layered_drift(
        {**params, "glass_temperature": params["glass_temperature"] + 3.0},
        layers,
        temperature,
        True,
    )
    np.testing.assert_allclose(
        layered_drift(params, layers, temperature, True, moved)[0], shifted[0], rtol=0, atol=1e-15
    )


def test_lot_scatters_the_extra_coefficients_around_the_design():
    same = make_thermal_campaign(
        **SETTINGS, physics="layered_glass_two", noise=False, lot_spread=0.0
    )
    for params in same.unit_params:
        assert {key: params[key] for key in EXTRA_KEYS} == {
            key: same.design_params[key] for key in EXTRA_KEYS
        }
    plain = make_thermal_campaign(**SETTINGS, physics="layered", noise=False, lot_spread=0.1)
    lot = make_thermal_campaign(
        **SETTINGS, physics="layered_glass_two", noise=False, lot_spread=0.1
    )
    assert {key: lot.design_params[key] for key in plain.design_params} == plain.design_params
    for a, b in zip(plain.unit_params, lot.unit_params, strict=True):
        assert {key: b[key] for key in a} == a
        ratio = b["glass_width_2"] / lot.design_params["glass_width_2"]
        assert ratio != 1.0
        assert 0.5 < ratio < 2.0
    np.testing.assert_array_equal(plain.frame["temperature"], lot.frame["temperature"])


def test_rate_table_takes_the_presets_too():
    bunch = make_rate_table_campaign(
        n_units=1, n_runs=1, physics="layered_glass_asymmetric", random_state=0, noise=False
    )
    assert {"stiffness", "glass_temperature"} <= set(bunch.components.columns)
    assert bunch.components["stiffness"].between(0.0, 1.0).all()


# ---------------------------------------------------------------------------------------
# names
# ---------------------------------------------------------------------------------------


def test_presets_are_listed_and_bad_names_are_refused():
    assert PHYSICS[-3:] == (
        "layered_glass_asymmetric",
        "layered_glass_two",
        "layered_glass_hysteresis",
    )
    with pytest.raises(ValueError, match=r"physics.*layered_glass_hysteresis"):
        make_thermal_campaign(n_units=1, n_runs=1, physics="layered_glass_hysteretic")
    with pytest.raises(ValueError, match="kind must be one of"):
        transition_state({"glass_temperature": 15.0}, np.zeros(3), "gompertz", 1.0)


def test_hysteresis_state_equals_its_recursion_step_by_step():
    """The state is solved without a loop over the samples (blocks of decay): it equals the
    recursion it stands for, step by step, on a long history that travels hundreds of
    memories (several blocks)."""
    rng = np.random.default_rng(0)
    n = 200_000
    history = 20.0 + 60.0 * np.sin(np.linspace(0.0, 40.0, n)) + np.cumsum(rng.normal(0, 0.01, n))
    memory, step, rate_scale = 0.5, 1.0, 0.02
    travel = np.diff(history)
    target = np.tanh(travel / step * 60.0 / rate_scale)
    keep = np.exp(-np.abs(travel) / memory)
    start = history[0] - 20.0
    expected = [np.sign(start) * -np.expm1(-abs(start) / memory)]
    for goal, factor in zip(target.tolist(), keep.tolist(), strict=True):
        expected.append(goal + (expected[-1] - goal) * factor)
    assert np.abs(travel).sum() / memory > 3 * 300.0  # several blocks
    state = hysteresis_state(history, step, memory=memory, rate_scale=rate_scale)
    np.testing.assert_allclose(state, expected, rtol=0, atol=1e-10)
