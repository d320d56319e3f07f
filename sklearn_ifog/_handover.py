"""Whether the model or its fallback should take a kind of novel row: held-out evidence.

A calibration with several runs can test its own model where it was not calibrated: fit on
some runs, predict the others, and look at the held-out rows that lie beyond the other
runs' domain. Evidence does not transfer between kinds of novelty (a network that
extrapolates a faster heating ramp well may be far off on a cooling one), so it is judged
per kind:

- ``"temperatures below"`` / ``"temperatures above"``: rows beyond the other runs'
  temperatures, on that side;
- ``"rates below"`` / ``"rates above"``: rows within the other runs' temperatures with a rate
  beyond their rates, on that side;
- ``"thermal state"``: rows within both, farther than the other runs' threshold from their
  box (a combination of calibrated temperatures and rates they did not show).

For each kind, the model keeps the rows when its held-out squared error beats the
fallback's by more than one standard error of the paired difference
(:func:`~sklearn_ifog._statistics.within_one_standard_error`, the network's own selection rule);
the domain then widens by what the evidence covered (:meth:`CalibrationDomain.extend
<sklearn_ifog.domain.CalibrationDomain.extend>`): its threshold to the largest held-out
thermal-state distance, its calibrated rates by the largest held-out rate excess on that
side, and the temperatures from which a row is held to the margin by the largest held-out
temperature excess on that side (a row beyond the calibrated temperatures stays flagged:
the firmware rule). Where the calibration shows no such rows, nothing changes: the fallback
takes them.
"""

from typing import NamedTuple

import numpy as np

from sklearn_ifog._statistics import within_one_standard_error

__all__ = ["KINDS", "Evidence", "collect", "decide"]

#: The kinds of novelty judged on held-out runs (the rate's two sides apart).
KINDS = (
    "temperatures below",
    "temperatures above",
    "rates below",
    "rates above",
    "thermal state",
)
# Fewest held-out rows of a kind that can decide for the model.
MIN_EVIDENCE_ROWS = 20


class Evidence(NamedTuple):
    """Held-out rows of one kind: the model's and the fallback's squared errors (one per
    row, averaged over the outputs) and how far each row lay beyond the other runs'
    domain (rate excess in the rate's units, or distance)."""

    model: np.ndarray
    fallback: np.ndarray
    extent: np.ndarray


def collect(features, y, model_prediction, fallback_prediction, domain):
    """The held-out rows of each kind, against the domain of the runs that did not see them.

    Parameters
    ----------
    features : ndarray of shape (n_samples, n_features)
        Thermal features of the held-out rows.
    y : ndarray of shape (n_samples, n_outputs)
        Their drift.
    model_prediction, fallback_prediction : ndarray of shape (n_samples, n_outputs)
        The fold's model (without its uncalibrated policy) and the fold's fallback.
    domain : CalibrationDomain
        The fold's domain (fitted on the other runs), with temperature and rate columns.

    Returns
    -------
    evidence : dict of str to Evidence
        One entry per kind in :data:`KINDS` (empty arrays where no row is of that kind).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.domain import CalibrationDomain
    >>> t = np.tile(np.linspace(10.0, 40.0, 50), 3)
    >>> rate = np.tile(np.linspace(0.1, 0.3, 50), 3)
    >>> domain = CalibrationDomain(temperature=0, rate=1).fit(
    ...     np.column_stack([t, rate]), groups=np.repeat([0, 1, 2], 50)
    ... )
    >>> rows = np.array([[25.0, 0.5], [25.0, 0.2]])  # a faster ramp, and a calibrated one
    >>> zeros = np.zeros((2, 1))
    >>> found = collect(rows, zeros, zeros + 1.0, zeros + 2.0, domain)
    >>> found["rates above"].extent.round(3).tolist(), found["rates above"].model.tolist()
    ([0.2], [1.0])
    """
    model = np.square(y - model_prediction).mean(axis=1)
    fallback = np.square(y - fallback_prediction).mean(axis=1)
    columns = domain.temperature_columns_
    values = features[:, columns]
    colder = np.max(domain.data_min_[columns] - values, axis=1)
    warmer = np.max(values - domain.data_max_[columns], axis=1)
    beyond_t = (colder > 0) | (warmer > 0)
    box = domain.box_
    rates = features[:, list(box.rate_columns)]
    below = np.max(box.rate_low - rates, axis=1)
    above = np.max(rates - box.rate_high, axis=1)
    distance = domain.distance(features)
    within = ~beyond_t & (below <= 0) & (above <= 0)
    masks = {
        "temperatures below": (colder > 0, colder),
        "temperatures above": (warmer > 0, warmer),
        "rates below": (~beyond_t & (below > 0), below),
        "rates above": (~beyond_t & (above > 0), above),
        "thermal state": (within & (distance > domain.threshold_), distance),
    }
    return {
        kind: Evidence(model[mask], fallback[mask], extent[mask])
        for kind, (mask, extent) in masks.items()
    }


def decide(evidence):
    """Which kinds the model keeps, and how far the evidence reached.

    Parameters
    ----------
    evidence : dict of str to list of Evidence
        Per kind, the held-out folds' :func:`collect` entries.

    Returns
    -------
    decision : dict of str to dict
        Per kind: ``rows``, ``model`` and ``fallback`` (their held-out mean squared errors,
        None without rows), ``keeps`` (the model keeps the kind: at least 20 rows and its
        error beats the fallback's by more than one standard error) and ``extent`` (the
        largest extent among the rows, None without rows).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> better = Evidence(rng.random(100), 2.0 + rng.random(100), np.linspace(0.0, 3.0, 100))
    >>> decide({"thermal state": [better]})["thermal state"]["keeps"]
    True
    >>> decide({"thermal state": [better._replace(model=better.fallback)]})["thermal state"][
    ...     "keeps"
    ... ]
    False
    """
    decision = {}
    for kind, parts in evidence.items():
        model = np.concatenate([part.model for part in parts]) if parts else np.empty(0)
        fallback = np.concatenate([part.fallback for part in parts]) if parts else np.empty(0)
        extent = np.concatenate([part.extent for part in parts]) if parts else np.empty(0)
        rows = int(model.size)
        keeps = False
        if rows >= MIN_EVIDENCE_ROWS and model.mean() < fallback.mean():
            keeps = not bool(within_one_standard_error(np.vstack([fallback, model]))[0])
        decision[kind] = {
            "rows": rows,
            "model": float(model.mean()) if rows else None,
            "fallback": float(fallback.mean()) if rows else None,
            "keeps": keeps,
            "extent": float(extent.max()) if rows else None,
        }
    return decision
