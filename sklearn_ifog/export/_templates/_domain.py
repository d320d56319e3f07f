"""The calibration domain's C: its functions, in pieces for the policy, and its header text."""

from string import Template

# The calibration domain (a CompensationPipeline's ``domain_``, ``margin`` and ``outside``),
# after the network in the source, in pieces that _c.py puts together for the policy. In
# double whatever the precision, as the front end: the decorrelated coordinates divide by
# the spread of nearly degenerate axes (a gradient term is an exact difference of two
# sensors), where single-precision rounding of the features alone would read as a distance.
# ``$zero``: the literal 0 of the precision; ``$sqrt``: sqrt or sqrtf.
DOMAIN_BOX = Template(
    """
/* Distance of a row of features outside the calibrated box, in standard deviations of the
 * calibration along each decorrelated axis (0 inside): the features standardised, rotated
 * onto the box's axes (coordinates), each coordinate's excess beyond [lower, upper] (inside:
 * the coordinates clamped to that range) over its axis scale, the Euclidean norm. */
static double ${prefix}_box(
    const double features[${PREFIX}_N_FEATURES],
    double coordinates[${PREFIX}_N_FEATURES], double inside[${PREFIX}_N_FEATURES])
{
    double standard[${PREFIX}_N_FEATURES];
    double total = 0.0;
    int j;
    int k;
    for (j = 0; j < ${PREFIX}_N_FEATURES; ++j) {
        standard[j] = (features[j] - ${prefix}_domain_center[j]) / ${prefix}_domain_scale[j];
    }
    for (k = 0; k < ${PREFIX}_N_FEATURES; ++k) {
        double coordinate = 0.0;
        double excess;
        for (j = 0; j < ${PREFIX}_N_FEATURES; ++j) {
            coordinate += standard[j] * ${prefix}_domain_axes[k][j];
        }
        coordinates[k] = coordinate;
        inside[k] = coordinate;
        if (coordinate < ${prefix}_domain_lower[k]) {
            inside[k] = ${prefix}_domain_lower[k];
        } else if (coordinate > ${prefix}_domain_upper[k]) {
            inside[k] = ${prefix}_domain_upper[k];
        }
        excess = (coordinate - inside[k]) / ${prefix}_domain_axis_scale[k];
        total += excess * excess;
    }
    return sqrt(total);
}
"""
)


# With temperature columns: a temperature beyond its calibrated range is outside, by any
# amount (the firmware convention of a calibrated [TMIN, TMAX]).
DOMAIN_BEYOND = Template(
    """
/* 1 when a temperature feature lies beyond its calibrated range, by any amount. */
static int ${prefix}_beyond(const double features[${PREFIX}_N_FEATURES])
{
    int t;
    for (t = 0; t < ${PREFIX}_N_TEMPERATURES; ++t) {
        const double value = features[${prefix}_temperature_columns[t]];
        if (value < ${prefix}_temperature_low[t] || value > ${prefix}_temperature_high[t]) {
            return 1;
        }
    }
    return 0;
}
"""
)


# With rate columns (dT of each sensor): the rate term of the distance. The decorrelated
# axes spread a rate's excess over several of them, so a rate the calibration never showed
# (a cooling row of a heating-only calibration) can stay within the margin of the box; its
# excess over the rate's own range is one more term under the root. Only the flag, the
# distance and "blend" read it: "clip" moves a row by the box alone (``${prefix}_box``),
# as ``project_to_box`` does.
DOMAIN_RATES = Template(
    """
/* The distance outside the calibration domain from the box's (box): with, under the root,
 * the square of every rate feature's excess beyond its calibrated range over its scale
 * (the feature's standard deviation over the rate weight); plus BOOST times the novelty
 * (the norm of the rate terms and of every temperature's excess over its standard
 * deviation) up to 1, so that a sample beyond the calibrated rates or temperatures is held
 * to the margin rather than to the threshold calibrated on held-out runs within both. */
static double ${prefix}_with_rates(const double features[${PREFIX}_N_FEATURES], double box)
{
    double total = 0.0;
    double novelty;
    int r;
    for (r = 0; r < ${PREFIX}_N_RATES; ++r) {
        const double value = features[${prefix}_rate_columns[r]];
        double excess = 0.0;
        if (value < ${prefix}_rate_low[r]) {
            excess = ${prefix}_rate_low[r] - value;
        } else if (value > ${prefix}_rate_high[r]) {
            excess = value - ${prefix}_rate_high[r];
        }
        excess = excess / ${prefix}_rate_scale[r];
        total += excess * excess;
    }
    novelty = total / ${PREFIX}_BOOST_RATE_RAMP / ${PREFIX}_BOOST_RATE_RAMP;$temperature_novelty
    if (novelty == 0.0) {
        return box; /* every rate and temperature within its range: the box's distance */
    }
    novelty = sqrt(novelty);
    return sqrt(box * box + total) + ${PREFIX}_BOOST * (novelty < 1.0 ? novelty : 1.0);
}
"""
)


# ``$temperature_novelty`` of DOMAIN_RATES, with temperature columns: their excess beyond the
# calibrated range over the feature's standard deviation, squared into the novelty.
TEMPERATURE_NOVELTY = Template(
    """
    {
        int t;
        for (t = 0; t < ${PREFIX}_N_TEMPERATURES; ++t) {
            const int column = ${prefix}_temperature_columns[t];
            const double value = features[column];
            double excess = 0.0;
            if (value < ${prefix}_boost_temperature_low[t]) {
                excess = ${prefix}_boost_temperature_low[t] - value;
            } else if (value > ${prefix}_boost_temperature_high[t]) {
                excess = value - ${prefix}_boost_temperature_high[t];
            }
            excess = excess / ${prefix}_domain_scale[column] / ${PREFIX}_BOOST_TEMPERATURE_RAMP;
            novelty += excess * excess;
        }
    }"""
)


# "clip": a row farther than the margin moves from the box towards itself until its
# distance is the margin (its coordinates on the axes given, overwritten).
DOMAIN_PROJECT = Template(
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


# ``${prefix}_domain``: the flag, the distance, and the row the network is evaluated at.
# ``$distance``: the full distance from the box's (``box``; ``${prefix}_with_rates(features,
# box)`` with rate columns); ``$beyond_test``: `` && !${prefix}_beyond(features)`` with
# temperature columns; ``$clip_block``: CLIP_ONCE or CLIP_ROUNDS under "clip", else nothing.
DOMAIN_FLAG = Template(
    """
/* Whether a row of features lies outside the calibration domain (returns 1; *distance: its
 * distance outside it), and the row the network is evaluated at (evaluated): the features
 * themselves, except under "clip" for a row outside, the nearest point of the domain. */
static int ${prefix}_domain(
    const double features[${PREFIX}_N_FEATURES],
    double evaluated[${PREFIX}_N_FEATURES], double *distance)
{
    double coordinates[${PREFIX}_N_FEATURES];
    double inside[${PREFIX}_N_FEATURES];
    const double box = ${prefix}_box(features, coordinates, inside);
    int j;
    *distance = $distance;
    for (j = 0; j < ${PREFIX}_N_FEATURES; ++j) {
        evaluated[j] = features[j];
    }
    if (!(*distance > ${PREFIX}_MARGIN)$beyond_test) {
        return 0;
    }
$clip_block    return 1;
}
"""
)


# Without temperature columns, "clip" projects once, by the box's distance alone: a row
# outside by its rates only stays as it is (its box distance is within the margin, where
# margin / distance would move it outward).
CLIP_ONCE = Template(
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
DOMAIN_PULL_BACK = Template(
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
# more, the pull-back (DOMAIN_PULL_BACK).
CLIP_ROUNDS = Template(
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


# The drift under the policy (``$blend_call``: "blend"'s change of a row outside, else
# nothing), and the public distance (``$row_distance``: DOMAIN_FLAG's ``$distance`` of
# ``row``).
DOMAIN_GUARDED = Template(
    """
/* The drift of one row of features under the domain's policy; returns 1 when the row lies
 * outside the domain (*distance: its distance outside it). */
static int ${prefix}_guarded(
    const double features[${PREFIX}_N_FEATURES],
    ${prefix}_real drift[${PREFIX}_N_OUTPUTS], double *distance)
{
    double evaluated[${PREFIX}_N_FEATURES];
    const int outside = ${prefix}_domain(features, evaluated, distance);
    ${prefix}_evaluate(evaluated, drift);
$blend_call    return outside;
}

double ${prefix}_calibration_distance(const ${prefix}_real features[${PREFIX}_N_FEATURES])
{
    double row[${PREFIX}_N_FEATURES];
    double coordinates[${PREFIX}_N_FEATURES];
    double inside[${PREFIX}_N_FEATURES];
    double box;
    int j;
    for (j = 0; j < ${PREFIX}_N_FEATURES; ++j) {
        row[j] = (double)features[j];
    }
    box = ${prefix}_box(row, coordinates, inside);
    return $row_distance;
}
"""
)


# "blend": the drift of a row outside moves smoothly to the fallback. ``$fallback``: the
# fallback's expression for output ``k`` (a line in one feature, or a constant).
BLEND_FUNCTION = Template(
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


# The calibration domain's parts of the header (with a domain; without one the header only
# defines ``${PREFIX}_HAS_DOMAIN 0``). ``$policy``: the ``outside`` policy; ``$description``:
# what it does (one of POLICY_TEXT); ``$margin``, ``$blend_width``: literals;
# ``$temperature_define``, ``$rate_define``: TEMPERATURE_DEFINE, RATE_DEFINE or nothing.
DOMAIN_DEFINE = Template(
    """\
#define ${PREFIX}_HAS_DOMAIN 1
/* Distance outside the calibration domain that still counts as inside, and the width of
 * the "blend" policy's transition (both in decorrelated standard deviations). */
#define ${PREFIX}_MARGIN $margin
#define ${PREFIX}_BLEND_WIDTH $blend_width
$temperature_define$rate_define"""
)


# In the header's note on precision, with a domain.
DOMAIN_PRECISION = """
 * The calibration domain (distance, flag, the policy's projection, weight and fallback) is
 * computed in double too, from the front end's double features: its decorrelated coordinates
 * divide by the spread of nearly degenerate axes (a gradient is an exact difference of two
 * sensors), where rounding the features to float alone would read as a distance."""


# With temperature columns (``$temperature_define`` of DOMAIN_DEFINE).
TEMPERATURE_DEFINE = Template(
    """\
/* Temperature features whose calibrated range admits no margin, and the rounds of the
 * "clip" policy's alternating projection (box, temperature ranges). */
#define ${PREFIX}_N_TEMPERATURES $n_temperatures
#define ${PREFIX}_PROJECTION_ROUNDS $rounds
"""
)


# With rate columns (``$rate_define`` of DOMAIN_DEFINE).
RATE_DEFINE = Template(
    """\
/* Rate features (dT of each sensor) whose excess beyond their calibrated range adds to the
 * distance. */
#define ${PREFIX}_N_RATES $n_rates
/* Added to the distance of a sample beyond the calibrated rates, times its rate term up to
 * 1 (the calibrated threshold less the margin). */
#define ${PREFIX}_BOOST $boost
/* The novelty's scales: the boost is added in full at a rate term of BOOST_RATE_RAMP, or a
 * temperature BOOST_TEMPERATURE_RAMP of its standard deviations beyond its range. */
#define ${PREFIX}_BOOST_RATE_RAMP $boost_rate_ramp
#define ${PREFIX}_BOOST_TEMPERATURE_RAMP $boost_temperature_ramp
"""
)


# ``$rate_note``: with rate columns, how their excess adds to the distance; ``$temperature_note``:
# with temperature columns, the second way to be outside.
DOMAIN_COMMENT = Template(
    """\
 *
 * Calibration domain: a sample's distance outside it is computed from its features
 * (standardised, rotated onto the calibration's principal axes; along each axis, the excess
 * beyond the calibrated range over the calibration's standard deviation along it; the
 * Euclidean norm of those excesses: 0 inside$rate_note).
 * A sample is outside when its distance exceeds ${PREFIX}_MARGIN$temperature_note.
 * Outside, its drift follows the policy "$policy": $description.
 * After each ${prefix}_step or ${prefix}_compensate$adapt_note, state.last_distance and
 * state.last_outside hold the sample's distance and flag (1: outside); ${prefix}_batch keeps
 * no state to read them from.
"""
)


DOMAIN_FIELDS = Template(
    """\
    /* The last sample's distance outside the calibration domain (0 inside) and whether it
     * lay outside (distance > ${PREFIX}_MARGIN: its drift followed the policy "$policy"). */
    double last_distance;
    int last_outside;
"""
)


DOMAIN_PROTOTYPES = Template(
    """\
/* Distance of one row of features outside the calibration domain (0 inside; the row is
 * outside above ${PREFIX}_MARGIN). */
double ${prefix}_calibration_distance(const ${prefix}_real features[${PREFIX}_N_FEATURES]);

"""
)


# What each ``outside`` policy does, for the header comment (``$fallback``: the fallback).
POLICY_TEXT = {
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

# The state's reset of the domain's fields, the call of ``"blend"`` on a row outside, and the
# note of the predict_features prototype.
DOMAIN_RESET = "    state->last_distance = 0.0;\n    state->last_outside = 0;\n"

BLEND_CALL = Template(
    "    if (outside) {\n        ${prefix}_blend(features, *distance, drift);\n    }\n"
)

POLICY_NOTE = ", then the calibration domain's policy"
