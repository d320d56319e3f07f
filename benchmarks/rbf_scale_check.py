"""Scale check of RBFNetRegressor's defaults: fit time, peak memory, predict latency.

Run (about two minutes on two cores)::

    python benchmarks/rbf_scale_check.py

Each fit runs in its own process, so its peak resident memory is its own. Data: the smooth
function of issue 3 (``y = sin 3x0 + x1 x2 + 0.5 cos 2x2 + noise 0.05``, x uniform in
``[-1, 1]^3``; ``rbf_scale_smooth`` in ``benchmarks/_cases.py``).

Targets (issue 26, "production scale"; PASS/FAIL lines printed last, exit 1 when one
fails): RBF fit time at 1e5 rows at most half MLP(20)'s; RBF test MSE at 1e5 at most ``0.3x``
MLP(20)'s; RBF fit time at 1e6 at most ``2.5x`` poly3 Ridge's; log-log slope of the RBF fit
time from 1e5 to 1e6 at most ``0.6`` (issue 3's, kept); batch predict of 1e6 rows at most
``1.5x`` the bare-numpy floor; one-row predict at most a one-row ``LinearRegression.predict``
(the median of five rounds, each timing the two in turn, so both see the same load); peak
resident memory of the RBF fit at 1e6 rows at most 500 MB. Also printed (not a target): the
fit time of the network and of the polynomial Ridge against rows (1e4, 1e5 and 1e6), with the
exponent of a least-squares line through their logs.

Writes ``benchmarks/results/rbf_scale.md`` and ``rbf_scale.json`` (the one result format of
``benchmarks/_results.py``); ``--out DIR`` writes elsewhere.

``--quick`` (CI): ``1e2``, ``3e2`` and ``3e3`` rows (a decade between the last two, as
between 1e5 and 1e6), a batch of ``3e3`` rows, the network timed for predict fitted on
2000 rows instead of 20000, 200 calls per round of the one-row timing; the middle size's
fits run in this process (no peak memory: a child process would cost more than they do),
the large size's each in its own process as in the full run, written to the ``_quick``
files. There only ``QUICK_JUDGED`` are judged (the accuracy against the MLP and the one-row
predict overhead: a broken network fails them at any size); the fit-time ratios, the slope,
the batch ratio and the peak memory print as ``INFO`` (toy sizes say nothing about 1e6
rows).
"""

import argparse
import json
import resource
import subprocess
import sys
import time
import timeit
import warnings

import numpy as np

from _cases import (  # isort: skip
    RBF_SCALE_QUICK_SIZES,
    RBF_SCALE_QUICK_SMALL_SIZE,
    RBF_SCALE_SIZES,
    RBF_SCALE_SMALL_SIZE,
    RBF_SCALE_TEST_ROWS,
    rbf_scale_batch,
    rbf_scale_smooth,
)
from _results import add_out_argument, command_line, publish  # isort: skip
from _verdict import exit_code, verdict_line  # isort: skip

# (ratio name, threshold, what it is): the targets, all "at most".
TARGETS = (
    ("fit_1e5_vs_mlp", 0.5, "RBF fit time / MLP(20) fit time at the middle size"),
    ("mse_1e5_vs_mlp", 0.3, "RBF test MSE / MLP(20) test MSE at the middle size"),
    ("fit_1e6_vs_poly3", 2.5, "RBF fit time / poly3 Ridge fit time at the large size"),
    ("loglog_slope_1e5_1e6", 0.6, "log-log slope of the RBF fit time, middle to large size"),
    ("batch_vs_floor", 1.5, "RBF batch predict time / bare-numpy floor"),
    ("single_row_ratio", 1.0, "RBF one-row predict time / LinearRegression's (median of 5)"),
    ("peak_1e6_MB", 500.0, "peak resident memory (MB) of the RBF fit at the large size"),
)
# The targets judged by --quick (the others print as INFO there).
QUICK_JUDGED = ("mse_1e5_vs_mlp", "single_row_ratio")
# Rounds of the one-row timing (each times RBF then LinearRegression), and calls per round.
SINGLE_ROW_ROUNDS = 5
SINGLE_ROW_CALLS = 2000
QUICK_SINGLE_ROW_CALLS = 200  # --quick
# --quick: the training rows of the network whose predict is timed (RBF_SCALE_TEST_ROWS).
QUICK_PREDICT_FIT_ROWS = 2000


def make_model(name):
    from sklearn.linear_model import Ridge
    from sklearn.neural_network import MLPRegressor
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import PolynomialFeatures, StandardScaler

    from sklearn_ifog import RBFNetRegressor

    return {
        "RBFNet (default)": lambda: RBFNetRegressor(random_state=0),
        "poly3 Ridge": lambda: make_pipeline(PolynomialFeatures(3), StandardScaler(), Ridge()),
        "MLP (20,)": lambda: MLPRegressor(hidden_layer_sizes=(20,), random_state=0),
    }[name]()


def fit_once(name, n_samples):
    """One fit in this process: time, peak memory, test MSE against the noise-free f."""
    X, y, _ = rbf_scale_smooth(n_samples, 0)
    model = make_model(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.perf_counter()
        model.fit(X, y)
        fit_s = time.perf_counter() - start
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    X_test, _, f_test = rbf_scale_smooth(RBF_SCALE_TEST_ROWS, 1)
    mse = float(np.mean((model.predict(X_test) - f_test) ** 2))
    return {"model": name, "n": n_samples, "fit_s": fit_s, "peak_MB": peak_mb, "mse": mse}


def predict_timings(batch_rows=1_000_000, calls=SINGLE_ROW_CALLS, fit_rows=RBF_SCALE_TEST_ROWS):
    """Single-row latency against LinearRegression, batch throughput against the floor."""
    from sklearn.linear_model import LinearRegression

    from sklearn_ifog import RBFNetRegressor
    from sklearn_ifog.rbf._basis import tail_features

    X, y, _ = rbf_scale_smooth(fit_rows, 0)
    rbf = RBFNetRegressor(random_state=0).fit(X, y)
    linear = LinearRegression().fit(X, y)
    row = X[:1].copy()

    def best(func, number):
        return min(timeit.repeat(func, number=number, repeat=7)) / number

    # One-row latency: rounds that time the two models in turn (the same load for both), the
    # median round's ratio.
    rbf_rows, linear_rows = [], []
    for _ in range(SINGLE_ROW_ROUNDS):
        rbf_rows.append(timeit.timeit(lambda: rbf.predict(row), number=calls))
        linear_rows.append(timeit.timeit(lambda: linear.predict(row), number=calls))
    rbf_rows, linear_rows = np.array(rbf_rows), np.array(linear_rows)
    batch = rbf_scale_batch(batch_rows)
    Z = (batch - rbf.x_mean_) / rbf.x_scale_
    inv_var = 1.0 / np.square(rbf.widths_)
    centers = rbf.centers_
    W = np.vstack(
        [centers.T * inv_var, -0.5 * inv_var, -0.5 * inv_var * np.square(centers).sum(axis=1)]
    )
    augmented = np.column_stack([Z, np.square(Z).sum(axis=1), np.ones(Z.shape[0])])

    def floor():
        # The bare-numpy limit: one product [z, ||z||², 1] @ W gives -||z - c||² / (2σ²),
        # then one in-place exp and one matrix-vector product (no validation, no blocks).
        activations = augmented @ W
        np.exp(activations, out=activations)
        tail = tail_features(Z, rbf.tail_degree_) @ rbf.tail_coef_ if rbf.tail_degree_ else 0.0
        return activations @ rbf.coef_ + tail + rbf.intercept_

    return {
        "n_centers": int(centers.shape[0]),
        "single_row_us": float(np.median(rbf_rows)) / calls * 1e6,
        "linear_single_row_us": float(np.median(linear_rows)) / calls * 1e6,
        "single_row_ratio": float(np.median(rbf_rows / linear_rows)),
        "batch_1e6_s": best(lambda: rbf.predict(batch), 1),
        "floor_1e6_s": best(floor, 1),
    }


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) == 3 and argv[0] == "--child":  # child process: one fit
        print(json.dumps(fit_once(argv[1], int(float(argv[2])))))
        return 0
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI mode: sizes / 100")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    command = command_line(__file__, argv)
    started = time.perf_counter()
    middle, large = RBF_SCALE_QUICK_SIZES if args.quick else RBF_SCALE_SIZES
    small = RBF_SCALE_QUICK_SMALL_SIZE if args.quick else RBF_SCALE_SMALL_SIZE
    # The smallest size only times the fits (for the exponent), in this process: a child
    # process of its own, which only the peak memory needs, would cost more than the fit.
    # One untimed fit first, so that the timed ones pay no first-call imports.
    fit_once("RBFNet (default)", 100)
    fits = [
        {**fit_once(name, int(small)), "peak_MB": None}
        for name in ("RBFNet (default)", "poly3 Ridge")
    ]
    for name, n_samples in [
        ("RBFNet (default)", middle),
        ("MLP (20,)", middle),
        ("poly3 Ridge", middle),
        ("RBFNet (default)", large),
        ("poly3 Ridge", large),
    ]:
        if args.quick and n_samples == middle:
            # --quick: the middle size in this process (no peak memory), so that only the
            # large size's fits, whose peak memory is a target, pay a child's imports
            fits.append({**fit_once(name, int(n_samples)), "peak_MB": None})
            print(fits[-1], flush=True)
            continue
        out = subprocess.run(
            [sys.executable, __file__, "--child", name, str(n_samples)],
            capture_output=True,
            text=True,
            check=True,
        )
        fits.append(json.loads(out.stdout.splitlines()[-1]))
        print(fits[-1], flush=True)
    calls = QUICK_SINGLE_ROW_CALLS if args.quick else SINGLE_ROW_CALLS
    fit_rows = QUICK_PREDICT_FIT_ROWS if args.quick else RBF_SCALE_TEST_ROWS
    timings = predict_timings(int(large), calls, fit_rows)
    by = {(f["model"], f["n"]): f for f in fits}
    middle, large = int(middle), int(large)
    rbf5, rbf6 = by["RBFNet (default)", middle], by["RBFNet (default)", large]
    ratios = {
        "fit_1e5_vs_mlp": rbf5["fit_s"] / by["MLP (20,)", middle]["fit_s"],
        "fit_1e6_vs_poly3": rbf6["fit_s"] / by["poly3 Ridge", large]["fit_s"],
        "loglog_slope_1e5_1e6": float(np.log10(rbf6["fit_s"] / rbf5["fit_s"])),
        "mse_1e5_vs_mlp": rbf5["mse"] / by["MLP (20,)", middle]["mse"],
        "batch_vs_floor": timings["batch_1e6_s"] / timings["floor_1e6_s"],
        "peak_1e6_MB": rbf6["peak_MB"],
    }
    measures = {**timings, **ratios}
    sizes = (int(small), middle, large)
    exponents = {
        name: float(
            np.polyfit(np.log10(sizes), np.log10([by[name, n]["fit_s"] for n in sizes]), 1)[0]
        )
        for name in ("RBFNet (default)", "poly3 Ridge")
    }
    checks = [
        (
            bool(measures[key] <= threshold),
            f"{what}: {measures[key]:.3g} <= {threshold:g}",
            not args.quick or key in QUICK_JUDGED,
        )
        for key, threshold, what in TARGETS
    ]
    lines = [
        "# RBFNetRegressor scale check",
        "",
        f"Command: `{command}` (sizes {middle:.0e} and {large:.0e} rows; ratio names keep the "
        "full run's sizes)",
        "",
        "| model | rows | fit s | peak MB | test MSE |",
        "|---|---|---|---|---|",
    ]
    lines += [
        f"| {f['model']} | {f['n']:.0e} | {f['fit_s']:.2f} | "
        + ("-" if f["peak_MB"] is None else f"{f['peak_MB']:.0f}")
        + f" | {f['mse']:.2e} |"
        for f in fits
    ]
    lines += [
        "",
        "Fit time against rows, and its exponent (least squares on the logs of the three sizes):",
        "",
        "| model | " + " | ".join(f"{n:.0e} rows (s)" for n in sizes) + " | exponent |",
        "|---|" + "---|" * (len(sizes) + 1),
    ]
    lines += [
        f"| {name} | "
        + " | ".join(f"{by[name, n]['fit_s']:.3g}" for n in sizes)
        + f" | {exponents[name]:.2f} |"
        for name in exponents
    ]
    lines += ["", "| measure | value |", "|---|---|"]
    lines += [f"| {k} | {v:.3g} |" for k, v in measures.items()]
    verdicts = [verdict_line(ok, text, judged) for ok, text, judged in checks]
    lines += ["", "## Targets", ""] + [f"- {line}" for line in verdicts]
    payload = {
        "fits": fits,
        "predict": timings,
        "ratios": ratios,
        "fit_time_exponents": exponents,
        "checks": [{"pass": ok, "target": text, "judged": judged} for ok, text, judged in checks],
    }
    stem = "rbf_scale_quick" if args.quick else "rbf_scale"
    publish(
        args.out,
        stem,
        "\n".join(lines) + "\n",
        payload,
        script=__file__,
        command=command,
        seconds=time.perf_counter() - started,
        verdicts=verdicts,
        echo="\n".join(lines),
    )
    return exit_code(ok for ok, _, judged in checks if judged)


if __name__ == "__main__":
    raise SystemExit(main())
