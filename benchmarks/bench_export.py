"""Deployment speed: compiled C against Python streaming and the batch ``predict``.

Run: ``.venv/bin/python benchmarks/bench_export.py`` (``--quick`` for a smoke run, which CI
runs; ``--out DIR`` to write elsewhere, ``--output`` being the older spelling). Writes
``benchmarks/results/bench_export.md`` and ``.json``.

One simulated campaign (``_cases.export_run``), one fitted Pipeline per model
(ThermalFeatures → StandardScaler → RBFNetRegressor with 40 Gaussian units and its default
tail, and a Ridge baseline), measured in one run, on one core:

- C: the exported ``{prefix}_step`` (double and float), compiled with ``cc -O2`` in a
  temporary directory and timed inside the driver with ``clock()`` (CPU time), over the same
  samples as Python, repeated to last at least ``--min-seconds``;
- Python streaming: :meth:`StreamingCompensator.step` per sample, and
  :meth:`StreamingCompensator.update` in chunks of ``--chunk`` samples;
- Python batch: ``pipeline.predict`` on all samples at once (BLAS limited to one thread).

Speeds are samples per second (best of ``--repeats``), reported with their ratio to the batch
``predict``. Timings are noisy on a shared machine: read the ratios, not the absolute values.

No target is stated for these speeds, so the script prints no verdict and exits 0 when it
ran (non-zero only when it could not: no C compiler, a compile or run error).
"""

import argparse
import os
import platform
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from sklearn.linear_model import Ridge
from threadpoolctl import threadpool_limits

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.export import to_c
from sklearn_ifog.streaming import StreamingCompensator

from _cases import export_run  # isort: skip
from _results import add_out_argument, command_line, write_results  # isort: skip

# Loops over the samples, calling the streaming step, until at least min_seconds of CPU time
# have passed; prints "<calls> <seconds> <checksum>" (the checksum keeps the work alive).
TIMING_DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "ifog.h"

int main(int argc, char **argv)
{
    long n, i, calls = 0;
    double *rows, min_seconds, seconds = 0.0, checksum = 0.0;
    ifog_real drift[IFOG_N_OUTPUTS];
    ifog_state state;
    clock_t start;
    FILE *in;
    if (argc != 4) return 1;
    n = atol(argv[1]);
    min_seconds = atof(argv[3]);
    rows = malloc((size_t)(n * (1 + IFOG_N_SENSORS)) * sizeof(double));
    in = fopen(argv[2], "rb");
    if (!rows || !in) return 2;
    if (fread(rows, sizeof(double), (size_t)(n * (1 + IFOG_N_SENSORS)), in)
        != (size_t)(n * (1 + IFOG_N_SENSORS))) return 3;
    fclose(in);
    start = clock();
    while (seconds < min_seconds) {
        ifog_init(&state);
        for (i = 0; i < n; ++i) {
            const double *row = rows + i * (1 + IFOG_N_SENSORS);
            ifog_step(&state, row[0], row + 1, drift);
            checksum += (double)drift[0];
        }
        calls += n;
        seconds = (double)(clock() - start) / CLOCKS_PER_SEC;
    }
    printf("%ld %.9f %.17g\n", calls, seconds, checksum);
    free(rows);
    return 0;
}
"""


def _pin_to_one_core():
    """Run this process (and the C driver it starts) on one core, where the OS allows it."""
    if hasattr(os, "sched_setaffinity"):
        core = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {core})
        return f"pinned to core {core}"
    return "not pinned (no sched_setaffinity)"


def _models(frame, quick):
    # A fixed number of Gaussian units (criterion=None): the cost measured is that of a
    # network of this size (40 is the "auto" maximum), whatever the selection would keep.
    rbf = RBFNetRegressor(
        n_centers=15 if quick else 40,
        criterion=None,
        refine=None if quick else "varpro",
        random_state=0,
    )
    return {
        "RBF network": make_compensation_pipeline(rbf),
        "Ridge baseline": make_compensation_pipeline(Ridge(alpha=1e-3)),
    }


def _best(function, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def _c_speed(model, run, precision, directory, min_seconds):
    directory = Path(directory) / precision
    to_c(model, directory, precision=precision)
    (directory / "driver.c").write_text(TIMING_DRIVER)
    subprocess.run(
        ["cc", "-std=c99", "-O2", "driver.c", "ifog.c", "-lm", "-o", "driver"],
        cwd=directory,
        check=True,
    )
    rows = np.column_stack([run["time"], run["temperature"]]).astype(np.float64)
    rows.tofile(directory / "in.bin")
    out = subprocess.run(
        [directory / "driver", str(len(rows)), "in.bin", str(min_seconds)],
        cwd=directory,
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    calls, seconds = int(out[0]), float(out[1])
    return calls / seconds


def measure(n_samples, repeats, chunk, min_seconds, quick):
    frame, run = export_run(n_samples)
    step_samples = run.iloc[: min(len(run), 300 if quick else 2000)]
    results = []
    with tempfile.TemporaryDirectory() as directory, threadpool_limits(1):
        for name, model in _models(frame, quick).items():
            model.fit(frame, frame["drift"])
            batch = len(run) / _best(lambda model=model: model.predict(run), repeats)

            def stream_steps(model=model):
                compensator = StreamingCompensator(model)
                for t, temperature, rate in zip(
                    step_samples["time"],
                    step_samples["temperature"],
                    step_samples["rate"],
                    strict=True,
                ):
                    compensator.step(t, temperature, rate)

            def stream_chunks(model=model):
                compensator = StreamingCompensator(model)
                for start in range(0, len(run), chunk):
                    rows = run.iloc[start : start + chunk]
                    compensator.update(rows, rows["rate"])

            step = len(step_samples) / _best(stream_steps, repeats)
            chunked = len(run) / _best(stream_chunks, repeats)
            speeds = {
                "C step, double (-O2)": _c_speed(model, run, "double", directory, min_seconds),
                "C step, float (-O2)": _c_speed(model, run, "float", directory, min_seconds),
                "Python batch predict": batch,
                f"Python streaming update (chunks of {chunk})": chunked,
                "Python streaming step": step,
            }
            n_centers = getattr(model[-1], "centers_", np.empty((0, 0))).shape[0]
            for method, speed in speeds.items():
                results.append(
                    {
                        "model": name,
                        "n_centers": n_centers,
                        "method": method,
                        "samples_per_second": speed,
                        "microseconds_per_sample": 1e6 / speed,
                        "ratio_to_batch_predict": speed / batch,
                    }
                )
    return results, len(run)


def _markdown(results, meta):
    lines = [
        "# Export benchmark: compiled C vs Python streaming vs batch predict",
        "",
        f"Command: `{meta['command']}`  ",
        f"{meta['samples']} samples of one simulated run; single core ({meta['affinity']}, "
        f"BLAS 1 thread); {meta['compiler']}; best of {meta['repeats']}; {meta['date']}.",
        "",
        "| model | method | samples/s | µs/sample | × batch predict |",
        "|---|---|---:|---:|---:|",
    ]
    for row in results:
        model = row["model"]
        if row["n_centers"]:
            model += f" ({row['n_centers']} centres)"
        lines.append(
            f"| {model} | {row['method']} | {row['samples_per_second']:.3g} | "
            f"{row['microseconds_per_sample']:.3g} | {row['ratio_to_batch_predict']:.3g} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1000, help="samples of the run")
    parser.add_argument("--repeats", type=int, default=5, help="best of this many")
    parser.add_argument("--chunk", type=int, default=100, help="streaming chunk size")
    parser.add_argument("--min-seconds", type=float, default=0.5, help="C timing duration")
    parser.add_argument("--quick", action="store_true", help="small smoke run")
    add_out_argument(parser, "--output")
    args = parser.parse_args(argv)
    if shutil.which("cc") is None:
        raise SystemExit("bench_export needs a C compiler ('cc').")
    start = time.perf_counter()
    if args.quick:
        args.repeats, args.min_seconds = 2, 0.1
    affinity = _pin_to_one_core()
    results, n_samples = measure(
        args.samples, args.repeats, args.chunk, args.min_seconds, args.quick
    )
    compiler = subprocess.run(["cc", "--version"], capture_output=True, text=True, check=True)
    meta = {
        "command": command_line(__file__, argv, drop=("--out", "--output")),
        "samples": n_samples,
        "repeats": args.repeats,
        "affinity": affinity,
        "compiler": compiler.stdout.splitlines()[0],
        "machine": platform.platform(),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    markdown = _markdown(results, meta)
    # No target, so no verdict lines.
    write_results(
        args.out,
        "bench_export",
        markdown,
        {**meta, "results": results},
        script=__file__,
        command=meta["command"],
        seconds=time.perf_counter() - start,
    )
    print(markdown)


if __name__ == "__main__":
    main()
