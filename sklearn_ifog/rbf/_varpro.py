"""Variable projection: refine centres and widths with the output layer solved inside.

Golub & Pereyra (1973): the output weights (Gaussian weights, polynomial tail, intercept) are
the ridge solution for the current centres and widths, so the optimiser only sees the
nonlinear parameters. ``scipy.optimize.least_squares`` (trust-region reflective, bounded;
exact trust-region steps up to ``EXACT_TRUST_REGION_MAX_ENTRIES`` Jacobian entries, truncated
LSMR steps of at most ``LSMR_MAX_ITER`` inner iterations beyond) with the *exact*
Golub–Pereyra Jacobian of the projected residual (:func:`varpro_jacobian`; Kaufman's 1975
approximation, which drops the second term, is available with ``kaufman=True``). The inner
linear solve is an SVD of the weighted design with a relative rank cut-off, so a collinear or
empty design costs accuracy in the weights, never a ``LinAlgError`` or a NaN.
"""

import numpy as np
import scipy.linalg
from scipy.optimize import least_squares

from sklearn_ifog.rbf._basis import Network, tail_features
from sklearn_ifog.rbf._refine_core import (
    center_bounds,
    check_weights,
    log_activations,
    log_width_bounds,
    nonlinear_derivatives,
    unit_of_parameter,
)

#: Largest VarPro Jacobian (entries) for which least_squares solves each trust-region step
#: exactly (an SVD of the Jacobian per iteration); larger ones use its LSMR subspace steps,
#: about twice as fast per iteration at the estimator's 4000 rows and 40 centres.
EXACT_TRUST_REGION_MAX_ENTRIES = 250_000
#: Inner LSMR iterations per trust-region step when the steps are not exact (truncated,
#: inexact steps: measured faster to the same validation loss than LSMR run to its tolerance).
LSMR_MAX_ITER = 30


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
        self.D2, self.Phi, self.inv_var = log_activations(Z, centers, log_widths)
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
        unit = unit_of_parameter(K, Z.shape[1])
        deriv = nonlinear_derivatives(Z, centers, self.D2, self.Phi, self.inv_var, root_w)
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
    root_w = np.sqrt(check_weights(sample_weight, Z.shape[0], "sample_weight"))
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


def refine_varpro(data, start, tracker, max_iter, tol):
    """Variable projection from the network ``start``; the best iterate goes to ``tracker``."""
    Z, total, alpha, T = data.Z, data.total, data.alpha, data.T
    K, d = start.centers.shape
    root_w = np.sqrt(data.sw)
    Yw = data.Y * root_w[:, None]
    log_w0, lw_lo, lw_hi = log_width_bounds(start.widths)
    c_lo, c_hi = center_bounds(Z, K)
    lower = np.concatenate([c_lo, lw_lo])
    upper = np.concatenate([c_hi, lw_hi])
    x0 = np.clip(np.concatenate([start.centers.ravel(), log_w0]), lower, upper)
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
        return Network(
            centers=centers.copy(),
            widths=np.exp(x[K * d :]),
            coef=coef,
            tail_coef=tail_coef,
            intercept=intercept,
        )

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
