"""A production line's scale: what a lot of gyros costs to fit, serially and in parallel.

Run (about 9 minutes on two cores)::

    .venv/bin/python benchmarks/bench_scale.py

``--quick`` (CI): 2, 3 and 4 units of 2 runs at 600 s sampling, lots of the tuning seed. At
that size only the Dask target is judged (a regression guard: equal predictions); the timing
targets print as ``INFO`` (a toy lot's timings say nothing about a lot's). Writes
``benchmarks/results/scale[_quick].md`` and ``.json`` (``--out DIR`` elsewhere). The lots
are built in ``_cases.py`` (its ``bench_scale`` section; the full run draws them with the
judged seed of ``SEEDS["bench_scale"]``).

Measures ``UnitwiseRegressor`` around the default pipeline
(``make_compensation_pipeline(RBFNetRegressor(random_state=0))``) on simulated lots of similar
units (``make_thermal_campaign``, one azimuth, ``--runs`` runs of about 280 rows per unit,
``lot_spread=0.2``), every ratio from timings taken in this run, one after the other:

- ``pooling="none"`` on 10, 30 and 100 units, and the exponent of its fit time against the
  number of units (least squares on the logs);
- ``pooling="partial"`` (the default) on 10 units against ``"none"`` on the same lot, and on
  100 units in seconds;
- ``n_jobs=2`` against serial (``n_jobs=None``) on 30 units with ``"none"``, the worker
  processes started beforehand (their start-up timed on its own), in ``PARALLEL_PAIRS``
  pairs of fits timed back to back (serial, then parallel; one pair in ``--quick``), with
  the cores this process sees, the load average before the pairs, and how many cores a
  serial fit already keeps busy (numpy's BLAS threads). **The judged statistic**, fixed in
  issue 42 before the measurement it judges and not to be changed after one is seen: the
  median of the five ratios (n_jobs=2 time / serial time) of five pairs. Every pair (both
  times and its ratio) is printed in the results table and in the target's line. (Before,
  the protocol had moved from one measurement, which failed, to the median of three pairs,
  which passed: a statistic chosen after its result.)
- a two-worker Dask ``LocalCluster`` (``joblib.parallel_config(backend="dask")``) against
  serial on 10 units: the largest absolute difference of the predictions.

Targets (issue 26; a FAIL line each, exit 1 when one fails):

- ``"partial"`` fit <= 3 x ``"none"`` on 10 units;
- 100 units with the default pooling in <= 300 s;
- ``"none"``: fitted exponent of time against units <= 1.1;
- ``n_jobs=2`` <= 0.6 x serial on 30 units, the median ratio of the five pairs (meaningful
  on an idle machine with two cores or more: the cores and the load are printed beside it);
- Dask equal to serial within 1e-12.

The network's own scale (fit and predict at 1e6 rows against its peers) is measured by
``rbf_scale_check.py``.
"""

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import joblib
import numpy as np

from sklearn_ifog import RBFNetRegressor, UnitwiseRegressor, make_compensation_pipeline

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _cases import SEEDS, scale_sizes
from _cases import scale_lot as lot
from _results import add_out_argument, command_line, write_results
from _verdict import exit_code, verdict_line

PARTIAL_RATIO = 3.0  # "partial" fit <= 3 x "none"
LARGE_LOT_SECONDS = 300.0  # 100 units with the default pooling
UNIT_EXPONENT = 1.1  # "none": time ~ units ** exponent
PARALLEL_RATIO = 0.6  # n_jobs=2 against serial
# Pairs of fits (serial, then n_jobs=2, back to back on the same lot) whose median ratio is
# judged: a serial fit timed early against a parallel one timed minutes later moved from run
# to run, on an idle two-core machine, by more than its margin to the target. Five, fixed
# in issue 42 before measuring (see the module docstring).
PARALLEL_PAIRS = 5
DASK_TOLERANCE = 1e-12


def timed_fit(X, y, pooling, n_jobs=None, cpu=None):
    """(seconds, fitted model) of one UnitwiseRegressor fit; ``cpu``: a dict that receives
    the CPU seconds of this process (BLAS threads included, worker processes not)."""
    model = UnitwiseRegressor(
        make_compensation_pipeline(RBFNetRegressor(random_state=0)), pooling=pooling, n_jobs=n_jobs
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        before = os.times()
        start = time.perf_counter()
        model.fit(X, y)
        after = os.times()
    if cpu is not None:
        cpu["seconds"] = (after.user + after.system) - (before.user + before.system)
    return time.perf_counter() - start, model


def dask_difference(X, y):
    """Largest |prediction difference| between a two-worker Dask cluster and serial."""
    import distributed

    _, serial = timed_fit(X, y, "none")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster),
        joblib.parallel_config(backend="dask"),
    ):
        _, spread = timed_fit(X, y, "none", n_jobs=-1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return float(np.max(np.abs(spread.predict(X) - serial.predict(X))))


def measure(units, n_runs, sampling_period, seed, log=print):
    """Every timing of the module docstring, in turn, on lots drawn with ``seed``."""
    small, middle, large = units
    record = {"cores": os.cpu_count(), "load_before": os.getloadavg()[0], "none": {}}
    record["seed"] = seed
    lots = {n: lot(n, n_runs, sampling_period, seed) for n in units}
    record["rows_per_unit"] = int(lots[small][0].shape[0] / small)
    cpu = {}
    for n in units:
        record["none"][n], _ = timed_fit(*lots[n], "none", cpu=cpu if n == large else None)
        log(f"none, {n} units: {record['none'][n]:.1f} s")
    # cores a serial fit keeps busy (numpy's BLAS threads): what n_jobs can still add
    record["serial_cores_used"] = cpu["seconds"] / record["none"][large]
    record["partial_small"], partial = timed_fit(*lots[small], "partial")
    record["own_models_small"] = sum(v is None for v in partial.shrinkage_.values())
    log(f"partial, {small} units: {record['partial_small']:.1f} s")
    record["partial_large"], _ = timed_fit(*lots[large], "partial")
    log(f"partial, {large} units: {record['partial_large']:.1f} s")
    record["load_parallel"] = os.getloadavg()[0]
    # the worker processes start, and import the package, once per session (loky reuses
    # them): a two-unit fit starts them beforehand, so that the ratio is the fits' (the
    # start-up is timed and reported on its own)
    X_small, y_small = lots[small]
    two = X_small["unit"].isin(np.unique(X_small["unit"])[:2]).to_numpy()
    record["worker_startup"], _ = timed_fit(X_small[two], y_small[two], "none", n_jobs=2)
    record["parallel_pairs"] = []
    for _ in range(PARALLEL_PAIRS if large >= 100 else 1):  # one pair on the quick lots
        serial, _ = timed_fit(*lots[middle], "none")
        parallel, _ = timed_fit(*lots[middle], "none", n_jobs=2)
        record["parallel_pairs"].append([serial, parallel])
        log(f"{middle} units, serial {serial:.1f} s, n_jobs=2 {parallel:.1f} s")
    ratios = [parallel / serial for serial, parallel in record["parallel_pairs"]]
    record["parallel_ratios"] = ratios
    # the judged statistic: the median of the pairs' ratios (an odd count: one pair's)
    record["parallel_ratio"] = float(np.median(ratios))
    pair = sorted(record["parallel_pairs"], key=lambda p: p[1] / p[0])[len(ratios) // 2]
    record["parallel_middle"] = pair[1]
    record["parallel_serial"] = pair[0]
    record["dask_difference"] = dask_difference(*lots[small])
    log(f"dask against serial: {record['dask_difference']:.3g}")
    logs = np.log([float(n) for n in units])
    times = np.log([record["none"][n] for n in units])
    record["unit_exponent"] = float(np.polyfit(logs, times, 1)[0])
    return record


def checks(record, units, quick=False):
    """``(passed, text, judged)`` per target; with ``quick`` only the Dask one is judged."""
    small, middle, large = units
    ratio_partial = record["partial_small"] / record["none"][small]
    ratio_parallel = record["parallel_ratio"]
    pairs = ", ".join(
        f"{serial:.2f} s / {parallel:.2f} s = {parallel / serial:.3f}"
        for serial, parallel in record["parallel_pairs"]
    )
    timing = not quick
    return [
        (
            ratio_partial <= PARTIAL_RATIO,
            f"partial fit <= {PARTIAL_RATIO:g} x none on {small} units ({ratio_partial:.3f})",
            timing,
        ),
        (
            record["partial_large"] <= LARGE_LOT_SECONDS,
            f"{large} units with the default pooling in <= {LARGE_LOT_SECONDS:g} s "
            f"({record['partial_large']:.1f} s)",
            timing,
        ),
        (
            record["unit_exponent"] <= UNIT_EXPONENT,
            f"none: fit time ~ units ** exponent, exponent <= {UNIT_EXPONENT:g} "
            f"({record['unit_exponent']:.3f})",
            timing,
        ),
        (
            ratio_parallel <= PARALLEL_RATIO,
            f"n_jobs=2 <= {PARALLEL_RATIO:g} x serial on {middle} units, the median ratio of "
            f"{len(record['parallel_pairs'])} pairs timed back to back "
            f"({ratio_parallel:.3f}; pairs serial / n_jobs=2: {pairs}; "
            f"{record['cores']} cores seen, load {record['load_parallel']:.2f}, a serial fit "
            f"keeps {record['serial_cores_used']:.2f} cores busy)",
            timing,
        ),
        (
            record["dask_difference"] <= DASK_TOLERANCE,
            f"two-worker Dask cluster equal to serial within {DASK_TOLERANCE:g} "
            f"({record['dask_difference']:.3g})",
            True,
        ),
    ]


def markdown(record, units, lines, command, seconds):
    small, middle, large = units
    best = min(1.0, record["serial_cores_used"] / 2.0)  # the same CPU time over two cores
    out = [
        "# A production line's scale",
        "",
        f"Command: `{command}` ({seconds:.0f} s). {record['cores']} cores seen, load average "
        f"{record['load_before']:.2f} before the run; lots of seed {record['seed']}, about "
        f"{record['rows_per_unit']} rows per unit. See the script's docstring for the lots "
        "and the targets.",
        "",
        "| fit | units | seconds | per unit |",
        "|---|---|---|---|",
    ]
    for n in units:
        out.append(f"| none | {n} | {record['none'][n]:.2f} | {record['none'][n] / n:.3f} |")
    out.append(
        f"| partial | {small} | {record['partial_small']:.2f} | "
        f"{record['partial_small'] / small:.3f} |"
    )
    out.append(
        f"| partial | {large} | {record['partial_large']:.2f} | "
        f"{record['partial_large'] / large:.3f} |"
    )
    out.append(
        f"| none, n_jobs=2 (the median pair) | {middle} | {record['parallel_middle']:.2f} | "
        f"{record['parallel_middle'] / middle:.3f} |"
    )
    pairs = record.get("parallel_pairs", [])
    if pairs:
        out += [
            "",
            f"Serial and n_jobs=2 on {middle} units, every pair timed back to back (the "
            f"judged statistic, fixed before measuring: the median of the {len(pairs)} ratios, "
            f"{record['parallel_ratio']:.3f}):",
            "",
            "| pair | serial (s) | n_jobs=2 (s) | ratio |",
            "|---|---|---|---|",
            *(
                f"| {k + 1} | {serial:.2f} | {parallel:.2f} | {parallel / serial:.3f} |"
                for k, (serial, parallel) in enumerate(pairs)
            ),
        ]
    out += [
        "",
        f"Units keeping their own model under partial pooling on {small} units: "
        f"{record['own_models_small']}. A serial fit of {large} units kept "
        f"{record['serial_cores_used']:.2f} cores busy on average (numpy's BLAS threads), so "
        f"two processes can at best bring it to about {best:.2f} of its time here; starting "
        f"the two worker processes (a two-unit fit) took {record['worker_startup']:.1f} s "
        "(once per session, not in the ratio).",
        "",
        "## Targets",
        "",
        *(f"- {line}" for line in lines),
    ]
    return "\n".join(out) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI mode: small lots")
    parser.add_argument("--runs", type=int, default=20, help="runs per unit (full mode)")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    units, n_runs, period = scale_sizes(args.quick, args.runs)
    seeds = SEEDS["bench_scale"]
    seed = seeds["tuning"][0] if args.quick else seeds["judged"][0]
    start = time.perf_counter()
    record = measure(units, n_runs, period, seed)
    seconds = time.perf_counter() - start
    verdicts = checks(record, units, args.quick)
    lines = [verdict_line(ok, text, judged) for ok, text, judged in verdicts]
    command = command_line(__file__, argv)
    stem = "scale_quick" if args.quick else "scale"
    results = {
        "units": units,
        "runs_per_unit": n_runs,
        "sampling_period": period,
        "record": {k: v for k, v in record.items() if k != "none"},
        "none": {str(n): t for n, t in record["none"].items()},
        "checks": [
            {"pass": bool(ok), "target": text, "judged": judged} for ok, text, judged in verdicts
        ],
    }
    write_results(
        args.out,
        stem,
        markdown(record, units, lines, command, seconds),
        results,
        script=__file__,
        command=command,
        seconds=seconds,
        verdicts=lines,
    )
    print("\n".join(lines))
    return exit_code(ok for ok, _, judged in verdicts if judged)


if __name__ == "__main__":
    raise SystemExit(main())
