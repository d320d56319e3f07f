"""Behaviour of the calibration domain that mutation testing found unguarded (issue 42, point 5).

Each test here kills mutants of :mod:`sklearn_ifog.domain` that survived the domain's other
tests (``tools/mutation.sh domain``); the docstrings say which.
"""

import re
import warnings

import numpy as np
import pytest

from sklearn_ifog.domain import CalibrationDomain
from sklearn_ifog.fallback import Fallback, fallback_name, fit_fallback
from sklearn_ifog.policy import BlendWithFallback, fallback_weight


def _heating_runs(rng, n_runs=4, n_rows=150):
    """Runs that soak at 10 degC then ramp to 40 at a rate drawn per run (degC/min)."""
    t, rate, runs = [], [], []
    for run in range(n_runs):
        soak = n_rows // 3
        t.append(np.r_[np.full(soak, 10.0), np.linspace(10.0, 40.0, n_rows - soak)])
        rate.append(np.r_[np.zeros(soak), np.full(n_rows - soak, rng.uniform(0.3, 1.0))])
        runs.append(np.full(n_rows, run))
    return np.concatenate(t), np.concatenate(rate), np.concatenate(runs)


def test_plane_fallback_is_held_flat_above_the_warm_end_it_did_not_extrapolate():
    """The warm mirror of ``test_plane_fallback_is_held_flat_beyond_the_end_it_did_not_
    extrapolate``: drift that bends down above 34 degC, so the plane does not carry to the
    warm extreme and is held at its value at ``high`` above it, while it goes on below
    ``low``. Kills ``hold_above=None`` (and ``~carries[1]`` read as ``carries[1]`` or
    ``~carries[0]``) in :func:`fit_fallback`. Holds on seeds 0-49 (checked once); the test
    runs 0-19."""
    for seed in range(20):
        rng = np.random.default_rng(seed)
        t, rate, runs = _heating_runs(rng)
        y = 0.05 * t + 0.8 * rate - 0.05 * np.maximum(t - 34.0, 0.0) ** 2
        y += rng.normal(scale=0.02, size=t.size)
        plane = fit_fallback(t, y[:, None], 0, rate=rate, rate_column=1, runs=runs)
        assert fallback_name(plane) == "plane", seed
        assert plane.hold_above.tolist() == [True], seed
        assert plane.hold_below.tolist() == [False], seed
        rows = np.array([[0.0, 0.0], [5.0, 0.0], [40.0, 0.0], [50.0, 0.0], [70.0, 0.0]])
        predicted = plane.predict(rows)[:, 0]
        # Flat above 40 degC, at the line's value there ...
        np.testing.assert_allclose(predicted[3:], predicted[2], rtol=1e-12, err_msg=str(seed))
        expected = plane.intercept[0] + 40.0 * plane.slope[0]
        assert predicted[2] == pytest.approx(expected, abs=1e-12), seed
        # ... and the line goes on below 10 degC.
        assert predicted[1] - predicted[0] == pytest.approx(5.0 * plane.slope[0]), seed
        assert plane.slope[0] > 0.0, seed


def _smoothstep(s):
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def test_the_blend_takes_over_within_one_standard_deviation_beyond_the_threshold():
    """The blend's default width is 1: half-way (0.5 beyond the threshold) the blend is the
    mean of the model and its fallback, from 1 beyond on it is the fallback alone. The
    domain's other tests read the width from ``BlendWithFallback().width`` itself, so a
    default width of 10 passed them; this one kills it (and every change of the default)."""
    margin = 1.5
    distance = margin + np.array([0.0, 0.25, 0.5, 0.75, 1.0, 3.0])
    np.testing.assert_allclose(
        fallback_weight(distance, margin), [0.0, 0.15625, 0.5, 0.84375, 1.0, 1.0], atol=1e-15
    )
    # Through the policy, on a domain of one feature (10-40 degC, sd of the 31 rows).
    t = np.linspace(10.0, 40.0, 31)
    domain = CalibrationDomain(margin=margin, temperature=0).fit(t[:, None])
    assert domain.threshold_ == margin
    beyond = np.array([0.0, 0.5, 1.0, 2.0])
    rows = 40.0 + (margin + beyond)[:, None] * t.std()
    distance = domain.distance(rows)
    np.testing.assert_allclose(distance, margin + beyond, rtol=1e-12)
    fallback = Fallback(np.array([1.0]), np.array([0.0]), 0)
    blended = BlendWithFallback().apply(
        np.full((4, 1), 7.0),
        rows,
        distance,
        domain.predict(rows) == -1,
        domain=domain,
        fallback=fallback,
    )
    weight = _smoothstep(beyond)
    np.testing.assert_allclose(blended[:, 0], 7.0 * (1 - weight) + weight, rtol=1e-12)
    np.testing.assert_allclose(blended[1:, 0], [4.0, 1.0, 1.0], rtol=1e-12)
    assert blended[0, 0] == 7.0  # at the threshold itself: the model


def test_the_blend_width_argument_stretches_the_ramp():
    """Kills ``(distance - margin) * width`` (the same as ``/`` at the default width 1)."""
    weight = fallback_weight([2.0, 2.5, 3.0, 3.5], margin=1.5, width=2.0)
    np.testing.assert_allclose(weight, _smoothstep(np.array([0.25, 0.5, 0.75, 1.0])))


def _calibration(n_runs=3, n_rows=60, seed=0):
    """Rows of T (10-40 degC) and a rate (0.1-0.3) from ``n_runs`` runs."""
    rng = np.random.default_rng(seed)
    n = n_runs * n_rows
    X = np.column_stack([rng.uniform(10.0, 40.0, n), rng.uniform(0.1, 0.3, n)])
    return X, np.repeat(np.arange(n_runs), n_rows)


def test_extend_only_widens_and_moves_the_boost_and_offset_with_the_threshold():
    """Kills the mutants of :meth:`CalibrationDomain.extend` (only one handover test reached
    it, through its temperature-low branch)."""
    X, groups = _calibration()
    domain = CalibrationDomain(temperature=0, rate=1).fit(X, groups=groups)
    threshold, margin = domain.threshold_, domain.margin
    rate_low, rate_high = domain.rate_low_.copy(), domain.rate_high_.copy()
    boost_low, boost_high = domain.boost_low_.copy(), domain.boost_high_.copy()
    # Nothing narrows: a lower threshold and ranges inside the calibrated ones change nothing.
    domain.extend(
        threshold=threshold - 0.5,
        rate_low=rate_low + 0.05,
        rate_high=rate_high - 0.05,
        temperature_low=boost_low + 5.0,
        temperature_high=boost_high - 5.0,
    )
    assert (domain.threshold_, domain.offset_) == (threshold, -threshold)
    for now, before in [
        (domain.rate_low_, rate_low),
        (domain.rate_high_, rate_high),
        (domain.boost_low_, boost_low),
        (domain.boost_high_, boost_high),
    ]:
        np.testing.assert_array_equal(now, before)
    # Widening: every range moves out to what it is given, the boost and offset follow.
    domain.extend(threshold=threshold + 1.0)
    assert domain.threshold_ == threshold + 1.0
    assert domain.boost_ == pytest.approx(threshold + 1.0 - margin)
    assert domain.offset_ == -(threshold + 1.0)
    domain.extend(rate_low=[0.05], rate_high=[0.45], temperature_low=[0.0])
    domain.extend(temperature_high=[50.0])
    np.testing.assert_array_equal(domain.rate_low_, [0.05])
    np.testing.assert_array_equal(domain.rate_high_, [0.45])
    np.testing.assert_array_equal(domain.boost_low_, [0.0])
    np.testing.assert_array_equal(domain.boost_high_, [50.0])
    # The widened rates are inside now; a temperature beyond the calibration is still out
    # (the firmware rule), scored below every row inside.
    rows = np.array([[25.0, 0.4], [25.0, 0.07], [25.0, 0.6], [45.0, 0.2]])
    assert domain.predict(rows).tolist() == [1, 1, -1, -1]
    np.testing.assert_allclose(
        domain.decision_function(rows), domain.score_samples(rows) + domain.threshold_
    )


def test_extend_without_both_temperature_and_rate_columns_changes_nothing():
    """Kills ``temperature_columns_ or rate_columns_`` in :meth:`CalibrationDomain.extend`."""
    X, groups = _calibration()
    for params in ({"temperature": 0}, {"rate": 1}, {}):
        domain = CalibrationDomain(**params).fit(X, groups=groups)
        before = (domain.threshold_, domain.boost_, domain.offset_)
        assert domain.extend(threshold=9.0, rate_high=[9.0], temperature_high=[99.0]) is domain
        assert (domain.threshold_, domain.boost_, domain.offset_) == before == (1.5, 0.0, -1.5)
        np.testing.assert_array_equal(domain.boost_high_, X[:, domain.temperature_columns_].max(0))
        np.testing.assert_array_equal(domain.rate_high_, X[:, domain.rate_columns_].max(axis=0))


def test_decision_function_is_negative_exactly_outside():
    """scikit-learn's outlier convention: ``decision_function = score_samples - offset_``,
    below 0 where :meth:`~CalibrationDomain.predict` gives -1. Kills ``+ offset_``."""
    X, groups = _calibration()
    domain = CalibrationDomain(temperature=0, rate=1).fit(X, groups=groups)
    rows = np.array([[25.0, 0.2], [10.0, 0.1], [25.0, 0.35], [25.0, 0.9], [41.0, 0.2]])
    decision = domain.decision_function(rows)
    np.testing.assert_allclose(decision, domain.score_samples(rows) + domain.threshold_)
    np.testing.assert_array_equal(decision < 0, domain.predict(rows) == -1)
    assert decision[0] == domain.threshold_  # a calibration-like row: distance 0


def test_score_samples_beyond_the_calibrated_temperatures():
    """Inside the temperatures the score is minus the distance (0 for the calibration's own
    rows); beyond them it is ``-(threshold_ + excess / sd)`` while the distance is smaller.
    Kills ``beyond >= 0`` and ``beyond * scale``."""
    t = np.linspace(10.0, 40.0, 31)
    domain = CalibrationDomain(margin=1.5, temperature=0).fit(t[:, None])
    np.testing.assert_array_equal(domain.score_samples(t[:, None]), np.zeros(t.size))
    rows = np.array([[40.5], [9.0]])  # beyond T, within the margin of the box
    assert domain.distance(rows).max() < domain.threshold_
    expected = -(domain.threshold_ + np.array([0.5, 1.0]) / t.std())
    np.testing.assert_allclose(domain.score_samples(rows), expected, rtol=1e-12)


def test_project_without_temperature_columns_is_the_widened_box():
    """:meth:`CalibrationDomain.project` of a domain without ``temperature`` columns: rows
    within ``threshold_`` stay, rows farther out land at distance ``threshold_`` (kills the
    mutants of its first branch, which no test reached)."""
    X, _ = _calibration()
    domain = CalibrationDomain(margin=0.5).fit(X)
    rows = np.array([[25.0, 0.2], [60.0, 0.2], [25.0, 0.6], [-10.0, 0.0]])
    assert domain.distance(rows).tolist()[0] == 0.0
    assert domain.distance(rows[1:]).min() > 0.5
    projected = domain.project(rows)
    np.testing.assert_array_equal(projected[0], rows[0])
    np.testing.assert_allclose(domain.distance(projected[1:]), 0.5, rtol=1e-9)
    # One feature: a clamp to [min - 0.5 sd, max + 0.5 sd].
    t = np.linspace(10.0, 40.0, 31)
    one = CalibrationDomain(margin=0.5).fit(t[:, None])
    clamped = one.project(np.array([[60.0], [0.0], [20.0]])).ravel()
    np.testing.assert_allclose(clamped, [40.0 + 0.5 * t.std(), 10.0 - 0.5 * t.std(), 20.0])


def test_project_clamps_every_temperature_into_its_range_on_both_sides():
    """Kills ``np.clip(..., low, None)``: a row warmer than the calibration is clamped to
    its warmest temperature, as a colder one to its coldest."""
    X, groups = _calibration()
    domain = CalibrationDomain(temperature=0, rate=1).fit(X, groups=groups)
    rows = np.array([[60.0, 0.2], [-20.0, 0.2], [25.0, 0.2]])
    projected = domain.project(rows)
    assert projected[:, 0].tolist() == [X[:, 0].max(), X[:, 0].min(), 25.0]
    assert domain.predict(projected).tolist() == [1, 1, 1]


def test_integer_rows_are_projected_as_floats():
    """A row given as integers is not truncated: kills ``dtype=None`` in
    :func:`~sklearn_ifog.domain.project_to_box` and :meth:`CalibrationDomain.project`."""
    from sklearn_ifog.domain import fit_box, project_to_box

    box = fit_box(np.linspace(0.0, 10.0, 11)[:, None])
    sd = np.linspace(0.0, 10.0, 11).std()
    projected = project_to_box(box, [[40], [-40], [5]], 0.5)
    np.testing.assert_allclose(projected.ravel(), [10 + 0.5 * sd, -0.5 * sd, 5.0])
    t = np.linspace(10.0, 40.0, 31)
    domain = CalibrationDomain(margin=0.5).fit(np.column_stack([t, np.sin(t)]))
    integer = domain.project(np.array([[60, 0], [25, 0]]))
    assert integer.dtype == np.float64
    np.testing.assert_allclose(integer, domain.project(np.array([[60.0, 0.0], [25.0, 0.0]])))


def test_fallback_name_of_a_line_and_of_a_zero_rate_term():
    """Kills the mutants of :func:`~sklearn_ifog.fallback.fallback_name` (only its doctest
    named a line)."""
    line = Fallback(np.array([1.0]), np.array([0.5]), 0)
    assert fallback_name(line) == "line"
    assert fallback_name(line._replace(rate_slope=np.array([0.0]), rate_column=1)) == "line"
    assert fallback_name(line._replace(rate_slope=np.array([1.0]), rate_column=1)) == "plane"
    flat = Fallback(np.array([1.0, 2.0]), np.array([0.0, 0.0]), 0, rate_slope=np.zeros(2))
    assert fallback_name(flat) == "constant"
    # A rate slope without a rate column (or a column without a slope) adds no rate term.
    rows = np.array([[10.0, 3.0], [20.0, -3.0]])
    assert flat.predict(rows).tolist() == [[1.0, 2.0], [1.0, 2.0]]
    assert flat._replace(rate_slope=None, rate_column=1).predict(rows).tolist() == [
        [1.0, 2.0],
        [1.0, 2.0],
    ]


def test_plane_of_a_constant_rate_is_the_line_and_fits_each_output():
    """:func:`~sklearn_ifog.fallback._plane`: a rate that does not vary gets a rate slope of
    0 and the plane is the line in T; two outputs get their own intercepts. Kills the
    mutants of its zero-scale guard and ``Y.mean(axis=None)`` in its intercept."""
    from sklearn_ifog.fallback import _line, _plane

    t = np.linspace(10.0, 40.0, 50)
    Y = np.column_stack([1.0 + 0.5 * t, -3.0 + 0.1 * t + np.sin(t)])
    intercept, slope, rate_slope = _plane(t, np.full(t.size, 0.25), Y)
    line_intercept, line_slope = _line(t, Y)
    np.testing.assert_array_equal(rate_slope, [0.0, 0.0])
    np.testing.assert_allclose(slope, line_slope, rtol=1e-10)
    np.testing.assert_allclose(intercept, line_intercept, rtol=1e-10)
    assert intercept[0] == pytest.approx(1.0)
    assert slope[0] == pytest.approx(0.5)
    # With a rate that varies: the exact plane of each output.
    rate = np.cos(t)
    Y = np.column_stack([1.0 + 0.5 * t + 2.0 * rate, -3.0 + 0.1 * t - rate])
    intercept, slope, rate_slope = _plane(t, rate, Y)
    np.testing.assert_allclose(intercept, [1.0, -3.0], atol=1e-10)
    np.testing.assert_allclose(slope, [0.5, 0.1], atol=1e-12)
    np.testing.assert_allclose(rate_slope, [2.0, -1.0], atol=1e-10)


def test_line_of_a_small_temperature_spread_and_of_one_temperature():
    """:func:`~sklearn_ifog.fallback._line`: a spread of millikelvin still has its slope (kills
    ``denominator > 1``); a single temperature has slope 0, not NaN (kills the mutants of
    that guard: ``>= 0``, ``or True``, ``0 / Y[0]``, ``1 * Y[0]``)."""
    from sklearn_ifog.fallback import _line

    t = np.linspace(0.0, 0.01, 5)
    intercept, slope = _line(t, np.column_stack([2.0 + 3.0 * t, -t]))
    np.testing.assert_allclose(slope, [3.0, -1.0], rtol=1e-9)
    np.testing.assert_allclose(intercept, [2.0, 0.0], atol=1e-12)
    intercept, slope = _line(
        np.full(4, 25.0), np.array([[1.0, 5.0], [2.0, 5.0], [3.0, 5.0], [2.0, 5.0]])
    )
    assert slope.tolist() == [0.0, 0.0]
    assert intercept.tolist() == [2.0, 5.0]


def test_a_calibration_mostly_at_one_soak_keeps_a_finite_fallback():
    """80 % of the rows at one soak temperature, 20 % at another: holding out the warm end
    (every row within a fifth of the span of it: the 20 warm rows) leaves one temperature,
    where the line is the constant (slope 0, no NaN)."""
    from sklearn_ifog.fallback import extremes_held_out

    t = np.r_[np.full(80, 10.0), np.full(20, 30.0)]
    y = np.r_[np.linspace(0.0, 1.0, 80), np.linspace(5.0, 6.0, 20)][:, None]
    losses = extremes_held_out(t, y)
    assert all(np.all(np.isfinite(end)) for end in losses)
    # Warm end: the line fitted on the 80 soak rows is their mean, like the constant.
    np.testing.assert_array_equal(losses[1][1], losses[1][0])
    np.testing.assert_allclose(losses[1][0][:, 0], np.square(y[80:, 0] - 0.5))
    fallback = fit_fallback(t, y, column=0)
    assert np.all(np.isfinite(fallback.predict(np.array([[0.0], [20.0], [50.0]]))))


def test_extremes_held_out_sizes_ties_and_rate():
    """:func:`~sklearn_ifog.fallback.extremes_held_out`: 48 rows hold out at least 10 at
    each end, 47 rows are too few (kills ``n_held <= 10``); a temperature span of exactly 1
    degree is a span (kills ``ptp == 1``), a single temperature is not; each end holds out
    every row within a fifth of the span of its extreme, ties included, and the models are
    fitted on the other rows; with ``rate`` the model is the plane in T and dT (kills
    ``rate = None``)."""
    from sklearn_ifog.fallback import extremes_held_out

    line = lambda t: (2.0 * t)[:, None]  # noqa: E731
    shapes = [
        end.shape
        for end in extremes_held_out(np.linspace(0.0, 1.0, 48), line(np.linspace(0.0, 1.0, 48)))
    ]
    assert shapes == [(2, 10, 1), (2, 10, 1)]
    assert extremes_held_out(np.linspace(0.0, 30.0, 47), line(np.linspace(0.0, 30.0, 47))) is None
    assert extremes_held_out(np.full(100, 20.0), np.arange(100.0)[:, None]) is None
    # A soak of 40 rows at 10 degC, then a ramp to 40: the cold end holds out the whole soak
    # and the ramp up to 16 degC (a fifth of the 30-degree span), the warm end the ramp from
    # 34 degC; each time the constant is the mean of the other rows.
    t = np.r_[np.full(40, 10.0), np.linspace(10.5, 40.0, 60)]
    y = np.arange(100.0)[:, None]
    cold, warm = extremes_held_out(t, y)
    below, above = t <= 16.0, t >= 34.0
    np.testing.assert_allclose(cold[0][:, 0], np.square(y[below, 0] - y[~below, 0].mean()))
    np.testing.assert_allclose(warm[0][:, 0], np.square(y[above, 0] - y[~above, 0].mean()))
    assert cold.shape[1] == np.sum(t <= 16.0) > 40
    # A sparse extreme: fewer than 10 rows within a fifth of the span still hold out 10.
    t = np.r_[np.linspace(0.0, 10.0, 90), 15.0, 30.0]
    cold, warm = extremes_held_out(t, line(t))
    assert warm.shape[1] == 10
    # A drift in T and dT: the plane extrapolates it exactly, the line in T does not.
    rng = np.random.default_rng(0)
    t = np.linspace(10.0, 40.0, 100)
    rate = rng.uniform(-1.0, 1.0, 100)
    y = (0.1 * t + 2.0 * rate)[:, None]
    assert max(end[1].max() for end in extremes_held_out(t, y, rate)) < 1e-20
    assert max(end[1].max() for end in extremes_held_out(t, y)) > 0.1


@pytest.mark.parametrize("seed", range(5))
def test_each_output_is_judged_on_its_own_errors(seed):
    """:func:`fit_fallback` compares each output's line with that output's constant: an
    output a thousand times larger must not lend its errors to a small one. A small exact
    slope beside large noise keeps its slope (kills ``end[1].mean(axis=None)``); a weak
    slope that explains less than three quarters at the extremes stays a constant beside a
    large real slope (kills ``end[0].mean(axis=None)``). Both hold on seeds 0-49 (checked
    once); the test runs 0-4."""
    rng = np.random.default_rng(seed)
    t = np.linspace(10.0, 22.0, 400)
    small = 0.01 * t + rng.normal(scale=0.001, size=t.size)
    big_noise = rng.normal(scale=1000.0, size=t.size)
    fallback = fit_fallback(t, np.column_stack([small, big_noise]), column=0)
    assert fallback.slope[0] == pytest.approx(0.01, rel=0.05)
    assert fallback.slope[1] == 0.0
    real = 1000.0 * t + rng.normal(scale=20.0, size=t.size)
    weak = 0.1 * t + rng.normal(scale=0.5, size=t.size)
    fallback = fit_fallback(t, np.column_stack([real, weak]), column=0)
    assert fallback.slope[0] == pytest.approx(1000.0, rel=0.01)
    assert fallback.slope[1] == 0.0
    assert fallback.intercept[1] == pytest.approx(weak.mean())


def test_a_fallback_with_too_few_rows_is_the_mean_in_its_column():
    """Too few rows to test a slope: the constant, still naming its temperature column
    (kills ``Fallback(None, ...)`` and ``Fallback(..., None)`` on that path)."""
    Y = np.column_stack([np.arange(30.0), np.full(30, -2.0)])
    fallback = fit_fallback(np.arange(30.0), Y, column=3)
    assert fallback.column == 3
    assert fallback.predict(np.zeros((2, 4))).tolist() == [[14.5, -2.0], [14.5, -2.0]]


def test_runs_without_a_rate_give_the_line_in_t():
    """``runs`` alone (no rate): the line-in-T rule (kills ``rate is None and runs is
    None``)."""
    rng = np.random.default_rng(0)
    t, rate, runs = _heating_runs(rng)
    y = (0.05 * t + 0.8 * rate + rng.normal(scale=0.05, size=t.size))[:, None]
    line = fit_fallback(t, y, 0)
    alone = fit_fallback(t, y, 0, runs=runs)
    assert fallback_name(alone) == fallback_name(line) == "line"
    np.testing.assert_array_equal(alone.slope, line.slope)
    np.testing.assert_array_equal(alone.intercept, line.intercept)
    assert alone.rate_slope is None


def test_a_plane_is_trusted_at_a_ratio_of_exactly_repeated_ratio():
    """``repeated_ratio`` is the *largest* ratio trusted: at exactly the plane's own
    held-out ratio it is kept, just below it not (kills ``ratio < repeated_ratio``)."""
    from sklearn_ifog.fallback import held_out_runs

    rng = np.random.default_rng(0)
    t, rate, runs = _heating_runs(rng)
    y = (0.05 * t + 0.8 * rate + rng.normal(scale=0.05, size=t.size))[:, None]
    ratio = held_out_runs(t, rate, y, runs)[0]
    assert 0.0 < ratio < 0.75
    kw = dict(rate=rate, rate_column=1, runs=runs, carried_scale=np.inf)
    assert fallback_name(fit_fallback(t, y, 0, repeated_ratio=ratio, **kw)) == "plane"
    below = np.nextafter(ratio, 0.0)
    assert fallback_name(fit_fallback(t, y, 0, repeated_ratio=below, **kw)) != "plane"


@pytest.mark.parametrize("seed", range(5))
def test_the_plane_is_decided_output_by_output(seed):
    """Several outputs: each gets the plane only where its own runs repeat it and its own
    extremes carry it, its rate slope 0 and the line's intercept and slope otherwise; the
    plane's intercept is the least-squares plane's. An output a thousand times larger does
    not lend its errors to a small one (kills ``trusted | carries``, ``carries.any(axis=
    None)``, a rate slope of 1 off the plane, ``np.where(None, intercept, ...)`` and
    ``end[1].mean(axis=None)`` in :func:`fit_fallback`). Holds on seeds 0-29 (checked
    once); the test runs 0-4."""
    from sklearn_ifog.fallback import _plane

    rng = np.random.default_rng(seed)
    t, rate, runs = _heating_runs(rng)
    plane = 0.05 * t + 0.8 * rate
    exact = plane + rng.normal(scale=0.02, size=t.size)
    noisy = plane + rng.normal(scale=0.3, size=t.size)  # a held-out-run ratio near 0.15
    kw = dict(rate=rate, rate_column=1, runs=runs)
    Y = np.column_stack([exact, noisy])
    fallback = fit_fallback(t, Y, 0, repeated_ratio=0.05, carried_scale=np.inf, **kw)
    line = fit_fallback(t, Y, 0)
    intercept, slope, rate_slope = _plane(t, rate, Y)
    assert fallback.rate_slope[0] == rate_slope[0] == pytest.approx(0.8, rel=0.05)
    assert (fallback.intercept[0], fallback.slope[0]) == (intercept[0], slope[0])
    assert fallback.rate_slope[1] == 0.0
    assert (fallback.intercept[1], fallback.slope[1]) == (line.intercept[1], line.slope[1])
    # A small output bending above 34 degC beside a large exact plane: held above, kept.
    bend = plane - 0.05 * np.maximum(t - 34.0, 0.0) ** 2 + rng.normal(scale=0.02, size=t.size)
    fallback = fit_fallback(t, np.column_stack([bend, 1000.0 * exact]), 0, **kw)
    assert fallback.hold_above.tolist() == [True, False]
    assert fallback.hold_below.tolist() == [False, False]
    assert np.all(fallback.rate_slope > 0.5)


def test_fallback_predict_holds_only_the_outputs_it_holds():
    """Two outputs, the first held below ``low``, the second not: inside the calibrated
    temperatures both are their lines, below only the first is flat (kills ``slope /
    hold_below`` and ``min(t - low, 1.0)`` in :meth:`Fallback.predict`)."""
    fallback = Fallback(
        np.array([1.0, 2.0]),
        np.array([0.5, -1.0]),
        0,
        low=20.0,
        high=40.0,
        hold_below=np.array([True, False]),
        hold_above=np.array([False, True]),
    )
    rows = np.array([[10.0], [20.0], [30.0], [40.0], [50.0]])
    np.testing.assert_array_equal(
        fallback.predict(rows),
        [[11.0, -8.0], [11.0, -18.0], [16.0, -28.0], [21.0, -38.0], [26.0, -38.0]],
    )


# --- Survivors of the second domain run (held_out_*, fit_box, _no_spread, _columns, ...). ---


def _raises_exactly(exception, message):
    """``pytest.raises`` of ``exception`` with exactly ``message``."""
    return pytest.raises(exception, match="^" + re.escape(message) + "$")


def test_a_bool_in_a_column_list_is_refused_by_name():
    """A bool among integer positions (``[0, True]``) is not read as column 1: TypeError
    naming the parameter and the bool. Kills ``flags = None``, ``flags[1]`` and the
    message mutants in :func:`~sklearn_ifog.domain._columns`, and ``np.asarray(value)``
    without ``dtype=object`` there (``[0, True]`` would become the integers ``[0, 1]``)."""
    X, _ = _calibration()
    X = np.column_stack([X, np.sin(X[:, 0])])
    message = (
        "temperature must name columns of X by integer position, got the bool True "
        "(a bool is not a column index)."
    )
    with _raises_exactly(TypeError, message):
        CalibrationDomain(temperature=[0, True]).fit(X)
    with pytest.raises(TypeError, match=r"^rate must name .* got the bool np.True_ \(a bool"):
        CalibrationDomain(rate=[np.True_]).fit(X)
    # Integer positions of any integer type are columns.
    domain = CalibrationDomain(temperature=[np.int64(0)], rate=[2]).fit(X)
    assert (domain.temperature_columns_, domain.rate_columns_) == ([0], [2])


def test_a_column_named_twice_is_refused_with_its_count():
    """A column named twice would count its excess twice: ValueError naming the column,
    how often and the list. Kills ``repeated = None``, ``count(None)``, ``count(c) > 2``,
    ``repeated[1]`` and the message mutants of :func:`~sklearn_ifog.domain._columns`."""
    X, _ = _calibration()
    X = np.column_stack([X, np.sin(X[:, 0])])
    message = "temperature must name each column once, got column 1 2 times in [1, 0, 1]."
    with _raises_exactly(ValueError, message):
        CalibrationDomain(temperature=[1, 0, 1]).fit(X)
    with pytest.raises(ValueError, match=r"^rate must name each column once, got column 2 3 "):
        CalibrationDomain(rate=[2, 2, 2]).fit(X)


def test_no_spread_is_judged_column_by_column_against_its_own_magnitude():
    """:func:`~sklearn_ifog.domain._no_spread` flags a column without a spread to
    standardise by, each against its own values, and warns of nothing:

    - a column in tiny units (1e-15 beside degrees) has a spread (kills the magnitude over
      every column, ``max(axis=None)`` and a missing ``axis``, and ``initial=1.0``);
    - a 0/1 column varies by exactly 1 (kills ``spread == 1``);
    - a column whose standard deviation underflows to 0 (values near 1e-170) has none though
      its range is not 0 (kills ``std(axis=None)``, ``std >= 0`` and the first ``|`` read
      as ``&``);
    - a column that varies at the round-off of its values (1e6 + 1e-9 steps) has none
      though its standard deviation is positive (kills ``ptp(axis=None)``, ``ptp`` without
      ``axis``, ``eps / magnitude`` and the second ``|`` read as ``&``);
    - the round-off rule is inclusive: a spread of exactly 1000 ulps of 1.0 is none (kills
      ``spread < ...``);
    - ``np.finfo(None)`` (a DeprecationWarning in numpy 2) is caught by the warning filter.
    """
    from sklearn_ifog.domain import _no_spread

    t = np.linspace(10.0, 40.0, 31)
    one_ulp_range = np.tile([1.0 - 1000 * 2.0**-52, 1.0], 16)[:31]
    columns = {
        "tiny units": (1e-16 * t, False),
        "zero or one": (np.tile([0.0, 1.0], 16)[:31], False),
        "underflow": (np.linspace(0.0, 2e-170, 31), True),
        "round-off": (1e6 + 1e-9 * np.arange(31), True),
        "1000 ulps": (one_ulp_range, True),
    }
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name, (column, flagged) in columns.items():
            X = np.column_stack([t, column])
            assert np.ptp(column) > 0, name
            assert _no_spread(X).tolist() == [False, flagged], name
    assert np.ptp(one_ulp_range) == 1e3 * np.finfo(np.float64).eps
    assert np.linspace(0.0, 2e-170, 31).std() == 0.0  # the premise of the underflow case
    # A column in tiny units fits a domain whose box holds its own rows.
    X = np.column_stack([t, 1e-16 * t + 1e-17 * np.sin(t)])
    domain = CalibrationDomain().fit(X)
    np.testing.assert_array_equal(domain.distance(X), np.zeros(31))


def test_check_varies_says_how_a_feature_fails_to_vary():
    """The message names the feature, says whether it is constant (with its value) or varies
    too little (by how much), and counts the calibration rows. Kills ``spread == 0 or
    True``, ``X[1, column]`` (a single row is constant in every feature), ``X.shape[1]``
    for the row count, and the mutants of the message's text in
    :func:`~sklearn_ifog.domain.check_varies`."""
    from sklearn_ifog.domain import check_varies

    t = np.linspace(10.0, 40.0, 31)
    tail = (
        " calibration rows. A calibration must cover a range of temperatures (and rates) "
        "to say where it holds; calibrate on runs that change temperature."
    )
    head = "Cannot fit a calibration domain: feature "
    with _raises_exactly(ValueError, head + "'dT' is constant (2.5) over the 31" + tail):
        check_varies(np.column_stack([t, np.full(31, 2.5)]), ["T", "dT"])
    too_little = "column 1 varies by 3e-08 only, too little to standardise by over the 31"
    with _raises_exactly(ValueError, head + too_little + tail):
        check_varies(np.column_stack([t, 1e6 + 1e-9 * np.arange(31)]))
    with pytest.raises(ValueError, match=r"varies by 2e-170 only, too little to standardise"):
        check_varies(np.column_stack([t, np.linspace(0.0, 2e-170, 31)]))
    with _raises_exactly(ValueError, head + "column 0 is constant (7.0) over the 1" + tail):
        check_varies(np.array([[7.0, 2.0]]))


def test_fit_box_of_fewer_rows_than_features_completes_an_orthonormal_basis():
    """Three calibration rows of five features: the box still has five orthonormal axes,
    the two that the rows do not span (and the third, degenerate one) at the floored
    spread ``1e-6`` of the widest, and a row off the rows' span is far outside while the
    rows themselves are inside. Kills every mutant of the basis completion in
    :func:`~sklearn_ifog.domain.fit_box` (``axes.shape[1]``, ``eye + axes.T @ axes``, the
    slices and the padding of ``singular``), ``full_matrices`` True or omitted (which
    leave three axis scales for five axes) and ``_AXIS_FLOOR / max``."""
    from sklearn_ifog.domain import box_distance, fit_box

    X = np.array(
        [
            [10.0, 0.1, 3.0, -1.0, 100.0],
            [25.0, 0.4, 2.0, 0.5, 140.0],
            [40.0, 0.2, 7.0, 2.0, 90.0],
        ]
    )
    box = fit_box(X)
    assert box.axes.shape == (5, 5)
    np.testing.assert_allclose(box.axes @ box.axes.T, np.eye(5), atol=1e-12)
    assert box.axis_scale.shape == box.lower.shape == box.upper.shape == (5,)
    widest = box.axis_scale.max()
    assert widest > 1.0  # five unit-variance features over two real axes
    np.testing.assert_array_equal(box.axis_scale[2:], 1e-6 * widest)
    assert np.all(box.axis_scale[:2] > 0.5)
    np.testing.assert_allclose(box_distance(box, X), 0.0, atol=1e-6)
    # The mean moved off the rows' plane by 1e-3 standard deviations of one feature.
    off = X.mean(axis=0) + np.r_[0.0, 0.0, 0.0, 1e-3 * X[:, 3].std(), 0.0]
    assert box_distance(box, off[None, :])[0] > 100.0


def test_fit_box_floors_a_degenerate_axis_at_a_millionth_of_the_widest():
    """A duplicated column: all the spread is on one axis (``sqrt 2`` standard deviations of
    the standardised features), the other is floored at ``1e-6`` times it, so a row off the
    relation by ``+-1e-8`` standard deviations of the two features lies at ``sqrt 2 1e-8 /
    (1e-6 sqrt 2) = 0.01``. Kills ``_AXIS_FLOOR / axis_scale.max()`` in
    :func:`~sklearn_ifog.domain.fit_box`."""
    from sklearn_ifog.domain import box_distance, fit_box

    t = np.linspace(10.0, 40.0, 31)
    box = fit_box(np.column_stack([t, t]))
    np.testing.assert_allclose(box.axis_scale, [np.sqrt(2.0), 1e-6 * np.sqrt(2.0)], rtol=1e-12)
    # Off the relation along the degenerate axis: (+d, -d) standard deviations.
    d = 1e-8
    row = np.array([[25.0 + d * t.std(), 25.0 - d * t.std()]])
    expected = d * np.sqrt(2.0) / (1e-6 * np.sqrt(2.0))  # |excess| over the floored scale
    assert box_distance(box, row)[0] == pytest.approx(expected, rel=1e-4)


def test_a_row_just_beyond_any_face_of_the_box_lies_at_its_excess():
    """In decorrelated coordinates every axis keeps its own range: a row a tenth of an axis's
    standard deviation beyond its lower (or upper) face, at the middle of every other axis,
    lies at distance 0.1. Kills ``projected.min(axis=None)`` (one lower bound for every
    axis, the smallest) in :func:`~sklearn_ifog.domain.fit_box`."""
    from sklearn_ifog.domain import box_distance, fit_box

    X, _ = _calibration()
    X = np.column_stack([X, X[:, 0] ** 2 / 40.0 + X[:, 1]])
    box = fit_box(X)
    assert box.lower.shape == box.upper.shape == (3,)
    middle = (box.lower + box.upper) / 2
    for k in range(3):
        for face, sign in ((box.lower, -1.0), (box.upper, 1.0)):
            P = middle.copy()
            P[k] = face[k] + sign * 0.1 * box.axis_scale[k]
            row = (P @ box.axes) * box.scale + box.center
            assert box_distance(box, row[None, :])[0] == pytest.approx(0.1, rel=1e-9), (k, sign)


def test_fit_box_keeps_its_rate_columns_and_their_term():
    """:func:`~sklearn_ifog.domain.fit_box` records the rate columns it was given, so that
    :func:`~sklearn_ifog.domain.box_distance` adds a rate's excess (in standard deviations
    over ``RATE_WEIGHT``) under the root. Kills ``Box(..., None, ...)`` for
    ``rate_columns`` (the domain builds its own Box, so no other test saw it)."""
    from sklearn_ifog._tuning import RATE_WEIGHT
    from sklearn_ifog.domain import box_distance, fit_box

    X, _ = _calibration()
    box = fit_box(X, rate_columns=[np.int64(1)])
    assert box.rate_columns == (1,)
    assert (box.rate_low.tolist(), box.rate_high.tolist()) == ([X[:, 1].min()], [X[:, 1].max()])
    assert box.rate_scale[0] == pytest.approx(X[:, 1].std() / RATE_WEIGHT, rel=1e-12)
    row = np.array([[25.0, X[:, 1].max() + 0.25 * X[:, 1].std()]])
    plain = box_distance(fit_box(X), row)[0]
    assert box_distance(box, row)[0] == pytest.approx(np.hypot(plain, 0.25 * RATE_WEIGHT))


def test_the_boost_ramps_in_over_a_hundredth_of_a_standard_deviation_row_by_row():
    """``Box.boost`` is added in proportion to the novelty ``n``, in hundredths of a standard
    deviation beyond the calibrated rate or temperature (``sqrt`` of the sum of squares of
    both), up to 1, for each row on its own. Kills ``(RATE_WEIGHT * NOVELTY_RAMP) ** 3``,
    ``excess * (scale * NOVELTY_RAMP)``, ``excess / (scale / NOVELTY_RAMP)`` and
    ``sum(axis=None)`` over every row in :func:`~sklearn_ifog.domain.box_distance`."""
    from sklearn_ifog.domain import box_distance, fit_box

    X, _ = _calibration()
    low, high = X.min(axis=0), X.max(axis=0)
    sd = X.std(axis=0)
    box = fit_box(X, [1])._replace(
        boost=2.0,
        temperature_columns=(0,),
        temperature_low=low[:1],
        temperature_high=high[:1],
    )
    # (degrees beyond, rate beyond), each in hundredths of its standard deviation.
    steps = np.array(
        [
            [0.0, 0.0],
            [0.5, 0.0],
            [-0.25, 0.0],
            [0.0, 0.5],
            [0.0, -0.75],
            [0.3, 0.4],
            [3.0, 0.0],
            [0.0, 2.0],
        ]
    )
    expected = 2.0 * np.minimum(np.hypot(steps[:, 0], steps[:, 1]), 1.0)
    rows = np.empty_like(steps)
    for column in (0, 1):
        s = steps[:, column] * 0.01 * sd[column]
        inside = np.where(s < 0, low[column] + s, X[0, column])
        rows[:, column] = np.where(s > 0, high[column] + s, inside)
    added = box_distance(box, rows) - box_distance(box._replace(boost=0.0), rows)
    np.testing.assert_allclose(added, expected, rtol=1e-6, atol=1e-12)
    assert added[0] == 0.0


def test_a_distance_equal_to_the_margin_is_inside():
    """``margin`` is the distance that still counts as inside; a temperature exactly at its
    calibrated end is inside too. Kills ``distance >= margin`` in
    :func:`~sklearn_ifog.domain.outside_domain`."""
    from sklearn_ifog.domain import outside_domain

    above = np.nextafter(1.5, 2.0)
    outside = outside_domain([1.5, above, 0.0, 0.0], [0.0, 0.0, 0.0, 1e-12], margin=1.5)
    assert outside.tolist() == [False, True, False, True]


def test_calibrated_threshold_needs_twenty_distances_and_counts_the_bad_ones():
    """Twenty held-out distances are enough for a quantile, nineteen are not (kills
    ``size <= 20``); a non-finite distance is an error that counts them (kills
    ``np.sum(np.isfinite(...))`` and the mutants of the message's text); float32 or
    integer distances give the float64 quantile (kills ``np.asarray(distances)`` without
    ``dtype``, which takes the quantile in float32) in
    :func:`~sklearn_ifog.domain.calibrated_threshold`."""
    from sklearn_ifog.domain import calibrated_threshold

    twenty = np.linspace(0.0, 19.0, 20)
    assert calibrated_threshold(twenty, alpha=0.5, floor=0.0) == 9.5
    assert calibrated_threshold(twenty[:19], alpha=0.5, floor=0.0) is None
    message = (
        "Cannot calibrate the domain's threshold (alpha): 2 held-out distances are NaN or "
        "infinite; the calibration rows must be finite and every feature must vary."
    )
    with _raises_exactly(ValueError, message):
        calibrated_threshold([0.0, 1.0, np.nan, 2.0, -np.inf], alpha=0.02, floor=1.5)
    rng = np.random.default_rng(0)
    single = rng.gamma(2.0, size=(5, 100)).astype(np.float32)
    for distances in single:
        threshold = calibrated_threshold(distances, alpha=0.02, floor=0.0)
        assert threshold == float(np.quantile(distances.astype(np.float64), 0.98))
    assert calibrated_threshold(np.arange(101), alpha=0.02, floor=1.5) == 98.0


def test_fit_box_of_float32_rows_is_fitted_in_double_precision():
    """A single-precision recording gets the box of its values in double precision, not a
    float32 box. Kills ``np.asarray(X)`` without ``dtype`` in
    :func:`~sklearn_ifog.domain.fit_box` (mean, spread and axes then in float32, off by
    about 1e-6)."""
    from sklearn_ifog.domain import box_distance, fit_box

    X, _ = _calibration()
    single = X.astype(np.float32)
    box, double = fit_box(single, [1]), fit_box(single.astype(np.float64), [1])
    for name in ("center", "scale", "axes", "axis_scale", "lower", "upper", "rate_scale"):
        assert getattr(box, name).dtype == np.float64, name
        np.testing.assert_array_equal(getattr(box, name), getattr(double, name), err_msg=name)
    rows = np.array([[45.0, 0.5], [25.0, 1.3]])
    np.testing.assert_array_equal(box_distance(box, rows), box_distance(double, rows))


def _three_runs(n_rows=50):
    """Three runs over the same temperatures (10-40 degC) with a second feature of their own."""
    t = np.tile(np.linspace(10.0, 40.0, n_rows), 3)
    runs = np.repeat([0, 1, 2], n_rows)
    return np.column_stack([t, np.sin(t / 5.0 + runs)]), runs


def test_held_out_rows_at_the_others_extreme_temperatures_are_kept():
    """A held-out row is kept when its temperature lies within the other folds' range, its
    ends included: three runs over the same 10-40 degC keep every row. Kills ``values >
    low`` and ``values < high`` in :func:`~sklearn_ifog.domain.held_out_distances`."""
    from sklearn_ifog.domain import held_out_distances, held_out_folds

    X, runs = _three_runs()
    folds = held_out_folds(runs.size, runs)
    assert folds.tolist() == runs.tolist()
    distances = held_out_distances(X, folds, temperature_columns=[0])
    assert distances.shape == (150,)
    assert np.all(np.isfinite(distances))


def test_held_out_distances_skip_only_the_folds_that_leave_a_feature_constant():
    """A feature that varies in run 0 only: holding run 0 out leaves it constant, so that fold
    is skipped (no NaN), and the later folds still count, each the distance of its rows to
    the others' box. Kills ``and`` for ``or``, ``np.any(None)`` and ``break`` for
    ``continue`` in :func:`~sklearn_ifog.domain.held_out_distances`."""
    from sklearn_ifog.domain import box_distance, fit_box, held_out_distances

    X, runs = _three_runs()
    X[runs > 0, 1] = 0.0
    distances = held_out_distances(X, runs)
    expected = np.concatenate([box_distance(fit_box(X[runs != k]), X[runs == k]) for k in (1, 2)])
    np.testing.assert_array_equal(distances, expected)
    assert distances.shape == (100,)


def test_held_out_distances_of_one_feature_and_of_two_kept_rows():
    """One feature is enough (kills ``kept.shape[1] < 2``); two kept rows make a box (kills
    ``kept.shape[0] <= 2`` and ``< 3``): three rows, one per fold, each measured against
    the other two. With no fold left to measure the result is empty (kills ``if distances
    or True``, ``np.empty(None)`` and ``np.empty(1)``)."""
    from sklearn_ifog.domain import held_out_distances, held_out_folds

    t = np.linspace(10.0, 40.0, 100)[:, None]
    distances = held_out_distances(t, held_out_folds(100), temperature_columns=[0])
    np.testing.assert_array_equal(distances, np.zeros(60))
    # Row 0 (0) against [1, 3]: 1 sd below; row 1 inside [0, 3]; row 2 (3) against [0, 1]:
    # 4 sd above.
    three = np.array([[0.0], [1.0], [3.0]])
    np.testing.assert_allclose(held_out_distances(three, np.array([0, 1, 2])), [1.0, 0.0, 4.0])
    empty = held_out_distances(three, np.zeros(3, dtype=int))
    assert empty.shape == (0,)
    assert empty.dtype == np.float64


def test_held_out_folds_are_integers_even_for_no_rows():
    """The folds are integers (kills ``np.empty(n_samples)`` as float64 in
    :func:`~sklearn_ifog.domain.held_out_folds`) and no rows give no folds (kills
    ``max(initial=None)`` and ``initial=-2``)."""
    from sklearn_ifog.domain import held_out_folds

    for folds in (held_out_folds(10), held_out_folds(6, [0, 0, 0, 1, 1, 1])):
        assert folds.dtype.kind == "i"
    assert held_out_folds(6, [0, 0, 0, 1, 1, 1]).tolist() == [0, 1, 3, 0, 1, 3]
    for folds in (held_out_folds(0), held_out_folds(0, [])):
        assert folds.shape == (0,)
        assert folds.dtype.kind == "i"


def _plane_runs(seed=0):
    rng = np.random.default_rng(seed)
    t, rate, runs = _heating_runs(rng)
    y = 0.05 * t + 0.8 * rate + rng.normal(scale=0.05, size=t.size)
    return t, rate, runs, y


def test_held_out_runs_does_not_depend_on_the_units():
    """The ratio and scale of :func:`~sklearn_ifog.fallback.held_out_runs` are those of the
    plane, whatever the units of T, dT and the drift: T and dT scaled by 1e-8 or 1e4
    (each column is standardised on its own, kills ``std(axis=None)``, ``Z * spread``,
    ``np.where(None, ...)`` and ``spread > 1``), a drift in mdeg/h instead of deg/h
    (kills ``constant > 1`` and ``spread > 1`` in the ratio's and the scale's guards),
    and T with an offset of 1e6 (raw sensor counts: the columns are centred before the
    sums, kills ``Z + Z.mean``, off by 1e-5 then)."""
    from sklearn_ifog.fallback import held_out_runs

    t, rate, runs, y = _plane_runs()
    reference = np.r_[held_out_runs(t, rate, y[:, None], runs, return_scale=True)].ravel()
    assert reference[0] < 0.05
    assert reference[1] == pytest.approx(1.0, abs=0.01)
    for name, (T, dT, Y) in {
        "dT x 1e-8": (t, 1e-8 * rate, y),
        "T x 1e-8": (1e-8 * t, rate, y),
        "T x 1e4": (1e4 * t, rate, y),
        "drift x 1e-3": (t, rate, 1e-3 * y),
        "T + 1e6": (t + 1e6, rate, y),
    }.items():
        ratio, scale = held_out_runs(T, dT, Y[:, None], runs, return_scale=True)
        np.testing.assert_allclose(np.r_[ratio, scale], reference, rtol=1e-8, err_msg=name)


def test_held_out_runs_of_a_drift_free_output_and_of_no_rows():
    """An output with no drift at all (zeros): the plane predicts no deviation from the
    constant, so its ratio and scale are 0, not NaN (kills ``constant >= 0`` and
    ``spread >= 0``), beside an output with a real plane; no rows are fewer than two runs
    (kills ``labels.max(initial=None)``)."""
    from sklearn_ifog.fallback import held_out_runs

    t, rate, runs, y = _plane_runs()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ratio, scale = held_out_runs(
            t, rate, np.column_stack([y, np.zeros_like(y)]), runs, return_scale=True
        )
    assert ratio[1] == 0.0
    assert scale[1] == 0.0
    assert 0.0 < ratio[0] < 0.05
    assert scale[0] == pytest.approx(1.0, abs=0.01)
    assert held_out_runs([], [], np.empty((0, 1)), []) is None
    assert held_out_runs([], [], np.empty((0, 1)), [], return_scale=True) == (None, None)


def test_the_domain_refuses_nan_as_its_tags_say():
    """:class:`CalibrationDomain` declares ``allow_nan=False`` and refuses NaN at fit and
    predict alike (kills ``allow_nan = None`` and ``= True`` in its
    ``__sklearn_tags__``)."""
    from sklearn.utils import get_tags

    assert get_tags(CalibrationDomain()).input_tags.allow_nan is False
    X, _ = _calibration()
    bad = X.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        CalibrationDomain().fit(bad)
    with pytest.raises(ValueError, match="NaN"):
        CalibrationDomain().fit(X).predict(bad[:5])
