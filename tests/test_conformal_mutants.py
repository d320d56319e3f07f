"""Numerics of the conformal intervals that mutation testing found unguarded (issue 42,
point 5).

Each test here kills mutants of :mod:`sklearn_ifog.conformal`'s plain functions that
survived ``tests/test_conformal.py`` (``tools/mutation.sh conformal`` on those functions);
the docstrings say which.
"""

import numpy as np
import pytest

from sklearn_ifog.conformal import _cover_both, conformal_quantile, knn_distance, thermal_slope


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
