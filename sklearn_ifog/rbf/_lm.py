"""Levenberg–Marquardt on all parameters of the network jointly.

Centres, log-widths, Gaussian weights, tail and intercept move together, with the analytic
Jacobian :func:`full_jacobian`. The normal equations ``JᵀJ`` and ``Jᵀr`` are accumulated in
row blocks, so memory does not grow with the rows beyond the data itself; each damped system
is solved by Cholesky, the damping raised until it succeeds (Marquardt's diagonal scaling,
Nielsen's damping update).
"""

import numpy as np
import scipy.linalg

from sklearn_ifog.rbf._basis import Network, tail_degree_from_size, tail_features
from sklearn_ifog.rbf._refine_core import (
    center_bounds,
    check_weights,
    log_activations,
    log_width_bounds,
    nonlinear_derivatives,
    unit_of_parameter,
)

#: Target size, in float64 entries, of one row block of the Jacobian.
_BLOCK_ENTRIES = 2**21
#: Largest damping (relative to JᵀJ's diagonal) at which a small gain counts as convergence.
_CONVERGED_DAMPING = 1.0


def full_residuals(Z, Y, network, *, sample_weight=None, alpha=0.0):
    """Residuals of the network with all parameters free.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    Y : ndarray of shape (n_samples, n_outputs)
        Targets.
    network : ~sklearn_ifog.rbf._basis.Network
        The network; the tail's degree follows from ``tail_coef.shape[1]`` (0, ``d`` or
        ``d + d (d + 1) / 2``).
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
    >>> network = Network(
    ...     centers=Z[:1],
    ...     widths=np.ones(1),
    ...     coef=np.ones((1, 1)),
    ...     tail_coef=np.zeros((1, 0)),
    ...     intercept=np.zeros(1),
    ... )
    >>> full_residuals(Z, np.ones((2, 1)), network)
    array([0., 0.])
    """
    Y = np.asarray(Y, dtype=np.float64).reshape(Z.shape[0], -1)
    root_w = np.sqrt(check_weights(sample_weight, Z.shape[0], "sample_weight"))
    pred = network.predict(Z)
    data = (pred - Y) * root_w[:, None]
    if alpha > 0:
        data = np.vstack([data, np.sqrt(alpha) * network.coef.T])
    return data.T.ravel()


def _full_jacobian_rows(Z, root_w, centers, log_widths, coef, n_tail, alpha, activations=None):
    n, d = Z.shape
    m, K = coef.shape
    if activations is None:
        activations = log_activations(Z, centers, log_widths)
    D2, Phi, inv_var = activations
    deriv = nonlinear_derivatives(Z, centers, D2, Phi, inv_var, root_w)
    unit = unit_of_parameter(K, d)
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


def full_jacobian(Z, network, *, sample_weight=None, alpha=0.0):
    """Jacobian of :func:`full_residuals` w.r.t. all parameters.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    network : ~sklearn_ifog.rbf._basis.Network
        The network (the Jacobian does not depend on its intercept).
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
    >>> network = Network(
    ...     centers=Z[:2],
    ...     widths=np.ones(2),
    ...     coef=np.ones((1, 2)),
    ...     tail_coef=np.zeros((1, 1)),
    ...     intercept=np.zeros(1),
    ... )
    >>> full_jacobian(Z, network).shape
    (5, 8)
    """
    root_w = np.sqrt(check_weights(sample_weight, Z.shape[0], "sample_weight"))
    return _full_jacobian_rows(
        Z,
        root_w,
        network.centers,
        np.log(network.widths),
        network.coef,
        network.tail_coef.shape[1],
        alpha,
    )


def _pack(network):
    """The network's parameters as one vector (widths as their logarithms)."""
    return np.concatenate(
        [
            network.centers.ravel(),
            np.log(network.widths),
            network.coef.ravel(),
            network.tail_coef.ravel(),
            network.intercept,
        ]
    )


def _unpack(theta, K, d, m, n_tail):
    """The network of a parameter vector of :func:`_pack`."""
    i = 0
    centers = theta[i : i + K * d].reshape(K, d)
    i += K * d
    widths = np.exp(theta[i : i + K])
    i += K
    coef = theta[i : i + m * K].reshape(m, K)
    i += m * K
    tail_coef = theta[i : i + m * n_tail].reshape(m, n_tail)
    i += m * n_tail
    return Network(
        centers=centers,
        widths=widths,
        coef=coef,
        tail_coef=tail_coef,
        intercept=theta[i : i + m].copy(),
    )


def _normal_equations(Z, Y, root_w, theta, shape, alpha):
    """``JᵀJ`` and ``Jᵀr`` of the full problem, accumulated over row blocks."""
    K, d, m, n_tail = shape
    network = _unpack(theta, K, d, m, n_tail)
    centers, coef = network.centers, network.coef
    log_widths = theta[K * d : K * d + K]
    n_params = theta.size
    JtJ = np.zeros((n_params, n_params))
    Jtr = np.zeros(n_params)
    block_rows = max(1, _BLOCK_ENTRIES // max(1, m * n_params))
    for start in range(0, Z.shape[0], block_rows):
        rows = slice(start, start + block_rows)
        activations = log_activations(Z[rows], centers, log_widths)
        J = _full_jacobian_rows(
            Z[rows], root_w[rows], centers, log_widths, coef, n_tail, 0.0, activations
        )
        pred = activations[1] @ coef.T + network.intercept
        if n_tail:
            pred += tail_features(Z[rows], tail_degree_from_size(n_tail, d)) @ network.tail_coef.T
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


def refine_lm(data, start, tracker, max_iter, tol):
    """Levenberg–Marquardt from the network ``start``; the best iterate goes to ``tracker``."""
    Z, Y, total, alpha = data.Z, data.Y, data.total, data.alpha
    K, d = start.centers.shape
    m = start.coef.shape[0]
    n_tail = start.tail_coef.shape[1]
    shape = (K, d, m, n_tail)
    root_w = np.sqrt(data.sw)
    log_w0, lw_lo, lw_hi = log_width_bounds(start.widths)
    c_lo, c_hi = center_bounds(Z, K)
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
                step_damping = damping
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
        # A small gain is convergence only near a Gauss-Newton step: a step accepted after
        # the damping was raised far (a poorly conditioned JᵀJ) gains little because it is
        # short, and the damping falls again after it.
        small_gain = actual <= tol * loss and step_damping <= _CONVERGED_DAMPING
        theta, loss = candidate, new_loss
        net = _unpack(theta, *shape)
        if tracker.update(net, loss, data.val_loss(net)) and tracker.has_val:
            converged = True
            break
        if small_step or small_gain:
            converged = True
    return tracker.result(n_iter, converged)
