"""The command ``fit``: read a thermal-test CSV, (cross-validate,) fit and save the model.

:func:`command_fit` takes the parsed arguments, validates the user's input (an
:class:`~sklearn_ifog.cli._common.InputError` for anything the user can fix), builds the
package's pipeline on the given columns (one model per unit with ``--unit``, a conformal
band with ``--interval``), cross-validates it against no compensation and a constant bias
when asked (per unit, one run left out at a time, with ``--unit``), fits it, saves it with
its column roles and prints one summary; it returns the exit status.
"""

import contextlib
import sys
import warnings
from pathlib import Path

import numpy as np

from sklearn_ifog.cli._common import (
    EXIT_OK,
    PROGRAM,
    InputError,
    check_coverage,
    one_line,
    print_table,
)
from sklearn_ifog.cli._files import check_output_parent
from sklearn_ifog.cli._input import (
    Columns,
    _labels,
    model_input,
    read_csv,
    read_rate,
    read_reference,
    require_columns,
)


@contextlib.contextmanager
def _held_out_outside_counted():
    """Count, instead of printing, the OutsideCalibrationWarnings of cross-validation.

    Yields a list that holds, after the block, one entry per prediction call that warned
    (those of parallel workers are not seen: they stay in the workers).
    """
    from sklearn_ifog.domain import OutsideCalibrationWarning

    counted = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", OutsideCalibrationWarning)
        yield counted
    for record in caught:
        if issubclass(record.category, OutsideCalibrationWarning):
            counted.append(record)
        else:
            warnings.warn_explicit(record.message, record.category, record.filename, record.lineno)


def _print_held_out_outside(counted, n_folds):
    if counted:
        print(
            f"In {len(counted)} of the {n_folds} folds, held-out rows lay outside the "
            "calibration domain of the model fitted without them: their cross-validated MSD "
            "includes the model's uncalibrated policy."
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
    require_columns(frame, [(role, name)], path)
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


def _fit_columns(args):
    """The column roles given to ``fit``, checked for consistency."""
    if args.pooling is not None and args.unit is None:
        raise InputError("--pooling says how the units of --unit COL share; give --unit COL")
    if args.unit is not None and args.pooling is None:
        args.pooling = "partial"
    if args.latitude is not None and args.reference is not None:
        raise InputError("give either --reference COL or --latitude DEG --azimuth COL, not both")
    if args.latitude is not None and args.azimuth is None:
        raise InputError("--latitude needs --azimuth COL (the azimuth of each row, degrees)")
    if args.latitude is not None and not -90.0 <= args.latitude <= 90.0:
        raise InputError(f"--latitude must be in [-90, 90] degrees, got {args.latitude:g}")
    _check_input_rate(args)
    columns = Columns(
        input_rate=args.input_rate,
        temperature=args.temperature,
        time=args.time,
        run=args.run,
        rate=args.rate or "rate",
        reference=None if args.latitude is not None else (args.reference or "reference"),
        latitude=args.latitude,
        azimuth=args.azimuth,
        unit=args.unit,
    )
    if args.rate is None:
        columns.defaulted.add("--rate")
    if args.reference is None and args.latitude is None:
        columns.defaulted.add("--reference")
    return columns


def _check_input_rate(args):
    """--input-rate: a column of its own, for one pipeline (no --unit, no --interval)."""
    if args.input_rate is None:
        return
    for option, given in (("--unit", args.unit), ("--interval", args.interval)):
        if given is not None:
            raise InputError(
                f"--input-rate (a scale-factor model) does not take {option} yet; fit one "
                f"model on the rate-table data without {option}"
            )
    roles = [("--rate", args.rate or "rate"), ("--time", args.time), ("--run", args.run)]
    roles += [("--temperature", name) for name in args.temperature]
    for option, name in roles:
        if name == args.input_rate:
            raise InputError(
                f"--input-rate {args.input_rate!r} is also the {option} column; it must be the "
                "column of the true input rate (the rate table's, deg/h)"
            )


def _build_pipeline(columns, args):
    """The package's pipeline on the given columns, with the regressor of ``--model``."""
    from sklearn.linear_model import LinearRegression

    from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline

    if args.model == "linear":
        regressor = LinearRegression()
    else:
        regressor = RBFNetRegressor(random_state=args.random_state)
    temperature = columns.temperature[0] if len(columns.temperature) == 1 else columns.temperature
    pipeline = make_compensation_pipeline(
        regressor,
        temperature=temperature,
        time=columns.time,
        run=columns.run,
        terms=None if args.terms is None else tuple(args.terms),
        input_rate=columns.input_rate,
    )
    if columns.unit is None:
        return pipeline
    from sklearn_ifog import UnitwiseRegressor

    return UnitwiseRegressor(
        pipeline,
        unit=columns.unit,
        pooling=args.pooling,
        run=columns.run,
        n_jobs=args.n_jobs,
        verbose=1,  # a line per unit on stderr: a lot of a hundred units takes minutes
    )


def _warn_several_units(frame, args, path):
    """One stderr line when a 'unit' column holds several units and --unit is not given."""
    if args.unit is not None or "unit" not in frame.columns:
        return
    n_units = frame["unit"].nunique(dropna=True)
    if n_units > 1:
        print(
            f"{PROGRAM} fit: warning: column 'unit' of {path} holds {n_units} units; one model "
            "is fitted across all of them (give --unit unit for one model per unit)",
            file=sys.stderr,
        )


def _unit_cross_validation(args, model, X, target, frame, columns, path):
    """Per-unit table: leave one run of a unit out at a time (each unit needs two runs)."""
    from sklearn.base import clone
    from sklearn.dummy import DummyRegressor
    from sklearn.model_selection import LeaveOneGroupOut

    from sklearn_ifog import UnitwiseRegressor
    from sklearn_ifog.comparison import compare_regressors

    units = _labels(frame, columns.unit, "--unit", path)
    if columns.run is None:
        print(
            "No per-unit cross-validation: it leaves out one run of a unit at a time; give "
            "--run COL."
        )
        return None
    runs = _labels(frame, columns.run, "--run", path)
    pairs = np.unique(np.column_stack([runs.astype(str), units.astype(str)]), axis=0)
    if np.unique(pairs[:, 0]).size != pairs.shape[0]:
        raise InputError(f"{path}: a run straddles several units; each run must be one unit's")
    per_unit = np.unique(pairs[:, 1], return_counts=True)
    lonely = per_unit[0][per_unit[1] < 2]
    if lonely.size:
        print(
            f"No per-unit cross-validation: unit(s) {', '.join(lonely[:5])} have a single "
            "run; it leaves out one run of a unit at a time."
        )
        return None
    candidates = {
        "raw": DummyRegressor(strategy="constant", constant=0.0),
        "bias": UnitwiseRegressor(DummyRegressor(), unit=columns.unit, pooling="none"),
        # the folds quietly: the progress lines are the final fit's
        f"{args.model} ({args.pooling})": clone(model).set_params(verbose=0),
    }
    try:
        with _held_out_outside_counted() as outside:
            summary = compare_regressors(
                X,
                target,
                regressors=candidates,
                cv=LeaveOneGroupOut(),
                groups=runs,
                n_jobs=args.n_jobs,
                by=columns.unit,
            )
    except (ValueError, TypeError) as error:
        raise InputError(f"{path}: cross-validation failed: {one_line(error)}") from None
    print_table(
        "Cross-validated MSD ((deg/h)^2) per unit, one fold per run left out (the bias "
        "baseline is each unit's own mean):",
        # one line per (unit, model): the unit first, every cell written out
        summary[["msd_before", "msd_after", "reduction", "n_folds"]]
        .swaplevel()
        .sort_index(level=0, sort_remaining=False)
        .reset_index()
        .set_index([columns.unit, "model"]),
    )
    _print_held_out_outside(outside, np.unique(runs).size)
    row = summary.xs(f"{args.model} ({args.pooling})", level="model")
    return {
        "kind": "run, per unit",
        "units": {
            str(unit): {
                "msd_before": float(values["msd_before"]),
                "msd_after": float(values["msd_after"]),
                "n_folds": int(values["n_folds"]),
            }
            for unit, values in row.iterrows()
        },
    }


def _cross_validate(args, pipeline, X, target, splitter, groups, path):
    """compare_regressors of the pipeline against no compensation and a constant bias."""
    from sklearn.dummy import DummyRegressor

    from sklearn_ifog.comparison import compare_regressors

    candidates = {
        "raw": DummyRegressor(strategy="constant", constant=0.0),
        "bias": DummyRegressor(strategy="mean"),
        args.model: pipeline,
    }
    try:
        with _held_out_outside_counted() as outside:
            summary = compare_regressors(
                X, target, regressors=candidates, cv=splitter, groups=groups, n_jobs=args.n_jobs
            )
    except (ValueError, TypeError) as error:
        raise InputError(f"{path}: cross-validation failed: {one_line(error)}") from None
    print_table(
        f"Cross-validated MSD ((deg/h)^2), one fold per value of the {args.cv or 'group'} "
        "column left out:",
        summary[["msd_before", "msd_after", "reduction", "n_folds"]],
    )
    row = summary.loc[args.model]
    _print_held_out_outside(outside, int(row["n_folds"]))
    return {
        "kind": args.cv or "groups",
        "msd_before": float(row["msd_before"]),
        "msd_after": float(row["msd_after"]),
        "n_folds": int(row["n_folds"]),
    }


def command_fit(args):
    """``fit``: read, (cross-validate,) fit, save with the column roles."""
    from sklearn_ifog.metrics import mean_squared_deviation
    from sklearn_ifog.persistence import save_model

    columns = _fit_columns(args)
    check_output_parent(args.output)
    path = Path(args.data)
    frame = read_csv(path)
    X, _ = model_input(frame, columns, path)
    target = read_rate(frame, columns, path) - read_reference(frame, columns, path)
    _warn_several_units(frame, args, path)
    pipeline = _build_pipeline(columns, args)
    metadata = {"columns": columns.as_dict()}
    if columns.unit is not None:
        if args.cv is not None or args.groups is not None:
            raise InputError(
                "--unit cross-validates per unit, one run left out at a time; drop --cv and "
                "--groups"
            )
        splitter = None
        cross_validation = _unit_cross_validation(args, pipeline, X, target, frame, columns, path)
    else:
        splitter, groups = _cv_splitter(args, frame, columns, path)
        cross_validation = None
    if splitter is not None:
        cross_validation = _cross_validate(args, pipeline, X, target, splitter, groups, path)
    fit_params = {}
    if getattr(args, "interval", None) is not None:
        pipeline, fit_params = _conformal(args, pipeline, frame, columns, path)
        metadata["interval"] = {"coverage": args.interval}
    try:
        pipeline.fit(X, target, **fit_params)
    except (ValueError, TypeError) as error:
        raise InputError(f"{path}: {one_line(error)}") from None
    _quiet_units(pipeline)
    prediction = np.asarray(pipeline.predict(X), dtype=np.float64).reshape(-1)
    msd_before = float(mean_squared_deviation(target, np.zeros_like(target)))
    msd_after = float(mean_squared_deviation(target, prediction))
    metadata["training"] = {
        "file": path.name,
        "n_samples": int(X.shape[0]),
        "msd_before": msd_before,
        "msd_after": msd_after,
    }
    if cross_validation is not None:
        metadata["cross_validation"] = cross_validation
    save_model(pipeline, args.output, metadata=metadata)
    what = args.model
    if columns.unit is not None:
        lot = getattr(pipeline, "estimator_", pipeline)  # inside ConformalRegressor or not
        what = f"{len(lot.units_)} {args.model} models ({args.pooling} pooling)"
    print(
        f"\nFitted {what} on {X.shape[0]} rows of {path}: training MSD "
        f"{msd_before:.3g} -> {msd_after:.3g} (deg/h)^2 (reduction {msd_before / msd_after:.3g}x)."
    )
    if columns.input_rate is not None:
        _print_scale_factor(frame, columns, X, target, prediction, path)
    print(f"Wrote the model to {args.output}")
    return EXIT_OK


def _print_scale_factor(frame, columns, X, target, prediction, path):
    """One line: the training rows' scale-factor error over temperature, before and after."""
    from sklearn_ifog.metrics import scale_factor_peak_to_peak

    omega = X[columns.input_rate].to_numpy(dtype=np.float64)
    temperature = X[columns.temperature[0]].to_numpy(dtype=np.float64)
    runs = None if columns.run is None else _labels(frame, columns.run, "--run", path)
    before, after = (
        scale_factor_peak_to_peak(omega, error, temperature, run=runs)
        for error in (target, target - prediction)
    )
    print(
        f"Scale-factor error over temperature (peak-to-peak of 10 bins, training rows): "
        f"{before:.3g} -> {after:.3g} ppm."
    )


def _quiet_units(model):
    """Every UnitwiseRegressor of the fitted ``model`` set back to ``verbose=0``.

    The progress lines were for the ``fit`` command; the saved model (and its fitted clones
    inside a ConformalRegressor) refits quietly.
    """
    from sklearn_ifog import UnitwiseRegressor

    parts = [model, getattr(model, "estimator", None), getattr(model, "estimator_", None)]
    folds = getattr(model, "estimators_", None)  # a ConformalRegressor's fold models
    if isinstance(folds, list):
        parts += folds
    for part in parts:
        if isinstance(part, UnitwiseRegressor):
            part.set_params(verbose=0)


def _conformal(args, pipeline, frame, columns, path):
    """(ConformalRegressor around the pipeline, its fit parameters) for ``fit --interval``."""
    from sklearn_ifog.conformal import ConformalRegressor

    check_coverage(args.interval)
    if columns.run is None:
        raise InputError(
            f"{path}: --interval calibrates run by run and needs the run column (--run COL)"
        )
    runs = frame[columns.run].to_numpy()
    n_runs = len(np.unique(runs))
    if n_runs < 2:
        raise InputError(
            f"{path}: --interval needs at least two runs to calibrate on, column "
            f"{columns.run!r} has {n_runs}"
        )
    model = ConformalRegressor(
        pipeline, coverage=args.interval, cv=min(5, n_runs), n_jobs=args.n_jobs
    )
    return model, {"groups": runs}
