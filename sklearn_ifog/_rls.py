"""Recursive least squares with exponential forgetting: the online recalibration's numerics.

The model is linear in its weights, ``y = phi @ W`` (``phi``: one row of the output layer's
design, ``W``: shape ``(n_weights, n_outputs)``; every output shares the design, hence one
covariance ``P`` for all). A sample with a known target ``y`` updates, with the forgetting
factor ``lam`` in (0, 1]::

    e = y - phi @ W  # a-priori error, one per output
    s = lam + phi @ P @ phi  # >= lam > 0
    k = P @ phi / s  # gain
    W = W + outer(k, e)
    P = (P - outer(k, P @ phi)) / lam

**Square-root form.** ``P`` is carried as a factor ``S`` with ``P = S @ S.T`` and updated
by Potter's square-root step (the same recursion in exact arithmetic)::

    f = S.T @ phi
    s = lam + f @ f
    k = S @ f / s
    S = (S - outer(S @ f / (s + sqrt(lam * s)), f)) / sqrt(lam)

Why: the initial covariance is diffuse (1e4) along two directions and tight (1e-4) along
the others, a condition number of 1e8, and the covariance form subtracts numbers of size
1e4 to update entries of size 1e-4: it loses digits to rounding, enough that two correct
implementations summing in other orders (numpy's BLAS and the exported C) parted by more
than 1e-9 of the drift on the default two-sensor features. The factor's condition number
is the square root of ``P``'s, and the factor step has no such cancellation.
``tests/test_streaming_adapt.py::test_square_root_recursion_keeps_the_digits`` requires the
drift within 1e-12 of the same recursion in extended precision (and the covariance form in
double farther than 1e-11), and ``tests/test_export.py`` the C within 1e-11 of Python.
``P = S S'`` is symmetric and positive semi-definite by construction (the factor step
multiplies ``S`` by ``I - b f f'``, whose eigenvalues are 1 and ``sqrt(lam / s) > 0``).

Guards (each counted in the state): a factor that overflows (``f @ f`` or the updated factor
not finite) is reset to the initial factor ``S0``; and whenever the trace of ``P`` (the sum of
the squares of ``S``) exceeds that of ``P0 = S0 S0'`` (the "wind-up" of forgetting when the
samples do not excite every direction), ``S`` is scaled so that the trace is back to
``trace(P0)`` (a constant-trace bound), so ``P`` stays bounded by its start. Samples without
a target change nothing: forgetting acts only on the samples that inform.

The recursion is sequential by nature: one short numpy step per sample with a target (the
samples in between are predicted in one product).
"""

import math

import numpy as np

__all__ = [
    "covariance_trace",
    "initial_covariance",
    "initial_factor",
    "rls_sequence",
    "rls_step",
]

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


def initial_factor(weights, *, bias_index):
    """The recursion's starting factor ``S0``: the Cholesky factor of :func:`initial_covariance`.

    Parameters
    ----------
    weights : ndarray of shape (n_weights, n_outputs)
        The fitted output-layer weights (the intercept's row included).
    bias_index : int
        Row of ``weights`` holding the intercept.

    Returns
    -------
    S0 : ndarray of shape (n_weights, n_weights)
        Lower triangular, ``S0 @ S0.T`` equal to ``initial_covariance`` to rounding.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._rls import initial_factor
    >>> S0 = initial_factor(np.array([[2.0], [0.0], [5.0]]), bias_index=2)
    >>> np.diagonal(S0).tolist()
    [100.0000005, 0.01, 100.0000005]
    """
    return np.linalg.cholesky(initial_covariance(weights, bias_index=bias_index))


def covariance_trace(factor):
    """``trace(S @ S.T)``: the sum of the squares of the factor ``S``.

    Parameters
    ----------
    factor : ndarray of shape (n_weights, n_weights)

    Returns
    -------
    trace : float

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._rls import covariance_trace
    >>> covariance_trace(np.array([[1.0, 0.0], [2.0, 3.0]]))
    14.0
    """
    return float(np.vdot(factor, factor))


def rls_step(weights, factor, phi, target, forgetting, factor0, trace0):
    """One square-root RLS update (new arrays; the inputs are not modified).

    Parameters
    ----------
    weights : ndarray of shape (n_weights, n_outputs)
    factor : ndarray of shape (n_weights, n_weights)
        ``S``, the covariance's factor (``P = S @ S.T``).
    phi : ndarray of shape (n_weights,)
        The sample's design row.
    target : ndarray of shape (n_outputs,)
        Its known output.
    forgetting : float
        In (0, 1].
    factor0 : ndarray of shape (n_weights, n_weights)
        Initial factor, for a reset.
    trace0 : float
        ``trace(S0 @ S0.T)``: the bound on the trace (:func:`covariance_trace`).

    Returns
    -------
    weights, factor : ndarray
        After the update.
    resets : int
        The number of resets of the factor to ``factor0`` (0, 1 or 2: before the update
        when ``phi`` overflows against it, after when the update does).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._rls import rls_step
    >>> S0 = np.eye(1) * 1e3
    >>> W, S, resets = rls_step(np.zeros((1, 1)), S0, np.ones(1), np.array([3.0]), 1.0, S0, 1e6)
    >>> W.round(4), (S @ S.T).round(4), resets
    (array([[3.]]), array([[1.]]), 0)
    """
    # An overflow is caught below (a reset), not warned about.
    with np.errstate(over="ignore", invalid="ignore"):
        return _potter_step(weights, factor, phi, target, forgetting, factor0, trace0)


def _potter_step(weights, factor, phi, target, forgetting, factor0, trace0):
    """:func:`rls_step`'s arithmetic (floating-point warnings off)."""
    resets = 0
    f = factor.T @ phi
    gain2 = float(f @ f)
    if not math.isfinite(gain2):
        factor, resets = factor0, 1
        f = factor.T @ phi
        gain2 = float(f @ f)
    s = forgetting + gain2
    Pphi = factor @ f
    error = target - phi @ weights
    weights = weights + np.outer(Pphi / s, error)
    # Potter's step, with 1 / (s + sqrt(lam s)) for (1 - sqrt(lam / s)) / (f'f): no
    # cancellation when f'f is small.
    beta = 1.0 / (s + math.sqrt(forgetting * s))
    factor = (factor - np.outer(beta * Pphi, f)) / math.sqrt(forgetting)
    trace = covariance_trace(factor)
    if not math.isfinite(trace):
        factor, resets = factor0.copy(), resets + 1
    elif trace > trace0:
        factor = factor * math.sqrt(trace0 / trace)
    return weights, factor, resets


def rls_sequence(weights, factor, design, target, has_target, forgetting, factor0):
    """Predict and update over consecutive samples, in order.

    Each sample is predicted with the weights before its own update (the a-priori
    prediction: what a compensator outputs before the sample's reference is used).

    Parameters
    ----------
    weights : ndarray of shape (n_weights, n_outputs)
    factor : ndarray of shape (n_weights, n_weights)
        ``S`` (``P = S @ S.T``).
    design : ndarray of shape (n_samples, n_weights)
    target : ndarray of shape (n_samples, n_outputs)
        Known outputs (any value where ``has_target`` is False).
    has_target : ndarray of bool of shape (n_samples,)
    forgetting : float
    factor0 : ndarray of shape (n_weights, n_weights)
        Initial factor: the reset, and its trace the bound.

    Returns
    -------
    prediction : ndarray of shape (n_samples, n_outputs)
    weights, factor : ndarray
        After the last sample.
    resets : int
        Number of factor resets.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._rls import rls_sequence
    >>> S0 = np.eye(1) * 1e3
    >>> y, W, S, n = rls_sequence(
    ...     np.zeros((1, 1)),
    ...     S0,
    ...     np.ones((3, 1)),
    ...     np.array([[2.0], [0.0], [4.0]]),
    ...     np.array([True, False, True]),
    ...     1.0,
    ...     S0,
    ... )
    >>> y.ravel().round(4), W.ravel().round(4)
    (array([0., 2., 2.]), array([3.]))
    """
    n_samples = design.shape[0]
    prediction = np.empty((n_samples, weights.shape[1]))
    trace0 = covariance_trace(factor0)
    resets = 0
    start = 0
    for row in np.flatnonzero(has_target):
        if row > start:
            prediction[start:row] = design[start:row] @ weights
        phi = design[row]
        prediction[row] = phi @ weights
        weights, factor, reset = rls_step(
            weights, factor, phi, target[row], forgetting, factor0, trace0
        )
        resets += reset
        start = row + 1
    if start < n_samples:
        prediction[start:] = design[start:] @ weights
    return prediction, weights, factor, resets
