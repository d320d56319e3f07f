"""Tests of sklearn_ifog.make_compensation_pipeline."""

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import MinMaxScaler, StandardScaler

from sklearn_ifog import RBFNetRegressor, ThermalFeatures, make_compensation_pipeline


def test_default_is_the_documented_pipeline():
    model = make_compensation_pipeline()
    assert [name for name, _ in model.steps] == ["features", "scale", "regressor"]
    features, scale, regressor = (step for _, step in model.steps)
    assert isinstance(scale, StandardScaler)
    assert isinstance(regressor, RBFNetRegressor)
    assert regressor.get_params() == RBFNetRegressor().get_params()
    assert features.get_params() == ThermalFeatures(time="time", run="run").get_params()


def test_equals_the_hand_built_pipeline_bit_for_bit(small_campaign):
    X, y = small_campaign.data, small_campaign.target
    by_hand = Pipeline(
        [
            ("features", ThermalFeatures(temperature="temperature", time="time", run="run")),
            ("scale", StandardScaler()),
            ("regressor", RBFNetRegressor(random_state=0)),
        ]
    ).fit(X, y)
    made = make_compensation_pipeline(RBFNetRegressor(random_state=0)).fit(X, y)
    np.testing.assert_array_equal(made.predict(X), by_hand.predict(X))


def test_feature_parameters_are_passed_on():
    model = make_compensation_pipeline(
        LinearRegression(), temperature=["a", "b"], time=None, run="id", terms=("T", "dT"),
        smoothing=2.0, rate_unit="s",
    )  # fmt: skip
    params = model.named_steps["features"].get_params()
    assert params == {
        "temperature": ["a", "b"], "time": None, "run": "id", "terms": ("T", "dT"),
        "smoothing": 2.0, "rate_unit": "s", "transition": None,
    }  # fmt: skip
    # terms=None keeps ThermalFeatures' own default
    assert make_compensation_pipeline(terms=None)[0].terms == ThermalFeatures().terms


def test_regressor_is_used_as_given_and_the_pipeline_clones():
    regressor = LinearRegression()
    model = make_compensation_pipeline(regressor)
    assert model.named_steps["regressor"] is regressor
    assert clone(model).get_params()["regressor__fit_intercept"] is True


@pytest.mark.parametrize("bad", [MinMaxScaler(), "rbf", 3, ThermalFeatures()])
def test_not_a_regressor_is_a_type_error_naming_it(bad):
    with pytest.raises(TypeError, match="regressor must be a scikit-learn regressor") as info:
        make_compensation_pipeline(bad)
    assert repr(bad) in str(info.value)
    assert type(bad).__name__ in str(info.value)


def test_unknown_feature_parameter_is_a_type_error():
    with pytest.raises(TypeError, match="smothing"):
        make_compensation_pipeline(smothing=1.0)
