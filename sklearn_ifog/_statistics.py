"""Statistics shared by the package's model selections.

:func:`within_one_standard_error` is the "one-standard-error rule" the network's selection
(:mod:`sklearn_ifog.rbf`), the fallback's choice (:mod:`sklearn_ifog.fallback`) and the
held-out handover (:mod:`sklearn_ifog._handover`) all apply: a neutral home below each.
"""

import numpy as np

__all__ = ["within_one_standard_error"]


def within_one_standard_error(losses, sample_weight=None, *, n_chunks=20):
    """Which models' validation loss is within one standard error of the best one's.

    The standard error is that of the paired difference to the best model, estimated from
    the means over ``n_chunks`` consecutive chunks of the validation rows: rows of a
    contiguous block are autocorrelated, so a per-row estimate would be far too small.
    Choosing the simplest model inside this set (the "one-standard-error rule") keeps the
    criterion from chasing differences its own noise cannot resolve.

    Parameters
    ----------
    losses : ndarray of shape (n_models, n_rows)
        Squared validation error of every row under every model.
    sample_weight : ndarray of shape (n_rows,), default=None
        Weights of the validation rows.
    n_chunks : int, default=20
        Number of consecutive chunks the standard error is estimated from.

    Returns
    -------
    within : ndarray of shape (n_models,), dtype=bool
        True for models whose mean loss is at most the best one's plus one standard error.

    Examples
    --------
    >>> import numpy as np
    >>> noise = np.random.default_rng(0).normal(size=400) ** 2
    >>> wobble = np.repeat(0.001 + 0.01 * (-1.0) ** np.arange(20), 20)
    >>> losses = np.vstack([noise, noise + wobble, noise + 1.0])
    >>> within_one_standard_error(losses).tolist()
    [True, True, False]
    """
    n_rows = losses.shape[1]
    sw = np.ones(n_rows) if sample_weight is None else np.asarray(sample_weight, float)
    means = losses @ sw / sw.sum()
    best = int(np.argmin(means))
    n_chunks = max(2, min(n_chunks, n_rows))
    bounds = np.linspace(0, n_rows, n_chunks + 1).astype(int)
    chunk_w = np.add.reduceat(sw, bounds[:-1])
    keep = chunk_w > 0
    differences = np.add.reduceat((losses - losses[best]) * sw, bounds[:-1], axis=1)
    chunk_means = differences[:, keep] / chunk_w[keep]
    n_kept = int(keep.sum())
    if n_kept < 2:
        return means <= means[best]
    standard_error = chunk_means.std(axis=1, ddof=1) / np.sqrt(n_kept)
    return means <= means[best] + standard_error
