"""Grid search and compare_regressors on a Dask cluster give the default backend's results.

The cluster is a ``distributed.LocalCluster`` with two single-threaded in-process workers
(``processes=False``: starts in milliseconds and needs no picklable ``__main__``); the work
still goes through the scheduler, joblib's Dask backend and the workers, as on a real
cluster.
"""

import joblib
import numpy as np
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GridSearchCV
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import RBFNetRegressor, ThermalFeatures
from sklearn_ifog.comparison import compare_regressors, default_regressors
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.metrics import neg_mean_squared_deviation_scorer
from sklearn_ifog.model_selection import LeaveOneAzimuthOut

distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")


@pytest.fixture(scope="module")
def client():
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as dask_client,
    ):
        yield dask_client


@pytest.fixture(scope="module")
def campaign():
    return make_thermal_campaign(
        n_units=1, n_runs=3, azimuths=(0.0, 90.0), sampling_period=60.0, random_state=1
    )


def _pipe():
    return Pipeline(
        [
            ("features", ThermalFeatures(time="time", run="run")),
            ("scale", StandardScaler()),
            ("rbf", RBFNetRegressor(random_state=0)),
        ]
    )


GRID = {"features__smoothing": [0.0, 1200.0], "rbf__alpha": [1e-4, 1e-1]}


def test_grid_search_under_dask_equals_default_backend(client, campaign):
    X, y = campaign.data, campaign.target

    def search():
        return GridSearchCV(
            _pipe(), GRID, cv=LeaveOneAzimuthOut(), scoring=neg_mean_squared_deviation_scorer
        )

    local = search().fit(X, y)
    tasks_before = client.run_on_scheduler(_n_task_kinds)
    with joblib.parallel_backend("dask"):
        remote = search().set_params(n_jobs=2).fit(X, y)
    # The work really went through the cluster.
    assert client.run_on_scheduler(_n_task_kinds) > tasks_before
    assert remote.best_params_ == local.best_params_
    # Equal to rounding: BLAS sums in a thread-count-dependent order, and the workers are
    # single-threaded while the test process is not.
    for key in ("mean_test_score", "split0_test_score", "split1_test_score"):
        np.testing.assert_allclose(remote.cv_results_[key], local.cv_results_[key], rtol=1e-12)
    np.testing.assert_allclose(remote.predict(X), local.predict(X), rtol=1e-12)


def _n_task_kinds(dask_scheduler):
    # Kinds (key prefixes) of the tasks the scheduler has run so far.
    return len(dask_scheduler.task_prefixes)


def test_compare_regressors_under_dask_equals_default_backend(client, campaign):
    """The network's reduction above 5 held on campaign seeds 1-10 (checked once)."""
    X, y = campaign.data, campaign.target
    defaults = default_regressors()
    regressors = {
        "raw": defaults["raw"],
        "linear": defaults["linear"],
        "rbf_modified": defaults["rbf_modified"],
        "plain_linear": LinearRegression(),
    }
    columns = ["msd_before", "msd_after", "reduction", "worst_fold_reduction", "n_folds"]
    local = compare_regressors(X, y, regressors=regressors)
    # As the docs advise for large campaigns: ship X and y to the workers once.
    with joblib.parallel_backend("dask", scatter=[X, y]):
        remote = compare_regressors(X, y, regressors=regressors, n_jobs=2)
    assert list(remote.index) == list(regressors)
    np.testing.assert_allclose(remote[columns].to_numpy(), local[columns].to_numpy(), rtol=1e-12)
    assert remote.loc["rbf_modified", "reduction"] > 5.0
