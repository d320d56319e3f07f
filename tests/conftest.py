"""Shared fixtures: simulated campaigns built once per test session, and ``pyplot``.

The campaigns are session-scoped: tests must not modify them (copy a frame before changing
it).
"""

import pytest

from sklearn_ifog.datasets import make_thermal_campaign


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
