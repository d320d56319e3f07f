"""The scale factor's C: the header text and functions of a model fitted with ``input_rate``.

Such a model predicts two outputs, the bias ``b`` (deg/h) and the scale-factor error ``s``
(dimensionless); ``${prefix}_step`` gives that pair under the calibration domain's policy,
and these functions make it the input rate a gyro output stands for, ``(rate - b) / (1 +
s + a sign(rate - b))``, or the drift at a known input rate, ``b + input_rate * s + a
|input_rate|`` (``a`` the constant asymmetry between positive and negative inputs; in double
whatever the
precision, as :func:`sklearn_ifog.scale_factor.input_rate_estimate` and
:func:`~sklearn_ifog.scale_factor.drift_of` compute them). They replace the drift model's
``${prefix}_compensate`` (``_source.COMPENSATE_PROTOTYPE`` / ``COMPENSATE_FUNCTION``).
"""

from string import Template

# The output line of the header's comment.
SCALE_OUTPUT_NOTE = Template(
    """\
 * Output of ${prefix}_step, ${prefix}_batch and ${prefix}_predict_features: the pair
 * {bias b (deg/h), scale-factor error s (dimensionless, 1e-6 is 1 ppm)} of the gyro's
 * thermal state (the model was fitted with a scale factor on input-rate column $column):
 * the gyro output is rate = input_rate * (1 + s) + a * |input_rate| + b, a the asymmetry
 * between positive and negative inputs. ${prefix}_compensate gives the input rate a gyro
 * output stands for, (rate - b) / (1 + s + a * sign(rate - b)); ${prefix}_drift_at the
 * drift b + input_rate * s + a * |input_rate| at a known input rate (deg/h).
"""
)

# The calibrated input rates (after the domain's defines).
SCALE_DEFINE = Template(
    """\
#define ${PREFIX}_HAS_SCALE_FACTOR 1
/* The calibrated input rates, deg/h, and the slack beyond them that still counts as
 * calibrated ($share of the larger magnitude): an input rate below LOW - SLACK or above
 * HIGH + SLACK sets state.last_outside (the policy reads the domain's distance alone). */
#define ${PREFIX}_INPUT_RATE_LOW $low
#define ${PREFIX}_INPUT_RATE_HIGH $high
#define ${PREFIX}_INPUT_RATE_SLACK $slack
/* The asymmetry a between positive and negative input rates (dimensionless). */
#define ${PREFIX}_ASYMMETRY $asymmetry
"""
)

SCALE_PROTOTYPES = Template(
    """\
/* 1 when an input rate (deg/h) lies beyond the calibrated input rates (by more than
 * ${PREFIX}_INPUT_RATE_SLACK), else 0. */
int ${prefix}_beyond_input_rates(double input_rate);

/* One sample: compensated[0] = (rate[0] - b) / (1 + s + a sign(rate[0] - b)), the input
 * rate (deg/h) the gyro output rate[0] (deg/h) stands for, with the bias b and the
 * scale-factor error s of the sample (${prefix}_step's pair, under the domain's policy)
 * and the asymmetry a (${PREFIX}_ASYMMETRY). The output stands in for the
 * input rate in the calibration check: state.last_outside is also 1 when it lies beyond
 * the calibrated input rates. */
void ${prefix}_compensate(
    ${prefix}_state *state, double time, const double temperature[${PREFIX}_N_SENSORS],
    const ${prefix}_real rate[1], ${prefix}_real compensated[1]);

/* One sample whose input rate is known (deg/h, a rate table's): the drift the gyro adds
 * to it, drift[0] = b + s * input_rate + a * |input_rate| (deg/h); state.last_outside is
 * also 1 when the input rate lies beyond the calibrated ones. */
void ${prefix}_drift_at(
    ${prefix}_state *state, double time, const double temperature[${PREFIX}_N_SENSORS],
    double input_rate, ${prefix}_real drift[1]);
"""
)

SCALE_FUNCTIONS = Template(
    """\
int ${prefix}_beyond_input_rates(double input_rate)
{
    const double low = ${PREFIX}_INPUT_RATE_LOW - ${PREFIX}_INPUT_RATE_SLACK;
    const double high = ${PREFIX}_INPUT_RATE_HIGH + ${PREFIX}_INPUT_RATE_SLACK;
    return (input_rate < low || input_rate > high) ? 1 : 0;
}

void ${prefix}_compensate(
    ${prefix}_state *state, double time, const double temperature[${PREFIX}_N_SENSORS],
    const ${prefix}_real rate[1], ${prefix}_real compensated[1])
{
    ${prefix}_real pair[${PREFIX}_N_OUTPUTS];
    const double output = (double)rate[0];
    ${prefix}_step(state, time, temperature, pair);
    const double excess = output - (double)pair[0];
    const double sign = (double)((excess > 0.0) - (excess < 0.0));
    compensated[0] = (${prefix}_real)(
        excess / (1.0 + (double)pair[1] + ${PREFIX}_ASYMMETRY * sign));
    if (${prefix}_beyond_input_rates(output)) {
        state->last_outside = 1;
    }
}

void ${prefix}_drift_at(
    ${prefix}_state *state, double time, const double temperature[${PREFIX}_N_SENSORS],
    double input_rate, ${prefix}_real drift[1])
{
    ${prefix}_real pair[${PREFIX}_N_OUTPUTS];
    ${prefix}_step(state, time, temperature, pair);
    drift[0] = (${prefix}_real)(
        (double)pair[0] + input_rate * (double)pair[1] + ${PREFIX}_ASYMMETRY * fabs(input_rate));
    if (${prefix}_beyond_input_rates(input_rate)) {
        state->last_outside = 1;
    }
}
"""
)
