"""Online recalibration of the output layer: its prior, its state and its step, in one place.

A private module that serves several: :class:`~sklearn_ifog.streaming.StreamingCompensator`
(each sample with a reference updates the layer) and the C export
(:func:`~sklearn_ifog.export.to_c` writes the same prior, checked by the same rules, so that
the generated recalibration equals the Python one).

With ``adapt="bias"`` the layer is one offset per output added to the drift; with
``adapt="output"`` it is the final regressor's output layer
(:class:`~sklearn_ifog._output_layer.OutputLayer`, as the compiled path evaluates it:
:attr:`sklearn_ifog._compiled.CompiledSteps.final`). The recursion is the square-root
recursive least squares of :mod:`sklearn_ifog._rls`.
"""

import numbers
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from sklearn_ifog._rls import covariance_trace, initial_factor, rls_sequence, rls_step
from sklearn_ifog.streaming._inputs import state_numbers

#: The recalibration modes of ``StreamingCompensator(adapt=...)``.
ADAPT_MODES = (None, "bias", "output")


def check_adaptation(adapt, forgetting):
    """Raise a ``ValueError`` unless ``adapt`` and ``forgetting`` are valid parameters."""
    if adapt not in ADAPT_MODES:
        raise ValueError(f"adapt must be None, 'bias' or 'output', got {adapt!r}.")
    if (
        isinstance(forgetting, bool)
        or not isinstance(forgetting, numbers.Real)
        or not (0.0 < float(forgetting) <= 1.0)
    ):
        raise ValueError(f"forgetting must be a number in (0, 1], got {forgetting!r}.")


class RecalibrationPrior(NamedTuple):
    """Where the recalibration starts: the fitted layer and its initial covariance factor.

    Attributes
    ----------
    weights : ndarray of shape (n_weights, n_outputs)
        The initial weights (zeros for ``"bias"``; the fitted output layer for
        ``"output"``).
    factor : ndarray of shape (n_weights, n_weights)
        The factor ``S0`` of the initial covariance ``P0 = S0 S0'``
        (:func:`sklearn_ifog._rls.initial_factor`): also the reset after an overflow.
    trace : float
        ``trace(P0)``, the bound on the covariance's trace (wind-up).
    """

    weights: np.ndarray
    factor: np.ndarray
    trace: float


def recalibration_prior(adapt, compiled, n_outputs, regressor=None):
    """The prior of the recalibration ``adapt`` (None without one).

    Parameters
    ----------
    adapt : {None, "bias", "output"}
        The mode.
    compiled : CompiledSteps or None
        The pipeline's compiled steps (:func:`sklearn_ifog._compiled.compile_steps`);
        ``"output"`` needs them.
    n_outputs : int
        Outputs of the model.
    regressor : estimator, default=None
        The final regressor, named in the error when ``"output"`` has no compiled steps.

    Returns
    -------
    prior : RecalibrationPrior or None
    """
    if adapt is None:
        return None
    if adapt == "bias":
        weights = np.zeros((1, n_outputs))
        bias_index = 0
    else:
        if compiled is None:
            raise ValueError(
                "adapt='output' needs a final regressor with a linear output layer "
                "(RBFNetRegressor or a linear model) after known scalers; got "
                f"{type(regressor).__module__}.{type(regressor).__qualname__} (use "
                "adapt='bias')."
            )
        weights = compiled.final.weights.copy()
        bias_index = compiled.final.bias_index
    factor = initial_factor(weights, bias_index=bias_index)
    return RecalibrationPrior(weights, factor, covariance_trace(factor))


def _count(value, key):
    """A count of the state (``state['rls'][key]``) as an int; else a ``ValueError``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < 0:
        raise ValueError(
            f"state['rls'][{key!r}] must be a count (an integer >= 0), got {value!r}."
        )
    return int(value)


@dataclass(frozen=True)
class RecalibrationState:
    """The recalibration between samples: the layer's weights and their covariance factor.

    Never modified in place: every update returns a new state (a call that fails half-way
    leaves the compensator's state as it was).

    Attributes
    ----------
    weights : ndarray of shape (n_weights, n_outputs)
        The current output-layer weights.
    covariance_factor : ndarray of shape (n_weights, n_weights)
        The factor ``S`` of their covariance ``P = S S'`` (over the noise variance).
    n_updates : int
        References used (those of samples inside the calibration domain).
    n_resets : int
        Resets of the factor to the prior's (after an overflow).
    """

    weights: np.ndarray
    covariance_factor: np.ndarray
    n_updates: int = 0
    n_resets: int = 0

    KEYS = ("weights", "covariance_factor", "n_updates", "n_resets")

    @classmethod
    def start(cls, prior):
        """The state at the prior (copies of its arrays)."""
        return cls(prior.weights.copy(), prior.factor.copy())

    def to_dict(self):
        """The state as JSON-able nested lists and ints (``get_state``'s ``"rls"``)."""
        return {
            "weights": self.weights.tolist(),
            "covariance_factor": self.covariance_factor.tolist(),
            "n_updates": int(self.n_updates),
            "n_resets": int(self.n_resets),
        }

    @classmethod
    def from_dict(cls, value, shape):
        """A state from :meth:`to_dict`'s form, checked against the weights' ``shape``.

        Raises a ``ValueError`` naming the entry (``state['rls'][...]``) that is missing or
        not what it must be.
        """
        keys = set(cls.KEYS)
        if not isinstance(value, dict) or set(value) != keys:
            got = sorted(value) if isinstance(value, dict) else type(value).__name__
            raise ValueError(f"state['rls'] must be a dict with keys {sorted(keys)}, got {got}.")
        weights = state_numbers(value["weights"], "state['rls']['weights']", shape)
        factor = state_numbers(
            value["covariance_factor"],
            "state['rls']['covariance_factor']",
            (shape[0], shape[0]),
            "(weights, weights)",
        )
        counts = [_count(value[key], key) for key in ("n_updates", "n_resets")]
        return cls(weights, factor, *counts)

    def learn_row(self, phi, target, forgetting, prior):
        """The state after one sample with design row ``phi`` and measured ``target``."""
        weights, factor, resets = rls_step(
            self.weights,
            self.covariance_factor,
            phi,
            np.atleast_1d(np.asarray(target, dtype=np.float64)),
            forgetting,
            prior.factor,
            prior.trace,
        )
        return RecalibrationState(weights, factor, self.n_updates + 1, self.n_resets + resets)

    def learn_rows(self, design, target, learns, forgetting, prior):
        """``(prediction, state)`` over consecutive samples, in order.

        Each row is predicted with the weights before its own update; the rows where
        ``learns`` is True then update them (see :func:`sklearn_ifog._rls.rls_sequence`).
        """
        prediction, weights, factor, resets = rls_sequence(
            self.weights, self.covariance_factor, design, target, learns, forgetting, prior.factor
        )
        state = RecalibrationState(
            weights, factor, self.n_updates + int(learns.sum()), self.n_resets + resets
        )
        return prediction, state
