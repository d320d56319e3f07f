"""Refinement of a Gaussian RBF network's centres, widths and output weights.

The network, on standardised inputs ``Z`` (see ``_basis``)::

    f(Z) = Phi(Z; centers, widths) @ coef.T + tail_features(Z, degree) @ tail_coef.T + intercept
    Phi_ij = exp(-||z_i - c_j||² / (2 σ_j²))

with the tail degree (0, 1 or 2) given by the number of tail columns (``_basis.tail_features``);
the tail weights enter linearly, so the degree only changes which tail design is used. The loss
every method decreases (``s`` the sample weights, summed over the outputs)::

    L = Σ_i s_i ||y_i - f(z_i)||² + alpha ||coef||²

Three methods, all on log-parametrised widths ``log σ_j`` (so a width can never reach zero or
change sign):

``"varpro"``
    Variable projection (Golub & Pereyra 1973): the output weights (Gaussian weights, polynomial
    tail, intercept) are the ridge solution for the current centres and widths, so the
    optimiser only sees the nonlinear parameters. ``scipy.optimize.least_squares`` (trust-region
    reflective, bounded; exact trust-region steps up to ``EXACT_TRUST_REGION_MAX_ENTRIES``
    Jacobian entries, truncated LSMR steps of at most ``LSMR_MAX_ITER`` inner iterations
    beyond) with the *exact* Golub–Pereyra Jacobian of
    the projected residual (``varpro_jacobian``; Kaufman's 1975 approximation, which drops the
    second term, is available with ``kaufman=True``). The inner linear solve is an SVD of the
    weighted design with a relative rank cut-off, so a collinear or empty design costs accuracy
    in the weights, never a ``LinAlgError`` or a NaN.
``"lm"``
    Levenberg–Marquardt on all parameters jointly (centres, log-widths, Gaussian weights, tail,
    intercept) with the analytic Jacobian ``full_jacobian``. The normal equations ``JᵀJ`` and
    ``Jᵀr`` are accumulated in row blocks, so memory does not grow with the rows beyond the data
    itself; each damped system is solved by Cholesky, the damping raised until it succeeds
    (Marquardt's diagonal scaling, Nielsen's damping update).
``"gd"``
    The reference paper's gradient rules (its Eqs. 17–19), applied as mini-batch steps of
    ``GD_BATCH_SIZE`` rows over a shuffled epoch (``random_state``), one learning rate for all
    parameters. Eq. 17 updates the weights, Eq. 18 the centres; Eq. 19 is used in log space:
    since ``∂L/∂log σ = σ ∂L/∂σ``, the step is
    ``Δ log σ_j = η Σ_i (d_i - y_i) W_j φ_ij ||z_i - c_j||² / σ_j²`` (Eq. 19 times ``σ_j``).
    Sums are means over the batch (weighted), and the targets are divided by their standard
    deviation inside the method, so ``learning_rate`` does not depend on the units of ``y``.
    The tail and intercept (absent in the paper) follow the same rule as Eq. 17. An epoch whose
    training loss is not finite or more than doubles is undone and the learning rate halved.

Bounds, identical for all methods: widths stay within a factor ``WIDTH_RANGE`` of their start
and within ``WIDTH_LIMITS`` (standardised units); centres stay within the data's bounding box
widened by its span (at least 1) on each side.

Cost: every method works on at most ``max_samples`` training rows (a random subsample), so its
cost does not grow with the data beyond that; all work in the target divided by its standard
deviation (undone on return), so tolerances do not depend on the units of ``y``; BLAS runs
single-threaded inside (threads slow these small factorisations down on shared cores).

Early stopping: with validation data, the returned network is the iterate with the lowest
validation loss (weighted mean squared error summed over outputs), and the method stops once it
has not improved by a relative ``max(tol, EARLY_STOPPING_TOL)`` for ``PATIENCE`` iterations
(``PATIENCE_GD`` epochs for ``"gd"``; ``"gd"`` applies the same rule to the training loss when
there is no validation data). Without validation data it runs to convergence or ``max_iter``
and returns the iterate with the lowest training loss (for ``"varpro"`` and ``"lm"``, which
only accept descent steps, the last one). In both cases, if no iterate beats the starting
network, the starting network is returned unchanged with ``improved=False``.
"""

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import scipy.linalg
from scipy.optimize import least_squares
from sklearn.utils import check_random_state
from threadpoolctl import threadpool_limits

from sklearn_ifog.rbf._basis import (
    predict_network,
    squared_distances,
    tail_degree_from_size,
    tail_features,
)

#: Absolute limits on the widths during refinement, in standardised input units.
WIDTH_LIMITS = (1e-3, 1e3)
#: Widths may move by at most this factor (up or down) from their starting values.
WIDTH_RANGE = 100.0
#: Iterations without a relative improvement of ``tol`` before "varpro"/"lm" stop early.
PATIENCE = 5
#: Epochs without a relative improvement of ``tol`` before "gd" stops.
PATIENCE_GD = 10
#: Relative improvement of the early-stopping loss below which patience is not reset (an
#: improvement smaller than this, or than ``tol``, counts as none).
EARLY_STOPPING_TOL = 1e-3
#: Rows per mini-batch of the gradient rules.
GD_BATCH_SIZE = 32
#: Target size, in float64 entries, of one row block of the Jacobian in "lm".
_BLOCK_ENTRIES = 2**21

_METHODS = ("varpro", "lm", "gd")
#: Largest VarPro Jacobian (entries) for which least_squares solves each trust-region step
#: exactly (an SVD of the Jacobian per iteration); larger ones use its LSMR subspace steps,
#: about twice as fast per iteration at the estimator's 4000 rows and 40 centres.
EXACT_TRUST_REGION_MAX_ENTRIES = 250_000
#: Inner LSMR iterations per trust-region step when the steps are not exact (truncated,
#: inexact steps: measured faster to the same validation loss than LSMR run to its tolerance).
LSMR_MAX_ITER = 30


@dataclass
class RefineResult:
    """Outcome of :func:`refine_network`.

    Parameters
    ----------
    centers : ndarray of shape (n_centers, n_features)
        Centres, standardised units.
    widths : ndarray of shape (n_centers,)
        Widths, standardised units.
    coef : ndarray of shape (n_outputs, n_centers)
        Gaussian output weights.
    tail_coef : ndarray of shape (n_outputs, n_tail)
        Polynomial-tail weights (``n_tail`` is 0 without a tail, ``d`` for the inputs,
        ``d + d (d + 1) / 2`` with their degree-2 monomials).
    intercept : ndarray of shape (n_outputs,)
        Intercepts.
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
    >>> res = RefineResult(
    ...     np.zeros((1, 1)),
    ...     np.ones(1),
    ...     np.zeros((1, 1)),
    ...     np.zeros((1, 0)),
    ...     np.zeros(1),
    ...     0,
    ...     True,
    ...     False,
    ... )
    >>> res.history
    {'train_loss': [], 'val_loss': []}
    """

    centers: np.ndarray
    widths: np.ndarray
    coef: np.ndarray
    tail_coef: np.ndarray
    intercept: np.ndarray
    n_iter: int
    converged: bool
    improved: bool
    history: dict = field(default_factory=lambda: {"train_loss": [], "val_loss": []})


# --------------------------------------------------------------------------------------------
# Shared pieces
# --------------------------------------------------------------------------------------------


def _activations(Z, centers, log_widths):
    """Squared distances, Gaussian activations and ``1/σ²`` for log-widths."""
    D2 = squared_distances(Z, centers)
    inv_var = np.exp(-2.0 * log_widths)
    Phi = np.exp(D2 * (-0.5 * inv_var))
    return D2, Phi, inv_var


def _nonlinear_derivatives(Z, centers, D2, Phi, inv_var, root_w):
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


def _unit_of_parameter(n_centers, n_features):
    """Index of the Gaussian unit each nonlinear parameter belongs to."""
    return np.concatenate([np.repeat(np.arange(n_centers), n_features), np.arange(n_centers)])


def _log_width_bounds(widths):
    """Starting log-widths (clipped into the absolute limits) and their bounds."""
    lo_abs, hi_abs = np.log(WIDTH_LIMITS)
    with np.errstate(divide="ignore"):
        log_w0 = np.clip(np.log(widths), lo_abs, hi_abs)
    lower = np.maximum(log_w0 - np.log(WIDTH_RANGE), lo_abs)
    upper = np.minimum(log_w0 + np.log(WIDTH_RANGE), hi_abs)
    return log_w0, lower, upper


def _center_bounds(Z, n_centers):
    """Per-feature box for the centres: the data's box widened by its span (at least 1)."""
    zmin, zmax = Z.min(axis=0), Z.max(axis=0)
    span = np.maximum(zmax - zmin, 1.0)
    lower = np.tile(zmin - span, n_centers)
    upper = np.tile(zmax + span, n_centers)
    return lower, upper


def _loss(Z, Y, sw, total, centers, widths, coef, tail_coef, intercept, alpha):
    """Weighted sum of squares plus ridge penalty, divided by the total weight; inf if bad."""
    with np.errstate(all="ignore"):
        pred = predict_network(Z, centers, widths, coef, tail_coef, intercept)
        value = (sw @ np.square(pred - Y).sum(axis=1) + alpha * np.sum(np.square(coef))) / total
    return float(value) if np.isfinite(value) else np.inf


def _weights(sample_weight, n, name):
    if sample_weight is None:
        return np.ones(n)
    sw = np.asarray(sample_weight, dtype=np.float64)
    if sw.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {sw.shape}.")
    if not np.all(np.isfinite(sw)) or np.any(sw < 0) or sw.sum() <= 0:
        raise ValueError(f"{name} must be finite, non-negative and have a positive sum.")
    return sw


def _as_2d_float(a, name, ndim=2):
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-D array, got shape {a.shape}.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinity.")
    return a


# --------------------------------------------------------------------------------------------
# Variable projection
# --------------------------------------------------------------------------------------------


class _Projection:
    """Linear output layer solved for given centres and log-widths, with its SVD.

    The weighted design is ``A = [√s Phi, √s T, √s]`` stacked over ``[√alpha I, 0, 0]``
    (ridge rows, when alpha > 0), the target ``[√s Y; 0]``; ``beta = A⁺ target`` and the
    residual ``A beta - target`` (one column per output). ``T`` is the tail regressors,
    ``tail_features(Z, degree)``, computed once by the caller.
    """

    def __init__(self, Z, Yw, root_w, T, alpha, centers, log_widths):
        n = Z.shape[0]
        K = centers.shape[0]
        self.D2, self.Phi, self.inv_var = _activations(Z, centers, log_widths)
        n_tail = T.shape[1]
        n_pen = K if alpha > 0 else 0
        A = np.zeros((n + n_pen, K + n_tail + 1))
        np.multiply(self.Phi, root_w[:, None], out=A[:n, :K])
        if n_tail:
            np.multiply(T, root_w[:, None], out=A[:n, K : K + n_tail])
        A[:n, -1] = root_w
        if n_pen:
            A[n:, :K] = np.sqrt(alpha) * np.eye(K)
        try:
            U, s, Vt = scipy.linalg.svd(
                A, full_matrices=False, lapack_driver="gesdd", check_finite=False
            )
        except (np.linalg.LinAlgError, ValueError):
            U, s, Vt = scipy.linalg.svd(
                A, full_matrices=False, lapack_driver="gesvd", check_finite=False
            )
        cutoff = s[0] * max(A.shape) * np.finfo(np.float64).eps if s.size else 0.0
        rank = int(np.count_nonzero(s > cutoff))
        self.U, self.s, self.Vt = U[:, :rank], s[:rank], Vt[:rank]
        target_proj = self.U[:n].T @ Yw  # the ridge rows of the target are zero
        self.beta = self.Vt.T @ (target_proj / self.s[:, None])  # (p, n_outputs)
        self.residual = self.U @ target_proj
        self.residual[:n] -= Yw
        self.n_rows, self.n_centers, self.n_tail = n, K, n_tail

    def split(self):
        """``coef`` (m, K), ``tail_coef`` (m, n_tail), ``intercept`` (m,)."""
        K, t = self.n_centers, self.n_tail
        return self.beta[:K].T.copy(), self.beta[K : K + t].T.copy(), self.beta[-1].copy()

    def jacobian(self, Z, centers, root_w, kaufman=False):
        n, K = self.n_rows, self.n_centers
        unit = _unit_of_parameter(K, Z.shape[1])
        deriv = _nonlinear_derivatives(Z, centers, self.D2, self.Phi, self.inv_var, root_w)
        n_params = deriv.shape[1]
        n_aug, rank = self.U.shape
        m = self.beta.shape[1]
        J = np.empty((m * n_aug, n_params))
        left = self.U
        if not kaufman:
            # A⁺ᵀ = U diag(1/s) Vt; only its columns for the Gaussian units are needed.
            left = np.hstack([self.U, (self.U / self.s) @ self.Vt[:, :K]])
        right = np.zeros((left.shape[1], n_params))
        G = np.empty_like(deriv)
        for out in range(m):
            block = J[out * n_aug : (out + 1) * n_aug]
            np.multiply(deriv, self.beta[:K, out][unit], out=G)
            # J = P⊥ (∂A/∂θ) beta  -  (A⁺)ᵀ (∂A/∂θ)ᵀ r  (Golub–Pereyra; Kaufman drops the
            # second term). ∂A/∂θ_k is zero on the ridge rows and has one non-zero column
            # (unit k's), so the second term is column unit(k) of A⁺ᵀ times a scalar; both
            # terms come out of one product [U, A⁺ᵀ_units] @ [UᵀG; S].
            right[:rank] = self.U[:n].T @ G
            if not kaufman:
                right[rank:] = 0.0
                right[rank + unit, np.arange(n_params)] = self.residual[:n, out] @ deriv
            np.matmul(left, right, out=block)
            np.subtract(G, block[:n], out=block[:n])
            np.negative(block[n:], out=block[n:])
        return J


def _varpro_setup(Z, Y, sample_weight):
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[:, None]
    root_w = np.sqrt(_weights(sample_weight, Z.shape[0], "sample_weight"))
    return Y * root_w[:, None], root_w


def varpro_residuals(Z, Y, centers, widths, *, tail=True, sample_weight=None, alpha=0.0):
    """Residuals of the variable-projection problem (weights solved for the given nonlinear part).

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    Y : ndarray of shape (n_samples, n_outputs) or (n_samples,)
        Targets.
    centers : ndarray of shape (n_centers, n_features)
        Centres.
    widths : ndarray of shape (n_centers,)
        Widths (positive).
    tail : {0, 1, 2} or bool, default=True
        Degree of the polynomial tail in the linear layer (:func:`~sklearn_ifog.rbf._basis.
        tail_features`): ``True``/1 the columns of ``Z``, 2 also their degree-2 monomials,
        ``False``/0 none.
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative sample weights.
    alpha : float, default=0.0
        Ridge penalty on the Gaussian weights.

    Returns
    -------
    residuals : ndarray of shape (n_outputs * (n_samples + n_pen),)
        For each output in turn, ``√s_i (f(z_i) - y_i)`` for every row then, when
        ``alpha > 0``, the ``n_pen = n_centers`` ridge rows ``√alpha coef_j``; the squared norm
        is the loss ``L`` at the optimal weights.

    Examples
    --------
    >>> import numpy as np
    >>> Z = np.linspace(-1, 1, 7)[:, None]
    >>> r = varpro_residuals(Z, 3 * Z[:, 0] + 1, Z[:2], np.ones(2))
    >>> float(np.abs(r).max()) < 1e-12
    True
    """
    Yw, root_w = _varpro_setup(Z, Y, sample_weight)
    T = tail_features(Z, int(tail))
    proj = _Projection(Z, Yw, root_w, T, alpha, centers, np.log(widths))
    return proj.residual.T.ravel()


def varpro_jacobian(
    Z, Y, centers, widths, *, tail=True, sample_weight=None, alpha=0.0, kaufman=False
):
    """Jacobian of :func:`varpro_residuals` w.r.t. the centres and log-widths.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    Y : ndarray of shape (n_samples, n_outputs) or (n_samples,)
        Targets.
    centers : ndarray of shape (n_centers, n_features)
        Centres.
    widths : ndarray of shape (n_centers,)
        Widths (positive).
    tail : {0, 1, 2} or bool, default=True
        Degree of the polynomial tail in the linear layer, as in :func:`varpro_residuals`.
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative sample weights.
    alpha : float, default=0.0
        Ridge penalty on the Gaussian weights.
    kaufman : bool, default=False
        False: the exact Jacobian of Golub & Pereyra (1973). True: Kaufman's (1975)
        approximation, which keeps only the projected term ``P⊥ (∂A/∂θ) beta``.

    Returns
    -------
    jacobian : ndarray of shape (n_outputs * (n_samples + n_pen), n_centers * (n_features + 1))
        Rows as in :func:`varpro_residuals`; columns: ``centers.ravel()`` (unit-major), then the
        log-widths.

    Examples
    --------
    >>> import numpy as np
    >>> Z = np.linspace(-1, 1, 9)[:, None]
    >>> varpro_jacobian(Z, np.sin(3 * Z[:, 0]), Z[[2, 6]], np.ones(2)).shape
    (9, 4)
    """
    Yw, root_w = _varpro_setup(Z, Y, sample_weight)
    T = tail_features(Z, int(tail))
    proj = _Projection(Z, Yw, root_w, T, alpha, centers, np.log(widths))
    return proj.jacobian(Z, centers, root_w, kaufman=kaufman)


# --------------------------------------------------------------------------------------------
# Joint (full) parametrisation
# --------------------------------------------------------------------------------------------


def full_residuals(
    Z, Y, centers, widths, coef, tail_coef, intercept, *, sample_weight=None, alpha=0.0
):
    """Residuals of the network with all parameters free.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    Y : ndarray of shape (n_samples, n_outputs)
        Targets.
    centers, widths, coef, tail_coef, intercept : ndarray
        The network (shapes as in :class:`RefineResult`); the tail's degree follows from
        ``tail_coef.shape[1]`` (0, ``d`` or ``d + d (d + 1) / 2``).
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative sample weights.
    alpha : float, default=0.0
        Ridge penalty on the Gaussian weights.

    Returns
    -------
    residuals : ndarray of shape (n_outputs * (n_samples + n_pen),)
        For each output, ``√s_i (f(z_i) - y_i)`` then (``alpha > 0``) ``√alpha coef``.

    Examples
    --------
    >>> import numpy as np
    >>> Z = np.zeros((2, 1))
    >>> full_residuals(
    ...     Z, np.ones((2, 1)), Z[:1], np.ones(1), np.ones((1, 1)), np.zeros((1, 0)), np.zeros(1)
    ... )
    array([0., 0.])
    """
    Y = np.asarray(Y, dtype=np.float64).reshape(Z.shape[0], -1)
    root_w = np.sqrt(_weights(sample_weight, Z.shape[0], "sample_weight"))
    pred = predict_network(Z, centers, widths, coef, tail_coef, intercept)
    data = (pred - Y) * root_w[:, None]
    if alpha > 0:
        data = np.vstack([data, np.sqrt(alpha) * coef.T])
    return data.T.ravel()


def _full_jacobian_rows(Z, root_w, centers, log_widths, coef, n_tail, alpha, activations=None):
    n, d = Z.shape
    m, K = coef.shape
    if activations is None:
        activations = _activations(Z, centers, log_widths)
    D2, Phi, inv_var = activations
    deriv = _nonlinear_derivatives(Z, centers, D2, Phi, inv_var, root_w)
    unit = _unit_of_parameter(K, d)
    n_nl = deriv.shape[1]
    n_pen = K if alpha > 0 else 0
    n_aug = n + n_pen
    J = np.zeros((m * n_aug, n_nl + m * (K + n_tail + 1)))
    weighted_phi = Phi * root_w[:, None]
    weighted_tail = (
        tail_features(Z, tail_degree_from_size(n_tail, d)) * root_w[:, None] if n_tail else None
    )
    for out in range(m):
        rows = slice(out * n_aug, out * n_aug + n)
        np.multiply(deriv, coef[out][unit], out=J[rows, :n_nl])
        col = n_nl + out * K
        J[rows, col : col + K] = weighted_phi
        if n_tail:
            col = n_nl + m * K + out * n_tail
            J[rows, col : col + n_tail] = weighted_tail
        J[rows, n_nl + m * (K + n_tail) + out] = root_w
        if n_pen:
            col = n_nl + out * K
            J[out * n_aug + n + np.arange(K), col + np.arange(K)] = np.sqrt(alpha)
    return J


def full_jacobian(
    Z, centers, widths, coef, tail_coef, intercept, *, sample_weight=None, alpha=0.0
):
    """Jacobian of :func:`full_residuals` w.r.t. all parameters.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    centers, widths, coef, tail_coef, intercept : ndarray
        The network (shapes as in :class:`RefineResult`).
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative sample weights.
    alpha : float, default=0.0
        Ridge penalty on the Gaussian weights.

    Returns
    -------
    jacobian : ndarray of shape (n_outputs * (n_samples + n_pen), n_params)
        Columns in this order: ``centers.ravel()``, log-widths, ``coef.ravel()``,
        ``tail_coef.ravel()``, ``intercept`` (``n_params = K (d + 1) + m (K + n_tail + 1)``).

    Examples
    --------
    >>> import numpy as np
    >>> Z = np.linspace(-1, 1, 5)[:, None]
    >>> full_jacobian(Z, Z[:2], np.ones(2), np.ones((1, 2)), np.zeros((1, 1)), np.zeros(1)).shape
    (5, 8)
    """
    del intercept  # the Jacobian does not depend on it; kept for a uniform signature
    root_w = np.sqrt(_weights(sample_weight, Z.shape[0], "sample_weight"))
    return _full_jacobian_rows(Z, root_w, centers, np.log(widths), coef, tail_coef.shape[1], alpha)


# --------------------------------------------------------------------------------------------
# Early stopping / best-iterate bookkeeping
# --------------------------------------------------------------------------------------------


class _Tracker:
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
        centers, widths, coef, tail_coef, intercept = (np.array(a, copy=True) for a in network)
        return RefineResult(
            centers, widths, coef, tail_coef, intercept, n_iter, converged, improved, self.history
        )


# --------------------------------------------------------------------------------------------
# The three methods
# --------------------------------------------------------------------------------------------


class _Data(NamedTuple):
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
        return _loss(self.Z_val, self.Y_val, self.sw_val, self.total_val, *network, 0.0)

    def train_loss(self, network):
        return _loss(self.Z, self.Y, self.sw, self.total, *network, self.alpha)


def _refine_varpro(data, start, tracker, max_iter, tol):
    Z, total, alpha, T = data.Z, data.total, data.alpha, data.T
    K, d = start[0].shape
    root_w = np.sqrt(data.sw)
    Yw = data.Y * root_w[:, None]
    log_w0, lw_lo, lw_hi = _log_width_bounds(start[1])
    c_lo, c_hi = _center_bounds(Z, K)
    lower = np.concatenate([c_lo, lw_lo])
    upper = np.concatenate([c_hi, lw_hi])
    x0 = np.clip(np.concatenate([start[0].ravel(), log_w0]), lower, upper)
    cache = {}

    def state(x):
        # Two entries: the accepted point and the latest trial, which is all trf revisits.
        key = x.tobytes()
        if key not in cache:
            if len(cache) >= 2:
                del cache[next(iter(cache))]
            centers = x[: K * d].reshape(K, d)
            cache[key] = (centers, _Projection(Z, Yw, root_w, T, alpha, centers, x[K * d :]))
        return cache[key]

    def network(x):
        centers, proj = state(x)
        coef, tail_coef, intercept = proj.split()
        return centers.copy(), np.exp(x[K * d :]), coef, tail_coef, intercept

    def losses(x):
        _, proj = state(x)
        train = float(np.sum(np.square(proj.residual))) / total
        net = network(x)
        return net, train, data.val_loss(net)

    def fun(x):
        return state(x)[1].residual.T.ravel()

    def jac(x):
        centers, proj = state(x)
        return proj.jacobian(Z, centers, root_w)

    # The weights re-solved at the starting centres and widths are the first candidate.
    net0, train0, val0 = losses(x0)
    if tracker.has_val:
        if val0 < tracker.best_key:
            tracker.best, tracker.best_key = net0, val0
    elif train0 < tracker.best_key:
        tracker.best, tracker.best_key = net0, train0

    stop = {"n_iter": 0, "max_iter": False}

    def callback(x):
        stop["n_iter"] += 1
        net, train, val = losses(np.asarray(x, dtype=np.float64))
        patience_out = tracker.update(net, train, val) and tracker.has_val
        if stop["n_iter"] >= max_iter:
            stop["max_iter"] = not patience_out
            raise StopIteration
        if patience_out:
            raise StopIteration

    if max_iter > 0 and K > 0:
        ls_tol = max(tol, 1e-15)  # least_squares refuses tolerances below machine epsilon
        jacobian_entries = Yw.shape[1] * (Z.shape[0] + (K if alpha > 0 else 0)) * x0.size
        tr_solver = "exact" if jacobian_entries <= EXACT_TRUST_REGION_MAX_ENTRIES else "lsmr"
        result = least_squares(
            fun,
            x0,
            jac=jac,
            bounds=(lower, upper),
            method="trf",
            x_scale="jac",
            tr_solver=tr_solver,
            tr_options={"maxiter": LSMR_MAX_ITER} if tr_solver == "lsmr" else None,
            ftol=ls_tol,
            xtol=ls_tol,
            gtol=ls_tol,
            max_nfev=10 * max_iter + 10,
            callback=callback,
        )
        converged = result.status > 0 or (result.status == -2 and not stop["max_iter"])
    else:
        converged = K == 0
    return tracker.result(stop["n_iter"], converged)


def _pack(network):
    centers, widths, coef, tail_coef, intercept = network
    return np.concatenate(
        [centers.ravel(), np.log(widths), coef.ravel(), tail_coef.ravel(), intercept]
    )


def _unpack(theta, K, d, m, n_tail):
    i = 0
    centers = theta[i : i + K * d].reshape(K, d)
    i += K * d
    widths = np.exp(theta[i : i + K])
    i += K
    coef = theta[i : i + m * K].reshape(m, K)
    i += m * K
    tail_coef = theta[i : i + m * n_tail].reshape(m, n_tail)
    i += m * n_tail
    return centers, widths, coef, tail_coef, theta[i : i + m].copy()


def _normal_equations(Z, Y, root_w, theta, shape, alpha):
    """``JᵀJ`` and ``Jᵀr`` of the full problem, accumulated over row blocks."""
    K, d, m, n_tail = shape
    centers, _, coef, tail_coef, intercept = _unpack(theta, K, d, m, n_tail)
    log_widths = theta[K * d : K * d + K]
    n_params = theta.size
    JtJ = np.zeros((n_params, n_params))
    Jtr = np.zeros(n_params)
    block_rows = max(1, _BLOCK_ENTRIES // max(1, m * n_params))
    for start in range(0, Z.shape[0], block_rows):
        rows = slice(start, start + block_rows)
        activations = _activations(Z[rows], centers, log_widths)
        J = _full_jacobian_rows(
            Z[rows], root_w[rows], centers, log_widths, coef, n_tail, 0.0, activations
        )
        pred = activations[1] @ coef.T + intercept
        if n_tail:
            pred += tail_features(Z[rows], tail_degree_from_size(n_tail, d)) @ tail_coef.T
        r = ((pred - Y[rows]) * root_w[rows, None]).T.ravel()
        JtJ += J.T @ J
        Jtr += J.T @ r
    if alpha > 0:
        coef_cols = slice(K * (d + 1), K * (d + 1) + m * K)
        JtJ[coef_cols, coef_cols] += alpha * np.eye(m * K)
        Jtr[coef_cols] += alpha * coef.ravel()
    return JtJ, Jtr


def _damped_step(JtJ, Jtr, damping):
    """Solve ``(JᵀJ + λ D) δ = -Jᵀr`` (Marquardt scaling ``D``), raising λ until Cholesky works."""
    diag = np.diag(JtJ).copy()
    floor = max(float(diag.max(initial=0.0)), 1.0) * 1e-12
    scale = np.maximum(diag, floor)
    for _ in range(30):
        system = JtJ + np.diag(damping * scale)
        try:
            factor = scipy.linalg.cho_factor(system, check_finite=False)
            step = -scipy.linalg.cho_solve(factor, Jtr, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            damping *= 10.0
            continue
        if np.all(np.isfinite(step)):
            return step, damping
        damping *= 10.0
    return np.zeros_like(Jtr), damping


def _refine_lm(data, start, tracker, max_iter, tol):
    Z, Y, total, alpha = data.Z, data.Y, data.total, data.alpha
    K, d = start[0].shape
    m = start[2].shape[0]
    n_tail = start[3].shape[1]
    shape = (K, d, m, n_tail)
    root_w = np.sqrt(data.sw)
    log_w0, lw_lo, lw_hi = _log_width_bounds(start[1])
    c_lo, c_hi = _center_bounds(Z, K)
    theta = _pack(start)
    theta[: K * d] = np.clip(theta[: K * d], c_lo, c_hi)
    theta[K * d : K * d + K] = log_w0

    def project(t):
        t[: K * d] = np.clip(t[: K * d], c_lo, c_hi)
        t[K * d : K * d + K] = np.clip(t[K * d : K * d + K], lw_lo, lw_hi)
        return t

    def train_loss(t):
        return data.train_loss(_unpack(t, *shape))

    loss = train_loss(theta)
    damping = 1e-3
    n_iter, converged = 0, K == 0
    while n_iter < max_iter and not converged and K > 0:
        JtJ, Jtr = _normal_equations(Z, Y, root_w, theta, shape, alpha)
        if np.max(np.abs(Jtr)) <= tol * max(loss * total, np.finfo(float).tiny):
            converged = True
            break
        nu = 2.0
        accepted = False
        for _ in range(30):
            step, damping = _damped_step(JtJ, Jtr, damping)
            candidate = project(theta + step)
            step = candidate - theta
            new_loss = train_loss(candidate)
            # Predicted decrease of ||r||² for the (projected) step under the linear model.
            predicted = -(2.0 * step @ Jtr + step @ JtJ @ step) / total
            actual = loss - new_loss
            if np.isfinite(new_loss) and actual > 0 and predicted > 0:
                rho = actual / predicted
                damping *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                accepted = True
                break
            damping *= nu
            nu *= 2.0
        n_iter += 1
        if not accepted:
            converged = True  # no descent step even at large damping: a stationary point
            break
        small_step = np.linalg.norm(step) <= tol * (np.linalg.norm(theta) + tol)
        small_gain = actual <= tol * loss
        theta, loss = candidate, new_loss
        net = _unpack(theta, *shape)
        if tracker.update(net, loss, data.val_loss(net)) and tracker.has_val:
            converged = True
            break
        if small_step or small_gain:
            converged = True
    return tracker.result(n_iter, converged)


def _refine_gd(data, start, tracker, max_iter, tol, learning_rate, rng):
    Z, Y, sw, total, T = data.Z, data.Y, data.sw, data.total, data.T
    n, d = Z.shape
    K = start[0].shape[0]
    mean_y = sw @ Y / total
    y_scale = np.sqrt(sw @ np.square(Y - mean_y) / total)
    y_scale[~(y_scale > 1e-12 * np.maximum(np.abs(mean_y), 1.0))] = 1.0
    Ys = Y / y_scale
    log_w0, lw_lo, lw_hi = _log_width_bounds(start[1])
    c_lo, c_hi = _center_bounds(Z, K)
    c_lo, c_hi = c_lo.reshape(K, d), c_hi.reshape(K, d)
    params = [
        np.clip(start[0], c_lo, c_hi),
        log_w0,
        start[2] / y_scale[:, None],
        start[3] / y_scale[:, None],
        start[4] / y_scale,
    ]

    def network(p):
        C, lw, W, A, b = p
        return (
            C.copy(),
            np.exp(lw),
            W * y_scale[:, None],
            A * y_scale[:, None],
            b * y_scale,
        )

    penalty = data.alpha / total
    eta = float(learning_rate)
    previous = tracker.history["train_loss"][0]
    n_iter, converged = 0, False
    batch = min(GD_BATCH_SIZE, n)
    while n_iter < max_iter:
        saved = [a.copy() for a in params]
        C, lw, W, A, b = params
        order = rng.permutation(n)
        for begin in range(0, n, batch):
            idx = order[begin : begin + batch]
            Zb, Tb, sb = Z[idx], T[idx], sw[idx]
            weight_sum = sb.sum()
            if weight_sum <= 0:
                continue
            D2, Phi, inv_var = _activations(Zb, C, lw)
            pred = Phi @ W.T + b
            if A.shape[1]:
                pred += Tb @ A.T
            E = (Ys[idx] - pred) * (sb / weight_sum)[:, None]  # (d - y), weighted mean
            Q = (E @ W) * Phi
            grad_W = E.T @ Phi - penalty * W  # Eq. 17
            grad_C = (Q.T @ Zb - Q.sum(axis=0)[:, None] * C) * inv_var[:, None]  # Eq. 18
            grad_lw = np.einsum("ij,ij->j", Q, D2) * inv_var  # Eq. 19 in log space
            W += eta * grad_W
            b += eta * E.sum(axis=0)
            if A.shape[1]:
                A += eta * (E.T @ Tb)
            C += eta * grad_C
            np.clip(C, c_lo, c_hi, out=C)
            lw += eta * grad_lw
            np.clip(lw, lw_lo, lw_hi, out=lw)
        n_iter += 1
        net = network(params)
        train = data.train_loss(net)
        if not np.isfinite(train) or train > 2.0 * previous:
            # Diverging: undo the epoch and halve the learning rate. (Undoing every epoch that
            # raises the loss, the "bold driver", stalls on mini-batch noise: measured.)
            params[:] = saved
            eta *= 0.5
            net = network(params)
            train = previous
        previous = train
        if tracker.update(net, train, data.val_loss(net)):
            converged = True
            break
    return tracker.result(n_iter, converged)


# --------------------------------------------------------------------------------------------
# Public entry point
# --------------------------------------------------------------------------------------------


def refine_network(
    Z,
    Y,
    centers,
    widths,
    coef,
    tail_coef,
    intercept,
    *,
    method,
    sample_weight=None,
    alpha=0.0,
    Z_val=None,
    Y_val=None,
    sample_weight_val=None,
    max_iter=100,
    tol=1e-6,
    learning_rate=0.01,
    max_samples=None,
    random_state=None,
):
    """Refine centres, widths and output weights of a Gaussian RBF network.

    See the module docstring for the three methods, the bounds and the early-stopping rule.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised training inputs.
    Y : ndarray of shape (n_samples, n_outputs) or (n_samples,)
        Training targets.
    centers : ndarray of shape (n_centers, n_features)
        Starting centres (standardised units).
    widths : ndarray of shape (n_centers,)
        Starting widths (positive).
    coef : ndarray of shape (n_outputs, n_centers)
        Starting Gaussian weights.
    tail_coef : ndarray of shape (n_outputs, n_tail)
        Starting tail weights; ``n_tail`` is 0 (no tail), ``n_features`` (linear tail) or
        ``d + d (d + 1) / 2`` (quadratic tail, see ``_basis.tail_features``).
    intercept : ndarray of shape (n_outputs,)
        Starting intercepts.
    method : {"varpro", "lm", "gd"}
        Variable projection, Levenberg–Marquardt on all parameters, or the reference paper's
        gradient rules.
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative training weights.
    alpha : float, default=0.0
        Ridge penalty on the Gaussian weights.
    Z_val, Y_val : ndarray, default=None
        Validation data for early stopping (both or neither).
    sample_weight_val : ndarray of shape (n_val,), default=None
        Validation weights.
    max_iter : int, default=100
        Maximum iterations (epochs for ``"gd"``).
    tol : float, default=1e-6
        Relative tolerance on the loss (and, for "varpro"/"lm", on the step and gradient).
    learning_rate : float, default=0.01
        Step size of the gradient rules (``"gd"`` only); unit-free (targets are scaled).
    max_samples : int, default=None
        Refine on a random subsample of at most this many training rows, and evaluate the
        validation loss on at most this many validation rows (drawn without replacement by
        ``random_state``, kept in their original order), so the cost is bounded whatever the
        number of rows. ``None`` uses all rows.
    random_state : int, RandomState instance or None, default=None
        Seeds the subsampling and the mini-batch order of ``"gd"``.

    Returns
    -------
    result : RefineResult
        The best network found (or the starting one, with ``improved=False``).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.rbf._basis import gaussian_design, solve_output_weights
    >>> rng = np.random.default_rng(0)
    >>> Z = rng.uniform(-1, 1, size=(200, 1))
    >>> Y = np.sin(3 * Z)
    >>> centers, widths = Z[:4], np.full(4, 2.0)
    >>> coef, tail, b = solve_output_weights(gaussian_design(Z, centers, widths), Z[:, :0], Y)
    >>> res = refine_network(Z, Y, centers, widths, coef, tail, b, method="varpro")
    >>> res.improved, res.history["train_loss"][-1] < 0.1 * res.history["train_loss"][0]
    (True, True)
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}.")
    Z = _as_2d_float(Z, "Z")
    n, d = Z.shape
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[:, None]
    Y = _as_2d_float(Y, "Y")
    if Y.shape[0] != n:
        raise ValueError(f"Y has {Y.shape[0]} rows but Z has {n}.")
    centers = _as_2d_float(centers, "centers")
    K = centers.shape[0]
    if centers.shape[1] != d:
        raise ValueError(f"centers must have {d} columns (as Z), got {centers.shape[1]}.")
    widths = _as_2d_float(widths, "widths", ndim=1)
    if widths.shape != (K,) or np.any(widths <= 0):
        raise ValueError(f"widths must be {K} positive values, got shape {widths.shape}.")
    m = Y.shape[1]
    coef = _as_2d_float(coef, "coef")
    if coef.shape != (m, K):
        raise ValueError(f"coef must have shape ({m}, {K}), got {coef.shape}.")
    tail_coef = _as_2d_float(tail_coef, "tail_coef")
    n_quadratic = d + d * (d + 1) // 2
    if tail_coef.shape not in ((m, 0), (m, d), (m, n_quadratic)):
        raise ValueError(
            f"tail_coef must have shape ({m}, 0), ({m}, {d}) or ({m}, {n_quadratic}) (no, "
            f"linear or quadratic tail), got {tail_coef.shape}."
        )
    tail_degree = tail_degree_from_size(tail_coef.shape[1], d)
    intercept = _as_2d_float(np.reshape(intercept, -1), "intercept", ndim=1)
    if intercept.shape != (m,):
        raise ValueError(f"intercept must have shape ({m},), got {intercept.shape}.")
    if not (alpha >= 0 and np.isfinite(alpha)):
        raise ValueError(f"alpha must be a finite non-negative number, got {alpha!r}.")
    if int(max_iter) != max_iter or max_iter < 0:
        raise ValueError(f"max_iter must be a non-negative integer, got {max_iter!r}.")
    if not (tol >= 0):
        raise ValueError(f"tol must be non-negative, got {tol!r}.")
    if method == "gd" and not (learning_rate > 0 and np.isfinite(learning_rate)):
        raise ValueError(f"learning_rate must be positive, got {learning_rate!r}.")
    if max_samples is not None and (int(max_samples) != max_samples or max_samples < 1):
        raise ValueError(f"max_samples must be a positive integer or None, got {max_samples!r}.")
    sw = _weights(sample_weight, n, "sample_weight")
    if (Z_val is None) != (Y_val is None):
        raise ValueError("Z_val and Y_val must be given together.")

    rng = check_random_state(random_state)
    if max_samples is not None and n > max_samples:
        rows = np.sort(rng.choice(n, size=int(max_samples), replace=False))
        Z, Y, sw = Z[rows], Y[rows], sw[rows]
    total = float(sw.sum())
    if total <= 0:
        raise ValueError("sample_weight of the refinement rows must have a positive sum.")

    has_val = Z_val is not None
    Zv = Yv = swv = None
    totalv = 1.0
    if has_val:
        Zv = _as_2d_float(Z_val, "Z_val")
        Yv = np.asarray(Y_val, dtype=np.float64)
        Yv = _as_2d_float(Yv[:, None] if Yv.ndim == 1 else Yv, "Y_val")
        if Zv.shape[1] != d or Yv.shape != (Zv.shape[0], m):
            raise ValueError(
                f"Z_val/Y_val must have shapes (n_val, {d}) and (n_val, {m}), "
                f"got {Zv.shape} and {Yv.shape}."
            )
        swv = _weights(sample_weight_val, Zv.shape[0], "sample_weight_val")
        if max_samples is not None and Zv.shape[0] > max_samples:
            rows = np.sort(rng.choice(Zv.shape[0], size=int(max_samples), replace=False))
            Zv, Yv, swv = Zv[rows], Yv[rows], swv[rows]
        totalv = float(swv.sum())
        if totalv <= 0:
            raise ValueError("sample_weight_val must have a positive sum.")

    # Work on targets divided by one scale, so that the tolerances (absolute ones inside
    # least_squares, step norms mixing centres and weights in "lm") mean the same whatever the
    # units of y. The loss is homogeneous of degree 2 in (y, coef, tail, intercept), so the
    # nonlinear optimum does not move; outputs keep their relative weight.
    mean_y = sw @ Y / total
    y_scale = float(np.sqrt(np.sum(sw @ np.square(Y - mean_y)) / (total * m)))
    if not (np.isfinite(y_scale) and y_scale > 0):
        y_scale = 1.0
    start = (centers, widths, coef / y_scale, tail_coef / y_scale, intercept / y_scale)
    Y = Y / y_scale
    Yv = Yv / y_scale if has_val else None
    train0 = _loss(Z, Y, sw, total, *start, alpha)
    val0 = _loss(Zv, Yv, swv, totalv, *start, 0.0) if has_val else None
    patience = PATIENCE_GD if method == "gd" else PATIENCE
    tracker = _Tracker(start, train0, val0, has_val, tol, patience)
    T = tail_features(Z, tail_degree)
    data = _Data(Z, Y, sw, total, Zv, Yv, swv, totalv, float(alpha), T)
    max_iter = int(max_iter)
    # Single-threaded BLAS: the tall, skinny SVD/QR/Cholesky calls here gain nothing from
    # threads, and OpenBLAS threads on shared cores made them 50x slower (measured).
    with threadpool_limits(limits=1, user_api="blas"):
        if method == "varpro":
            result = _refine_varpro(data, start, tracker, max_iter, tol)
        elif method == "lm":
            result = _refine_lm(data, start, tracker, max_iter, tol)
        else:
            result = _refine_gd(data, start, tracker, max_iter, tol, learning_rate, rng)
    return _in_target_units(result, y_scale, (centers, widths, coef, tail_coef, intercept))


def _in_target_units(result, y_scale, original):
    """Undo the target scaling; without improvement, return copies of the original start."""
    if result.improved:
        result.coef *= y_scale
        result.tail_coef *= y_scale
        result.intercept *= y_scale
    else:
        (
            result.centers,
            result.widths,
            result.coef,
            result.tail_coef,
            result.intercept,
        ) = (np.array(a, copy=True) for a in original)
    for key in ("train_loss", "val_loss"):
        result.history[key] = [value * y_scale**2 for value in result.history[key]]
    return result
