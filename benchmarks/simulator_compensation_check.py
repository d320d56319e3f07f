"""Quick check that the simulator reproduces the reference paper's claims.

Per unit: train on the runs at one azimuth, test on the runs at another azimuth, with simple
hand-computed features (T, per-sample dT, T*dT; optionally EMA-smoothed before differencing).
Prints raw MSD and compensated MSD for several models ("vs drift": MSD of the prediction
against the noise-free true drift, i.e. the model error without the noise floor).

Targets (the paper's claims, with the paper's per-sample ΔT, smoothing 0; PASS/FAIL lines
printed last, exit 1 when one fails):

1. the linear model on (T, dT, TdT) cuts the MSD more than tenfold (median over the cases of
   raw / compensated MSD);
2. the linear model on (T, dT, TdT) WINs against the same model on (T, dT): mean MSD lower
   by more than the tie margin of ``benchmarks/_verdict.py``.

Comparison lines (WIN/TIE/LOSS, reported, not targets): every model on (T, dT, TdT) against
the same model on (T, dT), for each smoothing.

Run::

    .venv/bin/python benchmarks/simulator_compensation_check.py

Writes ``benchmarks/results/simulator_compensation.md``. ``--quick`` (CI): unit 0 only (2
cases), smoothing 0 only, ``simulator_compensation_quick.md``; ``--out DIR`` elsewhere.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.signal import lfilter
from sklearn.compose import ColumnTransformer
from sklearn.kernel_approximation import Nystroem
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

from sklearn_ifog._io import write_text_files
from sklearn_ifog.datasets import make_thermal_campaign

from _verdict import comparison_line, exit_code, target_line  # isort: skip

RESULTS = Path(__file__).parent / "results"
RAW_CUT = 10.0
PAIRS = (
    ("linear (T,dT,TdT)", "linear (T,dT)"),
    ("poly3 (T,dT,TdT)", "poly3 (T,dT) [has T*dT cross]"),
    ("gaussian-rbf (T,dT,TdT)", "gaussian-rbf (T,dT)"),
)


def features(frame, smoothing):
    out = []
    for _, run in frame.groupby("run", sort=False):
        T = run["temperature"].to_numpy()
        a = 1.0 / (1.0 + smoothing)
        s, _ = lfilter([a], [1.0, a - 1.0], T[1:], zi=[(1.0 - a) * T[0]])
        s = np.concatenate(([T[0]], s))
        dT = np.diff(s, prepend=s[0])
        out.append(np.column_stack([T, dT, T * dT]))
    return np.vstack(out)


def models():
    poly = lambda: make_pipeline(  # noqa: E731
        StandardScaler(), PolynomialFeatures(3), Ridge(alpha=1e-3)
    )
    additive = make_pipeline(
        StandardScaler(),
        ColumnTransformer(
            [
                ("T", PolynomialFeatures(3, include_bias=False), [0]),
                ("dT", PolynomialFeatures(3, include_bias=False), [1]),
            ]
        ),
        Ridge(alpha=1e-3),
    )
    rbf = lambda: make_pipeline(  # noqa: E731
        StandardScaler(), Nystroem(gamma=0.5, n_components=100, random_state=0), Ridge(1e-3)
    )
    return {
        "linear (T,dT)": ([0, 1], LinearRegression()),
        "linear (T,dT,TdT)": ([0, 1, 2], LinearRegression()),
        "additive poly3 g(T)+h(dT)": ([0, 1], additive),
        "poly3 (T,dT) [has T*dT cross]": ([0, 1], poly()),
        "poly3 (T,dT,TdT)": ([0, 1, 2], poly()),
        "gaussian-rbf (T,dT)": ([0, 1], rbf()),
        "gaussian-rbf (T,dT,TdT)": ([0, 1, 2], rbf()),
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI mode: unit 0, smoothing 0")
    parser.add_argument("--out", type=Path, default=RESULTS, help="results directory")
    args = parser.parse_args(argv)
    out = []

    def say(line=""):
        print(line)
        out.append(line)

    start = time.perf_counter()
    campaign = make_thermal_campaign(random_state=0)
    say(f"default campaign: {len(campaign.frame)} rows in {time.perf_counter() - start:.3f} s")
    frame = campaign.frame
    y_all = (frame["rate"] - frame["reference"]).to_numpy()
    drift = frame["drift"].to_numpy()
    units = sorted(frame["unit"].unique())[:1] if args.quick else sorted(frame["unit"].unique())
    checks, comparisons = [], []
    for smoothing in (0.0,) if args.quick else (0.0, 6.0):
        say(f"\n--- dT from EMA-smoothed temperature, smoothing={smoothing} samples ---")
        say("train on one azimuth's 5 runs of a unit, test on another azimuth's 5 runs;")
        say(
            f"{2 * len(units)} cases ({len(units)} unit(s) x (0->90, 45->135 deg)); "
            "MSD in (deg/h)^2"
        )
        X_all = features(frame, smoothing)
        results, errors, raws = {}, {}, []
        for unit in units:
            for train_az, test_az in [(0.0, 90.0), (45.0, 135.0)]:
                train = ((frame["unit"] == unit) & (frame["azimuth"] == train_az)).to_numpy()
                test = ((frame["unit"] == unit) & (frame["azimuth"] == test_az)).to_numpy()
                raws.append(np.mean(y_all[test] ** 2))
                predictions = {"oracle (true drift)": drift[test]}
                for name, (cols, model) in models().items():
                    model.fit(X_all[train][:, cols], y_all[train])
                    predictions[name] = model.predict(X_all[test][:, cols])
                for name, pred in predictions.items():
                    results.setdefault(name, []).append(np.mean((y_all[test] - pred) ** 2))
                    errors.setdefault(name, []).append(np.mean((drift[test] - pred) ** 2))
        raw = np.array(raws)
        header = f"{'model':36s} {'MSD':>9s} {'min ratio':>9s} {'med ratio':>9s} {'vs drift':>9s}"
        say(header)
        say(f"{'raw (no compensation)':36s} {raw.mean():9.2e}")
        for name, values in results.items():
            ratio = raw / np.array(values)
            say(
                f"{name:36s} {np.mean(values):9.2e} {ratio.min():9.1f} {np.median(ratio):9.1f}"
                f" {np.mean(errors[name]):9.2e}"
            )
        for modified, traditional in PAIRS:
            comparisons.append(
                comparison_line(
                    modified,
                    traditional,
                    float(np.mean(results[modified])),
                    float(np.mean(results[traditional])),
                    f"mean MSD, smoothing {smoothing:g}",
                )
            )
        if smoothing == 0.0:
            name, other = PAIRS[0]
            cut = float(np.median(raw / np.array(results[name])))
            checks.append(
                (cut > RAW_CUT, f"{name}: median raw/compensated MSD {cut:.1f} > {RAW_CUT:g}")
            )
            outcome = comparisons[0].split(":")[0]
            checks.append((outcome == "WIN", f"{name} WINs against {other}: {comparisons[0]}"))
    lines = [target_line(ok, text) for ok, text in checks] + comparisons
    say()
    command = "python benchmarks/simulator_compensation_check.py" + (
        " --quick" if args.quick else ""
    )
    text = (
        "# Simulator compensation check\n\n"
        f"Command: `{command}`\n\n```\n"
        + "\n".join(out)
        + "\n```\n\n## Verdicts\n\n"
        + "".join(f"- {line}\n" for line in lines)
    )
    args.out.mkdir(parents=True, exist_ok=True)
    stem = "simulator_compensation" + ("_quick" if args.quick else "")
    write_text_files({args.out / f"{stem}.md": text})
    for line in lines:
        print(line)
    return exit_code(ok for ok, _ in checks)


if __name__ == "__main__":
    sys.exit(main())
