"""Gaussian basis and output-weight solve shared by selection and refinement.

The network, on inputs already standardised to ``Z``::

    f(Z) = (gaussian_design(Z, centers, widths) @ coef.T
            + tail_features(Z, tail_degree) @ tail_coef.T + intercept)

``coef`` has shape (n_outputs, n_centers), ``tail_coef`` (n_outputs, n_tail) and ``intercept``
(n_outputs,). The polynomial tail has degree 0 (no tail, ``n_tail = 0``), 1 (the inputs,
``n_tail = d``) or 2 (the inputs then their degree-2 monomials, ``n_tail = d + d (d + 1) / 2``);
the degree follows from ``n_tail`` (:func:`tail_degree_from_size`). A network travels as a
:class:`Network` value. Plain numpy in, numpy out.
"""

from functools import lru_cache
from typing import NamedTuple

import numpy as np
import scipy.linalg

# Rows per block of a prediction: 2**14 rows times a few dozen centres stays within a few
# megabytes, in cache (about 10% faster than 2**16 rows on 1e6 rows and 40 centres, with
# the blocks' arrays reused).
DEFAULT_CHUNK_ROWS = 16384
# Entries (rows x columns) of one block of the blocked output-weight solve by default: a
# block of about a megabyte stays in cache while LAPACK factorises it, which on a skinny
# design (a few dozen columns, where the Householder QR is mostly memory-bound vector
# operations) is 2.5 times faster than 65536-row blocks (1e6 rows, 45 columns, one thread);
# a wide design (a quadratic tail on many features) gets fewer rows, so memory stays bounded.
QR_BLOCK_ENTRIES = 2**17
# The blocked output-weight solve factorises the Gram matrix (normal equations, one BLAS-3
# pass) when the parameters' triangular factor is conditioned at most this well, else by QR:
# the normal equations lose about eps * cond**2 of relative accuracy in the weights, so 1e5
# keeps them within about 1e-6 relative (the fitted values far closer), far below any
# drift model's noise; a worse-conditioned design keeps the QR's accuracy.
GRAM_CONDITION_LIMIT = 1e5
# Up to this many rows, predictions use explicit differences (fewer numpy calls, exact for
# points at a centre): the single-row latency of an embedded compensator.
SMALL_BATCH_ROWS = 16
# Widths are kept inside this range (standardised units), by selection and by refinement, so
# no design column is all zeros or all ones by construction.
WIDTH_LIMITS = (1e-3, 1e3)


class Network(NamedTuple):
    """A Gaussian RBF network on standardised inputs, as one value.

    ``f(Z) = gaussian_design(Z, centers, widths) @ coef.T + tail_features(Z, tail_degree)
    @ tail_coef.T + intercept``, which :meth:`predict` evaluates. Read its fields by name
    (the order is that of :func:`predict_network`'s arguments, which callers outside
    ``rbf`` still rely on, but nothing in ``rbf`` does).

    Attributes
    ----------
    centers : ndarray of shape (n_centers, n_features)
        Centres, standardised units.
    widths : ndarray of shape (n_centers,)
        Widths, standardised units.
    coef : ndarray of shape (n_outputs, n_centers)
        Gaussian output weights.
    tail_coef : ndarray of shape (n_outputs, n_tail)
        Polynomial-tail weights; ``n_tail`` (0, ``d`` or ``d + d (d + 1) / 2``) sets the
        tail's degree (:attr:`tail_degree`).
    intercept : ndarray of shape (n_outputs,)
        Intercepts.

    Examples
    --------
    >>> import numpy as np
    >>> net = Network(
    ...     centers=np.zeros((1, 1)),
    ...     widths=np.ones(1),
    ...     coef=np.ones((1, 1)),
    ...     tail_coef=np.zeros((1, 1)),
    ...     intercept=np.zeros(1),
    ... )
    >>> net.tail_degree, net.predict(np.array([[1.0]])).round(4)
    (1, array([[0.6065]]))
    """

    centers: np.ndarray
    widths: np.ndarray
    coef: np.ndarray
    tail_coef: np.ndarray
    intercept: np.ndarray

    @property
    def tail_degree(self):
        """Degree (0, 1 or 2) of the polynomial tail, from the number of tail columns."""
        return tail_degree_from_size(self.tail_coef.shape[1], self.centers.shape[1])

    def copy(self):
        """A network holding copies of the arrays."""
        return Network(**{name: np.array(getattr(self, name), copy=True) for name in self._fields})

    def predict(self, Z, *, chunk_rows=None):
        """The network's output on standardised inputs ``Z``: :func:`predict_network`."""
        return predict_network(
            Z,
            centers=self.centers,
            widths=self.widths,
            coef=self.coef,
            tail_coef=self.tail_coef,
            intercept=self.intercept,
            chunk_rows=chunk_rows,
        )


def weighted_mean_std(A, sample_weight, *, pooled=False):
    """Weighted column means and standard deviations, the one target standardisation.

    Parameters
    ----------
    A : ndarray of shape (n_samples, n_columns)
        Values.
    sample_weight : ndarray of shape (n_samples,)
        Non-negative weights with a positive sum.
    pooled : bool, default=False
        False: one standard deviation per column. True: one for all columns, the root of
        their mean variance (every column keeps its relative weight when divided by it).

    Returns
    -------
    mean : ndarray of shape (n_columns,)
        Weighted means.
    std : ndarray of shape (n_columns,) or float
        Weighted standard deviations (not guarded: a constant column gives 0).

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[0.0, 0.0], [2.0, 4.0]])
    >>> weighted_mean_std(A, np.ones(2))
    (array([1., 2.]), array([1., 2.]))
    >>> round(weighted_mean_std(A, np.ones(2), pooled=True)[1], 6)
    1.581139
    """
    total = sample_weight.sum()
    mean = sample_weight @ A / total
    deviation = A - mean
    sum_sq = sample_weight @ np.square(deviation, out=deviation)
    if pooled:
        return mean, float(np.sqrt(np.sum(sum_sq) / (total * A.shape[1])))
    return mean, np.sqrt(sum_sq / total)


def standardisation(A, sample_weight):
    """:func:`weighted_mean_std`, guarded: scale 1 for a constant column.

    An exactly constant column (over the rows of positive weight) gets its own value as mean,
    so it standardises to 0; a standard deviation that is not positive becomes 1. Returns
    ``(mean, scale)``, each of shape (n_columns,).

    Examples
    --------
    >>> import numpy as np
    >>> standardisation(np.array([[1.0, 3.0], [1.0, 5.0]]), np.ones(2))
    (array([1., 4.]), array([1., 1.]))
    """
    mean, scale = weighted_mean_std(A, sample_weight)
    has_weight = sample_weight > 0
    positive = A if has_weight.all() else A[has_weight]  # no copy of the rows when all count
    constant = np.ptp(positive, axis=0) == 0
    mean[constant] = positive[0, constant]
    scale[constant | ~(scale > 0)] = 1.0
    return mean, scale


def n_tail_features(n_features, degree):
    """Number of columns of :func:`tail_features` for ``n_features`` inputs.

    Parameters
    ----------
    n_features : int
        Number of inputs ``d``.
    degree : {0, 1, 2}
        Degree of the polynomial tail.

    Returns
    -------
    n_tail : int
        0, ``d`` or ``d + d (d + 1) / 2``.

    Examples
    --------
    >>> n_tail_features(3, 0), n_tail_features(3, 1), n_tail_features(3, 2)
    (0, 3, 9)
    """
    if degree not in (0, 1, 2):
        raise ValueError(f"The tail degree must be 0, 1 or 2, got {degree!r}.")
    return (0, n_features, n_features + n_features * (n_features + 1) // 2)[degree]


def tail_degree_from_size(n_tail, n_features):
    """Degree of the polynomial tail that has ``n_tail`` columns on ``n_features`` inputs.

    Parameters
    ----------
    n_tail : int
        Number of tail columns (``tail_coef.shape[-1]``).
    n_features : int
        Number of inputs ``d``.

    Returns
    -------
    degree : {0, 1, 2}
        The degree; the three sizes are distinct for every ``d >= 1``.

    Examples
    --------
    >>> tail_degree_from_size(9, 3)
    2
    """
    for degree in (0, 1, 2):
        if n_tail == n_tail_features(n_features, degree):
            return degree
    raise ValueError(
        f"A tail on {n_features} inputs has 0, {n_tail_features(n_features, 1)} or "
        f"{n_tail_features(n_features, 2)} columns, got {n_tail}."
    )


@lru_cache(maxsize=32)
def _monomial_pairs(n_features):
    # Row-major upper triangle: (0, 0), (0, 1), ..., (0, d-1), (1, 1), ... which is the order
    # of sklearn's PolynomialFeatures(degree=2).
    return np.triu_indices(n_features)


def transformed(T, M):
    """``T @ M``, or ``T`` itself when ``M`` is None (the plain ridge): the tail columns
    reparametrised for the tail penalty (``M`` from
    :func:`sklearn_ifog.rbf._tail_penalty.tail_transform`).

    Examples
    --------
    >>> import numpy as np
    >>> T = np.array([[1.0, 2.0]])
    >>> transformed(T, np.array([[2.0, 0.0], [0.0, 3.0]]))
    array([[2., 6.]])
    >>> transformed(T, None) is T
    True
    """
    if M is None or T is None:
        return T
    return T @ M


def tail_features(Z, degree):
    """Regressors of the polynomial tail: none, the inputs, or the inputs and their squares.

    Degree 2 gives the inputs followed by every degree-2 monomial ``z_i z_j`` (``i <= j``) in
    the order of ``sklearn.preprocessing.PolynomialFeatures(degree=2, include_bias=False)``:
    ``z0, z1, ..., z0², z0 z1, ..., z1², ...``. The intercept is never a tail column.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    degree : {0, 1, 2}
        Degree of the tail.

    Returns
    -------
    T : ndarray of shape (n_samples, n_tail)
        ``n_tail`` is :func:`n_tail_features` ``(n_features, degree)``; for degree 1 this is
        ``Z`` itself (no copy).

    Examples
    --------
    >>> import numpy as np
    >>> tail_features(np.array([[2.0, 3.0]]), 2)
    array([[2., 3., 4., 6., 9.]])
    """
    n_samples, n_features = Z.shape
    if degree == 1:
        return Z
    if degree == 0:
        return Z[:, :0]
    n_tail_features(n_features, degree)  # validates the degree
    first, second = _monomial_pairs(n_features)
    T = np.empty((n_samples, n_tail_features(n_features, 2)), dtype=np.result_type(Z, float))
    T[:, :n_features] = Z
    np.multiply(Z.take(first, axis=1), Z.take(second, axis=1), out=T[:, n_features:])
    return T


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
    return _design_from_weights(Z, _exponent_weights(centers, widths))


def _exponent_weights(centers, widths):
    """``[c/σ²; -1/(2σ²); -||c||²/(2σ²)]``, shape (n_features + 2, n_centers).

    One matrix product gives the exponent: ``[z, ||z||², 1] @ weights = -||z - c||² / (2σ²)``
    (:func:`_design_from_weights`).
    """
    n_features = centers.shape[1]
    inv_var = 1.0 / np.square(np.broadcast_to(widths, (centers.shape[0],)))
    weights = np.empty((n_features + 2, centers.shape[0]))
    weights[:n_features] = centers.T * inv_var
    weights[n_features] = -0.5 * inv_var
    weights[n_features + 1] = -0.5 * inv_var * np.square(centers).sum(axis=1)
    return weights


def _design_buffers(n_rows, n_features, n_centers):
    """``buffers`` for :func:`_design_from_weights` on blocks of at most ``n_rows`` rows."""
    return (
        np.empty((n_rows, n_features + 2)),
        np.empty((n_rows, n_centers)),
        np.zeros((n_rows, n_centers)),
    )


def _design_from_weights(Z, weights, *, buffers=None):
    """Gaussian activations from :func:`_exponent_weights` (see :func:`gaussian_design`).

    ``buffers``: ``(augmented, Phi, zeros)`` arrays of at least ``len(Z)`` rows, the last
    all zeros, to write into (the blocks of a long prediction or solve reuse them); None
    allocates what is needed.
    """
    n_samples, n_features = Z.shape
    # The N x K array is written once, then clipped and exp'd in place (three passes
    # instead of six).
    if buffers is None:
        augmented = np.empty((n_samples, n_features + 2))
        Phi = zeros = None
    else:
        augmented, Phi, zeros = (buffer[:n_samples] for buffer in buffers)
    augmented[:, :n_features] = Z
    squares = augmented[:, n_features]
    if 0 < n_features < 8:
        # Column by column: the sums numpy's row reduction gives for so few columns (the
        # same order), without its per-row loop (five times faster on three columns).
        np.square(Z[:, 0], out=squares)
        for feature in range(1, n_features):
            squares += np.square(Z[:, feature])
    else:
        np.square(Z).sum(axis=1, out=squares)
    augmented[:, n_features + 1] = 1.0
    Phi = np.matmul(augmented, weights, out=Phi)
    # Round-off can make the exponent of a point at a centre slightly positive. (Against
    # an array of zeros numpy's minimum is vectorised: three times faster than the scalar.)
    np.minimum(Phi, 0.0 if zeros is None else zeros, out=Phi)
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
    tail_coef : ndarray of shape (n_outputs, n_tail)
        Weights of the polynomial tail; ``n_tail`` (0, ``d`` or ``d + d (d + 1) / 2``) sets
        its degree (0, 1 or 2), see :func:`tail_features`.
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
    n_samples, n_features = Z.shape
    degree = tail_degree_from_size(tail_coef.shape[1], n_features)
    if n_samples <= SMALL_BATCH_ROWS:
        return _predict_small(Z, centers, widths, coef, tail_coef, intercept, degree)
    chunk_rows = DEFAULT_CHUNK_ROWS if chunk_rows is None else int(chunk_rows)
    Y = np.empty((n_samples, coef.shape[0]), dtype=np.float64)
    weights = _exponent_weights(centers, widths)
    buffers = _design_buffers(min(chunk_rows, n_samples), n_features, centers.shape[0])
    for start in range(0, n_samples, chunk_rows):
        block = Z[start : start + chunk_rows]
        out = _design_from_weights(block, weights, buffers=buffers) @ coef.T
        if degree:
            out += tail_features(block, degree) @ tail_coef.T
        out += intercept
        Y[start : start + chunk_rows] = out
    return Y


def _predict_small(Z, centers, widths, coef, tail_coef, intercept, degree):
    """Few rows (single-row latency): explicit differences, fewest numpy calls."""
    diff = Z[:, None, :] - centers
    diff *= diff
    D2 = diff.sum(axis=2)
    D2 *= -0.5 / np.square(widths)
    np.exp(D2, out=D2)
    out = D2 @ coef.T
    if degree:
        n_features = Z.shape[1]
        out += Z @ tail_coef[:, :n_features].T
        if degree == 2:
            # The monomials straight into the product: no (n, n_tail) array is assembled.
            first, second = _monomial_pairs(n_features)
            monomials = Z.take(first, axis=1)
            monomials *= Z.take(second, axis=1)
            out += monomials @ tail_coef[:, n_features:].T
    out += intercept
    return out


def solve_output_weights(Phi, T, Y, *, sample_weight=None, alpha=0.0):
    """Weighted ridge solve of the linear output layer.

    Minimises ``Σ_i s_i ||y_i - Phi_i W - T_i A - b||² + alpha ||W||²``: the ridge penalty
    falls on the Gaussian weights only; the polynomial tail ``A`` and the intercept ``b`` are
    free.
    Solved by a least-squares solve of the augmented system (not the normal equations), so
    near-collinear columns cost accuracy in the weights, never a ``LinAlgError`` or a NaN.

    Parameters
    ----------
    Phi : ndarray of shape (n_samples, n_centers)
        Gaussian activations.
    T : ndarray of shape (n_samples, n_tail)
        Tail regressors (:func:`tail_features` of the standardised inputs, or ``n_tail=0``).
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
    Z,
    Y,
    centers,
    widths,
    *,
    tail=1,
    sample_weight=None,
    alpha=0.0,
    tail_alpha=0.0,
    tail_transform=None,
    chunk_rows=None,
):
    """Weighted ridge solve of the output layer over all rows, in row blocks.

    Same problem as :func:`solve_output_weights` (ridge on the Gaussian weights only, free
    polynomial tail and intercept) but the design is never held whole: each block of rows is
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
    tail : {0, 1, 2} or bool, default=1
        Degree of the polynomial tail beside the Gaussian units (:func:`tail_features`);
        ``True`` means 1 (the inputs), ``False`` 0 (none).
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative weights.
    alpha : float, default=0.0
        Ridge penalty on the Gaussian weights (absolute, as in
        :func:`solve_output_weights`).
    tail_alpha : float, default=0.0
        Ridge penalty on the tail weights (absolute); the intercept is never penalised.
    tail_transform : ndarray of shape (n_tail, n_tail), default=None
        The tail penalty's shape (:func:`~sklearn_ifog.rbf._tail_penalty.tail_transform`):
        the ridge falls on ``w'`` where the tail weights are ``w = tail_transform @ w'``.
        None: on the tail weights themselves.
    chunk_rows : int, default=None
        Rows per block; ``None`` gives blocks of about ``QR_BLOCK_ENTRIES`` entries (at
        least 256 rows), small enough to stay in cache while they are factorised.

    Returns
    -------
    coef : ndarray of shape (n_outputs, n_centers)
    tail_coef : ndarray of shape (n_outputs, n_tail)
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
    n_samples, n_features = Z.shape
    n_centers, n_outputs = centers.shape[0], Y.shape[1]
    degree = int(tail)
    n_tail = n_tail_features(n_features, degree)
    n_params = 1 + n_tail + n_centers
    n_columns = n_params + n_outputs
    if chunk_rows is None:
        chunk_rows = max(256, QR_BLOCK_ENTRIES // n_columns)
    chunk_rows = max(1, min(int(chunk_rows), n_samples))
    if sample_weight is not None and np.sum(sample_weight) <= 0:
        raise ValueError("sample_weight must have a positive sum.")
    # Unit weights (the estimator's default) leave the rows as they are: no product.
    root_w = None
    if sample_weight is not None and not np.all(sample_weight == 1.0):
        root_w = np.sqrt(sample_weight)
    weights = _exponent_weights(centers, widths)
    design_buffers = _design_buffers(chunk_rows, n_features, n_centers)

    def blocks(destination):
        # Each block of rows of the augmented design [1, tail, Gaussians, Y] (times the
        # square-root weights), written where ``destination(rows)`` says.
        for start in range(0, n_samples, chunk_rows):
            stop = min(start + chunk_rows, n_samples)
            block = destination(stop - start)
            block[:, 0] = 1.0
            if degree:
                block[:, 1 : 1 + n_tail] = transformed(tail_features(Z[start:stop], degree), M)
            block[:, 1 + n_tail : n_params] = _design_from_weights(
                Z[start:stop], weights, buffers=design_buffers
            )
            block[:, n_params:] = Y[start:stop]
            if root_w is not None:
                block *= root_w[start:stop, None]
            yield block

    # The penalty's shape is a reparametrisation of the tail; without a penalty it is moot.
    M = tail_transform if (tail_alpha > 0 and degree) else None
    # The ridge penalty of every column (never on the intercept, nor on the targets).
    penalty = np.zeros(n_columns)
    if tail_alpha > 0:
        penalty[1 : 1 + n_tail] = tail_alpha
    if alpha > 0:
        penalty[1 + n_tail : n_params] = alpha
    R = _gram_factor(blocks, chunk_rows, n_columns, n_params, penalty)
    if R is None:
        R = _tall_skinny_factor(blocks, chunk_rows, n_columns, n_tail, n_centers, penalty)
    R11 = np.zeros((n_params, n_params))
    R12 = np.zeros((n_params, n_outputs))
    rows = min(R.shape[0], n_params)
    R11[:rows] = R[:rows, :n_params]
    R12[:rows] = R[:rows, n_params:]
    W = guarded_lstsq(R11, R12)
    tail_weights = W[1 : 1 + n_tail] if M is None else M @ W[1 : 1 + n_tail]
    return W[1 + n_tail :].T.copy(), tail_weights.T.copy(), W[0].copy()


def _gram_factor(blocks, chunk_rows, n_columns, n_params, penalty):
    """The triangular factor of the penalised augmented design from its Gram matrix, or None.

    One pass of matrix products over the row blocks and a Cholesky factorisation: several
    times faster than the tall-skinny QR on a million rows (the QR's Householder updates
    are memory-bound on a skinny block; the Gram matrix is one BLAS-3 product per block),
    and as accurate while the design is well conditioned. The Gram matrix squares the
    condition number, so None (the caller then factorises by QR) when the parameters'
    factor is conditioned worse than ``GRAM_CONDITION_LIMIT``, or when the Gram matrix is
    not positive definite (a rank-deficient design, or targets the design fits exactly).
    """
    block_buffer = np.empty((chunk_rows, n_columns))
    gram = np.zeros((n_columns, n_columns))
    for block in blocks(lambda rows: block_buffer[:rows]):
        gram += block.T @ block
    gram[np.diag_indices(n_columns)] += penalty
    try:
        R = np.linalg.cholesky(gram).T
    except np.linalg.LinAlgError:
        return None
    if not np.isfinite(R).all():
        return None
    if np.linalg.cond(R[:n_params, :n_params]) > GRAM_CONDITION_LIMIT:
        return None
    return R


def _tall_skinny_factor(blocks, chunk_rows, n_columns, n_tail, n_centers, penalty):
    """The triangular factor of the penalised augmented design by a tall-skinny QR.

    Each block of rows is stacked under the running factor and re-factorised; the penalty
    rows (the square root of each parameter's penalty) start the factor.
    """
    tail_penalty = penalty[1 : 1 + n_tail]
    gaussian_penalty = penalty[1 + n_tail : 1 + n_tail + n_centers]
    n_tail_rows = n_tail if tail_penalty.any() else 0
    # One buffer holds the running factor (at most n_columns rows) on top of the next block
    # of rows, so no block is stacked by a copy.
    buffer = np.zeros((n_columns + chunk_rows, n_columns))
    if n_tail_rows:
        buffer[:n_tail, 1 : 1 + n_tail] = np.diag(np.sqrt(tail_penalty))
    if gaussian_penalty.any():
        buffer[n_tail_rows : n_tail_rows + n_centers, 1 + n_tail : 1 + n_tail + n_centers] = (
            np.diag(np.sqrt(gaussian_penalty))
        )
    # Without a penalty the original factor had n_centers rows of zeros; they change
    # nothing but are kept, so the blocks are factorised as before.
    # The factor's height, read by the next block's placement (a list, so that the
    # placement sees each update).
    top = [n_tail_rows + n_centers]
    R = buffer[: top[0]]
    for block in blocks(lambda rows: buffer[top[0] : top[0] + rows]):
        R = np.linalg.qr(buffer[: top[0] + block.shape[0]], mode="r")
        top[0] = R.shape[0]
        buffer[: top[0]] = R
    return R


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
