"""Bad input to the conformal band and the calibration domain: a clear error naming the
argument and what was expected, never a band silently widened, dropped or NaN (issue 42)."""

import warnings

import numpy as np
import pytest
from _campaigns import rate_drift_table
from sklearn.linear_model import LinearRegression

from sklearn_ifog import ConformalRegressor, make_compensation_pipeline
from sklearn_ifog.conformal import (
    conformal_quantile,
    extrapolation_variance,
    knn_distance,
    plus_interval,
    run_quantile_scores,
    thermal_slope,
)
from sklearn_ifog.domain import CalibrationDomain, OutsideCalibrationWarning, temperature_excess
from sklearn_ifog.policy import fallback_weight


@pytest.fixture(scope="module")
def band_inputs():
    """A blending model calibrated warm, and the inputs of its band on colder runs."""
    X_warm, y_warm = rate_drift_table(0, (10.0, 40.0))
    X_cold, _ = rate_drift_table(100, (-10.0, 40.0))
    pipeline = make_compensation_pipeline(LinearRegression(), uncalibrated="blend")
    model = ConformalRegressor(pipeline, coverage=0.9).fit(X_warm, y_warm)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        centre = model.predict(X_cold)
        folds = np.stack([fold.predict(X_cold) for fold in model.estimators_])
        expected = model.predict_interval(X_cold)
    full = model.estimator_
    domain = full.domain_
    share = fallback_weight(full.calibration_distance(X_cold), domain.margin)
    rows = np.asarray(full[0].transform(X_cold), dtype=float)
    beyond = temperature_excess(
        rows, domain.temperature_columns_, domain.data_min_, domain.data_max_
    )
    inputs = {
        "centre": centre,
        "fold_predictions": folds,
        "difficulty_features": model._raw_features(X_cold),
        "fallback_share": share,
        "temperature_beyond": beyond,
    }
    return model, inputs, expected


def _bounds(model, inputs, **changes):
    arguments = {**inputs, **changes}
    return model.bounds_from_predictions(
        arguments["centre"],
        arguments["fold_predictions"],
        arguments["difficulty_features"],
        fallback_share=arguments["fallback_share"],
        temperature_beyond=arguments["temperature_beyond"],
    )


def test_the_inputs_as_given_are_the_band_of_predict_interval(band_inputs):
    """The valid inputs (share 0 to 1 included, degrees 0 and beyond) still pass, bit for
    bit, so the checks below reject only bad input."""
    model, inputs, expected = band_inputs
    assert inputs["fallback_share"].min() == 0.0
    assert inputs["fallback_share"].max() == 1.0
    assert inputs["temperature_beyond"].min() == 0.0
    assert inputs["temperature_beyond"].max() > 0.0
    np.testing.assert_array_equal(_bounds(model, inputs), expected)


def test_a_share_or_degrees_of_the_wrong_length_name_the_argument(band_inputs):
    model, inputs, _ = band_inputs
    n = inputs["centre"].shape[0]
    for name in ("fallback_share", "temperature_beyond"):
        short = inputs[name][:-1]
        with pytest.raises(
            ValueError, match=rf"{name} must have shape \({n},\), got \({n - 1},\)"
        ):
            _bounds(model, inputs, **{name: short})
        column = inputs[name][:, None]
        with pytest.raises(ValueError, match=rf"{name} must have shape \({n},\), got \({n}, 1\)"):
            _bounds(model, inputs, **{name: column})


def test_difficulty_features_of_the_wrong_width_or_length_name_the_argument(band_inputs):
    model, inputs, _ = band_inputs
    raw = inputs["difficulty_features"]
    n, width = raw.shape
    assert width == model.feature_mean_.shape[0]
    with pytest.raises(
        ValueError, match=rf"difficulty_features must have shape \({n}, {width}\), got \({n}, "
    ):
        _bounds(model, inputs, difficulty_features=raw[:, :-1])
    with pytest.raises(
        ValueError, match=rf"difficulty_features must have shape \({n}, {width}\), got \({n - 2}, "
    ):
        _bounds(model, inputs, difficulty_features=raw[:-2])
    with pytest.raises(ValueError, match="difficulty_features must be finite"):
        _bounds(model, inputs, difficulty_features=np.where(raw == raw[3, 0], np.nan, raw))


@pytest.mark.parametrize("share", [5.0, 1.5, -0.1])
def test_a_share_outside_0_1_is_refused_not_a_wider_band(band_inputs, share):
    """A share of 5 used to widen the band silently."""
    model, inputs, _ = band_inputs
    shares = inputs["fallback_share"].copy()
    shares[7] = share
    with pytest.raises(ValueError, match=r"fallback_share must be a weight in \[0, 1\]"):
        _bounds(model, inputs, fallback_share=shares)
    with pytest.raises(ValueError, match=r"fallback_share must be a weight in \[0, 1\]"):
        _bounds(model, inputs, fallback_share=np.full_like(shares, share))


@pytest.mark.parametrize("where", ["one", "all"])
def test_a_nan_share_is_refused_not_nan_bounds_nor_a_dropped_term(band_inputs, where):
    """One NaN share gave NaN bounds; an all-NaN share dropped the fallback term."""
    model, inputs, _ = band_inputs
    shares = inputs["fallback_share"].copy()
    if where == "one":
        shares[np.argmax(shares)] = np.nan
    else:
        shares[:] = np.nan
    with pytest.raises(ValueError, match=r"fallback_share must be a weight in .* got nan"):
        _bounds(model, inputs, fallback_share=shares)


@pytest.mark.parametrize("bad", [-2.0, np.nan, np.inf])
def test_negative_or_nan_degrees_beyond_are_refused(band_inputs, bad):
    """A negative number of degrees beyond the calibrated range used to widen the band."""
    model, inputs, _ = band_inputs
    beyond = inputs["temperature_beyond"].copy()
    beyond[0] = bad
    with pytest.raises(ValueError, match="temperature_beyond must be a number of degrees >= 0"):
        _bounds(model, inputs, temperature_beyond=beyond)


def test_degrees_beyond_without_a_share_are_refused_not_dropped(band_inputs):
    model, inputs, _ = band_inputs
    with pytest.raises(ValueError, match="temperature_beyond is used only with fallback_share"):
        _bounds(model, inputs, fallback_share=None)


def test_a_nan_centre_or_fold_prediction_is_refused_not_a_finite_band(band_inputs):
    model, inputs, _ = band_inputs
    centre = inputs["centre"].copy()
    centre[5] = np.nan
    with pytest.raises(ValueError, match=r"centre must be finite .* at index 5 \(1 of"):
        _bounds(model, inputs, centre=centre)
    # the same without the terms outside the domain (a plain CV+ band ignores the centre)
    with pytest.raises(ValueError, match="centre must be finite"):
        _bounds(model, inputs, centre=centre, fallback_share=None, temperature_beyond=None)
    folds = inputs["fold_predictions"].copy()
    folds[1, 2] = np.inf
    with pytest.raises(
        ValueError, match=r"fold_predictions must be finite; got inf at index \(1, 2\)"
    ):
        _bounds(model, inputs, fold_predictions=folds)


def test_a_share_of_text_is_a_type_error(band_inputs):
    model, inputs, _ = band_inputs
    with pytest.raises(TypeError, match="fallback_share must be an array of numbers"):
        _bounds(model, inputs, fallback_share=["a"] * inputs["centre"].shape[0])


def test_a_centre_or_fold_predictions_of_text_is_a_type_error_naming_it(band_inputs):
    """As the docstring promises: a TypeError naming the argument, not numpy's ValueError
    from the conversion (found by a surviving mutant, issue 42)."""
    model, inputs, _ = band_inputs
    n = inputs["centre"].shape[0]
    with pytest.raises(TypeError, match="centre must be an array of numbers"):
        _bounds(model, inputs, centre=["a"] * n)
    folds = np.asarray(inputs["fold_predictions"]).astype(object)
    folds[0, 0] = "a"
    with pytest.raises(TypeError, match="fold_predictions must be an array of numbers"):
        _bounds(model, inputs, fold_predictions=folds)


# -- the plain functions of conformal.py ----------------------------------------------------


@pytest.mark.parametrize("level", [0.0, 1.0, 1.5, -0.2, np.nan])
def test_conformal_quantile_refuses_a_level_outside_0_1(level):
    with pytest.raises(ValueError, match=r"level must be a real number in \(0, 1\)"):
        conformal_quantile([1.0, 2.0, 3.0], level)


def test_conformal_quantile_refuses_nan_scores_and_no_scores():
    # a NaN sorts last: it would silently drop out of a lower quantile
    with pytest.raises(ValueError, match="scores must be finite; got nan at index 1"):
        conformal_quantile([1.0, np.nan, 3.0, 4.0], 0.5)
    with pytest.raises(ValueError, match="scores must hold at least one score"):
        conformal_quantile([], 0.5)
    with pytest.raises(TypeError, match="level must be a real number"):
        conformal_quantile([1.0, 2.0], True)


def test_run_quantile_scores_needs_one_group_per_score():
    with pytest.raises(
        ValueError, match=r"groups must hold one label per score.*\(3,\) and \(2,\)"
    ):
        run_quantile_scores([1.0, 2.0, 3.0], [0, 0], 0.5)
    with pytest.raises(ValueError, match=r"level must be a real number in \[0, 1\]"):
        run_quantile_scores([1.0, 2.0], [0, 1], 1.5)


def test_plus_interval_names_a_scale_or_fold_that_does_not_fit():
    predictions = np.array([[0.0, 1.0], [1.0, 2.0]])
    scores, folds = np.array([1.0, 2.0]), np.array([0, 1])
    with pytest.raises(ValueError, match=r"scale must hold one value per row: shape \(2,\)"):
        plus_interval(predictions, np.ones(3), scores, folds, 0.5)
    with pytest.raises(ValueError, match="group_fold must hold one fold per group score"):
        plus_interval(predictions, np.ones(2), scores, np.array([0]), 0.5)
    with pytest.raises(ValueError, match=r"group_fold must hold fold indices in \[0, 2\)"):
        plus_interval(predictions, np.ones(2), scores, np.array([0, 2]), 0.5)


def test_knn_distance_names_a_width_mismatch_and_no_neighbours():
    reference = np.zeros((5, 2))
    with pytest.raises(
        ValueError, match=r"same number of columns .* got shapes \(5, 2\) and \(1, 3\)"
    ):
        knn_distance(reference, np.zeros((1, 3)))
    # 0 neighbours used to become 1 silently
    with pytest.raises(ValueError, match="n_neighbors must be an integer >= 1, got 0"):
        knn_distance(reference, np.zeros((1, 2)), n_neighbors=0)


@pytest.mark.parametrize("reference", [-0.5, np.nan])
def test_extrapolation_variance_refuses_a_negative_or_nan_reference(reference):
    # a negative reference would count calibrated disagreement as extrapolation
    with pytest.raises(ValueError, match="reference must be a finite variance >= 0"):
        extrapolation_variance(np.array([[0.0, 1.0], [0.0, -1.0]]), reference)


def test_thermal_slope_needs_as_many_targets_as_temperatures():
    with pytest.raises(ValueError, match=r"temperature and y .* got 3 and 2 values"):
        thermal_slope([10.0, 20.0, 30.0], [1.0, 2.0])


# -- CalibrationDomain's columns ------------------------------------------------------------


@pytest.fixture(scope="module")
def rows():
    return np.random.default_rng(0).normal(size=(60, 3))


@pytest.mark.parametrize(
    ("params", "name"),
    [
        ({"temperature": True}, "temperature"),
        ({"temperature": [0, False]}, "temperature"),
        ({"temperature": 0, "rate": True}, "rate"),
    ],
)
def test_a_bool_is_not_a_column_index(rows, params, name):
    """temperature=True used to read column 1."""
    with pytest.raises(TypeError, match=f"{name} must name columns of X by integer position"):
        CalibrationDomain(**params).fit(rows)


@pytest.mark.parametrize("name", ["temperature", "rate"])
def test_a_column_named_twice_is_refused(rows, name):
    with pytest.raises(ValueError, match=rf"{name} must name each column once, got column 1 2"):
        CalibrationDomain(**{name: [1, 1]}).fit(rows)


@pytest.mark.parametrize(("temperature", "rate"), [(0, 0), ([0, 1], [2, 1])])
def test_one_column_as_temperature_and_rate_is_refused(rows, temperature, rate):
    with pytest.raises(ValueError, match="temperature and rate must name different columns"):
        CalibrationDomain(temperature=temperature, rate=rate).fit(rows)


def test_distinct_temperature_and_rate_columns_are_kept(rows):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        domain = CalibrationDomain(temperature=[0, 2], rate=1).fit(rows)
    assert domain.temperature_columns_ == [0, 2]
    assert domain.rate_columns_ == [1]


@pytest.mark.parametrize(
    ("column", "message"),
    [
        # The standard deviation of values near 1e-182 underflows to 0: standardising by it
        # made NaN coordinates and a LinAlgError deep in the SVD (found by Hypothesis).
        (1e-182 * np.sin(np.linspace(0.0, 9.0, 120)), "varies by 2e-182 only"),
        # A spread of a few units of round-off of 25 degC is noise of the arithmetic.
        (25.0 + 1e-14 * np.sin(np.linspace(0.0, 9.0, 120)), "varies by 2.13e-14 only"),
        (np.full(120, 3.0), r"is constant \(3.0\)"),
    ],
)
def test_a_feature_without_a_usable_spread_is_named(column, message):
    X = np.column_stack([np.linspace(10.0, 40.0, 120), column])
    with pytest.raises(ValueError, match=f"feature column 1 {message}"):
        CalibrationDomain(temperature=0).fit(X)


def test_a_small_spread_of_small_values_is_a_spread():
    """Values near 1e-150 with their own spread standardise fine: the rule is relative."""
    t = np.linspace(10.0, 40.0, 120)
    domain = CalibrationDomain(temperature=0).fit(np.column_stack([t, 1e-150 * np.sin(t)]))
    assert np.all(domain.distance(np.column_stack([t, 1e-150 * np.sin(t)])) == 0.0)
    assert np.isfinite(domain.scale_).all()
    assert domain.scale_[1] > 0


@pytest.fixture
def extendable():
    t = np.linspace(10.0, 40.0, 150)
    rate = np.tile(np.linspace(0.1, 0.3, 50), 3)
    return CalibrationDomain(temperature=0, rate=1).fit(
        np.column_stack([t, rate]), groups=np.repeat([0, 1, 2], 50)
    )


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        (
            "rate_low",
            [0.0, 0.0],
            r"rate_low must hold one value per rate column .* \(1,\), got \(2,\)",
        ),
        ("rate_high", 0.5, r"rate_high must hold one value per rate column .* got \(\)"),
        ("temperature_low", [np.nan], "temperature_low must not hold NaN"),
        ("temperature_high", [[45.0]], r"temperature_high must hold one value per temperature"),
        ("threshold", np.nan, "threshold must be a distance, not NaN"),
    ],
)
def test_extend_refuses_a_range_that_does_not_fit_and_changes_nothing(
    extendable, name, value, message
):
    before = {
        key: np.copy(getattr(extendable, key))
        for key in ("threshold_", "rate_low_", "rate_high_", "boost_low_", "boost_high_")
    }
    with pytest.raises(ValueError, match=message):
        extendable.extend(**{name: value})
    for key, array in before.items():
        np.testing.assert_array_equal(getattr(extendable, key), array)
    # a range of the right shape widens it
    extendable.extend(rate_high=[0.45], temperature_low=[5.0])
    assert extendable.rate_high_.tolist() == [0.45]
    assert extendable.boost_low_.tolist() == [5.0]
