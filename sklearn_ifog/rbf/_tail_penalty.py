"""The shape of the tail penalty: a ridge, or one that follows the features' spread.

The default features of a thermal test are nearly collinear (the temperature, its lags and
their products move together): over a calibration, their thinnest principal direction can
hold a ten-thousandth of the widest one's spread. A plain ridge on the linear tail's weights
barely touches such a direction, so its weight is set by noise, and a small change of the
features along it (a lag that differs by 0.14 degC between two subsets of one recording)
moves the prediction far. The ``"spread"`` penalty is a generalised ridge that charges each
principal direction ``k`` of the tail features in inverse proportion to its variance
``lambda_k``::

    tail_alpha * w' V diag(1 / lambda) V' w

so a direction is kept in proportion ``lambda_k**2 / (lambda_k**2 + tail_alpha)``: the
well-spread directions as by least squares, the thin ones shrunk to nothing.

The numerics solve it as a plain ridge on reparametrised tail columns ``T M`` with
``M = V diag(sqrt(lambda))`` (``||w'||**2`` on the new weights ``w'`` is the penalty above
for ``w = M w'``), so every solver that knows a ridge on the tail knows this one; the tail
weights are mapped back with ``M`` and the fitted network is the same as ever. The
reparametrised columns themselves are the basis's
(:func:`sklearn_ifog.rbf._basis.transformed`), since its output-weight solve builds them.
"""

import numpy as np

#: The values of ``RBFNetRegressor(tail_penalty=...)``.
TAIL_PENALTIES = ("spread", "ridge")

# A direction's variance is floored at this fraction of the largest: an exactly constant
# combination of the tail features (the intercept spans it) then gets a finite, vast penalty.
SPREAD_FLOOR = 1e-12


def tail_transform(T, sample_weight, penalty):
    """The reparametrisation ``M`` under which a ridge is the tail penalty ``penalty``.

    Parameters
    ----------
    T : ndarray of shape (n_samples, n_tail)
        Tail features of the rows the selection runs on.
    sample_weight : ndarray of shape (n_samples,)
        Their non-negative weights (positive sum).
    penalty : {"spread", "ridge"}
        The penalty's shape (module docstring).

    Returns
    -------
    M : ndarray of shape (n_tail, n_tail) or None
        ``V diag(sqrt(lambda))`` from the weighted covariance of ``T`` for ``"spread"``;
        None (the identity) for ``"ridge"`` or without a tail.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(-1, 1, 50)
    >>> T = np.column_stack([t, t + 1e-3 * np.sin(7 * t)])
    >>> M = tail_transform(T, np.ones(50), "spread")
    >>> lam = np.linalg.eigvalsh(np.cov(T.T, bias=True))
    >>> bool(np.allclose(np.sort(np.square(M).sum(axis=0)), np.sort(lam)))
    True
    >>> tail_transform(T, np.ones(50), "ridge") is None
    True
    """
    if penalty == "ridge" or T is None or T.shape[1] == 0 or not np.sum(sample_weight) > 0:
        # No spread to measure (no tail, or rows without weight): the plain ridge.
        return None
    covariance = np.atleast_2d(np.cov(T, rowvar=False, aweights=sample_weight, bias=True))
    spread, directions = np.linalg.eigh(covariance)
    floor = SPREAD_FLOOR * max(float(spread.max()), np.finfo(float).tiny)
    return directions * np.sqrt(np.maximum(spread, floor))
