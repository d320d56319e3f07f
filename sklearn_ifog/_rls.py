"""Recursive least squares with exponential forgetting: the online recalibration's numerics.

The model is linear in its weights, ``y = phi @ W`` (``phi``: one row of the output layer's
design, ``W``: shape ``(n_weights, n_outputs)``; every output shares the design, hence one
covariance ``P`` for all). A sample with a known target ``y`` updates, with the forgetting
factor ``lam`` in (0, 1]::

    e = y - phi @ W                 # a-priori error, one per output
    s = lam + phi @ P @ phi         # > 0 when P is positive definite
    k = P @ phi / s                 # gain
    W = W + outer(k, e)
    P = (P - outer(k, P @ phi)) / lam, then symmetrised: P = (P + P.T) / 2

Guards (each counted in the state): a covariance that is not positive definite (``s <= lam``
or not finite, or a non-positive or non-finite diagonal after the update) is reset to the
initial covariance ``P0``; and whenever the trace of ``P`` exceeds that of ``P0`` (the
"wind-up" of forgetting when the samples do not excite every direction), ``P`` is scaled
back to the trace of ``P0`` (a constant-trace bound), so ``P`` stays bounded by its start.
Samples without a target change nothing: forgetting acts only on the samples that inform.

The recursion is sequential by nature: one short numpy step per sample with a target (the
samples in between are predicted in one product).
"""

import numpy as np

__all__ = ["initial_covariance", "rls_sequence", "rls_step"]

#: Prior variance (in units of the noise variance) of the free directions of the initial
#: covariance: diffuse, so the data alone set the bias and the thermal sensitivity.
FREE_VARIANCE = 1e4

#: Prior variance of the other output weights (same units): they move only under sustained,
#: informative data.
RESIDUAL_VARIANCE = 1e-4


def initial_covariance(weights, *, bias_index):
    """Initial RLS covariance: free offset and thermal sensitivity, the rest held.

    Ageing shifts a gyro's bias and scales its thermal sensitivity (the references in the
    user guide's deployment page), which in the output layer are two directions: the
    intercept's unit vector ``e`` and the fitted weights without the intercept, ``u_k`` (a
    common relative change of every thermal weight of output ``k``). The prior is diffuse on
    them and tight elsewhere::

        P0 = FREE_VARIANCE * (e e' + sum_k u_k u_k' / ||u_k||^2) + RESIDUAL_VARIANCE * I

    (``||u_k||``: normalises the direction; a weight vector of zeros adds nothing). Units:
    the noise variance of the references' residuals (RLS's ``P`` is a covariance divided by
    it), so the two free directions are learnt from the data as by least squares, and every
    other weight moves by at most about ``1e-2`` noise standard deviations per unit design
    unless many references ask for it.

    Parameters
    ----------
    weights : ndarray of shape (n_weights, n_outputs)
        The fitted output-layer weights (the intercept's row included).
    bias_index : int
        Row of ``weights`` holding the intercept (the design's constant column).

    Returns
    -------
    P0 : ndarray of shape (n_weights, n_weights)
        Symmetric positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._rls import initial_covariance
    >>> P0 = initial_covariance(np.array([[2.0], [0.0], [5.0]]), bias_index=2)
    >>> P0.round(4)
    array([[1.e+04, 0.e+00, 0.e+00],
           [0.e+00, 1.e-04, 0.e+00],
           [0.e+00, 0.e+00, 1.e+04]])
    """
    weights = np.asarray(weights, dtype=np.float64)
    n_weights = weights.shape[0]
    P0 = RESIDUAL_VARIANCE * np.eye(n_weights)
    P0[bias_index, bias_index] += FREE_VARIANCE
    thermal = weights.copy()
    thermal[bias_index] = 0.0
    for column in thermal.T:
        norm2 = float(column @ column)
        if norm2 > 0:
            P0 += FREE_VARIANCE * np.outer(column, column) / norm2
    return (P0 + P0.T) / 2


def rls_step(weights, covariance, phi, target, forgetting, P0, trace0):
    """One RLS update (new arrays; the inputs are not modified).

    Parameters
    ----------
    weights : ndarray of shape (n_weights, n_outputs)
    covariance : ndarray of shape (n_weights, n_weights)
    phi : ndarray of shape (n_weights,)
        The sample's design row.
    target : ndarray of shape (n_outputs,)
        Its known output.
    forgetting : float
        In (0, 1].
    P0 : ndarray of shape (n_weights, n_weights)
        Initial covariance, for a reset.
    trace0 : float
        ``trace(P0)``: the bound on the trace.

    Returns
    -------
    weights, covariance : ndarray
        After the update.
    resets : int
        1 if the covariance was reset (not positive definite), else 0.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._rls import rls_step
    >>> P0 = np.eye(1) * 1e6
    >>> W, P, resets = rls_step(np.zeros((1, 1)), P0, np.ones(1), np.array([3.0]), 1.0, P0, 1e6)
    >>> W.round(4), resets
    (array([[3.]]), 0)
    """
    resets = 0
    Pphi = covariance @ phi
    gain2 = float(phi @ Pphi)
    if not np.isfinite(gain2) or gain2 < 0:
        covariance, resets = P0, 1
        Pphi = covariance @ phi
        gain2 = float(phi @ Pphi)
    error = target - phi @ weights
    k = Pphi / (forgetting + gain2)
    weights = weights + np.outer(k, error)
    covariance = (covariance - np.outer(k, Pphi)) / forgetting
    covariance = 0.5 * (covariance + covariance.T)
    diagonal = np.diagonal(covariance)
    if not (np.all(diagonal > 0) and np.all(np.isfinite(diagonal))):
        covariance, resets = P0.copy(), 1
    else:
        trace = float(diagonal.sum())
        if trace > trace0:
            covariance = covariance * (trace0 / trace)
    return weights, covariance, resets


def rls_sequence(weights, covariance, design, target, has_target, forgetting, P0):
    """Predict and update over consecutive samples, in order.

    Each sample is predicted with the weights before its own update (the a-priori
    prediction: what a compensator outputs before the sample's reference is used).

    Parameters
    ----------
    weights : ndarray of shape (n_weights, n_outputs)
    covariance : ndarray of shape (n_weights, n_weights)
    design : ndarray of shape (n_samples, n_weights)
    target : ndarray of shape (n_samples, n_outputs)
        Known outputs (any value where ``has_target`` is False).
    has_target : ndarray of bool of shape (n_samples,)
    forgetting : float
    P0 : ndarray of shape (n_weights, n_weights)

    Returns
    -------
    prediction : ndarray of shape (n_samples, n_outputs)
    weights, covariance : ndarray
        After the last sample.
    resets : int
        Number of covariance resets.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._rls import rls_sequence
    >>> P0 = np.eye(1) * 1e6
    >>> y, W, P, n = rls_sequence(
    ...     np.zeros((1, 1)),
    ...     P0,
    ...     np.ones((3, 1)),
    ...     np.array([[2.0], [0.0], [4.0]]),
    ...     np.array([True, False, True]),
    ...     1.0,
    ...     P0,
    ... )
    >>> y.ravel().round(4), W.ravel().round(4)
    (array([0., 2., 2.]), array([3.]))
    """
    n_samples = design.shape[0]
    prediction = np.empty((n_samples, weights.shape[1]))
    trace0 = float(np.trace(P0))
    resets = 0
    start = 0
    for row in np.flatnonzero(has_target):
        if row > start:
            prediction[start:row] = design[start:row] @ weights
        phi = design[row]
        prediction[row] = phi @ weights
        weights, covariance, reset = rls_step(
            weights, covariance, phi, target[row], forgetting, P0, trace0
        )
        resets += reset
        start = row + 1
    if start < n_samples:
        prediction[start:] = design[start:] @ weights
    return prediction, weights, covariance, resets
