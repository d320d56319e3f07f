"""Numerics of partial pooling: a unit's output layer shrunk towards the lot's.

Plain numpy functions, no estimator: the ridge solve towards prior weights for a grid of
strengths, the choice of the strength by empirical Bayes (the marginal likelihood of the
unit's rows, :func:`log_evidence`), and held-out errors over a unit's runs (or contiguous
blocks of a single run), with which the estimator compares the shrunk layers with the
unit's own model.

The problem, for one unit with output-layer design ``Phi`` (intercept column included) and
targets ``Y``::

    W(lam) = argmin_W  ||Y - Phi W||² / n  +  lam Σ_j s_j² ||W_j - W_lot_j||²

``s_j`` is the root mean square of column ``j`` of the lot's design (1 for the intercept),
so the penalty is, column by column, the mean squared change of the prediction that moving
a weight away from the lot's causes: ``lam`` is free of units, of the number of rows and of
the scale of the columns. ``lam = 0`` is the unit's own least-squares weights on the lot's
basis, ``lam = inf`` the lot's weights.
"""

from itertools import pairwise

import numpy as np

__all__ = [
    "SHRINKAGE_GRID",
    "choose_shrinkage",
    "cv_folds",
    "design_scale",
    "fold_prior",
    "log_evidence",
    "lot_statistics",
    "pick_strength",
    "solve_shrunk",
]

# Candidate strengths: 0 (own weights), a log grid, inf (the lot's weights).
SHRINKAGE_GRID = np.concatenate([[0.0], np.logspace(-4.0, 2.0, 13), [np.inf]])

# Contiguous blocks a unit's single run is cut into to choose its strength.
SINGLE_RUN_BLOCKS = 4

# Damping (in the penalty's metric) of the lot's re-solve without a fold's rows.
LOT_DAMPING = 1e-4

# Relative jitter on the normal equations' diagonal, so that lam = 0 with collinear columns
# gives the minimum-change solution instead of failing.
_JITTER = 1e-10


def design_scale(Phi):
    """Root mean square of every column of ``Phi``, floored so no column scale is zero.

    Parameters
    ----------
    Phi : ndarray of shape (n_samples, n_columns)
        A design (e.g. the lot's output-layer design).

    Returns
    -------
    scale : ndarray of shape (n_columns,)
        ``sqrt(mean(Phi[:, j]²))``, at least 1e-12 times the largest.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._shrinkage import design_scale
    >>> design_scale(np.array([[1.0, 3.0], [1.0, -3.0]]))
    array([1., 3.])
    """
    scale = np.sqrt(np.mean(np.square(Phi), axis=0))
    floor = 1e-12 * max(float(scale.max(initial=0.0)), 1e-300)
    return np.maximum(scale, floor)


def solve_shrunk(Phi, Y, prior, scale, strengths):
    """Output weights shrunk towards ``prior``, one solution per strength.

    Parameters
    ----------
    Phi : ndarray of shape (n_samples, n_columns)
        The unit's output-layer design.
    Y : ndarray of shape (n_samples, n_outputs)
        Its targets.
    prior : ndarray of shape (n_columns, n_outputs)
        The lot's weights.
    scale : ndarray of shape (n_columns,)
        Column scales of the penalty (:func:`design_scale` of the lot's design).
    strengths : array-like of float
        Penalty strengths ``lam`` (0 and ``inf`` allowed).

    Returns
    -------
    weights : ndarray of shape (n_strengths, n_columns, n_outputs)
        The solutions.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._shrinkage import solve_shrunk
    >>> Phi = np.column_stack([np.ones(4), np.arange(4.0)])
    >>> Y = (1.0 + 2.0 * np.arange(4.0))[:, None]
    >>> W = solve_shrunk(Phi, Y, np.zeros((2, 1)), np.ones(2), [0.0, np.inf])
    >>> W[0].ravel().round(6), W[1].ravel()
    (array([1., 2.]), array([0., 0.]))
    """
    n_samples = Phi.shape[0]
    strengths = np.asarray(strengths, dtype=np.float64)
    residual = Y - Phi @ prior
    gram = Phi.T @ Phi / n_samples
    rhs = Phi.T @ residual / n_samples
    penalty = np.square(scale)
    jitter = _JITTER * max(float(np.trace(gram)), 1e-300) / max(gram.shape[0], 1)
    weights = np.empty((strengths.size, *prior.shape))
    for index, lam in enumerate(strengths):
        if np.isinf(lam) or n_samples == 0:
            weights[index] = prior
            continue
        system = gram + np.diag(lam * penalty + jitter)
        weights[index] = prior + np.linalg.solve(system, rhs)
    return weights


def log_evidence(Phi, Y, prior, scale, strengths):
    """Log marginal likelihood of a unit's targets for every strength (empirical Bayes).

    The ridge problem of :func:`solve_shrunk` is the posterior mode of the Gaussian model::

        Y[:, k] = Phi @ W[:, k] + noise,   noise ~ N(0, sigma_k² I)
        W[j, k] - prior[j, k] ~ N(0, sigma_k² / (n lam s_j²))

    so ``1 / (n lam s_j²)`` is the between-unit spread of weight ``j`` relative to the noise.
    Integrating the weights out, the targets' likelihood as a function of ``lam`` (with each
    ``sigma_k²`` at its maximum) measures how far the unit's rows say the unit lies from
    the lot; choosing ``lam`` by its maximum (type-II maximum likelihood) needs no
    held-out rows. ``lam = 0`` (an improper, flat prior) has likelihood ``-inf``.

    Parameters
    ----------
    Phi, Y, prior, scale, strengths
        As for :func:`solve_shrunk`.

    Returns
    -------
    log_evidence : ndarray of shape (n_strengths,)
        Summed over outputs, up to a constant that depends on neither ``lam`` nor ``sigma``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._shrinkage import log_evidence
    >>> rng = np.random.default_rng(0)
    >>> Phi = np.column_stack([np.ones(50), rng.normal(size=50)])
    >>> Y = Phi @ [[0.5], [2.0]] + rng.normal(0, 0.1, (50, 1))
    >>> strengths = [0.0, 1e-4, 1.0, np.inf]
    >>> same = log_evidence(Phi, Y, [[0.5], [2.0]], np.ones(2), strengths)
    >>> int(np.argmax(same))  # a unit the lot already knows: the lot's weights
    3
    >>> far = log_evidence(Phi, Y, [[-3.0], [0.0]], np.ones(2), strengths)
    >>> int(np.argmax(far))  # a unit far from the lot: nearly its own weights
    1
    """
    strengths = np.asarray(strengths, dtype=np.float64)
    prior = np.asarray(prior, dtype=np.float64)
    n_samples = Phi.shape[0]
    residual = Y - Phi @ prior
    if n_samples == 0:
        return np.zeros(strengths.size)
    U, singular, _ = np.linalg.svd(Phi / scale, full_matrices=False)
    projected = np.square(U.T @ residual)  # (rank, n_outputs)
    total = np.square(residual).sum(axis=0)  # (n_outputs,)
    # a residual the lot's basis spans exactly (no more rows than columns) would make the
    # likelihood unbounded at small strengths: floor the quadratic form
    floor = 1e-12 * np.maximum(total, 1e-300)
    result = np.empty(strengths.size)
    for index, lam in enumerate(strengths):
        if lam <= 0.0:
            result[index] = -np.inf
            continue
        gain = np.zeros_like(singular) if np.isinf(lam) else singular**2 / (n_samples * lam)
        quadratic = total - (projected * (gain / (1.0 + gain))[:, None]).sum(axis=0)
        quadratic = np.maximum(quadratic, floor)
        result[index] = -0.5 * float(
            np.sum(n_samples * np.log(quadratic / n_samples)) + Y.shape[1] * np.sum(np.log1p(gain))
        )
    return result


def cv_folds(runs, n_blocks=SINGLE_RUN_BLOCKS):
    """Held-out row sets to choose a unit's strength: one per run, or blocks of one run.

    Parameters
    ----------
    runs : ndarray of shape (n_samples,)
        The run of each of the unit's rows.
    n_blocks : int, default=4
        With a single run, the number of contiguous blocks it is cut into (each held out in
        turn).

    Returns
    -------
    folds : list of ndarray of bool
        Test masks, one per fold.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._shrinkage import cv_folds
    >>> [mask.astype(int).tolist() for mask in cv_folds(np.array([0, 0, 1, 1]))]
    [[1, 1, 0, 0], [0, 0, 1, 1]]
    >>> [int(mask.sum()) for mask in cv_folds(np.zeros(10), n_blocks=4)]
    [2, 3, 3, 2]
    """
    labels = np.unique(runs)
    if labels.size >= 2:
        return [runs == label for label in labels]
    n_samples = runs.shape[0]
    edges = np.linspace(0, n_samples, min(n_blocks, n_samples) + 1).round().astype(int)
    positions = np.arange(n_samples)
    return [(positions >= low) & (positions < high) for low, high in pairwise(edges)]


def lot_statistics(Phi, Y, prior):
    """Sums the fold priors of :func:`choose_shrinkage` are re-solved from.

    Parameters
    ----------
    Phi : ndarray of shape (n_samples, n_columns)
        The lot's output-layer design (every unit's rows).
    Y : ndarray of shape (n_samples, n_outputs)
        The lot's targets.
    prior : ndarray of shape (n_columns, n_outputs)
        The lot model's weights.

    Returns
    -------
    statistics : tuple
        ``(Phi.T @ Phi, Phi.T @ (Y - Phi @ prior), n_samples)``.
    """
    return Phi.T @ Phi, Phi.T @ (Y - Phi @ prior), Phi.shape[0]


def _lot_correction(gram, rhs, n_samples, scale):
    """The least-squares change of the lot's weights on rows with these sums (lightly
    damped towards no change, in the metric of ``scale``)."""
    system = gram / n_samples + np.diag(LOT_DAMPING * np.square(scale))
    return np.linalg.solve(system, rhs / n_samples)


def fold_prior(prior, scale, lot, Phi_test, Y_test):
    """The lot's weights re-solved without a fold's held-out rows.

    The lot model was fitted on every row, the held-out ones included; choosing a unit's
    strength against those weights would favour them unduly. The prior of a fold is
    therefore ``prior`` plus the change a least-squares re-solve of the lot's output layer
    makes when the held-out rows are removed (the basis stays the lot's).

    Parameters
    ----------
    prior, scale
        As for :func:`solve_shrunk`.
    lot : tuple
        :func:`lot_statistics` of the lot.
    Phi_test, Y_test : ndarray
        The held-out rows' design and targets.

    Returns
    -------
    prior : ndarray of shape (n_columns, n_outputs)
        The fold's prior.
    """
    gram, rhs, n_samples = lot
    n_rest = n_samples - Phi_test.shape[0]
    if n_rest <= 0:
        return prior
    fold_gram = Phi_test.T @ Phi_test
    fold_rhs = Phi_test.T @ (Y_test - Phi_test @ prior)
    full = _lot_correction(gram, rhs, n_samples, scale)
    rest = _lot_correction(gram - fold_gram, rhs - fold_rhs, n_rest, scale)
    return prior + rest - full


def choose_shrinkage(Phi, Y, prior, scale, folds, strengths=SHRINKAGE_GRID, lot=None):
    """The strength with the lowest held-out squared error over ``folds``.

    Parameters
    ----------
    Phi, Y, prior, scale
        As for :func:`solve_shrunk`.
    folds : list of ndarray of bool
        Test masks (:func:`cv_folds`); each fold is fitted on the other rows.
    strengths : array-like of float, default=SHRINKAGE_GRID
        Candidates, increasing.
    lot : tuple, default=None
        :func:`lot_statistics` of the lot the prior was fitted on (these rows included):
        each fold's prior is then re-solved without its held-out rows
        (:func:`fold_prior`). None: ``prior`` is used as it is (it did not see them).

    Returns
    -------
    strength : float
        The chosen strength; on a tie, the largest (the most pooling).
    scores : ndarray of shape (n_strengths,)
        Held-out mean squared error of every candidate, over all held-out rows.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._shrinkage import choose_shrinkage, cv_folds
    >>> rng = np.random.default_rng(0)
    >>> Phi = np.column_stack([np.ones(40), rng.normal(size=40)])
    >>> Y = (Phi @ [0.5, 2.0])[:, None]
    >>> folds = cv_folds(np.repeat([0, 1], 20))
    >>> lot = np.array([[0.5], [2.0]])  # the lot already knows this unit
    >>> float(choose_shrinkage(Phi, Y, lot, np.ones(2), folds)[0])
    inf
    >>> far = np.array([[-3.0], [0.0]])  # a unit unlike the lot keeps its own weights
    >>> float(choose_shrinkage(Phi, Y + rng.normal(0, 0.01, (40, 1)), far, np.ones(2), folds)[0])
    0.0
    """
    strengths = np.asarray(strengths, dtype=np.float64)
    sse = np.zeros(strengths.size)
    n_held = 0
    for test in folds:
        train = ~test
        if not train.any() or not test.any():
            continue
        fold = prior if lot is None else fold_prior(prior, scale, lot, Phi[test], Y[test])
        weights = solve_shrunk(Phi[train], Y[train], fold, scale, strengths)
        predictions = np.einsum("ij,sjk->sik", Phi[test], weights)
        sse += np.square(Y[test][None] - predictions).sum(axis=(1, 2))
        n_held += int(test.sum()) * Y.shape[1]
    if n_held == 0:
        return float(strengths[-1]), np.full(strengths.size, np.nan)
    scores = sse / n_held
    return pick_strength(scores, strengths), scores


def pick_strength(scores, strengths=SHRINKAGE_GRID):
    """The strength of the lowest score, the largest on a tie (NaN scores: the largest).

    Parameters
    ----------
    scores : ndarray of shape (n_strengths,)
        Held-out errors, e.g. summed over several units, or negated log-evidences (any
        sign; ``inf`` never wins unless every score is).
    strengths : array-like of float, default=SHRINKAGE_GRID
        The candidates, increasing.

    Returns
    -------
    strength : float
        The chosen strength.

    Examples
    --------
    >>> from sklearn_ifog._shrinkage import pick_strength
    >>> pick_strength([3.0, 1.0, 1.0, 2.0], [0.0, 1.0, 2.0, 3.0])
    2.0
    """
    scores = np.asarray(scores, dtype=np.float64)
    strengths = np.asarray(strengths, dtype=np.float64)
    if not np.isfinite(scores).any():
        return float(strengths[-1])
    lowest = np.nanmin(scores)
    best = np.flatnonzero(scores <= lowest + 1e-12 * abs(lowest))[-1]
    return float(strengths[best])
