"""The ``sklearn-ifog`` entry point: parse the command line and dispatch to a command."""

import argparse
import sys
from pathlib import Path

from sklearn_ifog import _version
from sklearn_ifog.cli._common import (
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    PROGRAM,
    InputError,
    one_line,
)
from sklearn_ifog.cli._compensate import command_compensate, command_report
from sklearn_ifog.cli._demo import DEMO_SIZES, run_demo
from sklearn_ifog.cli._export import command_export
from sklearn_ifog.cli._fit import command_fit

__all__ = ["main"]


def _terms_help():
    """The help of ``fit --terms``: ThermalFeatures' ``terms="auto"``, read from the code."""
    from sklearn_ifog._contract import (
        DEFAULT_ROW_TERMS,
        DEFAULT_SMOOTHING,
        DEFAULT_STATE_TERMS,
        DEFAULT_TERMS,
        traditional_terms,
    )

    return (
        "thermal terms (default: ThermalFeatures' terms='auto': "
        f"{' '.join(DEFAULT_STATE_TERMS)}, dT smoothed over {DEFAULT_SMOOTHING:g} s, with a "
        f"time column; {' '.join(DEFAULT_ROW_TERMS)} without one; "
        f"'{' '.join(DEFAULT_TERMS)}' is the paper's modified model, "
        f"'{' '.join(traditional_terms(DEFAULT_TERMS))}' its traditional one)"
    )


def command_demo(args):
    """``demo``: :func:`~sklearn_ifog.cli._demo.run_demo` into ``--out``."""
    run_demo(Path(args.out), quick=args.quick, size=args.size, n_jobs=args.n_jobs)
    return EXIT_OK


def _add_demo(commands):
    """The ``demo`` command: simulate, compare, plot and report."""
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
    demo.add_argument("--size", choices=tuple(DEMO_SIZES), default=None, help=argparse.SUPPRESS)
    demo.add_argument("--n-jobs", type=int, default=None, help="parallel jobs (default: cores)")
    demo.set_defaults(handler=command_demo)


def _add_fit(commands):
    """The ``fit`` command: fit a drift model to a thermal-test CSV and save it."""
    fit = commands.add_parser(
        "fit",
        help="fit a drift model to a thermal-test CSV",
        description="Fit ThermalFeatures -> StandardScaler -> RBFNetRegressor (or a linear "
        "model) to the drift, rate - reference (or rate - Earth rate), and save it with the "
        "column roles, so that 'compensate', 'report' and 'export' need only the model file. "
        "With --cv or --groups, first cross-validate it against no compensation and a "
        "constant bias. With --unit, one model per unit (gyro) of a lot, cross-validated "
        "per unit.",
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
        "--input-rate",
        metavar="COL",
        help="true input rate column (deg/h) of rate-table data, usually the --reference "
        "column: learn the scale factor too, the drift as bias + input rate x scale-factor "
        "error, both over temperature; 'compensate' then writes the estimated input rate",
    )
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
        default=None,
        metavar="TERM",
        help=_terms_help(),
    )
    fit.add_argument(
        "--unit",
        metavar="COL",
        help="unit (gyro) id column: fit one model per unit (UnitwiseRegressor) and show a "
        "per-unit cross-validation table",
    )
    fit.add_argument(
        "--pooling",
        choices=("partial", "none", "full"),
        default=None,
        help="with --unit: how the units share (default: partial, each unit's output layer "
        "shrunk towards the lot's)",
    )
    fit.add_argument("--model", choices=("rbf", "linear"), default="rbf", help="regressor")
    fit.add_argument("--random-state", type=int, default=0, help="seed of the RBF network")
    fit.add_argument(
        "--n-jobs",
        type=int,
        default=None,
        help="parallel jobs: cross-validation folds, the units of --unit and the folds of "
        "--interval (default: one at a time; -1: all cores)",
    )
    fit.add_argument(
        "--interval",
        type=float,
        default=None,
        metavar="COVERAGE",
        help="also calibrate prediction intervals (ConformalRegressor, run by run, 5 folds "
        "of runs; needs --run and at least two runs), e.g. 0.9",
    )
    fit.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="MODEL",
        help="model file: skops format for a .skops suffix, joblib otherwise",
    )
    fit.set_defaults(handler=command_fit)


def _add_compensate(commands):
    """The ``compensate`` command: add the drift and the compensated rate to a CSV."""
    compensate = commands.add_parser(
        "compensate",
        help="add the predicted drift and the compensated rate to a CSV",
        description="Add the predicted drift and the compensated rate (rate - drift) to a "
        "CSV. For a model that knows its calibration domain (any model fitted by this "
        "version), also add 'outside_calibration' (True where the row lies outside the "
        "temperatures, rates and thermal states the model was calibrated on; its "
        "prediction there follows the model's uncalibrated policy) and 'calibration_distance' "
        "(decorrelated standard deviations from the calibrated box), and print one line "
        "per run with rows outside. For a model fitted with --input-rate (a scale factor), "
        "the compensated column is the estimated input rate (rate - bias) / (1 + "
        "scale-factor error ± asymmetry), deg/h, and the drift column rate minus it; the "
        "file needs no input-rate column (the output stands in for it in the calibration "
        "check).",
    )
    compensate.add_argument("model", metavar="MODEL")
    compensate.add_argument("data", metavar="DATA.csv")
    compensate.add_argument("-o", "--output", required=True, metavar="OUT.csv")
    compensate.add_argument("--drift-column", default="drift", metavar="NAME")
    compensate.add_argument("--compensated-column", default="compensated", metavar="NAME")
    compensate.add_argument(
        "--interval",
        type=float,
        default=None,
        metavar="COVERAGE",
        help="add the drift band's bounds as <drift>_lower and <drift>_upper columns "
        "(a model fitted with 'fit --interval'), e.g. 0.9",
    )
    compensate.set_defaults(handler=command_compensate)


def _add_report(commands):
    """The ``report`` command: a compensation's metrics and figures."""
    report = commands.add_parser(
        "report",
        help="MSD, bias stability, Allan deviation and plots of a compensation",
        description="Write a report (HTML and Markdown, with PNG figures) of a model's "
        "compensation of a CSV: MSD and bias stability per run before and after, the raw "
        "and compensated output with the temperature, the Allan deviation; for a model "
        "that knows its calibration domain, the rows outside it per run (share, largest "
        "distance, degrees C beyond the calibrated temperatures), what the model did there, "
        "and those stretches shaded in the figures. For a model fitted with --input-rate, a "
        "scale-factor section: ppm per temperature bin before and after, its peak-to-peak, "
        "linearity, asymmetry and the residual at each input rate.",
    )
    report.add_argument("model", metavar="MODEL")
    report.add_argument("data", metavar="DATA.csv")
    report.add_argument("--out", required=True, metavar="DIR")
    report.set_defaults(handler=command_report)


def _add_export(commands):
    """The ``export`` command: a model as C99 source or JSON."""
    export = commands.add_parser(
        "export",
        help="write a model as C99 source or JSON (a per-unit model: one C source per unit, "
        "one JSON file with every unit)",
    )
    export.add_argument("model", metavar="MODEL")
    target = export.add_mutually_exclusive_group(required=True)
    target.add_argument("--c", metavar="DIR", help="directory for the .h/.c files")
    target.add_argument("--json", metavar="FILE", help="JSON file")
    export.add_argument("--precision", choices=("double", "float"), default="double")
    export.add_argument("--prefix", default="ifog", help="C identifier prefix")
    export.set_defaults(handler=command_export)


def _build_parser():
    parser = argparse.ArgumentParser(
        prog=PROGRAM,
        description="Learn and remove the temperature drift of fibre-optic gyroscopes.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version.__version__}")
    parser.add_argument(
        "--debug", action="store_true", help="show the traceback of internal errors"
    )
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    _add_demo(commands)
    _add_fit(commands)
    _add_compensate(commands)
    _add_report(commands)
    _add_export(commands)
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
        0 on success, 2 on bad input (one line on stderr says what), 1 on an internal error,
        130 when interrupted.

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
        return exit_request.code if isinstance(exit_request.code, int) else EXIT_BAD_INPUT
    try:
        return args.handler(args)
    except InputError as error:
        print(f"{PROGRAM} {args.command}: error: {one_line(error)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{PROGRAM} {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as error:
        if args.debug:
            raise
        print(
            f"{PROGRAM} {args.command}: internal error: {type(error).__name__}: "
            f"{one_line(error)} (rerun with --debug for the traceback)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL
