"""The parts of the generated C that depend on the model beyond its steps: the
ThermalFeatures front end (its body and the state's lags), the calibration domain, the
online recalibration and the scale factor; each returns the text
:func:`sklearn_ifog.export._c.render_c` puts into the templates
(:mod:`sklearn_ifog.export._templates`)."""

import math

import numpy as np

from sklearn_ifog._contract import get_term, uses_rate
from sklearn_ifog.export._c_steps import DESIGNS, RENDERERS
from sklearn_ifog.export._c_writer import c_array, c_comment, format_c_literal
from sklearn_ifog.export._templates._adapt import (
    ADAPT_DEFINE,
    ADAPT_FIELDS,
    ADAPT_FUNCTIONS,
    ADAPT_INIT,
    ADAPT_PROTOTYPES,
    DESIGN_DOMAIN,
    DESIGN_FUNCTION,
    DESIGN_PLAIN,
    DRIFT_BIAS,
    DRIFT_OUTPUT,
    DRIFT_PROTOTYPE,
    EVALUATE_GUARDED,
    EVALUATE_PLAIN,
    EVALUATED_LINE,
    OUTSIDE_RULE,
    PRIOR_COMMENT,
    STEP_ADAPTED,
)
from sklearn_ifog.export._templates._domain import (
    DOMAIN_BEYOND,
    DOMAIN_BOX,
    DOMAIN_COMMENT,
    DOMAIN_DEFINE,
    DOMAIN_FIELDS,
    DOMAIN_FLAG,
    DOMAIN_GUARDED,
    DOMAIN_PRECISION,
    DOMAIN_PROTOTYPES,
    DOMAIN_RATES,
    DOMAIN_RESET,
    POLICY_NOTE,
    RATE_DEFINE,
    TEMPERATURE_DEFINE,
    TEMPERATURE_NOVELTY,
)
from sklearn_ifog.export._templates._scale import (
    SCALE_DEFINE,
    SCALE_FUNCTIONS,
    SCALE_OUTPUT_NOTE,
    SCALE_PROTOTYPES,
)
from sklearn_ifog.export._templates._source import (
    COMPENSATE_FUNCTION,
    COMPENSATE_PROTOTYPE,
    LAG_COEFFICIENTS,
    LAG_DECLARATIONS,
    LAG_DEFINE,
    LAG_FIELD,
    LAG_RESET,
    LAG_TABLE_COMMENT,
    LAG_UPDATE,
    OUTPUT_NOTE,
    PREDICT_EVALUATE,
    PREDICT_GUARDED,
    RECORD_DOMAIN,
    RECORD_NOTHING,
    STEP_EVALUATE,
    STEP_GUARDED,
)
from sklearn_ifog.policy import policy_for


def features_body(features, prefix):
    """ThermalFeatures' causal step in C: differences, exact lags, then the terms."""
    terms = features["terms"]
    taus = features["time_constants"]
    n_lags = len(taus)
    names = {"prefix": prefix, "PREFIX": prefix.upper()}
    needs_delta = uses_rate(terms)
    needs_previous = needs_delta or n_lags > 0
    uses_time = features["time"] is not None and needs_previous
    smoothing = features["smoothing"]
    lines = ["    int sensor;", "    int column = 0;"]
    if n_lags:
        lines.append(LAG_DECLARATIONS.substitute(names))
    if uses_time:
        lines.append("    const double elapsed = time - state->last_time;")
    else:
        lines.append("    (void)time;")
    if n_lags:
        # One exact step of every first-order lag (_lags.lag_step): the coefficients are
        # shared by the sensors.
        lines.append(LAG_COEFFICIENTS.substitute(names))
    lines.append(f"    for (sensor = 0; sensor < {prefix.upper()}_N_SENSORS; ++sensor) {{")
    lines.append("        const double raw = temperature[sensor];")
    if n_lags:
        # Deficits T - lag_tau(T), 0 at a run's first row (reset).
        lines.append("        double *deficit = state->deficit[sensor];")
    if needs_delta:
        lines.append("        double delta = 0.0;")
    if needs_previous:
        lines += [
            "        if (state->has_history) {",
            "            const double change = raw - state->last_temperature[sensor];",
        ]
        if n_lags:
            lines.append(LAG_UPDATE.substitute(names))
        if needs_delta:
            per_unit = (
                None
                if features["time"] is None
                else format_c_literal(features["seconds_per_unit"])
            )
            if smoothing > 0:
                index = taus.index(smoothing)
                lines.append(
                    f"            delta = deficit[{index}] / {format_c_literal(smoothing)} * "
                    f"{per_unit};"
                )
            elif uses_time:
                lines.append(f"            delta = change / elapsed * {per_unit};")
            else:
                lines.append("            delta = change;")
        lines += ["        }", "        state->last_temperature[sensor] = raw;"]
    for term in map(get_term, terms):
        expression = term.expression(taus)
        assignment = f"features[column++] = ({expression});"
        if not term.first_sensor:
            # The first sensor has no column of this term (e.g. its gradient is zero).
            lines += ["        if (sensor > 0) {", f"            {assignment}", "        }"]
        else:
            lines.append(f"        {assignment}")
    lines.append("    }")
    if uses_time:
        lines.append("    state->last_time = time;")
    lines.append("    state->has_history = 1;")
    return "\n".join(lines)


def state_parts(features, prefix):
    """The state struct's lag fields, the reset of them, and the time-constant table."""
    taus = features["time_constants"]
    if not taus:
        return "", "", "", ""
    names = {"PREFIX": prefix.upper()}
    table = c_array(f"{prefix}_time_constants", taus, "double", "double")
    return (
        LAG_DEFINE.substitute(names, n_lags=len(taus)),
        LAG_FIELD.substitute(names),
        LAG_RESET.substitute(names),
        LAG_TABLE_COMMENT + table,
    )


def _fallback_text(domain, feature_names):
    """The "blend" fallback in words, for the header comment."""
    fallback = domain["fallback"]
    if fallback["column"] is None or not any(fallback["slope"]):
        return "a constant, the calibration's mean drift"
    name = c_comment(feature_names[fallback["column"]])
    if fallback.get("rate_column") is None or not any(fallback["rate_slope"]):
        return f"a line in the feature {name}"
    rate = c_comment(feature_names[fallback["rate_column"]])
    return (
        f"a line in the features {name} and {rate} ({rate} clipped to the calibrated "
        f"magnitude; the line held flat beyond a calibrated extreme it did not extrapolate to)"
    )


def _fallback_expression(writer, fallback):
    """The C expression of the fallback of output ``k`` (the arithmetic of
    :meth:`~sklearn_ifog.fallback.Fallback.predict`, in its order), and whether it reads the
    features."""
    intercept = writer.array("fallback_intercept", fallback["intercept"], double=True)
    column = fallback["column"]
    if column is None:
        return f"{intercept}[k]", False
    slope = writer.array("fallback_slope", fallback["slope"], double=True)
    expression = f"{intercept}[k] + features[{column}] * {slope}[k]"
    for side, edge, clamp in (("below", "low", "fmin"), ("above", "high", "fmax")):
        hold = fallback.get(f"hold_{side}")
        if hold and any(hold):
            held = writer.array(f"fallback_hold_{side}", [float(h) for h in hold], double=True)
            limit = format_c_literal(fallback[edge], "double")
            expression = (
                f"({expression}) - {clamp}((double)features[{column}] - {limit}, 0.0) "
                f"* ({slope}[k] * {held}[k])"
            )
    rate_column = fallback.get("rate_column")
    if rate_column is not None and any(fallback["rate_slope"]):
        rate_slope = writer.array("fallback_rate_slope", fallback["rate_slope"], double=True)
        limit = format_c_literal(fallback["rate_bound"], "double")
        expression = (
            f"({expression}) + fmin(fmax((double)features[{rate_column}], -{limit}), {limit}) "
            f"* {rate_slope}[k]"
        )
    return expression, True


def _policy_fragment(writer, domain, prefix, feature_names):
    """The C of the domain's policy, from the policy object (``c_fragment``)."""
    return policy_for(domain["uncalibrated"]).c_fragment(
        prefix,
        temperatures=bool(domain["temperature_columns"]),
        fallback=lambda: _fallback_expression(writer, domain["fallback"]),
        fallback_words=_fallback_text(domain, feature_names),
    )


def _domain_functions(writer, domain, prefix, feature_names):
    """The C functions of the calibration domain, with its policy's (see _templates), and
    the policy's fragment."""
    names = {"prefix": prefix, "PREFIX": prefix.upper()}
    for key in ("center", "scale", "axes", "axis_scale", "lower", "upper"):
        writer.array(f"domain_{key}", domain[key], double=True)
    parts = [DOMAIN_BOX.substitute(names)]
    beyond_test = ""
    # The full distance from the box's (``box``): with rate columns, plus their term (the
    # arithmetic of box_distance); without them, no rate code at all.
    distance, row_distance = "box", "box"
    if domain["temperature_columns"]:
        writer.array("temperature_columns", domain["temperature_columns"], index_type="int")
        writer.array("temperature_low", domain["temperature_low"], double=True)
        writer.array("temperature_high", domain["temperature_high"], double=True)
        parts.append(DOMAIN_BEYOND.substitute(names))
        beyond_test = f" && !{prefix}_beyond(features)"
    if domain.get("rate_columns"):
        writer.array("rate_columns", domain["rate_columns"], index_type="int")
        writer.array("rate_low", domain["rate_low"], double=True)
        writer.array("rate_high", domain["rate_high"], double=True)
        writer.array("rate_scale", domain["rate_scale"], double=True)
        novelty = ""
        if domain["temperature_columns"] and domain.get("boost", 0.0):
            low, high = domain["boost_temperature_low"], domain["boost_temperature_high"]
            writer.array("boost_temperature_low", low, double=True)
            writer.array("boost_temperature_high", high, double=True)
            novelty = TEMPERATURE_NOVELTY.substitute(names)
        parts.append(DOMAIN_RATES.substitute(names, temperature_novelty=novelty))
        distance = f"{prefix}_with_rates(features, box)"
        row_distance = f"{prefix}_with_rates(row, box)"
    fragment = _policy_fragment(writer, domain, prefix, feature_names)
    parts.append(fragment.functions)
    parts.append(
        DOMAIN_FLAG.substitute(
            names, distance=distance, beyond_test=beyond_test, clip_block=fragment.flag_block
        )
    )
    parts.append(fragment.after_flag)
    parts.append(
        DOMAIN_GUARDED.substitute(
            names, blend_call=fragment.guarded_call, row_distance=row_distance
        )
    )
    return "".join(parts), fragment


def domain_parts(writer, spec, prefix, adapt):
    """Header text, state fields and functions of the calibration domain.

    Without a domain (a plain Pipeline) only ``{PREFIX}_HAS_DOMAIN 0`` is written.
    """
    upper = prefix.upper()
    domain = spec.get("domain")
    names = {"prefix": prefix, "PREFIX": upper}
    if domain is None:
        empty = ("domain_comment", "domain_fields", "domain_reset", "domain_prototypes")
        return {
            **dict.fromkeys(empty, ""),
            "domain_define": f"#define {upper}_HAS_DOMAIN 0\n",
            "domain_functions": "",
            "domain_precision": "",
            "predict_features_body": PREDICT_EVALUATE.substitute(names),
            "policy_note": "",
        }
    names = {"prefix": prefix, "PREFIX": upper, "policy": domain["uncalibrated"]}
    feature_names = spec["features"]["feature_names"]
    temperatures = domain["temperature_columns"]
    temperature_define = temperature_note = rate_define = rate_note = ""
    if temperatures:
        temperature_define = TEMPERATURE_DEFINE.substitute(
            names, n_temperatures=len(temperatures), rounds=domain["projection_rounds"]
        )
        listed = c_comment(", ".join(feature_names[column] for column in temperatures))
        temperature_note = (
            f",\n * or when a temperature ({listed}) lies beyond its calibrated range (by any\n"
            " * amount)"
        )
    rates = domain.get("rate_columns") or []
    if rates:
        rate_define = RATE_DEFINE.substitute(
            names,
            n_rates=len(rates),
            boost=format_c_literal(domain.get("boost", 0.0)),
            boost_rate_ramp=format_c_literal(domain.get("boost_rate_ramp", 1.0)),
            boost_temperature_ramp=format_c_literal(domain.get("boost_temperature_ramp", 1.0)),
        )
        listed = c_comment(", ".join(feature_names[column] for column in rates))
        rate_note = (
            f";\n * a rate ({listed}) beyond its calibrated range adds to the distance: its\n"
            " * excess over the rate's scale (its calibrated standard deviation over the rate\n"
            " * weight) is one more term of the norm (where a heating-only calibration's\n"
            " * cooling samples lie)"
        )
    functions, fragment = _domain_functions(writer, domain, prefix, feature_names)
    return {
        "domain_define": DOMAIN_DEFINE.substitute(
            names,
            margin=format_c_literal(domain["margin"]),
            blend_width=format_c_literal(domain["blend_width"]),
            temperature_define=temperature_define,
            rate_define=rate_define,
        ),
        "domain_comment": DOMAIN_COMMENT.substitute(
            names,
            description=fragment.description,
            temperature_note=temperature_note,
            rate_note=rate_note,
            adapt_note=_state_note(spec, prefix, adapt),
        ),
        "domain_fields": DOMAIN_FIELDS.substitute(names),
        "domain_reset": DOMAIN_RESET,
        "domain_prototypes": DOMAIN_PROTOTYPES.substitute(names),
        "domain_functions": functions,
        "domain_precision": DOMAIN_PRECISION,
        "predict_features_body": PREDICT_GUARDED.substitute(names),
        "policy_note": POLICY_NOTE,
    }


def _state_note(spec, prefix, adapt):
    """The other functions after which the state holds the last sample's flag."""
    if spec.get("scale_factor") is not None:
        return f" (or {prefix}_drift_at)"
    return "" if adapt is None else f" (or {prefix}_adapt)"


def _record(domain, call):
    """Lines that keep a sample's distance and flag in the state (``call``: the flag)."""
    return (RECORD_NOTHING if domain is None else RECORD_DOMAIN).substitute(call=call)


def _drift_lines(names, adapt, domain, fragment):
    """The body of the recalibrated ``{prefix}_drift``: the model, then the domain's policy.

    ``"output"``: the recalibrated output layer at the row the policy evaluates (``"clip"``:
    the domain's edge), then the policy's change of a row outside (``fragment``'s
    ``recalibrated_call``: ``"blend"``'s fallback); ``"bias"``: the fitted model under the
    policy, then the offset (added after the policy).
    """
    if adapt == "bias":
        evaluate = EVALUATE_PLAIN if domain is None else EVALUATE_GUARDED
        return DRIFT_BIAS.substitute(names, evaluate_line=evaluate.substitute(names))
    return DRIFT_OUTPUT.substitute(
        names,
        evaluated_line="" if domain is None else EVALUATED_LINE.substitute(names),
        design_lines=(DESIGN_PLAIN if domain is None else DESIGN_DOMAIN).substitute(names),
        blend_lines="" if fragment is None else fragment.recalibrated_call,
    )


def _design_function(writer, spec, names, degree):
    """``{prefix}_design``: the final regressor's output-layer row of a row of features."""
    saved, writer.lines = writer.lines, []
    steps = spec["steps"]
    for k, step in enumerate(steps[:-1], start=1):
        writer.emit(f"    {writer.real} x{k}[{step['n_outputs']}];")
    buffers = ["features"] + [f"x{k}" for k in range(1, len(steps))]
    for k, step in enumerate(steps[:-1]):
        RENDERERS[step["op"]](writer, f"step{k}", step, buffers[k], buffers[k + 1])
    last = steps[-1]
    DESIGNS[last["op"]](writer, f"step{len(steps) - 1}", last, buffers[-1], degree)
    design_lines = ["    int i;", "    int j;", *writer.lines, "    (void)i;", "    (void)j;"]
    writer.lines = saved
    return DESIGN_FUNCTION.substitute(names, body="\n".join(design_lines))


def adaptation_parts(writer, spec, prefix, adapt, forgetting, prior, degree):
    """Fields, prototypes and functions of the RLS recalibration (empty without ``adapt``).

    ``prior``: the recalibration's
    :class:`~sklearn_ifog.streaming._recalibration.RecalibrationPrior`, the Python
    compensator's; ``degree``: the degree of the network's stored tail (the design's).
    """
    names = {"prefix": prefix, "PREFIX": prefix.upper()}
    domain = spec.get("domain")
    if adapt is None:
        if domain is None:
            step_drift = STEP_EVALUATE.substitute(names)
        else:
            record = _record(domain, f"{prefix}_guarded(features, drift, &distance)")
            step_drift = STEP_GUARDED.substitute(record=record)
        empty = ("adapt_define", "adapt_fields", "adapt_prototypes", "adapt_init")
        return {**dict.fromkeys(empty, ""), "adapt_functions": "", "step_drift": step_drift}
    weights = np.asarray(prior.weights, dtype=np.float64)
    factor = np.asarray(prior.factor, dtype=np.float64)
    writer.parameters += [
        PRIOR_COMMENT + c_array(f"{prefix}_initial_weights", weights, "double", "double"),
        c_array(f"{prefix}_initial_factor", factor, "double", "double"),
        DRIFT_PROTOTYPE.substitute(names),
    ]
    lam = format_c_literal(forgetting)
    fragment = None
    if domain is not None:
        fragment = _policy_fragment(writer, domain, prefix, spec["features"]["feature_names"])
    functions = [_design_function(writer, spec, names, degree)] if adapt == "output" else []
    functions.append(
        ADAPT_FUNCTIONS.substitute(
            names,
            lam=lam,
            sqrt_lam=format_c_literal(math.sqrt(forgetting)),
            trace0=format_c_literal(float(prior.trace)),
            drift_lines=_drift_lines(names, adapt, domain, fragment),
            record_domain="" if domain is None else _record(domain, "outside"),
        )
    )
    drift_call = f"{prefix}_drift(state, features, phi, base, drift, &distance)"
    return {
        "adapt_define": ADAPT_DEFINE.substitute(names, n_weights=weights.shape[0], lam=lam),
        "adapt_fields": ADAPT_FIELDS.substitute(names, adapt=adapt),
        "adapt_prototypes": ADAPT_PROTOTYPES.substitute(
            names, outside_rule="" if domain is None else OUTSIDE_RULE
        ),
        "adapt_init": ADAPT_INIT.substitute(names),
        "adapt_functions": "".join(functions),
        "step_drift": STEP_ADAPTED.substitute(names, record=_record(domain, drift_call)),
    }


def scale_parts(spec, prefix):
    """The header's output note and defines, and ``{prefix}_compensate``'s prototypes and
    functions: the drift model's, or with a ``"scale_factor"`` entry the input rate's
    (``{prefix}_compensate``, ``{prefix}_drift_at``, ``{prefix}_beyond_input_rates``)."""
    names = {"prefix": prefix, "PREFIX": prefix.upper()}
    scale = spec.get("scale_factor")
    if scale is None:
        return {
            "output_note": OUTPUT_NOTE.substitute(names, n_outputs=spec["n_outputs"]),
            "scale_define": "",
            "compensate_prototype": COMPENSATE_PROTOTYPE.substitute(names),
            "compensate_function": COMPENSATE_FUNCTION.substitute(names),
        }
    low, high = (float(value) for value in scale["input_rate_range"])
    # The slack in deg/h, as the pipeline computes it (share times the larger magnitude).
    slack = scale["slack"] * max(abs(low), abs(high))
    return {
        "output_note": SCALE_OUTPUT_NOTE.substitute(
            names, column=c_comment(repr(scale["input_rate"]))
        ),
        "scale_define": SCALE_DEFINE.substitute(
            names,
            share=f"{scale['slack']:g}",
            low=format_c_literal(low),
            high=format_c_literal(high),
            slack=format_c_literal(slack),
            asymmetry=format_c_literal(float(scale.get("asymmetry", 0.0))),
        ),
        "compensate_prototype": SCALE_PROTOTYPES.substitute(names),
        "compensate_function": SCALE_FUNCTIONS.substitute(names),
    }
