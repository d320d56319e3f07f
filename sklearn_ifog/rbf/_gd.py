"""The reference paper's gradient rules (its Eqs. 17–19) as mini-batch steps.

Mini-batches of ``GD_BATCH_SIZE`` rows over a shuffled epoch (``random_state``), one learning
rate for all parameters. Eq. 17 updates the weights, Eq. 18 the centres; Eq. 19 is used in log
space: since ``∂L/∂log σ = σ ∂L/∂σ``, the step is
``Δ log σ_j = η Σ_i (d_i - y_i) W_j φ_ij ||z_i - c_j||² / σ_j²`` (Eq. 19 times ``σ_j``).
Sums are means over the batch (weighted), and each target is divided by its standard
deviation inside the method, so ``learning_rate`` does not depend on the units of ``y``. The
tail and intercept (absent in the paper) follow the same rule as Eq. 17. An epoch whose
training loss is not finite or more than doubles is undone and the learning rate halved.
"""

import numpy as np

from sklearn_ifog.rbf._basis import Network, weighted_mean_std
from sklearn_ifog.rbf._refine_core import center_bounds, log_activations, log_width_bounds

#: Rows per mini-batch of the gradient rules.
GD_BATCH_SIZE = 32


def refine_gd(data, start, tracker, max_iter, tol, learning_rate, rng):
    """The paper's gradient rules from the network ``start``; the best iterate to ``tracker``."""
    Z, Y, sw, total, T = data.Z, data.Y, data.sw, data.total, data.T
    n, d = Z.shape
    K = start.centers.shape[0]
    mean_y, y_scale = weighted_mean_std(Y, sw)
    y_scale[~(y_scale > 1e-12 * np.maximum(np.abs(mean_y), 1.0))] = 1.0
    Ys = Y / y_scale
    log_w0, lw_lo, lw_hi = log_width_bounds(start.widths)
    c_lo, c_hi = center_bounds(Z, K)
    c_lo, c_hi = c_lo.reshape(K, d), c_hi.reshape(K, d)
    params = [
        np.clip(start.centers, c_lo, c_hi),
        log_w0,
        start.coef / y_scale[:, None],
        start.tail_coef / y_scale[:, None],
        start.intercept / y_scale,
    ]

    def network(p):
        C, lw, W, A, b = p
        return Network(
            centers=C.copy(),
            widths=np.exp(lw),
            coef=W * y_scale[:, None],
            tail_coef=A * y_scale[:, None],
            intercept=b * y_scale,
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
            D2, Phi, inv_var = log_activations(Zb, C, lw)
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
