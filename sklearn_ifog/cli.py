"""The ``sklearn-ifog`` command line.

Subcommands::

    sklearn-ifog demo [--out DIR] [--quick]
    sklearn-ifog fit DATA.csv --temperature COL [--time COL] [--run COL]
                 [--rate COL] [--reference COL | --latitude DEG --azimuth COL]
                 [--groups COL] [--cv unit|azimuth|run] -o MODEL
    sklearn-ifog compensate MODEL DATA.csv -o OUT.csv
    sklearn-ifog report MODEL DATA.csv --out DIR
    sklearn-ifog export MODEL (--c DIR | --json FILE)

Exit status: 0 on success; 2 on bad input (a missing file or column, text in a number
column, time not increasing within a run, an empty file, ...) with one line on stderr naming
the problem; 1 on an unexpected internal error. Every output is written to a temporary file
(or directory) first and renamed into place only when complete, so a failure leaves no
partial output behind.
"""

import argparse
import contextlib
import os
import shutil
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

import numpy as np

__all__ = ["main"]

_PROGRAM = "sklearn-ifog"
_EXIT_OK = 0
_EXIT_INTERNAL = 1
_EXIT_BAD_INPUT = 2


class InputError(Exception):
    """Bad input the user can fix: reported as one line on stderr, exit status 2."""


def _one_line(error):
    return " ".join(str(error).split()) or type(error).__name__


# --------------------------------------------------------------------------------------------
# Progress
# --------------------------------------------------------------------------------------------


class _Progress:
    """Step-by-step progress on stderr, with no dependency.

    Each step prints ``[i/n] label`` when it starts and its duration when it ends. On a
    terminal a background thread redraws the line every quarter second with the elapsed
    time (and a bar when the step has a known number of items), so a step that takes more
    than a second is visibly alive; in a log (not a terminal) only the start and end lines
    appear.
    """

    def __init__(self, n_steps, stream=None, enabled=True):
        self.n_steps = n_steps
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled
        self.live = enabled and hasattr(self.stream, "isatty") and self.stream.isatty()
        self._index = 0

    def _write(self, text):
        self.stream.write(text)
        self.stream.flush()

    @contextlib.contextmanager
    def step(self, label, total=None):
        """Context manager for one step; yields ``advance(n=1)`` to move the bar."""
        self._index += 1
        prefix = f"[{self._index}/{self.n_steps}] {label}"
        state = {"done": 0}
        lock = threading.Lock()
        start = time.perf_counter()

        def line():
            elapsed = time.perf_counter() - start
            if total:
                filled = int(20 * state["done"] / total)
                bar = "#" * filled + "-" * (20 - filled)
                return f"{prefix} [{bar}] {state['done']}/{total} {elapsed:5.1f} s"
            return f"{prefix} ... {elapsed:5.1f} s"

        def advance(n=1):
            with lock:
                state["done"] += n
                if self.enabled and not self.live:
                    self._write(f"    {prefix}: {state['done']}/{total}\n")

        stop = threading.Event()
        ticker = None
        if self.live:

            def redraw():
                while not stop.wait(0.25):
                    with lock:
                        self._write("\r" + line() + "\x1b[K")

            ticker = threading.Thread(target=redraw, daemon=True)
            self._write(line())
            ticker.start()
        elif self.enabled:
            self._write(prefix + " ...\n")
        outcome = "failed after"
        try:
            yield advance
            outcome = "done in"
        finally:
            stop.set()
            if ticker is not None:
                ticker.join()
            if self.enabled:
                elapsed = time.perf_counter() - start
                ending = f"{prefix}: {outcome} {elapsed:.1f} s"
                self._write(("\r" + ending + "\x1b[K\n") if self.live else f"    {ending}\n")


# --------------------------------------------------------------------------------------------
# Input
# --------------------------------------------------------------------------------------------


def _pandas():
    try:
        import pandas as pd
    except ImportError as error:  # pragma: no cover - depends on the installation
        raise InputError(
            "the command line reads CSV files with pandas: pip install 'sklearn-ifog[pandas]'"
        ) from error
    return pd


def _read_csv(path, *, as_text=False):
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
        raise InputError(f"{path} is not a readable CSV file: {_one_line(error)}") from None
    if frame.shape[0] == 0:
        raise InputError(f"{path} has a header but no data rows")
    return frame


def _line_number(position):
    """CSV line of the data row at ``position`` (line 1 is the header)."""
    return int(position) + 2


def _require_columns(frame, columns, path):
    """``columns``: (role, name) pairs; the role says where the name came from."""
    for role, name in columns:
        if name not in frame.columns:
            available = ", ".join(map(str, frame.columns))
            raise InputError(f"{path}: no column {name!r} ({role}); its columns: {available}")


def _numeric(frame, name, option, path):
    """Column ``name`` as finite float64, or an InputError naming the first bad line."""
    pd = _pandas()
    column = frame[name]
    values = pd.to_numeric(column, errors="coerce")
    not_numbers = np.flatnonzero(values.isna().to_numpy() & column.notna().to_numpy())
    if not_numbers.size:
        position = not_numbers[0]
        raise InputError(
            f"{path}, line {_line_number(position)}: column {name!r} ({option}) holds "
            f"{column.iloc[position]!r}, not a number"
        )
    values = values.to_numpy(dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        position = bad[0]
        what = "is empty" if np.isnan(values[position]) else "is infinite"
        raise InputError(
            f"{path}, line {_line_number(position)}: column {name!r} ({option}) {what}"
        )
    return values


def _labels(frame, name, option, path):
    column = frame[name]
    missing = np.flatnonzero(column.isna().to_numpy())
    if missing.size:
        raise InputError(
            f"{path}, line {_line_number(missing[0])}: column {name!r} ({option}) is empty"
        )
    return column.to_numpy()


def _check_time_order(time_values, runs, time_name, run_name, path):
    """Time must increase strictly within each run (runs may be interleaved)."""
    n = time_values.size
    if runs is None:
        run_codes = np.zeros(n, dtype=np.intp)
    else:
        _, run_codes = np.unique(runs, return_inverse=True)
        run_codes = run_codes.ravel()
    order = np.argsort(run_codes, kind="stable")
    same_run = run_codes[order][1:] == run_codes[order][:-1]
    not_increasing = same_run & (np.diff(time_values[order]) <= 0)
    if not_increasing.any():
        candidates = order[1:][not_increasing]
        position = candidates.min()
        previous = order[:-1][not_increasing][np.argmin(candidates)]
        where = "" if runs is None else f" of {run_name!r} {runs[position]!r}"
        raise InputError(
            f"{path}, line {_line_number(position)}: column {time_name!r} does not increase "
            f"within the run{where} ({time_values[position]:g} after "
            f"{time_values[previous]:g} on line {_line_number(previous)}); sort the rows of "
            "each run by time"
        )


class _Columns:
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
    ):
        self.temperature = list(temperature)
        self.time = time
        self.run = run
        self.rate = rate
        self.reference = reference
        self.latitude = latitude
        self.azimuth = azimuth
        self.from_model = False
        self.defaulted = set()

    def as_dict(self):
        names = ("temperature", "time", "run", "rate", "reference", "latitude", "azimuth")
        return {name: getattr(self, name) for name in names}

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
                f"saved by '{_PROGRAM} fit'); use the Python API for it"
            )
        columns = cls(**stored)
        columns.from_model = True
        return columns

    def model_columns(self):
        """The columns the fitted pipeline reads, in order."""
        extra = [name for name in (self.time, self.run) if name is not None]
        return [*self.temperature, *extra]

    def has_reference(self):
        return self.reference is not None or self.latitude is not None


def _model_input(frame, columns, path):
    """Validate and select the pipeline's input columns; return (X, runs)."""
    roles = [(columns.role("--temperature"), name) for name in columns.temperature]
    if columns.time is not None:
        roles.append((columns.role("--time"), columns.time))
    if columns.run is not None:
        roles.append((columns.role("--run"), columns.run))
    _require_columns(frame, roles, path)
    X = frame[columns.model_columns()].copy()
    for name in columns.temperature:
        X[name] = _numeric(frame, name, columns.role("--temperature"), path)
    runs = None
    if columns.run is not None:
        runs = _labels(frame, columns.run, columns.role("--run"), path)
    if columns.time is not None:
        X[columns.time] = _numeric(frame, columns.time, columns.role("--time"), path)
        _check_time_order(X[columns.time].to_numpy(), runs, columns.time, columns.run, path)
    return X, runs


def _rate(frame, columns, path):
    _require_columns(frame, [(columns.role("--rate"), columns.rate)], path)
    return _numeric(frame, columns.rate, columns.role("--rate"), path)


def _reference(frame, columns, path):
    """The true input rate of every row: a column, or the Earth rate at the azimuth."""
    if columns.latitude is not None:
        from sklearn_ifog.metrics import earth_rate

        _require_columns(frame, [(columns.role("--azimuth"), columns.azimuth)], path)
        azimuth = _numeric(frame, columns.azimuth, columns.role("--azimuth"), path)
        return np.broadcast_to(earth_rate(columns.latitude, azimuth), azimuth.shape).copy()
    _require_columns(frame, [(columns.role("--reference"), columns.reference)], path)
    return _numeric(frame, columns.reference, columns.role("--reference"), path)


def _load_model(path):
    """(model, metadata) from ``path``; version warnings become one stderr line each."""
    from sklearn_ifog.persistence import load_model

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such model file")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            model, metadata = load_model(path, return_metadata=True)
        except Exception as error:  # unpickling/unzipping errors come in many types
            raise InputError(f"{path}: cannot load the model: {_one_line(error)}") from None
    for warning in caught:
        print(f"{_PROGRAM}: warning: {_one_line(warning.message)}", file=sys.stderr)
    return model, metadata


def _predict(model, X, path):
    try:
        prediction = np.asarray(model.predict(X), dtype=np.float64)
    except (ValueError, TypeError) as error:
        raise InputError(f"{path}: {_one_line(error)}") from None
    return prediction.reshape(X.shape[0])


# --------------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------------


def _check_output_parent(path):
    parent = Path(path).parent
    if not parent.is_dir():
        raise InputError(f"{path}: the directory {parent} does not exist")


@contextlib.contextmanager
def _staged_directory(out):
    """Yield a fresh temporary directory; on success move its files into ``out``.

    ``out`` is created if needed; files already in it and not rewritten are kept. On failure
    the staging directory is removed and ``out`` is untouched.
    """
    out = Path(out)
    parent = out.parent
    if not parent.is_dir():
        raise InputError(f"{out}: the directory {parent} does not exist")
    if out.exists() and not out.is_dir():
        raise InputError(f"{out} exists and is not a directory")
    staging = Path(tempfile.mkdtemp(dir=parent, prefix=f".{out.name}.", suffix=".tmp"))
    try:
        yield staging
        out.mkdir(exist_ok=True)
        for item in sorted(staging.iterdir()):
            target = out / item.name
            if item.is_dir():
                if target.exists():
                    shutil.rmtree(target)
                os.replace(item, target)
            else:
                os.replace(item, target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _print_table(title, table, stream=None, float_format="{:.3g}"):
    stream = sys.stdout if stream is None else stream
    print(f"\n{title}", file=stream)
    print(table.to_string(float_format=float_format.format), file=stream)


# --------------------------------------------------------------------------------------------
# fit
# --------------------------------------------------------------------------------------------


def _build_pipeline(columns, args):
    from sklearn.linear_model import LinearRegression
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    from sklearn_ifog import RBFNetRegressor, ThermalFeatures

    temperature = columns.temperature[0] if len(columns.temperature) == 1 else columns.temperature
    features = ThermalFeatures(
        temperature=temperature, time=columns.time, run=columns.run, terms=tuple(args.terms)
    )
    if args.model == "linear":
        regressor = LinearRegression()
    else:
        regressor = RBFNetRegressor(random_state=args.random_state)
    return Pipeline(
        [("features", features), ("scale", StandardScaler()), ("regressor", regressor)]
    )


def _cv_splitter(args, frame, columns, path):
    """(splitter, groups) for --cv/--groups, or (None, None) when no CV was asked for."""
    from sklearn.model_selection import LeaveOneGroupOut

    if args.cv is None and args.groups is None:
        return None, None
    if args.groups is not None:
        name, role = args.groups, "given by --groups"
    elif args.cv == "run":
        name, role = columns.run, f"the run column of --cv {args.cv}"
        if name is None:
            raise InputError("--cv run needs the run column: give --run COL (or --groups COL)")
    elif args.cv == "azimuth" and columns.azimuth is not None:
        name, role = columns.azimuth, "given by --azimuth"
    else:
        name = args.cv
        role = f"the default group column of --cv {args.cv}; name another with --groups"
    _require_columns(frame, [(role, name)], path)
    groups = _labels(frame, name, role, path)
    n_groups = np.unique(groups).size
    if n_groups < 2:
        raise InputError(
            f"{path}: cross-validation over column {name!r} needs at least two distinct "
            f"values, found {n_groups}"
        )
    if columns.run is not None:
        runs = _labels(frame, columns.run, "--run", path)
        pairs = np.unique(np.column_stack([runs.astype(str), groups.astype(str)]), axis=0)
        if np.unique(pairs[:, 0]).size != pairs.shape[0]:
            raise InputError(
                f"{path}: a run straddles several values of {name!r}; each run must belong "
                "to one cross-validation group"
            )
    return LeaveOneGroupOut(), groups


def _command_fit(args):
    from sklearn.dummy import DummyRegressor

    from sklearn_ifog.metrics import mean_squared_deviation
    from sklearn_ifog.model_selection import compare_regressors
    from sklearn_ifog.persistence import save_model

    if args.latitude is not None and args.reference is not None:
        raise InputError("give either --reference COL or --latitude DEG --azimuth COL, not both")
    if args.latitude is not None and args.azimuth is None:
        raise InputError("--latitude needs --azimuth COL (the azimuth of each row, degrees)")
    if args.latitude is not None and not -90.0 <= args.latitude <= 90.0:
        raise InputError(f"--latitude must be in [-90, 90] degrees, got {args.latitude:g}")
    _check_output_parent(args.output)
    columns = _Columns(
        temperature=args.temperature,
        time=args.time,
        run=args.run,
        rate=args.rate or "rate",
        reference=None if args.latitude is not None else (args.reference or "reference"),
        latitude=args.latitude,
        azimuth=args.azimuth,
    )
    if args.rate is None:
        columns.defaulted.add("--rate")
    if args.reference is None and args.latitude is None:
        columns.defaulted.add("--reference")
    path = Path(args.data)
    frame = _read_csv(path)
    X, _ = _model_input(frame, columns, path)
    target = _rate(frame, columns, path) - _reference(frame, columns, path)
    splitter, groups = _cv_splitter(args, frame, columns, path)
    pipeline = _build_pipeline(columns, args)

    cv_summary = None
    if splitter is not None:
        candidates = {
            "raw": DummyRegressor(strategy="constant", constant=0.0),
            "bias": DummyRegressor(strategy="mean"),
            args.model: pipeline,
        }
        try:
            cv_summary = compare_regressors(
                X, target, regressors=candidates, cv=splitter, groups=groups, n_jobs=args.n_jobs
            )
        except (ValueError, TypeError) as error:
            raise InputError(f"{path}: cross-validation failed: {_one_line(error)}") from None
        _print_table(
            f"Cross-validated MSD ((deg/h)^2), one fold per value of the {args.cv or 'group'} "
            "column left out:",
            cv_summary[["msd_before", "msd_after", "reduction", "n_folds"]],
        )
    try:
        pipeline.fit(X, target)
    except (ValueError, TypeError) as error:
        raise InputError(f"{path}: {_one_line(error)}") from None
    prediction = np.asarray(pipeline.predict(X), dtype=np.float64).reshape(-1)
    msd_before = float(mean_squared_deviation(target, np.zeros_like(target)))
    msd_after = float(mean_squared_deviation(target, prediction))
    metadata = {
        "columns": columns.as_dict(),
        "training": {
            "file": path.name,
            "n_samples": int(X.shape[0]),
            "msd_before": msd_before,
            "msd_after": msd_after,
        },
    }
    if cv_summary is not None:
        metadata["cross_validation"] = {
            "kind": args.cv or "groups",
            "msd_before": float(cv_summary.loc[args.model, "msd_before"]),
            "msd_after": float(cv_summary.loc[args.model, "msd_after"]),
            "n_folds": int(cv_summary.loc[args.model, "n_folds"]),
        }
    save_model(pipeline, args.output, metadata=metadata)
    print(
        f"\nFitted {args.model} on {X.shape[0]} rows of {path}: training MSD "
        f"{msd_before:.3g} -> {msd_after:.3g} (deg/h)^2 (reduction {msd_before / msd_after:.3g}x)."
    )
    print(f"Wrote the model to {args.output}")
    return _EXIT_OK


# --------------------------------------------------------------------------------------------
# compensate
# --------------------------------------------------------------------------------------------


def _compensate_frame(model, metadata, model_path, data_path):
    """(frame, columns, rate, drift) for a model and a CSV, everything validated."""
    columns = _Columns.from_metadata(metadata, model_path)
    frame = _read_csv(data_path)
    X, _ = _model_input(frame, columns, data_path)
    rate = _rate(frame, columns, data_path)
    drift = _predict(model, X, data_path)
    return frame, columns, rate, drift


def _command_compensate(args):
    model_path, data_path = Path(args.model), Path(args.data)
    _check_output_parent(args.output)
    model, metadata = _load_model(model_path)
    frame, _, rate, drift = _compensate_frame(model, metadata, model_path, data_path)
    for option, name in (
        ("--drift-column", args.drift_column),
        ("--compensated-column", args.compensated_column),
    ):
        if name in frame.columns:
            raise InputError(
                f"{data_path} already has a column {name!r}; name the new column with {option}"
            )
    if args.drift_column == args.compensated_column:
        raise InputError("--drift-column and --compensated-column must differ")
    # the input columns are written back as the text they were (no reformatted numbers)
    output = _read_csv(data_path, as_text=True)
    output[args.drift_column] = drift
    output[args.compensated_column] = rate - drift
    from sklearn_ifog._io import atomic_path

    with atomic_path(args.output) as temporary:
        output.to_csv(temporary, index=False)
    print(
        f"Compensated {len(output)} rows of {data_path}; wrote {args.output} with columns "
        f"{args.drift_column!r} and {args.compensated_column!r} added."
    )
    return _EXIT_OK


# --------------------------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------------------------


def _command_report(args):
    from sklearn_ifog.report import compensation_report

    model_path, data_path = Path(args.model), Path(args.data)
    model, metadata = _load_model(model_path)
    frame, columns, rate, drift = _compensate_frame(model, metadata, model_path, data_path)
    if not columns.has_reference():
        raise InputError(f"{model_path}: the model has no reference column to measure against")
    reference = _reference(frame, columns, data_path)
    time_values = None if columns.time is None else frame[columns.time].to_numpy(float)
    runs = None if columns.run is None else frame[columns.run].to_numpy()
    with _staged_directory(args.out) as staging:
        written = compensation_report(
            staging,
            rate=rate,
            drift=drift,
            reference=reference,
            temperature=frame[columns.temperature[0]].to_numpy(float),
            time=time_values,
            run=runs,
            title=f"Thermal compensation of {data_path.name}",
            model_metadata=metadata,
            data_name=str(data_path),
        )
    _print_table("MSD per run ((deg/h)^2):", written.table)
    print(
        f"\nWrote the report to {Path(args.out) / written.paths['html'].name} (HTML) and "
        f"{Path(args.out) / written.paths['markdown'].name} (Markdown), with "
        f"{len(written.figures)} figure(s)."
    )
    return _EXIT_OK


# --------------------------------------------------------------------------------------------
# export
# --------------------------------------------------------------------------------------------


def _command_export(args):
    from sklearn_ifog.export import to_c, to_json

    model_path = Path(args.model)
    model, _ = _load_model(model_path)
    if args.c is not None:
        target = Path(args.c)
        if not target.parent.is_dir():
            raise InputError(f"{target}: the directory {target.parent} does not exist")
        try:
            header, source = to_c(model, target, precision=args.precision, prefix=args.prefix)
        except (ValueError, TypeError) as error:
            raise InputError(f"{model_path}: cannot export to C: {_one_line(error)}") from None
        print(f"Wrote {header} and {source}")
    else:
        _check_output_parent(args.json)
        try:
            written = to_json(model, args.json)
        except (ValueError, TypeError) as error:
            raise InputError(f"{model_path}: cannot export to JSON: {_one_line(error)}") from None
        print(f"Wrote {written}")
    return _EXIT_OK


# --------------------------------------------------------------------------------------------
# demo
# --------------------------------------------------------------------------------------------


# Sizes of the demo. "full" is the main job, on the simulator's default campaign (one-minute
# samples, the usual resolution of thermal modelling); "quick" keeps every step on a smaller
# campaign and drops the two slowest baselines; "tiny" (hidden) is for the test suite.
_DEMO_SIZES = {
    "full": {
        "campaign": {"n_runs": 5, "sampling_period": 60.0},
        "models": None,
        "max_kernel_samples": 400,
    },
    "quick": {
        "campaign": {"n_runs": 2, "sampling_period": 60.0},
        "models": (
            "raw",
            "bias",
            "linear",
            "poly2_ridge",
            "svr",
            "kernel_ridge",
            "rbf_traditional",
            "rbf_modified",
        ),
        "max_kernel_samples": 200,
    },
    "tiny": {
        "campaign": {"n_runs": 1, "sampling_period": 120.0},
        "models": ("raw", "bias", "linear", "rbf_modified"),
        "max_kernel_samples": 100,
    },
}
_DEMO_SEED = 0
_CAMPAIGN_COLUMNS = ["unit", "run", "azimuth", "time", "temperature"]
_MODEL_COLUMNS = _Columns(
    temperature=["temperature"], time="time", run="run", rate="rate", reference="reference"
)


# The reference paper's MSDs per test run, (raw, modified model), from its Tables 2-4.
_PAPER_MSD = {
    "table2": [(1.72e-4, 1.24e-5), (9.90e-4, 1.76e-5), (1.80e-3, 2.05e-5), (2.67e-4, 1.33e-5),
               (9.29e-4, 0.78e-5)],
    "table3": [(5.40e-3, 2.02e-4), (3.37e-2, 9.93e-4), (5.79e-2, 7.70e-3), (3.87e-2, 2.90e-3),
               (1.00e-2, 1.40e-3)],
    "table4": [(5.40e-3, 6.05e-4), (2.45e-2, 7.48e-4), (3.51e-2, 3.30e-3), (3.11e-2, 2.70e-3),
               (8.40e-2, 1.90e-3)],
}  # fmt: skip


def _compare_with_paper(paper):
    """Per table: the range and geometric mean of the raw/modified MSD ratio, here and there."""
    import pandas as pd

    def describe(ratios):
        ratios = np.asarray(ratios, dtype=float)
        geometric_mean = float(np.exp(np.mean(np.log(ratios))))
        if ratios.size == 1:
            return f"{ratios[0]:.3g}x"
        return f"{ratios.min():.3g}-{ratios.max():.3g}x (geometric mean {geometric_mean:.3g}x)"

    rows = []
    for name, paper_runs in _PAPER_MSD.items():
        table = paper[name]
        before, after = ("msd_before", "msd_after") if name == "table2" else ("raw", "modified")
        rows.append(
            {
                "table": name.replace("table", "Table "),
                "this campaign": describe(table[before] / table[after]),
                "paper": describe([raw / modified for raw, modified in paper_runs]),
            }
        )
    return pd.DataFrame(rows).set_index("table")


def _save_paper_fig12(frame, paper, units, azimuths, directory):
    """The reference paper's Fig. 12: raw, traditional and modified output of two gyros."""
    from sklearn_ifog.compensation import compensate
    from sklearn_ifog.plotting import new_figure, plot_compensation, save_figure

    figure, axes = new_figure(len(units), 1)
    axes = np.atleast_1d(axes)
    for ax, unit, azimuth in zip(axes, units, azimuths, strict=True):
        selected = frame[(frame["unit"] == unit) & np.isclose(frame["azimuth"], azimuth)]
        run = selected["run"].iloc[0]
        run_frame = selected[selected["run"] == run]
        models = paper.models[unit]
        rate = run_frame["rate"].to_numpy()
        plot_compensation(
            run_frame["time"].to_numpy(),
            rate,
            {
                "traditional (T, ΔT)": compensate(models["traditional"], run_frame, rate),
                "modified (T, ΔT, T·ΔT)": compensate(models["modified"], run_frame, rate),
            },
            run_frame["temperature"].to_numpy(),
            reference=run_frame["reference"].to_numpy(),
            ax=ax,
            title=f"unit {unit}, azimuth {azimuth:g}°, run {run}",
        )
    return save_figure(figure, directory / "paper_fig12.png")


def run_demo(out, *, quick=False, size=None, n_jobs=None, stream=None):
    """The demo: simulate, compare, repeat the paper's experiments, plot, report, save.

    Parameters
    ----------
    out : path-like
        Output directory (created; files in it with the demo's names are replaced).
    quick : bool, default=False
        The smaller "quick" size.
    size : {"full", "quick", "tiny"} or None, default=None
        Overrides ``quick``.
    n_jobs : int or None, default=None
        Parallel jobs; None uses every core.
    stream : file-like, default=None
        Where the tables and the list of files go (stdout by default); progress goes to
        stderr.

    Returns
    -------
    written : dict of str to Path
        What was written, by role.
    """
    import pandas as pd
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    from sklearn_ifog import RBFNetRegressor, ThermalFeatures
    from sklearn_ifog.datasets import make_thermal_campaign
    from sklearn_ifog.experiments import run_paper_experiments
    from sklearn_ifog.metrics import mean_squared_deviation
    from sklearn_ifog.model_selection import (
        LeaveOneAzimuthOut,
        compare_regressors,
        default_regressors,
    )
    from sklearn_ifog.persistence import save_model
    from sklearn_ifog.plotting import plot_msd_by_model, save_figure
    from sklearn_ifog.report import Report, compensation_report

    stream = sys.stdout if stream is None else stream
    size = size or ("quick" if quick else "full")
    settings = _DEMO_SIZES[size]
    n_jobs = -1 if n_jobs is None else n_jobs
    out = Path(out)
    progress = _Progress(n_steps=7)
    started = time.perf_counter()

    with _staged_directory(out) as staging:
        with progress.step("simulating a thermal-test campaign"):
            campaign = make_thermal_campaign(**settings["campaign"], random_state=_DEMO_SEED)
            frame = campaign.frame
            target = (frame["rate"] - frame["reference"]).to_numpy()
            X = frame[_CAMPAIGN_COLUMNS]
        units = sorted(frame["unit"].unique().tolist())
        period = settings["campaign"]["sampling_period"]
        description = (
            f"{len(frame)} samples: {len(units)} simulated gyros, "
            f"{frame['run'].nunique()} runs at azimuths "
            f"{', '.join(f'{a:g}' for a in sorted(frame['azimuth'].unique()))} deg, "
            f"one sample every {period:g} s, "
            f"{frame['temperature'].min():.0f} to {frame['temperature'].max():.0f} °C "
            f"(simulator seed {_DEMO_SEED}, demo size {size!r})."
        )
        print(f"Campaign: {description}", file=stream)

        regressors = default_regressors(
            max_kernel_samples=settings["max_kernel_samples"], random_state=_DEMO_SEED
        )
        if settings["models"] is not None:
            regressors = {name: regressors[name] for name in settings["models"]}
        cv = LeaveOneAzimuthOut(within_unit=True)
        summaries, folds = [], []
        with progress.step(
            f"comparing {len(regressors)} models (leave one azimuth out, per gyro)",
            total=len(regressors),
        ) as advance:
            for name, regressor in regressors.items():
                # scikit-learn passes these filters on to the joblib workers
                with warnings.catch_warnings():
                    warnings.filterwarnings("ignore", category=ConvergenceWarning)
                    summary, fold_table = compare_regressors(
                        X,
                        target,
                        regressors={name: regressor},
                        cv=cv,
                        n_jobs=n_jobs,
                        return_folds=True,
                    )
                summaries.append(summary)
                folds.append(fold_table)
                advance()
        comparison = pd.concat(summaries)
        fold_table = pd.concat(folds, ignore_index=True)
        shown = ["msd_before", "msd_after", "reduction", "worst_fold_reduction", "fit_time"]
        _print_table(
            "Model comparison: MSD ((deg/h)^2) of each held-out azimuth, mean over "
            f"{int(comparison['n_folds'].iloc[0])} folds:",
            comparison[shown],
            stream=stream,
        )
        # The simulator knows the true thermal drift: what a perfect model would leave is the
        # gyro's noise and run biases, averaged over the same folds (one per unit and azimuth).
        residual = pd.Series((target - frame["drift"].to_numpy()) ** 2)
        floor = float(residual.groupby([frame["unit"], frame["azimuth"]]).mean().mean())
        floor_text = (
            f"Noise floor: a perfect model of the simulated thermal drift would leave an MSD "
            f"of {floor:.3g} (angle random walk, bias instability and turn-on bias), a "
            f"reduction of at most {comparison['msd_before'].iloc[0] / floor:.3g}x."
        )
        print(floor_text, file=stream)
        silenced = (
            "scikit-learn's ConvergenceWarnings of the baselines (e.g. the MLP's lbfgs solver "
            "stopping at max_iter) are silenced in the comparison."
        )
        print(f"({silenced})", file=stream)

        with progress.step("repeating the paper's experiments (Tables 2-4)"):
            paper = run_paper_experiments(
                frame, regressor=RBFNetRegressor(random_state=_DEMO_SEED), n_jobs=n_jobs
            )
        for name, caption in (
            ("table2", "Table 2: unit trained at 0°, tested at 90°, MSD before and after"),
            ("table3", "Table 3: trained at 0°, tested at 45°: raw, traditional, modified"),
            ("table4", "Table 4: trained at 0°, tested at 135°: raw, traditional, modified"),
        ):
            _print_table(caption + ":", paper[name], stream=stream)
        versus_paper = _compare_with_paper(paper)
        _print_table(
            "MSD reduction (raw / modified model) per test run, this campaign against the "
            "paper's real gyros:",
            versus_paper,
            stream=stream,
        )

        first_unit = units[0]
        train = (frame["unit"] == first_unit) & np.isclose(frame["azimuth"], 0.0)
        test = (frame["unit"] == first_unit) & np.isclose(frame["azimuth"], 90.0)
        columns = _MODEL_COLUMNS
        with progress.step(f"fitting the modified model of unit {first_unit} (azimuth 0°)"):
            model = Pipeline(
                [
                    (
                        "features",
                        ThermalFeatures(temperature="temperature", time="time", run="run"),
                    ),
                    ("scale", StandardScaler()),
                    ("regressor", RBFNetRegressor(random_state=_DEMO_SEED)),
                ]
            )
            model.fit(frame.loc[train, columns.model_columns()], target[train.to_numpy()])

        report = Report("sklearn-ifog demo: temperature compensation of simulated IFOGs")
        report.add_paragraph(f"Campaign: {description}")
        figure_paths = []
        with progress.step("drawing the comparison and the paper's Fig. 12", total=2) as advance:
            ax = plot_msd_by_model(
                {
                    name: fold_table.loc[fold_table["model"] == name, "msd_after"].to_numpy()
                    for name in comparison.index
                    if name != "raw"
                },
                before=fold_table.loc[fold_table["model"] == "raw", "msd_after"].to_numpy(),
                floor=floor,
                title="MSD after compensation, per held-out azimuth",
            )
            figure_paths.append(save_figure(ax, staging / "msd_by_model.png"))
            advance()
            fig12 = _save_paper_fig12(frame, paper, units[1:3], (45.0, 135.0), staging)
            figure_paths.append(fig12)
            advance()

        report.add_heading("Model comparison")
        report.add_paragraph(
            "Each gyro's runs at one azimuth are compensated by a model trained on the same "
            "gyro's runs at the other azimuths (leave one azimuth out, within each unit). "
            "MSD in (deg/h)^2; reduction = MSD before / MSD after; times in seconds per fit. "
            + floor_text
            + " "
            + silenced
        )
        report.add_table(comparison[shown])
        report.add_figure(
            figure_paths[0],
            "MSD after compensation per model (bars: mean over folds; dots: folds; grey: "
            "no compensation).",
        )
        report.add_heading("The reference paper's experiments")
        report.add_paragraph(
            "Table 2: a model of the first gyro trained on its runs at azimuth 0° compensates "
            "its runs at 90°. Tables 3-4: the second and third gyros, tested at 45° and 135°, "
            "with the traditional model on (T, ΔT) and the modified one on (T, ΔT, T·ΔT). "
            "MSD in (deg/h)^2."
        )
        for name in ("table2", "table3", "table4"):
            report.add_table(paper[name], caption=f"{name.replace('table', 'Table ')}.")
        report.add_paragraph(
            "MSD reduction (raw / modified model) per test run, this simulated campaign "
            "against the paper's real gyros (computed from its Tables 2-4):"
        )
        report.add_table(versus_paper)
        report.add_figure(
            fig12,
            "As the paper's Fig. 12: raw and compensated output of the second and third "
            "gyros (one test run each), with the temperature.",
        )

        model_path = staging / "model.joblib"
        with progress.step("writing the report (Fig. 10, Allan deviation) and the model"):
            metadata = save_model(
                model,
                model_path,
                metadata={
                    "columns": columns.as_dict(),
                    "training": {
                        "file": "campaign.csv",
                        "n_samples": int(train.sum()),
                        "msd_before": float(np.mean(target[train.to_numpy()] ** 2)),
                        "msd_after": float(
                            mean_squared_deviation(
                                target[train.to_numpy()],
                                model.predict(frame.loc[train, columns.model_columns()]),
                            )
                        ),
                    },
                },
            )
            test_frame = frame[test]
            result = compensation_report(
                staging,
                rate=test_frame["rate"].to_numpy(),
                drift=model.predict(test_frame[columns.model_columns()]),
                reference=test_frame["reference"].to_numpy(),
                temperature=test_frame["temperature"].to_numpy(),
                time=test_frame["time"].to_numpy(),
                run=test_frame["run"].to_numpy(),
                model_metadata=metadata,
                data_name=f"unit {first_unit} at azimuth 90°",
                report=report,
                heading=(
                    f"Unit {first_unit}: trained at 0°, compensating its runs at 90° "
                    "(as the paper's Fig. 10)"
                ),
            )

        with progress.step("writing the campaign as CSV"):
            from sklearn_ifog._io import atomic_path

            with atomic_path(staging / "campaign.csv") as temporary:
                frame.to_csv(temporary, index=False)

    written = {
        "report (HTML, figures embedded)": out / result.paths["html"].name,
        "report (Markdown)": out / result.paths["markdown"].name,
        "figures": [out / path.name for path in figure_paths + result.figures],
        "model (joblib)": out / model_path.name,
        "campaign (CSV)": out / "campaign.csv",
    }
    elapsed = time.perf_counter() - started
    print(f"\nDone in {elapsed:.0f} s. Wrote to {out}/:", file=stream)
    for role, paths in written.items():
        names = ", ".join(p.name for p in paths) if isinstance(paths, list) else paths.name
        print(f"  {role}: {names}", file=stream)
    print(
        f"\nTry: {_PROGRAM} compensate {out / 'model.joblib'} {out / 'campaign.csv'} "
        f"--drift-column drift_predicted -o compensated.csv",
        file=stream,
    )
    return written


def _command_demo(args):
    run_demo(Path(args.out), quick=args.quick, size=args.size, n_jobs=args.n_jobs)
    return _EXIT_OK


# --------------------------------------------------------------------------------------------
# Parser and entry point
# --------------------------------------------------------------------------------------------


def _build_parser():
    from sklearn_ifog import __version__

    parser = argparse.ArgumentParser(
        prog=_PROGRAM,
        description="Learn and remove the temperature drift of fibre-optic gyroscopes.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument(
        "--debug", action="store_true", help="show the traceback of internal errors"
    )
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    demo = commands.add_parser(
        "demo", help="simulate a thermal-test campaign, compare models, write plots and a report"
    )
    demo.add_argument(
        "--out",
        default="sklearn_ifog_demo",
        metavar="DIR",
        help="output directory (default: ./sklearn_ifog_demo)",
    )
    demo.add_argument("--quick", action="store_true", help="a smaller campaign (under a minute)")
    demo.add_argument("--size", choices=tuple(_DEMO_SIZES), default=None, help=argparse.SUPPRESS)
    demo.add_argument("--n-jobs", type=int, default=None, help="parallel jobs (default: cores)")
    demo.set_defaults(handler=_command_demo)

    fit = commands.add_parser(
        "fit",
        help="fit a drift model to a thermal-test CSV",
        description="Fit ThermalFeatures -> StandardScaler -> RBFNetRegressor (or a linear "
        "model) to the drift, rate - reference (or rate - Earth rate), and save it with the "
        "column roles, so that 'compensate', 'report' and 'export' need only the model file. "
        "With --cv or --groups, first cross-validate it against no compensation and a "
        "constant bias.",
        epilog="example: sklearn-ifog fit campaign.csv --temperature temperature --time time "
        "--run run --cv azimuth -o model.joblib",
    )
    fit.add_argument("data", metavar="DATA.csv")
    fit.add_argument(
        "--temperature",
        nargs="+",
        required=True,
        metavar="COL",
        help="temperature column(s), deg C",
    )
    fit.add_argument("--time", metavar="COL", help="time column, seconds")
    fit.add_argument("--run", metavar="COL", help="run (recording) id column")
    fit.add_argument("--rate", metavar="COL", help="gyro output, deg/h (default: 'rate')")
    fit.add_argument(
        "--reference", metavar="COL", help="true input rate, deg/h (default: 'reference')"
    )
    fit.add_argument(
        "--latitude",
        type=float,
        metavar="DEG",
        help="use the Earth rate at this latitude as the reference (needs --azimuth)",
    )
    fit.add_argument("--azimuth", metavar="COL", help="azimuth of the sensitive axis, deg")
    fit.add_argument(
        "--groups",
        metavar="COL",
        help="column whose values form the CV folds (default for --cv unit: 'unit'; "
        "azimuth: the --azimuth column or 'azimuth'; run: the --run column)",
    )
    fit.add_argument(
        "--cv",
        choices=("unit", "azimuth", "run"),
        help="cross-validate leaving out one unit, azimuth or run at a time",
    )
    fit.add_argument(
        "--terms",
        nargs="+",
        default=["T", "dT", "TdT"],
        metavar="TERM",
        help="thermal terms (default: T dT TdT; 'T dT' is the traditional model)",
    )
    fit.add_argument("--model", choices=("rbf", "linear"), default="rbf", help="regressor")
    fit.add_argument("--random-state", type=int, default=0, help="seed of the RBF network")
    fit.add_argument("--n-jobs", type=int, default=None, help="parallel CV jobs")
    fit.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="MODEL",
        help="model file: skops format for a .skops suffix, joblib otherwise",
    )
    fit.set_defaults(handler=_command_fit)

    compensate = commands.add_parser(
        "compensate", help="add the predicted drift and the compensated rate to a CSV"
    )
    compensate.add_argument("model", metavar="MODEL")
    compensate.add_argument("data", metavar="DATA.csv")
    compensate.add_argument("-o", "--output", required=True, metavar="OUT.csv")
    compensate.add_argument("--drift-column", default="drift", metavar="NAME")
    compensate.add_argument("--compensated-column", default="compensated", metavar="NAME")
    compensate.set_defaults(handler=_command_compensate)

    report = commands.add_parser(
        "report", help="MSD, bias stability, Allan deviation and plots of a compensation"
    )
    report.add_argument("model", metavar="MODEL")
    report.add_argument("data", metavar="DATA.csv")
    report.add_argument("--out", required=True, metavar="DIR")
    report.set_defaults(handler=_command_report)

    export = commands.add_parser("export", help="write a model as C99 source or JSON")
    export.add_argument("model", metavar="MODEL")
    target = export.add_mutually_exclusive_group(required=True)
    target.add_argument("--c", metavar="DIR", help="directory for the .h/.c files")
    target.add_argument("--json", metavar="FILE", help="JSON file")
    export.add_argument("--precision", choices=("double", "float"), default="double")
    export.add_argument("--prefix", default="ifog", help="C identifier prefix")
    export.set_defaults(handler=_command_export)
    return parser


def main(argv=None):
    """Run the ``sklearn-ifog`` command line.

    Parameters
    ----------
    argv : list of str, default=None
        Arguments (without the program name); None reads ``sys.argv[1:]``.

    Returns
    -------
    status : int
        0 on success, 2 on bad input (one line on stderr says what), 1 on an internal error.

    Examples
    --------
    >>> from sklearn_ifog.cli import main
    >>> main(["compensate", "no-such-model.joblib", "data.csv", "-o", "out.csv"])
    2
    """
    parser = _build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_request:  # --help, --version, or a usage error
        return exit_request.code if isinstance(exit_request.code, int) else _EXIT_BAD_INPUT
    try:
        return args.handler(args)
    except InputError as error:
        print(f"{_PROGRAM} {args.command}: error: {_one_line(error)}", file=sys.stderr)
        return _EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{_PROGRAM} {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as error:
        if args.debug:
            raise
        print(
            f"{_PROGRAM} {args.command}: internal error: {type(error).__name__}: "
            f"{_one_line(error)} (rerun with --debug for the traceback)",
            file=sys.stderr,
        )
        return _EXIT_INTERNAL
