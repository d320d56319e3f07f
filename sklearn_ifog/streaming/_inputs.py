"""The compensator's input checks: numbers, references, time order, a chunk's shapes.

Every check raises a ``ValueError`` naming the input (``temperature``, ``time``, ``rate``,
``reference``) and what was expected, before any state changes.
"""

import numbers

import numpy as np

from sklearn_ifog import _table


def is_number(value):
    """A real number that is not a bool (True is not a rate)."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def describe_value(value):
    """``value`` for an error message: a string as the string, anything else by its type."""
    if isinstance(value, (str, bytes)):
        return f"the string {value!r}"
    if isinstance(value, (bool, np.bool_)):
        return f"the boolean {value!r}"
    return f"{value!r} ({type(value).__name__})"


def number_array(values, label, unit, *, allow_none=False):
    """``values`` (a number, a sequence or an array) as float64, refusing what is not a number.

    Strings (even ``"1.0"``), booleans and other objects raise a ``ValueError`` naming
    ``label``, what was expected and the first bad entry: numpy would convert a numeric
    string, and a boolean mask passed for the values would be read as 0 and 1. With
    ``allow_none``, None entries are kept (an object array), for the caller to mark.
    """
    expected = f"{label} must hold numbers ({unit})"
    if isinstance(values, (str, bytes, bool, np.bool_)):
        raise ValueError(f"{expected}, got {describe_value(values)}.")
    raw = values.to_numpy() if hasattr(values, "to_numpy") else values
    try:
        array = np.asarray(raw)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{expected}, got an array numpy cannot read ({exc}).") from None
    kind = array.dtype.kind
    if kind in "iuf":
        return array.astype(np.float64, copy=False)
    if kind == "O":
        flat = array.reshape(-1)
        for index, value in enumerate(flat.tolist()):
            if not (is_number(value) or (allow_none and value is None)):
                row = np.unravel_index(index, array.shape)[0] if array.ndim else 0
                raise ValueError(f"{expected}, got {describe_value(value)} at row {row}.")
        if allow_none:
            return array
        return array.astype(np.float64)
    what = {"U": "strings", "S": "bytes", "b": "booleans", "c": "complex numbers"}.get(
        kind, f"values of dtype {array.dtype}"
    )
    first = array.reshape(-1)[0].item() if array.size else None
    example = "" if first is None else f" (first: {first!r})"
    raise ValueError(f"{expected}, got {what}{example}.")


def state_numbers(value, label, shape, axes=""):
    """A state entry as a finite float64 array of ``shape``; else a ``ValueError`` naming it."""
    try:
        array = None if value is None else np.asarray(value)
    except (TypeError, ValueError):
        array = None
    numeric = array is not None and array.dtype.kind in "iuf"
    if not numeric or array.shape != shape:
        got = value if not numeric else f"shape {array.shape}"
        if len(shape) == 0:
            raise ValueError(f"{label} must be a number, got {got!r}.")
        if len(shape) == 1:
            raise ValueError(f"{label} must hold {shape[0]} value(s) (numbers), got {got}.")
        axes = f" {axes}" if axes else ""
        raise ValueError(f"{label} must have shape {shape}{axes} of numbers, got {got}.")
    array = array.astype(np.float64)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{label} holds NaN or inf.")
    return array


def sensor_floats(values):
    """A sensor reading (a number or a sequence of numbers) as a list of Python floats."""
    if is_number(values):
        return [float(values)]
    return number_array(values, "temperature", "deg C").reshape(-1).tolist()


def reference_values(reference):
    """``(values, known)`` of a reference column: None or masked entries are unknown.

    Every known entry must be a number (not a string, even ``"1.0"``, nor a boolean): a
    ``ValueError`` naming ``reference`` otherwise.
    """
    if isinstance(reference, np.ma.MaskedArray):
        known = ~np.ma.getmaskarray(reference)
        data = number_array(np.ma.getdata(reference), "reference", "deg/h")
        values = np.where(known, data, 0.0)
    else:
        raw = number_array(reference, "reference", "deg/h", allow_none=True)
        if raw.dtype == object:
            known = np.vectorize(lambda value: value is not None, otypes=[bool])(raw)
            values = np.where(known, raw, 0.0).astype(np.float64)
        else:
            known = np.ones(raw.shape, dtype=bool)
            values = raw
    bad = known & ~np.isfinite(values)
    if bad.any():
        _table.check_finite(np.where(known, values, 0.0), "reference")
    return values, known


def check_increasing(time, state, offset):
    """Raise unless ``time`` (rows ``offset:`` of a chunk) continues the run strictly."""
    previous = state["last_time"] if state["has_history"] else None
    violation = _table.first_time_violation(time, previous=previous)
    if violation is not None:
        where = (
            "the current run (call reset() or give the run id at the start of a new run)"
            if state["run"] is None
            else f"run {state['run']!r}"
        )
        raise ValueError(
            f"time must increase strictly within {where}: row {offset + violation[0]} of the "
            "chunk is not after the previous sample."
        )


def check_chunk(temperature, time, rate, reference, *, n_sensors, sensors, time_column):
    """A chunk's arrays checked against each other and the model: ``(time, reference,
    has_reference)``.

    ``time`` becomes None when the model has no time column; ``reference`` is the
    ``(values, known)`` pair of :func:`reference_values` (or None), returned as the values
    and a flag per sample (a reference is given for every output of a sample, or for
    none).
    """
    n_samples = temperature.shape[0]
    if temperature.shape[1] != n_sensors:
        raise ValueError(
            f"Expected {n_sensors} temperature value(s) per sample (sensors "
            f"{sensors}), got {temperature.shape[1]}."
        )
    _table.check_finite(temperature, "temperature")
    if time_column is not None:
        if time is None:
            raise ValueError(f"The model needs the time column {time_column!r}.")
        _table.check_finite(time, "time")
    else:
        time = None
    if rate is not None:
        if rate.shape[0] != n_samples:
            raise ValueError(f"rate has {rate.shape[0]} rows, the samples {n_samples}.")
        _table.check_finite(rate, "rate")
    if reference is None:
        return time, None, None
    if rate is None:
        raise ValueError("reference needs the rate of the same samples (rate=None).")
    reference, has_reference = reference
    if reference.shape != rate.shape:
        raise ValueError(
            f"reference has shape {reference.shape}; rate has {rate.shape} (one "
            "reference per rate)."
        )
    has_reference = has_reference.reshape(n_samples, -1)
    if not np.all(has_reference == has_reference[:, :1]):
        raise ValueError("reference must be given for every output of a sample, or for none.")
    return time, reference, has_reference[:, 0]
