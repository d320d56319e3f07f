"""The report's text: how the package says, in words, what its models did outside their
calibration domain.

Shared by the report (:func:`sklearn_ifog.report.compensation_report`) and the command
line (``sklearn-ifog compensate`` and ``report``), so that both tell a gyro engineer the
same thing in the same words.
"""

import numpy as np

from sklearn_ifog._tuning import ROUNDOFF_SHARE
from sklearn_ifog.policy import policy_for

__all__ = ["number_text", "policy_actions"]


def policy_actions(status):
    """What the policies did to the rows outside, one clause per policy and fallback (the
    words of each policy object: :meth:`~sklearn_ifog.policy.UncalibratedPolicy.describe`)."""
    outside = status.outside
    clauses = []
    pairs = np.column_stack([status.policy[outside], status.fallback[outside]]).astype(str)
    for policy, fallback in np.unique(pairs, axis=0).tolist():
        rows = outside & (status.policy == policy) & (status.fallback == fallback)
        total = int(rows.sum())
        kept = int((rows & ~status.adjusted).sum())
        clauses.append(policy_for(policy).describe(total, kept, fallback))
    return clauses


def rate_beyond_text(below, above, low, high):
    """:func:`beyond_text` for the rate dT, without what is round-off.

    ``below`` and ``above`` count only beyond ``sklearn_ifog._tuning.ROUNDOFF_SHARE``
    times the calibrated range ``high - low`` (the domain's rule of what is round-off).

    Parameters
    ----------
    below, above : float
        How far the rate went below ``low`` and above ``high`` (0 or NaN: not at all).
    low, high : float
        The calibrated rate range (the slowest and the fastest calibrated rate), in dT's
        unit.

    Returns
    -------
    text : str
        As :func:`beyond_text` with "slowest" and "fastest"; "" when neither excess is
        beyond round-off.

    Examples
    --------
    >>> rate_beyond_text(1.47e-14, 0.0, 0.0, 0.5)
    ''
    >>> rate_beyond_text(0.02, 0.0, 0.0, 0.5)
    '0.02 below the slowest'
    """
    tolerance = ROUNDOFF_SHARE * abs(high - low)
    below = below if below > tolerance else 0.0
    above = above if above > tolerance else 0.0
    return beyond_text(below, above, "slowest", "fastest")


def number_text(value):
    """Three significant digits, without an exponent below 100 000."""
    return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"


def beyond_text(below, above, low, high, unit=""):
    """How far a reading went past a calibrated range, in words.

    ``"<below><unit> below the <low>"`` and/or ``"<above><unit> above the <high>"`` joined
    by "and"; "" when neither is positive (NaN, a model without the feature, compares
    False).

    Examples
    --------
    >>> beyond_text(2.5, 0.0, "coldest", "warmest", " degC")
    '2.5 degC below the coldest'
    >>> beyond_text(0.12, 0.3, "slowest", "fastest")
    '0.12 below the slowest and 0.3 above the fastest'
    >>> beyond_text(float("nan"), 0.0, "slowest", "fastest")
    ''
    """
    parts = []
    if below > 0:
        parts.append(f"{below:.3g}{unit} below the {low}")
    if above > 0:
        parts.append(f"{above:.3g}{unit} above the {high}")
    return " and ".join(parts)
