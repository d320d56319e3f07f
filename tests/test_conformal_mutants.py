"""Numerics of the conformal intervals that mutation testing found unguarded (issue 42,
point 5).

Each test here kills mutants of :mod:`sklearn_ifog.conformal`'s plain functions and of
:class:`~sklearn_ifog.conformal.ConformalRegressor`'s methods that survived
``tests/test_conformal.py`` and ``tests/test_conformal_domain.py`` (``tools/mutation.sh
conformal``); the docstrings say which (mutmut's numbers, within the function named).
"""

import copy
import os
import warnings

import numpy as np
import pandas as pd
import pytest
from _campaigns import rate_drift_table
from scipy.stats import norm
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline

from sklearn_ifog import ConformalRegressor, make_compensation_pipeline
from sklearn_ifog.conformal import (
    _cover_both,
    conformal_quantile,
    extrapolation_variance,
    knn_distance,
    run_quantile_scores,
    thermal_slope,
)
from sklearn_ifog.domain import OutsideCalibrationWarning


def test_conformal_quantile_of_a_low_level_and_of_shuffled_scores():
    """A level below ``1 / (n + 1)`` gives the smallest score (kills ``max(rank, 2)``); the
    ``rank``-th smallest of shuffled scores, exactly, along the first axis."""
    assert float(conformal_quantile([3.0, 1.0, 2.0, 5.0, 4.0], 0.1)) == 1.0
    scores = np.random.default_rng(0).permutation(100).astype(float)
    for level, expected in [(0.5, 50.0), (0.9, 90.0), (0.2, 20.0)]:
        # rank = ceil(101 * level): the (rank)-th smallest of 0..99 is rank - 1.
        assert float(conformal_quantile(scores, level)) == expected
    columns = np.column_stack([scores, scores[::-1]])
    assert conformal_quantile(columns, 0.5).tolist() == [50.0, 50.0]


def test_knn_distance_with_one_neighbour():
    """``n_neighbors=1`` is the nearest reference row alone (kills ``max(2, ...)``)."""
    reference = np.array([[0.0], [1.0], [2.0]])
    np.testing.assert_allclose(knn_distance(reference, np.array([[0.2], [5.0]]), 1), [0.2, 3.0])


def test_cover_both_spans_the_band_moved_onto_the_extrapolation():
    """The hull of the band and the band shifted by ``extrapolation - centre``, whichever
    side the shift is on; an extrapolation given as a column is read as one value per row
    (kills the mutants of :func:`~sklearn_ifog.conformal._cover_both`)."""
    bounds = np.array([[-1.0, 1.0], [-1.0, 1.0], [9.0, 11.0]])
    centre = np.array([0.0, 0.0, 10.0])
    extrapolation = np.array([[0.5], [-2.0], [10.0]])
    np.testing.assert_array_equal(
        _cover_both(bounds, centre, extrapolation), [[-1.0, 1.5], [-3.0, 1.0], [9.0, 11.0]]
    )
    np.testing.assert_array_equal(_cover_both(bounds, centre, centre), bounds)


def test_thermal_slope():
    """The least-squares slope in T, 0 for one temperature, any input shape (no selected
    test reached it: its 20 mutants had no test)."""
    assert thermal_slope([10.0, 20.0, 30.0], [1.0, 3.0, 5.0]) == pytest.approx(0.2)
    assert thermal_slope([[10.0], [20.0], [30.0]], [[5.0], [3.0], [1.0]]) == pytest.approx(-0.2)
    rng = np.random.default_rng(0)
    t = rng.uniform(-10.0, 40.0, 50)
    y = 0.7 * t + 3.0 + rng.normal(size=50)
    assert thermal_slope(t, y) == pytest.approx(np.polyfit(t, y, 1)[0], rel=1e-12)
    assert thermal_slope([25.0, 25.0, 25.0], [1.0, 2.0, 9.0]) == 0.0


# -- ConformalRegressor: the band from predictions, its terms outside the domain -----------


@pytest.fixture(scope="module")
def blend():
    """A compensation pipeline with ``uncalibrated="blend"`` calibrated on 10 to 40 degC, and the
    inputs of the band of other runs reaching -10 degC (many rows outside, many beyond)."""
    X_warm, y_warm = rate_drift_table(0, (10.0, 40.0))
    X_cold, _ = rate_drift_table(100, (-10.0, 40.0))
    pipeline = make_compensation_pipeline(LinearRegression(), uncalibrated="blend")
    model = ConformalRegressor(pipeline, coverage=0.9).fit(X_warm, y_warm)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        folds = np.stack([fold.predict(X_cold) for fold in model.estimators_])
        centre = model.predict(X_cold)
    raw = model._raw_features(X_cold)
    share, beyond = model._outside_terms(X_cold)
    extrapolation = model.estimator_[-1].predict(raw)
    return model, X_cold, centre, folds, raw, share, beyond, extrapolation


def _half_widths(bounds, shift=0.0):
    """Half the width of a band, less the stretch onto the extrapolation (``shift``)."""
    return (bounds[:, 1] - bounds[:, 0] - shift) / 2


def test_bounds_from_predictions_names_each_bad_argument_and_what_it_expected(blend):
    """Each refused argument is named with what it should hold, word for word, and a
    coverage outside (0, 1), or not a number, is a ValueError naming it (kills the mutants
    of the messages and of the coverage check in ``bounds_from_predictions``: 41-45, 54,
    85-89, 141-146)."""
    model, _, centre, folds, raw, share, _, _ = blend
    with pytest.raises(
        ValueError,
        match=r"^difficulty_features is required when adaptive=True: the rows through the "
        r"steps of estimator_ before its regressor\.$",
    ):
        model.bounds_from_predictions(centre, folds)
    bad = raw.copy()
    bad[3, 1] = np.nan
    with pytest.raises(
        ValueError,
        match=r"^difficulty_features must be finite \(the rows through the steps of "
        r"estimator_ before its regressor\); got nan at index \(3, 1\) \(1 of ",
    ):
        model.bounds_from_predictions(centre, folds, bad)
    with pytest.raises(
        ValueError,
        match=r"^temperature_beyond is used only with fallback_share \(its slope term is one "
        r"of the terms outside the domain\); pass fallback_share too, or leave "
        r"temperature_beyond None\.$",
    ):
        model.bounds_from_predictions(centre, folds, raw, temperature_beyond=np.zeros(len(centre)))
    for coverage in (0.0, 1.0, 1.5, -0.2, "0.9"):
        with pytest.raises(
            ValueError, match=rf"^coverage must be a float in \(0, 1\), got {coverage!r}\.$"
        ):
            model.bounds_from_predictions(centre, folds, raw, coverage=coverage)
    # the share's and the degrees' bounds are the documented ones, not wider
    for name, value, expected in [
        ("fallback_share", 1.5, r"a weight in \[0, 1\] for every row"),
        ("fallback_share", -0.5, r"a weight in \[0, 1\] for every row"),
        ("temperature_beyond", -1.0, "a number of degrees >= 0 for every row"),
    ]:
        values = np.zeros(len(centre))
        values[2] = value
        kwargs = {"fallback_share": share, name: values}
        with pytest.raises(
            ValueError, match=rf"^{name} must be {expected}; got {value!r} at index 2 \(1 of "
        ):
            model.bounds_from_predictions(centre, folds, raw, **kwargs)


@pytest.mark.parametrize("coverage", [None, 0.8])
def test_fallback_term_is_its_quantile_times_the_share_in_quadrature(blend, coverage):
    """Outside the domain the half-width grows, in quadrature, by exactly the fallback's
    quantile (at the band's coverage) times its share: ``half**2 - plain**2 == (share *
    q)**2`` once the stretch onto the extrapolation is taken off (kills 130, 136, 137 (no
    term at the coverage of fit), 217 and 221 (a wrong normal quantile) of
    ``bounds_from_predictions``)."""
    model, _, centre, folds, raw, share, _, extrapolation = blend
    flat = copy.copy(model)
    flat.thermal_slope_ = 0.0  # the fallback's term alone
    bounds = flat.bounds_from_predictions(
        centre, folds, raw, coverage=coverage, fallback_share=share
    )
    plain = flat.bounds_from_predictions(centre, folds, raw, coverage=coverage)
    quantile = model.fallback_quantile_ if coverage is None else model._fallback_quantile(0.8)
    assert quantile > 0
    assert (share > 0.5).sum() >= 20
    half = _half_widths(bounds, np.abs(extrapolation - centre))
    np.testing.assert_allclose(
        half**2 - _half_widths(plain) ** 2, (share * quantile) ** 2, rtol=1e-7, atol=1e-15
    )


def test_no_share_leaves_every_term_outside_out(blend):
    """Without ``fallback_share`` the band is the one of a model without the terms outside
    the domain: not stretched onto the regressor's extrapolation (kills 107 of
    ``bounds_from_predictions``)."""
    model, _, centre, folds, raw, _, _, extrapolation = blend
    assert np.sum(np.abs(extrapolation - centre) > 1e-3) >= 20
    without = copy.copy(model)
    without.fallback_scores_ = None
    np.testing.assert_array_equal(
        model.bounds_from_predictions(centre, folds, raw),
        without.bounds_from_predictions(centre, folds, raw),
    )


def test_a_model_fitted_before_the_terms_outside_gives_the_band_without_them(blend):
    """A model pickled before the terms outside the domain (no ``fallback_scores_``,
    ``fallback_quantile_``, ``thermal_slope_``) still gives its band, without them, from
    ``predict_interval`` and from a share; one fitted before the slope term alone (no
    ``thermal_slope_``) the band with the fallback's term and no slope (kills 113, 135, 227,
    230, 233 of ``bounds_from_predictions`` and 5 of ``_outside_terms``)."""
    model, X_cold, centre, folds, raw, share, beyond, _ = blend
    plain = model.bounds_from_predictions(centre, folds, raw)
    old = copy.copy(model)
    del old.fallback_scores_, old.fallback_quantile_, old.thermal_slope_
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        np.testing.assert_array_equal(old.predict_interval(X_cold), plain)
    np.testing.assert_array_equal(
        old.bounds_from_predictions(
            centre, folds, raw, fallback_share=share, temperature_beyond=beyond
        ),
        plain,
    )
    no_slope = copy.copy(model)
    del no_slope.thermal_slope_
    zero_slope = copy.copy(model)
    zero_slope.thermal_slope_ = 0.0
    np.testing.assert_array_equal(
        no_slope.bounds_from_predictions(
            centre, folds, raw, fallback_share=share, temperature_beyond=beyond
        ),
        zero_slope.bounds_from_predictions(centre, folds, raw, fallback_share=share),
    )


@pytest.mark.parametrize(("slope", "coverage"), [(1.0, None), (-0.5, 0.8)])
def test_slope_term_is_the_slope_times_the_degrees_at_the_coverage_of_fit(blend, slope, coverage):
    """The slope term is a standard deviation at the coverage of fit: ``slope * beyond``
    in quadrature there, scaled by ``z(coverage) / z(fit)`` at another coverage; a slope
    of exactly 1 is no exception (kills 236 of ``bounds_from_predictions``)."""
    model, _, centre, folds, raw, share, beyond, extrapolation = blend
    steep, flat = copy.copy(model), copy.copy(model)
    steep.thermal_slope_, flat.thermal_slope_ = slope, 0.0
    kwargs = {"coverage": coverage, "fallback_share": share, "temperature_beyond": beyond}
    bounds = steep.bounds_from_predictions(centre, folds, raw, **kwargs)
    base = flat.bounds_from_predictions(centre, folds, raw, **kwargs)
    assert (beyond > 5.0).sum() >= 20
    shift = np.abs(extrapolation - centre)
    ratio = 1.0 if coverage is None else norm.ppf(0.9) / norm.ppf(0.95)
    np.testing.assert_allclose(
        _half_widths(bounds, shift) ** 2 - _half_widths(base, shift) ** 2,
        (ratio * slope * beyond) ** 2,
        rtol=1e-7,
        atol=1e-12,
    )


# -- ConformalRegressor: the band's construction ---------------------------------------------


def _runs(seed, n_runs=12, per_run=30, offset=20.0, spread=3.0):
    """Runs of one feature far from zero mean and unit scale (``offset + spread * x``), a
    line in it and noise growing with ``|x|``."""
    rng = np.random.default_rng(seed)
    x = (rng.uniform(-2, 2, n_runs)[:, None] + rng.uniform(-0.5, 0.5, (n_runs, per_run))).ravel()
    y = 1.5 * x + (0.05 + 0.3 * np.abs(x)) * rng.normal(size=x.size)
    return offset + spread * x[:, None], y, np.repeat(np.arange(n_runs), per_run)


@pytest.mark.parametrize("coverage", [None, 0.7])
def test_base_and_minmax_bands_are_the_quantile_about_the_predictions(coverage):
    """Without adaptivity ``"base"`` is ``predict -/+ quantile`` and ``"minmax"`` the fold
    predictions' range widened by it, the quantile re-read at another coverage (kills 154,
    169, 170, 172, 178, 179, 181 of ``bounds_from_predictions``)."""
    X, y, runs = _runs(0)
    X_new = np.array([[14.0], [20.0], [27.0]])
    for method in ("base", "minmax"):
        model = ConformalRegressor(LinearRegression(), method=method, adaptive=False, cv=4)
        model.fit(X, y, groups=runs)
        quantile = model.quantile_
        if coverage is not None:
            _, scores = run_quantile_scores(model.scores_, model.score_groups_, coverage)
            quantile = float(conformal_quantile(scores, model.run_probability))
            assert quantile != model.quantile_
        assert quantile != 1.0
        folds = np.stack([fold.predict(X_new) for fold in model.estimators_])
        if method == "base":
            low, high = model.predict(X_new), model.predict(X_new)
        else:
            low, high = folds.min(axis=0), folds.max(axis=0)
        expected = np.column_stack([low - quantile, high + quantile])
        np.testing.assert_allclose(
            model.predict_interval(X_new, coverage=coverage), expected, rtol=1e-12
        )


def test_jackknife_widening_is_at_the_requested_coverage():
    """Where the fold models part, the half-width grows in quadrature by ``z(coverage) *
    sqrt(extrapolation_variance)`` at the coverage asked for, not the one of fit (kills 204
    of ``bounds_from_predictions``)."""
    X, y, runs = _runs(1)
    model = ConformalRegressor(LinearRegression(), coverage=0.8, cv=4).fit(X, y, groups=runs)
    X_new = np.array([[20.0], [40.0], [60.0], [-5.0]])
    folds = np.stack([fold.predict(X_new) for fold in model.estimators_])
    variance = extrapolation_variance(folds, model.fold_variance_reference_)
    assert np.all(variance[1:] > 0)
    unwidened = copy.copy(model)
    unwidened.fold_variance_reference_ = 1e300
    for coverage, level in [(None, 0.8), (0.95, 0.95)]:
        bounds = model.predict_interval(X_new, coverage=coverage)
        plain = unwidened.predict_interval(X_new, coverage=coverage)
        np.testing.assert_allclose(bounds.mean(axis=1), plain.mean(axis=1), rtol=1e-12)
        np.testing.assert_allclose(
            _half_widths(bounds) ** 2 - _half_widths(plain) ** 2,
            norm.ppf((1 + level) / 2) ** 2 * variance,
            rtol=1e-9,
        )


def test_difficulty_is_the_softened_variance_model_on_standardised_features():
    """With ``"base"`` the half-width is ``quantile * (sigma / mean sigma) ** 0.5``, sigma
    the floored variance model of the distance of the standardised features (the feature
    here has mean 20 and scale 3), and the scores' squared normalisation averages 1 over
    the calibration rows (kills 3, 4 of ``_scale`` and 1, 2 of ``_soften``)."""
    X, y, runs = _runs(2)
    model = ConformalRegressor(LinearRegression(), method="base", cv=4).fit(X, y, groups=runs)
    assert abs(model.feature_mean_[0]) > 10
    assert abs(model.feature_scale_[0] - 1) > 1
    model.fold_variance_reference_ = 1e300  # no jackknife widening: the difficulty alone
    X_new = np.array([[14.0], [19.0], [23.0], [30.0]])
    features = (X_new - model.feature_mean_) / model.feature_scale_
    distance = knn_distance(model.calibration_features_, features) / model.distance_scale_
    variance = np.maximum(model.difficulty_.predict(distance[:, None]), model.difficulty_floor_)
    half = model.quantile_ * (np.sqrt(variance) / model.difficulty_mean_) ** 0.5
    assert half.max() > 1.5 * half.min()
    np.testing.assert_allclose(_half_widths(model.predict_interval(X_new)), half, rtol=1e-9)
    residual = np.abs(y - model.oof_prediction_)
    kept = model.scores_ > 0
    assert np.mean((residual[kept] / model.scores_[kept]) ** 2) == pytest.approx(1.0, rel=1e-9)


def test_difficulty_reads_a_dataframe_and_a_one_step_pipeline_as_their_columns():
    """Around a plain regressor the difficulty reads X's columns, a DataFrame's as an
    array's; a one-step Pipeline has no steps before its regressor, so it reads X too: the
    bands are the same (kills 3 and 12 of ``_raw_features``)."""
    X, y, runs = _runs(3)
    X_new = np.array([[15.0], [21.0], [29.0]])
    reference = ConformalRegressor(LinearRegression(), cv=4).fit(X, y, groups=runs)
    expected = reference.predict_interval(X_new)
    frame = ConformalRegressor(LinearRegression(), cv=4).fit(
        pd.DataFrame({"x": X[:, 0]}), y, groups=runs
    )
    np.testing.assert_allclose(
        frame.predict_interval(pd.DataFrame({"x": X_new[:, 0]})), expected, rtol=1e-12
    )
    one_step = ConformalRegressor(make_pipeline(LinearRegression()), cv=4).fit(X, y, groups=runs)
    np.testing.assert_allclose(one_step.predict_interval(X_new), expected, rtol=1e-12)


def test_predict_and_predict_interval_of_one_row_check_without_refitting():
    """One row is predicted (fit needs two, predict one), and a row of the wrong width is
    ConformalRegressor's own error, the fitted width kept (kills 9 of ``predict`` and of
    ``predict_interval``)."""
    X, y, runs = _runs(4)
    model = ConformalRegressor(LinearRegression(), cv=4).fit(X, y, groups=runs)
    np.testing.assert_allclose(model.predict(X[:1]), model.predict(X[:2])[:1], rtol=1e-12)
    np.testing.assert_allclose(
        model.predict_interval(X[:1]), model.predict_interval(X[:2])[:1], rtol=1e-12
    )
    for method in (model.predict, model.predict_interval):
        with pytest.raises(ValueError, match="ConformalRegressor is expecting 1 features"):
            method(np.ones((3, 2)))
        assert model.n_features_in_ == 1


def test_fit_params_reach_every_fold_model_and_the_model_on_all_rows():
    """``sample_weight`` given to fit weights the model on all rows and each fold model on
    its own training rows (kills 6 and 19 of ``_fit_fold``)."""
    X, y, runs = _runs(5)
    weight = np.random.default_rng(5).uniform(0.0, 2.0, y.size)
    model = ConformalRegressor(LinearRegression(), cv=3).fit(
        X, y, groups=runs, sample_weight=weight
    )
    full = LinearRegression().fit(X, y, sample_weight=weight)
    np.testing.assert_allclose(model.estimator_.coef_, full.coef_, rtol=1e-10)
    assert not np.allclose(LinearRegression().fit(X, y).coef_, full.coef_, rtol=1e-4)
    folds = np.unique(model.group_fold_)
    for k, fold in zip(folds, model.estimators_, strict=True):
        train = ~np.isin(runs, model.groups_[model.group_fold_ == k])
        expected = LinearRegression().fit(X[train], y[train], sample_weight=weight[train])
        np.testing.assert_allclose(fold.coef_, expected.coef_, rtol=1e-10)


def test_fit_with_the_adaptive_band_warns_of_nothing():
    """Fitting the adaptive band (difficulty model, floors) raises no warning at all, a
    deprecation included (kills 15 of ``_fit_difficulty``, ``np.finfo(None)``)."""
    X, y, runs = _runs(6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ConformalRegressor(LinearRegression(), cv=4).fit(X, y, groups=runs)


def test_band_around_a_pipeline_whose_features_are_a_dataframe(blend):
    """A compensation pipeline set to output pandas DataFrames gives the same band: the
    feature rows of the terms outside the domain are read out of the DataFrame (kills 11 of
    ``_fallback_features``)."""
    model, X_cold, *_ = blend
    X_warm, y_warm = rate_drift_table(0, (10.0, 40.0))
    pipeline = make_compensation_pipeline(LinearRegression(), uncalibrated="blend")
    framed = ConformalRegressor(pipeline.set_output(transform="pandas"), coverage=0.9)
    framed.fit(X_warm, y_warm)
    assert isinstance(framed.estimator_.steps[0][1].transform(X_cold), pd.DataFrame)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        # the regressor, fitted on named features, is given the difficulty inputs as an
        # array for its own extrapolation: scikit-learn's warning, not this test's concern
        warnings.filterwarnings("ignore", "X does not have valid feature names", UserWarning)
        np.testing.assert_allclose(
            framed.predict_interval(X_cold), model.predict_interval(X_cold), rtol=1e-12
        )


# -- ConformalRegressor: the fold models' warnings -------------------------------------------


class _WarningColumnMean(RegressorMixin, BaseEstimator):
    """The rounded mean of ``y`` (an integer prediction) from a DataFrame's ``x`` column;
    a model fitted on fewer than ``full`` rows (a fold model) warns, when it predicts, that
    it is outside its domain, then a message shared by every fold model, then its own."""

    def __init__(self, full=0):
        self.full = full

    def fit(self, X, y):
        self.n_rows_ = len(y)
        self.mean_ = round(float(np.mean(y)))
        return self

    def predict(self, X):
        if self.n_rows_ < self.full:
            warnings.warn("outside", OutsideCalibrationWarning, stacklevel=2)
            warnings.warn("a fold model predicts", UserWarning, stacklevel=2)
            warnings.warn(f"fitted on {self.n_rows_} rows", UserWarning, stacklevel=2)
        return np.full(X["x"].shape[0], self.mean_)


_CONFORMAL_PY = os.path.join("sklearn_ifog", "conformal.py")


@pytest.fixture(scope="module")
def warning_folds():
    """Three runs of 20, 30 and 40 rows with a text run column, X not all numbers."""
    sizes = [20, 30, 40]
    X = pd.DataFrame(
        {
            "run": np.repeat(["a", "b", "c"], sizes),
            "x": np.random.default_rng(7).normal(size=sum(sizes)),
        }
    )
    y = np.linspace(0.0, 10.0, sum(sizes))
    return X, y


def test_fit_passes_on_the_fold_models_warnings_but_the_domains(warning_folds):
    """While fitting, a fold model's warnings of its held-out rows reach the user, except
    its OutsideCalibrationWarning (kills 11 of ``_fit_fold``)."""
    X, y = warning_folds
    model = ConformalRegressor(_WarningColumnMean(full=len(y)), adaptive=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.fit(X, y)
    messages = [str(w.message) for w in caught]
    assert messages.count("a fold model predicts") == 3
    assert {"fitted on 70 rows", "fitted on 60 rows", "fitted on 50 rows"} <= set(messages)
    assert "outside" not in messages


def test_predict_interval_warns_each_fold_warning_once_at_the_caller(warning_folds):
    """The fold models' warnings other than OutsideCalibrationWarning are warned again once
    each, in order, as the caller's (``stacklevel``); without the difficulty the band needs
    no numeric X, and the predictions are floats (kills 1-3, 9-16 of ``_reissue``, 12 of
    ``predict_interval``, 11 and 13 of ``predict``)."""
    X, y = warning_folds
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = ConformalRegressor(_WarningColumnMean(full=len(y)), adaptive=False).fit(X, y)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bounds = model.predict_interval(X)
    assert [(w.category, str(w.message)) for w in caught] == [
        (UserWarning, "a fold model predicts"),
        (UserWarning, "fitted on 70 rows"),
        (UserWarning, "fitted on 60 rows"),
        (UserWarning, "fitted on 50 rows"),
    ]
    # at the caller, not in conformal.py (mutmut's trampolines add frames, so the test
    # names the module the warnings must not point into rather than the caller's file)
    assert not [w.filename for w in caught if w.filename.endswith(_CONFORMAL_PY)]
    assert bounds.shape == (len(y), 2)
    assert np.all(bounds[:, 0] <= bounds[:, 1])
    assert model.predict(X).dtype == np.float64


# -- ConformalRegressor: the calibration folds -----------------------------------------------


def test_an_integer_cv_splits_whole_groups_or_plain_rows():
    """``cv=k`` with groups is a GroupKFold: every row of a run is predicted out of fold by
    the one fold model that did not see the run, even with the runs interleaved; without
    groups (an array X, no run column) a KFold over the rows (kills 4 and 5 of
    ``_splits``)."""
    X, y, runs = _runs(8)
    runs = np.tile(np.arange(12), 30)  # the same rows, runs interleaved
    model = ConformalRegressor(LinearRegression(), cv=3).fit(X, y, groups=runs)
    for run, fold in zip(model.groups_, model.group_fold_, strict=True):
        rows = runs == run
        np.testing.assert_allclose(
            model.oof_prediction_[rows], model.estimators_[fold].predict(X[rows]), rtol=1e-12
        )
    rows = ConformalRegressor(LinearRegression(), cv=3).fit(X, y)
    assert len(rows.estimators_) == 3
    np.testing.assert_array_equal(rows.score_groups_, np.arange(len(y)))


def test_no_groups_and_no_run_column_says_what_to_pass():
    """Without groups, a run column or a cv, the error says what to pass, word for word
    (kills 28-33 of ``_groups``)."""
    X, y, _ = _runs(9)
    with pytest.raises(
        ValueError,
        match=r"^ConformalRegressor calibrates run by run: X has no 'run' column and groups "
        r"is None; pass groups= \(the run of every row\), or an explicit cv\.$",
    ):
        ConformalRegressor(LinearRegression()).fit(X, y)


class _SplitOnTarget:
    """A splitter that reads y: two folds, the rows with y = 0 and those with y = 1."""

    def split(self, X, y, groups=None):
        y = np.asarray(y)  # None is an error here: the splitter needs the target
        for value in (0.0, 1.0):
            yield np.flatnonzero(y != value), np.flatnonzero(y == value)

    def get_n_splits(self, X=None, y=None, groups=None):
        return 2


def test_a_splitter_is_given_the_target_and_n_jobs_is_kept():
    """A cv splitter gets ``y`` as well as X and the groups (a splitter may stratify on
    it), and ``n_jobs`` is a parameter like the others (kills 13 of ``_splits`` and 12 of
    ``__init__``)."""
    X = np.arange(40.0)[:, None]
    y = np.tile([0.0, 1.0], 20)
    model = ConformalRegressor(LinearRegression(), cv=_SplitOnTarget(), n_jobs=1).fit(X, y)
    assert model.get_params()["n_jobs"] == 1
    assert len(model.estimators_) == 2
    np.testing.assert_allclose(model.estimators_[0].predict(X), 1.0, atol=1e-9)
    np.testing.assert_allclose(model.estimators_[1].predict(X), 0.0, atol=1e-9)
