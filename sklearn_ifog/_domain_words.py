"""How the package says, in words, what its models did outside their calibration domain.

Shared by the report (:func:`sklearn_ifog.report.compensation_report`) and the command
line (``sklearn-ifog compensate`` and ``report``), so that both tell a gyro engineer the
same thing in the same words.
"""

import numpy as np

__all__ = ["number_text", "policy_actions"]


def policy_actions(status):
    """What the ``outside`` policies did to the rows outside, one clause per policy."""
    outside = status.outside
    clauses = []
    pairs = np.column_stack([status.policy[outside], status.fallback[outside]]).astype(str)
    for policy, fallback in np.unique(pairs, axis=0).tolist():
        rows = outside & (status.policy == policy) & (status.fallback == fallback)
        total = int(rows.sum())
        kept = int((rows & ~status.adjusted).sum())
        if policy == "none":
            clauses.append(
                "the model extrapolated freely, nothing bounding its error (outside='none')"
            )
            continue
        if policy == "clip":
            clause = (
                "the model was held at the domain's edge, its prediction at the nearest "
                "calibrated point (outside='clip')"
            )
        else:
            towards = {
                "plane": "a line in T and the rate dT fitted on the calibration runs",
                "line": "a line in T fitted on the calibration",
                "constant": (
                    "the calibration's mean drift (a constant: no slope in T extrapolated better)"
                ),
            }[fallback]
            if kept == total:
                clauses.append(
                    f"each of these {total} rows kept the model's own prediction: "
                    f"outside='blend' gives way to its fallback, {towards}, only farther "
                    "from the calibrated combinations than these rows lie"
                )
                continue
            clause = (
                f"the model fell back towards {towards}, the farther out the more "
                "(outside='blend')"
            )
        if kept:
            clause += (
                f", for {total - kept} of these {total} rows; the other {kept} kept the "
                "model's own prediction"
            )
        clauses.append(clause)
    return clauses


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
