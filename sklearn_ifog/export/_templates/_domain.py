"""The calibration domain's C: its functions, in pieces for the policy, and its header text."""

from string import Template

# The calibration domain (a CompensationPipeline's ``domain_``, ``margin`` and
# ``uncalibrated``), after the network in the source, in pieces that _c.py puts together
# with the policy's own C (``c_fragment`` of the policy object, sklearn_ifog.policy). In
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


# ``${prefix}_domain``: the flag, the distance, and the row the network is evaluated at.
# ``$distance``: the full distance from the box's (``box``; ``${prefix}_with_rates(features,
# box)`` with rate columns); ``$beyond_test``: `` && !${prefix}_beyond(features)`` with
# temperature columns; ``$clip_block``: the policy's ``flag_block`` (the projection under
# "clip", else nothing).
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


# The drift under the policy (``$blend_call``: the policy's ``guarded_call``, "blend"'s
# change of a row outside, else nothing), and the public distance (``$row_distance``:
# DOMAIN_FLAG's ``$distance`` of ``row``).
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


# The calibration domain's parts of the header (with a domain; without one the header only
# defines ``${PREFIX}_HAS_DOMAIN 0``). ``$policy``: the policy's name; ``$description``:
# what it does (the policy's ``description``); ``$margin``, ``$blend_width``: literals;
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


# The state's reset of the domain's fields, and the note of the predict_features prototype.
DOMAIN_RESET = "    state->last_distance = 0.0;\n    state->last_outside = 0;\n"


POLICY_NOTE = ", then the calibration domain's policy"
