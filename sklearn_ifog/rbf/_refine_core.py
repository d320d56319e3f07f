"""What the three refinement methods share: data, loss, bounds, derivatives, best iterate.

The network, on standardised inputs ``Z`` (a :class:`~sklearn_ifog.rbf._basis.Network`)::

    f(Z) = Phi(Z; centers, widths) @ coef.T + tail_features(Z, degree) @ tail_coef.T + intercept
    Phi_ij = exp(-||z_i - c_j||² / (2 σ_j²))

and the loss every method decreases (``s`` the sample weights, summed over the outputs)::

    L = Σ_i s_i ||y_i - f(z_i)||² + alpha ||coef||²

All methods work on log-parametrised widths ``log σ_j`` (so a width can never reach zero or
change sign), within the same bounds: widths within a factor ``WIDTH_RANGE`` of their start
and within ``WIDTH_LIMITS`` (standardised units); centres within the data's bounding box
widened by its span (at least 1) on each side. :class:`Tracker` keeps the best iterate and
applies the early-stopping rule (see ``_refine``).
"""

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from sklearn_ifog.rbf._basis import WIDTH_LIMITS, Network, squared_distances

#: Widths may move by at most this factor (up or down) from their starting values.
WIDTH_RANGE = 100.0
#: Iterations without a relative improvement of ``tol`` before "varpro"/"lm" stop early.
PATIENCE = 5
#: Epochs without a relative improvement of ``tol`` before "gd" stops.
PATIENCE_GD = 10
#: Relative improvement of the early-stopping loss below which patience is not reset (an
#: improvement smaller than this, or than ``tol``, counts as none).
EARLY_STOPPING_TOL = 1e-3


@dataclass
class RefineResult:
    """Outcome of :func:`~sklearn_ifog.rbf._refine.refine_network`.

    Parameters
    ----------
    network : Network
        Centres and widths (standardised units), Gaussian weights ``coef`` (n_outputs,
        n_centers), tail weights ``tail_coef`` (n_outputs, n_tail: 0 without a tail, ``d``
        for the inputs, ``d + d (d + 1) / 2`` with their degree-2 monomials) and intercepts.
    n_iter : int
        Iterations run (epochs for ``"gd"``).
    converged : bool
        True when the method stopped on its tolerance or on early stopping, False when it
        stopped on ``max_iter``.
    improved : bool
        True when the returned network's selection loss (validation loss when validation data
        was given, training loss otherwise) is lower than the starting network's. When False,
        the returned arrays are copies of the starting network.
    history : dict
        ``{"train_loss": [...], "val_loss": [...]}``: entry 0 is the starting network, then
        one entry per iteration. ``train_loss`` is ``L`` divided by the total sample weight,
        ``val_loss`` the weighted validation mean squared error summed over outputs (empty
        without validation data).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.rbf._basis import Network
    >>> net = Network(
    ...     centers=np.zeros((1, 1)),
    ...     widths=np.ones(1),
    ...     coef=np.zeros((1, 1)),
    ...     tail_coef=np.zeros((1, 0)),
    ...     intercept=np.zeros(1),
    ... )
    >>> res = RefineResult(net, 0, True, False)
    >>> res.history
    {'train_loss': [], 'val_loss': []}
    """

    network: Network
    n_iter: int
    converged: bool
    improved: bool
    history: dict = field(default_factory=lambda: {"train_loss": [], "val_loss": []})


def log_activations(Z, centers, log_widths):
    """Squared distances, Gaussian activations and ``1/σ²`` for log-widths."""
    D2 = squared_distances(Z, centers)
    inv_var = np.exp(-2.0 * log_widths)
    Phi = np.exp(D2 * (-0.5 * inv_var))
    return D2, Phi, inv_var


def nonlinear_derivatives(Z, centers, D2, Phi, inv_var, root_w):
    """Derivatives of ``root_w * Phi_j`` w.r.t. the centres then the log-widths.

    Column ``j * d + l`` is ``∂/∂c_jl``, column ``K * d + j`` is ``∂/∂ log σ_j``; each column only
    involves unit ``j``. Returns an array of shape (n_samples, K * (d + 1)).
    """
    n, d = Z.shape
    K = centers.shape[0]
    Psi = Phi * inv_var
    Psi *= root_w[:, None]
    out = np.empty((n, K * (d + 1)))
    dC = out[:, : K * d].reshape(n, K, d)
    # One feature at a time: 2-D temporaries are ~4x faster than a 3-D broadcast.
    for feature in range(d):
        column = np.subtract(Z[:, feature : feature + 1], centers[:, feature])
        column *= Psi
        dC[:, :, feature] = column
    np.multiply(Psi, D2, out=out[:, K * d :])
    return out


def unit_of_parameter(n_centers, n_features):
    """Index of the Gaussian unit each nonlinear parameter belongs to."""
    return np.concatenate([np.repeat(np.arange(n_centers), n_features), np.arange(n_centers)])


def log_width_bounds(widths):
    """Starting log-widths (clipped into the absolute limits) and their bounds."""
    lo_abs, hi_abs = np.log(WIDTH_LIMITS)
    with np.errstate(divide="ignore"):
        log_w0 = np.clip(np.log(widths), lo_abs, hi_abs)
    lower = np.maximum(log_w0 - np.log(WIDTH_RANGE), lo_abs)
    upper = np.minimum(log_w0 + np.log(WIDTH_RANGE), hi_abs)
    return log_w0, lower, upper


def center_bounds(Z, n_centers):
    """Per-feature box for the centres: the data's box widened by its span (at least 1)."""
    zmin, zmax = Z.min(axis=0), Z.max(axis=0)
    span = np.maximum(zmax - zmin, 1.0)
    lower = np.tile(zmin - span, n_centers)
    upper = np.tile(zmax + span, n_centers)
    return lower, upper


def network_loss(Z, Y, sw, total, network, alpha):
    """Weighted sum of squares plus ridge penalty, divided by the total weight; inf if bad."""
    with np.errstate(all="ignore"):
        pred = network.predict(Z)
        value = (
            sw @ np.square(pred - Y).sum(axis=1) + alpha * np.sum(np.square(network.coef))
        ) / total
    return float(value) if np.isfinite(value) else np.inf


def check_weights(sample_weight, n, name):
    if sample_weight is None:
        return np.ones(n)
    sw = np.asarray(sample_weight, dtype=np.float64)
    if sw.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {sw.shape}.")
    if not np.all(np.isfinite(sw)) or np.any(sw < 0) or sw.sum() <= 0:
        raise ValueError(f"{name} must be finite, non-negative and have a positive sum.")
    return sw


def as_float_array(a, name, ndim=2):
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-D array, got shape {a.shape}.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinity.")
    return a


class Tracker:
    """Keeps the best network seen, the loss history, and decides when to stop early."""

    def __init__(self, start, train0, val0, has_val, tol, patience):
        self.has_val = has_val
        self.tol = tol
        self.patience = patience
        self.start = start
        self.start_key = val0 if has_val else train0
        self.best = start
        self.best_key = self.start_key
        self.reference_key = self.start_key  # last value that counted as a real improvement
        self.stale = 0
        self.history = {"train_loss": [train0], "val_loss": [val0] if has_val else []}

    def update(self, network, train, val):
        """Record an iterate; return True when patience has run out."""
        self.history["train_loss"].append(train)
        if self.has_val:
            self.history["val_loss"].append(val)
        key = val if self.has_val else train
        if key < self.best_key:
            self.best, self.best_key = network, key
        if np.isfinite(self.reference_key):
            threshold = max(self.tol, EARLY_STOPPING_TOL) * abs(self.reference_key)
            significant = key < self.reference_key - threshold
        else:
            significant = np.isfinite(key)
        if significant:
            self.reference_key, self.stale = key, 0
        else:
            self.stale += 1
        return self.stale >= self.patience

    def result(self, n_iter, converged):
        improved = self.best_key < self.start_key
        network = self.best if improved else self.start
        return RefineResult(network.copy(), n_iter, converged, improved, self.history)


class RefineData(NamedTuple):
    """Training rows (possibly subsampled), validation rows, and the penalty."""

    Z: np.ndarray
    Y: np.ndarray
    sw: np.ndarray
    total: float
    Z_val: np.ndarray | None
    Y_val: np.ndarray | None
    sw_val: np.ndarray | None
    total_val: float
    alpha: float
    T: np.ndarray  # tail regressors of the training rows, (n, n_tail)

    def val_loss(self, network):
        if self.Z_val is None:
            return None
        return network_loss(self.Z_val, self.Y_val, self.sw_val, self.total_val, network, 0.0)

    def train_loss(self, network):
        return network_loss(self.Z, self.Y, self.sw, self.total, network, self.alpha)
