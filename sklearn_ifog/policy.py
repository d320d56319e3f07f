"""The policy: what a compensation model predicts where it was not calibrated.

A :class:`~sklearn_ifog.pipeline.CompensationPipeline` names its policy with the parameter
``uncalibrated`` (``"blend"``, ``"clip"`` or ``"none"``); :func:`policy_for` resolves the name
to one object, an :class:`UncalibratedPolicy`, and this module is the one place that
compares the names. Each object applies itself to the rows outside the calibration domain
(:meth:`~UncalibratedPolicy.apply`, shared by the batch ``predict`` and the streaming
compensator), says which rows it changed and how much of each row its fallback takes,
describes itself in words for the report and the command line, and hands the C export its
fragment of C (the same arithmetic):

- :class:`BlendWithFallback` (``"blend"``, the default) mixes the model with its fallback
  (:mod:`sklearn_ifog.fallback`) by a weight that grows from 0 at the domain's threshold to
  1 (:func:`fallback_weight`);
- :class:`ClipToDomain` (``"clip"``) evaluates the model at the nearest point of the domain
  (:meth:`~sklearn_ifog.domain.CalibrationDomain.project`);
- :class:`KeepModel` (``"none"``) keeps the model's own extrapolation.
"""

import math
import numbers
from string import Template
from typing import NamedTuple

import numpy as np

from sklearn_ifog.domain import require_box, threshold_of

__all__ = [
    "POLICY_NAMES",
    "BlendWithFallback",
    "CFragment",
    "ClipToDomain",
    "KeepModel",
    "UncalibratedPolicy",
    "fallback_weight",
    "policy_for",
]

# Distance (in decorrelated standard deviations beyond the domain's threshold) over which
# BlendWithFallback moves from the model to its fallback (a smoothstep: no step at the edge,
# and none at the end); chosen on the tuning seeds of benchmarks/bench_extrapolation.py.
_BLEND_WIDTH = 1.0


def fallback_weight(distance, margin, width=_BLEND_WIDTH):
    """Weight of the fallback under the ``"blend"`` policy: 0 inside, 1 far outside.

    A smoothstep ``s² (3 - 2 s)`` of ``s = (distance - margin) / width`` clipped to [0, 1]:
    continuous with a continuous slope, so the prediction has no step at the edge.

    Parameters
    ----------
    distance : array-like of shape (n_samples,)
        Distance to the box (:func:`~sklearn_ifog.domain.box_distance`).
    margin : float
        Distance at which the fallback starts to weigh in.
    width : float, default=1.0
        Distance beyond ``margin`` at which the fallback has taken over
        (:class:`BlendWithFallback`'s ``width``).

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


class CFragment(NamedTuple):
    """A policy's part of the exported C (text with the writer's ``prefix`` substituted).

    Made by :meth:`UncalibratedPolicy.c_fragment` and read by the C export
    (:func:`sklearn_ifog.export.to_c`), which puts each part in its place around the
    calibration domain's own functions. An empty string: nothing there.

    Parameters
    ----------
    functions : str
        Static functions written before the domain's flag function (``{prefix}_domain``).
    flag_block : str
        Lines of ``{prefix}_domain`` for a row outside: where the network is evaluated.
    after_flag : str
        Static functions written after the flag function.
    guarded_call : str
        Lines of ``{prefix}_guarded`` after the network's drift: the change of a row
        outside.
    recalibrated_call : str
        Lines after the recalibrated output layer's drift (``adapt="output"``).
    description : str
        What the policy does, in words, for the header comment.

    Examples
    --------
    >>> fragment = policy_for("none").c_fragment(
    ...     "ifog", temperatures=True, fallback=None, fallback_words=""
    ... )
    >>> fragment.functions, fragment.flag_block
    ('', '')
    >>> print(fragment.description)
    the model's own
     * extrapolation (the sample is only flagged)
    """

    functions: str
    flag_block: str
    after_flag: str
    guarded_call: str
    recalibrated_call: str
    description: str


class UncalibratedPolicy:
    """What a compensation model predicts for the rows outside its calibration domain.

    The base class of the policies that :func:`policy_for` resolves the pipeline's
    ``uncalibrated`` parameter to. A policy leaves the rows inside the domain as they are.
    Its public methods are here; a policy fills in their private parts.

    Attributes
    ----------
    name : str
        The value of ``uncalibrated`` that names the policy.
    uses_fallback : bool
        Whether the policy hands rows to the pipeline's fallback (``fallback_``).
    moves_rows : bool
        Whether the policy evaluates the model at another row than the one outside (the
        streaming recalibration then evaluates its output layer there).
    keeps_model : bool
        Whether the policy leaves every prediction as the model made it.

    Examples
    --------
    >>> from sklearn_ifog.policy import policy_for
    >>> policy = policy_for("clip")
    >>> policy.name, policy.moves_rows, policy.uses_fallback, policy.parameter_text
    ('clip', True, False, "uncalibrated='clip'")
    """

    name = None
    uses_fallback = False
    moves_rows = False
    keeps_model = False

    def __repr__(self):
        return f"{type(self).__name__}()"

    @property
    def parameter_text(self):
        """The parameter that names the policy, as a user writes it."""
        return f"uncalibrated={self.name!r}"

    def apply(
        self, prediction, features, distance, outside, *, domain, fallback=None, evaluate=None
    ):
        """The prediction of every row under the policy (rows inside unchanged).

        The one implementation, shared by
        :meth:`~sklearn_ifog.pipeline.CompensationPipeline.predict` and the streaming
        compensator (the C export writes the same arithmetic).

        Parameters
        ----------
        prediction : ndarray of shape (n_samples, n_outputs)
            The model's prediction of the rows (not modified).
        features : ndarray of shape (n_samples, n_features)
            Their thermal features.
        distance, outside : ndarray of shape (n_samples,)
            Their distance to the box and their outside flags
            (:func:`~sklearn_ifog.domain.locate`).
        domain : CalibrationDomain
            The fitted domain (its ``threshold_`` and
            :meth:`~sklearn_ifog.domain.CalibrationDomain.project`).
        fallback : Fallback, default=None
            The conservative model (read when :attr:`uses_fallback`).
        evaluate : callable, default=None
            ``evaluate(rows) -> (n_rows, n_outputs)``, the model's prediction of feature
            rows (called when :attr:`moves_rows`).

        Returns
        -------
        prediction : ndarray of shape (n_samples, n_outputs)
            ``prediction`` itself when no row changes, else a new array.
        """
        if self.keeps_model or not outside.any():
            return prediction
        return self._apply(
            prediction.copy(), features, distance, outside, domain, fallback, evaluate
        )

    def _apply(self, prediction, features, distance, outside, domain, fallback, evaluate):
        """The policy's change of the rows outside, in ``prediction`` (a copy)."""
        raise NotImplementedError

    def fallback_share(self, distance, threshold):
        """The share of every row's prediction that the fallback takes, in [0, 1].

        Parameters
        ----------
        distance : array-like of shape (n_samples,)
            The rows' distance outside the domain's box.
        threshold : float
            The domain's ``threshold_``.

        Returns
        -------
        share : ndarray of shape (n_samples,)
            0 for a policy without a fallback.
        """
        if not self.uses_fallback:
            return np.zeros(np.shape(distance), dtype=np.float64)
        return self._share(distance, threshold)

    def changed_rows(self, features, where, domain):
        """Which rows the policy changes from the model's own prediction.

        Without predicting: from where the rows lie (the answer of predicting them with and
        without the policy, for a model whose prediction changes when its input or its
        output moves).

        Parameters
        ----------
        features : ndarray of shape (n_samples, n_features)
            The rows' thermal features.
        where : Where
            Their :func:`~sklearn_ifog.domain.locate` by ``domain``.
        domain : CalibrationDomain
            The fitted domain.

        Returns
        -------
        changed : ndarray of shape (n_samples,), dtype=bool
        """
        changed = np.array(where.outside, dtype=bool)
        if self.keeps_model or not changed.any():
            return np.zeros(changed.shape, dtype=bool)
        return self._changed(features, where, domain, changed)

    def describe(self, total, kept, fallback):
        """What the policy did to rows outside, in words (one clause, for the report).

        Parameters
        ----------
        total : int
            The rows outside that the clause is about.
        kept : int
            How many of them kept the model's own prediction.
        fallback : str
            The fallback's kind (:func:`~sklearn_ifog.fallback.fallback_name`).

        Returns
        -------
        clause : str
        """
        clause = self._action(total, kept, fallback)
        if self._counts_kept(total, kept):
            clause += (
                f", for {total - kept} of these {total} rows; the other {kept} kept the "
                "model's own prediction"
            )
        return clause

    def _action(self, total, kept, fallback):
        """The clause of :meth:`describe`, before the count of the rows kept."""
        raise NotImplementedError

    def _counts_kept(self, total, kept):
        """Whether :meth:`describe` adds how many rows kept the model's prediction."""
        return kept > 0

    def c_fragment(self, prefix, *, temperatures, fallback, fallback_words):
        """The policy's C, for the C export.

        Parameters
        ----------
        prefix : str
            The prefix of the generated C names.
        temperatures : bool
            Whether the domain has temperature columns.
        fallback : callable
            ``fallback() -> (expression, reads_features)``: the C expression of the
            fallback's output ``k`` (called only when :attr:`uses_fallback`).
        fallback_words : str
            The fallback in words, for the header comment.

        Returns
        -------
        fragment : CFragment
        """
        names = {"prefix": prefix, "PREFIX": prefix.upper()}
        description = _C_DESCRIPTION[self.name].substitute(names, fallback=fallback_words)
        return self._c_fragment(names, temperatures, fallback)._replace(description=description)

    def _c_fragment(self, names, temperatures, fallback):
        """:meth:`c_fragment` without its description."""
        return CFragment("", "", "", "", "", "")


class KeepModel(UncalibratedPolicy):
    """``uncalibrated="none"``: the model's own extrapolation (rows are only flagged).

    Examples
    --------
    >>> import numpy as np
    >>> prediction = np.array([[1.0], [2.0]])
    >>> outside = np.array([False, True])
    >>> KeepModel().apply(prediction, None, None, outside, domain=None) is prediction
    True
    """

    name = "none"
    keeps_model = True

    def _counts_kept(self, total, kept):
        return False

    def _action(self, total, kept, fallback):
        return f"the model extrapolated freely, nothing bounding its error ({self.parameter_text})"


class ClipToDomain(UncalibratedPolicy):
    """``uncalibrated="clip"``: the model at the nearest point of the domain.

    The domain's :meth:`~sklearn_ifog.domain.CalibrationDomain.project`: the box widened by
    its threshold, every temperature clamped to its calibrated range (the firmware
    convention of clamping T to [TMIN, TMAX]). A row outside by its rate alone is not moved.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.domain import CalibrationDomain, locate
    >>> t = np.linspace(10.0, 40.0, 31)
    >>> domain = CalibrationDomain(margin=1.0, temperature=0).fit(t[:, None])
    >>> rows = np.array([[25.0], [45.0]])
    >>> where = locate(domain, rows)
    >>> clipped = ClipToDomain().apply(
    ...     rows * 2.0,
    ...     rows,
    ...     where.distance,
    ...     where.outside,
    ...     domain=domain,
    ...     evaluate=lambda moved: moved * 2.0,
    ... )
    >>> clipped.ravel().tolist()  # 45 degC is evaluated at the warmest calibrated 40 degC
    [50.0, 80.0]
    >>> ClipToDomain().changed_rows(rows, where, domain).tolist()
    [False, True]
    """

    name = "clip"
    moves_rows = True

    def _apply(self, prediction, features, distance, outside, domain, fallback, evaluate):
        require_box(domain, "uncalibrated='clip'")
        prediction[outside] = evaluate(domain.project(features[outside]))
        return prediction

    def _changed(self, features, where, domain, changed):
        # The rows the projection moves (a row outside by its rate alone stays as it is).
        require_box(domain, "uncalibrated='clip'")
        rows = features[changed]
        changed[changed] = (domain.project(rows) != rows).any(axis=1)
        return changed

    def _action(self, total, kept, fallback):
        return (
            "the model was held at the domain's edge, its prediction at the nearest "
            f"calibrated point ({self.parameter_text})"
        )

    def _c_fragment(self, names, temperatures, fallback):
        functions = _C_PROJECT.substitute(names)
        if temperatures:
            functions += _C_PULL_BACK.substitute(names)
        rounds = _C_CLIP_ROUNDS if temperatures else _C_CLIP_ONCE
        return CFragment(functions, rounds.substitute(names), "", "", "", "")


class BlendWithFallback(UncalibratedPolicy):
    """``uncalibrated="blend"``: the model moves smoothly to its fallback farther out.

    ``(1 - w) * model + w * fallback`` with ``w`` the :func:`fallback_weight` of the row's
    distance: 0 at the domain's threshold, rising smoothly to 1 at the threshold plus
    ``width`` (no step anywhere). A row outside by a temperature alone, within the
    threshold, keeps the model's prediction.

    Parameters
    ----------
    width : float, default=None
        Distance beyond the threshold, in decorrelated standard deviations, at which the
        fallback has taken over; None: the package's width, 1.0 (chosen on the tuning
        seeds of ``benchmarks/bench_extrapolation.py``).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.domain import CalibrationDomain, locate
    >>> from sklearn_ifog.fallback import Fallback
    >>> t = np.linspace(10.0, 40.0, 31)
    >>> domain = CalibrationDomain(margin=1.0, temperature=0).fit(t[:, None])
    >>> rows = np.array([[25.0], [41.0], [300.0]])  # inside, just beyond T, far
    >>> where = locate(domain, rows)
    >>> fallback = Fallback(np.array([1.0]), np.array([0.0]), 0)
    >>> policy = BlendWithFallback()
    >>> policy.apply(
    ...     np.full((3, 1), 7.0),
    ...     rows,
    ...     where.distance,
    ...     where.outside,
    ...     domain=domain,
    ...     fallback=fallback,
    ... ).ravel().tolist()
    [7.0, 7.0, 1.0]
    >>> policy.fallback_share(where.distance, domain.threshold_).tolist()
    [0.0, 0.0, 1.0]
    >>> policy.changed_rows(rows, where, domain).tolist()
    [False, False, True]
    """

    name = "blend"
    uses_fallback = True

    def __init__(self, width=None):
        width = _BLEND_WIDTH if width is None else width
        if (
            isinstance(width, bool)
            or not isinstance(width, numbers.Real)
            or not (math.isfinite(width) and width > 0)
        ):
            raise ValueError(f"width must be a finite number > 0, got {width!r}.")
        self.width = float(width)

    def __repr__(self):
        return f"BlendWithFallback(width={self.width!r})"

    def _apply(self, prediction, features, distance, outside, domain, fallback, evaluate):
        weight = fallback_weight(distance[outside], threshold_of(domain), self.width)[:, None]
        blended = fallback.predict(features[outside])
        prediction[outside] = (1.0 - weight) * prediction[outside] + weight * blended
        return prediction

    def _share(self, distance, threshold):
        return fallback_weight(distance, threshold, self.width)

    def _changed(self, features, where, domain, changed):
        # The rows outside that the fallback takes a share of (0 within the threshold).
        return changed & (self._share(where.distance, threshold_of(domain)) > 0.0)

    def _action(self, total, kept, fallback):
        towards = _FALLBACK_WORDS[fallback]
        if kept == total:
            return (
                f"each of these {total} rows kept the model's own prediction: "
                f"{self.parameter_text} gives way to its fallback, {towards}, only farther "
                "from the calibrated combinations than these rows lie"
            )
        return (
            f"the model fell back towards {towards}, the farther out the more "
            f"({self.parameter_text})"
        )

    def _counts_kept(self, total, kept):
        return 0 < kept < total  # every row kept: the clause says so itself

    def _c_fragment(self, names, temperatures, fallback):
        expression, reads = fallback()
        unused = "" if reads else "    (void)features;\n"
        return CFragment(
            "",
            "",
            _C_BLEND.substitute(names, fallback=expression, unused=unused),
            _C_BLEND_CALL.substitute(names),
            _C_RECALIBRATED_BLEND.substitute(names),
            "",
        )


# The one place the names are compared: the value of ``uncalibrated`` -> the policy's class.
_POLICIES = {policy.name: policy for policy in (BlendWithFallback, ClipToDomain, KeepModel)}

#: The values of ``uncalibrated`` (:class:`~sklearn_ifog.pipeline.CompensationPipeline`).
POLICY_NAMES = tuple(_POLICIES)


def policy_for(uncalibrated):
    """The policy object that the parameter ``uncalibrated`` names.

    Parameters
    ----------
    uncalibrated : {"blend", "clip", "none"}
        A value of :class:`~sklearn_ifog.pipeline.CompensationPipeline`'s
        ``uncalibrated``.

    Returns
    -------
    policy : UncalibratedPolicy
        :class:`BlendWithFallback`, :class:`ClipToDomain` or :class:`KeepModel`.

    Raises
    ------
    TypeError
        If ``uncalibrated`` is not a string.
    ValueError
        If it names no policy.

    Examples
    --------
    >>> policy_for("blend")
    BlendWithFallback(width=1.0)
    >>> policy_for("hold")
    Traceback (most recent call last):
    ...
    ValueError: uncalibrated must be one of ['blend', 'clip', 'none'], got 'hold'.
    """
    if not isinstance(uncalibrated, str):
        raise TypeError(
            f"uncalibrated must be a str among {list(POLICY_NAMES)}, got "
            f"{type(uncalibrated).__name__} {uncalibrated!r}."
        )
    if uncalibrated not in _POLICIES:
        raise ValueError(
            f"uncalibrated must be one of {list(POLICY_NAMES)}, got {uncalibrated!r}."
        )
    return _POLICIES[uncalibrated]()


# What "blend" falls back towards, by the fallback's kind (fallback_name).
_FALLBACK_WORDS = {
    "plane": "a line in T and the rate dT fitted on the calibration runs",
    "line": "a line in T fitted on the calibration",
    "constant": "the calibration's mean drift (a constant: no slope in T extrapolated better)",
}


# --- the C of each policy (for sklearn_ifog.export; ``${prefix}`` / ``${PREFIX}``) ----------
# In double whatever the precision, as the domain's other functions
# (sklearn_ifog/export/_templates/_domain.py, which puts them together).

# "clip": a row farther than the margin moves from the box towards itself until its
# distance is the margin (its coordinates on the axes given, overwritten).
_C_PROJECT = Template(
    """
/* "clip": the point at the margin on the way from the box (inside) to the row (coordinates),
 * rotated back and unstandardised into projected. */
static void ${prefix}_project(
    double coordinates[${PREFIX}_N_FEATURES],
    const double inside[${PREFIX}_N_FEATURES], double distance,
    double projected[${PREFIX}_N_FEATURES])
{
    const double shrink = ${PREFIX}_MARGIN / distance;
    int j;
    int k;
    for (k = 0; k < ${PREFIX}_N_FEATURES; ++k) {
        coordinates[k] = inside[k] + (coordinates[k] - inside[k]) * shrink;
    }
    for (j = 0; j < ${PREFIX}_N_FEATURES; ++j) {
        double total = 0.0;
        for (k = 0; k < ${PREFIX}_N_FEATURES; ++k) {
            total += coordinates[k] * ${prefix}_domain_axes[k][j];
        }
        projected[j] = total * ${prefix}_domain_scale[j] + ${prefix}_domain_center[j];
    }
}
"""
)


# Without temperature columns, "clip" projects once, by the box's distance alone: a row
# outside by its rates only stays as it is (its box distance is within the margin, where
# margin / distance would move it outward).
_C_CLIP_ONCE = Template(
    """\
    if (box > ${PREFIX}_MARGIN) {
        ${prefix}_project(coordinates, inside, box, evaluated);
    }
"""
)


# With temperature columns, "clip" alternates the projection onto the box widened by the
# margin and the clamp of every temperature to its range: both sets are convex, so the row
# converges into their intersection, slowly where they meet at a narrow angle. The rounds
# end on the box; then a row with a temperature beyond its range moves along the segment to
# the box's centre (the calibration's mean: inside the box and every range) until every
# temperature is within it, as ``pull_back_to_ranges`` does, and the temperatures are
# clamped (a rounding error's change).
_C_PULL_BACK = Template(
    """
/* "clip": the row moved onto the box widened by the margin when it lies beyond it. */
static void ${prefix}_onto_box(double row[${PREFIX}_N_FEATURES])
{
    double coordinates[${PREFIX}_N_FEATURES];
    double inside[${PREFIX}_N_FEATURES];
    const double point = ${prefix}_box(row, coordinates, inside);
    if (point > ${PREFIX}_MARGIN) {
        ${prefix}_project(coordinates, inside, point, row);
    }
}

/* "clip": every temperature of the row clamped to its calibrated range. */
static void ${prefix}_clamp_temperatures(double row[${PREFIX}_N_FEATURES])
{
    int t;
    for (t = 0; t < ${PREFIX}_N_TEMPERATURES; ++t) {
        const int column = ${prefix}_temperature_columns[t];
        if (row[column] < ${prefix}_temperature_low[t]) {
            row[column] = ${prefix}_temperature_low[t];
        } else if (row[column] > ${prefix}_temperature_high[t]) {
            row[column] = ${prefix}_temperature_high[t];
        }
    }
}

/* "clip" with temperature columns: a row with a temperature beyond its calibrated range
 * moves towards the box's centre until every temperature lies within its range. */
static void ${prefix}_pull_back(double row[${PREFIX}_N_FEATURES])
{
    double share = 1.0;
    int j;
    int t;
    for (t = 0; t < ${PREFIX}_N_TEMPERATURES; ++t) {
        const int column = ${prefix}_temperature_columns[t];
        const double middle = ${prefix}_domain_center[column];
        double bound;
        double ratio;
        if (row[column] > ${prefix}_temperature_high[t]) {
            bound = ${prefix}_temperature_high[t];
        } else if (row[column] < ${prefix}_temperature_low[t]) {
            bound = ${prefix}_temperature_low[t];
        } else {
            continue;
        }
        ratio = (bound - middle) / (row[column] - middle);
        if (ratio < share) {
            share = ratio;
        }
    }
    if (share == 1.0) {
        return;
    }
    for (j = 0; j < ${PREFIX}_N_FEATURES; ++j) {
        row[j] = ${prefix}_domain_center[j] + share * (row[j] - ${prefix}_domain_center[j]);
    }
    ${prefix}_clamp_temperatures(row);
}
"""
)


# With temperature columns: the rounds (box, then the temperatures' clamp), the box once
# more, the pull-back (_C_PULL_BACK).
_C_CLIP_ROUNDS = Template(
    """    {
        int round;
        for (round = 0; round < ${PREFIX}_PROJECTION_ROUNDS; ++round) {
            ${prefix}_onto_box(evaluated);
            ${prefix}_clamp_temperatures(evaluated);
        }
        ${prefix}_onto_box(evaluated);
        ${prefix}_pull_back(evaluated);
    }
"""
)


# "blend": the drift of a row outside moves smoothly to the fallback. ``$fallback``: the
# fallback's expression for output ``k`` (a line in one feature, or a constant).
_C_BLEND = Template(
    """
/* "blend": drift = (1 - w) drift + w fallback, with s = (distance - margin) / BLEND_WIDTH
 * clamped to [0, 1] and w = s^2 (3 - 2 s) (a smoothstep: no step at the margin or beyond). */
static void ${prefix}_blend(
    const double features[${PREFIX}_N_FEATURES], double distance,
    ${prefix}_real drift[${PREFIX}_N_OUTPUTS])
{
    double s = (distance - ${PREFIX}_MARGIN) / ${PREFIX}_BLEND_WIDTH;
    double weight;
    int k;
    if (s < 0.0) {
        s = 0.0;
    } else if (s > 1.0) {
        s = 1.0;
    }
    weight = s * s * (3.0 - 2.0 * s);
    for (k = 0; k < ${PREFIX}_N_OUTPUTS; ++k) {
        const double fallback = $fallback;
        drift[k] = (${prefix}_real)((1.0 - weight) * (double)drift[k] + weight * fallback);
    }
$unused}
"""
)


# "blend" in {prefix}_guarded, on a row outside.
_C_BLEND_CALL = Template(
    "    if (outside) {\n        ${prefix}_blend(features, *distance, drift);\n    }\n"
)


# What each policy does, for the header comment (``$fallback``: the fallback).
_C_DESCRIPTION = {
    "blend": Template(
        "(1 - w) * model + w * fallback,\n"
        " * w rising smoothly (a smoothstep) from 0 at ${PREFIX}_MARGIN to 1 at\n"
        " * ${PREFIX}_MARGIN + ${PREFIX}_BLEND_WIDTH (0 for a sample outside by its temperature\n"
        " * alone); the fallback is $fallback"
    ),
    "clip": Template(
        "the model at the\n"
        " * nearest point of the domain (at the margin, every temperature within its range)"
    ),
    "none": Template("the model's own\n * extrapolation (the sample is only flagged)"),
}


# "blend" after the recalibrated output layer's drift (adapt="output"), on a row outside.
_C_RECALIBRATED_BLEND = Template(
    "\n    if (outside) {\n        ${prefix}_blend(features, *distance, drift);\n    }"
)
