"""Behaviour of the lag wrappers that mutation testing found unguarded (issue 42, point 5).

:func:`~sklearn_ifog._lags.first_order_lag`, :func:`~sklearn_ifog._lags.smoothed_rate` and
:func:`~sklearn_ifog._lags.lead_estimate` are built on
:func:`~sklearn_ifog._lags.lag_deficit`; ``tools/mutation.sh lags`` found that dropping
their ``run_starts``, ``hold`` or ``initial`` on the way, or changing their default time
constants, failed no test. Each test here kills those mutants.
"""

import numpy as np
import pytest

from sklearn_ifog._lags import (
    LagState,
    first_order_lag,
    lag_deficit,
    lag_step,
    lead_estimate,
    smoothed_rate,
)


@pytest.fixture
def two_runs():
    """Two runs of irregular steps (a ramp then a step), the second starting warm."""
    time = np.array([0.0, 30.0, 90.0, 100.0, 400.0, 0.0, 45.0, 60.0, 300.0])
    values = np.array([20.0, 20.5, 22.0, 22.0, 25.0, 30.0, 29.0, 31.0, 31.0])
    starts = np.array([True, False, False, False, False, True, False, False, False])
    return time, values, starts


def _state(time=-60.0, value=18.0, deficit=(-1.5,)):
    return LagState(time, np.array([value]), np.array([deficit]))


@pytest.mark.parametrize("hold", ["linear", "previous", "current"])
def test_wrappers_forward_runs_hold_and_initial_state(two_runs, hold):
    """Each wrapper is its formula on :func:`lag_deficit` called with the same
    ``run_starts``, ``hold`` and ``initial``; each of them changes the result."""
    time, values, starts = two_runs
    tau = 120.0
    starts_then = starts.copy()
    starts_then[0] = False  # row 0 continues the state given
    initial = _state()
    kw = dict(hold=hold, initial=initial)
    deficit = lag_deficit(values, time, starts_then, tau, **kw)
    np.testing.assert_allclose(
        first_order_lag(values, time, starts_then, tau, **kw), values - deficit, rtol=1e-15
    )
    np.testing.assert_allclose(
        smoothed_rate(values, time, starts_then, tau, **kw), deficit / tau * 60.0, rtol=1e-15
    )
    lead = lead_estimate(values, time, starts_then, 30.0, smoothing=tau, **kw)
    np.testing.assert_allclose(lead, values + 30.0 * deficit / tau, rtol=1e-15)
    # None of the three is indifferent to what it forwards.
    one_run = lag_deficit(values[:5], time[:5], None, tau, hold=hold, initial=initial)
    assert not np.allclose(one_run, lag_deficit(values[:5], time[:5], None, tau, hold=hold))
    both = lag_deficit(values, time, starts, tau, hold=hold)
    assert both[5] == 0.0  # the second run starts at rest
    for wrapper, args in [
        (first_order_lag, (tau,)),
        (smoothed_rate, (tau,)),
        (lead_estimate, (30.0,)),
    ]:
        kwargs = {"smoothing": tau} if wrapper is lead_estimate else {}
        with_runs = wrapper(values, time, starts, *args, hold=hold, **kwargs)
        # The first row of the second run is at rest: lag = value, rate 0, lead = value.
        expected = 0.0 if wrapper is smoothed_rate else values[5]
        assert with_runs[5] == expected, wrapper.__name__
        continued = wrapper(
            values[:5], time[:5], None, *args, hold=hold, initial=initial, **kwargs
        )
        fresh = wrapper(values[:5], time[:5], None, *args, hold=hold, **kwargs)
        assert not np.allclose(continued, fresh), wrapper.__name__


def test_hold_reaches_the_deficit_through_every_wrapper(two_runs):
    """The three holds differ on irregular steps, through each wrapper and through
    :func:`lag_step` (kills the mutants that dropped ``hold=hold``)."""
    time, values, _ = two_runs
    time, values = time[:5], values[:5]
    for wrapper, kwargs in [
        (first_order_lag, {"time_constants": 120.0}),
        (smoothed_rate, {"time_constant": 120.0}),
        (lead_estimate, {"sensor_lag": 30.0, "smoothing": 120.0}),
    ]:
        results = [wrapper(values, time, **kwargs, hold=hold) for hold in ("linear", "previous")]
        assert not np.allclose(*results), wrapper.__name__
    deficit = lag_deficit(values, time, None, 120.0, hold="current")
    step = lag_step(deficit[1], values[1], values[2], time[2] - time[1], 120.0, hold="current")
    assert step == pytest.approx(deficit[2], rel=1e-12)
    linear = lag_step(deficit[1], values[1], values[2], time[2] - time[1], 120.0)
    assert linear != pytest.approx(deficit[2], rel=1e-6)


def test_default_time_constants():
    """The documented defaults: 600 s for :func:`first_order_lag`, 60 s (and degrees per
    minute) for :func:`smoothed_rate`, a 60 s sensor lag smoothed over 60 s for
    :func:`lead_estimate` (kills 601, 61 and 61)."""
    time = np.array([0.0, 60.0, 300.0, 900.0])
    values = np.array([20.0, 21.0, 25.0, 25.0])
    np.testing.assert_array_equal(
        first_order_lag(values, time), first_order_lag(values, time, None, 600.0)
    )
    np.testing.assert_array_equal(
        smoothed_rate(values, time),
        smoothed_rate(values, time, None, 60.0, seconds_per_unit=60.0),
    )
    np.testing.assert_array_equal(
        lead_estimate(values, time), lead_estimate(values, time, None, 60.0, smoothing=60.0)
    )
    # And they are not those of a second longer.
    assert not np.array_equal(
        first_order_lag(values, time), first_order_lag(values, time, None, 601.0)
    )
    assert not np.array_equal(smoothed_rate(values, time), smoothed_rate(values, time, None, 61.0))
    assert not np.array_equal(lead_estimate(values, time), lead_estimate(values, time, None, 61.0))
    assert not np.array_equal(
        lead_estimate(values, time), lead_estimate(values, time, None, 60.0, smoothing=61.0)
    )


def test_lag_deficit_defaults_and_the_first_row():
    """:func:`lag_deficit`'s default time constant is 600 s (kills 601); without ``initial``
    row 0 starts a run even where ``run_starts[0]`` is False, with it row 0 continues the
    state."""
    time = np.array([0.0, 60.0, 300.0, 900.0])
    values = np.array([20.0, 21.0, 25.0, 25.0])
    np.testing.assert_array_equal(
        lag_deficit(values, time), lag_deficit(values, time, None, 600.0)
    )
    assert not np.array_equal(lag_deficit(values, time), lag_deficit(values, time, None, 601.0))
    starts = np.array([False, False, True, False])
    expected = lag_deficit(values, time[[0, 1, 0, 1]] + [0, 0, 0, 600], np.r_[True, starts[1:]])
    got = lag_deficit(values, time[[0, 1, 0, 1]] + [0, 0, 0, 600], starts)
    np.testing.assert_array_equal(got, expected)
    assert got[0] == 0.0
    assert got[2] == 0.0
    # With ``initial``, a first row that does not start a run continues the state, whether
    # ``run_starts`` is given or not (kills ``initial is not None`` in that branch).
    state = LagState(-60.0, np.array([18.0]), np.array([[-1.5]]))
    given = lag_deficit(values, time, np.zeros(4, dtype=bool), 600.0, initial=state)
    np.testing.assert_array_equal(given, lag_deficit(values, time, None, 600.0, initial=state))
    assert given[0] != 0.0


def test_bad_values_and_initial_state_are_named():
    """A non-finite value of a 2-column input names its row (kills ``reshape(n, +1)`` and
    ``reshape(n, -2)``); a wrong ``initial`` names its type (kills ``type(None)``)."""
    time = np.array([0.0, 60.0, 120.0])
    values = np.array([[20.0, 1.0], [21.0, 1.0], [22.0, np.nan]])
    with pytest.raises(ValueError, match=r"values must be finite; row 2 holds NaN or inf"):
        lag_deficit(values, time)
    with pytest.raises(TypeError, match=r"initial must be a LagState or None, got tuple"):
        lag_deficit(values[:, 0], time, initial=(0.0, 20.0, 0.0))
