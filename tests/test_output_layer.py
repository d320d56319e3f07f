"""The output layer of a fitted final regressor (sklearn_ifog._output_layer): one list of the
supported linear regressors for the exports, the compiled path, the recalibration and
partial pooling, and the functions that read and replace the layer."""

import numpy as np
import pytest
from sklearn import linear_model

from sklearn_ifog import RBFNetRegressor, UnitwiseRegressor, make_compensation_pipeline
from sklearn_ifog._compiled import compile_steps
from sklearn_ifog._description import describe_pipeline
from sklearn_ifog._output_layer import (
    LINEAR_REGRESSORS,
    has_output_layer,
    layer_design,
    layer_kind,
    layer_weights,
    read_layer,
    with_weights,
)
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.streaming import StreamingCompensator


def _regressor(cls):
    """A small, deterministic instance of ``cls`` that fits the campaign's drift."""
    params = {
        "SGDRegressor": {"random_state": 0},
        "TheilSenRegressor": {"random_state": 0, "max_subpopulation": 200},
        "QuantileRegressor": {"alpha": 0.0},
        "Lasso": {"alpha": 1e-3},
        "LassoLars": {"alpha": 1e-3},
        "ElasticNet": {"alpha": 1e-3},
    }
    return cls(**params.get(cls.__name__, {}))


@pytest.fixture(scope="module")
def lot():
    """Three units of one design, one run each (see ``_no_far_units``)."""
    frame = make_thermal_campaign(
        n_units=3,
        n_runs=1,
        azimuths=[0.0],
        sampling_period=300.0,
        lot_spread=0.15,
        random_state=3,
    ).frame
    assert (frame.groupby("unit")["run"].nunique() == 1).all()
    return frame, (frame["rate"] - frame["reference"]).to_numpy()


def test_one_list_of_linear_regressors():
    assert len(set(LINEAR_REGRESSORS)) == len(LINEAR_REGRESSORS) == 15
    for cls in (RBFNetRegressor, *LINEAR_REGRESSORS):
        assert has_output_layer(_regressor(cls) if cls is not RBFNetRegressor else cls())
    assert layer_kind(linear_model.Ridge()) == "linear"
    assert layer_kind(RBFNetRegressor()) == "rbf_network"
    assert layer_kind(linear_model.LogisticRegression()) is None


@pytest.fixture
def _no_far_units(monkeypatch):
    """The far-unit rule off (``OWN_MODEL_SPREAD`` infinite): a unit the evidence puts far
    from the lot would keep its own model, and these tests read the shrunk layers."""
    monkeypatch.setattr("sklearn_ifog.unitwise.OWN_MODEL_SPREAD", np.inf)


@pytest.mark.parametrize("cls", LINEAR_REGRESSORS, ids=lambda cls: cls.__name__)
@pytest.mark.usefixtures("_no_far_units")
def test_every_exported_regressor_is_pooled(cls, lot):
    """Every regressor the exports write has its layer shrunk by partial pooling."""
    frame, y = lot
    X = frame[["unit", "temperature", "time", "run"]]
    pipeline = make_compensation_pipeline(_regressor(cls))
    model = UnitwiseRegressor(pipeline, pooling="partial").fit(X, y)
    lot_model = model.lot_estimator_
    describe_pipeline(lot_model)  # it exports
    inner = X.drop(columns="unit")
    prediction = model.predict(X)
    for unit, unit_model in model.estimators_.items():
        rows = (X["unit"] == unit).to_numpy()
        final = unit_model[-1]
        assert type(final) is cls
        assert final is not lot_model[-1]
        assert model.shrinkage_[unit] in model.shrinkage_grid_
        # The unit's prediction is its layer's: the lot's design times the shrunk weights.
        Phi = layer_design(final, unit_model[:-1].transform(inner[rows]))
        np.testing.assert_allclose(
            prediction[rows], Phi @ layer_weights(final)[:, 0], rtol=1e-10, atol=1e-10
        )
    # The lot's own weights differ from a shrunk unit's: the pooling moved them.
    moved = [
        np.max(np.abs(layer_weights(m[-1]) - layer_weights(lot_model[-1])))
        for m in model.estimators_.values()
    ]
    assert max(moved) > 0


@pytest.mark.parametrize(
    "make",
    [
        lambda: linear_model.LinearRegression(),
        lambda: RBFNetRegressor(n_centers=4, criterion=None, random_state=0),
        lambda: RBFNetRegressor(n_centers=4, criterion=None, tail="quadratic", random_state=0),
        lambda: RBFNetRegressor(n_centers=4, criterion=None, tail=False, random_state=0),
    ],
    ids=["linear", "rbf", "rbf-quadratic", "rbf-no-tail"],
)
@pytest.mark.parametrize("n_outputs", [1, 2])
def test_read_and_replace_the_layer(make, n_outputs, lot):
    frame, y = lot
    X = frame[["temperature"]].to_numpy()
    X = np.column_stack([X, np.gradient(X[:, 0])])
    Y = y if n_outputs == 1 else np.column_stack([y, 2 * y + 0.1])
    final = make().fit(X, Y)
    layer = read_layer(final)
    assert layer.single_output is (n_outputs == 1)
    assert layer.n_outputs == n_outputs
    # The pooled view: design @ weights is the regressor's prediction.
    Phi, W = layer_design(final, X), layer_weights(final)
    np.testing.assert_allclose(Phi @ W, final.predict(X).reshape(len(X), -1), rtol=1e-9, atol=1e-9)
    # Writing the weights back leaves the model as it was; writing others moves it.
    same = with_weights(final, W)
    np.testing.assert_array_equal(same.predict(X), final.predict(X))
    moved = with_weights(final, 2 * W)
    np.testing.assert_allclose(moved.predict(X), 2 * final.predict(X), rtol=1e-9, atol=1e-9)
    assert np.shape(moved.coef_) == np.shape(final.coef_)
    assert np.shape(moved.intercept_) == np.shape(final.intercept_)
    # The stored view (compiled path, recalibration, exports): the tail as stored, so a
    # network fitted without a tail carries a zero linear tail there, and not in pooling.
    stored = layer.weights
    assert stored.shape[1] == n_outputs
    if isinstance(final, RBFNetRegressor) and final.tail_degree_ == 0:
        assert layer.tail_degree == 1
        assert layer.fitted_tail_degree == 0
        n_centers = layer.coef.shape[1]
        assert stored.shape[0] == W.shape[0] + X.shape[1]
        assert not np.any(stored[n_centers:-1])
    else:
        np.testing.assert_array_equal(stored, W)


def test_the_compiled_path_and_the_recalibration_read_the_same_layer(lot):
    frame, y = lot
    X = frame[frame["unit"] == 0]
    model = make_compensation_pipeline(
        RBFNetRegressor(n_centers=4, criterion=None, tail=False, random_state=0)
    ).fit(X, y[(frame["unit"] == 0).to_numpy()])
    compiled = compile_steps(model)
    np.testing.assert_array_equal(compiled.final.weights, read_layer(model[-1]).weights)
    compensator = StreamingCompensator(model, adapt="output")
    np.testing.assert_array_equal(
        compensator.get_state()["rls"]["weights"], read_layer(model[-1]).weights
    )
    # and the C export writes the stored tail (degree 1, zeros) of the same network
    step = describe_pipeline(model)["steps"][-1]
    assert step["tail_degree"] == 1
    assert not np.any(step["tail_coef"])
