"""Refinement of a Gaussian RBF network's centres, widths and output weights.

:func:`refine_network` checks its input, subsamples, scales the targets once and hands the
network (a :class:`~sklearn_ifog.rbf._basis.Network`) to one of three methods, each in its own
module over the shared pieces of ``_refine_core`` (data, loss, bounds, derivatives, the
best-iterate tracker):

``"varpro"`` (``_varpro``)
    Variable projection (Golub & Pereyra 1973): the output weights are the ridge solution for
    the current centres and widths, so the optimiser only sees the nonlinear parameters.
``"lm"`` (``_lm``)
    Levenberg–Marquardt on all parameters jointly, with the analytic Jacobian.
``"gd"`` (``_gd``)
    The reference paper's gradient rules (its Eqs. 17–19), as mini-batch steps.

The loss every method decreases (``s`` the sample weights, summed over the outputs) is
``L = Σ_i s_i ||y_i - f(z_i)||² + alpha ||coef||²``, on log-parametrised widths; the bounds
are the same for all methods (see ``_refine_core``).

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

import numpy as np
from sklearn.utils import check_random_state

from sklearn_ifog.rbf._basis import Network, n_tail_features, tail_features, weighted_mean_std
from sklearn_ifog.rbf._gd import refine_gd
from sklearn_ifog.rbf._lm import refine_lm
from sklearn_ifog.rbf._refine_core import (
    PATIENCE,
    PATIENCE_GD,
    RefineData,
    Tracker,
    as_float_array,
    check_weights,
    network_loss,
)
from sklearn_ifog.rbf._threads import single_blas_thread
from sklearn_ifog.rbf._varpro import refine_varpro

#: The refinement methods, by name.
REFINE_METHODS = ("varpro", "lm", "gd")


def _checked_network(network, d, m):
    """The starting network with float64 arrays, checked against ``d`` features and ``m``
    outputs."""
    centers = as_float_array(network.centers, "centers")
    K = centers.shape[0]
    if centers.shape[1] != d:
        raise ValueError(f"centers must have {d} columns (as Z), got {centers.shape[1]}.")
    widths = as_float_array(network.widths, "widths", ndim=1)
    if widths.shape != (K,) or np.any(widths <= 0):
        raise ValueError(f"widths must be {K} positive values, got shape {widths.shape}.")
    coef = as_float_array(network.coef, "coef")
    if coef.shape != (m, K):
        raise ValueError(f"coef must have shape ({m}, {K}), got {coef.shape}.")
    tail_coef = as_float_array(network.tail_coef, "tail_coef")
    n_quadratic = n_tail_features(d, 2)
    if tail_coef.shape not in ((m, 0), (m, d), (m, n_quadratic)):
        raise ValueError(
            f"tail_coef must have shape ({m}, 0), ({m}, {d}) or ({m}, {n_quadratic}) (no, "
            f"linear or quadratic tail), got {tail_coef.shape}."
        )
    intercept = as_float_array(np.reshape(network.intercept, -1), "intercept", ndim=1)
    if intercept.shape != (m,):
        raise ValueError(f"intercept must have shape ({m},), got {intercept.shape}.")
    return Network(
        centers=centers, widths=widths, coef=coef, tail_coef=tail_coef, intercept=intercept
    )


def _validation_rows(Z_val, Y_val, sample_weight_val, d, m, max_samples, rng):
    """The early-stopping rows, checked and subsampled as the training rows are:
    ``(Zv, Yv, swv, totalv)``."""
    Zv = as_float_array(Z_val, "Z_val")
    Yv = np.asarray(Y_val, dtype=np.float64)
    Yv = as_float_array(Yv[:, None] if Yv.ndim == 1 else Yv, "Y_val")
    if Zv.shape[1] != d or Yv.shape != (Zv.shape[0], m):
        raise ValueError(
            f"Z_val/Y_val must have shapes (n_val, {d}) and (n_val, {m}), "
            f"got {Zv.shape} and {Yv.shape}."
        )
    swv = check_weights(sample_weight_val, Zv.shape[0], "sample_weight_val")
    if max_samples is not None and Zv.shape[0] > max_samples:
        rows = np.sort(rng.choice(Zv.shape[0], size=int(max_samples), replace=False))
        Zv, Yv, swv = Zv[rows], Yv[rows], swv[rows]
    totalv = float(swv.sum())
    if totalv <= 0:
        raise ValueError("sample_weight_val must have a positive sum.")
    return Zv, Yv, swv, totalv


def refine_network(
    Z,
    Y,
    network,
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
    network : ~sklearn_ifog.rbf._basis.Network
        The starting network: ``centers`` (n_centers, n_features) and positive ``widths``
        (n_centers,), in standardised units; ``coef`` (n_outputs, n_centers); ``tail_coef``
        (n_outputs, n_tail), where ``n_tail`` is 0 (no tail), ``n_features`` (linear tail)
        or ``d + d (d + 1) / 2`` (quadratic tail, see ``_basis.tail_features``);
        ``intercept`` (n_outputs,).
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
    result : ~sklearn_ifog.rbf._refine_core.RefineResult
        The best network found (or the starting one, with ``improved=False``).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.rbf._basis import Network, gaussian_design, solve_output_weights
    >>> rng = np.random.default_rng(0)
    >>> Z = rng.uniform(-1, 1, size=(200, 1))
    >>> Y = np.sin(3 * Z)
    >>> centers, widths = Z[:4], np.full(4, 2.0)
    >>> coef, tail, b = solve_output_weights(gaussian_design(Z, centers, widths), Z[:, :0], Y)
    >>> start = Network(centers=centers, widths=widths, coef=coef, tail_coef=tail, intercept=b)
    >>> res = refine_network(Z, Y, start, method="varpro")
    >>> res.improved, res.history["train_loss"][-1] < 0.1 * res.history["train_loss"][0]
    (True, True)
    """
    if method not in REFINE_METHODS:
        raise ValueError(f"method must be one of {REFINE_METHODS}, got {method!r}.")
    Z = as_float_array(Z, "Z")
    n, d = Z.shape
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[:, None]
    Y = as_float_array(Y, "Y")
    if Y.shape[0] != n:
        raise ValueError(f"Y has {Y.shape[0]} rows but Z has {n}.")
    m = Y.shape[1]
    original = _checked_network(network, d, m)
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
    sw = check_weights(sample_weight, n, "sample_weight")
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
        Zv, Yv, swv, totalv = _validation_rows(
            Z_val, Y_val, sample_weight_val, d, m, max_samples, rng
        )

    # Work on targets divided by one scale, so that the tolerances (absolute ones inside
    # least_squares, step norms mixing centres and weights in "lm") mean the same whatever the
    # units of y. The loss is homogeneous of degree 2 in (y, coef, tail, intercept), so the
    # nonlinear optimum does not move; outputs keep their relative weight.
    _, y_scale = weighted_mean_std(Y, sw, pooled=True)
    if not (np.isfinite(y_scale) and y_scale > 0):
        y_scale = 1.0
    start = original._replace(
        coef=original.coef / y_scale,
        tail_coef=original.tail_coef / y_scale,
        intercept=original.intercept / y_scale,
    )
    Y = Y / y_scale
    Yv = Yv / y_scale if has_val else None
    train0 = network_loss(Z, Y, sw, total, start, alpha)
    val0 = network_loss(Zv, Yv, swv, totalv, start, 0.0) if has_val else None
    patience = PATIENCE_GD if method == "gd" else PATIENCE
    tracker = Tracker(start, train0, val0, has_val, tol, patience)
    T = tail_features(Z, original.tail_degree)
    data = RefineData(Z, Y, sw, total, Zv, Yv, swv, totalv, float(alpha), T)
    max_iter = int(max_iter)
    # Single-threaded BLAS: the tall, skinny SVD/QR/Cholesky calls here gain nothing from
    # threads, and OpenBLAS threads on shared cores made them 50x slower (measured).
    with single_blas_thread():
        if method == "varpro":
            result = refine_varpro(data, start, tracker, max_iter, tol)
        elif method == "lm":
            result = refine_lm(data, start, tracker, max_iter, tol)
        else:
            result = refine_gd(data, start, tracker, max_iter, tol, learning_rate, rng)
    return _in_target_units(result, y_scale, original)


def _in_target_units(result, y_scale, original):
    """Undo the target scaling; without improvement, return copies of the original start."""
    if result.improved:
        net = result.network
        result.network = net._replace(
            coef=net.coef * y_scale,
            tail_coef=net.tail_coef * y_scale,
            intercept=net.intercept * y_scale,
        )
    else:
        result.network = original.copy()
    for key in ("train_loss", "val_loss"):
        result.history[key] = [value * y_scale**2 for value in result.history[key]]
    return result
