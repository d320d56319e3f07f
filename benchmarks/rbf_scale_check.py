"""Scale check of RBFNetRegressor's defaults: fit time, peak memory, predict latency.

Each fit runs in its own process, so its peak resident memory is its own. Data: the smooth
function of issue 3 (y = sin 3x0 + x1 x2 + 0.5 cos 2x2 + noise 0.05, x uniform in [-1, 1]^3).

Run (about two minutes on two cores)::

    .venv/bin/python benchmarks/rbf_scale_check.py

Writes ``benchmarks/results/rbf_scale.md`` and ``rbf_scale.json``.
"""

import json
import resource
import subprocess
import sys
import time
import timeit
import warnings
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).parent / "results"


def smooth(n, seed):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, size=(n, 3))
    f = np.sin(3 * X[:, 0]) + X[:, 1] * X[:, 2] + 0.5 * np.cos(2 * X[:, 2])
    return X, f + 0.05 * rng.normal(size=n), f


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
    X, y, _ = smooth(n_samples, 0)
    model = make_model(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.perf_counter()
        model.fit(X, y)
        fit_s = time.perf_counter() - start
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    X_test, _, f_test = smooth(20000, 1)
    mse = float(np.mean((model.predict(X_test) - f_test) ** 2))
    return {"model": name, "n": n_samples, "fit_s": fit_s, "peak_MB": peak_mb, "mse": mse}


def predict_timings():
    """Single-row latency against LinearRegression, batch throughput against the floor."""
    from sklearn.linear_model import LinearRegression

    from sklearn_ifog import RBFNetRegressor
    from sklearn_ifog.rbf._basis import tail_features

    X, y, _ = smooth(20000, 0)
    rbf = RBFNetRegressor(random_state=0).fit(X, y)
    linear = LinearRegression().fit(X, y)
    row = X[:1].copy()

    def best(func, number):
        return min(timeit.repeat(func, number=number, repeat=7)) / number

    rbf_row, linear_row = (
        best(lambda: rbf.predict(row), 2000),
        best(lambda: linear.predict(row), 2000),
    )
    batch = np.random.default_rng(2).uniform(-1, 1, size=(1_000_000, 3))
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
        "single_row_us": rbf_row * 1e6,
        "linear_single_row_us": linear_row * 1e6,
        "single_row_ratio": rbf_row / linear_row,
        "batch_1e6_s": best(lambda: rbf.predict(batch), 1),
        "floor_1e6_s": best(floor, 1),
    }


def main():
    if len(sys.argv) == 3:  # child process: one fit
        print(json.dumps(fit_once(sys.argv[1], int(float(sys.argv[2])))))
        return
    fits = []
    for name, n_samples in [
        ("RBFNet (default)", 1e5),
        ("MLP (20,)", 1e5),
        ("poly3 Ridge", 1e5),
        ("RBFNet (default)", 1e6),
        ("poly3 Ridge", 1e6),
    ]:
        out = subprocess.run(
            [sys.executable, __file__, name, str(n_samples)],
            capture_output=True,
            text=True,
            check=True,
        )
        fits.append(json.loads(out.stdout.splitlines()[-1]))
        print(fits[-1], flush=True)
    timings = predict_timings()
    by = {(f["model"], f["n"]): f for f in fits}
    rbf5, rbf6 = by["RBFNet (default)", 100000], by["RBFNet (default)", 1000000]
    ratios = {
        "fit_1e5_vs_mlp": rbf5["fit_s"] / by["MLP (20,)", 100000]["fit_s"],
        "fit_1e6_vs_poly3": rbf6["fit_s"] / by["poly3 Ridge", 1000000]["fit_s"],
        "loglog_slope_1e5_1e6": float(np.log10(rbf6["fit_s"] / rbf5["fit_s"])),
        "mse_1e5_vs_mlp": rbf5["mse"] / by["MLP (20,)", 100000]["mse"],
        "batch_vs_floor": timings["batch_1e6_s"] / timings["floor_1e6_s"],
    }
    lines = [
        "# RBFNetRegressor scale check",
        "",
        "Command: `.venv/bin/python benchmarks/rbf_scale_check.py`",
        "",
        "| model | rows | fit s | peak MB | test MSE |",
        "|---|---|---|---|---|",
    ]
    lines += [
        f"| {f['model']} | {f['n']:.0e} | {f['fit_s']:.2f} | {f['peak_MB']:.0f} | {f['mse']:.2e} |"
        for f in fits
    ]
    lines += ["", "| measure | value |", "|---|---|"]
    lines += [f"| {k} | {v:.3g} |" for k, v in {**timings, **ratios}.items()]
    RESULTS.mkdir(exist_ok=True)
    payload = {"fits": fits, "predict": timings, "ratios": ratios}
    from sklearn_ifog._io import write_text_files

    write_text_files(
        {
            RESULTS / "rbf_scale.json": json.dumps(payload, indent=1),
            RESULTS / "rbf_scale.md": "\n".join(lines) + "\n",
        }
    )
    print("\n".join(lines))


if __name__ == "__main__":
    main()
