"""Real time in the field: streaming latency, chunked throughput, C, and online recalibration.

Run: ``python benchmarks/bench_streaming.py`` (5 judged seeds, 4261-4265) or ``--quick``
(seed 0, a tuning seed; fewer and shorter timing blocks). Writes
``benchmarks/results/bench_streaming[_quick].md`` and ``.json`` (``--out DIR`` elsewhere;
``--output`` is the older spelling).

Everything is measured in one run, against peers of the same run (issue 13):

1. **Latency.** :meth:`StreamingCompensator.step` on one sample of the default pipeline
   (``make_compensation_pipeline(RBFNetRegressor(random_state=0))`` fitted on the
   calibration runs of seed 0), as a ratio to scikit-learn's ``LinearRegression.predict`` on
   one row (fitted on the same features). Blocks of calls of the two alternate, so both see
   the same machine load; each figure is the median over the blocks of the time per call.
   Also, for information: ``adapt="bias"`` / ``"output"`` (no reference; with a reference),
   and a 40-centre network.
2. **Throughput.** ``update`` on chunks of 1,000 rows against the batch ``pipeline.predict``
   of the same rows (alternating, median).
3. **C.** The exported ``{prefix}_step`` without adaptation, and with ``adapt="bias"`` and
   ``"output"`` (``{prefix}_adapt`` on the samples with a reference, 30 % of them), compiled
   with ``cc -std=c99 -Wall -Wextra -Werror -O2``; time per sample, and the largest
   difference to Python over 10,000 samples relative to the largest drift.
4. **An aged unit.** Per seed, one simulated unit (``_cases.streaming_aged_unit``, the
   judged seeds of ``_cases.SEEDS["bench_streaming"]``; 60 s samples, "cycle" chamber profile:
   a calibration programme spans the operating range, low-high-low):
   6 calibration runs of the new unit; then the unit ages
   (:func:`sklearn_ifog.datasets.age_campaign`: bias ``+0.05`` deg/h, thermal sensitivity
   +20 %) and records one recalibration run with a known reference (the unit at rest, its
   true rate known) and 6 later runs on which MSD = mean((rate - drift - reference)²) is
   measured. "Refit": a model fitted from scratch on the aged unit's own calibration runs
   (the same chamber programme as the first calibration, recorded after the ageing). Adapted: the
   new unit's model in a ``StreamingCompensator(adapt=..., forgetting=0.999)`` given the
   recalibration run with its reference, then the later runs without. The same with no
   ageing (the no-harm target).

Targets (exit status 1 when one fails): step latency <= ``0.15`` x LinearRegression.predict
on one row (default pipeline); chunked update of 1,000 rows <= ``1.5`` x batch predict; on the
aged unit, MSD with ``adapt="output"`` <= ``0.5`` x unadapted and <= ``1.3`` x refit, on every
seed; with no ageing, adapted MSD <= ``1.05`` x unadapted on every seed; C with adaptation
equal to Python to 1e-11 (relative to the largest drift; the bound of
``tests/test_export.py``).
``adapt="bias"`` is reported against the same bounds for information.
"""

import argparse
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from sklearn.linear_model import LinearRegression
from threadpoolctl import threadpool_limits

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.export import to_c
from sklearn_ifog.streaming import StreamingCompensator

from _cases import (  # isort: skip
    SEEDS,
    STREAMING_BIAS_SHIFT,
    STREAMING_SENSITIVITY_CHANGE,
    STREAMING_TEST_RUNS,
    streaming_aged_unit,
    streaming_c_samples,
)
from _results import add_out_argument, command_line, publish  # isort: skip
from _verdict import info_line, target_line  # isort: skip

FORGETTING = 0.999
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror"]

# rows: run-start flag, time, has-reference flag, rate, reference, temperature. Mode 0:
# timing (repeat the samples until min_seconds of CPU time); prints "<calls> <seconds>
# <checksum>". Mode 1: one pass, writes the drift of every sample.
C_DRIVER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "ifog.h"

#define WIDTH 6

int main(int argc, char **argv)
{
    long n, i, calls = 0;
    int mode;
    double *rows, min_seconds, seconds = 0.0, checksum = 0.0;
    ifog_real drift[IFOG_N_OUTPUTS];
    ifog_state state;
    clock_t start;
    FILE *in, *out = NULL;
    if (argc != 5) return 1;
    n = atol(argv[1]);
    min_seconds = atof(argv[3]);
    mode = atoi(argv[4]);
    rows = malloc((size_t)(n * WIDTH) * sizeof(double));
    in = fopen(argv[2], "rb");
    if (!rows || !in) return 2;
    if (fread(rows, sizeof(double), (size_t)(n * WIDTH), in) != (size_t)(n * WIDTH)) return 3;
    fclose(in);
    if (mode == 1) {
        out = fopen("out.bin", "wb");
        if (!out) return 4;
    }
    start = clock();
    do {
        ifog_init(&state);
        for (i = 0; i < n; ++i) {
            const double *row = rows + i * WIDTH;
            if (row[0] != 0.0) ifog_reset(&state); /* a new run */
#ifdef IFOG_N_WEIGHTS
            if (row[2] != 0.0) {
                ifog_real rate[1];
                double reference[1];
                rate[0] = row[3];
                reference[0] = row[4];
                ifog_adapt(&state, row[1], row + 5, rate, reference, drift);
            } else {
                ifog_step(&state, row[1], row + 5, drift);
            }
#else
            ifog_step(&state, row[1], row + 5, drift);
#endif
            checksum += (double)drift[0];
            if (out) fwrite(drift, sizeof(ifog_real), 1, out);
        }
        calls += n;
        seconds = (double)(clock() - start) / CLOCKS_PER_SEC;
    } while (mode == 0 && seconds < min_seconds);
    if (out) fclose(out);
    printf("%ld %.9f %.17g\n", calls, seconds, checksum);
    free(rows);
    return 0;
}
"""


def _model():
    return make_compensation_pipeline(RBFNetRegressor(random_state=0))


def _fit(rows):
    return _model().fit(rows, rows["rate"] - rows["reference"])


def _msd(compensated, rows):
    return float(np.mean(np.square(np.asarray(compensated) - rows["reference"].to_numpy())))


def _adapted_msd(model, parts, adapt):
    compensator = StreamingCompensator(model, adapt=adapt, forgetting=FORGETTING)
    recal = parts["recalibration"]
    compensator.update(recal, recal["rate"].to_numpy(), reference=recal["reference"].to_numpy())
    test = parts["test"]
    compensated, _ = compensator.update(test, test["rate"].to_numpy())
    return _msd(compensated, test)


def ageing_study(seeds):
    rows = []
    for seed in seeds:
        for ageing in (True, False):
            parts = streaming_aged_unit(seed, ageing)
            model = _fit(parts["calibration"])
            test = parts["test"]
            row = {
                "seed": seed,
                "ageing": ageing,
                "n_centers": int(model[-1].centers_.shape[0]),
                "unadapted": _msd(test["rate"] - model.predict(test), test),
                "bias": _adapted_msd(model, parts, "bias"),
                "output": _adapted_msd(model, parts, "output"),
            }
            if ageing:
                refit = _fit(parts["aged_calibration"])
                row["refit"] = _msd(test["rate"] - refit.predict(test), test)
            rows.append(row)
    return rows


def _alternate(functions, blocks, calls):
    """Median time per call of each function, timed in alternating blocks."""
    times = {name: [] for name in functions}
    for _ in range(blocks):
        for name, function in functions.items():
            start = time.perf_counter()
            for _ in range(calls):
                function()
            times[name].append((time.perf_counter() - start) / calls)
    return {name: float(np.median(values)) for name, values in times.items()}


def _stepper(compensator, rows, reference=False):
    t = rows["time"].to_numpy().tolist()
    temperature = rows["temperature"].to_numpy().tolist()
    rate = rows["rate"].to_numpy().tolist()
    truth = rows["reference"].to_numpy().tolist()
    state = {"i": 0, "offset": 0.0}
    n = len(t)
    span = t[-1] - t[0] + 60.0

    def step():
        i = state["i"]
        if i == n:
            state["i"] = i = 0
            state["offset"] += span
        if reference:
            compensator.step(t[i] + state["offset"], temperature[i], rate[i], reference=truth[i])
        else:
            compensator.step(t[i] + state["offset"], temperature[i], rate[i])
        state["i"] = i + 1

    return step


def latency_study(blocks, calls):
    parts = streaming_aged_unit(0, ageing=False)
    model = _fit(parts["calibration"])
    test = parts["test"]
    rows = test[test["run"] == test["run"].iloc[0]]  # one run: time increases
    features = model[0].transform(parts["calibration"])
    linear = LinearRegression().fit(features, parts["calibration"]["drift"])
    one_row = features[:1]
    wide = make_compensation_pipeline(
        RBFNetRegressor(n_centers=40, criterion=None, random_state=0)
    ).fit(parts["calibration"], parts["calibration"]["rate"] - parts["calibration"]["reference"])
    functions = {
        "LinearRegression.predict, one row": lambda: linear.predict(one_row),
        "step, default pipeline": _stepper(StreamingCompensator(model), rows),
        'step, adapt="bias", no reference': _stepper(
            StreamingCompensator(model, adapt="bias"), rows
        ),
        'step, adapt="output", no reference': _stepper(
            StreamingCompensator(model, adapt="output"), rows
        ),
        'step, adapt="bias", with reference': _stepper(
            StreamingCompensator(model, adapt="bias"), rows, reference=True
        ),
        'step, adapt="output", with reference': _stepper(
            StreamingCompensator(model, adapt="output"), rows, reference=True
        ),
        "step, 40-centre network": _stepper(StreamingCompensator(wide), rows),
    }
    with threadpool_limits(1):
        step_times = _alternate(functions, blocks, calls)
        chunk = test.iloc[:1000]
        rate = chunk["rate"].to_numpy()
        reference = np.where(np.arange(len(chunk)) % 3 == 0, chunk["reference"], None)
        chunk_functions = {
            "batch predict, 1000 rows": lambda: model.predict(chunk),
            "update, 1000 rows": lambda: StreamingCompensator(model).update(chunk, rate),
            'update, 1000 rows, adapt="output", no reference': lambda: StreamingCompensator(
                model, adapt="output"
            ).update(chunk, rate),
            'update, 1000 rows, adapt="output", 1/3 with reference': lambda: StreamingCompensator(
                model, adapt="output"
            ).update(chunk, rate, reference=reference),
        }
        chunk_times = _alternate(chunk_functions, blocks, max(1, calls // 50))
    return model, parts, step_times, chunk_times, len(chunk), model[-1].centers_.shape[0]


def c_study(model, min_seconds):
    # 10,000 samples of the same unit type every 10 s, 30 % of them with a reference.
    rows, has = streaming_c_samples()
    run = rows["run"].to_numpy()
    starts = np.r_[True, run[1:] != run[:-1]]
    data = np.column_stack(
        [starts, rows["time"], has, rows["rate"], rows["reference"], rows["temperature"]]
    ).astype(np.float64)
    results = {}
    with tempfile.TemporaryDirectory() as directory:
        for adapt in (None, "bias", "output"):
            where = Path(directory) / str(adapt)
            to_c(model, where, adapt=adapt, forgetting=FORGETTING)
            (where / "driver.c").write_text(C_DRIVER)
            subprocess.run(
                ["cc", *STRICT, "-O2", "driver.c", "ifog.c", "-lm", "-o", "driver"],
                cwd=where,
                check=True,
            )
            data.tofile(where / "in.bin")
            out = subprocess.run(
                [where / "driver", str(len(data)), "in.bin", str(min_seconds), "0"],
                cwd=where,
                check=True,
                capture_output=True,
                text=True,
            ).stdout.split()
            seconds_per_call = float(out[1]) / int(out[0])
            subprocess.run(
                [where / "driver", str(len(data)), "in.bin", "0", "1"],
                cwd=where,
                check=True,
                capture_output=True,
            )
            c_drift = np.fromfile(where / "out.bin", dtype=np.float64)
            compensator = StreamingCompensator(model, adapt=adapt, forgetting=FORGETTING)
            reference = None
            if adapt is not None:
                reference = np.where(has, rows["reference"].to_numpy(), None)
            _, drift = compensator.update(rows, rows["rate"].to_numpy(), reference=reference)
            error = float(np.max(np.abs(c_drift - drift)) / np.max(np.abs(drift)))
            results[str(adapt)] = {
                "seconds_per_sample": seconds_per_call,
                "max_relative_difference_to_python": error,
                "n_samples": len(rows),
                "n_references": int(has.sum()) if adapt else 0,
            }
    return results


# The targets on timings (their names' beginnings): judged in full runs only.
TIMING_TARGETS = ("step latency", "update of 1,000 rows")


def _targets(step_times, chunk_times, ageing, c_results):
    lr = step_times["LinearRegression.predict, one row"]
    targets = [
        {
            "target": "step latency <= 0.15 x LinearRegression.predict (one row), default RBF",
            "value": step_times["step, default pipeline"] / lr,
            "bound": 0.15,
        },
        {
            "target": "update of 1,000 rows <= 1.5 x batch predict",
            "value": chunk_times["update, 1000 rows"] / chunk_times["batch predict, 1000 rows"],
            "bound": 1.5,
        },
    ]
    aged = [row for row in ageing if row["ageing"]]
    fresh = [row for row in ageing if not row["ageing"]]
    targets += [
        {
            "target": 'aged unit: adapt="output" MSD <= 0.5 x unadapted (worst seed)',
            "value": max(row["output"] / row["unadapted"] for row in aged),
            "bound": 0.5,
        },
        {
            "target": 'aged unit: adapt="output" MSD <= 1.3 x refit from scratch (worst seed)',
            "value": max(row["output"] / row["refit"] for row in aged),
            "bound": 1.3,
        },
        {
            "target": 'no ageing: adapt="output" MSD <= 1.05 x unadapted (worst seed)',
            "value": max(row["output"] / row["unadapted"] for row in fresh),
            "bound": 1.05,
        },
    ]
    for mode in ("bias", "output"):
        targets.append(
            {
                "target": f'C with adapt="{mode}" equals Python to 1e-11 (10,000 samples)',
                "value": c_results[mode]["max_relative_difference_to_python"],
                "bound": 1e-11,
            }
        )
    for target in targets:
        target["pass"] = bool(target["value"] <= target["bound"])
    info = [
        {
            "target": 'aged unit: adapt="bias" MSD <= 0.5 x unadapted (worst seed; information)',
            "value": max(row["bias"] / row["unadapted"] for row in aged),
            "bound": 0.5,
        },
        {
            "target": 'aged unit: adapt="bias" MSD <= 1.3 x refit (worst seed; information)',
            "value": max(row["bias"] / row["refit"] for row in aged),
            "bound": 1.3,
        },
        {
            "target": 'no ageing: adapt="bias" MSD <= 1.05 x unadapted (worst seed; information)',
            "value": max(row["bias"] / row["unadapted"] for row in fresh),
            "bound": 1.05,
        },
    ]
    for target in info:
        target["pass"] = bool(target["value"] <= target["bound"])
    return targets, info


def _markdown(meta, step_times, chunk_times, c_results, ageing, targets, info):
    lr = step_times["LinearRegression.predict, one row"]
    batch = chunk_times["batch predict, 1000 rows"]
    lines = [
        "# Streaming benchmark: fast step, chunked update, C, online recalibration",
        "",
        f"Command: `{meta['command']}`  ",
        f"{meta['machine']}; {meta['compiler']}; BLAS 1 thread; {meta['date']}. Default "
        f"pipeline: {meta['n_centers']} Gaussian unit(s) selected, {meta['tail']} tail. Timings: "
        f"median over {meta['blocks']} alternating blocks.",
        "",
        "## Latency (one sample)",
        "",
        "| call | µs | × LinearRegression.predict (one row) |",
        "|---|---:|---:|",
    ]
    for name, seconds in step_times.items():
        lines.append(f"| {name} | {seconds * 1e6:.3g} | {seconds / lr:.3g} |")
    for mode, row in c_results.items():
        label = "C step" if mode == "None" else f'C step/adapt, adapt="{mode}" (30 % references)'
        seconds = row["seconds_per_sample"]
        lines.append(f"| {label} | {seconds * 1e6:.3g} | {seconds / lr:.3g} |")
    lines += [
        "",
        "## Throughput (1,000 rows)",
        "",
        "| call | ms | × batch predict |",
        "|---|---:|---:|",
    ]
    for name, seconds in chunk_times.items():
        lines.append(f"| {name} | {seconds * 1e3:.3g} | {seconds / batch:.3g} |")
    lines += [
        "",
        "## C against Python (10,000 samples, 30 % with a reference)",
        "",
        "| adapt | max abs difference / max abs drift |",
        "|---|---:|",
    ]
    for mode, row in c_results.items():
        lines.append(f"| {mode} | {row['max_relative_difference_to_python']:.2g} |")
    lines += [
        "",
        f"## Aged unit (bias +{STREAMING_BIAS_SHIFT} deg/h, thermal sensitivity "
        f"+{STREAMING_SENSITIVITY_CHANGE:.0%}); MSD on {STREAMING_TEST_RUNS} later runs, "
        "(deg/h)²",
        "",
        "| seed | ageing | centres | unadapted | refit | bias | output | output/unadapted | "
        "output/refit | bias/unadapted | bias/refit |",
        "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in ageing:
        refit = row.get("refit")
        cells = [
            str(row["seed"]),
            "yes" if row["ageing"] else "no",
            str(row["n_centers"]),
            f"{row['unadapted']:.3g}",
            "" if refit is None else f"{refit:.3g}",
            f"{row['bias']:.3g}",
            f"{row['output']:.3g}",
            f"{row['output'] / row['unadapted']:.3f}",
            "" if refit is None else f"{row['output'] / refit:.3f}",
            f"{row['bias'] / row['unadapted']:.3f}",
            "" if refit is None else f"{row['bias'] / refit:.3f}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "## Targets", "", "| target | value | bound | verdict |", "|---|---:|---:|---|"]
    for target in targets:
        verdict = "PASS" if target["pass"] else "FAIL"
        lines.append(
            f"| {target['target']} | {target['value']:.4g} | {target['bound']:g} | {verdict} |"
        )
    for target in info:
        verdict = "holds" if target["pass"] else "does not hold"
        lines.append(
            f"| {target['target']} | {target['value']:.4g} | {target['bound']:g} | {verdict} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="seed 0, fewer timing blocks")
    add_out_argument(parser, "--output")
    args = parser.parse_args(argv)
    if shutil.which("cc") is None:
        raise SystemExit("bench_streaming needs a C compiler ('cc').")
    start = time.perf_counter()
    # the ageing study: the judged seeds, or with --quick the tuning seed (0)
    register = SEEDS["bench_streaming"]
    seeds = register["tuning"][:1] if args.quick else register["judged"]
    blocks, calls, min_seconds = (5, 100, 0.05) if args.quick else (41, 500, 1.0)
    model, _, step_times, chunk_times, _, n_centers = latency_study(blocks, calls)
    c_results = c_study(model, min_seconds)
    ageing = ageing_study(seeds)
    targets, info = _targets(step_times, chunk_times, ageing, c_results)
    compiler = subprocess.run(["cc", "--version"], capture_output=True, text=True, check=True)
    meta = {
        "command": command_line(__file__, argv, drop=("--out", "--output")),
        "machine": platform.platform(),
        "compiler": compiler.stdout.splitlines()[0],
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "blocks": blocks,
        "n_centers": int(n_centers),
        "tail": {0: "no", 1: "linear", 2: "quadratic"}[int(model[-1].tail_degree_)],
        "seeds": list(seeds),
    }
    markdown = _markdown(meta, step_times, chunk_times, c_results, ageing, targets, info)
    name = "bench_streaming_quick" if args.quick else "bench_streaming"
    record = {
        **meta,
        "latency_seconds": step_times,
        "throughput_seconds": chunk_times,
        "c": c_results,
        "ageing": ageing,
        "targets": targets,
        "information": info,
    }
    # Timings over a few blocks of a quick run on a shared machine are not a verdict: the
    # quick run prints them as information, the full run judges them.
    timed = [t for t in targets if args.quick and t["target"].startswith(TIMING_TARGETS)]
    judged = [t for t in targets if t not in timed]
    verdicts = [
        target_line(t["pass"], f"{t['target']}: {t['value']:.4g} (bound {t['bound']:g})")
        for t in judged
    ] + [
        info_line(t["pass"], f"{t['target']}: {t['value']:.4g} (bound {t['bound']:g})")
        for t in timed
    ]
    publish(
        args.out,
        name,
        markdown,
        record,
        script=__file__,
        command=meta["command"],
        seconds=time.perf_counter() - start,
        verdicts=verdicts,
    )
    return 0 if all(target["pass"] for target in judged) else 1


if __name__ == "__main__":
    sys.exit(main())
