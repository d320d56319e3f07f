"""The network alone on the recording's interleaved bursts, at each tail penalty.

Run (about 10 s)::

    python benchmarks/tail_penalty_check.py

``--quick`` (CI): the even->odd split only. Writes
``benchmarks/results/tail_penalty[_quick].md`` and ``.json`` (``--out DIR`` elsewhere).

Issue 41 asks for a network that needs no rescue by the calibration domain: on the shipped
recording (``real_per_second``: one row per second, one run, a time column, so the default
features with their lags), calibrated on the even bursts and used on the odd ones (and the
reverse), the default network alone (``uncalibrated="none"``) should leave at most 2 x the MSD of
a line in T. Its linear tail sits on eight nearly collinear features. This table gives the
network alone for both shapes of the tail penalty (``tail_penalty="ridge"``, the plain
ridge, and ``"spread"``, the default: each principal direction of the tail features charged
in inverse proportion to its variance) at each strength ``tail_alpha`` (fixed, and
``"auto"``: chosen by the network's own cross-validation), with the strength used and the
number of Gaussian units kept. The default strength was chosen on the simulator's tuning
seeds (``bench_thermal_state.py``), not here: the recording is judged (by this script and
``bench_extrapolation.py``), and this table only reports it.
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.linear_model import LinearRegression

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _cases import EXTRAPOLATION_REAL_SPLITS, real_per_second
from _results import add_out_argument, command_line, publish

SPLITS = ("even->odd bursts", "odd->even bursts")
AXES = ("gyro_x", "gyro_y")
TAIL_ALPHAS = (0.0, "auto", 1e-5, 1e-4, 1e-3, 1e-2, 1e-1)
TAIL_PENALTIES = ("spread", "ridge")
_DEFAULTS = RBFNetRegressor().get_params()
DEFAULT = f"{_DEFAULTS['tail_penalty']} {_DEFAULTS['tail_alpha']}"


def network_alone(X_cal, y_cal, X_op, tail_alpha, tail_penalty):
    """The default pipeline's network with ``tail_alpha`` and ``tail_penalty``, without its
    uncalibrated policy: its predictions of ``X_op``, the strength it used and its centres."""
    model = make_compensation_pipeline(
        RBFNetRegressor(random_state=0, tail_alpha=tail_alpha, tail_penalty=tail_penalty),
        uncalibrated="none",
    ).fit(X_cal, y_cal)
    network = model.named_steps["regressor"]
    used = network.selection_path_.get("tail_alpha", tail_alpha)
    return model.predict(X_op), float(used), int(network.centers_.shape[0])


def case(split, axis):
    table = real_per_second(AXES)
    calibrate = EXTRAPOLATION_REAL_SPLITS[split](table["burst"].to_numpy())
    X = table[["run", "time", "temperature"]]
    y = table[axis].to_numpy()
    X_cal, y_cal, X_op, y_op = X[calibrate], y[calibrate], X[~calibrate], y[~calibrate]
    line = LinearRegression().fit(X_cal[["temperature"]], y_cal)
    line_msd = float(np.mean((y_op - line.predict(X_op[["temperature"]])) ** 2))
    record = {"line in T": line_msd, "networks": {}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for tail_penalty, tail_alpha in _settings():
            prediction, used, centres = network_alone(X_cal, y_cal, X_op, tail_alpha, tail_penalty)
            record["networks"][f"{tail_penalty} {tail_alpha}"] = {
                "ratio to the line": float(np.mean((y_op - prediction) ** 2)) / line_msd,
                "tail_alpha used": used,
                "centres": centres,
            }
    return record


def _settings():
    """Every (shape, strength) measured; a free tail (0) once, whatever its shape."""
    return [("ridge", 0.0)] + [
        (shape, alpha) for shape in TAIL_PENALTIES for alpha in TAIL_ALPHAS if alpha != 0.0
    ]


def markdown(records, command, seconds):
    out = [
        "# The network alone on the recording's interleaved bursts, by tail penalty",
        "",
        f"Command: `{command}` ({seconds:.0f} s). The network alone's MSD (uncalibrated='none') "
        "over the line in T's, on the compensated bursts; in brackets the relative tail "
        "penalty used and the Gaussian units kept. One row per shape and strength "
        f"(the default: {DEFAULT}); a free tail (0) has no shape.",
        "",
        "| tail_penalty, tail_alpha | " + " | ".join(f"{s}, {a}" for s, a in records) + " |",
        "|---|" + "---|" * len(records),
    ]
    for tail_penalty, tail_alpha in _settings():
        key = f"{tail_penalty} {tail_alpha}"
        label = "free tail, 0" if tail_alpha == 0.0 else f"{tail_penalty}, {tail_alpha}"
        if key == DEFAULT:
            label += " (default)"
        cells = []
        for record in records.values():
            entry = record["networks"][key]
            cells.append(
                f"{entry['ratio to the line']:.3f} "
                f"({entry['tail_alpha used']:g}, {entry['centres']})"
            )
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI mode: one split")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    splits = SPLITS[:1] if args.quick else SPLITS
    records = {(split, axis): case(split, axis) for split in splits for axis in AXES}
    seconds = time.perf_counter() - started
    command = command_line(__file__, argv)
    publish(
        args.out,
        "tail_penalty" + ("_quick" if args.quick else ""),
        markdown(records, command, seconds),
        {f"{split}|{axis}": record for (split, axis), record in records.items()},
        script=__file__,
        command=command,
        seconds=seconds,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
