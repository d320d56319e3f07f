"""Metadata routing of ``groups`` and ``sample_weight`` through the package's meta-estimators.

With ``sklearn.set_config(enable_metadata_routing=True)``, a ``fit`` parameter reaches an
inner estimator that requests it (``set_fit_request``), cut to the rows that estimator fits
on; one it does not request is scikit-learn's own error. Without routing, ``fit`` parameters
go to the inner ``fit`` as they are (the scikit-learn convention of, e.g.,
``TransformedTargetRegressor``).
"""

import warnings

import numpy as np
import pytest
import sklearn
from sklearn.exceptions import UnsetMetadataPassedError
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GridSearchCV, GroupKFold

from sklearn_ifog import (
    ConformalRegressor,
    RBFNetRegressor,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog.datasets import make_thermal_campaign


@pytest.fixture(scope="module")
def lot():
    """Three independent units of three runs, coarse sampling (fast)."""
    return make_thermal_campaign(
        n_units=3, n_runs=3, azimuths=[0.0], sampling_period=300.0, random_state=2
    )


@pytest.fixture
def routing():
    with sklearn.config_context(enable_metadata_routing=True):
        yield


def _network(**requests):
    network = RBFNetRegressor(n_centers="auto", refine=None, max_samples=400, random_state=0)
    return network.set_fit_request(**requests) if requests else network


def _quiet(function, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return function(*args, **kwargs)


def _unit(lot, unit):
    rows = (lot.data["unit"] == unit).to_numpy()
    return rows, lot.data[rows].drop(columns="unit"), lot.target.to_numpy()[rows]


def test_routed_groups_change_the_inner_network_of_each_unit(lot, routing):
    """Blocks of 25 rows as groups: each unit's network is the one fitted directly on its
    rows with its groups, and (on at least one unit) not the one fitted without them."""
    groups = np.arange(lot.data.shape[0]) // 25
    model = UnitwiseRegressor(make_compensation_pipeline(_network(groups=True)), pooling="none")
    _quiet(model.fit, lot.data, lot.target, groups=groups)
    changed = 0
    for unit in range(3):
        rows, X, y = _unit(lot, unit)
        direct = _quiet(
            make_compensation_pipeline(_network(groups=True)).fit, X, y, groups=groups[rows]
        )
        plain = _quiet(make_compensation_pipeline(_network()).fit, X, y)
        fitted = model.estimators_[unit][-1]
        np.testing.assert_array_equal(fitted.coef_, direct[-1].coef_)
        changed += fitted.coef_.shape != plain[-1].coef_.shape or not np.array_equal(
            fitted.coef_, plain[-1].coef_
        )
    assert changed >= 1


def test_an_unrequested_parameter_is_scikit_learns_error(lot, routing):
    groups = np.arange(lot.data.shape[0]) // 25
    for model in (
        UnitwiseRegressor(make_compensation_pipeline(_network()), pooling="none"),
        ConformalRegressor(make_compensation_pipeline(LinearRegression())),
    ):
        with pytest.raises(UnsetMetadataPassedError, match="sample_weight"):
            _quiet(model.fit, lot.data, lot.target, sample_weight=np.ones(len(lot.target)))
    with pytest.raises(UnsetMetadataPassedError, match="groups"):
        _quiet(
            UnitwiseRegressor(make_compensation_pipeline(_network())).fit,
            lot.data,
            lot.target,
            groups=groups,
        )


def test_routed_sample_weight_reaches_every_fold_model(lot, routing):
    _, X, y = _unit(lot, 0)
    weight = np.linspace(0.5, 2.0, y.size)
    inner = make_compensation_pipeline(LinearRegression().set_fit_request(sample_weight=True))
    model = _quiet(ConformalRegressor(inner).fit, X, y, sample_weight=weight)
    runs = X["run"].to_numpy()
    for fold, run in zip(model.estimators_, np.unique(runs), strict=True):
        train = runs != run
        direct = _quiet(
            make_compensation_pipeline(LinearRegression().set_fit_request(sample_weight=True)).fit,
            X[train],
            y[train],
            sample_weight=weight[train],
        )
        np.testing.assert_allclose(fold[-1].coef_, direct[-1].coef_, rtol=1e-10)
    unweighted = _quiet(
        ConformalRegressor(make_compensation_pipeline(LinearRegression())).fit, X, y
    )
    assert not np.allclose(model.estimator_[-1].coef_, unweighted.estimator_[-1].coef_)


def test_grid_search_routes_groups_to_its_folds_and_the_conformal_calibration(lot, routing):
    """Groups of half a run each (six, where the run column holds three): GridSearchCV
    splits on them and hands them to ConformalRegressor, whose calibration groups they
    become; the weights reach the inner regression."""
    _, X, y = _unit(lot, 1)
    runs = X["run"].to_numpy()
    position = np.concatenate([np.arange(n) for n in np.unique(runs, return_counts=True)[1]])
    size = np.repeat(
        np.unique(runs, return_counts=True)[1], np.unique(runs, return_counts=True)[1]
    )
    halves = runs * 2 + (position >= size / 2)
    weight = np.linspace(0.5, 2.0, y.size)
    inner = make_compensation_pipeline(LinearRegression().set_fit_request(sample_weight=True))
    # scikit-learn's rule: the score says whether it wants the weights too (here: no)
    conformal = ConformalRegressor(inner, cv=2).set_score_request(sample_weight=False)
    search = GridSearchCV(conformal, {"coverage": [0.8, 0.9]}, cv=GroupKFold(n_splits=3))
    _quiet(search.fit, X, y, groups=halves, sample_weight=weight)
    best = search.best_estimator_
    assert np.unique(runs).size == 3
    assert sorted(best.groups_.tolist()) == sorted(np.unique(halves).tolist())
    direct = _quiet(
        make_compensation_pipeline(LinearRegression().set_fit_request(sample_weight=True)).fit,
        X,
        y,
        sample_weight=weight,
    )
    np.testing.assert_allclose(best.estimator_[-1].coef_, direct[-1].coef_, rtol=1e-10)


def test_without_routing_fit_parameters_go_to_the_inner_fit(lot):
    rows, X, y = _unit(lot, 2)
    weight = np.linspace(0.5, 2.0, y.size)
    model = UnitwiseRegressor(make_compensation_pipeline(LinearRegression()), pooling="none")
    model.fit(lot.data[rows], y, regressor__sample_weight=weight)
    direct = make_compensation_pipeline(LinearRegression()).fit(
        X, y, regressor__sample_weight=weight
    )
    np.testing.assert_allclose(model.estimators_[2][-1].coef_, direct[-1].coef_, rtol=1e-10)


def test_add_units_passes_and_routes_fit_parameters_as_fit_does(lot):
    X, y = lot.data, lot.target.to_numpy()
    new = (X["unit"] == 2).to_numpy()
    weight = np.linspace(0.5, 2.0, int(new.sum()))
    direct = make_compensation_pipeline(LinearRegression()).fit(
        X[new].drop(columns="unit"), y[new], regressor__sample_weight=weight
    )
    model = UnitwiseRegressor(make_compensation_pipeline(LinearRegression()), pooling="none")
    model.fit(X[~new], y[~new]).add_units(X[new], y[new], regressor__sample_weight=weight)
    np.testing.assert_allclose(model.estimators_[2][-1].coef_, direct[-1].coef_, rtol=1e-10)
    with sklearn.config_context(enable_metadata_routing=True):
        inner = make_compensation_pipeline(LinearRegression().set_fit_request(sample_weight=True))
        routed = UnitwiseRegressor(inner, pooling="none").fit(X[~new], y[~new])
        routed.add_units(X[new], y[new], sample_weight=weight)
        np.testing.assert_allclose(routed.estimators_[2][-1].coef_, direct[-1].coef_, rtol=1e-10)
        unrequested = UnitwiseRegressor(make_compensation_pipeline(LinearRegression()))
        unrequested.set_params(pooling="none").fit(X[~new], y[~new])
        with pytest.raises(UnsetMetadataPassedError, match="sample_weight"):
            unrequested.add_units(X[new], y[new], sample_weight=weight)
        assert 2 not in unrequested.estimators_
