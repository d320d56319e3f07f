"""The calibration domain's detector as a parameter of CompensationPipeline (issue 43, point 1).

Like ``TransformedTargetRegressor(transformer=...)``: the ``domain`` parameter is cloned at
fit (``domain_`` is the fitted clone, the parameter is left unfitted), its parameters are
``domain__...`` for a grid search, and another novelty detector in scikit-learn's shape can
take its place.
"""

import warnings

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.covariance import EllipticEnvelope
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.neighbors import LocalOutlierFactor
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import (
    CalibrationDomain,
    CompensationPipeline,
    ConformalRegressor,
    OutsideCalibrationWarning,
    make_compensation_pipeline,
)
from sklearn_ifog._compat import InvalidParameterError
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import locate
from sklearn_ifog.export import to_json
from sklearn_ifog.policy import fallback_weight
from sklearn_ifog.report import calibration_status
from sklearn_ifog.streaming import StreamingCompensator

SMALL = dict(n_units=1, azimuths=(0.0,), sampling_period=120.0, random_state=0)


@pytest.fixture(scope="module")
def heating_and_cold():
    """Three heating runs (10-40 degC) and copies of them 20 degC colder."""
    calibration = make_thermal_campaign(
        profile="paper", temperature_range=(10.0, 40.0), n_runs=3, **SMALL
    )
    X, y = calibration.data, calibration.target
    cold = X.assign(temperature=X["temperature"] - 20.0)
    return X, y, cold


def _fit(model, X, y):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        return model.fit(X, y)


def test_the_default_domain_is_a_calibration_domain_given_the_feature_columns(
    heating_and_cold,
):
    X, y, _ = heating_and_cold
    model = make_compensation_pipeline(LinearRegression())
    bare = CompensationPipeline([(name, clone(step)) for name, step in model.steps])
    assert bare.domain is None
    _fit(model, X, y)
    _fit(bare, X, y)
    for fitted in (model, bare):
        assert isinstance(fitted.domain_, CalibrationDomain)
        names = list(fitted.feature_names_out_)
        assert fitted.domain_.temperature_columns_ == [names.index("T")]
        assert fitted.domain_.rate_columns_ == [names.index("dT")]
    # None means CalibrationDomain() with its defaults: the same domain and predictions.
    assert bare.domain_.threshold_ == model.domain_.threshold_
    np.testing.assert_array_equal(bare.predict(X), model.predict(X))


def test_the_domain_parameter_is_cloned_not_fitted(heating_and_cold):
    X, y, _ = heating_and_cold
    given = CalibrationDomain(margin=0.5, alpha=0.1)
    model = make_compensation_pipeline(LinearRegression()).set_params(domain=given)
    _fit(model, X, y)
    assert model.domain is given
    assert not hasattr(given, "box_")  # untouched: the fitted one is a clone
    assert given.temperature is None
    assert given.rate is None
    assert model.domain_ is not given
    assert (model.domain_.margin, model.domain_.alpha) == (0.5, 0.1)
    assert model.domain_.threshold_ >= 0.5


def test_domain_parameters_are_reachable_and_grid_searchable(heating_and_cold):
    X, y, _ = heating_and_cold
    model = make_compensation_pipeline(LinearRegression(), margin=0.7, alpha=0.05)
    params = model.get_params()
    assert (params["domain__margin"], params["domain__alpha"]) == (0.7, 0.05)
    model.set_params(domain__margin=4.0)
    assert model.domain.margin == 4.0
    search = GridSearchCV(
        make_compensation_pipeline(LinearRegression()),
        {"domain__margin": [0.25, 6.0], "domain__alpha": [0.3]},
        cv=GroupKFold(n_splits=3),
        scoring="neg_mean_squared_error",
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        search.fit(X, y, groups=X["run"])
    margins = search.cv_results_["param_domain__margin"].tolist()
    assert margins == [0.25, 6.0]
    best = search.best_estimator_
    assert best.domain_.margin == best.domain.margin == search.best_params_["domain__margin"]
    # The margin reaches the fitted threshold (a floor under it).
    low = _fit(make_compensation_pipeline(LinearRegression(), margin=0.25, alpha=0.3), X, y)
    high = _fit(make_compensation_pipeline(LinearRegression(), margin=6.0, alpha=0.3), X, y)
    assert high.domain_.threshold_ == 6.0 > low.domain_.threshold_


def test_another_novelty_detector_decides_what_is_outside(heating_and_cold):
    X, y, cold = heating_and_cold
    detector = EllipticEnvelope(contamination=0.01, random_state=0)
    model = _fit(make_compensation_pipeline(LinearRegression()).set_params(domain=detector), X, y)
    assert isinstance(model.domain_, EllipticEnvelope)
    assert model.domain_ is not detector
    features = np.asarray(model.steps[0][1].transform(cold), dtype=float)
    expected_outside = model.domain_.predict(features) == -1
    expected_distance = np.maximum(-model.domain_.decision_function(features), 0.0)
    np.testing.assert_array_equal(model.outside_calibration(cold), expected_outside)
    np.testing.assert_allclose(model.calibration_distance(cold), expected_distance)
    assert expected_outside.mean() > 0.5  # its verdict, whichever rows it picks
    # About the contamination of the calibration's own rows are flagged.
    assert model.outside_calibration(X).mean() <= 0.05
    # "blend" weighs the fallback by how far the decision function lies below 0.
    with pytest.warns(OutsideCalibrationWarning, match="uncalibrated="):
        blended = model.predict(cold)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        free = model.set_params(uncalibrated="none").predict(cold)
    fallback = model.fallback_.predict(features)[:, 0]
    weight = np.where(expected_outside, fallback_weight(expected_distance, 0.0), 0.0)
    np.testing.assert_allclose(blended, (1.0 - weight) * free + weight * fallback, rtol=1e-12)
    assert np.any(weight == 1.0)


def test_local_outlier_factor_in_novelty_mode_works_and_groups_are_not_forced_on_it(
    heating_and_cold,
):
    X, y, cold = heating_and_cold
    model = make_compensation_pipeline(LinearRegression()).set_params(
        domain=LocalOutlierFactor(novelty=True, n_neighbors=10)
    )
    _fit(model, X, y)
    features = np.asarray(model.steps[0][1].transform(cold), dtype=float)
    np.testing.assert_array_equal(
        model.outside_calibration(cold), model.domain_.predict(features) == -1
    )
    assert locate(model.domain_, features).beyond.max() == 0.0


def test_what_only_a_calibration_domain_can_do_says_so(heating_and_cold, tmp_path):
    X, y, cold = heating_and_cold
    detector = EllipticEnvelope(contamination=0.01, random_state=0)
    model = _fit(make_compensation_pipeline(LinearRegression()).set_params(domain=detector), X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        with pytest.raises(ValueError, match=r"uncalibrated='clip' needs .*CalibrationDomain"):
            model.set_params(uncalibrated="clip").predict(cold)
    model.set_params(uncalibrated="blend")
    with pytest.raises(ValueError, match=r"Streaming compensation .*EllipticEnvelope"):
        StreamingCompensator(model)
    with pytest.raises(ValueError, match=r"C and JSON exports .*EllipticEnvelope"):
        to_json(model, tmp_path / "model.json")
    assert not list(tmp_path.iterdir())  # nothing written
    handover = make_compensation_pipeline(LinearRegression(), handover=True)
    with pytest.raises(ValueError, match="handover=True widens a CalibrationDomain"):
        handover.set_params(domain=detector).fit(X, y)


@pytest.mark.parametrize(
    "domain",
    [StandardScaler(), LocalOutlierFactor(novelty=False), "box"],
    ids=["transformer", "lof-not-novelty", "string"],
)
def test_a_domain_that_is_no_novelty_detector_is_refused_by_name(heating_and_cold, domain):
    X, y, _ = heating_and_cold
    model = make_compensation_pipeline(LinearRegression()).set_params(domain=domain)
    with pytest.raises(InvalidParameterError, match="'domain' parameter"):
        model.fit(X, y)


def test_a_step_named_domain_clashes_with_the_parameter(heating_and_cold):
    X, y, _ = heating_and_cold
    model = make_compensation_pipeline(LinearRegression())
    steps = [("domain", model.steps[0][1]), *model.steps[1:]]
    with pytest.raises(ValueError, match="conflict with constructor arguments"):
        CompensationPipeline(steps).fit(X, y)


def test_the_report_and_the_band_ask_another_detector_too(heating_and_cold):
    X, y, cold = heating_and_cold
    detector = EllipticEnvelope(contamination=0.01, random_state=0)
    model = make_compensation_pipeline(LinearRegression()).set_params(domain=detector)
    _fit(model, X, y)
    status = calibration_status(model, cold)
    np.testing.assert_array_equal(status.outside, model.outside_calibration(cold))
    np.testing.assert_array_equal(status.distance, model.calibration_distance(cold))
    np.testing.assert_array_equal(status.adjusted, model.fallback_share(cold) > 0.0)
    # It knows no calibrated ranges: NaN, as for a model without a T feature.
    assert np.isnan(status.temperature_excess).all()
    assert np.isnan(status.rate_excess).all()
    band = ConformalRegressor(clone(model), coverage=0.9)
    _fit(band, X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        inside = band.predict_interval(X)
        outside = band.predict_interval(cold)
    assert np.all(inside[:, 0] <= inside[:, 1])
    # Where the fallback takes over, the band takes the fallback's width, not the model's.
    share = band.estimator_.fallback_share(cold)
    assert share.max() == 1.0
    assert band.fallback_quantile_ is not None
    width = outside[:, 1] - outside[:, 0]
    assert np.all(np.isfinite(width))
    assert np.all(width > 0.0)
