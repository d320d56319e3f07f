"""Checks of sklearn_ifog._transition that its mutants showed missing (tools/mutation.sh)."""

import numpy as np

from sklearn_ifog import _transition


def test_step_values_at_chosen_points():
    # logistic(1) = 1 / (1 + e^-1); the normal CDF at one width; softplus(0) = w log 2.
    assert _transition.step("logistic", 22.0, 20.0, 2.0) == np.float64(1.0 / (1.0 + np.exp(-1.0)))
    np.testing.assert_allclose(_transition.step("erf", 21.0, 20.0, 1.0), 0.8413447460685429)
    np.testing.assert_allclose(_transition.step("hinge", 20.0, 20.0, 3.0), 3.0 * np.log(2.0))
