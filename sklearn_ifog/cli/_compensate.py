"""The commands ``compensate`` and ``report``: a saved model applied to a thermal-test CSV.

Each ``command_*`` function takes the parsed arguments, validates the user's input (an
:class:`~sklearn_ifog.cli._common.InputError` for anything the user can fix), predicts the
drift of every row with the model and writes its output (the CSV with the drift and the
compensated rate added; the report's directory), then prints one summary; it returns the
exit status. Both say, run by run, which rows lay outside the model's calibration domain
(instead of the model's :class:`~sklearn_ifog.OutsideCalibrationWarning`, one per
prediction call).
"""

import contextlib
import warnings
from pathlib import Path

import numpy as np

from sklearn_ifog.cli._common import EXIT_OK, InputError, check_coverage, one_line, print_table
from sklearn_ifog.cli._files import check_output_directory, check_output_parent, load_model
from sklearn_ifog.cli._input import Columns, model_input, read_csv, read_rate, read_reference

#: The columns ``compensate`` adds for a model with a calibration domain.
OUTSIDE_COLUMN = "outside_calibration"
DISTANCE_COLUMN = "calibration_distance"


@contextlib.contextmanager
def _outside_reported_per_run():
    """Silence OutsideCalibrationWarning: the command reports those rows run by run."""
    from sklearn_ifog.domain import OutsideCalibrationWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        yield


def _predict(model, X, path):
    try:
        with _outside_reported_per_run():
            prediction = np.asarray(model.predict(X), dtype=np.float64)
    except (ValueError, TypeError) as error:
        raise InputError(f"{path}: {one_line(error)}") from None
    return prediction.reshape(X.shape[0])


def _calibration_status(model, X, path):
    """The model's calibration status of every row of X (None: the model has no domain)."""
    from sklearn_ifog.report import calibration_status

    try:
        return calibration_status(model, X)
    except (ValueError, TypeError) as error:
        raise InputError(f"{path}: {one_line(error)}") from None


def _outside_lines(status, runs, run_name, units=None, unit_name=None):
    """One line per run with rows outside the calibration domain, after a heading (a run
    of a lot named with its unit)."""
    from sklearn_ifog._table import run_segments
    from sklearn_ifog.report import per_run_calibration
    from sklearn_ifog.report._words import (
        beyond_text,
        number_text,
        policy_actions,
        rate_beyond_text,
    )

    n_outside = int(status.outside.sum())
    if n_outside == 0:
        return [f"All {status.outside.size} rows lie inside the calibration domain of the model."]
    lines = [
        f"{n_outside} of {status.outside.size} rows lie outside the calibration domain of the "
        f"model; there {'; '.join(policy_actions(status))}:"
    ]
    table = per_run_calibration(status, runs)
    # per_run_calibration's rows are the runs in run_segments' order, then "(all runs)"
    for (label, rows), run in zip(
        run_segments(runs, status.outside.size), table.itertuples(), strict=False
    ):
        if run.rows_outside == 0:
            continue
        what = "all rows" if runs is None else f"{run_name} {label}"
        if units is not None:
            what = f"{unit_name} {units[rows[0]]}, {what}"
        line = (
            f"  {what}: {run.rows_outside} of {run.samples} rows ({run.outside_share:.1%}) "
            f"outside, largest distance {number_text(run.max_distance)} sd"
        )
        beyond = beyond_text(run.degC_below, run.degC_above, "coldest", "warmest", " degC")
        if beyond:
            coldest = np.nanmin(status.temperature_min[rows])
            warmest = np.nanmax(status.temperature_max[rows])
            line += (
                f", temperature up to {beyond} calibrated temperature "
                f"({coldest:.4g} to {warmest:.4g} degC)"
            )
        rates = ""
        if not np.isnan(status.rate_min[rows]).all():  # a model with a rate dT
            slowest = np.nanmin(status.rate_min[rows])
            fastest = np.nanmax(status.rate_max[rows])
            rates = rate_beyond_text(run.rate_below, run.rate_above, slowest, fastest)
        if rates:
            line += f", rate dT up to {rates} calibrated rate ({slowest:.3g} to {fastest:.3g})"
        lines.append(line)
    return lines


def _compensate_frame(model, metadata, model_path, data_path, *, estimate_input_rate=False):
    """(frame, columns, X, rate, drift) for a model and a CSV, everything validated.

    With ``estimate_input_rate``, a scale-factor model (fitted with ``--input-rate``)
    estimates every row's input rate from the output (:meth:`~sklearn_ifog.
    CompensationPipeline.compensate`; the file may lack the input-rate column, the output
    then stands in for it in X) and the drift is the output minus that estimate.
    """
    columns = Columns.from_metadata(metadata, model_path)
    frame = read_csv(data_path)
    if columns.input_rate is None or not estimate_input_rate:
        X, _ = model_input(frame, columns, data_path)
        return (
            frame,
            columns,
            X,
            read_rate(frame, columns, data_path),
            _predict(model, X, data_path),
        )
    rate = read_rate(frame, columns, data_path)
    X, _ = model_input(frame, columns, data_path, stand_in=rate)
    try:
        with _outside_reported_per_run():
            estimate = np.asarray(model.compensate(X, rate), dtype=np.float64)
    except (ValueError, TypeError) as error:
        raise InputError(f"{data_path}: {one_line(error)}") from None
    return frame, columns, X, rate, rate - estimate


def command_compensate(args):
    """``compensate``: the CSV with the predicted drift and the compensated rate added."""
    from sklearn_ifog._io import atomic_path

    model_path, data_path = Path(args.model), Path(args.data)
    check_output_parent(args.output)
    model, metadata = load_model(model_path)
    frame, columns, X, rate, drift = _compensate_frame(
        model, metadata, model_path, data_path, estimate_input_rate=True
    )
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
    status = _calibration_status(model, X, data_path)
    if status is not None:
        for name in (OUTSIDE_COLUMN, DISTANCE_COLUMN):
            if name in frame.columns:
                raise InputError(
                    f"{data_path} already has a column {name!r}, where compensate writes the "
                    "model's calibration-domain flag and distance; rename that column"
                )
            for option, given in (
                ("--drift-column", args.drift_column),
                ("--compensated-column", args.compensated_column),
            ):
                if given == name:
                    raise InputError(
                        f"{option} cannot be {name!r}: compensate writes the model's "
                        "calibration-domain flag and distance in that column"
                    )
    bounds = None
    if args.interval is not None:
        check_coverage(args.interval)
        if not hasattr(model, "predict_interval"):
            raise InputError(
                f"{model_path}: the model has no intervals; fit it with "
                "'sklearn-ifog fit ... --interval 0.9'"
            )
        with _outside_reported_per_run():
            bounds = model.predict_interval(X, coverage=args.interval)
        for suffix in ("_lower", "_upper"):
            if args.drift_column + suffix in frame.columns:
                raise InputError(
                    f"{data_path} already has a column {args.drift_column + suffix!r}; "
                    "name the drift column with --drift-column"
                )
    # the input columns are written back as the text they were (no reformatted numbers)
    output = read_csv(data_path, as_text=True)
    output[args.drift_column] = drift
    output[args.compensated_column] = rate - drift
    added = [args.drift_column, args.compensated_column]
    if bounds is not None:
        output[args.drift_column + "_lower"] = bounds[:, 0]
        output[args.drift_column + "_upper"] = bounds[:, 1]
        added += [args.drift_column + "_lower", args.drift_column + "_upper"]
    if status is not None:
        output[OUTSIDE_COLUMN] = status.outside
        output[DISTANCE_COLUMN] = status.distance
        added += [OUTSIDE_COLUMN, DISTANCE_COLUMN]
    with atomic_path(args.output) as temporary:
        output.to_csv(temporary, index=False)
    print(
        f"Compensated {len(output)} rows of {data_path}; wrote {args.output} with columns "
        f"{', '.join(repr(name) for name in added)} added."
    )
    if columns.input_rate is not None:
        stood_in = (
            ""
            if columns.input_rate in frame.columns
            else (
                f"; the file has no {columns.input_rate!r} column, the output stood in for it in "
                "the calibration check"
            )
        )
        print(
            f"The model learnt the scale factor: {args.compensated_column!r} is the estimated "
            f"input rate (rate - bias) / (1 + scale-factor error ± asymmetry), deg/h{stood_in}."
        )
    if status is not None:
        runs = None if columns.run is None else frame[columns.run].to_numpy()
        units = None if columns.unit is None else frame[columns.unit].to_numpy()
        print("\n".join(_outside_lines(status, runs, columns.run, units, columns.unit)))
    return EXIT_OK


def command_report(args):
    """``report``: per-run metrics, figures and the report, in one staged directory."""
    from sklearn_ifog._io import staged_directory
    from sklearn_ifog.report import RunColumns, compensation_report

    model_path, data_path = Path(args.model), Path(args.data)
    check_output_directory(args.out)
    model, metadata = load_model(model_path)
    frame, columns, X, rate, drift = _compensate_frame(model, metadata, model_path, data_path)
    if not columns.has_reference():
        raise InputError(f"{model_path}: the model has no reference column to measure against")
    reference = read_reference(frame, columns, data_path)
    time_values = None if columns.time is None else frame[columns.time].to_numpy(float)
    runs = None if columns.run is None else frame[columns.run].to_numpy()
    interval = None
    if hasattr(model, "predict_interval"):  # fitted with 'fit --interval': show the band
        with _outside_reported_per_run():
            interval = model.predict_interval(X)
    units = None if columns.unit is None else frame[columns.unit].to_numpy()
    with staged_directory(args.out) as staging:
        written = compensation_report(
            staging,
            RunColumns(
                rate=rate,
                drift=drift,
                reference=reference,
                temperature=frame[columns.temperature[0]].to_numpy(float),
                time=time_values,
                run=runs,
                unit=units,
            ),
            title=f"Thermal compensation of {data_path.name}",
            model_metadata=metadata,
            data_name=str(data_path),
            interval=interval,
            model=model,
            X=X,
        )
    if written.unit_table is not None:
        print_table("MSD per unit ((deg/h)^2):", written.unit_table)
    print_table("MSD per run ((deg/h)^2):", written.table)
    if written.calibration_table is not None:
        print_table(
            "Rows outside the calibration domain per run (distance in decorrelated standard "
            "deviations; degC below the coldest / above the warmest calibrated temperature):",
            written.calibration_table,
        )
    print(
        f"\nWrote the report to {Path(args.out) / written.paths['html'].name} (HTML) and "
        f"{Path(args.out) / written.paths['markdown'].name} (Markdown), with "
        f"{len(written.figures)} figure(s)."
    )
    return EXIT_OK
