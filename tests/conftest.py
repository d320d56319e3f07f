"""Shared fixtures: simulated campaigns built once per test session, and ``pyplot``.

The campaigns are session-scoped: tests must not modify them (copy a frame before changing
it).

Under pytest-xdist (the README's ``-n 2``) the workers share the machine's cores: each gets
its share of BLAS and OpenMP threads, in its own process and in the processes its tests start
(the benchmarks' quick runs, the CLI). A pool of one thread per core in every worker only
makes the workers' threads wait for each other: on two cores, the whole suite took 20 to
25 % longer, and bench_thermal_state's quick run (HistGradientBoosting's OpenMP loops) up to
twice as long. A thread count set in the environment is kept.
"""

import os

import pytest
from threadpoolctl import threadpool_limits

from sklearn_ifog.datasets import make_thermal_campaign

_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_WORKERS = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
if _WORKERS > 1 and not any(variable in os.environ for variable in _THREAD_VARIABLES):
    _THREADS = max(1, (os.cpu_count() or 1) // _WORKERS)
    os.environ.update(dict.fromkeys(_THREAD_VARIABLES, str(_THREADS)))
    # The libraries loaded before this line (numpy's and scipy's BLAS, OpenMP) read the
    # environment when they loaded: limit them here.
    threadpool_limits(limits=_THREADS)


@pytest.fixture(scope="session")
def default_campaign():
    """The simulator's default campaign (3 units, 4 azimuths, 5 runs each, 60 s), seed 0."""
    return make_thermal_campaign(random_state=0)


@pytest.fixture(scope="session")
def small_campaign():
    """One unit, three runs at each of two azimuths, 60 s samples (about 1 900 rows)."""
    return make_thermal_campaign(
        n_units=1, n_runs=3, azimuths=(0.0, 90.0), sampling_period=60.0, random_state=0
    )


@pytest.fixture
def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend; every figure closed after.

    As scikit-learn's own ``pyplot`` fixture: a test that draws through pyplot (or runs
    code that does) asks for it, and is skipped when matplotlib is not installed.
    """
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("agg", force=True)
    pyplot = pytest.importorskip("matplotlib.pyplot")
    pyplot.close("all")
    yield pyplot
    pyplot.close("all")
