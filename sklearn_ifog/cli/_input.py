"""Reading and validating a CSV file of the command line.

Every problem with the user's file is an :class:`~sklearn_ifog.cli._common.InputError`
naming the file, the line, the column and the option (or model) the column name came from.
The column readers (``_numeric``, ``_labels``, ``_check_time_order``) are
:mod:`sklearn_ifog._table`'s, their errors reworded with the CSV line number.
"""

from pathlib import Path

import numpy as np

from sklearn_ifog import _table
from sklearn_ifog._table import TableError
from sklearn_ifog.cli._common import PROGRAM, InputError, one_line

__all__ = [
    "Columns",
    "model_input",
    "read_csv",
    "read_rate",
    "read_reference",
    "require_columns",
]


def _pandas():
    try:
        import pandas as pd
    except ImportError as error:  # pragma: no cover - depends on the installation
        raise InputError(
            "the command line reads CSV files with pandas: pip install 'sklearn-ifog[pandas]'"
        ) from error
    return pd


def read_csv(path, *, as_text=False):
    """The CSV at ``path`` as a DataFrame, or an InputError naming what is wrong.

    ``as_text=True`` keeps every cell as the text it was (empty cells as ""), so a file can
    be written back with its columns exactly as they came.
    """
    pd = _pandas()
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if not path.is_file():
        raise InputError(f"{path}: not a file")
    options = {"dtype": str, "keep_default_na": False} if as_text else {}
    try:
        frame = pd.read_csv(path, **options)
    except pd.errors.EmptyDataError:
        raise InputError(f"{path} is empty") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as error:
        raise InputError(f"{path} is not a readable CSV file: {one_line(error)}") from None
    if frame.shape[0] == 0:
        raise InputError(f"{path} has a header but no data rows")
    return frame


def _line_number(position):
    """CSV line of the data row at ``position`` (line 1 is the header)."""
    return int(position) + 2


def require_columns(frame, columns, path):
    """``columns``: (role, name) pairs; the role says where the name came from."""
    for role, name in columns:
        if name not in frame.columns:
            available = ", ".join(map(str, frame.columns))
            raise InputError(f"{path}: no column {name!r} ({role}); its columns: {available}")


def _numeric(frame, name, option, path):
    """Column ``name`` as finite float64, or an InputError naming the first bad line."""
    try:
        return _table.numeric_column(frame, name, param=option, parse_text=True)
    except TableError as error:
        if isinstance(error.value, str):
            what = f"holds {error.value!r}, not a number"
        elif np.isnan(error.value):
            what = "is empty"
        else:
            what = "is infinite"
        raise InputError(
            f"{path}, line {_line_number(error.row)}: column {name!r} ({option}) {what}"
        ) from None


def _labels(frame, name, option, path):
    """Column ``name`` as labels, or an InputError naming the first empty line."""
    try:
        return _table.label_column(frame, name, param=option)
    except TableError as error:
        raise InputError(
            f"{path}, line {_line_number(error.row)}: column {name!r} ({option}) is empty"
        ) from None


def _check_time_order(time_values, runs, time_name, run_name, path):
    """Time must increase strictly within each run (runs may be interleaved)."""
    try:
        _table.check_time_increasing(time_values, runs)
    except TableError as error:
        where = "" if runs is None else f" of {run_name!r} {runs[error.row]!r}"
        raise InputError(
            f"{path}, line {_line_number(error.row)}: column {time_name!r} does not increase "
            f"within the run{where} ({error.value:g} after "
            f"{time_values[error.previous_row]:g} on line {_line_number(error.previous_row)}); "
            "sort the rows of each run by time"
        ) from None


class Columns:
    """The column roles of a model, as stored in its metadata by ``fit``."""

    def __init__(
        self,
        *,
        temperature,
        time=None,
        run=None,
        rate="rate",
        reference=None,
        latitude=None,
        azimuth=None,
        unit=None,
        input_rate=None,
    ):
        self.temperature = list(temperature)
        self.input_rate = input_rate
        self.unit = unit
        self.time = time
        self.run = run
        self.rate = rate
        self.reference = reference
        self.latitude = latitude
        self.azimuth = azimuth
        self.from_model = False
        self.defaulted = set()

    def as_dict(self):
        names = ("temperature", "time", "run", "rate", "reference", "latitude", "azimuth", "unit")
        stored = {name: getattr(self, name) for name in names}
        if self.input_rate is not None:  # a bias-only model's metadata stays as it was
            stored["input_rate"] = self.input_rate
        return stored

    def role(self, option):
        """Where a column name came from, for messages: the command line or the model."""
        if self.from_model:
            return f"read by the model as {option}"
        if option in self.defaulted:
            return f"the default of {option}"
        return f"given by {option}"

    @classmethod
    def from_metadata(cls, metadata, model_path):
        stored = (metadata.get("extra") or {}).get("columns")
        if not isinstance(stored, dict) or "temperature" not in stored:
            raise InputError(
                f"{model_path}: the model does not say which columns it reads (it was not "
                f"saved by '{PROGRAM} fit'); use the Python API for it"
            )
        columns = cls(**stored)
        columns.from_model = True
        return columns

    def model_columns(self):
        """The columns the fitted model reads, in order (the unit column first, if any; the
        input rate last, if any)."""
        extra = [name for name in (self.time, self.run, self.input_rate) if name is not None]
        unit = [] if self.unit is None else [self.unit]
        return [*unit, *self.temperature, *extra]

    def has_reference(self):
        return self.reference is not None or self.latitude is not None


def model_input(frame, columns, path, *, stand_in=None):
    """Validate and select the pipeline's input columns; return (X, runs).

    A model fitted with ``--input-rate`` reads that column too; where the file lacks it and
    ``stand_in`` (the gyro output) is given, the output stands in for the input rate.
    """
    roles = [(columns.role("--temperature"), name) for name in columns.temperature]
    if columns.input_rate is not None and (
        stand_in is None or columns.input_rate in frame.columns
    ):
        roles.append((columns.role("--input-rate"), columns.input_rate))
    if columns.time is not None:
        roles.append((columns.role("--time"), columns.time))
    if columns.run is not None:
        roles.append((columns.role("--run"), columns.run))
    if columns.unit is not None:
        roles.append((columns.role("--unit"), columns.unit))
    require_columns(frame, roles, path)
    if columns.unit is not None:
        _labels(frame, columns.unit, columns.role("--unit"), path)
    names = columns.model_columns()
    X = frame[[name for name in names if name != columns.input_rate]].copy()
    if columns.input_rate is not None:
        if columns.input_rate in frame.columns:
            rates = _numeric(frame, columns.input_rate, columns.role("--input-rate"), path)
        else:
            rates = np.asarray(stand_in, dtype=np.float64)
        X[columns.input_rate] = rates  # last, as model_columns() puts it
    for name in columns.temperature:
        X[name] = _numeric(frame, name, columns.role("--temperature"), path)
    runs = None
    if columns.run is not None:
        runs = _labels(frame, columns.run, columns.role("--run"), path)
    if columns.time is not None:
        X[columns.time] = _numeric(frame, columns.time, columns.role("--time"), path)
        _check_time_order(X[columns.time].to_numpy(), runs, columns.time, columns.run, path)
    return X, runs


def read_rate(frame, columns, path):
    require_columns(frame, [(columns.role("--rate"), columns.rate)], path)
    return _numeric(frame, columns.rate, columns.role("--rate"), path)


def read_reference(frame, columns, path):
    """The true input rate of every row: a column, or the Earth rate at the azimuth."""
    if columns.latitude is not None:
        from sklearn_ifog.metrics import earth_rate

        require_columns(frame, [(columns.role("--azimuth"), columns.azimuth)], path)
        azimuth = _numeric(frame, columns.azimuth, columns.role("--azimuth"), path)
        return np.broadcast_to(earth_rate(columns.latitude, azimuth), azimuth.shape).copy()
    require_columns(frame, [(columns.role("--reference"), columns.reference)], path)
    return _numeric(frame, columns.reference, columns.role("--reference"), path)
