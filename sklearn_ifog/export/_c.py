"""Export of a fitted compensation Pipeline to self-contained C99 (header + source)."""

import re
from pathlib import Path

import numpy as np

from sklearn_ifog._contract import get_term, uses_rate
from sklearn_ifog._io import write_text_files
from sklearn_ifog.export._spec import describe_pipeline
from sklearn_ifog.export._templates import HEADER, SOURCE

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

    def array(self, name, values, index_type=None):
        full = f"{self.prefix}_{name}"
        if full not in self.names:  # a second function reading the same parameters
            self.names.add(full)
            self.parameters.append(_array(full, values, self.real, self.precision, index_type))
        return full

    def literal(self, value):
        return format_c_literal(value, self.precision)

    def emit(self, *lines):
        self.lines.extend(lines)


def _features_body(features, prefix, real):
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
        assignment = f"features[column++] = ({real})({expression});"
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


def _adaptation_parts(writer, spec, prefix, adapt, forgetting, prior, degree):
    """Fields, prototypes and functions of the RLS recalibration (empty without ``adapt``)."""
    upper = prefix.upper()
    if adapt is None:
        return {
            "adapt_define": "",
            "adapt_fields": "",
            "adapt_prototypes": "",
            "adapt_init": "",
            "adapt_functions": "",
            "step_drift": f"    {prefix}_predict_features(features, drift);\n",
        }
    weights = np.asarray(prior["weights"], dtype=np.float64)
    covariance = np.asarray(prior["covariance"], dtype=np.float64)
    n_weights = weights.shape[0]
    parameters = [
        "/* Recalibration (RLS): initial output-layer weights and covariance. */\n"
        + _array(f"{prefix}_initial_weights", weights, "double", "double"),
        _array(f"{prefix}_initial_covariance", covariance, "double", "double"),
    ]
    parameters.append(
        f"static void {prefix}_drift(\n"
        f"    const {prefix}_state *state, const {prefix}_real features[{upper}_N_FEATURES],\n"
        f"    double phi_out[{upper}_N_WEIGHTS], {prefix}_real base[{upper}_N_OUTPUTS],\n"
        f"    {prefix}_real drift[{upper}_N_OUTPUTS]);\n"
    )
    writer.parameters.extend(parameters)
    trace0 = format_c_literal(float(np.trace(covariance)))
    lam = format_c_literal(forgetting)
    design_lines = []
    if adapt == "output":
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
    drift_lines = [
        f"    double phi[{upper}_N_WEIGHTS];",
        "    int i;",
        "    int k;",
    ]
    if adapt == "output":
        drift_lines += [
            f"    {prefix}_design(features, phi);",
            f"    for (k = 0; k < {upper}_N_OUTPUTS; ++k) {{",
            "        double total = 0.0;",
            f"        for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{",
            "            total += phi[i] * state->weights[i][k];",
            "        }",
            "        base[k] = 0.0;",
            f"        drift[k] = ({prefix}_real)total;",
            "    }",
        ]
    else:
        drift_lines += [
            "    phi[0] = 1.0;",
            "    (void)i;",
            f"    {prefix}_predict_features(features, base);",
            f"    for (k = 0; k < {upper}_N_OUTPUTS; ++k) {{",
            f"        drift[k] = ({prefix}_real)(base[k] + state->weights[0][k]);",
            "    }",
        ]
    functions = []
    if adapt == "output":
        functions.append(
            "\n/* The final regressor's output layer: the row its drift is linear in. */\n"
            f"static void {prefix}_design(\n"
            f"    const {prefix}_real features[{upper}_N_FEATURES],\n"
            f"    double phi[{upper}_N_WEIGHTS])\n"
            "{\n" + "\n".join(design_lines) + "\n}\n"
        )
    functions.append(
        f"""
/* Drift of one sample's features with the current (recalibrated) weights; phi: the
 * output-layer row, base: the fitted model's drift before the bias ("bias" mode). */
static void {prefix}_drift(
    const {prefix}_state *state, const {prefix}_real features[{upper}_N_FEATURES],
    double phi_out[{upper}_N_WEIGHTS], {prefix}_real base[{upper}_N_OUTPUTS],
    {prefix}_real drift[{upper}_N_OUTPUTS])
{{
{chr(10).join(drift_lines)}
    for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
        phi_out[i] = phi[i];
    }}
}}

void {prefix}_reset_adaptation({prefix}_state *state)
{{
    int i;
    int j;
    for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
        for (j = 0; j < {upper}_N_OUTPUTS; ++j) {{
            state->weights[i][j] = {prefix}_initial_weights[i][j];
        }}
        for (j = 0; j < {upper}_N_WEIGHTS; ++j) {{
            state->covariance[i][j] = {prefix}_initial_covariance[i][j];
        }}
    }}
    state->n_updates = 0;
    state->n_resets = 0;
}}

/* One recursive-least-squares update with forgetting (see {prefix}.h). */
static void {prefix}_rls(
    {prefix}_state *state, const double phi[{upper}_N_WEIGHTS],
    const double target[{upper}_N_OUTPUTS])
{{
    double p_phi[{upper}_N_WEIGHTS];
    double gain[{upper}_N_WEIGHTS];
    double error[{upper}_N_OUTPUTS];
    double quadratic = 0.0;
    double trace = 0.0;
    int positive = 1;
    int i;
    int j;
    for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
        double total = 0.0;
        for (j = 0; j < {upper}_N_WEIGHTS; ++j) {{
            total += state->covariance[i][j] * phi[j];
        }}
        p_phi[i] = total;
        quadratic += phi[i] * total;
    }}
    if (!isfinite(quadratic) || quadratic < 0.0) {{
        /* Not positive definite: back to the initial covariance. */
        quadratic = 0.0;
        for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
            double total = 0.0;
            for (j = 0; j < {upper}_N_WEIGHTS; ++j) {{
                state->covariance[i][j] = {prefix}_initial_covariance[i][j];
                total += state->covariance[i][j] * phi[j];
            }}
            p_phi[i] = total;
            quadratic += phi[i] * total;
        }}
        state->n_resets += 1;
    }}
    for (j = 0; j < {upper}_N_OUTPUTS; ++j) {{
        double total = 0.0;
        for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
            total += phi[i] * state->weights[i][j];
        }}
        error[j] = target[j] - total;
    }}
    for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
        gain[i] = p_phi[i] / ({lam} + quadratic);
        for (j = 0; j < {upper}_N_OUTPUTS; ++j) {{
            state->weights[i][j] += gain[i] * error[j];
        }}
    }}
    for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
        for (j = 0; j < {upper}_N_WEIGHTS; ++j) {{
            state->covariance[i][j] = (state->covariance[i][j] - gain[i] * p_phi[j]) / {lam};
        }}
    }}
    for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
        for (j = i + 1; j < {upper}_N_WEIGHTS; ++j) {{
            const double mean = 0.5 * (state->covariance[i][j] + state->covariance[j][i]);
            state->covariance[i][j] = mean;
            state->covariance[j][i] = mean;
        }}
        if (!(state->covariance[i][i] > 0.0) || !isfinite(state->covariance[i][i])) {{
            positive = 0;
        }}
        trace += state->covariance[i][i];
    }}
    if (!positive) {{
        for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
            for (j = 0; j < {upper}_N_WEIGHTS; ++j) {{
                state->covariance[i][j] = {prefix}_initial_covariance[i][j];
            }}
        }}
        state->n_resets += 1;
    }} else if (trace > {trace0}) {{
        const double shrink = {trace0} / trace;
        for (i = 0; i < {upper}_N_WEIGHTS; ++i) {{
            for (j = 0; j < {upper}_N_WEIGHTS; ++j) {{
                state->covariance[i][j] *= shrink;
            }}
        }}
    }}
    state->n_updates += 1;
}}

void {prefix}_adapt(
    {prefix}_state *state, double time, const double temperature[{upper}_N_SENSORS],
    const {prefix}_real rate[{upper}_N_OUTPUTS], const double reference[{upper}_N_OUTPUTS],
    {prefix}_real drift[{upper}_N_OUTPUTS])
{{
    {prefix}_real features[{upper}_N_FEATURES];
    {prefix}_real base[{upper}_N_OUTPUTS];
    double phi[{upper}_N_WEIGHTS];
    double target[{upper}_N_OUTPUTS];
    int k;
    {prefix}_features(state, time, temperature, features);
    {prefix}_drift(state, features, phi, base, drift);
    for (k = 0; k < {upper}_N_OUTPUTS; ++k) {{
        target[k] = ((double)rate[k] - reference[k]) - (double)base[k];
    }}
    {prefix}_rls(state, phi, target);
}}
"""
    )
    step_drift = (
        f"    {prefix}_real base[{upper}_N_OUTPUTS];\n"
        f"    double phi[{upper}_N_WEIGHTS];\n"
        f"    {prefix}_drift(state, features, phi, base, drift);\n"
    )
    return {
        "adapt_define": (
            f"#define {upper}_N_WEIGHTS {n_weights}\n"
            f"/* Forgetting factor of the recalibration. */\n"
            f"#define {upper}_FORGETTING {lam}\n"
        ),
        "adapt_fields": (
            '    /* Recalibration (recursive least squares, mode "' + adapt + '"): the output\n'
            "     * layer's weights and their covariance (over the noise variance), the\n"
            "     * references used and the covariance resets. */\n"
            f"    double weights[{upper}_N_WEIGHTS][{upper}_N_OUTPUTS];\n"
            f"    double covariance[{upper}_N_WEIGHTS][{upper}_N_WEIGHTS];\n"
            "    long n_updates;\n"
            "    long n_resets;\n"
        ),
        "adapt_prototypes": (
            "/* Return the recalibration to the fitted model (init does it; reset does not). */\n"
            f"void {prefix}_reset_adaptation({prefix}_state *state);\n\n"
            "/* One sample whose true rate is known: write its drift (as step does), then learn\n"
            " * from rate - reference (recursive least squares with forgetting). */\n"
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
        "features_body": _features_body(features, prefix, writer.real),
        "predict_body": "\n".join(predict_lines),
        "batch_time": "0.0" if time_column is None else "time[sample]",
        "batch_prelude": "    (void)time; /* the model differences per sample */\n"
        if time_column is None
        else "",
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
    ``forgetting``, same initial weights and covariance, same recursive least squares and
    guards, in fixed-size double arrays): ``{prefix}_adapt(&state, time, temperature, rate,
    reference, drift)`` compensates a sample whose true rate is known and then learns from
    it, ``{prefix}_step`` uses the recalibrated weights, ``{prefix}_reset`` (a new run)
    keeps them and ``{prefix}_reset_adaptation`` (called by ``{prefix}_init``) returns to
    the fitted model. Parameters are written with round-trip precision. The causal front
    end (differences of time and temperature, the exact first-order lags of the lag terms and
    of the smoothing, with fixed-size state arrays) is computed in double even for
    ``precision="float"``: differencing 0.01 °C steps of a 30 °C reading in single precision
    would alone cost about 1e-4 relative.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline
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
        needs ``precision="double"`` (a covariance updated in single precision soon loses
        its positive definiteness).
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
        On a bad ``precision`` or ``prefix``, a first step that is not ThermalFeatures, or a
        parameter that is not finite.

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
            "covariance is updated in double."
        )
    spec = describe_pipeline(pipeline)
    prior, degree = None, None
    if adapt is not None or forgetting != 0.999:
        from sklearn_ifog.streaming import StreamingCompensator

        # The same checks of adapt and forgetting, the same initial weights and covariance.
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
    unit keeps its own state and functions, so several can be linked together.

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
    >>> X = pd.DataFrame({"unit": ["A-1"] * 6 + ["B-2"] * 6, "time": np.tile(np.arange(6.0), 2)})
    >>> X["temperature"] = 20 + X["time"] ** 2 / 10
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
