"""Orthogonal-least-squares centre selection and model choice along the selection path.

Forward selection of Gaussian units by the (regularised) error-reduction ratio of Chen,
Cowan & Grant (1991) and Chen, Chng & Alkadhimi (1996), and the pieces around it: the
candidate pool, the width scale, contiguous validation blocks, the re-solved fit of every
prefix of the path and the criteria that pick a prefix. Plain numpy in, numpy out.
"""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.spatial import cKDTree
from scipy.spatial.distance import pdist
from sklearn.cluster import kmeans_plusplus
from sklearn.utils import check_random_state

from sklearn_ifog.rbf._basis import guarded_lstsq

CRITERIA = ("holdout", "gcv", "bic", "aicc")

# A column whose part orthogonal to the columns already chosen is smaller than this fraction
# of its own norm is treated as collinear with them and never chosen: its weight would be
# set by round-off.
DEFAULT_RTOL = 1e-5

# Selection stops once the best candidate would explain less than this fraction of the
# target's variance: such a unit fits round-off, not data.
_MIN_ERR = 1e-12


@dataclass
class OLSPath:
    """Result of :func:`ols_forward_select`.

    Attributes
    ----------
    selected : ndarray of shape (n_selected,)
        Indices of the chosen candidate columns, in the order chosen.
    err : ndarray of shape (n_selected,)
        (Regularised) error-reduction ratio of each chosen column: the fraction of the
        centred target's weighted sum of squares it explains, summed over outputs.
    tail_err : float
        Fraction explained by the always-in regressors (the polynomial tail).
    sse : ndarray of shape (n_selected + 1,)
        Weighted residual sum of squares (summed over outputs) of the least-squares fit on
        the intercept, the tail and the first ``k`` chosen columns, ``k = 0 .. n_selected``.
    n_rejected : int
        Candidates rejected as collinear with the columns already chosen.
    """

    selected: np.ndarray
    err: np.ndarray
    tail_err: float
    sse: np.ndarray
    n_rejected: int


def _weighted_centre(A, sw, root_w):
    """Subtract the weighted column means and scale rows by the root weights."""
    return (A - (sw @ A) / sw.sum()) * root_w[:, None]


def _orthogonalise(v, Q):
    """Project ``v`` off the orthonormal columns of ``Q`` twice ("twice is enough")."""
    if Q.shape[1]:
        v = v - Q @ (Q.T @ v)
        v = v - Q @ (Q.T @ v)
    return v


def ols_forward_select(
    P,
    Y,
    *,
    T=None,
    sample_weight=None,
    alpha=0.0,
    max_selected=None,
    rtol=DEFAULT_RTOL,
    workspace=None,
):
    """Greedy forward selection of candidate columns by the error-reduction ratio.

    The intercept and the columns of ``T`` (the polynomial tail) are always in the model and
    are projected out first; the target is centred. At each step the candidate whose
    component orthogonal to the columns already chosen explains most of the remaining
    target, ``(wᵀy)² / (wᵀw + alpha)`` summed over outputs (the regularised ratio of Chen,
    Chng & Alkadhimi; ``alpha=0`` gives the classical ratio), is added.

    The candidate matrix is never overwritten: each new orthonormal direction ``q`` costs one
    matrix-vector product ``Pᵀq`` over all candidates, from which their residual norms and
    correlations with the target are downdated. The chosen column itself is orthogonalised
    explicitly against all chosen directions, twice (re-orthogonalisation), and is rejected
    if what is left is below ``rtol`` times its own norm, so a near-collinear candidate is
    never picked, whatever the downdates say.

    Parameters
    ----------
    P : ndarray of shape (n_samples, n_candidates)
        Candidate columns (e.g. Gaussian activations at each candidate centre).
    Y : ndarray of shape (n_samples, n_outputs)
        Targets.
    T : ndarray of shape (n_samples, n_tail), default=None
        Always-in regressors.
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative weights.
    alpha : float, default=0.0
        Ridge term of the regularised error-reduction ratio (absolute).
    max_selected : int, default=None
        Upper bound on the number of columns chosen; ``None`` means all candidates.
    rtol : float, default=1e-5
        Relative tolerance below which a column counts as collinear.
    workspace : :class:`Workspace`, default=None
        Scratch arrays to reuse (between calls on candidate matrices of one shape, fresh
        arrays of megabytes cost their page faults every time); None allocates them.

    Returns
    -------
    path : OLSPath
        Chosen indices, error-reduction ratios and residual sums of squares.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.linspace(-1, 1, 9)
    >>> P = np.column_stack([x**2, np.abs(x), x**2])
    >>> path = ols_forward_select(P, (x**2)[:, None])
    >>> path.selected.tolist(), path.err.round(6).tolist(), path.n_rejected
    ([0], [1.0], 1)
    """
    n_samples, n_candidates = P.shape
    sw = np.ones(n_samples) if sample_weight is None else np.asarray(sample_weight, float)
    root_w = np.sqrt(sw)
    max_selected = n_candidates if max_selected is None else min(max_selected, n_candidates)
    n_tail = 0 if T is None else T.shape[1]

    # Unit weights (the estimator's default) scale nothing: the products by root_w are
    # skipped. The squares of the candidate matrix go to one scratch array.
    unit = bool(np.all(sw == 1.0))
    # Reference norms include the mean: a column that is nearly constant is collinear with
    # the intercept and must be rejected by the same relative test.
    workspace = Workspace() if workspace is None else workspace
    scratch = workspace.array("ols_scratch", P.shape)
    if unit:
        reference_sq = np.square(P, out=scratch).sum(axis=0)
        Pc = np.subtract(P, (sw @ P) / sw.sum(), out=workspace.array("ols_centred", P.shape))
    else:
        reference_sq = np.square(np.multiply(P, root_w[:, None], out=scratch), out=scratch)
        reference_sq = reference_sq.sum(axis=0)
        Pc = _weighted_centre(P, sw, root_w)
    Yr = _weighted_centre(Y, sw, root_w)
    total = float(np.square(Yr).sum())
    Q = np.zeros((n_samples, n_tail + max_selected))
    n_basis = 0
    if n_tail:
        tail_reference = np.sqrt(np.square(T * root_w[:, None]).sum(axis=0))
        for column, ref in zip(_weighted_centre(T, sw, root_w).T, tail_reference, strict=True):
            v = _orthogonalise(column, Q[:, :n_basis])
            norm = np.linalg.norm(v)
            if norm > rtol * ref and norm > 0:
                Q[:, n_basis] = v / norm
                n_basis += 1
    basis = Q[:, :n_basis]
    tail_yq = basis.T @ Yr
    Yr = Yr - basis @ tail_yq
    tail_err = float(np.square(tail_yq).sum() / total) if total > 0 else 0.0

    projections = Pc.T @ basis
    residual_sq = np.square(Pc, out=scratch).sum(axis=0) - np.square(projections).sum(axis=1)
    correlations = Pc.T @ Yr
    available = np.ones(n_candidates, dtype=bool)
    rejected = np.zeros(n_candidates, dtype=bool)
    selected, errs, sse = [], [], [float(np.square(Yr).sum())]
    floor_sq = rtol**2 * reference_sq
    while len(selected) < max_selected and total > 0:
        available &= residual_sq > floor_sq
        if not available.any():
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            score = np.where(
                available,
                np.square(correlations).sum(axis=1) / (np.maximum(residual_sq, 0.0) + alpha),
                -np.inf,
            )
        j = int(np.argmax(score))
        if not score[j] > _MIN_ERR * total:
            break
        v = _orthogonalise(Pc[:, j], Q[:, :n_basis])
        norm_sq = float(v @ v)
        available[j] = False
        if not norm_sq > floor_sq[j]:
            rejected[j] = True
            continue
        q = v / np.sqrt(norm_sq)
        Q[:, n_basis] = q
        n_basis += 1
        a = Pc.T @ q
        yq = q @ Yr
        residual_sq -= np.square(a)
        correlations -= np.outer(a, yq)
        Yr -= np.outer(q, yq)
        selected.append(j)
        errs.append(score[j] / total)
        sse.append(float(np.square(Yr).sum()))
    rejected |= residual_sq <= floor_sq
    rejected[selected] = False
    return OLSPath(
        selected=np.asarray(selected, dtype=np.intp),
        err=np.asarray(errs, dtype=float),
        tail_err=tail_err,
        sse=np.asarray(sse),
        n_rejected=int(np.count_nonzero(rejected)),
    )


class Workspace:
    """Named scratch arrays, reused while their shape stays the same.

    The selection runs one path per width (and per fold) on candidate matrices of one
    shape; allocating them afresh costs page faults of the same order as the arithmetic.
    One workspace belongs to one sequence of calls (not shared between threads).

    Examples
    --------
    >>> work = Workspace()
    >>> work.array("a", (2, 3)) is work.array("a", (2, 3))
    True
    """

    def __init__(self):
        self._arrays = {}

    def array(self, name, shape):
        """An uninitialised float64 array of ``shape``, the same one while the shape holds."""
        shape = tuple(shape)
        array = self._arrays.get(name)
        if array is None or array.shape != shape:
            array = self._arrays[name] = np.empty(shape)
        return array


@dataclass
class PrefixFits:
    """Result of :func:`prefix_fits`: the least-squares network on every path prefix.

    Attributes
    ----------
    weights : sequence of ndarray
        ``weights[k]`` has shape (1 + n_tail + k, n_outputs): intercept, tail weights and
        the weights of the first ``k`` columns (ridge on those only).
    train_mse : ndarray of shape (n_prefixes, n_outputs)
        Weighted training mean squared error of each prefix.
    dof : ndarray of shape (n_prefixes,)
        Effective degrees of freedom (trace of the ridge hat matrix, intercept included).
    val_mse : ndarray of shape (n_prefixes, n_outputs) or None
        Weighted mean squared error on the validation rows, if given.
    val_sq : ndarray of shape (n_prefixes, n_val) or None
        Squared validation error of every row (summed over outputs), if given.
    """

    weights: Sequence
    train_mse: np.ndarray
    dof: np.ndarray
    val_mse: np.ndarray | None
    val_sq: np.ndarray | None = None


def _regressors(T, Phi):
    n_samples = Phi.shape[0]
    parts = [np.ones((n_samples, 1))]
    if T is not None:
        parts.append(T)
    parts.append(Phi)
    return np.hstack(parts)


def prefix_fits(
    Phi,
    Y,
    *,
    T=None,
    sample_weight=None,
    alpha=0.0,
    tail_alpha=0.0,
    Phi_val=None,
    T_val=None,
    Y_val=None,
    sample_weight_val=None,
):
    """Ridge fit of the output layer on every prefix of a selection path, from one QR.

    The columns are ordered intercept, tail, then the chosen units in selection order; with
    the ridge rows appended under the design, the leading ``p x p`` block of one Householder
    QR factor is the factor of the first ``p`` columns' problem (the ridge rows of later
    columns are zero in earlier ones), so each prefix costs a small triangular solve.

    Parameters
    ----------
    Phi : ndarray of shape (n_samples, n_selected)
        Chosen columns, in selection order.
    Y : ndarray of shape (n_samples, n_outputs)
        Targets.
    T : ndarray of shape (n_samples, n_tail), default=None
        Always-in regressors.
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative weights.
    alpha : float, default=0.0
        Ridge penalty on the weights of ``Phi`` (absolute).
    tail_alpha : float, default=0.0
        Ridge penalty on the weights of ``T`` (absolute); the intercept is never penalised.
    Phi_val, T_val, Y_val, sample_weight_val : ndarray, default=None
        Validation rows; when ``Phi_val`` is given the validation error of every prefix is
        returned as well.

    Returns
    -------
    fits : PrefixFits
        Weights, training error, degrees of freedom and validation error per prefix.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.linspace(-1, 1, 9)[:, None]
    >>> fits = prefix_fits(x**2, 1 + 2 * x**2)
    >>> fits.weights[1].ravel().round(6).tolist(), fits.dof.tolist()
    ([1.0, 2.0], [1.0, 2.0])
    """
    n_samples, n_selected = Phi.shape
    n_outputs = Y.shape[1]
    sw = np.ones(n_samples) if sample_weight is None else np.asarray(sample_weight, float)
    root_w = np.sqrt(sw)[:, None]
    n_tail = 0 if T is None else T.shape[1]
    n_fixed = 1 + n_tail
    n_params = n_fixed + n_selected
    n_tail_rows = n_tail if tail_alpha > 0 else 0
    augmented = np.zeros((n_samples + n_tail_rows + n_selected, n_params + n_outputs))
    if np.all(sw == 1.0):
        # Unit weights: the data rows of the augmented system are the regressors themselves.
        A = augmented[:n_samples, :n_params]
        A[:, 0] = 1.0
        if n_tail:
            A[:, 1:n_fixed] = T
        A[:, n_fixed:] = Phi
        augmented[:n_samples, n_params:] = Y
    else:
        A = _regressors(T, Phi)
        augmented[:n_samples, :n_params] = A * root_w
        augmented[:n_samples, n_params:] = Y * root_w
    if n_tail_rows:
        augmented[n_samples : n_samples + n_tail, 1:n_fixed] = np.sqrt(tail_alpha) * np.eye(n_tail)
    if alpha > 0 and n_selected:
        augmented[n_samples + n_tail_rows :, n_fixed:n_params] = np.sqrt(alpha) * np.eye(
            n_selected
        )
    n_pen = n_tail_rows + (n_selected if alpha > 0 else 0)
    R = np.linalg.qr(augmented, mode="r")
    # (With fewer rows than columns the factor is not square: the general path.)
    fast = R.shape[0] >= n_params and _well_conditioned(R[:n_params, :n_params])
    if fast:
        # Hat-matrix trace: the squared norms of Q's data rows. Q's columns are unit
        # vectors and its ridge rows are penalty @ R⁻¹ (tiny), so no Q is formed.
        pen_q = scipy.linalg.solve_triangular(
            R[:n_params, :n_params],
            augmented[n_samples : n_samples + n_pen, :n_params].T,
            trans="T",
            check_finite=False,
        )
        dof_columns = 1.0 - np.square(pen_q).sum(axis=1)
    else:
        Q, R = np.linalg.qr(augmented)
        # A column with a negligible pivot (a constant feature in the tail) spans nothing
        # and adds no degree of freedom.
        pivots = np.abs(np.diag(R)[:n_params])
        live = pivots > 1e-10 * max(pivots.max(initial=0.0), 1e-300)
        dof_columns = np.where(live, np.square(Q[:n_samples, :n_params]).sum(axis=0), 0.0)
    total_w = sw.sum()
    n_prefixes = n_selected + 1
    # Every prefix's weights, zero-padded to all columns, side by side: the residuals of all
    # prefixes come out of one matrix product.
    stacked = np.zeros((n_params, n_prefixes, n_outputs))
    if fast:
        # R⁻¹ is upper triangular, so its leading blocks are the inverses of R's: one
        # inverse and one product give every prefix, W_p = R⁻¹ [b_:p; 0].
        R_inv = scipy.linalg.solve_triangular(
            R[:n_params, :n_params], np.eye(n_params), check_finite=False
        )
        for k in range(n_prefixes):
            stacked[: n_fixed + k, k] = R[: n_fixed + k, n_params:]
        stacked = (R_inv @ stacked.reshape(n_params, -1)).reshape(stacked.shape)
    else:
        for k in range(n_prefixes):
            p = n_fixed + k
            stacked[:p, k] = guarded_lstsq(R[:p, :p], R[:p, n_params:])
    # The weights handed on (only the chosen prefix's are ever read) are the SVD-based
    # solve's, as they always were; the solves above only score the prefixes.
    weights = _PrefixWeights(R, n_fixed, n_params)
    stacked = stacked.reshape(n_params, n_prefixes * n_outputs)
    residual = (A @ stacked).reshape(n_samples, n_prefixes, n_outputs)
    np.subtract(Y[:, None, :], residual, out=residual)
    np.square(residual, out=residual)
    train_mse = (sw @ residual.reshape(n_samples, -1) / total_w).reshape(n_prefixes, n_outputs)
    dof = np.array([dof_columns[: n_fixed + k].sum() for k in range(n_prefixes)])
    val_mse = val_sq = None
    if Phi_val is not None:
        A_val = _regressors(T_val, Phi_val)
        n_val = A_val.shape[0]
        sw_val = (
            np.ones(n_val) if sample_weight_val is None else np.asarray(sample_weight_val, float)
        )
        squared = (A_val @ stacked).reshape(n_val, n_prefixes, n_outputs)
        np.subtract(Y_val[:, None, :], squared, out=squared)
        np.square(squared, out=squared)
        val_mse = (sw_val @ squared.reshape(n_val, -1) / sw_val.sum()).reshape(
            n_prefixes, n_outputs
        )
        val_sq = np.ascontiguousarray(squared.sum(axis=2).T)
    return PrefixFits(
        weights=weights, train_mse=train_mse, dof=dof, val_mse=val_mse, val_sq=val_sq
    )


class _PrefixWeights(Sequence):
    """``weights[k]``: the least-squares weights of prefix ``k``, solved when first read."""

    def __init__(self, R, n_fixed, n_params):
        self._R, self._n_fixed, self._n_params = R, n_fixed, n_params
        self._solved = {}

    def __len__(self):
        return self._n_params - self._n_fixed + 1

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        k = range(len(self))[k]  # negative indices; IndexError past the end
        if k not in self._solved:
            p = self._n_fixed + k
            self._solved[k] = guarded_lstsq(self._R[:p, :p], self._R[:p, self._n_params :])
        return self._solved[k]


def _well_conditioned(R, max_condition=1e8):
    """Whether the triangular ``R`` (and so every leading block) is far from rank deficiency.

    A leading block ``R[:p, :p]`` spans the first ``p`` columns of ``R``, so its condition
    number is at most ``R``'s: below ``max_condition`` (far above ``guarded_lstsq``'s cutoff
    of 1e12) every prefix has full rank and a triangular solve is its least-squares solution.
    """
    if not np.all(np.isfinite(R)):
        return False
    singular = np.linalg.svd(R, compute_uv=False)
    return bool(singular.size and singular[-1] > singular[0] / max_condition)


def path_criterion(fits, criterion, n_samples):
    """Value of a model-choice criterion for every prefix of a path (lower is better).

    Parameters
    ----------
    fits : PrefixFits
        Output of :func:`prefix_fits`; ``val_mse`` is needed for ``"holdout"``.
    criterion : {"holdout", "gcv", "bic", "aicc"}
        ``"holdout"``: validation mean squared error (averaged over outputs);
        ``"gcv"``: training MSE / (1 - dof/n)²; ``"bic"``: n Σ log MSE + n_outputs dof log n;
        ``"aicc"``: n Σ log MSE + n_outputs (2 dof + 2 dof (dof + 1) / (n - dof - 1)).
    n_samples : float
        Sample size of the training rows (the sum of their weights).

    Returns
    -------
    values : ndarray of shape (n_prefixes,)
        Criterion per prefix; ``inf`` where it is undefined (too many degrees of freedom).

    Examples
    --------
    >>> import numpy as np
    >>> fits = PrefixFits([], np.array([[1.0], [0.5]]), np.array([1.0, 5.0]), None)
    >>> path_criterion(fits, "gcv", 10).round(4).tolist()
    [1.2346, 2.0]
    """
    mse = fits.train_mse
    n_outputs = mse.shape[1]
    dof = fits.dof
    if criterion == "holdout":
        return fits.val_mse.mean(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        if criterion == "gcv":
            values = mse.mean(axis=1) / np.square(1.0 - dof / n_samples)
            values[dof >= n_samples] = np.inf
            return values
        # A perfect fit would give log(0): floor the error far below any real residual.
        floor = 1e-12 * np.maximum(mse[0], 1e-300)
        log_mse = np.log(np.maximum(mse, floor)).sum(axis=1)
        if criterion == "bic":
            return n_samples * log_mse + n_outputs * dof * np.log(n_samples)
        if criterion == "aicc":
            spare = n_samples - dof - 1.0
            penalty = 2.0 * dof + 2.0 * dof * (dof + 1.0) / spare
            values = n_samples * log_mse + n_outputs * penalty
            values[spare <= 0] = np.inf
            return values
    raise ValueError(f"criterion must be one of {CRITERIA}, got {criterion!r}.")


def candidate_pool(
    Z, *, sample_weight=None, max_candidates=None, method="kmeans++", random_state=None
):
    """Candidate centres: the distinct rows of ``Z``, or a pool of at most ``max_candidates``.

    Rows with zero weight are never candidates; duplicate rows count once (their columns
    would be identical). When more distinct rows remain than ``max_candidates``, the pool
    is drawn by weighted k-means++ seeding (spread over the data, edges included) or
    uniformly at random (``method="random"``), by ``random_state``.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs.
    sample_weight : ndarray of shape (n_samples,), default=None
        Non-negative weights.
    max_candidates : int, default=None
        Largest pool; ``None`` keeps every distinct row.
    method : {"kmeans++", "random"}, default="kmeans++"
        How the pool is drawn when it must be thinned.
    random_state : int, RandomState instance or None, default=None
        Seed of the draw.

    Returns
    -------
    candidates : ndarray of shape (n_candidates, n_features)
        Distinct rows of ``Z``, in a deterministic order.

    Examples
    --------
    >>> import numpy as np
    >>> candidate_pool(np.array([[1.0], [0.0], [1.0]])).ravel().tolist()
    [0.0, 1.0]
    """
    if sample_weight is None:
        sample_weight = np.ones(Z.shape[0])
    positive = np.asarray(sample_weight) > 0
    unique, inverse = np.unique(Z[positive], axis=0, return_inverse=True)
    if max_candidates is None or unique.shape[0] <= max_candidates:
        return unique
    # Duplicates pool their weight, so a repeated row weighs as much as its weight says.
    pooled = np.bincount(inverse.ravel(), weights=sample_weight[positive])
    random_state = check_random_state(random_state)
    if method == "random":
        index = random_state.choice(
            unique.shape[0], size=max_candidates, replace=False, p=pooled / pooled.sum()
        )
        return unique[np.sort(index)]
    _, index = kmeans_plusplus(
        unique, max_candidates, sample_weight=pooled, random_state=random_state
    )
    return unique[np.sort(index)]


def median_nn_distance(candidates):
    """Median distance from each candidate to its nearest other candidate.

    Parameters
    ----------
    candidates : ndarray of shape (n_candidates, n_features)
        Distinct points.

    Returns
    -------
    distance : float
        The median nearest-neighbour distance, or 1.0 with fewer than two candidates.

    Examples
    --------
    >>> import numpy as np
    >>> median_nn_distance(np.array([[0.0], [1.0], [3.0]]))
    1.0
    """
    if candidates.shape[0] < 2:
        return 1.0
    distances, _ = cKDTree(candidates).query(candidates, k=2)
    median = float(np.median(distances[:, 1]))
    return median if median > 0 else 1.0


# Widths added above the multiples at most (each one more selection path to run), and the
# candidates the data's radius is measured on at most (their pairwise distances are held).
_MAX_EXTRA_WIDTHS = 6
_RADIUS_SAMPLE = 1000


def width_grid(candidates, multiples):
    """Shared widths to try: ``multiples`` of the median nearest-neighbour distance, then
    doublings until the widest reaches the data's radius.

    The nearest-neighbour distance is the local spacing of the candidates. When the rows
    come in clusters (a temperature held while the gyro is read, a quantised sensor at fast
    sampling) it is the spacing *within* a cluster, and every width on its multiples is
    narrower than the gaps between clusters: each unit could only fit one cluster. Widths
    are therefore doubled from the largest multiple until one reaches half the median
    distance between candidates (the radius of the data); on rows spread evenly the
    multiples reach it already and nothing is added. At most six widths are added (spread
    geometrically up to the radius when six doublings do not reach it, as with nearly
    duplicated rows), so the selection's cost stays bounded.

    Parameters
    ----------
    candidates : ndarray of shape (n_candidates, n_features)
        Distinct candidate centres.
    multiples : sequence of float
        Increasing multiples of the median nearest-neighbour distance.

    Returns
    -------
    widths : ndarray of shape (n_widths,)
        Increasing widths.

    Examples
    --------
    >>> import numpy as np
    >>> even = np.linspace(0.0, 1.0, 11)[:, None]
    >>> width_grid(even, (1.0, 2.0, 4.0)).round(3).tolist()
    [0.1, 0.2, 0.4]
    >>> clusters = np.concatenate([c + 0.001 * np.arange(5) for c in (0.0, 0.5, 1.0)])[:, None]
    >>> width_grid(clusters, (1.0, 2.0, 4.0)).round(3).tolist()
    [0.001, 0.002, 0.004, 0.008, 0.016, 0.032, 0.064, 0.128, 0.256]
    """
    widths = median_nn_distance(candidates) * np.asarray(multiples, dtype=float)
    n_candidates = candidates.shape[0]
    if n_candidates < 2:
        return widths
    if n_candidates > _RADIUS_SAMPLE:  # the median of a spread-out subset: memory bounded
        candidates = candidates[np.linspace(0, n_candidates - 1, _RADIUS_SAMPLE).astype(int)]
    radius = 0.5 * float(np.median(pdist(candidates)))
    if not widths[-1] < radius:
        return widths
    n_extra = int(np.ceil(np.log2(radius / widths[-1])))
    if n_extra <= _MAX_EXTRA_WIDTHS:
        extra = widths[-1] * 2.0 ** np.arange(1, n_extra + 1)
    else:  # near-duplicate rows: as many widths, spread geometrically up to the radius
        extra = np.geomspace(widths[-1], radius, _MAX_EXTRA_WIDTHS + 1)[1:]
    return np.concatenate([widths, extra])


def contiguous_validation_mask(n_samples, fraction, n_blocks):
    """Boolean mask of ``n_blocks`` contiguous blocks holding ``fraction`` of the rows.

    The rows are cut into ``n_blocks`` equal segments and the middle of each one is held
    out, so every block has training rows on both sides (the criterion measures
    interpolation across a gap of the series, not extrapolation past its end).

    Parameters
    ----------
    n_samples : int
        Number of rows.
    fraction : float
        Fraction of rows held out, in (0, 1).
    n_blocks : int
        Number of blocks.

    Returns
    -------
    mask : ndarray of shape (n_samples,), dtype=bool
        True on held-out rows.

    Examples
    --------
    >>> contiguous_validation_mask(10, 0.2, 1).nonzero()[0].tolist()
    [4, 5]
    """
    mask = np.zeros(n_samples, dtype=bool)
    n_held = round(fraction * n_samples)
    edges = np.linspace(0, n_samples, n_blocks + 1)
    sizes = np.diff(np.round(np.linspace(0, n_held, n_blocks + 1)).astype(int))
    for left, right, size in zip(edges[:-1], edges[1:], sizes, strict=True):
        start = round((left + right - size) / 2)
        mask[start : start + size] = True
    return mask
