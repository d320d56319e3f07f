"""The calibration domain and the CompensationPipeline's behaviour outside it."""

import pickle
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.base import clone
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GridSearchCV, GroupKFold

from sklearn_ifog import (
    CalibrationDomain,
    CompensationPipeline,
    OutsideCalibrationWarning,
    RBFNetRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog._compat import InvalidParameterError
from sklearn_ifog._tuning import CARRIED_SCALE, RATE_WEIGHT, REPEATED_RATIO
from sklearn_ifog.datasets import load_psim_tvc, make_thermal_campaign
from sklearn_ifog.domain import (
    box_distance,
    fit_box,
    project_to_box,
    pull_back_to_ranges,
)
from sklearn_ifog.fallback import (
    Fallback,
    fallback_name,
    fit_fallback,
    held_out_runs,
)
from sklearn_ifog.policy import BlendWithFallback, fallback_weight

SMALL = dict(n_units=1, n_runs=2, azimuths=(0.0,), sampling_period=120.0, random_state=0)


@pytest.fixture(scope="module")
def heating_and_cycling():
    """A gyro calibrated heating only (10-40 degC), and runs of it cycling down to -10."""
    calibration = make_thermal_campaign(profile="paper", temperature_range=(10.0, 40.0), **SMALL)
    operation = make_thermal_campaign(profile="cycle", temperature_range=(-10.0, 40.0), **SMALL)
    return calibration.data, calibration.target, operation.data, operation.target


@pytest.fixture(scope="module")
def partly_outside(heating_and_cycling):
    """The calibration runs themselves (inside) and copies of them 15 degC colder."""
    X, _, _, _ = heating_and_cycling
    colder = X.assign(temperature=X["temperature"] - 15.0, run=X["run"] + 100)
    return pd.concat([X, colder], ignore_index=True)


@pytest.fixture(scope="module")
def fitted(heating_and_cycling):
    X, y, _, _ = heating_and_cycling
    return make_compensation_pipeline(RBFNetRegressor(random_state=0)).fit(X, y)


# -- the domain alone ------------------------------------------------------------------


def _curve(n=400):
    """Rows on a curve in 3-D, as a single run's features lie on its time history."""
    t = np.linspace(0.0, 1.0, n)
    return np.column_stack([10.0 + 30.0 * t, np.exp(-3.0 * t), (10.0 + 30.0 * t) ** 2])


def test_training_rows_are_inside_and_combinations_outside():
    X = _curve()
    domain = CalibrationDomain(margin=0.5).fit(X)
    assert (domain.predict(X) == 1).all()
    assert np.all(domain.distance(X) == 0.0)
    # Every feature inside its own range, but a combination the curve never had (the
    # second feature at its warm value while the first is cold): a range check misses it.
    combination = np.array([[12.0, np.exp(-3.0), 144.0]])
    assert (combination >= X.min(axis=0)).all()
    assert (combination <= X.max(axis=0)).all()
    assert domain.predict(combination).tolist() == [-1]
    assert domain.distance(combination)[0] > 10 * domain.margin


def test_distance_is_in_axis_standard_deviations_one_feature():
    x = np.linspace(0.0, 10.0, 101)[:, None]
    domain = CalibrationDomain(margin=0.0).fit(x)
    sd = x.std()
    assert domain.distance([[10.0 + 2.5 * sd]])[0] == pytest.approx(2.5)
    assert domain.distance([[-sd]])[0] == pytest.approx(1.0)
    assert domain.decision_function([[5.0]])[0] == pytest.approx(0.0)
    assert domain.score_samples([[-sd]])[0] == pytest.approx(-1.0)


def test_temperature_beyond_range_is_outside_whatever_the_margin():
    X = _curve()
    domain = CalibrationDomain(margin=5.0, temperature=0).fit(X)
    just_below = X[:1].copy()
    just_below[0, 0] -= 0.01
    assert domain.distance(just_below)[0] < domain.margin
    assert domain.predict(just_below).tolist() == [-1]
    assert domain.temperature_excess(just_below)[0] == pytest.approx(0.01)
    assert domain.decision_function(just_below)[0] < 0
    assert domain.score_samples(just_below)[0] < domain.score_samples(X).min()
    # Without the temperature rule the same row is inside.
    assert CalibrationDomain(margin=5.0).fit(X).predict(just_below).tolist() == [1]


def test_excess_and_projection():
    X = _curve()
    domain = CalibrationDomain(margin=0.5, temperature=0).fit(X)
    far = np.array([[-20.0, 3.0, 0.0], [25.0, 0.5, 625.0]])
    excess = domain.excess(far)
    assert excess[0, 0] == pytest.approx(-30.0)  # degrees below the coldest
    assert excess[0, 1] == pytest.approx(2.0)  # above the largest second feature
    projected = domain.project(far)
    assert np.all(domain.temperature_excess(projected) == 0.0)
    assert np.all(domain.distance(projected) <= (1.0 + 1e-9) * domain.margin)
    # Projection leaves inside rows alone and is idempotent.
    np.testing.assert_array_equal(domain.project(X), X)
    np.testing.assert_allclose(domain.project(projected), projected, rtol=0, atol=1e-9)


def _two_sensor_rows(n=600, seed=0):
    """Two coil temperatures, their rates and the gradient term ``T2 - T1`` (an exact
    difference: a degenerate axis of the box), over three heating and cooling runs."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 3.0 * np.pi, n)
    t1 = 20.0 + 15.0 * np.sin(t) + 0.1 * rng.standard_normal(n)
    t2 = t1 + 1.5 * np.cos(0.7 * t) + 0.1 * rng.standard_normal(n)
    rate1, rate2 = np.gradient(t1), np.gradient(t2)
    return np.column_stack([t1, rate1, t2, rate2, t2 - t1]), np.repeat([0, 1, 2], n // 3)


def test_clip_lies_in_the_widened_box_and_the_ranges_with_a_degenerate_axis():
    """With a gradient term, the temperature clamp of the alternating projections leaves
    ``T2 - T1`` off the degenerate axis: rounds ending on the clamp left rows hundreds of
    thresholds outside the box. The projection ends on the box and comes back into the
    temperature ranges along the segment to the mean: inside both, to round-off."""
    X, groups = _two_sensor_rows()
    domain = CalibrationDomain(temperature=[0, 2], rate=[1, 3]).fit(X, groups=groups)
    rng = np.random.default_rng(1)
    rows = X[rng.integers(0, len(X), 300)] + rng.normal(0.0, 1.0, (300, 5)) * X.std(axis=0)
    rows[:, 4] = rows[:, 2] - rows[:, 0]  # rows as ThermalFeatures makes them
    assert 0.5 < np.mean(domain.predict(rows) == -1) < 1.0  # most rows outside, not all
    projected = domain.project(rows)
    box = fit_box(X)  # the box alone, without the rate term
    assert box_distance(box, projected).max() <= (1.0 + 1e-9) * domain.threshold_
    assert np.all(domain.temperature_excess(projected) == 0.0)
    # The rows the rounds left outside the box move little: the projection stays near.
    rounds = rows.copy()
    for _ in range(8):
        rounds = project_to_box(box, rounds, domain.threshold_)
        rounds[:, [0, 2]] = np.clip(rounds[:, [0, 2]], X[:, [0, 2]].min(0), X[:, [0, 2]].max(0))
    assert box_distance(box, rounds).max() > 10.0 * domain.threshold_
    np.testing.assert_allclose(projected, rounds, rtol=0, atol=0.05 * X.std(axis=0).min())


def test_pull_back_to_ranges_moves_along_the_segment_to_the_centre():
    X = np.array([[0.0, 0.0, 5.0], [10.0, 2.0, 1.0], [4.0, 4.0, 3.0]])
    box = fit_box(X)  # centre (14/3, 2, 3)
    rows = np.array([[5.0, 1.0, 3.0], [16.0, 2.0, 3.0], [-3.0, 2.0, 9.0], [12.0, 0.0, 11.0]])
    pulled = pull_back_to_ranges(box, rows, [0, 2], [0.0, 1.0], [10.0, 5.0])
    np.testing.assert_array_equal(pulled[0], rows[0])  # within every range: untouched
    # One column beyond: it lands on its bound, the row on the segment to the centre.
    share = (10.0 - 14.0 / 3.0) / (16.0 - 14.0 / 3.0)
    np.testing.assert_allclose(pulled[1], box.center + share * (rows[1] - box.center))
    assert pulled[1, 0] == 10.0
    # Two beyond: the one that needs the shorter share sets it (here the third, to 5).
    shares = [(0.0 - 14.0 / 3.0) / (-3.0 - 14.0 / 3.0), (5.0 - 3.0) / (9.0 - 3.0)]
    assert min(shares) == shares[1]
    np.testing.assert_allclose(pulled[2], box.center + shares[1] * (rows[2] - box.center))
    assert pulled[2, 2] == 5.0
    assert 0.0 < pulled[2, 0] < 10.0
    shares = [(10.0 - 14.0 / 3.0) / (12.0 - 14.0 / 3.0), (5.0 - 3.0) / (11.0 - 3.0)]
    np.testing.assert_allclose(pulled[3], box.center + min(shares) * (rows[3] - box.center))
    assert np.all((pulled[:, [0, 2]] >= [0.0, 1.0]) & (pulled[:, [0, 2]] <= [10.0, 5.0]))
    # No columns: nothing to pull.
    np.testing.assert_array_equal(pull_back_to_ranges(box, rows, [], [], []), rows)
    # Below a range only: pulled up to its low end (kills a test of the high end alone).
    low_only = pull_back_to_ranges(box, [[5.0, 1.0, -3.0]], [0, 2], [0.0, 1.0], [10.0, 5.0])
    share = (1.0 - 3.0) / (-3.0 - 3.0)
    np.testing.assert_allclose(low_only[0], box.center + share * ([5.0, 1.0, -3.0] - box.center))
    assert low_only[0, 2] == 1.0
    # Integer rows are pulled in floating point, not truncated.
    pulled = pull_back_to_ranges(box, np.array([[16, 2, 3]]), [0], [0.0], [10.0])
    assert pulled.dtype == np.float64
    share = (10.0 - 14.0 / 3.0) / (16.0 - 14.0 / 3.0)
    np.testing.assert_allclose(pulled[0], box.center + share * ([16.0, 2.0, 3.0] - box.center))


def test_project_to_box_one_feature_is_a_clamp():
    x = np.linspace(-5.0, 5.0, 11)[:, None]
    box = fit_box(x)
    sd = x.std()
    clamped = project_to_box(box, [[-50.0], [0.0], [50.0]], margin=1.0)
    np.testing.assert_allclose(clamped.ravel(), [-5.0 - sd, 0.0, 5.0 + sd])
    assert box_distance(box, clamped).max() == pytest.approx(1.0)


def _heating_rows(n=400):
    """A temperature that soaks and ramps up only, and its rate (never below 0)."""
    t = np.linspace(0.0, 1.0, n)
    temperature = 10.0 + 30.0 * np.clip((t - 0.2) / 0.6, 0.0, 1.0)
    rate = np.gradient(temperature)
    return np.column_stack([temperature, rate, temperature * rate])


def test_rate_excess_is_one_more_term_of_the_distance():
    X = _heating_rows()
    plain = CalibrationDomain(margin=1.5, temperature=0).fit(X)
    rated = CalibrationDomain(margin=1.5, temperature=0, rate=1).fit(X)
    assert rated.rate_columns_ == [1]
    assert rated.rate_scale_[0] == pytest.approx(X[:, 1].std() / RATE_WEIGHT)
    np.testing.assert_array_equal(rated.distance(X), 0.0)
    # The box of the other axes and the rate term add in quadrature; beyond the calibrated
    # rates the boost (threshold - margin) is added in full once the rate term reaches 1.
    row = np.array([[25.0, -0.75 * X[:, 1].std(), -25.0 * 0.75 * X[:, 1].std()]])
    box_part = plain.distance(row)[0]
    rate_part = 0.75 * RATE_WEIGHT  # 0.75 standard deviations below the smallest rate (0)
    boost = rated.threshold_ - rated.margin
    assert boost == rated.boost_ >= 0
    expected = np.hypot(box_part, rate_part) + boost
    assert rated.distance(row)[0] == pytest.approx(expected)
    assert rated.score_samples(row)[0] == pytest.approx(-expected)


def test_a_cooling_row_inside_the_box_is_outside_by_its_rate():
    # Heating only: a slow cooling rate at a calibrated temperature stays within the
    # decorrelated box's margin, and is outside once the rate counts on its own.
    X = _heating_rows()
    sd = X[:, 1].std()
    cooling = np.array([[25.0, -sd, -25.0 * sd]])
    plain = CalibrationDomain(margin=1.5, temperature=0).fit(X)
    rated = CalibrationDomain(margin=1.5, temperature=0, rate=1).fit(X)
    assert plain.predict(cooling).tolist() == [1]
    assert rated.predict(cooling).tolist() == [-1]
    assert rated.decision_function(cooling)[0] < 0
    # The "clip" projection moves the box's axes only: this row is left as it is.
    np.testing.assert_array_equal(rated.project(cooling), cooling)


def test_domain_errors_name_the_problem():
    X = _curve()
    X[:, 1] = 3.0
    with pytest.raises(ValueError, match="feature column 1 is constant"):
        CalibrationDomain().fit(X)
    with pytest.raises(InvalidParameterError, match="margin"):
        CalibrationDomain(margin=-1.0).fit(_curve())
    with pytest.raises(ValueError, match="temperature must name columns 0 to 2"):
        CalibrationDomain(temperature=[5]).fit(_curve())
    with pytest.raises(ValueError, match="rate must name columns 0 to 2"):
        CalibrationDomain(rate=[3]).fit(_curve())
    fitted = CalibrationDomain().fit(_curve())
    with pytest.raises(ValueError, match="NaN"):
        fitted.predict([[np.nan, 0.5, 100.0]])
    with pytest.raises(ValueError, match="3 features"):
        fitted.predict([[1.0, 2.0]])


def test_fallback_weight_is_smooth_and_bounded():
    width = BlendWithFallback().width
    distance = np.linspace(0.0, 3 * width, 3001)
    weight = fallback_weight(distance, margin=1.0)
    assert weight[distance <= 1.0].max() == 0.0
    assert weight[distance >= 1.0 + width].min() == 1.0
    assert np.all(np.diff(weight) >= 0)
    # No step: the largest change between neighbouring distances is that of a smoothstep.
    assert np.abs(np.diff(weight)).max() <= 1.5 * (distance[1] - distance[0]) / width


# -- the fallback ----------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(8))
def test_fallback_keeps_a_real_slope_and_drops_a_spurious_one(seed):
    """Holds on seeds 0-19 (checked once); the suite runs 0-7."""
    rng = np.random.default_rng(seed)
    t = np.linspace(10.0, 22.0, 400)
    real = 70.0 * t + rng.normal(scale=20.0, size=t.size)
    noise = rng.normal(scale=20.0, size=t.size)
    # A bias that wandered with time (and so with the temperature of a monotone run) and
    # turned back: a line fits its middle and misses both ends.
    wander = 30.0 * np.sin(np.linspace(0.0, np.pi, t.size)) + rng.normal(size=t.size)
    fallback = fit_fallback(t, np.column_stack([real, noise, wander]), column=0)
    assert fallback.slope[0] == pytest.approx(70.0, rel=0.05)
    assert fallback.slope[1:].tolist() == [0.0, 0.0]
    np.testing.assert_allclose(fallback.intercept[1:], [noise.mean(), wander.mean()])
    assert fallback.column == 0


def test_fallback_without_temperature_or_rows_is_the_mean():
    Y = np.arange(30.0)[:, None]
    assert fit_fallback(None, Y).slope.tolist() == [0.0]
    assert fit_fallback(np.arange(30.0), Y).slope.tolist() == [0.0]  # 6 rows per end < 10
    assert fit_fallback(None, Y).predict(np.zeros((2, 3))).ravel().tolist() == [14.5, 14.5]


def _heating_runs(rng, n_runs=3, n_rows=150):
    """Runs that soak at 10 degC then ramp to 40 at a rate drawn per run (degC/min)."""
    t, rate, runs = [], [], []
    for run in range(n_runs):
        ramp_rate = rng.uniform(0.3, 1.0)
        soak = n_rows // 3
        t.append(np.r_[np.full(soak, 10.0), np.linspace(10.0, 40.0, n_rows - soak)])
        rate.append(np.r_[np.zeros(soak), np.full(n_rows - soak, ramp_rate)])
        runs.append(np.full(n_rows, run))
    return np.concatenate(t), np.concatenate(rate), np.concatenate(runs)


@pytest.mark.parametrize("seed", range(8))
def test_plane_fallback_keeps_a_rate_term_the_runs_repeat(seed):
    """A heating-only calibration confounds a rate (Shupe) term with temperature: a line in
    T alone misreads it, the plane recovers both slopes and extrapolates on both sides.
    Holds on seeds 0-19 (checked once); the suite runs 0-7."""
    rng = np.random.default_rng(seed)
    t, rate, runs = _heating_runs(rng)
    y = 0.05 * t + 0.8 * rate + rng.normal(scale=0.05, size=t.size)
    plane = fit_fallback(t, y[:, None], 0, rate=rate, rate_column=1, runs=runs)
    assert fallback_name(plane) == "plane"
    assert plane.slope[0] == pytest.approx(0.05, rel=0.1)
    assert plane.rate_slope[0] == pytest.approx(0.8, rel=0.05)
    assert plane.rate_column == 1
    assert plane.rate_bound == pytest.approx(np.abs(rate).max())
    assert (plane.low, plane.high) == (10.0, 40.0)
    assert not plane.hold_below[0]
    assert not plane.hold_above[0]
    # Cooling at -0.5 degC/min down to -10 degC: the truth, within the noise.
    cold = np.column_stack([np.linspace(-10.0, 10.0, 50), np.full(50, -0.5)])
    truth = 0.05 * cold[:, 0] - 0.4
    assert np.abs(plane.predict(cold)[:, 0] - truth).max() < 0.1
    # Without runs (or with one run): the line-in-T rule of before, whatever the rate.
    line = fit_fallback(t, y[:, None], 0)
    for single in (None, np.zeros(t.size)):
        same = fit_fallback(t, y[:, None], 0, rate=rate, rate_column=1, runs=single)
        assert fallback_name(same) != "plane"
        np.testing.assert_array_equal(same.predict(cold), line.predict(cold))


def test_plane_fallback_is_held_flat_beyond_the_end_it_did_not_extrapolate():
    """Drift that bends below 16 degC, in runs that soak at their cold end (10 degC): the
    plane does not carry to the cold extreme, so below the calibrated temperatures it is
    held at its value at the edge (and carried on above them).

    The extremes are held out by temperature (a fifth of the span), so the cold test holds
    out the whole soak and the start of the ramps. Held out by rank (before issue 42's fix)
    the coldest fifth of the rows lay inside the soak, at the very temperature of kept rows,
    so the plane "carried" there and was not held flat (checked once with the old rule on
    seeds 0-199: no plane held flat). Asserted over seeds 0-99: every plane is held flat
    below and not above, and a plane is kept on at least 95 of them."""
    planes = 0
    for seed in range(100):
        rng = np.random.default_rng(seed)
        t, rate, runs = _heating_runs(rng, n_runs=4)
        y = 0.05 * t + 0.8 * rate + 0.025 * np.maximum(16.0 - t, 0.0) ** 2
        y += rng.normal(scale=0.02, size=t.size)
        plane = fit_fallback(t, y[:, None], 0, rate=rate, rate_column=1, runs=runs)
        if fallback_name(plane) != "plane":
            assert fallback_name(plane) == "constant", seed
            continue
        planes += 1
        assert plane.hold_below[0], seed
        assert not plane.hold_above[0], seed
        rows = np.array([[-10.0, 0.0], [0.0, 0.0], [10.0, 0.0], [50.0, 0.0], [60.0, 0.0]])
        predicted = plane.predict(rows)[:, 0]
        assert predicted[:2] == pytest.approx([predicted[2]] * 2, abs=1e-12), seed
        assert predicted[4] - predicted[3] == pytest.approx(10.0 * plane.slope[0]), seed
    assert planes >= 95


def test_plane_fallback_ignores_a_drift_the_runs_do_not_repeat():
    """Each run's bias wanders with time differently: carried from the other runs, a plane
    does worse than their mean, and the fallback stays a constant.

    A rate over seeds 0-199, not one draw: a random walk of four runs sometimes follows
    their temperatures by chance. Measured: the held-out ratio above REPEATED_RATIO on 193
    of 200, the fallback a constant on 184 (a plane on seeds 7, 16, 26, 33, 34, 44, 49, 69,
    87, 97, 112, 118, 150, 153, 158 and 174); asserted: at least 95 % and 90 %."""
    above, constant = 0, 0
    for seed in range(200):
        rng = np.random.default_rng(seed)
        t, rate, runs = _heating_runs(rng, n_runs=4)
        wander = np.concatenate([np.cumsum(rng.normal(scale=0.3, size=150)) for _ in range(4)])
        above += bool(held_out_runs(t, rate, wander[:, None], runs)[0] > REPEATED_RATIO)
        fallback = fit_fallback(t, wander[:, None], 0, rate=rate, rate_column=1, runs=runs)
        constant += fallback_name(fallback) == "constant"
    assert above >= 0.95 * 200
    assert constant >= 0.90 * 200


def _run_offsets_hide_a_plane(seed):
    """Four heating runs of a thermal plane, each run offset by a turn-on bias of its own
    (0.8 deg/h standard deviation) that leaves the plane's held-out ratio near 1."""
    rng = np.random.default_rng(seed)
    t, rate, runs = _heating_runs(rng, n_runs=4)
    y = 0.05 * t + 0.8 * rate + rng.normal(scale=0.8, size=4)[runs]
    return t, rate, runs, y + rng.normal(scale=0.05, size=t.size)


def test_a_plane_the_held_out_runs_bear_out_is_trusted_through_their_offsets():
    """Turn-on biases that differ from run to run raise the plane's held-out ratio above
    REPEATED_RATIO, but the held-out runs still follow its predictions in proportion (a
    scale of CARRIED_SCALE or more): the fallback is the plane. The rule before the scale
    (``carried_scale=np.inf``) kept a constant; the threshold is the measured scale's."""
    t, rate, runs, y = _run_offsets_hide_a_plane(seed=6)
    ratio, scale = held_out_runs(t, rate, y[:, None], runs, return_scale=True)
    assert REPEATED_RATIO < ratio[0] < 1.0
    assert scale[0] >= CARRIED_SCALE

    def fallback(**rule):
        return fit_fallback(t, y[:, None], 0, rate=rate, rate_column=1, runs=runs, **rule)

    assert fallback_name(fallback()) == "plane"
    assert fallback_name(fallback(carried_scale=np.inf)) == "constant"
    assert fallback_name(fallback(carried_scale=float(scale[0]))) == "plane"
    assert fallback_name(fallback(carried_scale=float(scale[0]) + 1e-9)) == "constant"
    # trusted by its ratio alone, the same plane
    np.testing.assert_array_equal(
        fallback().predict(np.c_[t, rate]),
        fallback(repeated_ratio=1.0, carried_scale=np.inf).predict(np.c_[t, rate]),
    )


def test_held_out_runs_of_a_single_run_is_none_with_or_without_the_scale():
    t, rate, _, y = _run_offsets_hide_a_plane(seed=0)
    one_run = np.zeros(t.size)
    assert held_out_runs(t, rate, y[:, None], one_run) is None
    assert held_out_runs(t, rate, y[:, None], one_run, return_scale=True) == (None, None)


def test_a_plane_the_held_out_runs_do_not_bear_out_is_not_trusted():
    """The same construction where the held-out runs follow the plane's predictions by a
    scale below CARRIED_SCALE (it overshoots them) and its ratio is above REPEATED_RATIO: a
    constant."""
    t, rate, runs, y = _run_offsets_hide_a_plane(seed=2)
    ratio, scale = held_out_runs(t, rate, y[:, None], runs, return_scale=True)
    assert REPEATED_RATIO < ratio[0] < 1.0
    assert scale[0] < CARRIED_SCALE
    fallback = fit_fallback(t, y[:, None], 0, rate=rate, rate_column=1, runs=runs)
    assert fallback_name(fallback) == "constant"


def _held_out_runs_by_refits(temperature, rate, Y, runs):
    """held_out_runs by its definition: one least-squares plane per held-out run; the ratio
    and the held-out scale."""
    plane, constant = np.zeros(Y.shape[1]), np.zeros(Y.shape[1])
    along, spread = np.zeros(Y.shape[1]), np.zeros(Y.shape[1])
    for run in np.unique(runs):
        held = runs == run
        columns = np.column_stack([np.ones((~held).sum()), temperature[~held], rate[~held]])
        if np.ptp(rate[~held]) == 0:  # a rate that does not vary: no rate slope
            columns = columns[:, :2]
        coef = np.linalg.lstsq(columns, Y[~held], rcond=None)[0]
        rows = np.column_stack([np.ones(held.sum()), temperature[held], rate[held]])
        predicted = rows[:, : columns.shape[1]] @ coef
        plane += np.square(Y[held] - predicted).sum(axis=0)
        constant += np.square(Y[held] - Y[~held].mean(axis=0)).sum(axis=0)
        along += ((Y[held] - Y[~held].mean(axis=0)) * (predicted - Y[~held].mean(axis=0))).sum(
            axis=0
        )
        spread += np.square(predicted - Y[~held].mean(axis=0)).sum(axis=0)
    return plane / constant, along / spread


@pytest.mark.parametrize(
    "case", ["thermal", "one run at rest", "one run moves", "no rate", "two runs"]
)
def test_held_out_runs_equals_one_refit_per_run(case):
    """The per-run sums give what refitting the plane without each run gives."""
    rng = np.random.default_rng(7)
    n_runs = 2 if case == "two runs" else 6
    t, rate, runs = _heating_runs(rng, n_runs=n_runs)
    if case == "one run at rest":
        rate = np.where(runs == runs[0], 0.0, rate)
    if case == "one run moves":  # held out, it leaves runs whose rate does not vary
        rate = np.where(runs == runs[0], rate, 0.5)
    if case == "no rate":
        rate = np.zeros_like(rate)
    Y = np.column_stack(
        [0.05 * t + 0.8 * rate + 0.01 * t**2 / 40, np.cumsum(rng.normal(size=t.size))]
    )
    Y += rng.normal(scale=0.05, size=Y.shape)
    labels = np.array([f"run-{run}" for run in runs])  # labels of any kind
    ratio, scale = _held_out_runs_by_refits(t, rate, Y, runs)
    np.testing.assert_allclose(held_out_runs(t, rate, Y, labels), ratio, rtol=1e-9)
    both = held_out_runs(t, rate, Y, labels, return_scale=True)
    np.testing.assert_allclose(both[0], ratio, rtol=1e-9)
    np.testing.assert_allclose(both[1], scale, rtol=1e-9)


def test_fallback_rate_term_is_bounded_to_the_calibrated_rates():
    fallback = Fallback(
        np.array([1.0]),
        np.array([0.0]),
        0,
        rate_slope=np.array([2.0]),
        rate_column=1,
        rate_bound=0.5,
        low=10.0,
        high=40.0,
        hold_below=np.array([False]),
        hold_above=np.array([False]),
    )
    rows = np.array([[20.0, -3.0], [20.0, -0.5], [20.0, 0.25], [20.0, 9.0]])
    assert fallback.predict(rows).ravel().tolist() == [0.0, 0.0, 1.5, 2.0]


# -- the pipeline --------------------------------------------------------------------


def test_default_pipeline_is_a_compensation_pipeline():
    model = make_compensation_pipeline()
    assert isinstance(model, CompensationPipeline)
    assert (model.uncalibrated, model.domain.margin, model.domain.alpha) == ("blend", 1.5, 0.02)
    assert [name for name, _ in model.steps] == ["features", "scale", "regressor"]
    assert clone(model).get_params()["uncalibrated"] == "blend"
    assert type(model[:-1]).__name__ == "Pipeline"


def test_inside_rows_are_unchanged_and_policies_apply_outside(
    fitted, heating_and_cycling, partly_outside
):
    X, y, _, _ = heating_and_cycling
    X_op = partly_outside
    model = clone(fitted).fit(X, y)
    outside = model.outside_calibration(X_op)
    assert 0.3 < outside.mean() < 1.0  # the rows leave the domain, partly
    predictions = {}
    for policy in ("none", "blend", "clip"):
        model.set_params(uncalibrated=policy)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OutsideCalibrationWarning)
            predictions[policy] = model.predict(X_op)
    for policy in ("blend", "clip"):
        np.testing.assert_array_equal(predictions[policy][~outside], predictions["none"][~outside])
    features = model.steps[0][1].transform(X_op)
    distance = model.calibration_distance(X_op)
    weight = fallback_weight(distance, model.domain_.threshold_)
    expected = (1 - weight) * predictions["none"] + weight * model.fallback_.predict(features)[
        :, 0
    ]
    np.testing.assert_allclose(predictions["blend"], expected, rtol=1e-12, atol=1e-12)
    far = weight == 1.0
    assert far.any()
    np.testing.assert_array_equal(
        predictions["blend"][far], model.fallback_.predict(features[far])[:, 0]
    )
    projected = model.domain_.project(features[outside])
    clipped = model.steps[-1][1].predict(model.steps[1][1].transform(projected))
    np.testing.assert_allclose(predictions["clip"][outside], clipped, rtol=1e-12)


def test_blend_has_no_step_as_a_run_leaves_the_domain(fitted, heating_and_cycling):
    """Shift a calibration run colder and colder, and bisect towards where the prediction
    changes most: a step would keep its full size however small the interval gets."""
    X, _, _, _ = heating_and_cycling
    run = X[X["run"] == X["run"].iloc[0]]

    def predict(shift):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OutsideCalibrationWarning)
            return fitted.predict(run.assign(temperature=run["temperature"] + shift))

    shifts = np.linspace(0.0, -20.0, 81)
    curves = np.array([predict(shift) for shift in shifts])
    assert fitted.outside_calibration(run.assign(temperature=run["temperature"] - 20)).all()
    worst = int(np.abs(np.diff(curves, axis=0)).max(axis=1).argmax())
    low, high = shifts[worst + 1], shifts[worst]
    values = {low: curves[worst + 1], high: curves[worst]}
    first = np.abs(values[high] - values[low]).max()
    for _ in range(12):
        middle = 0.5 * (low + high)
        values[middle] = predict(middle)
        left = np.abs(values[middle] - values[low]).max()
        right = np.abs(values[high] - values[middle]).max()
        low, high = (low, middle) if left >= right else (middle, high)
    assert first > 0
    assert np.abs(values[high] - values[low]).max() < 0.01 * first


def test_warning_once_per_call_with_share_and_degrees(fitted, heating_and_cycling):
    X, _, X_op, _ = heating_and_cycling
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fitted.predict(X)
    assert not [w for w in caught if w.category is OutsideCalibrationWarning]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fitted.predict(X_op)
    messages = [str(w.message) for w in caught if w.category is OutsideCalibrationWarning]
    assert len(messages) == 1
    share = fitted.outside_calibration(X_op).mean()
    assert f"({share:.1%})" in messages[0]
    beyond = X["temperature"].min() - X_op["temperature"].min()
    assert f"up to {beyond:.3g} degC beyond" in messages[0]
    assert "uncalibrated='blend'" in messages[0]
    # Cooling after a heating-only calibration: how far the rates went beyond, in dT's unit.
    column = list(fitted.feature_names_out_).index("dT")
    rate = fitted.steps[0][1].transform(X_op)[fitted.outside_calibration(X_op), column]
    slowest = fitted.domain_.data_min_[column]
    assert slowest >= -0.01  # heating only
    assert f"rates up to {slowest - rate.min():.3g} beyond the calibrated dT" in messages[0]


def test_bad_input_is_named(heating_and_cycling, fitted):
    X, y, X_op, _ = heating_and_cycling
    with pytest.raises(InvalidParameterError, match="uncalibrated"):
        make_compensation_pipeline(LinearRegression(), uncalibrated="hold").fit(X, y)
    constant = X.assign(temperature=25.0)
    with pytest.raises(ValueError, match="feature 'T' is constant"):
        make_compensation_pipeline(LinearRegression()).fit(constant, y)
    bad = X_op.copy()
    bad.loc[bad.index[7], "temperature"] = np.nan
    run = bad.loc[bad.index[7], "run"]
    with pytest.raises(ValueError, match="temperature column 'temperature' contains NaN") as info:
        fitted.predict(bad)
    assert f"It is in run {run!r}" in str(info.value)
    assert "first at row 7" in str(info.value)
    with pytest.raises(ValueError, match="drift target"):
        make_compensation_pipeline(LinearRegression()).fit(X)


def test_pipeline_flags_new_rates_inside_the_calibrated_temperatures():
    # The paper's heating-only calibration, then cooling through the same temperatures.
    unit = dict(SMALL, azimuths=(0.0, 90.0))
    calibration = make_thermal_campaign(profile="paper", temperature_range=(10.0, 40.0), **unit)
    operation = make_thermal_campaign(profile="cooling", temperature_range=(10.0, 40.0), **unit)
    model = make_compensation_pipeline(LinearRegression()).fit(
        calibration.data, calibration.target
    )
    X = operation.data
    names = list(model.feature_names_out_)
    t, r = names.index("T"), names.index("dT")
    assert model.domain_.rate_columns_ == [r]
    features = model.steps[0][1].transform(X)
    low, high = model.domain_.data_min_, model.domain_.data_max_
    inside_t = (features[:, t] >= low[t]) & (features[:, t] <= high[t])
    new_rates = inside_t & (features[:, r] < low[r])
    box = model.domain_.box_._replace(rate_columns=())
    within_box = box_distance(box, features) <= model.domain.margin
    # Rows the box alone would leave inside are outside by their rate, and blended.
    rate_only = new_rates & within_box & model.outside_calibration(X)
    assert rate_only.sum() >= 10
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        blended = model.predict(X)
        model.set_params(uncalibrated="none")
        free = model.predict(X)
    assert np.all(blended[rate_only] != free[rate_only])
    np.testing.assert_array_equal(
        blended[~model.outside_calibration(X)], free[~model.outside_calibration(X)]
    )


def test_a_domain_fitted_before_the_rate_term_still_predicts(heating_and_cycling, fitted):
    _, _, X_op, _ = heating_and_cycling
    old = pickle.loads(pickle.dumps(fitted))
    del old.domain_.rate_columns_, old.domain_.rate_scale_
    box = fitted.domain_.box_._replace(rate_columns=())
    features = fitted.steps[0][1].transform(X_op)
    np.testing.assert_array_equal(old.calibration_distance(X_op), box_distance(box, features))


def test_fits_in_grid_search_and_pickles(heating_and_cycling):
    X, y, X_op, _ = heating_and_cycling
    search = GridSearchCV(
        make_compensation_pipeline(LinearRegression()),
        {"uncalibrated": ["blend", "none"]},
        cv=GroupKFold(n_splits=2),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        search.fit(X, y, groups=X["run"])
        again = pickle.loads(pickle.dumps(search.best_estimator_))
        np.testing.assert_array_equal(again.predict(X_op), search.best_estimator_.predict(X_op))
    assert again.domain_.margin == again.domain.margin == 1.5


def _real_table():
    frame = load_psim_tvc(drop_spikes=True).frame
    frame = frame.assign(second=np.floor(frame["time"].to_numpy()).astype(int))
    aggregation = {"time": "mean", "burst": "first", "temperature": "mean"}
    aggregation.update({axis: "mean" for axis in ("gyro_x", "gyro_y", "gyro_z")})
    return frame.groupby("second", as_index=False).agg(aggregation).assign(run=0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_real_recording_warm_to_cold_never_worse_than_uncompensated(seed):
    """The shipped recording, calibrated on its 12 warmer bursts and used on the 13 colder
    ones: the default is no worse than removing the calibration's mean drift, on every axis.
    The network alone (``uncalibrated="none"``) needs no rescue on x and y since its tail is
    penalised along the features' thin directions (issue 41; with a free tail it was
    thousands of times worse, ``bench_extrapolation.py``): below a fifth of uncompensated
    there. On z, where the gyro barely drifts, it is still worse than uncompensated, and
    the domain is what keeps the default safe.

    Checked once on model seeds 0-9 (holds on each); the suite runs 0-2."""
    table = _real_table()
    warm = (table["burst"] < 12).to_numpy()
    X = table[["run", "time", "temperature"]]
    for axis in ("gyro_x", "gyro_y", "gyro_z"):
        y = table[axis].to_numpy()
        model = make_compensation_pipeline(RBFNetRegressor(random_state=seed)).fit(
            X[warm], y[warm]
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OutsideCalibrationWarning)
            default = np.mean((y[~warm] - model.predict(X[~warm])) ** 2)
            model.set_params(uncalibrated="none")
            free = np.mean((y[~warm] - model.predict(X[~warm])) ** 2)
        uncompensated = np.mean((y[~warm] - y[warm].mean()) ** 2)
        assert default <= uncompensated, axis
        if axis == "gyro_z":
            assert free > uncompensated, axis
        else:
            assert free < 0.2 * uncompensated, axis
        assert model.outside_calibration(X[~warm]).all()
