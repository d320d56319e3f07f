"""Thermal-test tables: columns, runs and time order, in one place.

Plain functions, numpy out, for numpy arrays and pandas / polars DataFrames:

- columns: :func:`as_table`, :func:`column_names`, :func:`column_at`, :func:`column_position`
  (strict, with an error naming the column and the parameter), :func:`find_column` (lenient),
  :func:`numeric_column`, :func:`label_column` (with :func:`check_ids`, :func:`id_kind` and
  :func:`plain_label` for the run and unit ids it holds), :func:`check_finite`, and
  :func:`read_thermal_columns` (the temperature, time and run columns of a thermal test);
- runs: :func:`run_codes`, :func:`group_rows_by_run` (a stable order that makes each run
  contiguous, however the runs are interleaved), :func:`run_segments` (the rows of each run,
  in order of first appearance), :func:`contiguous_runs` (stretches of constant run id, for a
  stream), :func:`per_run_mean`;
- time order: :func:`first_time_violation` and :func:`check_time_increasing`.

Errors are :class:`TableError` (a ``ValueError``; :class:`TableTypeError` is also a
``TypeError``) naming the column, the run and the row, with the row and the offending value as
attributes, so that a caller (the command line) can word them its own way.
"""

import contextlib
import itertools
import numbers
from typing import NamedTuple

import numpy as np
from sklearn.utils.validation import check_array

__all__ = [
    "TableError",
    "TableTypeError",
    "ThermalColumns",
    "as_float_rows",
    "as_table",
    "check_finite",
    "check_ids",
    "check_time_increasing",
    "column_at",
    "column_names",
    "column_position",
    "contiguous_runs",
    "find_column",
    "first_time_violation",
    "frame_kind",
    "group_rows_by_run",
    "id_kind",
    "label_column",
    "numeric_column",
    "per_run_mean",
    "plain_label",
    "read_thermal_columns",
    "run_codes",
    "run_segments",
]


class TableError(ValueError):
    """A bad column, run or row of a table; the message names it.

    Attributes
    ----------
    row : int or None
        Position in the input of the first offending row.
    value : object
        The offending value at ``row`` (None when there is none).
    previous_row : int or None
        For a time-order error: the row of the same run that ``row`` does not follow.
    run : object
        For a time-order error: the run id of ``row`` (None without runs).
    """

    def __init__(self, message, *, row=None, value=None, previous_row=None, run=None):
        super().__init__(message)
        self.row = row
        self.value = value
        self.previous_row = previous_row
        self.run = run


class TableTypeError(TableError, TypeError):
    """A column of the wrong type (e.g. text where numbers are expected)."""


def _scalar(value):
    """A numpy scalar as the Python scalar it holds."""
    return value.item() if isinstance(value, np.generic) else value


# ---------------------------------------------------------------------------------------------
# Columns
# ---------------------------------------------------------------------------------------------


def _library(obj):
    """ "pandas" or "polars" for their DataFrames and Series, None for anything else."""
    module = type(obj).__module__.split(".")[0]
    return module if module in ("pandas", "polars") else None


def frame_kind(X):
    """ "pandas" or "polars" for a DataFrame of that library, None for anything else.

    Parameters
    ----------
    X : object
        A table.

    Returns
    -------
    kind : {"pandas", "polars"} or None
        The DataFrame library.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from sklearn_ifog._table import frame_kind
    >>> frame_kind(pd.DataFrame({"a": [1]})), frame_kind(np.ones((1, 1)))
    ('pandas', None)
    """
    kind = _library(X)
    return kind if kind is not None and hasattr(X, "columns") else None


def as_float_rows(values):
    """A 2-D float array of a transformer's output (ndarray, pandas or polars)."""
    if hasattr(values, "to_numpy"):
        values = values.to_numpy()
    return np.asarray(values, dtype=np.float64)


def as_table(X):
    """A DataFrame as it is (no conversion), anything else as a 2-D array; non-empty.

    Parameters
    ----------
    X : {array-like, pandas.DataFrame, polars.DataFrame}
        The table. An array keeps its dtype (an object array, e.g. with string run ids,
        stays one).

    Returns
    -------
    table : DataFrame or ndarray of shape (n_samples, n_columns)
        The table.

    Raises
    ------
    ValueError
        If the table has no row or no column, or is not 2-D.
    TypeError
        If it is sparse.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._table import as_table
    >>> as_table(np.array([[20.0, "a"], [21.0, "b"]], dtype=object)).dtype
    dtype('O')
    """
    if frame_kind(X) is None:
        return check_array(
            X, dtype=None, accept_sparse=False, ensure_all_finite=False, input_name="X"
        )
    if X.shape[0] < 1 or X.shape[1] < 1:
        raise ValueError(
            f"Found array with {X.shape[0]} sample(s) and {X.shape[1]} feature(s) "
            f"(shape={X.shape}) while a minimum of 1 is required."
        )
    return X


def column_names(X):
    """The column names of a DataFrame as a list, None for an array.

    Parameters
    ----------
    X : {ndarray, pandas.DataFrame, polars.DataFrame}
        The table.

    Returns
    -------
    names : list or None
        The names, in order.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn_ifog._table import column_names
    >>> column_names(pd.DataFrame({"time": [0.0], "temperature": [20.0]}))
    ['time', 'temperature']
    """
    return None if frame_kind(X) is None else list(X.columns)


def column_position(X, key, *, param, source="X", hint=None):
    """Position of the column that ``key`` names (a string) or gives (an integer).

    Parameters
    ----------
    X : {ndarray, pandas.DataFrame, polars.DataFrame}
        The table (2-D).
    key : str or int
        A column name (DataFrames) or a position (0 to n_columns - 1).
    param : str
        The parameter that gave ``key``, for messages.
    source : str, default="X"
        What the table is called in messages.
    hint : str, default=None
        A sentence added to the message of a missing column.

    Returns
    -------
    position : int
        The column's position.

    Raises
    ------
    TypeError
        If ``key`` is neither a string nor an integer.
    ValueError
        If no column (or several) has that name, the position is out of range, or a name is
        given for an array.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn_ifog._table import column_position
    >>> column_position(pd.DataFrame({"time": [0.0], "coil": [20.0]}), "coil", param="temperature")
    1
    """
    n_columns = X.shape[1]
    columns = column_names(X)
    if isinstance(key, bool | np.bool_) or not isinstance(key, str | numbers.Integral):
        raise TypeError(
            f"{param} must name a column (str) or give its position (int), got {key!r}."
        )
    if isinstance(key, numbers.Integral):
        if not 0 <= key < n_columns:
            raise ValueError(
                f"{param}={key!r} is not a column position of {source}, which has {n_columns} "
                f"column(s) (positions 0 to {n_columns - 1})."
            )
        return int(key)
    if columns is None:
        raise ValueError(
            f"{param}={key!r} names a column, but {source} has no column names; pass a "
            "DataFrame or give the column's integer position."
        )
    matches = [position for position, name in enumerate(columns) if name == key]
    if not matches:
        extra = "" if hint is None else f" {hint}"
        raise ValueError(
            f"Column {key!r} ({param}) not found in {source}; available columns: "
            f"{list(columns)}.{extra}"
        )
    if len(matches) > 1:
        raise ValueError(f"Column {key!r} ({param}) appears {len(matches)} times in {source}.")
    return matches[0]


def find_column(X, key):
    """Position of column ``key`` of ``X``, or None when there is no such column (lenient).

    A name is looked up first (DataFrames); an integer that names no column is a position,
    negative positions counting from the end.

    Parameters
    ----------
    X : {array-like, pandas.DataFrame, polars.DataFrame} or None
        The table.
    key : str, int or None
        A column name or position.

    Returns
    -------
    position : int or None
        The column's position; None if ``X`` or ``key`` is None or no column matches.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._table import find_column
    >>> find_column(np.ones((2, 3)), -1), find_column(np.ones((2, 3)), "run")
    (2, None)
    """
    if key is None or X is None:
        return None
    columns = getattr(X, "columns", None)
    n_columns = None
    if columns is not None:
        columns = list(columns)
        matches = [position for position, name in enumerate(columns) if name == key]
        if matches:
            return matches[0]
        n_columns = len(columns)
    elif getattr(X, "ndim", None) == 2 or np.ndim(X) == 2:
        n_columns = np.shape(X)[1]
    if n_columns is None or isinstance(key, bool) or not isinstance(key, numbers.Integral):
        return None
    return int(key) % n_columns if -n_columns <= key < n_columns else None


def column_at(X, position):
    """Column ``position`` of ``X`` as it is stored (a pandas/polars Series or a 1-D array).

    Parameters
    ----------
    X : {array-like, pandas.DataFrame, polars.DataFrame}
        The table.
    position : int
        A column position, e.g. from :func:`column_position` or :func:`find_column`.

    Returns
    -------
    column : Series or ndarray of shape (n_samples,)
        The column, unconverted.

    Examples
    --------
    >>> from sklearn_ifog._table import column_at
    >>> column_at([[1, 2], [3, 4]], 1)
    array([2, 4])
    """
    kind = frame_kind(X)
    if kind == "pandas":
        return X.iloc[:, position]
    if kind == "polars":
        return X.to_series(position)
    return np.asarray(X)[:, position]


def _label(param, X, position):
    columns = column_names(X)
    name = position if columns is None else columns[position]
    return f"{param} column {name!r}"


def _object_as_float(values, label):
    """Numbers held in an object array as float64; anything else is rejected."""
    # Inferring the dtype from the Python values (in C) tells numbers from strings; a plain
    # ``astype(float)`` would silently parse strings such as "20.5".
    inferred = np.array(values.tolist()) if values.size else np.empty(0)
    if inferred.dtype.kind in "iuf" and inferred.ndim == 1:
        return inferred.astype(np.float64)
    if inferred.dtype.kind == "O":
        try:
            return values.astype(np.float64)
        except TypeError as exc:  # e.g. None or a dict among the numbers
            raise TableTypeError(f"{label} must be numeric: {exc}") from exc
    raise TableTypeError(
        f"{label} must be numeric, but it holds non-numeric values (object column inferred "
        f"as {inferred.dtype})."
    )


def _parse_text(column, label):
    """Numbers written as text (a CSV read as strings): each cell parsed, or an error."""
    import pandas as pd

    kind = _library(column)
    if kind == "polars":
        column = column.to_pandas()
    elif kind is None:
        column = pd.Series(column)
    values = pd.to_numeric(column, errors="coerce")
    not_numbers = np.flatnonzero(values.isna().to_numpy() & column.notna().to_numpy())
    if not_numbers.size:
        row = int(not_numbers[0])
        value = column.iloc[row]
        raise TableError(
            f"{label} holds {value!r} at row {row}, not a number.", row=row, value=value
        )
    return values.to_numpy(dtype=np.float64)


def _as_float(column, label):
    """One column (Series or 1-D array) as float64; a non-numeric one is a TableTypeError."""
    kind = _library(column)
    if kind == "pandas":
        import pandas as pd

        dtype = column.dtype
        if pd.api.types.is_bool_dtype(dtype) or not (
            pd.api.types.is_numeric_dtype(dtype) or pd.api.types.is_object_dtype(dtype)
        ):
            raise TableTypeError(f"{label} must be numeric, got dtype {dtype}.")
        if pd.api.types.is_object_dtype(dtype):
            return _object_as_float(column.to_numpy(), label)
        return column.to_numpy(dtype=np.float64, na_value=np.nan)
    if kind == "polars":
        if not column.dtype.is_numeric():
            raise TableTypeError(f"{label} must be numeric, got dtype {column.dtype}.")
        return np.asarray(column.to_numpy(), dtype=np.float64)
    if column.dtype.kind in "iuf":
        return column.astype(np.float64)
    if column.dtype.kind == "O":
        return _object_as_float(column, label)
    raise TableTypeError(f"{label} must be numeric, got dtype {column.dtype}.")


def check_finite(values, label):
    """Raise if ``values`` holds NaN or inf, naming ``label``, the count and the first row.

    Parameters
    ----------
    values : ndarray of float
        A column (1-D) or several (2-D: a row is bad if any of its values is).
    label : str
        What the values are, e.g. ``"temperature column 'coil'"``.

    Raises
    ------
    TableError
        If a value is not finite (``row`` and ``value``: the first one).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._table import check_finite
    >>> check_finite(np.array([20.0, np.nan]), "temperature column 'coil'")
    Traceback (most recent call last):
    ...
    sklearn_ifog._table.TableError: temperature column 'coil' contains NaN or inf (1 value(s);
    first at row 1: nan); rows are positions in the input.
    """
    values = np.asarray(values)
    bad = ~np.isfinite(values)
    if bad.any():
        rows = np.flatnonzero(bad.reshape(values.shape[0], -1).any(axis=1))
        row = int(rows[0])
        value = values.reshape(values.shape[0], -1)[row][bad.reshape(values.shape[0], -1)[row]]
        value = value[0].item()
        raise TableError(
            f"{label} contains NaN or inf ({int(bad.sum())} value(s); first at row {row}: "
            f"{value!r}); rows are positions in the input.",
            row=row,
            value=value,
        )


def numeric_column(X, key, *, param, finite=True, parse_text=False, source="X", hint=None):
    """Column ``key`` of ``X`` as float64, converting nothing else of ``X``.

    Parameters
    ----------
    X : {ndarray, pandas.DataFrame, polars.DataFrame}
        The table (see :func:`as_table`).
    key : str or int
        Column name or position (see :func:`column_position`).
    param : str
        The parameter that names the column (its role), for messages.
    finite : bool, default=True
        Reject NaN and inf (see :func:`check_finite`).
    parse_text : bool, default=False
        Parse numbers written as text (e.g. a CSV read as strings); by default text is an
        error, never silently parsed.
    source, hint : str
        See :func:`column_position`.

    Returns
    -------
    values : ndarray of shape (n_samples,), dtype float64
        The column.

    Raises
    ------
    TableTypeError
        If the column is not numeric (bool, text, ...), naming it and its role.
    TableError
        On NaN or inf (``finite=True``) or, with ``parse_text``, text that is no number.

    Examples
    --------
    >>> import pandas as pd, polars as pl
    >>> from sklearn_ifog._table import numeric_column
    >>> numeric_column(pd.DataFrame({"coil": [20, 21]}), "coil", param="temperature")
    array([20., 21.])
    >>> text = pl.DataFrame({"coil": ["a", "b"]})
    >>> numeric_column(text, "coil", param="temperature")
    Traceback (most recent call last):
    ...
    sklearn_ifog._table.TableTypeError: temperature column 'coil' must be numeric, got dtype
    String.
    """
    position = column_position(X, key, param=param, source=source, hint=hint)
    label = _label(param, X, position)
    column = column_at(X, position)
    try:
        values = _as_float(column, label)
    except TableTypeError:
        if not parse_text:
            raise
        values = _parse_text(column, label)
    if finite:
        check_finite(values, label)
    return values


def label_column(X, key, *, param, source="X", hint=None):
    """Column ``key`` of ``X`` as labels (run or unit ids), rejecting missing ones.

    Parameters
    ----------
    X, key, param, source, hint
        The table, the column (name or position), its role (e.g. ``"run"``, which also names
        the ids in messages) and the message details, as for :func:`numeric_column`.

    Returns
    -------
    labels : ndarray of shape (n_samples,)
        The labels, as the column holds them (numbers or strings).

    Raises
    ------
    TableError
        If a label is missing (None, NaN, null), naming the column and the first such row.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn_ifog._table import label_column
    >>> label_column(pd.DataFrame({"run": ["a", None]}), "run", param="run")
    Traceback (most recent call last):
    ...
    sklearn_ifog._table.TableError: run column 'run' has missing run ids (first at row 1); every
    row needs a run id.
    """
    position = column_position(X, key, param=param, source=source, hint=hint)
    label = _label(param, X, position)
    column = column_at(X, position)
    kind = _library(column)
    if kind == "pandas":
        missing = column.isna().to_numpy()
        labels = column.to_numpy()
    elif kind == "polars":
        missing = column.is_null().to_numpy()
        if column.dtype.is_float():
            missing |= column.is_nan().fill_null(False).to_numpy()
        labels = column.to_numpy()
    else:
        labels = column
        if labels.dtype.kind == "f":
            missing = np.isnan(labels)
        elif labels.dtype.kind == "O":
            try:
                missing = np.asarray((labels != labels) | np.equal(labels, None), dtype=bool)
            except TypeError as exc:  # e.g. pandas.NA, whose comparisons are undefined
                raise TableError(
                    f"{label} holds {param} ids that cannot be compared (e.g. pandas.NA)."
                ) from exc
        else:
            missing = np.zeros(labels.shape[0], dtype=bool)
    if missing.any():
        row = int(np.flatnonzero(missing)[0])
        raise TableError(
            f"{label} has missing {param} ids (first at row {row}); every row needs a {param} id.",
            row=row,
        )
    return np.asarray(labels)


class ThermalColumns(NamedTuple):
    """The columns of a thermal test read by :func:`read_thermal_columns`."""

    temperature: np.ndarray
    """Shape (n_samples, n_sensors), float64, finite."""
    time: np.ndarray | None
    """Shape (n_samples,), float64, finite; None without a time column."""
    run: np.ndarray | None
    """Shape (n_samples,), the run ids; None without a run column."""
    time_label: str | None
    """How messages name the time column (e.g. ``"time column 'time'"``)."""


def plain_label(value):
    """A unit label as a plain Python value (numpy scalars unwrapped), for dict keys."""
    return value.item() if isinstance(value, np.generic) else value


def id_kind(value):
    """The kind of a run or unit id: ``"string"``, ``"number"`` or its type's name."""
    if isinstance(value, (str, bytes, np.str_, np.bytes_)):
        return "string"
    if isinstance(value, (numbers.Number, np.number)):
        return "number"
    return type(value).__name__


def check_ids(labels, key, param):
    """``labels`` (unit or run ids), refused with a TypeError unless all numbers or all strings.

    Ids of mixed kinds cannot be sorted (``units_`` is sorted), and an integer ``0`` beside a
    string ``"0"`` would be two units that print alike: the column is named, with an example
    of each kind, instead of numpy's comparison error.
    """
    if labels.dtype.kind != "O":
        return labels
    values = labels.tolist()
    # distinct ids, first seen first; an unhashable id (e.g. a dict) leaves every row
    with contextlib.suppress(TypeError):
        values = dict.fromkeys(values)
    examples = {}
    for value in values:
        examples.setdefault(id_kind(value), value)
    if len(examples) > 1 or not examples.keys() <= {"number", "string"}:
        found = " and ".join(
            f"{kind}s (e.g. {value!r})" if kind in ("number", "string") else f"{kind} {value!r}"
            for kind, value in examples.items()
        )
        what = "mixes {0} ids of different types" if len(examples) > 1 else "holds {0} ids of type"
        raise TypeError(
            f"The {param} column {key!r} of X {what.format(param)}: {found}. Expected "
            f"{param} ids of one kind, all numbers or all strings (convert the column, e.g. "
            "with .astype(str))."
        )
    return labels


def read_thermal_columns(X, *, temperature, time=None, run=None):
    """The temperature, time and run columns of a table, validated, and nothing else.

    Parameters
    ----------
    X : {ndarray, pandas.DataFrame, polars.DataFrame}
        The table (see :func:`as_table`).
    temperature : list of (str or int)
        The temperature column of every sensor.
    time, run : str, int or None
        The time column (seconds) and the run-id column.

    Returns
    -------
    columns : ThermalColumns
        The columns as numpy arrays.

    Raises
    ------
    ValueError
        If a column is missing, named twice, given two roles, not numeric (temperature,
        time), not finite, or a run id is missing; the message names the column and its role.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn_ifog._table import read_thermal_columns
    >>> X = pd.DataFrame({"time": [0.0, 60.0], "coil": [20.0, 21.0]})
    >>> read_thermal_columns(X, temperature=["coil"], time="time").temperature
    array([[20.],
           [21.]])
    """
    temp_positions = [column_position(X, key, param="temperature") for key in temperature]
    if len(set(temp_positions)) < len(temp_positions):
        shown = temperature if len(temperature) != 1 else temperature[0]
        raise ValueError(f"temperature={shown!r} lists a column twice.")
    used = {position: "temperature" for position in temp_positions}
    for param, key in (("time", time), ("run", run)):
        if key is None:
            continue
        position = column_position(X, key, param=param)
        if position in used:
            raise ValueError(
                f"{param}={key!r} is the same column as {used[position]}; each column "
                "has one role."
            )
        used[position] = param

    run_values = None if run is None else label_column(X, run, param="run")
    values = np.empty((X.shape[0], len(temp_positions)))
    for sensor, position in enumerate(temp_positions):
        try:
            values[:, sensor] = numeric_column(X, position, param="temperature")
        except TableError as error:
            if run_values is None or error.row is None:
                raise
            # A missing reading is found in a log run by run: say which run it is in.
            run_id = run_values[error.row]
            raise TableError(
                f"{error} It is in run {run_id!r}; every temperature must be a finite "
                "reading in degC.",
                row=error.row,
                value=error.value,
                run=run_id,
            ) from None
    time_values = time_label = None
    if time is not None:
        time_values = numeric_column(X, time, param="time")
        time_label = _label("time", X, column_position(X, time, param="time"))
    return ThermalColumns(values, time_values, run_values, time_label)


# ---------------------------------------------------------------------------------------------
# Runs
# ---------------------------------------------------------------------------------------------


def _object_codes(run):
    """Integer codes of object run ids by hashing (pandas), or None without pandas.

    Sorting Python objects (``np.unique``) costs seconds per million rows; hashing them costs
    milliseconds and needs no order between the ids' types.
    """
    try:
        import pandas as pd
    except ImportError:  # pragma: no cover - pandas is an optional dependency
        return None
    codes, _ = pd.factorize(run, use_na_sentinel=True)
    if (codes < 0).any():
        row = int(np.flatnonzero(codes < 0)[0])
        raise TableError(
            f"Missing run id (None or NaN) at row {row}; every row needs one.", row=row
        )
    return codes


def run_codes(run):
    """An integer code per row, equal for the rows of one run.

    Parameters
    ----------
    run : array-like of shape (n_samples,)
        Run id of every row (numbers or strings).

    Returns
    -------
    codes : ndarray of shape (n_samples,), dtype intp
        Codes from 0 to n_runs - 1 (object ids: in order of first appearance; others: in
        sorted order of the ids).

    Raises
    ------
    ValueError
        If the ids cannot be ordered (e.g. a mix of strings and numbers), or one is missing.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._table import run_codes
    >>> run_codes(np.array([7, 3, 7]))
    array([1, 0, 1])
    """
    run = np.asarray(run)
    n_samples = run.shape[0]
    codes = _object_codes(run) if run.dtype.kind == "O" else None
    if codes is None:
        try:
            _, codes = np.unique(run, return_inverse=True)
        except TypeError as exc:
            kinds = sorted({type(value).__name__ for value in run[:1000].tolist()})
            raise ValueError(
                "Run ids must all be of one orderable type (all numbers or all strings); "
                f"got {kinds}."
            ) from exc
    return codes.reshape(n_samples).astype(np.intp, copy=False)


def group_rows_by_run(run):
    """Stable order that makes each run's rows contiguous.

    Rows of one run keep their relative order (the time order), whatever the interleaving of
    runs in the input.

    Parameters
    ----------
    run : array-like of shape (n_samples,) or None
        Run id of every row (numbers or strings, one type). None: all rows are one run.

    Returns
    -------
    order : ndarray of shape (n_samples,), dtype intp
        ``values[order]`` lists the rows run by run; ``out[order] = grouped`` scatters a
        result computed on the grouped rows back to the input order.
    run_starts : ndarray of shape (n_samples,), dtype bool
        True at the first row of every run, in the grouped order.

    Raises
    ------
    ValueError
        If the run ids cannot be ordered (e.g. a mix of strings and numbers).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.features import group_rows_by_run
    >>> order, run_starts = group_rows_by_run(np.array(["b", "a", "b", "a"]))
    >>> order
    array([1, 3, 0, 2])
    >>> run_starts
    array([ True, False,  True, False])
    """
    if run is None:
        return None, None
    codes = run_codes(run)
    order = np.argsort(codes, kind="stable")
    grouped = codes[order]
    run_starts = np.empty(codes.shape[0], dtype=bool)
    run_starts[:1] = True
    np.not_equal(grouped[1:], grouped[:-1], out=run_starts[1:])
    return order, run_starts


def run_segments(run, n_samples):
    """The rows of every run, in time (input) order, runs in order of first appearance.

    Parameters
    ----------
    run : array-like of shape (n_samples,) or None
        Run id of every row. None: one run, labelled None.
    n_samples : int
        Number of rows.

    Returns
    -------
    segments : list of (run id, ndarray of int)
        For every run, its id (as the input holds it) and the positions of its rows.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._table import run_segments
    >>> [(str(run), rows.tolist()) for run, rows in run_segments(np.array(["b", "a", "b"]), 3)]
    [('b', [0, 2]), ('a', [1])]
    """
    if run is None:
        return [(None, np.arange(n_samples))]
    run = np.asarray(run)
    order, run_starts = group_rows_by_run(run)
    bounds = np.append(np.flatnonzero(run_starts), n_samples)
    segments = [order[start:stop] for start, stop in itertools.pairwise(bounds)]
    segments.sort(key=lambda rows: rows[0])
    return [(run[rows[0]], rows) for rows in segments]


def contiguous_runs(run, n_samples):
    """(start, stop, run id) of the stretches of constant run id, in order (for a stream).

    Parameters
    ----------
    run : array-like of shape (n_samples,) or None
        Run id of every row. None: one stretch, with id None.
    n_samples : int
        Number of rows.

    Returns
    -------
    stretches : list of (int, int, object)
        Rows ``start:stop`` have the run id (a Python scalar; a whole float becomes an int).

    Examples
    --------
    >>> from sklearn_ifog._table import contiguous_runs
    >>> contiguous_runs([1.0, 1.0, 2.0, 1.0], 4)
    [(0, 2, 1), (2, 3, 2), (3, 4, 1)]
    """
    if run is None:
        return [(0, n_samples, None)] if n_samples else []
    run = np.asarray(run)
    bounds = [0, *(np.flatnonzero(run[1:] != run[:-1]) + 1).tolist(), n_samples]
    stretches = []
    for start, stop in itertools.pairwise(bounds):
        run_id = _scalar(run[start])
        if isinstance(run_id, float) and run_id.is_integer():
            run_id = int(run_id)
        stretches.append((start, stop, run_id))
    return stretches


def per_run_mean(values, run):
    """The mean of ``values`` over each run, broadcast back to the run's rows.

    Parameters
    ----------
    values : ndarray of shape (n_samples,)
        Values of every row.
    run : array-like of shape (n_samples,)
        Run id of every row.

    Returns
    -------
    means : ndarray of shape (n_samples,)
        Row i holds the mean of its run.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._table import per_run_mean
    >>> per_run_mean(np.array([1.0, 10.0, 3.0]), np.array(["a", "b", "a"]))
    array([ 2., 10.,  2.])
    """
    codes = run_codes(run)
    sums = np.bincount(codes, weights=values)
    counts = np.bincount(codes)
    return (sums / counts)[codes]


# ---------------------------------------------------------------------------------------------
# Time order
# ---------------------------------------------------------------------------------------------


def first_time_violation(time, order=None, run_starts=None, *, previous=None):
    """The first row whose time does not exceed the time of its run's previous row.

    Parameters
    ----------
    time : ndarray of shape (n_samples,)
        Time of every row, in input order.
    order, run_starts : ndarray or None
        From :func:`group_rows_by_run` (None: all rows are one run, in order).
    previous : float, default=None
        The time just before row 0 (a stream's last sample), for one run only.

    Returns
    -------
    violation : (int, int) or None
        ``(row, previous_row)``, positions in the input (``previous_row`` is -1 for the
        carried ``previous`` time); the violation with the smallest ``row``. None if time
        increases strictly within every run. NaN never counts as increasing.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._table import first_time_violation, group_rows_by_run
    >>> time = np.array([0.0, 0.0, 60.0, 30.0, 30.0])
    >>> first_time_violation(time, *group_rows_by_run(np.array([1, 2, 1, 2, 2])))
    (4, 3)
    >>> first_time_violation(np.array([5.0, 6.0]), previous=5.0)
    (0, -1)
    """
    time = np.asarray(time)
    if previous is not None:
        if order is not None:
            raise ValueError("previous is for one run: give no order.")
        found = first_time_violation(np.concatenate([[previous], time]))
        return None if found is None else (found[0] - 1, found[1] - 1)
    grouped = time if order is None else time[order]
    n_steps = max(time.shape[0] - 1, 0)
    continues = np.ones(n_steps, dtype=bool) if run_starts is None else ~run_starts[1:]
    bad = np.flatnonzero(continues & ~(grouped[1:] > grouped[:-1]))
    if bad.size == 0:
        return None
    if order is None:
        return int(bad[0]) + 1, int(bad[0])
    rows, previous_rows = order[bad + 1], order[bad]
    first = int(np.argmin(rows))
    return int(rows[first]), int(previous_rows[first])


def check_time_increasing(time, run=None, *, order=None, run_starts=None):
    """Raise unless time increases strictly within every run, however runs interleave.

    Parameters
    ----------
    time : ndarray of shape (n_samples,)
        Time of every row, in input order.
    run : array-like of shape (n_samples,), default=None
        Run id of every row (None: one run).
    order, run_starts : ndarray, default=None
        :func:`group_rows_by_run` of ``run``, when the caller has it already.

    Raises
    ------
    TableError
        Naming the run, the first offending row, its time and the row it does not follow
        (attributes ``row``, ``previous_row``, ``value``, ``run``).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._table import check_time_increasing
    >>> check_time_increasing(np.array([0.0, 0.0, 60.0, 30.0]), np.array(["a", "b", "a", "a"]))
    Traceback (most recent call last):
    ...
    sklearn_ifog._table.TableError: time must increase strictly within each run; in run 'a' row 3
    has time 30.0, not after 60.0 at row 2 (rows are positions in the input).
    """
    time = np.asarray(time, dtype=np.float64)
    if run is not None and order is None:
        order, run_starts = group_rows_by_run(run)
    violation = first_time_violation(time, order, run_starts)
    if violation is None:
        return
    row, previous = violation
    run_id = None if run is None else _scalar(np.asarray(run)[row])
    where = "" if run is None else f"in run {run_id!r} "
    raise TableError(
        f"time must increase strictly within each run; {where}row {row} has time "
        f"{time[row].item()!r}, not after {time[previous].item()!r} at row {previous} "
        "(rows are positions in the input).",
        row=row,
        value=time[row].item(),
        previous_row=previous,
        run=run_id,
    )
