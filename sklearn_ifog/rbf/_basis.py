"""Gaussian basis and output-weight solve shared by selection and refinement.

The network, on inputs already standardised to ``Z``::

    f(Z) = gaussian_design(Z, centers, widths) @ coef.T + Z @ tail_coef.T + intercept

``coef`` has shape (n_outputs, n_centers), ``tail_coef`` (n_outputs, n_features) (zero-width
when there is no affine tail) and ``intercept`` (n_outputs,). Plain numpy in, numpy out.
"""

import numpy as np
import scipy.linalg

# Rows per block when a design would not fit comfortably in memory: 2**16 rows times a few
# hundred centres stays in the tens of megabytes.
DEFAULT_CHUNK_ROWS = 65536
# Up to this many rows, predictions use explicit differences (fewer numpy calls, exact for
# points at a centre): the single-row latency of an embedded compensator.
SMALL_BATCH_ROWS = 16


def squared_distances(Z, centers):
    """Squared Euclidean distances between rows of ``Z`` and ``centers``, clipped at 0.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Inputs.
    centers : ndarray of shape (n_centers, n_features)
        Centres.

    Returns
    -------
    D2 : ndarray of shape (n_samples, n_centers)
        ``||z_i - c_j||²``, never negative.

    Examples
    --------
    >>> import numpy as np
    >>> squared_distances(np.array([[0.0, 0.0]]), np.array([[3.0, 4.0]]))
    array([[25.]])
    """
    D2 = Z @ centers.T
    D2 *= -2.0
    D2 += np.einsum("ij,ij->i", Z, Z)[:, None]
    D2 += np.einsum("ij,ij->i", centers, centers)[None, :]
    np.maximum(D2, 0.0, out=D2)
    return D2


def gaussian_design(Z, centers, widths):
    """Gaussian activations ``exp(-||z - c_j||² / (2 σ_j²))``.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    centers : ndarray of shape (n_centers, n_features)
        Centres, in the same units as ``Z``.
    widths : float or ndarray of shape (n_centers,)
        Widths σ_j (positive).

    Returns
    -------
    Phi : ndarray of shape (n_samples, n_centers)
        Activations in (0, 1].

    Examples
    --------
    >>> import numpy as np
    >>> gaussian_design(np.array([[0.0], [1.0]]), np.array([[0.0]]), 1.0).round(4)
    array([[1.    ],
           [0.6065]])
    """
    n_samples, n_features = Z.shape
    inv_var = 1.0 / np.square(np.broadcast_to(widths, (centers.shape[0],)))
    # One matrix product gives the exponent: [z, ||z||², 1] @ [c/σ²; -1/(2σ²); -||c||²/(2σ²)]
    # = -||z - c||² / (2σ²), so the N x K array is written once, then clipped and exp'd in
    # place (three passes instead of six).
    weights = np.empty((n_features + 2, centers.shape[0]))
    weights[:n_features] = centers.T * inv_var
    weights[n_features] = -0.5 * inv_var
    weights[n_features + 1] = -0.5 * inv_var * np.square(centers).sum(axis=1)
    augmented = np.empty((n_samples, n_features + 2))
    augmented[:, :n_features] = Z
    np.square(Z).sum(axis=1, out=augmented[:, n_features])
    augmented[:, n_features + 1] = 1.0
    Phi = augmented @ weights
    # Round-off can make the exponent of a point at a centre slightly positive.
    np.minimum(Phi, 0.0, out=Phi)
    np.exp(Phi, out=Phi)
    return Phi


def predict_network(Z, centers, widths, coef, tail_coef, intercept, *, chunk_rows=None):
    """Network output, computed in row blocks so memory stays bounded.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    centers : ndarray of shape (n_centers, n_features)
        Centres.
    widths : ndarray of shape (n_centers,)
        Widths.
    coef : ndarray of shape (n_outputs, n_centers)
        Output weights of the Gaussian units.
    tail_coef : ndarray of shape (n_outputs, n_features) or (n_outputs, 0)
        Weights of the affine tail.
    intercept : ndarray of shape (n_outputs,)
        Intercepts.
    chunk_rows : int, default=None
        Rows per block; ``None`` uses ``DEFAULT_CHUNK_ROWS``.

    Returns
    -------
    Y : ndarray of shape (n_samples, n_outputs)
        Predictions.

    Examples
    --------
    >>> import numpy as np
    >>> Z = np.array([[0.0], [1.0]])
    >>> predict_network(
    ...     Z,
    ...     np.zeros((1, 1)),
    ...     np.ones(1),
    ...     np.ones((1, 1)),
    ...     np.zeros((1, 1)),
    ...     np.zeros(1),
    ... ).round(4)
    array([[1.    ],
           [0.6065]])
    """
    n_samples = Z.shape[0]
    if n_samples <= SMALL_BATCH_ROWS:
        return _predict_small(Z, centers, widths, coef, tail_coef, intercept)
    chunk_rows = DEFAULT_CHUNK_ROWS if chunk_rows is None else int(chunk_rows)
    Y = np.empty((n_samples, coef.shape[0]), dtype=np.float64)
    for start in range(0, n_samples, chunk_rows):
        block = Z[start : start + chunk_rows]
        out = gaussian_design(block, centers, widths) @ coef.T
        if tail_coef.shape[1]:
            out += block @ tail_coef.T
        out += intercept
        Y[start : start + chunk_rows] = out
    return Y


def _predict_small(Z, centers, widths, coef, tail_coef, intercept):
    """Few rows (single-row latency): explicit differences, fewest numpy calls."""
    diff = Z[:, None, :] - centers
    diff *= diff
    D2 = diff.sum(axis=2)
    D2 *= -0.5 / np.square(widths)
    np.exp(D2, out=D2)
    out = D2 @ coef.T
    if tail_coef.shape[1]:
        out += Z @ tail_coef.T
    out += intercept
    return out


def solve_output_weights(Phi, T, Y, *, sample_weight=None, alpha=0.0):
    """Weighted ridge solve of the linear output layer.

    Minimises ``Σ_i s_i ||y_i - Phi_i W - T_i A - b||² + alpha ||W||²``: the ridge penalty
    falls on the Gaussian weights only; the affine tail ``A`` and the intercept ``b`` are free.
    Solved by a least-squares solve of the augmented system (not the normal equations), so
    near-collinear columns cost accuracy in the weights, never a ``LinAlgError`` or a NaN.

    Parameters
    ----------
    Phi : ndarray of shape (n_samples, n_centers)
        Gaussian activations.
    T : ndarray of shape (n_samples, n_tail)
        Tail regressors (the standardised inputs, or ``n_tail=0``).
    Y : ndarray of shape (n_samples, n_outputs)
        Targets.
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative weights.
    alpha : float, default=0.0
        Ridge penalty on the Gaussian weights.

    Returns
    -------
    coef : ndarray of shape (n_outputs, n_centers)
    tail_coef : ndarray of shape (n_outputs, n_tail)
    intercept : ndarray of shape (n_outputs,)

    Examples
    --------
    >>> import numpy as np
    >>> T = np.linspace(-1, 1, 5)[:, None]
    >>> coef, tail, b = solve_output_weights(np.zeros((5, 0)), T, 2 * T + 1)
    >>> tail.round(6), b.round(6)
    (array([[2.]]), array([1.]))
    """
    n_samples, n_centers = Phi.shape
    sw = np.ones(n_samples) if sample_weight is None else np.asarray(sample_weight, float)
    total = sw.sum()
    if total <= 0:
        raise ValueError("sample_weight must have a positive sum.")
    mean_phi = sw @ Phi / total
    mean_t = sw @ T / total
    mean_y = sw @ Y / total
    root_w = np.sqrt(sw)[:, None]
    A = np.hstack([Phi - mean_phi, T - mean_t]) * root_w
    B = (Y - mean_y) * root_w
    if alpha > 0 and n_centers:
        penalty = np.zeros((n_centers, A.shape[1]))
        penalty[:, :n_centers] = np.sqrt(alpha) * np.eye(n_centers)
        A = np.vstack([A, penalty])
        B = np.vstack([B, np.zeros((n_centers, B.shape[1]))])
    if A.shape[1]:
        W = scipy.linalg.lstsq(A, B, cond=None, lapack_driver="gelsd")[0]
    else:
        W = np.zeros((0, B.shape[1]))
    coef = W[:n_centers].T.copy()
    tail_coef = W[n_centers:].T.copy()
    intercept = mean_y - mean_phi @ W[:n_centers] - mean_t @ W[n_centers:]
    return coef, tail_coef, intercept


def solve_output_weights_chunked(
    Z, Y, centers, widths, *, tail=True, sample_weight=None, alpha=0.0, chunk_rows=None
):
    """Weighted ridge solve of the output layer over all rows, in row blocks.

    Same problem as :func:`solve_output_weights` (ridge on the Gaussian weights only, free
    affine tail and intercept) but the design is never held whole: each block of rows is
    stacked under the running triangular factor and re-factorised (a tall-skinny QR), so
    memory stays at one block and the accuracy is that of a least-squares solve on the full
    design, not of the normal equations. The intercept is a weighted constant column rather
    than a centring step, so no mean is subtracted in a single pass. The final triangular
    system is solved by an SVD-based least-squares solve with a relative cutoff: rank
    deficiency (a constant feature, duplicate centres) gives the minimum-norm weights, never
    a ``LinAlgError`` or a NaN.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    Y : ndarray of shape (n_samples, n_outputs)
        Targets.
    centers : ndarray of shape (n_centers, n_features)
        Centres.
    widths : ndarray of shape (n_centers,)
        Widths.
    tail : bool, default=True
        Whether the inputs are regressors beside the Gaussian units.
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative weights.
    alpha : float, default=0.0
        Ridge penalty on the Gaussian weights (absolute, as in
        :func:`solve_output_weights`).
    chunk_rows : int, default=None
        Rows per block; ``None`` uses ``DEFAULT_CHUNK_ROWS``.

    Returns
    -------
    coef : ndarray of shape (n_outputs, n_centers)
    tail_coef : ndarray of shape (n_outputs, n_features) or (n_outputs, 0)
    intercept : ndarray of shape (n_outputs,)

    Examples
    --------
    >>> import numpy as np
    >>> Z = np.linspace(-1, 1, 7)[:, None]
    >>> coef, tail, b = solve_output_weights_chunked(
    ...     Z, 3 * Z - 1, np.zeros((0, 1)), np.ones(0), chunk_rows=3
    ... )
    >>> tail.round(6), b.round(6)
    (array([[3.]]), array([-1.]))
    """
    chunk_rows = DEFAULT_CHUNK_ROWS if chunk_rows is None else int(chunk_rows)
    n_samples, n_features = Z.shape
    n_centers, n_outputs = centers.shape[0], Y.shape[1]
    n_tail = n_features if tail else 0
    n_params = 1 + n_tail + n_centers
    if sample_weight is not None and np.sum(sample_weight) <= 0:
        raise ValueError("sample_weight must have a positive sum.")
    # The penalty rows start the factor: sqrt(alpha) on each Gaussian weight.
    R = np.zeros((n_centers, n_params + n_outputs))
    if alpha > 0 and n_centers:
        R[:, 1 + n_tail : n_params] = np.sqrt(alpha) * np.eye(n_centers)
    for start in range(0, n_samples, chunk_rows):
        stop = min(start + chunk_rows, n_samples)
        block = np.empty((stop - start, n_params + n_outputs))
        block[:, 0] = 1.0
        block[:, 1 : 1 + n_tail] = Z[start:stop, :n_tail]
        block[:, 1 + n_tail : n_params] = gaussian_design(Z[start:stop], centers, widths)
        block[:, n_params:] = Y[start:stop]
        if sample_weight is not None:
            block *= np.sqrt(sample_weight[start:stop])[:, None]
        R = np.linalg.qr(np.vstack([R, block]), mode="r")
    R11 = np.zeros((n_params, n_params))
    R12 = np.zeros((n_params, n_outputs))
    rows = min(R.shape[0], n_params)
    R11[:rows] = R[:rows, :n_params]
    R12[:rows] = R[:rows, n_params:]
    W = guarded_lstsq(R11, R12)
    return W[1 + n_tail :].T.copy(), W[1 : 1 + n_tail].T.copy(), W[0].copy()


def guarded_lstsq(A, B, *, rcond=1e-12):
    """Least-squares solve that never raises on rank deficiency and never returns NaN.

    SVD-based (LAPACK ``gelsd``) with singular values below ``rcond`` times the largest
    treated as zero, so a rank-deficient system gives its minimum-norm solution. Non-finite
    input raises a ``ValueError`` (it can only come from a bug upstream).

    Parameters
    ----------
    A : ndarray of shape (m, n)
        Matrix.
    B : ndarray of shape (m, k)
        Right-hand sides.
    rcond : float, default=1e-12
        Relative cutoff on the singular values.

    Returns
    -------
    X : ndarray of shape (n, k)
        Minimum-norm least-squares solution.

    Examples
    --------
    >>> import numpy as np
    >>> guarded_lstsq(np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([[2.0], [2.0]]))
    array([[1.],
           [1.]])
    """
    if A.shape[1] == 0:
        return np.zeros((0, B.shape[1]))
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        raise ValueError("Non-finite values in a least-squares system.")
    if not np.any(A):
        return np.zeros((A.shape[1], B.shape[1]))
    return scipy.linalg.lstsq(A, B, cond=rcond, lapack_driver="gelsd", check_finite=False)[0]
