"""The calibration domain's threshold: calibrated on held-out runs, with a stated false-alarm
rate, and held to the margin where the held-out runs show nothing (new rates, new
temperatures)."""

import warnings

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression

from sklearn_ifog import make_compensation_pipeline
from sklearn_ifog.domain import (
    CalibrationDomain,
    SmallCalibrationWarning,
    box_distance,
    calibrated_threshold,
    fit_box,
    held_out_distances,
    held_out_folds,
)


def _runs(seed, n_runs, n_rows=200, tilt=0.05):
    """Runs of one profile: T sweeps the calibrated range at a steady rate, and a 'state'
    feature follows T with a run-specific tilt (``tilt``: its spread over runs), as a lag
    does with a run's own history: a new run's tilt is as new as a held-out run's."""
    rng = np.random.default_rng(seed)
    rows, labels = [], []
    for run in range(n_runs):
        t = np.linspace(10.0, 40.0, n_rows) + rng.normal(scale=0.3, size=n_rows)
        rate = 0.5 + rng.normal(scale=0.05, size=n_rows)
        state = 0.9 * t + rng.normal(scale=tilt) * (t - 25.0)
        state += rng.normal(scale=0.05, size=n_rows)
        rows.append(np.column_stack([t, rate, state]))
        labels.append(np.full(n_rows, run))
    return np.vstack(rows), np.concatenate(labels)


def test_folds_are_whole_runs_or_contiguous_blocks():
    np.testing.assert_array_equal(held_out_folds(10), np.repeat(np.arange(5), 2))
    # Two runs: the k-th fifth of each run is fold k, in the runs' own order.
    np.testing.assert_array_equal(
        held_out_folds(20, np.repeat(["b", "a"], 10)), np.tile(np.repeat(np.arange(5), 2), 2)
    )
    # Twelve runs: at most ten folds, runs dealt out in turn.
    folds = held_out_folds(24, np.repeat(np.arange(12), 2))
    np.testing.assert_array_equal(folds, np.repeat(np.arange(12) % 10, 2))
    with pytest.raises(ValueError, match=r"groups must hold one run label per calibration row"):
        held_out_folds(5, [0, 1])


def test_held_out_rows_beyond_the_others_temperatures_or_rates_are_left_out():
    X, runs = _runs(0, n_runs=3)
    folds = held_out_folds(X.shape[0], runs)
    every = held_out_distances(X, folds)
    by_temperature = held_out_distances(X, folds, temperature_columns=[0])
    by_both = held_out_distances(X, folds, rate_columns=[1], temperature_columns=[0])
    assert every.size == X.shape[0]
    assert by_both.size < by_temperature.size < every.size
    # Run by run, by hand: the box of the other runs, and the held-out run's rows within
    # the other runs' temperatures and rates.
    expected = []
    for run in range(3):
        kept, held = X[runs != run], X[runs == run]
        within = np.all(
            (held[:, :2] >= kept[:, :2].min(0)) & (held[:, :2] <= kept[:, :2].max(0)), 1
        )
        expected.append(box_distance(fit_box(kept, [1]), held[within]))
    np.testing.assert_allclose(by_both, np.concatenate(expected), rtol=1e-12, atol=1e-12)


def test_threshold_is_a_quantile_never_below_the_margin():
    assert calibrated_threshold(np.arange(101.0), alpha=0.1, floor=0.0) == pytest.approx(90.0)
    assert calibrated_threshold(np.arange(101.0), alpha=0.1, floor=95.0) == 95.0
    assert calibrated_threshold(np.arange(19.0), alpha=0.1, floor=0.0) is None
    with pytest.raises(ValueError, match=r"threshold \(alpha\).*NaN or infinite"):
        calibrated_threshold(np.r_[np.arange(30.0), np.nan], alpha=0.1, floor=0.0)


@pytest.mark.parametrize("alpha", [0.0, -0.1, 0.6, "0.02"])
def test_alpha_outside_its_range_is_refused_by_name(alpha):
    from sklearn_ifog.datasets import make_thermal_campaign

    X, _ = _runs(0, n_runs=3)
    with pytest.raises((ValueError, TypeError), match=r"'alpha' parameter"):
        CalibrationDomain(alpha=alpha, temperature=0, rate=1).fit(X)
    X, y = make_thermal_campaign(
        n_units=1,
        n_runs=1,
        azimuths=[0.0],
        sampling_period=300.0,
        random_state=0,
        return_X_y=True,
    )
    with pytest.raises((ValueError, TypeError), match=r"'alpha' parameter"):
        make_compensation_pipeline(LinearRegression(), alpha=alpha).fit(X, y)


def test_a_calibration_too_small_keeps_the_margin_and_says_so():
    X, runs = _runs(0, n_runs=1, n_rows=12)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        domain = CalibrationDomain(margin=1.5, temperature=0, rate=1).fit(X, groups=runs)
    small = [w for w in caught if w.category is SmallCalibrationWarning]
    assert len(small) == 1  # once per fit
    assert "alpha=0.02" in str(small[0].message)
    assert "the threshold is the margin" in str(small[0].message)
    assert domain.threshold_ == 1.5
    assert domain.boost_ == 0.0


@pytest.mark.parametrize(("temperature", "rate"), [(None, 1), (0, None), (None, None)])
def test_without_a_temperature_and_a_rate_column_the_margin_stays(temperature, rate):
    """The same runs that raise the threshold with both columns (checked first)."""
    X, runs = _runs(0, n_runs=3, tilt=0.5)
    both = CalibrationDomain(margin=1.5, temperature=0, rate=1).fit(X, groups=runs)
    assert both.threshold_ > 1.5
    domain = CalibrationDomain(margin=1.5, temperature=temperature, rate=rate)
    domain.fit(X, groups=runs)
    assert (domain.threshold_, domain.boost_, domain.n_held_out_) == (1.5, 0.0, 0)


def test_new_runs_of_a_calibrated_profile_are_flagged_at_about_alpha():
    """Over 20 seeds of three calibration runs and four new ones of the same profile: the
    share of a new run's rows (within the calibrated temperatures and rates) flagged stays
    near alpha, a rate over the seeds, while the margin alone flags more; the held-out runs
    raise the threshold above the margin on most seeds.

    The bounds are rates that hold on every block of 20 seeds checked (issue 42): over
    calibration seeds 0-399 in blocks of 20 (new runs from seed 100000 + seed), the mean
    share flagged was 0.009-0.081 (0.039 over all 400), the share of seeds at most 3 alpha
    0.80-1.00 (0.90), the threshold raised on 0.85-1.00 (0.95), and the margin alone
    flagged 1.36-5.2 times as many (1.83 over all; the earlier "more than twice" held on 8
    of the 20 blocks only). On this test's seeds: 0.027, 0.95, 0.95 and 2.7 times."""
    alpha, shares, margin_shares, raised = 0.05, [], [], []
    for seed in range(20):
        X, runs = _runs(seed, n_runs=3)
        domain = CalibrationDomain(alpha=alpha, temperature=0, rate=1).fit(X, groups=runs)
        new, _ = _runs(1000 + seed, n_runs=4)
        inside = np.all(
            (new[:, :2] >= domain.data_min_[:2]) & (new[:, :2] <= domain.data_max_[:2]), axis=1
        )
        rows = new[inside]
        shares.append(np.mean(domain.predict(rows) == -1))
        margin_shares.append(np.mean(domain.distance(rows) > domain.margin))
        raised.append(domain.threshold_ > domain.margin)
    assert np.mean(raised) >= 0.8
    assert np.mean(shares) <= 2 * alpha
    assert np.mean(np.array(shares) <= 3 * alpha) >= 0.8
    assert np.mean(margin_shares) > 1.3 * np.mean(shares)


def test_true_extrapolation_is_still_caught_beyond_rates_and_temperatures():
    """On every seed whose held-out runs raised the threshold (of 20): a temperature beyond
    the calibrated range and a cooling row at a calibrated temperature are outside."""
    checked = 0
    for seed in range(20):
        X, runs = _runs(seed, n_runs=3)
        domain = CalibrationDomain(temperature=0, rate=1).fit(X, groups=runs)
        if domain.threshold_ <= domain.margin:
            continue
        checked += 1
        centre = X.mean(axis=0)
        warm = [[domain.data_max_[0] + 0.1, centre[1], centre[2]]]
        assert domain.predict(warm)[0] == -1
        # Held to the margin, not the threshold: a rate the held-out runs never showed.
        cooling = np.array([[25.0, domain.data_min_[1] - X[:, 1].std(), 0.9 * 25.0]])
        assert domain.distance(cooling)[0] > domain.threshold_
        assert domain.predict(cooling)[0] == -1
    assert checked >= 10


def test_distance_is_continuous_where_a_rate_leaves_its_range():
    """The boost comes in over a short ramp: the distance has no step at the calibrated
    rate's edge (its change shrinks with the step), and holds the row to the margin once
    the ramp is passed.

    Holds on every seed of 0-199 (``_runs(seed, n_runs=3)``, checked once, issue 42) whose
    held-out runs raise the threshold, so that there is a boost: 191 of them (not 30, 87,
    104, 131, 158, 179, 182, 185, 187); the test runs seed 2."""
    X, runs = _runs(2, n_runs=3)
    domain = CalibrationDomain(temperature=0, rate=1).fit(X, groups=runs)
    assert domain.boost_ > 0
    edge = domain.data_max_[1]
    steps = (0.0, 1e-12, 1e-10, 1e-8)
    rows = np.array([[25.0, edge + step, 0.9 * 25.0] for step in steps])
    change = domain.distance(rows) - domain.distance(rows[:1])
    assert np.all(np.diff(change) >= 0)
    assert change[1] < 1e-6
    assert change[2] < 1e-4
    # Past the ramp (a hundredth of the rate's standard deviation) the whole boost is added.
    past = np.array([[25.0, edge + 0.02 * X[:, 1].std(), 0.9 * 25.0]])
    assert domain.distance(past)[0] >= domain.boost_


def test_the_pipeline_calibrates_on_its_runs_and_searches_alpha():
    from sklearn_ifog.datasets import make_thermal_campaign

    X, y = make_thermal_campaign(
        n_units=1, n_runs=2, sampling_period=120.0, random_state=0, return_X_y=True
    )
    model = make_compensation_pipeline(LinearRegression(), alpha=0.1)
    assert model.get_params()["domain__alpha"] == 0.1
    model.fit(X, y)
    domain = model.domain_
    assert domain.alpha == 0.1
    assert domain.n_held_out_ > 0
    assert domain.threshold_ >= model.domain.margin
    # Its calibration is inside its own domain, and its runs held out set the threshold.
    assert not model.outside_calibration(X).any()
    folds = held_out_folds(len(X), X["run"].to_numpy())
    raw = np.asarray(model[0].transform(X), dtype=np.float64)
    distances = held_out_distances(raw, folds, domain.rate_columns_, domain.temperature_columns_)
    expected = max(model.domain.margin, np.quantile(distances, 0.9))
    assert domain.threshold_ == pytest.approx(expected)


@pytest.fixture(scope="module")
def six_runs():
    """One gyro's six runs whose temperature ranges differ: a held-out run reaches
    temperatures the other runs did not."""
    from sklearn_ifog.datasets import make_thermal_campaign

    X, _ = make_thermal_campaign(
        n_units=1,
        n_runs=6,
        azimuths=[0.0],
        sampling_period=120.0,
        random_state=0,
        return_X_y=True,
    )
    features = make_compensation_pipeline(LinearRegression())[0].fit(X)
    raw = np.asarray(features.transform(X), dtype=np.float64)
    return X, raw, list(features.get_feature_names_out())


def test_handover_is_off_by_default_and_changes_nothing_then(six_runs):
    X, raw, names = six_runs
    y = 0.05 * raw[:, names.index("T_lag3600s")]
    plain = make_compensation_pipeline(LinearRegression()).fit(X, y)
    assert plain.handover_ is None
    domain = plain.domain_
    np.testing.assert_array_equal(domain.boost_low_, domain.data_min_[[0]])
    np.testing.assert_array_equal(domain.rate_low_, domain.data_min_[domain.rate_columns_])


def test_handover_widens_only_where_the_model_beat_its_fallback(six_runs):
    """A drift that follows a lag: the linear model on the features is exact, the fallback
    (a line or plane in T and dT) is not, so on the held-out runs' rows beyond the others'
    temperatures the model wins and the domain lets it keep them that far. A model that
    predicts a constant loses to the fallback on an exact line in T: nothing widens."""
    from sklearn.dummy import DummyRegressor

    X, raw, names = six_runs
    lag = 0.05 * raw[:, names.index("T_lag3600s")]
    winner = make_compensation_pipeline(LinearRegression(), handover=True).fit(X, lag)
    plain = make_compensation_pipeline(LinearRegression()).fit(X, lag)
    colder = winner.handover_["temperatures below"]
    assert colder["keeps"]
    assert colder["rows"] >= 20
    assert colder["model"] < colder["fallback"]
    expected = plain.domain_.boost_low_ - colder["extent"]
    np.testing.assert_allclose(winner.domain_.boost_low_, expected)
    # The firmware rule is not widened: a row colder than the calibration is still outside.
    np.testing.assert_array_equal(winner.domain_.data_min_, plain.domain_.data_min_)
    cold = X[X["run"] == X["run"].iloc[0]].assign(temperature=lambda t: t["temperature"] - 40)
    assert winner.outside_calibration(cold).all()
    # Kinds the model did not win keep the calibrated domain.
    for kind, entry in winner.handover_.items():
        if not entry["keeps"] and kind.startswith("rates"):
            side = 0 if kind.endswith("below") else 1
            ranges = (winner.domain_.rate_low_, winner.domain_.rate_high_)[side]
            calibrated = (plain.domain_.rate_low_, plain.domain_.rate_high_)[side]
            np.testing.assert_array_equal(ranges, calibrated)
    line = 0.3 * raw[:, names.index("T")]
    loser = make_compensation_pipeline(DummyRegressor(), handover=True).fit(X, line)
    assert not any(entry["keeps"] for entry in loser.handover_.values())
    alone = make_compensation_pipeline(DummyRegressor()).fit(X, line)
    assert loser.domain_.threshold_ == alone.domain_.threshold_
    np.testing.assert_array_equal(loser.domain_.boost_low_, alone.domain_.boost_low_)
    np.testing.assert_array_equal(loser.domain_.boost_high_, alone.domain_.boost_high_)


def test_handover_needs_three_runs(six_runs):
    X, raw, names = six_runs
    two = X[X["run"].isin(np.unique(X["run"])[:2])]
    y = 0.05 * raw[two.index, names.index("T_lag3600s")]
    model = make_compensation_pipeline(LinearRegression(), handover=True).fit(two, y)
    assert model.handover_ is None
    with pytest.raises((ValueError, TypeError), match=r"'handover' parameter"):
        make_compensation_pipeline(LinearRegression(), handover="yes").fit(two, y)
