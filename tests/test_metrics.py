"""Tests of sklearn_ifog.metrics: MSD, Earth rate, Allan deviation, bias stability, scorers."""

import pickle

import allantools
import numpy as np
import pandas as pd
import pytest
from sklearn.datasets import make_regression
from sklearn.linear_model import Ridge
from sklearn.metrics import mean_squared_error
from sklearn.model_selection import GridSearchCV, KFold

from sklearn_ifog.metrics import (
    EARTH_ROTATION_RATE,
    allan_deviation,
    angle_random_walk,
    bias_instability,
    bias_stability,
    earth_rate,
    get_scorer,
    get_scorer_names,
    mean_squared_deviation,
    neg_mean_squared_deviation_scorer,
)


# --------------------------------------------------------------------------- MSD
def test_msd_is_mean_of_squared_deviation():
    reference = np.array([10.0, 10.0, 10.0, 10.0])
    compensated = np.array([10.1, 9.8, 10.0, 10.3])
    expected = (0.01 + 0.04 + 0.0 + 0.09) / 4
    assert mean_squared_deviation(reference, compensated) == pytest.approx(expected, rel=1e-12)


def test_msd_of_compensated_rate_equals_mse_of_drift():
    rng = np.random.default_rng(0)
    reference = np.full(200, 7.52)
    rate = reference + 0.2 * np.sin(np.linspace(0, 6, 200)) + 0.01 * rng.standard_normal(200)
    predicted_drift = 0.19 * np.sin(np.linspace(0, 6, 200))
    msd = mean_squared_deviation(reference, rate - predicted_drift)
    mse = mean_squared_deviation(rate - reference, predicted_drift)
    assert msd == pytest.approx(mse, rel=1e-10)
    assert msd == pytest.approx(np.mean((rate - predicted_drift - reference) ** 2), rel=1e-12)


def test_msd_weights_and_multioutput():
    y_true = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
    y_pred = np.array([[1.0, 1.0], [2.0, 1.5], [0.0, 3.0]])
    weights = np.array([1.0, 2.0, 1.0])
    per_axis = mean_squared_deviation(y_true, y_pred, multioutput="raw_values")
    np.testing.assert_allclose(per_axis, [5 / 3, (0.25 + 4) / 3])
    weighted = mean_squared_deviation(
        y_true, y_pred, sample_weight=weights, multioutput="raw_values"
    )
    np.testing.assert_allclose(weighted, [(1 + 8 + 0) / 4, (0 + 0.5 + 4) / 4])
    assert mean_squared_deviation(y_true, y_pred) == pytest.approx(per_axis.mean())
    assert mean_squared_deviation(y_true, y_pred, multioutput=[0.0, 1.0]) == pytest.approx(
        per_axis[1]
    )


@pytest.mark.parametrize(
    ("y_true", "y_pred", "kwargs", "error", "match"),
    [
        ([1.0, 2.0], [1.0, 2.0, 3.0], {}, ValueError, "same number of samples, got 2 and 3"),
        ([1.0, np.nan], [1.0, 2.0], {}, ValueError, "y_true contains NaN"),
        ([1.0, 2.0], [1.0, np.inf], {}, ValueError, "y_pred contains infinity"),
        ([1.0, 2.0], [1.0, 2.0], {"multioutput": "mean"}, ValueError, "'multioutput' parameter"),
        (
            [1.0, 2.0],
            [1.0, 2.0],
            {"sample_weight": [1.0]},
            ValueError,
            r"sample_weight.shape == \(1,\), expected \(2,\)",
        ),
    ],
)
def test_msd_errors(y_true, y_pred, kwargs, error, match):
    with pytest.raises(error, match=match):
        mean_squared_deviation(y_true, y_pred, **kwargs)


# --------------------------------------------------------------------------- Earth rate
def test_earth_rate_values():
    assert pytest.approx(7.2921150e-5 * 180 / np.pi * 3600, rel=1e-7) == EARTH_ROTATION_RATE
    assert earth_rate(0.0) == pytest.approx(15.041067, abs=1e-9)
    assert isinstance(earth_rate(45.0, 30.0), float)
    assert earth_rate(45.0, 30.0) == pytest.approx(15.041067 * np.sqrt(0.5) * np.sqrt(3) / 2)
    assert earth_rate(90.0) == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(
        earth_rate(60.0, [0.0, 90.0, 180.0, 270.0]),
        [7.5205335, 0.0, -7.5205335, 0.0],
        atol=1e-7,
    )


def test_earth_rate_broadcasts():
    latitudes = np.array([[0.0], [30.0], [60.0]])
    azimuths = np.array([0.0, 45.0, 90.0, 135.0])
    rate = earth_rate(latitudes, azimuths)
    assert rate.shape == (3, 4)
    np.testing.assert_allclose(
        rate,
        15.041067 * np.cos(np.deg2rad(latitudes)) * np.cos(np.deg2rad(azimuths)),
        rtol=1e-14,
    )


@pytest.mark.parametrize(
    ("latitude", "azimuth", "match"),
    [
        (91.0, 0.0, r"latitude must be in \[-90, 90\] degrees, got 91.0"),
        ([10.0, -95.0], 0.0, "got -95.0"),
        (np.nan, 0.0, "latitude must be finite"),
        (10.0, [0.0, np.inf], "azimuth must be finite"),
        ("north", 0.0, "'latitude' parameter of earth_rate"),
    ],
)
def test_earth_rate_errors(latitude, azimuth, match):
    with pytest.raises(ValueError, match=match):
        earth_rate(latitude, azimuth)


# --------------------------------------------------------------------------- Allan deviation
def _series(kind, n_samples, seed):
    rng = np.random.default_rng(seed)
    if kind == "white":
        return 0.5 * rng.standard_normal(n_samples)
    if kind == "random_walk_on_large_bias":
        # A large mean and a random walk: the cumulative sums must stay accurate.
        return 1.0e3 + np.cumsum(0.01 * rng.standard_normal(n_samples))
    if kind == "drift_and_sine":
        t = np.arange(n_samples)
        return 7.5 + 1e-4 * t + 0.3 * np.sin(t / 37.0) + 0.05 * rng.standard_normal(n_samples)
    raise AssertionError(kind)


@pytest.mark.parametrize("kind", ["white", "random_walk_on_large_bias", "drift_and_sine"])
@pytest.mark.parametrize("n_samples", [3, 10, 1000, 1023, 1024, 4097])
@pytest.mark.parametrize("sample_period", [1.0, 0.02, 3.7])
@pytest.mark.parametrize("taus", ["octave", "decade"])
@pytest.mark.parametrize("overlapping", [True, False])
def test_allan_deviation_matches_allantools_keywords(
    kind, n_samples, sample_period, taus, overlapping
):
    rate = _series(kind, n_samples, seed=n_samples)
    reference_function = allantools.oadev if overlapping else allantools.adev
    ref_taus, ref_adev, _, ref_n = reference_function(
        rate, rate=1.0 / sample_period, data_type="freq", taus=taus
    )
    result_taus, adev, _, n_terms = allan_deviation(
        rate, sample_period=sample_period, taus=taus, overlapping=overlapping, return_error=True
    )
    np.testing.assert_allclose(result_taus, ref_taus, rtol=1e-12)
    np.testing.assert_allclose(adev, ref_adev, rtol=1e-10, atol=0)
    np.testing.assert_array_equal(n_terms, ref_n)


@pytest.mark.parametrize("overlapping", [True, False])
@pytest.mark.parametrize(
    "taus", [[0.1, 0.3, 2.0], [0.5, 1.0, 1.5, 2.0, 10.0, 50.0], np.arange(1, 40) * 0.1]
)
def test_allan_deviation_matches_allantools_explicit_taus(taus, overlapping):
    rate = _series("drift_and_sine", 1500, seed=3)
    reference_function = allantools.oadev if overlapping else allantools.adev
    ref_taus, ref_adev, _, _ = reference_function(rate, rate=10.0, data_type="freq", taus=taus)
    result_taus, adev = allan_deviation(
        rate, sample_period=0.1, taus=taus, overlapping=overlapping
    )
    np.testing.assert_allclose(result_taus, ref_taus, rtol=1e-12)
    np.testing.assert_allclose(adev, ref_adev, rtol=1e-10, atol=0)


def test_allan_deviation_explicit_taus_rounded_in_given_order():
    rate = _series("white", 100, seed=1)
    taus, adev = allan_deviation(rate, taus=[4.2, 1.0, 3.9])
    np.testing.assert_array_equal(taus, [4.0, 1.0, 4.0])
    assert adev[0] == adev[2]
    _, reference = allan_deviation(rate, taus=[1.0, 4.0])
    np.testing.assert_array_equal(adev[[1, 0]], reference)


def test_allan_deviation_columns_are_independent_series():
    rate = np.column_stack([_series("white", 900, seed=s) for s in range(3)])
    taus, adev = allan_deviation(rate, sample_period=0.5)
    assert adev.shape == (taus.size, 3)
    for column in range(3):
        _, single = allan_deviation(rate[:, column], sample_period=0.5)
        np.testing.assert_allclose(adev[:, column], single, rtol=1e-14)


def test_allan_deviation_of_white_noise_follows_theory():
    # White rate noise of standard deviation s per sample: sigma(tau) = s * sqrt(tau0 / tau).
    """Checked once on noise seeds 42-51 (holds on each)."""
    rng = np.random.default_rng(42)
    sample_period, s = 0.01, 2.0
    rate = s * rng.standard_normal(200_000)
    taus, adev, adev_error, _ = allan_deviation(
        rate, sample_period=sample_period, taus=[0.01, 0.1, 1.0, 10.0], return_error=True
    )
    theory = s * np.sqrt(sample_period / taus)
    # IEEE 952 Annex C uncertainty: 1 / sqrt(2 (N/m - 1)); 4 sigma bound.
    np.testing.assert_array_less(np.abs(adev - theory), 4 * adev_error)
    np.testing.assert_allclose(
        adev_error / adev, 1 / np.sqrt(2 * (200_000 // np.array([1, 10, 100, 1000]) - 1))
    )


def test_allan_deviation_ignores_constant_offset():
    rate = _series("drift_and_sine", 2000, seed=0)
    _, adev = allan_deviation(rate)
    _, shifted = allan_deviation(rate + 15.041067)
    np.testing.assert_allclose(shifted, adev, rtol=1e-9)


@pytest.mark.parametrize(
    ("rate", "kwargs", "match"),
    [
        ([1.0, 2.0], {}, "rate has 2 samples: too few"),
        ([1.0, np.nan, 3.0, 4.0], {}, "Input rate contains NaN"),
        ([1.0, 2.0, 3.0, np.inf], {}, "Input rate contains infinity"),
        (np.ones((4, 2, 2)), {}, "dim 3"),
        (np.ones(10), {"sample_period": 0.0}, "'sample_period' parameter of allan_deviation"),
        (np.ones(10), {"sample_period": -1.0}, "'sample_period' parameter"),
        (np.ones(10), {"taus": "all"}, "'taus' parameter of allan_deviation"),
        (np.ones(10), {"taus": [0.2]}, r"at least half the sample_period \(1.0 s\); got 0.2"),
        (np.ones(10), {"taus": [1.0, 5.0]}, r"tau=5.0 s is too long for 10 samples.*4.0 s"),
        (np.ones(10), {"taus": [4.0], "overlapping": False}, r"tau <= 3.0 s"),
        (np.ones(10), {"taus": [[1.0, 2.0]]}, "taus must be 1-D"),
    ],
)
def test_allan_deviation_errors(rate, kwargs, match):
    with pytest.raises(ValueError, match=match):
        allan_deviation(rate, **kwargs)


# --------------------------------------------------------------------------- ARW / BI readers
def test_angle_random_walk_from_white_noise():
    # ARW of 0.005 deg/sqrt(h) sampled at 10 Hz: per-sample sigma = ARW * 60 / sqrt(tau0).
    arw, sample_period = 0.005, 0.1
    rng = np.random.default_rng(7)
    rate = arw * 60 / np.sqrt(sample_period) * rng.standard_normal(100_000)
    taus, adev = allan_deviation(rate, sample_period=sample_period)
    assert angle_random_walk(taus, adev) == pytest.approx(arw, rel=0.05)


def test_angle_random_walk_picks_the_minus_half_slope():
    taus = np.array([1.0, 10.0, 100.0, 1000.0, 10000.0])
    # quantisation (slope -1), then white noise (slope -1/2), then flat.
    adev = np.array([3.0, 0.3, 0.3 / np.sqrt(10), 0.1, 0.1])
    expected = 0.3 * np.sqrt(10.0) / 60.0
    assert angle_random_walk(taus, adev) == pytest.approx(expected, rel=1e-12)
    per_series = angle_random_walk(taus, np.column_stack([adev, 2 * adev]))
    np.testing.assert_allclose(per_series, [expected, 2 * expected], rtol=1e-12)


def test_bias_instability_reads_the_minimum():
    taus = [1.0, 10.0, 100.0, 1000.0]
    adev = [0.2, 0.05, 0.03, 0.04]
    expected = 0.03 / np.sqrt(2 * np.log(2) / np.pi)
    assert bias_instability(taus, adev) == pytest.approx(expected, rel=1e-12)
    assert expected == pytest.approx(0.03 / 0.664, rel=1e-3)
    np.testing.assert_allclose(
        bias_instability(taus, np.column_stack([adev, adev[::-1]])), [expected, expected]
    )


@pytest.mark.parametrize("reader", [angle_random_walk, bias_instability])
@pytest.mark.parametrize(
    ("taus", "adev", "match"),
    [
        ([1.0, 2.0], [1.0], "n_taus=2"),
        ([1.0], [1.0], "at least 2 points"),
        ([2.0, 1.0], [1.0, 1.0], "strictly increasing"),
        ([1.0, 2.0], [1.0, 0.0], "adev must be positive"),
        ([1.0, 2.0], [1.0, np.nan], "adev contains NaN"),
    ],
)
def test_allan_readers_errors(reader, taus, adev, match):
    with pytest.raises(ValueError, match=match):
        reader(taus, adev)


# --------------------------------------------------------------------------- bias stability
def test_bias_stability_by_hand():
    rng = np.random.default_rng(5)
    rate = 3.0 + 0.2 * rng.standard_normal(1050)
    # 0.5 s samples, 100 s windows: 200 samples each, 5 windows, 50 samples left over.
    means = rate[:1000].reshape(5, 200).mean(axis=1)
    expected = np.std(means, ddof=1)
    assert bias_stability(rate, sample_period=0.5, window=100.0) == pytest.approx(
        expected, rel=1e-12
    )
    # The trailing incomplete window is not used.
    changed = rate.copy()
    changed[1000:] += 100.0
    assert bias_stability(changed, sample_period=0.5) == bias_stability(rate, sample_period=0.5)


def test_bias_stability_columns_and_float_period():
    rng = np.random.default_rng(6)
    rate = rng.standard_normal((3000, 2))
    both = bias_stability(rate, sample_period=0.02, window=10.0)  # 10 / 0.02 = 500 samples
    assert both.shape == (2,)
    for column in range(2):
        means = rate[:, column].reshape(6, 500).mean(axis=1)
        assert both[column] == pytest.approx(np.std(means, ddof=1), rel=1e-12)


@pytest.mark.parametrize(
    ("rate", "kwargs", "match"),
    [
        (np.ones(199), {}, r"199 samples \(199.0 s\).*two full windows of 100.0 s \(200 samples"),
        (np.ones(500), {"window": 2.5}, r"window \(2.5 s\) must be a whole multiple"),
        (np.ones(500), {"window": 0.0}, "'window' parameter of bias_stability"),
        (np.ones(500), {"sample_period": np.nan}, "'sample_period' parameter"),
        (np.r_[np.ones(499), np.nan], {}, "Input rate contains NaN"),
    ],
)
def test_bias_stability_errors(rate, kwargs, match):
    with pytest.raises(ValueError, match=match):
        bias_stability(rate, **kwargs)


# --------------------------------------------------------------------------- scorers
def test_scorer_in_grid_search_equals_minus_msd():
    X, y = make_regression(n_samples=90, n_features=3, noise=5.0, random_state=0)
    cv = KFold(n_splits=3, shuffle=True, random_state=0)
    alphas = [0.1, 100.0]
    search = GridSearchCV(
        Ridge(), {"alpha": alphas}, scoring=neg_mean_squared_deviation_scorer, cv=cv
    ).fit(X, y)
    for candidate, alpha in enumerate(alphas):
        for fold, (train, test) in enumerate(cv.split(X)):
            model = Ridge(alpha=alpha).fit(X[train], y[train])
            by_hand = np.mean((y[test] - model.predict(X[test])) ** 2)
            score = search.cv_results_[f"split{fold}_test_score"][candidate]
            assert score == pytest.approx(-by_hand, rel=1e-10)
    assert search.best_params_ == {"alpha": 0.1}
    assert search.best_score_ < 0


def test_get_scorer():
    scorer = get_scorer("neg_mean_squared_deviation")
    assert scorer is not neg_mean_squared_deviation_scorer
    X, y = make_regression(n_samples=30, n_features=2, random_state=1)
    model = Ridge().fit(X, y)
    assert scorer(model, X, y) == pytest.approx(-mean_squared_error(y, model.predict(X)))
    restored = pickle.loads(pickle.dumps(scorer))
    assert restored(model, X, y) == scorer(model, X, y)
    assert get_scorer("r2")(model, X, y) == pytest.approx(model.score(X, y))
    assert get_scorer(neg_mean_squared_deviation_scorer) is neg_mean_squared_deviation_scorer
    names = get_scorer_names()
    ours = ["interval_coverage", "neg_interval_score", "neg_mean_interval_width"]
    assert names[:4] == sorted([*ours, "neg_mean_squared_deviation"])
    assert "r2" in names
    assert len(names) == len(set(names))
    with pytest.raises(ValueError, match="'nope' is not a valid scoring value"):
        get_scorer("nope")


# -- per_run_metrics ----------------------------------------------------------------------


def _two_runs(rng):
    n = 400
    time = np.tile(np.arange(n, dtype=float), 2)
    run = np.repeat([7, 3], n)
    temperature = 20.0 + np.where(run == 7, 0.02, -0.02) * time
    drift = 0.05 * (temperature - 20.0)
    reference = 10.0
    rate = reference + drift + rng.normal(0.0, 0.01, 2 * n)
    predicted = drift + rng.normal(0.0, 0.002, 2 * n)
    return dict(rate=rate, drift=predicted, reference=reference, temperature=temperature,
                time=time, run=run)  # fmt: skip


def test_per_run_metrics_measures_each_run_and_all_runs():
    from sklearn_ifog.metrics import bias_stability, per_run_metrics

    data = _two_runs(np.random.default_rng(0))
    table = per_run_metrics(**data)
    assert table.index.tolist() == [7, 3, "(all runs)"]  # order of first appearance
    compensated = data["rate"] - data["drift"]
    for label in (7, 3):
        rows = data["run"] == label
        before = np.mean((data["rate"][rows] - 10.0) ** 2)
        after = np.mean((compensated[rows] - 10.0) ** 2)
        assert table.loc[label, "samples"] == rows.sum()
        assert table.loc[label, "hours"] == pytest.approx(399.0 / 3600.0)
        assert table.loc[label, "T_min"] == data["temperature"][rows].min()
        assert table.loc[label, "msd_before"] == pytest.approx(before, rel=1e-12)
        assert table.loc[label, "msd_after"] == pytest.approx(after, rel=1e-12)
        assert table.loc[label, "reduction"] == pytest.approx(before / after, rel=1e-12)
        expected = bias_stability(compensated[rows] - 10.0, sample_period=1.0, window=100.0)
        assert table.loc[label, "bias_stab_after"] == pytest.approx(expected, rel=1e-12)
    overall = table.loc["(all runs)"]
    assert overall["samples"] == 800
    assert overall["msd_after"] == pytest.approx(np.mean((compensated - 10.0) ** 2), rel=1e-12)
    assert np.isnan(overall["bias_stab_before"])


def test_per_run_metrics_does_not_depend_on_how_runs_are_interleaved():
    from sklearn_ifog.metrics import per_run_metrics

    data = _two_runs(np.random.default_rng(1))
    order = np.argsort(np.tile(np.arange(400), 2), kind="stable")  # rows alternate 7, 3, 7, ...
    shuffled = {key: value[order] if np.ndim(value) else value for key, value in data.items()}
    pd.testing.assert_frame_equal(per_run_metrics(**shuffled), per_run_metrics(**data))


def test_per_run_metrics_without_runs_or_time_and_bad_shapes():
    from sklearn_ifog.metrics import per_run_metrics

    data = _two_runs(np.random.default_rng(2))
    one = per_run_metrics(
        rate=data["rate"][:50], drift=data["drift"][:50], reference=10.0,
        temperature=data["temperature"][:50],
    )  # fmt: skip
    assert one.index.tolist() == ["(all runs)"]
    assert one.loc["(all runs)", "hours"] == pytest.approx(49.0 / 3600.0)  # 1 s per sample
    assert np.isnan(one.loc["(all runs)", "bias_stab_before"])  # shorter than two windows
    with pytest.raises(ValueError, match="temperature has shape"):
        per_run_metrics(rate=data["rate"], drift=data["drift"], reference=10.0,
                        temperature=data["temperature"][:5])  # fmt: skip
