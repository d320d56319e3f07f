"""First-order lags at time constants in seconds: exactness, the batch scan, runs, invariance."""

import math
import re

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.integrate import solve_ivp

from sklearn_ifog._lags import (
    LagState,
    first_order_lag,
    lag_coefficients,
    lag_deficit,
    lag_step,
    lead_estimate,
    smoothed_rate,
)
from sklearn_ifog.features import causal_rate, group_rows_by_run

HOLDS = ("linear", "previous", "current")


def _sequential(u, t, starts, tau, hold="linear"):
    """Plain Python reference: the per-sample recursion on the deficit, with math.exp."""
    out = np.empty(len(u))
    e = 0.0
    for i in range(len(u)):
        if starts[i]:
            e = 0.0
        else:
            x = (t[i] - t[i - 1]) / tau
            a = math.exp(-x)
            g = {"linear": -math.expm1(-x) / x, "previous": 1.0, "current": a}[hold]
            e = a * e + g * (u[i] - u[i - 1])
        out[i] = e
    return out


def _assert_close_to_scale(actual, reference, rtol, starts=None):
    """|actual - reference| <= rtol * (largest |reference| of the same run), per column."""
    actual = np.asarray(actual).reshape(len(actual), -1)
    reference = np.asarray(reference).reshape(len(reference), -1)
    run = np.zeros(len(actual), dtype=int) if starts is None else np.cumsum(starts) - 1
    scale = np.zeros_like(reference)
    for r in np.unique(run):
        rows = run == r
        scale[rows] = np.abs(reference[rows]).max(axis=0)
    assert np.all(np.abs(actual - reference) <= rtol * scale + 1e-300), (
        np.abs(actual - reference) / np.maximum(scale, 1e-300)
    ).max()


def _irregular_runs(rng, lengths, mean_step=30.0):
    values, times, starts = [], [], []
    for n in lengths:
        times.append(rng.uniform(0.0, 1e5) + np.cumsum(rng.exponential(mean_step, n) + 1e-3))
        values.append(20.0 + np.cumsum(rng.normal(0.0, 0.2, (n, 2)), axis=0))
        start = np.zeros(n, dtype=bool)
        start[0] = True
        starts.append(start)
    return np.concatenate(values), np.concatenate(times), np.concatenate(starts)


# ---------------------------------------------------------------------------------------------
# One step.
# ---------------------------------------------------------------------------------------------


def test_coefficients_limits_without_cancellation():
    x = np.array([0.0, 1e-300, 1e-12, 1e-6, 0.5, 30.0, 800.0, 1e300, np.inf])
    a, g = lag_coefficients(x, 1.0)
    assert np.all(np.isfinite(a))
    assert np.all(np.isfinite(g))
    # Taylor series of (1 - exp(-x)) / x for small x, 1 / x for large x.
    small = x[1:4]
    assert_allclose(g[1:4], 1 - small / 2 + small**2 / 6, rtol=1e-15)
    assert g[0] == 1.0  # the limit, for an underflowing h / tau
    assert_allclose(g[4], (1 - math.exp(-0.5)) / 0.5, rtol=1e-15)
    assert_allclose(g[5:8], 1 / x[5:8], rtol=1e-12)
    assert g[-1] == 0.0
    assert a[-1] == 0.0
    assert a[6] == 0.0
    # tau -> 0: the lag degenerates to the input (deficit 0).
    assert lag_step(3.0, 20.0, 25.0, 10.0, 1e-310) == 0.0
    _, g_previous = lag_coefficients(x[:4], 1.0, hold="previous")
    a_current, g_current = lag_coefficients(x[:4], 1.0, hold="current")
    assert_array_equal(g_previous, 1.0)
    assert_array_equal(g_current, a_current)


def test_step_is_the_closed_form_of_a_linear_input():
    # e' = du/h - e/tau from e0: e1 = a e0 + (du/h) tau (1 - a); with y = u - e, also the
    # form y1 = a y0 + (1 - a) u1 - du (tau (1 - a) / h - a).
    rng = np.random.default_rng(0)
    e0, u0, u1 = rng.normal(size=(3, 50))
    h, tau = rng.uniform(0.1, 100.0, (2, 50))
    a = np.exp(-h / tau)
    y0 = u0 - e0
    y1 = a * y0 + (1 - a) * u1 - (u1 - u0) * (tau * (1 - a) / h - a)
    assert_allclose(u1 - lag_step(e0, u0, u1, h, tau), y1, rtol=1e-12, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# Exactness against analytic and numerical solutions.
# ---------------------------------------------------------------------------------------------


def test_ramp_from_rest_is_exact_at_any_steps():
    rng = np.random.default_rng(1)
    # Steps from 1/64 s to 900 s on a binary grid and a rate of 1/32 degC/s: every u and
    # u1 - u0 is exact in float64, so only the lag's own arithmetic is measured.
    t = np.concatenate([[0.0], np.cumsum(rng.integers(1, 900 * 64, 400))]) / 64.0
    rate = 1.0 / 32.0  # degC/s
    u = -10.0 + rate * t
    taus = np.array([1.0, 60.0, 600.0, 3600.0, 1e7])
    exact = rate * taus * -np.expm1(-t[:, None] / taus)
    assert_allclose(lag_deficit(u, t, None, taus), exact, rtol=1e-13)
    lags = first_order_lag(u, t, None, taus)
    assert_allclose(lags, u[:, None] - exact, rtol=0, atol=1e-13 * np.abs(u).max())
    assert_allclose(
        smoothed_rate(u, t, None, taus), 60 * rate * -np.expm1(-t[:, None] / taus), rtol=1e-13
    )


def test_fast_step_is_exact():
    # A step of 1 degC rising over 1 microsecond, then held: for t >= delta,
    # y = 1 - (tau / delta) (exp(delta / tau) - 1) exp(-t / tau).
    delta, tau = 1e-6, 600.0
    t = np.array([0.0, delta, 1.0, 60.0, 600.0, 3000.0])
    u = np.array([0.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    exact = 1 - tau / delta * math.expm1(delta / tau) * np.exp(-t[1:] / tau)
    assert_allclose(first_order_lag(u, t, None, tau)[1:], exact, rtol=0, atol=1e-14)


def test_matches_an_ode_solver_for_piecewise_linear_input():
    rng = np.random.default_rng(2)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(1.0, 200.0, 60))])
    u = 20.0 + np.cumsum(rng.normal(0.0, 1.0, t.size))
    tau = 150.0
    reference = [u[0]]
    y = u[0]
    for i in range(1, t.size):  # integrate each linear piece on its own (no kinks inside)
        slope = (u[i] - u[i - 1]) / (t[i] - t[i - 1])

        def rhs(s, y, i=i, slope=slope):
            return (u[i - 1] + slope * (s - t[i - 1]) - y) / tau

        y = solve_ivp(rhs, (t[i - 1], t[i]), [y], method="DOP853", rtol=1e-13, atol=1e-13)
        y = y.y[0, -1]
        reference.append(y)
    assert_allclose(first_order_lag(u, t, None, tau), reference, rtol=0, atol=1e-10)


@pytest.mark.parametrize("hold", HOLDS)
def test_sine_error_is_second_order_with_linear_hold(hold):
    # From rest at u(0) = 0: y = A / (1 + w^2 tau^2) (sin wt - w tau cos wt + w tau e^(-t/tau)).
    amplitude, period, tau = 10.0, 3600.0, 600.0
    w = 2 * np.pi / period
    errors = []
    for step in (60.0, 30.0):
        t = np.arange(0.0, 4 * period + step / 2, step)
        u = amplitude * np.sin(w * t)
        exact = (
            amplitude
            / (1 + (w * tau) ** 2)
            * (np.sin(w * t) - w * tau * np.cos(w * t) + w * tau * np.exp(-t / tau))
        )
        error = np.abs(first_order_lag(u, t, None, tau, hold=hold) - exact).max()
        if hold == "linear":
            # Interpolation error h^2/8 max|u''| through a filter of unit gain.
            assert error <= step**2 / 8 * amplitude * w**2
        errors.append(error)
    ratio = errors[0] / errors[1]
    if hold == "linear":
        assert 3.5 < ratio < 4.5  # halving the step divides the error by 4
    else:
        assert 1.7 < ratio < 2.3  # a hold delays by half a step: first order


# ---------------------------------------------------------------------------------------------
# The vectorised scan against the sequential recursion.
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("hold", HOLDS)
def test_batch_equals_sequential_recursion(hold):
    rng = np.random.default_rng(3)
    # Many runs (one-row runs among them), irregular steps, and long runs whose duration is
    # far beyond 700 time constants (products of a would underflow in one piece).
    lengths = [1, 5000, 1, 2, 64, 65, 129, 1, 20000, 3, 700]
    u, t, starts = _irregular_runs(rng, lengths)
    taus = np.array([0.5, 30.0, 600.0, 3600.0, 1e6])
    assert (t[starts.nonzero()[0][1] + 4999] - t[1]) / taus[1] > 700 * 5
    batch = lag_deficit(u, t, starts, taus, hold=hold)
    assert batch.shape == (u.shape[0], 2, taus.size)
    for column in range(2):
        for k, tau in enumerate(taus):
            reference = _sequential(u[:, column], t, starts, tau, hold)
            _assert_close_to_scale(batch[:, column, k], reference, 1e-12, starts)
    assert_array_equal(batch[starts], 0.0)


def test_long_uniform_run_with_tiny_and_huge_time_constants():
    t = np.arange(200_000) * 1.0
    u = 20.0 + 5.0 * np.sin(t / 5000.0) + 0.01 * np.round(np.sin(t / 7.0) * 3)
    taus = np.array([1e-3, 0.2, 3600.0, 1e9])
    starts = np.zeros(t.size, dtype=bool)
    starts[0] = True
    batch = lag_deficit(u, t, None, taus)
    for k, tau in enumerate(taus):
        _assert_close_to_scale(batch[:, k], _sequential(u, t, starts, tau), 1e-12)
    assert np.all(np.isfinite(batch))


def test_streaming_step_by_step_equals_batch():
    rng = np.random.default_rng(4)
    u, t, _ = _irregular_runs(rng, [3000])
    taus = np.array([60.0, 600.0, 7200.0])
    batch = lag_deficit(u, t, None, taus)
    state = np.zeros((2, 3))
    streamed = [state]
    for i in range(1, t.size):
        state = lag_step(state, u[i - 1][:, None], u[i][:, None], t[i] - t[i - 1], taus)
        streamed.append(state)
    _assert_close_to_scale(
        np.array(streamed).reshape(t.size, -1), batch.reshape(t.size, -1), 1e-12
    )


@pytest.mark.parametrize("cut", [1, 63, 64, 65, 1000, 2999])
def test_chunks_continued_from_a_state_equal_the_whole_run(cut):
    rng = np.random.default_rng(5)
    u, t, _ = _irregular_runs(rng, [3000])
    taus = [60.0, 600.0]
    whole = lag_deficit(u, t, None, taus)
    head = lag_deficit(u[:cut], t[:cut], None, taus)
    state = LagState(time=t[cut - 1], value=u[cut - 1], deficit=head[-1])
    tail = lag_deficit(u[cut:], t[cut:], None, taus, initial=state)
    _assert_close_to_scale(
        np.concatenate([head, tail]).reshape(3000, -1), whole.reshape(3000, -1), 1e-12
    )
    assert_array_equal(head, whole[:cut])  # causal: a prefix is the prefix
    # A chunk that starts with a new run ignores the state.
    new_run = np.zeros(3000 - cut, dtype=bool)
    new_run[0] = True
    restarted = lag_deficit(u[cut:], t[cut:], new_run, taus, initial=state)
    assert_array_equal(restarted, lag_deficit(u[cut:], t[cut:], None, taus))


def test_interleaved_runs_follow_group_rows_by_run():
    rng = np.random.default_rng(6)
    lengths = [300, 1, 500, 70]
    u, t, _ = _irregular_runs(rng, lengths)
    run = np.repeat(np.array(["d", "a", "c", "b"]), lengths)
    shuffled = np.concatenate([np.flatnonzero(run == r) for r in "dacb"])
    # Interleave the runs at random while keeping each run's rows in time order.
    labels = rng.permutation(run)
    position = {r: iter(np.flatnonzero(run == r)) for r in "abcd"}
    interleaved = np.array([next(position[label]) for label in labels])
    order, grouped_starts = group_rows_by_run(run[interleaved])
    rows = interleaved[order]
    lags = np.empty((u.shape[0], 2, 2))
    lags[order] = lag_deficit(u[rows], t[rows], grouped_starts, [120.0, 900.0])
    for r in "abcd":
        alone = lag_deficit(u[run == r], t[run == r], None, [120.0, 900.0])
        mine = lags[run[interleaved] == r]
        _assert_close_to_scale(mine.reshape(len(mine), -1), alone.reshape(len(alone), -1), 1e-12)
    assert shuffled.size == u.shape[0]


# ---------------------------------------------------------------------------------------------
# Sampling invariance: the same physical signal sampled at 10 s and at 60 s.
# ---------------------------------------------------------------------------------------------

HOUSING_TAU = 1800.0  # s, the chamber air to the sensed temperature
RESOLUTION = 0.01  # degC, the sensor's quantisation step
# Chamber program: (duration in s, setpoint ramp in degC/min), from 20 degC; -10 to 40 degC.
PROGRAM = [
    (3600, 0.0),
    (1200, 1.0),
    (7200, 0.0),
    (6000, -0.5),
    (7200, 0.0),
    (1050, 2.0),
    (3600, 0.0),
    (3000, 0.1),
    (7200, 0.0),
    (2400, -0.25),
    (3600, 0.0),
]


def _chamber():
    """Sensed temperature (closed form) and a bound on its second derivative."""
    kinks = np.cumsum([0] + [d for d, _ in PROGRAM])[:-1].astype(float)
    change = np.diff(np.r_[0.0, [r / 60.0 for _, r in PROGRAM]])  # degC/s at each kink
    end = kinks[-1] + PROGRAM[-1][0]

    def temperature(t):
        s = np.maximum(t[:, None] - kinks, 0.0)
        return 20.0 + (change * (s + HOUSING_TAU * np.expm1(-s / HOUSING_TAU))).sum(axis=1)

    # u'' = sum_k change_k exp(-(t - t_k) / tau) / tau after each kink: largest at a kink.
    s = kinks[:, None] - kinks[None, :]
    curvature = (change * np.where(s >= 0, np.exp(-np.maximum(s, 0) / HOUSING_TAU), 0)).sum(1)
    return temperature, end, np.abs(curvature).max() / HOUSING_TAU


def _sampled(temperature, end, step):
    t = np.arange(0.0, end + 1.0, step)
    return t, np.round(temperature(t) / RESOLUTION) * RESOLUTION


def test_sampling_invariance():
    temperature, end, curvature = _chamber()
    t10, u10 = _sampled(temperature, end, 10.0)
    t60, u60 = _sampled(temperature, end, 60.0)
    assert -10.0 <= u10.min() < -9.5
    assert 39.5 < u10.max() <= 40.0
    coincident = slice(None, None, 6)
    assert_array_equal(t10[coincident], t60)
    # Bound at coincident times, where both sample sets hold the same value u:
    # - quantisation: each lag is u's lag plus the lag of an error within +-q/2 (a filter of
    #   unit gain and positive kernel), so the two differ by at most q;
    # - interpolation: a linear hold of step h misses u by at most h^2/8 max|u''| between
    #   samples, and the lag passes at most that through.
    # Deficits u - lag share u, so the same bound holds for them; the rate is deficit / tau.
    bound = RESOLUTION + (10.0**2 + 60.0**2) / 8 * curvature
    assert bound < 2 * RESOLUTION  # the bound is set by the resolution on this profile
    taus = np.array([300.0, 900.0, 3600.0])
    linear = {}
    for hold in HOLDS:
        d10 = lag_deficit(u10, t10, None, taus, hold=hold)[coincident]
        d60 = lag_deficit(u60, t60, None, taus, hold=hold)
        linear[hold] = np.abs(d10 - d60).max(axis=0)
        lag10 = first_order_lag(u10, t10, None, taus, hold=hold)[coincident]
        lag60 = first_order_lag(u60, t60, None, taus, hold=hold)
        assert_allclose(np.abs(lag10 - lag60).max(axis=0), linear[hold], rtol=1e-6)
    # Measured (deficits, degC): linear 0.0035, 0.0020, 0.0007; previous and current
    # 0.14-0.32: a hold shifts the input by half a step.
    assert np.all(linear["linear"] <= bound)
    for hold in ("previous", "current"):
        assert np.all(linear[hold] > 20 * linear["linear"])
        assert np.all(linear[hold] > bound)

    for tau in (60.0, 300.0):
        rate10 = smoothed_rate(u10, t10, None, tau)[coincident]
        rate60 = smoothed_rate(u60, t60, None, tau)
        exact = np.abs(rate10 - rate60).max()
        assert exact <= bound / tau * 60.0  # degC/min
        # Finite differences of the same lags (what differencing smoothed values gives): the
        # derivative over the last step, late by half a step.
        lag10 = first_order_lag(u10, t10, None, tau)
        lag60 = first_order_lag(u60, t60, None, tau)
        difference = np.abs(
            causal_rate(lag10, None, t10, 60.0)[coincident] - causal_rate(lag60, None, t60, 60.0)
        ).max()
        # Measured: exact 0.0056 and 0.0007 degC/min, differences 0.025 and 0.020.
        assert difference > 4 * exact


# ---------------------------------------------------------------------------------------------
# Lead estimate.
# ---------------------------------------------------------------------------------------------


def test_lead_estimate_undoes_a_sensor_lag_on_ramps():
    t = np.arange(0.0, 4 * 3600.0, 10.0)
    coil = 20.0 + np.minimum(t, 7200.0) / 60.0 * 0.5  # 0.5 degC/min, then a soak
    sensor = first_order_lag(coil, t, None, 120.0)
    lead = lead_estimate(sensor, t, None, 120.0, smoothing=60.0)
    # After 20 sensor time constants (the transients decay as exp(-t / 120 s)).
    ramp = (t > 2400.0) & (t < 7200.0)
    soak = t > 7200.0 + 2400.0
    assert np.abs(sensor - coil)[ramp].min() > 0.99  # the sensor lags tau_s * rate = 1 degC
    assert_allclose(lead[ramp], coil[ramp], rtol=0, atol=1e-8)
    assert_allclose(lead[soak], coil[soak], rtol=0, atol=1e-8)
    assert_array_equal(lead_estimate(sensor, t, None, 0.0), sensor)


# ---------------------------------------------------------------------------------------------
# Shapes and errors.
# ---------------------------------------------------------------------------------------------


def test_shapes():
    t = np.arange(5.0)
    u = np.arange(10.0).reshape(5, 2)
    assert lag_deficit(u[:, 0], t, None, 1.0).shape == (5,)
    assert lag_deficit(u[:, 0], t, None, [1.0]).shape == (5, 1)
    assert lag_deficit(u, t, None, 1.0).shape == (5, 2)
    assert first_order_lag(u, t, None, [1.0, 2.0, 3.0]).shape == (5, 2, 3)
    assert smoothed_rate(u, t, None, [1.0, 2.0]).shape == (5, 2, 2)
    assert lag_deficit(np.empty(0), np.empty(0), None, [1.0]).shape == (0, 1)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"time_constants": 0.0}, "time_constants must be finite and > 0"),
        ({"time_constants": [60.0, -1.0]}, "time_constants must be finite and > 0"),
        ({"time_constants": [np.inf]}, "time_constants must be finite and > 0"),
        ({"time_constants": [np.nan]}, "time_constants must be finite and > 0"),
        ({"time_constants": []}, "time_constants is empty"),
        ({"time_constants": [[1.0]]}, "time_constants must be a number or a 1-D"),
        ({"time": [0.0, 1.0, 1.0, 2.0]}, "row 2 has time 1.0, not after 1.0 at row 1"),
        ({"time": [0.0, 1.0, np.nan, 2.0]}, "time must be finite; row 2"),
        ({"time": [0.0, 1.0, 2.0]}, "time must have shape (4,)"),
        ({"values": [1.0, 2.0, np.inf, 3.0]}, "values must be finite; row 2"),
        ({"values": np.ones((4, 1, 1))}, "values must have shape (n_samples,)"),
        ({"run_starts": [True, False]}, "run_starts must be a boolean array of shape (4,)"),
        ({"run_starts": [1, 0, 0, 0]}, "run_starts must be a boolean array"),
        ({"hold": "cubic"}, "hold must be one of"),
        (
            {"initial": LagState(0.0, np.zeros(2), np.zeros((1, 1)))},
            "initial.value must have shape (1,)",
        ),
        (
            {"initial": LagState(5.0, np.zeros(1), np.zeros((1, 1)))},
            "row 0 has time 0.0, not after 5.0 of the initial state",
        ),
        ({"initial": (0.0, 1.0, 0.0)}, "initial must be a LagState"),
    ],
)
def test_errors_name_the_parameter(kwargs, message):
    arguments = {
        "values": [20.0, 21.0, 22.0, 23.0],
        "time": [0.0, 1.0, 2.0, 3.0],
        "run_starts": None,
        "time_constants": 60.0,
        **kwargs,
    }
    error = TypeError if message.startswith("initial must") else ValueError
    with pytest.raises(error, match=re.escape(message)):
        lag_deficit(**arguments)


def test_time_may_restart_at_a_new_run_only():
    u = [20.0, 21.0, 22.0, 23.0]
    t = [0.0, 60.0, 0.0, 60.0]
    starts = np.array([True, False, True, False])
    assert_allclose(lag_deficit(u, t, starts, 60.0)[[0, 2]], 0.0)
    with pytest.raises(ValueError, match=re.escape("row 2 has time 0.0, not after 60.0 at row 1")):
        lag_deficit(u, t, None, 60.0)


def test_rate_and_lead_errors():
    with pytest.raises(ValueError, match="time_constant must be finite and > 0"):
        smoothed_rate([1.0, 2.0], [0.0, 1.0], None, -5.0)
    with pytest.raises(ValueError, match="seconds_per_unit must be finite and > 0"):
        smoothed_rate([1.0, 2.0], [0.0, 1.0], None, 5.0, seconds_per_unit=0.0)
    with pytest.raises(ValueError, match="sensor_lag must be finite and >= 0"):
        lead_estimate([1.0, 2.0], [0.0, 1.0], None, -1.0)
    with pytest.raises(ValueError, match="smoothing must be finite and > 0"):
        lead_estimate([1.0, 2.0], [0.0, 1.0], None, 1.0, smoothing=0.0)
    with pytest.raises(ValueError, match="smoothing must be one time constant"):
        lead_estimate([1.0, 2.0], [0.0, 1.0], None, 1.0, smoothing=[1.0, 2.0])
