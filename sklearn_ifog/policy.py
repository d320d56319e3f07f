"""The policy: what a compensation model predicts for rows outside its calibration domain.

``"blend"`` mixes the model with its fallback (:mod:`sklearn_ifog.fallback`) by a weight
that grows from 0 at the domain's threshold to 1 (:func:`fallback_weight`); ``"clip"``
evaluates the model at the nearest point of the domain
(:meth:`~sklearn_ifog.domain.CalibrationDomain.project`); ``"none"`` keeps the model's own
extrapolation. :func:`apply_policy` is the one implementation, shared by
:class:`~sklearn_ifog.pipeline.CompensationPipeline` and the streaming compensator; the C
export writes the same arithmetic.
"""

import numpy as np

from sklearn_ifog.domain import require_box, threshold_of

__all__ = [
    "BLEND_WIDTH",
    "apply_policy",
    "fallback_weight",
]

#: Distance (in decorrelated standard deviations beyond the domain's margin) over which the
#: ``"blend"`` policy moves from the model to its fallback (a smoothstep: no step at the
#: edge, and none at the end).
BLEND_WIDTH = 1.0


def fallback_weight(distance, margin, width=BLEND_WIDTH):
    """Weight of the fallback under the ``"blend"`` policy: 0 inside, 1 far outside.

    A smoothstep ``s² (3 - 2 s)`` of ``s = (distance - margin) / width`` clipped to [0, 1]:
    continuous with a continuous slope, so the prediction has no step at the edge.

    Parameters
    ----------
    distance : array-like of shape (n_samples,)
        Distance to the box (:func:`~sklearn_ifog.domain.box_distance`).
    margin : float
        Distance at which the fallback starts to weigh in.
    width : float, default=BLEND_WIDTH
        Distance beyond ``margin`` at which the fallback has taken over.

    Returns
    -------
    weight : ndarray of shape (n_samples,)
        In [0, 1].

    Examples
    --------
    >>> fallback_weight([0.0, 1.5, 2.0, 2.5, 50.0], margin=1.5).tolist()
    [0.0, 0.0, 0.5, 1.0, 1.0]
    """
    s = np.clip((np.asarray(distance, dtype=np.float64) - margin) / width, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def apply_policy(policy, prediction, features, distance, outside, *, domain, fallback, evaluate):
    """The prediction of every row under an ``outside`` policy (rows inside unchanged).

    The one implementation of the policies, shared by
    :meth:`~sklearn_ifog.pipeline.CompensationPipeline.predict` and the streaming
    compensator (the C export writes the same arithmetic).

    Parameters
    ----------
    policy : {"blend", "clip", "none"}
        ``"blend"``: ``(1 - w) prediction + w fallback`` with ``w`` the
        :func:`fallback_weight` of the distance; ``"clip"``: the model at
        ``domain.project`` of the row; ``"none"``: the prediction as it is.
    prediction : ndarray of shape (n_samples, n_outputs)
        The model's prediction of the rows (not modified).
    features : ndarray of shape (n_samples, n_features)
        Their thermal features.
    distance, outside : ndarray of shape (n_samples,)
        Their distance to the box and their outside flags.
    domain : CalibrationDomain
        The fitted domain (its ``threshold_`` and
        :meth:`~sklearn_ifog.domain.CalibrationDomain.project`).
    fallback : Fallback
        The conservative model of ``"blend"``.
    evaluate : callable
        ``evaluate(rows) -> (n_rows, n_outputs)``, the model's prediction of feature rows
        (for ``"clip"``).

    Returns
    -------
    prediction : ndarray of shape (n_samples, n_outputs)
        ``prediction`` itself when no row changes, else a new array.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.domain import CalibrationDomain
    >>> from sklearn_ifog.fallback import Fallback
    >>> t = np.linspace(10.0, 40.0, 31)
    >>> domain = CalibrationDomain(margin=1.0, temperature=0).fit(t[:, None])
    >>> rows = np.array([[25.0], [41.0], [300.0]])  # inside, just beyond T, far
    >>> distance = domain.distance(rows)
    >>> outside = domain.predict(rows) == -1
    >>> fallback = Fallback(np.array([1.0]), np.array([0.0]), 0)
    >>> apply_policy(
    ...     "blend",
    ...     np.full((3, 1), 7.0),
    ...     rows,
    ...     distance,
    ...     outside,
    ...     domain=domain,
    ...     fallback=fallback,
    ...     evaluate=None,
    ... ).ravel().tolist()
    [7.0, 7.0, 1.0]
    """
    if policy == "none" or not outside.any():
        return prediction
    prediction = prediction.copy()
    if policy == "clip":
        require_box(domain, 'outside="clip"')
        prediction[outside] = evaluate(domain.project(features[outside]))
    else:
        weight = fallback_weight(distance[outside], threshold_of(domain))[:, None]
        blended = fallback.predict(features[outside])
        prediction[outside] = (1.0 - weight) * prediction[outside] + weight * blended
    return prediction
