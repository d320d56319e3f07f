"""Export of a fitted compensation Pipeline to self-contained C99 (header + source)."""

import math
import re
from pathlib import Path

import numpy as np

from sklearn_ifog._contract import get_term, uses_rate
from sklearn_ifog._io import write_text_files
from sklearn_ifog.export._spec import describe_pipeline
from sklearn_ifog.export._templates import (
    ADAPT_FUNCTIONS,
    BLEND_FUNCTION,
    CLIP_ONCE,
    CLIP_ROUNDS,
    DOMAIN_BEYOND,
    DOMAIN_BOX,
    DOMAIN_COMMENT,
    DOMAIN_DEFINE,
    DOMAIN_FIELDS,
    DOMAIN_FLAG,
    DOMAIN_GUARDED,
    DOMAIN_PRECISION,
    DOMAIN_PROJECT,
    DOMAIN_PROTOTYPES,
    HEADER,
    POLICY_TEXT,
    SOURCE,
    TEMPERATURE_DEFINE,
)

_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_VALUES_PER_LINE = 4


def format_c_literal(value, precision="double"):
    """A C floating literal that reads back to exactly ``value`` in the given precision.

    ``double``: Python's shortest round-trip ``repr`` (at most 17 significant digits).
    ``float``: the value rounded to single precision, written with 9 significant digits (the
    round-trip count for IEEE single) and an ``f`` suffix; values below the smallest normal
    float are written as zero so no compiler warns about an underflowing constant.

    Parameters
    ----------
    value : float
        A finite value.
    precision : {"double", "float"}, default="double"
        The C type the literal is for.

    Returns
    -------
    literal : str
        The C literal.

    Examples
    --------
    >>> from sklearn_ifog.export._c import format_c_literal
    >>> format_c_literal(0.1), format_c_literal(0.1, "float"), format_c_literal(2.0, "float")
    ('0.1', '0.100000001f', '2.0f')
    """
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"Cannot write {value!r} as a C literal: not finite.")
    if precision == "double":
        text = repr(value)
        if "e" not in text and "." not in text:
            text += ".0"
        return text
    if abs(value) > float(np.finfo(np.float32).max):
        raise ValueError(f"Cannot write {value!r} as a C float: it overflows single precision.")
    single = np.float32(value)
    if abs(single) < np.finfo(np.float32).tiny:
        single = np.float32(0.0)
    text = f"{float(single):.9g}"
    if "e" not in text and "." not in text:
        text += ".0"
    return text + "f"


def _array(name, values, real, precision, index_type=None):
    """A ``static const`` array definition (1-D or 2-D), values wrapped a few per line."""
    array = np.asarray(values)
    c_type = index_type or real
    dims = "".join(f"[{n}]" for n in array.shape)
    if index_type:
        cells = [str(int(v)) for v in array.ravel()]
    else:
        cells = [format_c_literal(v, precision) for v in array.ravel()]
    if array.ndim == 1:
        rows = [cells]
    else:
        width = array.shape[1]
        rows = [cells[i : i + width] for i in range(0, len(cells), width)]
    lines = []
    indent = "    " if array.ndim == 1 else "     "
    for row in rows:
        chunks = [
            ", ".join(row[i : i + _VALUES_PER_LINE]) for i in range(0, len(row), _VALUES_PER_LINE)
        ]
        body = f",\n{indent}".join(chunks)
        lines.append("    " + body if array.ndim == 1 else "    {" + body + "}")
    joined = ",\n".join(lines)
    return f"static const {c_type} {name}{dims} = {{\n{joined}\n}};\n"


def _comment(text):
    """User text (step and column names) made safe inside a C block comment."""
    return str(text).replace("*/", "* /").replace("\n", " ")


class _Writer:
    """Collects parameter arrays and body lines of the generated source."""

    def __init__(self, prefix, precision):
        self.prefix = prefix
        self.precision = precision
        self.real = f"{prefix}_real"
        self.exp = "exp" if precision == "double" else "expf"
        self.parameters = []
        self.names = set()
        self.lines = []

    def array(self, name, values, index_type=None, double=False):
        """A parameter array (``double``: in double whatever the precision)."""
        full = f"{self.prefix}_{name}"
        if full not in self.names:  # a second function reading the same parameters
            self.names.add(full)
            real, precision = ("double", "double") if double else (self.real, self.precision)
            self.parameters.append(_array(full, values, real, precision, index_type))
        return full

    def literal(self, value):
        return format_c_literal(value, self.precision)

    def emit(self, *lines):
        self.lines.extend(lines)


def _features_body(features, prefix):
    """ThermalFeatures' causal step in C: differences, exact lags, then the terms."""
    terms = features["terms"]
    taus = features["time_constants"]
    n_lags = len(taus)
    lags = f"{prefix.upper()}_N_LAGS"
    needs_delta = uses_rate(terms)
    needs_previous = needs_delta or n_lags > 0
    uses_time = features["time"] is not None and needs_previous
    smoothing = features["smoothing"]
    lines = ["    int sensor;", "    int column = 0;"]
    if n_lags:
        lines += [
            f"    double decay[{lags}] = {{0.0}};",
            f"    double gain[{lags}] = {{0.0}};",
            "    int k;",
        ]
    if uses_time:
        lines.append("    const double elapsed = time - state->last_time;")
    else:
        lines.append("    (void)time;")
    if n_lags:
        # One exact step of every first-order lag (_lags.lag_step): the coefficients are
        # shared by the sensors.
        lines += [
            "    if (state->has_history) {",
            f"        for (k = 0; k < {lags}; ++k) {{",
            f"            const double x = elapsed / {prefix}_time_constants[k];",
            "            decay[k] = exp(-x);",
            "            gain[k] = (x > 0.0) ? -expm1(-x) / x : 1.0;",
            "        }",
            "    }",
        ]
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
            lines += [
                f"            for (k = 0; k < {lags}; ++k) {{",
                "                deficit[k] = decay[k] * deficit[k] + gain[k] * change;",
                "            }",
            ]
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
        expression = term.c_expression
        if term.time_constant is not None:
            expression = expression.format(lag=taus.index(term.time_constant))
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


def _state_parts(features, prefix):
    """The state struct's lag fields, the reset of them, and the time-constant table."""
    taus = features["time_constants"]
    upper = prefix.upper()
    if not taus:
        return "", "", "", ""
    define = f"#define {upper}_N_LAGS {len(taus)}\n"
    field = (
        "    /* Deficit T - lag_tau(T) of each sensor at each time constant, degC. */\n"
        f"    double deficit[{upper}_N_SENSORS][{upper}_N_LAGS];\n"
    )
    reset = (
        "        {\n"
        "            int k;\n"
        f"            for (k = 0; k < {upper}_N_LAGS; ++k) {{\n"
        "                state->deficit[sensor][k] = 0.0;\n"
        "            }\n"
        "        }\n"
    )
    table = _array(f"{prefix}_time_constants", taus, "double", "double")
    table = "/* Time constants of the first-order lags, s. */\n" + table
    return define, field, reset, table


def _center_scale(writer, tag, spec, source, target):
    center = writer.array(f"{tag}_center", spec["center"])
    scale = writer.array(f"{tag}_scale", spec["scale"])
    writer.emit(
        f"    for (i = 0; i < {spec['n_inputs']}; ++i) {{",
        f"        {target}[i] = ({source}[i] - {center}[i]) / {scale}[i];",
        "    }",
    )


def _multiply_add(writer, tag, spec, source, target):
    multiply = writer.array(f"{tag}_multiply", spec["multiply"])
    add = writer.array(f"{tag}_add", spec["add"])
    writer.emit(
        f"    for (i = 0; i < {spec['n_inputs']}; ++i) {{",
        f"        {target}[i] = {source}[i] * {multiply}[i] + {add}[i];",
    )
    if spec["clip"] is not None:
        low, high = (writer.literal(v) for v in spec["clip"])
        writer.emit(
            f"        if ({target}[i] < {low}) {{",
            f"            {target}[i] = {low};",
            "        }",
            f"        if ({target}[i] > {high}) {{",
            f"            {target}[i] = {high};",
            "        }",
        )
    writer.emit("    }")


def _polynomial(writer, tag, spec, source, target):
    powers = writer.array(f"{tag}_powers", spec["powers"], index_type="int")
    one = writer.literal(1.0)
    writer.emit(
        f"    for (i = 0; i < {spec['n_outputs']}; ++i) {{",
        f"        {writer.real} product = {one};",
        f"        for (j = 0; j < {spec['n_inputs']}; ++j) {{",
        "            int power;",
        f"            for (power = 0; power < {powers}[i][j]; ++power) {{",
        f"                product *= {source}[j];",
        "            }",
        "        }",
        f"        {target}[i] = product;",
        "    }",
    )


def _linear(writer, tag, spec, source, target):
    coef = writer.array(f"{tag}_coef", spec["coef"])
    intercept = writer.array(f"{tag}_intercept", spec["intercept"])
    zero = writer.literal(0.0)
    writer.emit(
        f"    for (i = 0; i < {spec['n_outputs']}; ++i) {{",
        f"        {writer.real} total = {zero};",
        f"        for (j = 0; j < {spec['n_inputs']}; ++j) {{",
        f"            total += {coef}[i][j] * {source}[j];",
        "        }",
        f"        {target}[i] = total + {intercept}[i];",
        "    }",
    )


def _rbf_network(writer, tag, spec, source, target):
    n_inputs, n_outputs = spec["n_inputs"], spec["n_outputs"]
    n_centers = len(spec["widths"])
    zero = writer.literal(0.0)
    x_mean = writer.array(f"{tag}_x_mean", spec["x_mean"])
    x_scale = writer.array(f"{tag}_x_scale", spec["x_scale"])
    tail = np.asarray(spec["tail_coef"], dtype=np.float64)
    has_tail = bool(np.any(tail != 0))
    writer.emit(
        f"    {writer.real} {tag}_z[{n_inputs}];",
        f"    for (j = 0; j < {n_inputs}; ++j) {{",
        f"        {tag}_z[j] = ({source}[j] - {x_mean}[j]) / {x_scale}[j];",
        "    }",
    )
    if n_centers:
        centers = writer.array(f"{tag}_centers", spec["centers"])
        # Same constant as the Python network: -0.5 / widths**2, computed in float64.
        gains = -0.5 / np.square(np.asarray(spec["widths"], dtype=np.float64))
        gain = writer.array(f"{tag}_gain", gains)
        coef = writer.array(f"{tag}_coef", spec["coef"])
        writer.emit(
            f"    {writer.real} {tag}_phi[{n_centers}];",
            f"    for (i = 0; i < {n_centers}; ++i) {{",
            f"        {writer.real} distance2 = {zero};",
            f"        for (j = 0; j < {n_inputs}; ++j) {{",
            f"            const {writer.real} difference = {tag}_z[j] - {centers}[i][j];",
            "            distance2 += difference * difference;",
            "        }",
            f"        {tag}_phi[i] = {writer.exp}(distance2 * {gain}[i]);",
            "    }",
        )
    intercept = writer.array(f"{tag}_intercept", spec["intercept"])
    writer.emit(
        f"    for (i = 0; i < {n_outputs}; ++i) {{",
        f"        {writer.real} total = {zero};",
    )
    if n_centers:
        writer.emit(
            f"        for (j = 0; j < {n_centers}; ++j) {{",
            f"            total += {coef}[i][j] * {tag}_phi[j];",
            "        }",
        )
    if has_tail:
        tail_name = writer.array(f"{tag}_tail_coef", tail)
        writer.emit(
            f"        for (j = 0; j < {n_inputs}; ++j) {{",
            f"            total += {tail_name}[i][j] * {tag}_z[j];",
            "        }",
        )
        if spec["tail_degree"] == 2:
            # Then the monomials z[a] z[b], a <= b, row-major (PolynomialFeatures' order).
            writer.emit(
                "        {",
                f"            int column = {n_inputs};",
                "            int a;",
                f"            for (a = 0; a < {n_inputs}; ++a) {{",
                f"                for (j = a; j < {n_inputs}; ++j) {{",
                f"                    total += {tail_name}[i][column++] * "
                f"({tag}_z[a] * {tag}_z[j]);",
                "                }",
                "            }",
                "        }",
            )
    writer.emit(f"        {target}[i] = total + {intercept}[i];", "    }")


def _rbf_design(writer, tag, spec, source, degree):
    """The RBF network's output-layer design ``[phi(z), t(z), 1]`` into ``phi`` (double)."""
    n_inputs = spec["n_inputs"]
    n_centers = len(spec["widths"])
    zero = writer.literal(0.0)
    x_mean = writer.array(f"{tag}_x_mean", spec["x_mean"])
    x_scale = writer.array(f"{tag}_x_scale", spec["x_scale"])
    writer.emit(
        f"    {writer.real} {tag}_z[{n_inputs}];",
        "    int column;",
        f"    for (j = 0; j < {n_inputs}; ++j) {{",
        f"        {tag}_z[j] = ({source}[j] - {x_mean}[j]) / {x_scale}[j];",
        "    }",
    )
    if n_centers:
        centers = writer.array(f"{tag}_centers", spec["centers"])
        gains = -0.5 / np.square(np.asarray(spec["widths"], dtype=np.float64))
        gain = writer.array(f"{tag}_gain", gains)
        writer.emit(
            f"    for (i = 0; i < {n_centers}; ++i) {{",
            f"        {writer.real} distance2 = {zero};",
            f"        for (j = 0; j < {n_inputs}; ++j) {{",
            f"            const {writer.real} difference = {tag}_z[j] - {centers}[i][j];",
            "            distance2 += difference * difference;",
            "        }",
            f"        phi[i] = {writer.exp}(distance2 * {gain}[i]);",
            "    }",
        )
    writer.emit(f"    column = {n_centers};")
    if degree >= 1:
        writer.emit(
            f"    for (j = 0; j < {n_inputs}; ++j) {{",
            f"        phi[column++] = {tag}_z[j];",
            "    }",
        )
    if degree == 2:
        writer.emit(
            f"    for (i = 0; i < {n_inputs}; ++i) {{",
            f"        for (j = i; j < {n_inputs}; ++j) {{",
            f"            phi[column++] = {tag}_z[i] * {tag}_z[j];",
            "        }",
            "    }",
        )
    writer.emit("    phi[column] = 1.0;")


def _linear_design(writer, tag, spec, source, degree):
    """A linear model's output-layer design: its inputs, then 1."""
    writer.emit(
        f"    for (j = 0; j < {spec['n_inputs']}; ++j) {{",
        f"        phi[j] = {source}[j];",
        "    }",
        f"    phi[{spec['n_inputs']}] = 1.0;",
    )


_DESIGNS = {"rbf_network": _rbf_design, "linear": _linear_design}


def _drift_lines(prefix, adapt, domain):
    """The body of the recalibrated ``{prefix}_drift``: the model, then the domain's policy.

    ``"output"``: the recalibrated output layer at the row the policy evaluates (``"clip"``:
    the domain's edge), then ``"blend"``'s fallback; ``"bias"``: the fitted model under the
    policy, then the offset (added after the policy).
    """
    upper = prefix.upper()
    lines = [
        f"    double phi[{upper}_N_WEIGHTS];",
        "    int i;",
        "    int k;",
        "    int outside = 0;",
    ]
    if adapt == "output":
        if domain is None:
            lines += [
                "    *distance = 0.0;",
                f"    {prefix}_design(features, phi);",
            ]
        else:
            lines[:0] = [f"    double evaluated[{upper}_N_FEATURES];"]
            lines += [
                f"    outside = {prefix}_domain(features, evaluated, distance);",
                f"    {prefix}_design(evaluated, phi);",
            ]
        lines += [
            f"    for (k = 0; k < {upper}_N_OUTPUTS; ++k) {{",
            "        double total = 0.0;",
            f"        for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{",
            "            total += phi[i] * state->weights[i][k];",
            "        }",
            "        base[k] = 0.0;",
            f"        drift[k] = ({prefix}_real)total;",
            "    }",
        ]
        if domain is not None and domain["outside"] == "blend":
            lines += [
                "    if (outside) {",
                f"        {prefix}_blend(features, *distance, drift);",
                "    }",
            ]
        return lines
    lines += ["    phi[0] = 1.0;", "    (void)i;"]
    if domain is None:
        lines += [
            "    *distance = 0.0;",
            f"    {prefix}_evaluate(features, base);",
        ]
    else:
        lines.append(f"    outside = {prefix}_guarded(features, base, distance);")
    return [
        *lines,
        f"    for (k = 0; k < {upper}_N_OUTPUTS; ++k) {{",
        f"        drift[k] = ({prefix}_real)(base[k] + state->weights[0][k]);",
        "    }",
    ]


def _record_domain(domain, call):
    """Lines that store a sample's distance and flag in the state (``call``: the flag)."""
    if domain is None:
        return f"    (void){call};\n"
    return f"    state->last_outside = {call};\n    state->last_distance = distance;\n"


def _adaptation_parts(writer, spec, prefix, adapt, forgetting, prior, degree):
    """Fields, prototypes and functions of the RLS recalibration (empty without ``adapt``)."""
    upper = prefix.upper()
    domain = spec.get("domain")
    if adapt is None:
        if domain is None:
            step_drift = f"    {prefix}_evaluate(features, drift);\n"
        else:
            step_drift = "    double distance;\n" + _record_domain(
                domain, f"{prefix}_guarded(features, drift, &distance)"
            )
        return {
            "adapt_define": "",
            "adapt_fields": "",
            "adapt_prototypes": "",
            "adapt_init": "",
            "adapt_functions": "",
            "step_drift": step_drift,
        }
    weights = np.asarray(prior["weights"], dtype=np.float64)
    factor = np.asarray(prior["factor"], dtype=np.float64)
    n_weights = weights.shape[0]
    writer.parameters += [
        "/* Recalibration (RLS): initial output-layer weights and the factor S0 of the initial\n"
        " * covariance P0 = S0 S0' (Cholesky). */\n"
        + _array(f"{prefix}_initial_weights", weights, "double", "double"),
        _array(f"{prefix}_initial_factor", factor, "double", "double"),
        f"static int {prefix}_drift(\n"
        f"    const {prefix}_state *state, const double features[{upper}_N_FEATURES],\n"
        f"    double phi_out[{upper}_N_WEIGHTS], {prefix}_real base[{upper}_N_OUTPUTS],\n"
        f"    {prefix}_real drift[{upper}_N_OUTPUTS], double *distance);\n",
    ]
    lam = format_c_literal(forgetting)
    functions = []
    if adapt == "output":
        functions.append(_design_function(writer, spec, prefix, degree))
    functions.append(
        ADAPT_FUNCTIONS.substitute(
            prefix=prefix,
            PREFIX=upper,
            lam=lam,
            sqrt_lam=format_c_literal(math.sqrt(forgetting)),
            trace0=format_c_literal(float(prior["trace"])),
            drift_lines="\n".join(_drift_lines(prefix, adapt, domain)),
            record_domain="" if domain is None else _record_domain(domain, "outside"),
        )
    )
    step_drift = (
        f"    {prefix}_real base[{upper}_N_OUTPUTS];\n"
        f"    double phi[{upper}_N_WEIGHTS];\n"
        "    double distance;\n"
    ) + _record_domain(domain, f"{prefix}_drift(state, features, phi, base, drift, &distance)")
    outside_rule = (
        ""
        if domain is None
        else "\n * A sample outside the calibration domain is compensated by its policy and not\n"
        ' * learnt from (state.last_outside is 1; the "bias" offset is added after the policy).'
    )
    return {
        "adapt_define": (
            f"#define {upper}_N_WEIGHTS {n_weights}\n"
            f"/* Forgetting factor of the recalibration. */\n"
            f"#define {upper}_FORGETTING {lam}\n"
        ),
        "adapt_fields": (
            '    /* Recalibration (recursive least squares, mode "' + adapt + '"): the output\n'
            "     * layer's weights, the factor S of their covariance P = S S' (over the\n"
            "     * noise variance), the references used and the factor's resets. */\n"
            f"    double weights[{upper}_N_WEIGHTS][{upper}_N_OUTPUTS];\n"
            f"    double covariance_factor[{upper}_N_WEIGHTS][{upper}_N_WEIGHTS];\n"
            "    long n_updates;\n"
            "    long n_resets;\n"
        ),
        "adapt_prototypes": (
            "/* Return the recalibration to the fitted model (init does it; reset does not). */\n"
            f"void {prefix}_reset_adaptation({prefix}_state *state);\n\n"
            "/* One sample whose true rate is known: write its drift (as step does), then learn\n"
            " * from rate - reference (recursive least squares with forgetting)."
            f"{outside_rule} */\n"
            f"void {prefix}_adapt(\n"
            f"    {prefix}_state *state, double time,\n"
            f"    const double temperature[{upper}_N_SENSORS],\n"
            f"    const {prefix}_real rate[{upper}_N_OUTPUTS],\n"
            f"    const double reference[{upper}_N_OUTPUTS],\n"
            f"    {prefix}_real drift[{upper}_N_OUTPUTS]);\n\n"
        ),
        "adapt_init": f"    {prefix}_reset_adaptation(state);\n",
        "adapt_functions": "".join(functions),
        "step_drift": step_drift,
    }


def _design_function(writer, spec, prefix, degree):
    """``{prefix}_design``: the final regressor's output-layer row of a row of features."""
    upper = prefix.upper()
    saved, writer.lines = writer.lines, []
    steps = spec["steps"]
    for k, step in enumerate(steps[:-1], start=1):
        writer.emit(f"    {writer.real} x{k}[{step['n_outputs']}];")
    buffers = ["features"] + [f"x{k}" for k in range(1, len(steps))]
    for k, step in enumerate(steps[:-1]):
        _RENDERERS[step["op"]](writer, f"step{k}", step, buffers[k], buffers[k + 1])
    last = steps[-1]
    _DESIGNS[last["op"]](writer, f"step{len(steps) - 1}", last, buffers[-1], degree)
    design_lines = ["    int i;", "    int j;", *writer.lines, "    (void)i;", "    (void)j;"]
    writer.lines = saved
    return (
        "\n/* The final regressor's output layer: the row its drift is linear in. */\n"
        f"static void {prefix}_design(\n"
        f"    const double features[{upper}_N_FEATURES],\n"
        f"    double phi[{upper}_N_WEIGHTS])\n"
        "{\n" + "\n".join(design_lines) + "\n}\n"
    )


def _fallback_text(domain, feature_names):
    """The "blend" fallback in words, for the header comment."""
    fallback = domain["fallback"]
    if fallback["column"] is None or not any(fallback["slope"]):
        return "a constant, the calibration's mean drift"
    name = _comment(feature_names[fallback["column"]])
    return f"a line in the feature {name}"


def _domain_functions(writer, domain, prefix):
    """The C functions of the calibration domain, for its policy (see _templates)."""
    names = {"prefix": prefix, "PREFIX": prefix.upper()}
    policy = domain["outside"]
    for key in ("center", "scale", "axes", "axis_scale", "lower", "upper"):
        writer.array(f"domain_{key}", domain[key], double=True)
    parts = [DOMAIN_BOX.substitute(names)]
    beyond_test, clip_block, blend_call = "", "", ""
    if domain["temperature_columns"]:
        writer.array("temperature_columns", domain["temperature_columns"], index_type="int")
        writer.array("temperature_low", domain["temperature_low"], double=True)
        writer.array("temperature_high", domain["temperature_high"], double=True)
        parts.append(DOMAIN_BEYOND.substitute(names))
        beyond_test = f" && !{prefix}_beyond(features)"
    if policy == "clip":
        parts.append(DOMAIN_PROJECT.substitute(names))
        rounds = CLIP_ROUNDS if domain["temperature_columns"] else CLIP_ONCE
        clip_block = rounds.substitute(names)
    parts.append(DOMAIN_FLAG.substitute(names, beyond_test=beyond_test, clip_block=clip_block))
    if policy == "blend":
        fallback = domain["fallback"]
        intercept = writer.array("fallback_intercept", fallback["intercept"], double=True)
        expression, unused = f"{intercept}[k]", "    (void)features;\n"
        if fallback["column"] is not None:
            slope = writer.array("fallback_slope", fallback["slope"], double=True)
            expression += f" + features[{fallback['column']}] * {slope}[k]"
            unused = ""
        parts.append(BLEND_FUNCTION.substitute(names, fallback=expression, unused=unused))
        blend_call = (
            f"    if (outside) {{\n        {prefix}_blend(features, *distance, drift);\n    }}\n"
        )
    parts.append(DOMAIN_GUARDED.substitute(names, blend_call=blend_call))
    return "".join(parts)


def _domain_parts(writer, spec, prefix, adapt):
    """Header text, state fields and functions of the calibration domain.

    Without a domain (a plain Pipeline) only ``{PREFIX}_HAS_DOMAIN 0`` is written.
    """
    upper = prefix.upper()
    domain = spec.get("domain")
    if domain is None:
        empty = ("domain_comment", "domain_fields", "domain_reset", "domain_prototypes")
        return {
            **dict.fromkeys(empty, ""),
            "domain_define": f"#define {upper}_HAS_DOMAIN 0\n",
            "domain_functions": "",
            "domain_precision": "",
            "predict_features_body": f"    {prefix}_evaluate(row, drift);\n",
            "policy_note": "",
        }
    names = {"prefix": prefix, "PREFIX": upper, "policy": domain["outside"]}
    feature_names = spec["features"]["feature_names"]
    temperatures = domain["temperature_columns"]
    temperature_define = temperature_note = ""
    if temperatures:
        temperature_define = TEMPERATURE_DEFINE.substitute(
            names, n_temperatures=len(temperatures), rounds=domain["projection_rounds"]
        )
        listed = _comment(", ".join(feature_names[column] for column in temperatures))
        temperature_note = (
            f",\n * or when a temperature ({listed}) lies beyond its calibrated range (by any\n"
            " * amount)"
        )
    description = POLICY_TEXT[domain["outside"]].substitute(
        PREFIX=upper, fallback=_fallback_text(domain, feature_names)
    )
    return {
        "domain_define": DOMAIN_DEFINE.substitute(
            names,
            margin=format_c_literal(domain["margin"]),
            blend_width=format_c_literal(domain["blend_width"]),
            temperature_define=temperature_define,
        ),
        "domain_comment": DOMAIN_COMMENT.substitute(
            names,
            description=description,
            temperature_note=temperature_note,
            adapt_note="" if adapt is None else f" (or {prefix}_adapt)",
        ),
        "domain_fields": DOMAIN_FIELDS.substitute(names),
        "domain_reset": "    state->last_distance = 0.0;\n    state->last_outside = 0;\n",
        "domain_prototypes": DOMAIN_PROTOTYPES.substitute(names),
        "domain_functions": _domain_functions(writer, domain, prefix),
        "domain_precision": DOMAIN_PRECISION,
        "predict_features_body": (
            f"    double distance;\n    (void){prefix}_guarded(row, drift, &distance);\n"
        ),
        "policy_note": ", then the calibration domain's policy",
    }


_RENDERERS = {
    "center_scale": _center_scale,
    "multiply_add": _multiply_add,
    "polynomial": _polynomial,
    "linear": _linear,
    "rbf_network": _rbf_network,
}


def render_c(
    spec,
    prefix="ifog",
    precision="double",
    *,
    adapt=None,
    forgetting=0.999,
    prior=None,
    degree=None,
):
    """Render the export schema's dict as C99 header and source text.

    Parameters
    ----------
    spec : dict
        The output of :func:`sklearn_ifog.export._spec.describe_pipeline`.
    prefix : str, default="ifog"
        Prefix of every public C name and of the file names.
    precision : {"double", "float"}, default="double"
        Type of the parameters and of the network arithmetic.

    Returns
    -------
    header, source : str
        The contents of ``{prefix}.h`` and ``{prefix}.c``.
    """
    writer = _Writer(prefix, precision)
    steps = spec["steps"]
    buffers = ["features"] + [f"x{k}" for k in range(1, len(steps))] + ["drift"]
    for k, step in enumerate(steps[:-1], start=1):
        writer.emit(f"    {writer.real} x{k}[{step['n_outputs']}];")
    for k, step in enumerate(steps):
        writer.emit(f"    /* {_comment(step['name'])}: {step['class']} */")
        _RENDERERS[step["op"]](writer, f"step{k}", step, buffers[k], buffers[k + 1])
    # The last step (linear or RBF network) always loops over both indices.
    predict_lines = ["    int i;", "    int j;", *writer.lines]
    features = spec["features"]
    pipeline_lines = [" *   ThermalFeatures"] + [
        f" *   -> {_comment(step['name'])} ({step['class']})" for step in steps
    ]
    time_column = features["time"]
    lag_define, lag_field, lag_reset, lag_table = _state_parts(features, prefix)
    domain = _domain_parts(writer, spec, prefix, adapt)
    adaptation = _adaptation_parts(writer, spec, prefix, adapt, forgetting, prior, degree)
    fields = {
        "prefix": prefix,
        "PREFIX": prefix.upper(),
        "guard": f"{prefix.upper()}_H",
        "generator": spec["generator"],
        "pipeline_lines": "\n".join(pipeline_lines),
        "real": precision,
        "n_sensors": len(features["temperature"]),
        "n_features": spec["n_features"],
        "n_outputs": spec["n_outputs"],
        "sensor_list": _comment(", ".join(str(column) for column in features["temperature"])),
        "feature_list": _comment(", ".join(features["feature_names"])),
        "time_note": (
            " (ignored: the model differences per sample)"
            if time_column is None
            else f" (column {_comment(str(time_column))})"
        ),
        "time_null": " (may be NULL)" if time_column is None else "",
        "parameters": "\n".join(
            [lag_table, *writer.parameters] if lag_table else writer.parameters
        ),
        "lag_define": lag_define,
        "lag_field": lag_field,
        "lag_reset": lag_reset,
        "features_body": _features_body(features, prefix),
        "predict_body": "\n".join(predict_lines),
        "batch_time": "0.0" if time_column is None else "time[sample]",
        "batch_prelude": "    (void)time; /* the model differences per sample */\n"
        if time_column is None
        else "",
        **domain,
        **adaptation,
    }
    return HEADER.substitute(fields), SOURCE.substitute(fields)


def to_c(pipeline, directory, precision="double", prefix="ifog", *, adapt=None, forgetting=0.999):
    """Write a fitted compensation Pipeline as a self-contained C99 header and source.

    The generated ``{prefix}.h`` / ``{prefix}.c`` need nothing beyond ``<math.h>`` and
    allocate no memory. They provide a state struct ``{prefix}_state`` with
    ``{prefix}_init`` / ``{prefix}_reset`` (at the start of every run), the streaming
    ``{prefix}_step`` (one sample in, the drift out) and ``{prefix}_compensate``, the batch
    ``{prefix}_batch`` (one whole run, with the fitted model), and
    ``{prefix}_predict_features`` (the stateless part after ThermalFeatures, fitted model).

    With ``adapt``, the state also carries the online recalibration of
    :class:`~sklearn_ifog.streaming.StreamingCompensator` (same ``adapt`` and
    ``forgetting``, same initial weights and covariance factor, same square-root RLS and
    guards, in fixed-size double arrays): ``{prefix}_adapt(&state, time, temperature, rate,
    reference, drift)`` compensates a sample whose true rate is known and then learns from
    it, ``{prefix}_step`` uses the recalibrated weights, ``{prefix}_reset`` (a new run)
    keeps them and ``{prefix}_reset_adaptation`` (called by ``{prefix}_init``) returns to
    the fitted model. Parameters are written with round-trip precision. The causal front
    end (differences of time and temperature, the exact first-order lags of the lag terms and
    of the smoothing, with fixed-size state arrays) is computed in double even for
    ``precision="float"``: differencing 0.01 °C steps of a 30 °C reading in single precision
    would alone cost about 1e-4 relative.

    A :class:`~sklearn_ifog.pipeline.CompensationPipeline` also brings its calibration domain
    and ``outside`` policy (``{PREFIX}_HAS_DOMAIN`` is 1; 0 for a plain Pipeline): every
    sample's distance outside the domain and its flag, as ``calibration_distance`` and
    ``outside_calibration`` give them, and its drift under the same policy as ``predict``
    (``"blend"``, ``"clip"`` or ``"none"``, with the pipeline's ``margin`` and the current
    :data:`~sklearn_ifog.domain.BLEND_WIDTH`). After ``{prefix}_step``,
    ``{prefix}_compensate`` or ``{prefix}_adapt``, ``state.last_distance`` and
    ``state.last_outside`` hold the sample's distance and flag;
    ``{prefix}_calibration_distance(features)`` is the stateless distance and
    ``{prefix}_predict_features`` applies the policy. The domain is computed in double
    whatever the precision. With ``adapt``, a sample outside the domain is compensated by
    the policy and does not update the recalibration, and the ``"bias"`` offset is added
    after the policy (the rule of :class:`~sklearn_ifog.streaming.StreamingCompensator`).

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline or CompensationPipeline
        Fitted: :class:`~sklearn_ifog.ThermalFeatures`, then any of StandardScaler,
        RobustScaler, MaxAbsScaler, MinMaxScaler, PolynomialFeatures (or "passthrough"), then
        a :class:`~sklearn_ifog.RBFNetRegressor` or a linear regressor (LinearRegression,
        Ridge, Lasso, ElasticNet, BayesianRidge, HuberRegressor, ... and their CV forms).
    directory : str or path-like
        Where to write the two files (created if missing).
    precision : {"double", "float"}, default="double"
        C type of the parameters and of the network arithmetic.
    prefix : str, default="ifog"
        A C identifier: prefix of every generated name and the files' base name.
    adapt : {None, "bias", "output"}, default=None
        Online recalibration (see :class:`~sklearn_ifog.streaming.StreamingCompensator`);
        needs ``precision="double"`` (the initial covariance spans eight orders of
        magnitude: single precision cannot carry it).
    forgetting : float, default=0.999
        Forgetting factor of the recalibration, in (0, 1].

    Returns
    -------
    header, source : pathlib.Path
        The paths written.

    Raises
    ------
    TypeError
        If a step is of a type the exporter does not know (the message names the step).
    ValueError
        On a bad ``precision`` or ``prefix``, a first step that is not ThermalFeatures, a
        parameter that is not finite, or a CompensationPipeline whose ``outside`` or
        ``margin`` is not one it could predict with.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn_ifog import ThermalFeatures
    >>> from sklearn_ifog.export import to_c
    >>> X = np.column_stack([np.arange(6.0), 20 + np.arange(6.0) ** 2 / 10])
    >>> model = make_pipeline(ThermalFeatures(temperature=1, time=0), LinearRegression())
    >>> model = model.fit(X, X[:, 1] / 100)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     header, source = to_c(model, directory)
    ...     print(header.name, source.name, "ifog_step" in source.read_text())
    ifog.h ifog.c True

    A CompensationPipeline brings its calibration domain, its flag and its policy:

    >>> from sklearn_ifog import make_compensation_pipeline
    >>> model = make_compensation_pipeline(
    ...     LinearRegression(), temperature=1, time=0, run=None, terms=("T", "dT"), outside="clip"
    ... ).fit(X, X[:, 1] / 100)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     text = to_c(model, directory)[0].read_text()
    >>> "#define IFOG_HAS_DOMAIN 1" in text, "int last_outside;" in text
    (True, True)
    """
    if precision not in ("double", "float"):
        raise ValueError(f"precision must be 'double' or 'float', got {precision!r}.")
    if not isinstance(prefix, str) or not _IDENTIFIER.match(prefix):
        raise ValueError(
            f"prefix must be a C identifier (a letter, then letters, digits or '_'), "
            f"got {prefix!r}."
        )
    if adapt is not None and precision != "double":
        raise ValueError(
            f"adapt={adapt!r} needs precision='double', got {precision!r}: the recalibration's "
            "covariance factor is updated in double."
        )
    spec = describe_pipeline(pipeline)
    prior, degree = None, None
    if adapt is not None or forgetting != 0.999:
        from sklearn_ifog.streaming import StreamingCompensator

        # The same checks of adapt and forgetting, the same initial weights and factor.
        compensator = StreamingCompensator(pipeline, adapt=adapt, forgetting=forgetting)
        prior = compensator._prior
        if compensator.compiled:
            degree = getattr(compensator._compiled.final, "degree", None)
    header_text, source_text = render_c(
        spec,
        prefix=prefix,
        precision=precision,
        adapt=adapt,
        forgetting=float(forgetting),
        prior=prior,
        degree=degree,
    )
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    header = directory / f"{prefix}.h"
    source = directory / f"{prefix}.c"
    write_text_files({header: header_text, source: source_text})
    return header, source


def _unit_identifier(unit):
    """A unit label as the tail of a C identifier: letters, digits and '_' only."""
    text = re.sub(r"[^A-Za-z0-9_]", "_", str(unit))
    return text or "_"


def to_c_units(model, directory, precision="double", prefix="ifog"):
    """Write every unit of a fitted :class:`~sklearn_ifog.UnitwiseRegressor` as C99.

    One header and one source per unit, each exactly what :func:`to_c` writes for that
    unit's model, with the prefix ``{prefix}_unit_{unit}`` (characters of the unit label
    that cannot be in a C identifier become ``_``). Firmware flashes one gyro's pair; every
    unit keeps its own state and functions, so several can be linked together. A unit whose
    model is a :class:`~sklearn_ifog.pipeline.CompensationPipeline` carries that model's
    own calibration domain, fallback and ``outside`` policy, the ones its ``predict`` uses
    (:class:`~sklearn_ifog.UnitwiseRegressor` says which rows each unit's domain is fitted
    on).

    Parameters
    ----------
    model : UnitwiseRegressor
        Fitted; every unit's model must be a Pipeline :func:`to_c` accepts.
    directory : str or path-like
        Where to write the files (created if missing).
    precision : {"double", "float"}, default="double"
        As for :func:`to_c`.
    prefix : str, default="ifog"
        A C identifier: the start of every unit's prefix.

    Returns
    -------
    written : dict
        Unit -> ``(header, source)`` paths, in the order of ``model.units_``.

    Raises
    ------
    TypeError
        If ``model`` is not a fitted UnitwiseRegressor, or a unit's model is not exportable.
    ValueError
        As for :func:`to_c`, or when two unit labels give the same identifier.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> import pandas as pd
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn_ifog import ThermalFeatures, UnitwiseRegressor
    >>> from sklearn_ifog.export import to_c_units
    >>> time = np.tile(np.arange(30.0), 2)
    >>> X = pd.DataFrame({"unit": ["A-1"] * 30 + ["B-2"] * 30, "time": time})
    >>> X["temperature"] = 20 + X["time"] ** 2 / 100
    >>> pipe = make_pipeline(ThermalFeatures(time="time"), LinearRegression())
    >>> model = UnitwiseRegressor(pipe, pooling="none").fit(X, X["temperature"] / 100)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     written = to_c_units(model, directory)
    ...     print({unit: header.name for unit, (header, _) in written.items()})
    {'A-1': 'ifog_unit_A_1.h', 'B-2': 'ifog_unit_B_2.h'}
    """
    from sklearn.utils.validation import check_is_fitted

    from sklearn_ifog.unitwise import UnitwiseRegressor

    if not isinstance(model, UnitwiseRegressor):
        raise TypeError(
            f"to_c_units exports a UnitwiseRegressor, got {type(model).__name__}; use to_c."
        )
    check_is_fitted(model)
    if not isinstance(prefix, str) or not _IDENTIFIER.match(prefix):
        raise ValueError(
            f"prefix must be a C identifier (a letter, then letters, digits or '_'), "
            f"got {prefix!r}."
        )
    prefixes = {}
    for unit in model.estimators_:
        name = f"{prefix}_unit_{_unit_identifier(unit)}"
        if name in prefixes.values():
            other = next(key for key, value in prefixes.items() if value == name)
            raise ValueError(
                f"units {other!r} and {unit!r} give the same C identifier {name!r}; rename one."
            )
        prefixes[unit] = name
    if precision not in ("double", "float"):
        raise ValueError(f"precision must be 'double' or 'float', got {precision!r}.")
    rendered = {}
    for unit, name in prefixes.items():
        try:
            spec = describe_pipeline(model.estimators_[unit])
        except (TypeError, ValueError) as error:
            raise type(error)(f"unit {unit!r}: {error}") from error
        rendered[unit] = (name, *render_c(spec, prefix=name, precision=precision))
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    files, written = {}, {}
    for unit, (name, header_text, source_text) in rendered.items():
        header, source = directory / f"{name}.h", directory / f"{name}.c"
        files[header], files[source] = header_text, source_text
        written[unit] = (header, source)
    write_text_files(files)
    return written
