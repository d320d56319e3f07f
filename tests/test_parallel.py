"""``n_jobs`` of the meta-estimators: the same fitted models and predictions as serial.

Each unit of ``UnitwiseRegressor`` and each fold of ``ConformalRegressor`` is an independent
fit; spreading them over processes (joblib's loky backend) or a Dask cluster
(``joblib.parallel_config(backend="dask")``) must not change a single number.
"""

import warnings

import distributed
import joblib
import numpy as np
import pytest
from sklearn.linear_model import LinearRegression

from sklearn_ifog import (
    ConformalRegressor,
    RBFNetRegressor,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog.datasets import make_thermal_campaign


@pytest.fixture(scope="module")
def lot():
    """Four independent units of three runs, coarse sampling (fast)."""
    return make_thermal_campaign(
        n_units=4,
        n_runs=3,
        azimuths=[0.0],
        sampling_period=300.0,
        lot_spread=None,
        random_state=5,
    )


def _rbf():
    return make_compensation_pipeline(
        RBFNetRegressor(refine=None, tail="linear", max_samples=400, random_state=0)
    )


def _fitted_unitwise(lot, pooling, n_jobs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model = UnitwiseRegressor(_rbf(), pooling=pooling, n_jobs=n_jobs)
        return model.fit(lot.data, lot.target)


def _networks(model):
    """Every unit's fitted output: (centres, coefficients, intercept) in unit order."""
    arrays = []
    for unit in model.units_:
        final = model.estimators_[unit].steps[-1][1]
        arrays += [final.centers_, final.coef_, np.atleast_1d(final.intercept_)]
    return arrays


@pytest.mark.parametrize("pooling", ["none", "partial"])
def test_unitwise_n_jobs_gives_the_serial_models_bit_for_bit(lot, pooling):
    serial = _fitted_unitwise(lot, pooling, None)
    parallel = _fitted_unitwise(lot, pooling, 2)
    for a, b in zip(_networks(serial), _networks(parallel), strict=True):
        np.testing.assert_array_equal(a, b)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        np.testing.assert_array_equal(serial.predict(lot.data), parallel.predict(lot.data))
    if pooling == "partial":
        assert serial.shrinkage_ == parallel.shrinkage_
        assert serial.own_scores_ == parallel.own_scores_


def test_unitwise_n_jobs_names_a_failing_unit(lot):
    X = lot.data.copy()
    X.loc[X["unit"] == 2, "temperature"] = np.nan
    model = UnitwiseRegressor(_rbf(), pooling="none", n_jobs=2)
    with pytest.raises(ValueError, match=r"unit 2 \(column 'unit'\).*temperature"):
        model.fit(X, lot.target)


def test_conformal_n_jobs_gives_the_serial_band_bit_for_bit(lot):
    X = lot.data[lot.data["unit"] == 0]
    y = lot.target[X.index]
    serial = ConformalRegressor(make_compensation_pipeline(LinearRegression())).fit(X, y)
    parallel = ConformalRegressor(make_compensation_pipeline(LinearRegression()), n_jobs=2)
    parallel.fit(X, y)
    np.testing.assert_array_equal(serial.oof_prediction_, parallel.oof_prediction_)
    np.testing.assert_array_equal(serial.scores_, parallel.scores_)
    np.testing.assert_array_equal(serial.predict_interval(X), parallel.predict_interval(X))
    assert len(parallel.estimators_) == len(serial.estimators_) == 3


@pytest.mark.parametrize("n_jobs", [0, 1.5, "2"])
def test_bad_n_jobs_is_named(lot, n_jobs):
    for model in (
        UnitwiseRegressor(_rbf(), n_jobs=n_jobs),
        ConformalRegressor(_rbf(), n_jobs=n_jobs),
    ):
        with pytest.raises((ValueError, TypeError), match="n_jobs"):
            model.fit(lot.data, lot.target)


def test_a_dask_cluster_gives_the_serial_result(lot):
    serial = _fitted_unitwise(lot, "none", None)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster),
        joblib.parallel_config(backend="dask"),
    ):
        spread = _fitted_unitwise(lot, "none", -1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        np.testing.assert_allclose(
            spread.predict(lot.data), serial.predict(lot.data), rtol=0, atol=1e-12
        )


@pytest.mark.parametrize("n_jobs", [None, 2])
def test_verbose_reports_every_unit_on_stderr(lot, capsys, n_jobs):
    model = UnitwiseRegressor(_rbf(), pooling="none", n_jobs=n_jobs, verbose=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model.fit(lot.data, lot.target)
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert [line.split(" fitted ")[1].split(")")[0] + ")" for line in lines] == [
        f"({k} of 4)" for k in range(1, 5)
    ]
    assert all(line.startswith("[UnitwiseRegressor] unit ") for line in lines)
    UnitwiseRegressor(_rbf(), pooling="none").fit(lot.data, lot.target)
    assert capsys.readouterr().err == ""
