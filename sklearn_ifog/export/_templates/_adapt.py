"""The online recalibration's C (``to_c(..., adapt=...)``): its functions and header text."""

from string import Template

# The online recalibration's functions (``adapt``), at the end of the source. ``$lam``: the
# forgetting factor, ``$sqrt_lam`` its square root; ``$trace0``: the initial covariance's
# trace (the sum of the squares of the initial factor); ``$drift_lines``: the body
# of ``${prefix}_drift``; ``$record_domain``: how ``${prefix}_adapt`` records the sample's
# distance and flag in the state.
ADAPT_FUNCTIONS = Template(
    """
/* Drift of one sample's features with the current (recalibrated) weights and the calibration
 * domain's policy; phi: the output-layer row, base: the model's drift before the bias
 * ("bias" mode). Returns 1 when the row lies outside the calibration domain (*distance: its
 * distance), else 0 (always 0 without a domain). */
static int ${prefix}_drift(
    const ${prefix}_state *state, const double features[${PREFIX}_N_FEATURES],
    double phi_out[${PREFIX}_N_WEIGHTS], ${prefix}_real base[${PREFIX}_N_OUTPUTS],
    ${prefix}_real drift[${PREFIX}_N_OUTPUTS], double *distance)
{
$drift_lines
    for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
        phi_out[i] = phi[i];
    }
    return outside;
}

void ${prefix}_reset_adaptation(${prefix}_state *state)
{
    int i;
    int j;
    for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
        for (j = 0; j < ${PREFIX}_N_OUTPUTS; ++j) {
            state->weights[i][j] = ${prefix}_initial_weights[i][j];
        }
        for (j = 0; j < ${PREFIX}_N_WEIGHTS; ++j) {
            state->covariance_factor[i][j] = ${prefix}_initial_factor[i][j];
        }
    }
    state->n_updates = 0;
    state->n_resets = 0;
}

/* f = S' phi and its squared norm (the factor S of the covariance P = S S'). */
static double ${prefix}_rls_project(
    const ${prefix}_state *state, const double phi[${PREFIX}_N_WEIGHTS],
    double f[${PREFIX}_N_WEIGHTS])
{
    double norm2 = 0.0;
    int i;
    int j;
    for (j = 0; j < ${PREFIX}_N_WEIGHTS; ++j) {
        double total = 0.0;
        for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
            total += state->covariance_factor[i][j] * phi[i];
        }
        f[j] = total;
        norm2 += total * total;
    }
    return norm2;
}

/* One recursive-least-squares update with forgetting, in Potter's square-root form (see
 * ${prefix}.h): the covariance is carried as its factor S (P = S S'), which keeps the
 * digits the covariance form loses on the initial covariance's 1e8 condition number. */
static void ${prefix}_rls(
    ${prefix}_state *state, const double phi[${PREFIX}_N_WEIGHTS],
    const double target[${PREFIX}_N_OUTPUTS])
{
    double f[${PREFIX}_N_WEIGHTS];
    double p_phi[${PREFIX}_N_WEIGHTS];
    double error[${PREFIX}_N_OUTPUTS];
    double quadratic;
    double s;
    double beta;
    double trace = 0.0;
    int i;
    int j;
    quadratic = ${prefix}_rls_project(state, phi, f);
    if (!isfinite(quadratic)) {
        /* The factor overflows against this row: back to the initial factor. */
        for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
            for (j = 0; j < ${PREFIX}_N_WEIGHTS; ++j) {
                state->covariance_factor[i][j] = ${prefix}_initial_factor[i][j];
            }
        }
        quadratic = ${prefix}_rls_project(state, phi, f);
        state->n_resets += 1;
    }
    s = $lam + quadratic;
    for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
        double total = 0.0;
        for (j = 0; j < ${PREFIX}_N_WEIGHTS; ++j) {
            total += state->covariance_factor[i][j] * f[j];
        }
        p_phi[i] = total;
    }
    for (j = 0; j < ${PREFIX}_N_OUTPUTS; ++j) {
        double total = 0.0;
        for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
            total += phi[i] * state->weights[i][j];
        }
        error[j] = target[j] - total;
    }
    for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
        const double gain = p_phi[i] / s;
        for (j = 0; j < ${PREFIX}_N_OUTPUTS; ++j) {
            state->weights[i][j] += gain * error[j];
        }
    }
    /* 1 / (s + sqrt(lam s)) = (1 - sqrt(lam / s)) / (f'f), without the cancellation. */
    beta = 1.0 / (s + sqrt($lam * s));
    for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
        const double scaled = beta * p_phi[i];
        for (j = 0; j < ${PREFIX}_N_WEIGHTS; ++j) {
            const double value = (state->covariance_factor[i][j] - scaled * f[j]) / $sqrt_lam;
            state->covariance_factor[i][j] = value;
            trace += value * value;
        }
    }
    if (!isfinite(trace)) {
        for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
            for (j = 0; j < ${PREFIX}_N_WEIGHTS; ++j) {
                state->covariance_factor[i][j] = ${prefix}_initial_factor[i][j];
            }
        }
        state->n_resets += 1;
    } else if (trace > $trace0) {
        /* The trace of P is the sum of the squares of S: the wind-up bound. */
        const double shrink = sqrt($trace0 / trace);
        for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {
            for (j = 0; j < ${PREFIX}_N_WEIGHTS; ++j) {
                state->covariance_factor[i][j] *= shrink;
            }
        }
    }
    state->n_updates += 1;
}

void ${prefix}_adapt(
    ${prefix}_state *state, double time, const double temperature[${PREFIX}_N_SENSORS],
    const ${prefix}_real rate[${PREFIX}_N_OUTPUTS], const double reference[${PREFIX}_N_OUTPUTS],
    ${prefix}_real drift[${PREFIX}_N_OUTPUTS])
{
    double features[${PREFIX}_N_FEATURES];
    ${prefix}_real base[${PREFIX}_N_OUTPUTS];
    double distance;
    double phi[${PREFIX}_N_WEIGHTS];
    double target[${PREFIX}_N_OUTPUTS];
    int outside;
    int k;
    ${prefix}_features(state, time, temperature, features);
    outside = ${prefix}_drift(state, features, phi, base, drift, &distance);
$record_domain    if (outside) {
        /* Outside the calibration domain: compensated by the policy, but features the
         * calibration never covered must not move the output layer. */
        return;
    }
    for (k = 0; k < ${PREFIX}_N_OUTPUTS; ++k) {
        target[k] = ((double)rate[k] - reference[k]) - (double)base[k];
    }
    ${prefix}_rls(state, phi, target);
}
"""
)

# The recalibration's parameters: the comment above the initial weights and factor, and the
# prototype of ``${prefix}_drift`` (defined with ADAPT_FUNCTIONS, after the functions that
# call it).
PRIOR_COMMENT = (
    "/* Recalibration (RLS): initial output-layer weights and the factor S0 of the initial\n"
    " * covariance P0 = S0 S0' (Cholesky). */\n"
)

DRIFT_PROTOTYPE = Template(
    "static int ${prefix}_drift(\n"
    "    const ${prefix}_state *state, const double features[${PREFIX}_N_FEATURES],\n"
    "    double phi_out[${PREFIX}_N_WEIGHTS], ${prefix}_real base[${PREFIX}_N_OUTPUTS],\n"
    "    ${prefix}_real drift[${PREFIX}_N_OUTPUTS], double *distance);\n"
)

# The body of ``${prefix}_drift`` (``$drift_lines`` of ADAPT_FUNCTIONS). "output": the
# recalibrated output layer at ``$design_lines``'s row (the domain's edge under "clip"), then
# ``$blend_lines`` (the policy's ``recalibrated_call``); "bias": the fitted model under the
# policy (``$evaluate_line``), then the offset.
DRIFT_OUTPUT = Template(
    "$evaluated_line"
    "    double phi[${PREFIX}_N_WEIGHTS];\n"
    "    int i;\n"
    "    int k;\n"
    "    int outside = 0;\n"
    "$design_lines"
    "    for (k = 0; k < ${PREFIX}_N_OUTPUTS; ++k) {\n"
    "        double total = 0.0;\n"
    "        for (i = 0; i < ${PREFIX}_N_WEIGHTS; ++i) {\n"
    "            total += phi[i] * state->weights[i][k];\n"
    "        }\n"
    "        base[k] = 0.0;\n"
    "        drift[k] = (${prefix}_real)total;\n"
    "    }"
    "$blend_lines"
)

DESIGN_PLAIN = Template("    *distance = 0.0;\n    ${prefix}_design(features, phi);\n")

DESIGN_DOMAIN = Template(
    "    outside = ${prefix}_domain(features, evaluated, distance);\n"
    "    ${prefix}_design(evaluated, phi);\n"
)

EVALUATED_LINE = Template("    double evaluated[${PREFIX}_N_FEATURES];\n")


DRIFT_BIAS = Template(
    "    double phi[${PREFIX}_N_WEIGHTS];\n"
    "    int i;\n"
    "    int k;\n"
    "    int outside = 0;\n"
    "    phi[0] = 1.0;\n"
    "    (void)i;\n"
    "$evaluate_line"
    "    for (k = 0; k < ${PREFIX}_N_OUTPUTS; ++k) {\n"
    "        drift[k] = (${prefix}_real)(base[k] + state->weights[0][k]);\n"
    "    }"
)

EVALUATE_PLAIN = Template("    *distance = 0.0;\n    ${prefix}_evaluate(features, base);\n")

EVALUATE_GUARDED = Template("    outside = ${prefix}_guarded(features, base, distance);\n")

# ``${prefix}_design``: the final regressor's output-layer row; ``$body``: its lines.
DESIGN_FUNCTION = Template(
    "\n/* The final regressor's output layer: the row its drift is linear in. */\n"
    "static void ${prefix}_design(\n"
    "    const double features[${PREFIX}_N_FEATURES],\n"
    "    double phi[${PREFIX}_N_WEIGHTS])\n"
    "{\n$body\n}\n"
)

# The header's parts with ``adapt``; ``$lam``: the forgetting factor's literal, ``$adapt``:
# the mode, ``$outside_rule``: OUTSIDE_RULE with a domain, else nothing.
ADAPT_DEFINE = Template(
    "#define ${PREFIX}_N_WEIGHTS $n_weights\n"
    "/* Forgetting factor of the recalibration. */\n"
    "#define ${PREFIX}_FORGETTING $lam\n"
)

ADAPT_FIELDS = Template(
    '    /* Recalibration (recursive least squares, mode "$adapt"): the output\n'
    "     * layer's weights, the factor S of their covariance P = S S' (over the\n"
    "     * noise variance), the references used and the factor's resets. */\n"
    "    double weights[${PREFIX}_N_WEIGHTS][${PREFIX}_N_OUTPUTS];\n"
    "    double covariance_factor[${PREFIX}_N_WEIGHTS][${PREFIX}_N_WEIGHTS];\n"
    "    long n_updates;\n"
    "    long n_resets;\n"
)

ADAPT_PROTOTYPES = Template(
    "/* Return the recalibration to the fitted model (init does it; reset does not). */\n"
    "void ${prefix}_reset_adaptation(${prefix}_state *state);\n\n"
    "/* One sample whose true rate is known: write its drift (as step does), then learn\n"
    " * from rate - reference (recursive least squares with forgetting).$outside_rule */\n"
    "void ${prefix}_adapt(\n"
    "    ${prefix}_state *state, double time,\n"
    "    const double temperature[${PREFIX}_N_SENSORS],\n"
    "    const ${prefix}_real rate[${PREFIX}_N_OUTPUTS],\n"
    "    const double reference[${PREFIX}_N_OUTPUTS],\n"
    "    ${prefix}_real drift[${PREFIX}_N_OUTPUTS]);\n\n"
)

OUTSIDE_RULE = (
    "\n * A sample outside the calibration domain is compensated by its policy and not\n"
    ' * learnt from (state.last_outside is 1; the "bias" offset is added after the policy).'
)

ADAPT_INIT = Template("    ${prefix}_reset_adaptation(state);\n")

# ``${prefix}_step``'s drift with the recalibration; ``$record``: how the flag is kept.
STEP_ADAPTED = Template(
    "    ${prefix}_real base[${PREFIX}_N_OUTPUTS];\n"
    "    double phi[${PREFIX}_N_WEIGHTS];\n"
    "    double distance;\n"
    "$record"
)
