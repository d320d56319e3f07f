"""The C of the Pipeline's steps after ThermalFeatures: one renderer per step ``op`` of the
export schema (:data:`RENDERERS`), and the final regressor's output-layer design
(:data:`DESIGNS`) that the recalibration adapts."""

import numpy as np


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


def _gaussian_layer(writer, tag, spec, source, phi, *, z_lines=(), phi_lines=()):
    """Emit the network's standardised inputs ``{tag}_z`` and its Gaussian activations into
    ``phi`` (as the Python network: the gain ``-0.5 / widths**2`` computed in float64).

    ``z_lines`` are declared after ``{tag}_z``, ``phi_lines`` before the activations' loop.
    Registers ``x_mean``, ``x_scale``, then (with Gaussian units) ``centers`` and ``gain``.
    """
    n_inputs = spec["n_inputs"]
    n_centers = len(spec["widths"])
    x_mean = writer.array(f"{tag}_x_mean", spec["x_mean"])
    x_scale = writer.array(f"{tag}_x_scale", spec["x_scale"])
    writer.emit(
        f"    {writer.real} {tag}_z[{n_inputs}];",
        *z_lines,
        f"    for (j = 0; j < {n_inputs}; ++j) {{",
        f"        {tag}_z[j] = ({source}[j] - {x_mean}[j]) / {x_scale}[j];",
        "    }",
    )
    if not n_centers:
        return
    centers = writer.array(f"{tag}_centers", spec["centers"])
    gains = -0.5 / np.square(np.asarray(spec["widths"], dtype=np.float64))
    gain = writer.array(f"{tag}_gain", gains)
    writer.emit(
        *phi_lines,
        f"    for (i = 0; i < {n_centers}; ++i) {{",
        f"        {writer.real} distance2 = {writer.literal(0.0)};",
        f"        for (j = 0; j < {n_inputs}; ++j) {{",
        f"            const {writer.real} difference = {tag}_z[j] - {centers}[i][j];",
        "            distance2 += difference * difference;",
        "        }",
        f"        {phi}[i] = {writer.exp}(distance2 * {gain}[i]);",
        "    }",
    )


def _rbf_network(writer, tag, spec, source, target):
    n_inputs, n_outputs = spec["n_inputs"], spec["n_outputs"]
    n_centers = len(spec["widths"])
    zero = writer.literal(0.0)
    tail = np.asarray(spec["tail_coef"], dtype=np.float64)
    has_tail = bool(np.any(tail != 0))
    phi_lines = (f"    {writer.real} {tag}_phi[{n_centers}];",)
    _gaussian_layer(writer, tag, spec, source, f"{tag}_phi", phi_lines=phi_lines)
    if n_centers:
        coef = writer.array(f"{tag}_coef", spec["coef"])
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
    _gaussian_layer(writer, tag, spec, source, "phi", z_lines=("    int column;",))
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


#: The C of each step ``op``: ``renderer(writer, tag, spec, source, target)``.
RENDERERS = {
    "center_scale": _center_scale,
    "multiply_add": _multiply_add,
    "polynomial": _polynomial,
    "linear": _linear,
    "rbf_network": _rbf_network,
}

#: The output-layer design of the final step: ``design(writer, tag, spec, source, degree)``.
DESIGNS = {"rbf_network": _rbf_design, "linear": _linear_design}
