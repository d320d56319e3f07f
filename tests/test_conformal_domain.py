"""ConformalRegressor around a CompensationPipeline: the band outside the calibration domain."""

import copy
import warnings

import numpy as np
import pytest
from _campaigns import rate_drift_table
from sklearn.linear_model import LinearRegression

from sklearn_ifog import ConformalRegressor, make_compensation_pipeline
from sklearn_ifog.conformal import conformal_quantile, run_quantile_scores
from sklearn_ifog.domain import OutsideCalibrationWarning, temperature_excess
from sklearn_ifog.pipeline import CompensationPipeline
from sklearn_ifog.policy import fallback_weight


def _conformal(policy="blend", **params):
    pipeline = make_compensation_pipeline(LinearRegression(), uncalibrated=policy)
    return ConformalRegressor(pipeline, coverage=0.9, **params)


@pytest.fixture(scope="module")
def warm_cold():
    """Calibrated on 10 to 40 degC, tested on -10 to 40 degC (other runs)."""
    X_warm, y_warm = rate_drift_table(0, (10.0, 40.0))
    X_cold, y_cold = rate_drift_table(100, (-10.0, 40.0))
    return X_warm, y_warm, X_cold, y_cold


@pytest.fixture(scope="module")
def fitted(warm_cold):
    X_warm, y_warm, _, _ = warm_cold
    return _conformal().fit(X_warm, y_warm)


def _outside_warnings(caught):
    return [w for w in caught if issubclass(w.category, OutsideCalibrationWarning)]


def _without_domain_terms(model, X):
    """The band of the same fitted model without the widening outside the domain."""
    predictions = np.stack([fold.predict(X) for fold in model.estimators_])
    return model.bounds_from_predictions(model.predict(X), predictions, model._raw_features(X))


def _degrees_beyond(model, X):
    """Degrees beyond the full model's calibrated temperatures of every row of X."""
    domain = model.estimator_.domain_
    rows = np.asarray(model.estimator_[0].transform(X), dtype=float)
    return temperature_excess(
        rows, domain.temperature_columns_, domain.data_min_, domain.data_max_
    )


def _folds(model, X):
    """(fold model, its held-out rows) of a model fitted with the default cv (run by run)."""
    runs = X["run"].to_numpy()
    return [
        (fold, runs == run) for fold, run in zip(model.estimators_, model.groups_, strict=True)
    ]


def test_fit_is_silent_and_predict_interval_warns_at_most_once(warm_cold):
    X_warm, y_warm, X_cold, _ = warm_cold
    with warnings.catch_warnings():
        # held-out runs outside their fold model's domain are part of the calibration
        warnings.simplefilter("error", OutsideCalibrationWarning)
        model = _conformal().fit(X_warm, y_warm)
    assert model.estimator_.outside_calibration(X_cold).any()
    for X, expected in ((X_warm, 0), (X_cold, 1)):
        for method in (model.predict_interval, model.predict):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                method(X)
            assert len(_outside_warnings(caught)) == expected


def test_out_of_fold_residuals_measure_the_fold_models_policy(fitted, warm_cold):
    """The fold models are clones of the CompensationPipeline: the out-of-fold predictions
    are their policy's, which differ from the regressor's own extrapolation outside."""
    X_warm, _, _, _ = warm_cold
    blended = 0
    for fold, held in _folds(fitted, X_warm):
        assert isinstance(fold, CompensationPipeline)
        assert fold.uncalibrated == "blend"
        X_held = X_warm[held]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OutsideCalibrationWarning)
            np.testing.assert_array_equal(fitted.oof_prediction_[held], fold.predict(X_held))
        regressor_only = fold[-1].predict(fold[:-1].transform(X_held))
        share = fallback_weight(fold.calibration_distance(X_held), fold.domain_.margin)
        np.testing.assert_array_equal(
            fitted.oof_prediction_[held][share == 0], regressor_only[share == 0]
        )
        assert np.all(fitted.oof_prediction_[held][share > 0] != regressor_only[share > 0])
        blended += int((share > 0).sum())
    assert blended > 0


def test_fallback_scores_are_each_fold_fallbacks_held_out_errors(fitted, warm_cold):
    X_warm, y_warm, _, _ = warm_cold
    for fold, held in _folds(fitted, X_warm):
        fallback = fold.fallback_.predict(fold[:1].transform(X_warm[held]))[:, 0]
        np.testing.assert_allclose(
            fitted.fallback_scores_[held], np.abs(y_warm[held] - fallback), rtol=1e-12
        )
    _, run_scores = run_quantile_scores(fitted.fallback_scores_, X_warm["run"], 0.9)
    assert fitted.fallback_quantile_ == conformal_quantile(run_scores, fitted.run_probability)
    assert fitted.fallback_quantile_ > 0


def test_band_is_unchanged_inside_and_holds_both_candidates_outside(fitted, warm_cold):
    X_warm, _, X_cold, _ = warm_cold
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        # inside the domain (the calibration rows): exactly the band without the terms
        np.testing.assert_array_equal(
            fitted.predict_interval(X_warm), _without_domain_terms(fitted, X_warm)
        )
        bounds = fitted.predict_interval(X_cold)
        plain = _without_domain_terms(fitted, X_cold)
        centre = fitted.predict(X_cold)
    full = fitted.estimator_
    share = fallback_weight(full.calibration_distance(X_cold), full.domain_.margin)
    assert (share == 1).sum() >= 20
    # unchanged where the prediction is the regressor's, within the calibrated temperatures
    beyond = _degrees_beyond(fitted, X_cold)
    kept = (share == 0) & (beyond == 0)
    assert kept.sum() >= 20
    np.testing.assert_array_equal(bounds[kept], plain[kept])
    # only ever wider than without the terms
    assert np.all(bounds[:, 0] <= plain[:, 0])
    assert np.all(bounds[:, 1] >= plain[:, 1])
    # the band holds the prediction and the regressor's own extrapolation, ...
    extrapolation = full[-1].predict(full[:-1].transform(X_cold))
    for value in (centre, extrapolation):
        assert np.all((bounds[:, 0] <= value) & (value <= bounds[:, 1]))
    # ... and where the prediction is the fallback's, at least its held-out error quantile
    width = bounds[:, 1] - bounds[:, 0]
    assert np.all(width[share == 1] >= 2 * fitted.fallback_quantile_)


def test_band_beyond_the_calibrated_temperatures_spans_the_slope(fitted, warm_cold):
    """Beyond the calibrated temperatures the drift may go on at its calibrated slope or
    stop: the band's half-width grows, in quadrature, by the slope times the degrees
    beyond; within the calibrated temperatures it is the band without that term."""
    X_warm, y_warm, X_cold, _ = warm_cold
    full = fitted.estimator_
    column = full.fallback_.column
    temperature = fitted._raw_features(X_warm)[:, column]
    # the plane's slope in T, not the line's (which the heating runs' rate term inflates)
    assert full.fallback_.rate_column is not None
    assert fitted.thermal_slope_ == full.fallback_.slope[0]
    assert fitted.thermal_slope_ == pytest.approx(0.003, rel=0.2)
    assert abs(np.polyfit(temperature, y_warm, 1)[0]) > 3 * abs(fitted.thermal_slope_)
    without = copy.copy(fitted)
    without.thermal_slope_ = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        bounds = fitted.predict_interval(X_cold)
        flat = without.predict_interval(X_cold)
        centre = fitted.predict(X_cold)
    raw = fitted._raw_features(X_cold)
    beyond = _degrees_beyond(fitted, X_cold)
    assert (beyond > 5.0).sum() >= 20
    np.testing.assert_array_equal(bounds[beyond == 0], flat[beyond == 0])
    # both bands are stretched by the same shift onto the regressor's own extrapolation
    shift = np.abs(full[-1].predict(raw) - centre)
    half = (bounds[:, 1] - bounds[:, 0] - shift) / 2
    flat_half = (flat[:, 1] - flat[:, 0] - shift) / 2
    np.testing.assert_allclose(
        half**2 - flat_half**2, (fitted.thermal_slope_ * beyond) ** 2, rtol=1e-6, atol=1e-12
    )


def test_bounds_from_the_fallback_share_are_predict_interval(fitted, warm_cold):
    """What a streaming compensator computes: the bounds from the fold predictions, the
    difficulty inputs and the full model's blend weight of every row."""
    _, _, X_cold, _ = warm_cold
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        predictions = np.stack([fold.predict(X_cold) for fold in fitted.estimators_])
        centre = fitted.predict(X_cold)
        expected = fitted.predict_interval(X_cold)
    full = fitted.estimator_
    share = fallback_weight(full.calibration_distance(X_cold), full.domain_.margin)
    raw = fitted._raw_features(X_cold)
    beyond = _degrees_beyond(fitted, X_cold)
    bounds = fitted.bounds_from_predictions(
        centre, predictions, raw, fallback_share=share, temperature_beyond=beyond
    )
    np.testing.assert_array_equal(bounds, expected)
    # without the degrees beyond, the band lacks the slope term there, and only there
    partial = fitted.bounds_from_predictions(centre, predictions, raw, fallback_share=share)
    np.testing.assert_array_equal(partial[beyond == 0], expected[beyond == 0])
    assert np.all(
        partial[beyond > 0, 1] - partial[beyond > 0, 0]
        < expected[beyond > 0, 1] - expected[beyond > 0, 0]
    )


def test_band_outside_grows_with_the_coverage(fitted, warm_cold):
    _, _, X_cold, _ = warm_cold
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        narrow = fitted.predict_interval(X_cold, coverage=0.8)
        wide = fitted.predict_interval(X_cold, coverage=0.95)
    assert fitted._fallback_quantile(0.95) > fitted._fallback_quantile(0.8)
    assert np.all(wide[:, 0] <= narrow[:, 0])
    assert np.all(wide[:, 1] >= narrow[:, 1])


@pytest.mark.parametrize(
    ("policy", "adaptive"), [("clip", True), ("none", True), ("blend", False)]
)
def test_no_domain_terms_without_a_fallback_or_adaptivity(warm_cold, policy, adaptive):
    X_warm, y_warm, X_cold, _ = warm_cold
    model = _conformal(policy, adaptive=adaptive).fit(X_warm, y_warm)
    assert model.fallback_scores_ is None
    assert model.fallback_quantile_ == 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        np.testing.assert_array_equal(
            model.predict_interval(X_cold), _without_domain_terms(model, X_cold)
        )


@pytest.mark.parametrize("seed", range(5))
def test_coverage_on_rows_outside_the_domain_every_seed(seed):
    """Calibrated warm, tested on other runs reaching 20 degC colder: on the rows outside the
    domain the band covers at least 0.85 (nominal 0.9 - 0.05); the terms outside the domain
    never narrow the band, widen it there, and never lose coverage.

    The fallback here is a plane in T and dT fitted on the warm runs, and this drift's line
    in T does go on beyond the calibration (which the calibration cannot know): most of the
    widening outside is the slope term. The test runs seeds 0-4.
    """
    X_warm, y_warm = rate_drift_table(seed, (10.0, 40.0))
    X_cold, y_cold = rate_drift_table(seed + 100, (-10.0, 40.0))
    model = _conformal().fit(X_warm, y_warm)
    outside = model.estimator_.outside_calibration(X_cold)
    assert outside.sum() >= 100
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        bounds = model.predict_interval(X_cold)
        plain = _without_domain_terms(model, X_cold)

    def coverage(band):
        rows = band[outside]
        return np.mean((rows[:, 0] <= y_cold[outside]) & (y_cold[outside] <= rows[:, 1]))

    width, plain_width = bounds[:, 1] - bounds[:, 0], plain[:, 1] - plain[:, 0]
    assert coverage(bounds) >= 0.85
    assert coverage(bounds) >= coverage(plain)
    assert np.all(width >= plain_width - 1e-12)
    assert width[outside].mean() >= 1.2 * plain_width[outside].mean()
