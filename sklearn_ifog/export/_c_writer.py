"""The pieces every part of the C generator writes with: literals, arrays, comments, the
collected parameters and body lines (:class:`Writer`)."""

import numpy as np

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


def c_array(name, values, real, precision, index_type=None):
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


def c_comment(text):
    """User text (step and column names) made safe inside a C block comment."""
    return str(text).replace("*/", "* /").replace("\n", " ")


class Writer:
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
            self.parameters.append(c_array(full, values, real, precision, index_type))
        return full

    def literal(self, value):
        return format_c_literal(value, self.precision)

    def emit(self, *lines):
        self.lines.extend(lines)
