"""Whole runs held out inside RBFNetRegressor: ``fit(X, y, groups=runs)`` against row blocks.

Run::

    python benchmarks/rbf_run_folds_check.py --n-jobs 2          # about 4 min on two cores
    python benchmarks/rbf_run_folds_check.py --quick              # CI smoke run, see below

Issue 12 lists "more, shorter folds by run rather than by row blocks when runs are given"
among the changes worth measuring. ``RBFNetRegressor.fit`` takes ``groups``: its
cross-validation folds then hold out whole runs (one per fold, up to 10) and the
refinement's held-out rows are whole runs too, instead of contiguous row blocks. This
diagnostic measures it against the default (row blocks), with the default refinement
guard in both (a refined network is kept only when it beats the OLS network on the
held-out rows by more than one standard error), in three settings:

- **thermal-state folds**: the campaigns and folds of ``bench_thermal_state.py`` (one unit,
  four azimuths, three runs each, ``thermal_state_campaign``; seeds 0-2, the ones the
  network's defaults were chosen on, ``SEEDS["rbf_run_folds_check"]``; leave one azimuth
  out; the default ThermalFeatures -> StandardScaler -> regressor), RBFNetRegressor with
  and without the training runs as ``groups``, and a linear Ridge(1e-3) on the same
  features (the network's own linear tail, alone). Each number is the pooled excess
  ``sum(MSD - floor) / sum(floor)`` over the folds of a campaign, as a ratio to Ridge's;
  "units" counts the folds whose network keeps a Gaussian unit.
- **refinement on held-out runs**: the campaigns of ``tests/test_refine_holdout.py``
  (azimuths 0 and 180 train, 90 tests; two runs each, 60 s; ten fixed units;
  ``rbf_refine_split`` and ``RBF_REFINE_CASES`` in ``benchmarks/_cases.py``), the held-out
  MSD of each refinement mode over that of the unrefined network, with and without groups,
  and how often the guard rejected the refinement.
- **real recording**: ``load_psim_tvc``'s alternate bursts (as in ``bench_thermal_state``),
  burst-mean MSD with and without the training bursts as groups.

``--quick`` (CI): seed 0, 300 s samples, one fold of lumped and one of layered_glass, the
first refinement case, and gyro x on every fourth sample of the recording with the even
bursts training only.

No targets: a diagnostic (exits 0 when it ran). Writes
``benchmarks/results/rbf_run_folds[_quick].md`` and ``.json`` (the one result format of
``benchmarks/_results.py``; ``--out DIR`` writes elsewhere).
"""

import argparse
import sys
import time
import warnings
from collections import defaultdict

import numpy as np
from joblib import Parallel, delayed
from sklearn.linear_model import Ridge
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import RBFNetRegressor, ThermalFeatures, make_compensation_pipeline
from sklearn_ifog.datasets import noise_floor
from sklearn_ifog.model_selection import LeaveOneAzimuthOut

from _cases import (  # isort: skip
    PHYSICS,
    RBF_REFINE_CASES,
    SEEDS,
    REAL_QUICK_STEP,
    real_recording_xy,
    thermal_state_campaign,
)

# tests/test_refine_holdout.py and tests/test_rbf_groups.py import it from here.
from _cases import rbf_refine_split as refine_split  # isort: skip
from _results import add_out_argument, command_line, write_results  # isort: skip

MODELS = ("RBFNet", "RBFNet (run groups)", "Ridge")
REFINE_MODES = ("varpro", "lm", "gd")
REAL_AXES = ("gyro_x", "gyro_y")


def _quiet_fit(model, X, y, **params):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # convergence and refinement warnings: judged below
        return model.fit(X, y, **params)


def thermal_fold(seed, physics, period, fold):
    campaign = thermal_state_campaign(seed, physics, period)
    X, y = campaign.data, np.asarray(campaign.target)
    train, test = list(LeaveOneAzimuthOut().split(X))[fold]
    floor = noise_floor(campaign.frame, test)
    runs = X["run"].to_numpy()[train]
    record = {"seed": seed, "physics": physics, "period": period, "fold": fold, "floor": floor}
    for name in MODELS:
        regressor = Ridge(1e-3) if name == "Ridge" else RBFNetRegressor(random_state=seed)
        pipeline = Pipeline(
            [
                ("features", ThermalFeatures(time="time", run="run")),
                ("scale", StandardScaler()),
                ("regressor", regressor),
            ]
        )
        params = {"regressor__groups": runs} if name == "RBFNet (run groups)" else {}
        _quiet_fit(pipeline, X.iloc[train], y[train], **params)
        msd = float(np.mean(np.square(y[test] - pipeline.predict(X.iloc[test]))))
        units = int(regressor.centers_.shape[0]) if hasattr(regressor, "centers_") else 0
        record[name] = {"msd": msd, "units": units}
    return record


def refine_case(physics, seed):
    X_train, y_train, X_test, y_test = refine_split(physics, seed)
    runs = X_train["run"].to_numpy()
    record = {"physics": physics, "seed": seed}
    for grouped in (False, True):
        params = {"regressor__groups": runs} if grouped else {}
        msd, rejected, kept = {}, {}, {}
        for mode in (None, *REFINE_MODES):
            network = RBFNetRegressor(refine=mode, n_centers=10, criterion=None, random_state=seed)
            model = _quiet_fit(make_compensation_pipeline(network), X_train, y_train, **params)
            msd[mode] = float(np.mean(np.square(y_test - model.predict(X_test))))
            rejected[mode] = bool(network.selection_path_.get("refine_rejected", False))
            kept[mode] = bool(network.selection_path_["refined"])
        key = "run groups" if grouped else "row blocks"
        record[key] = {
            mode: {"ratio": msd[mode] / msd[None], "rejected": rejected[mode], "kept": kept[mode]}
            for mode in REFINE_MODES
        }
    return record


def real_scores(axes, parities=(0, 1), step=1):
    X, Y = real_recording_xy(step)
    burst = X["burst"].to_numpy()
    scores = {}
    for parity in parities:
        train = burst % 2 == parity
        held_out = np.unique(burst[~train])
        for axis in axes:
            key = f"{axis}, test {'odd' if parity == 0 else 'even'} bursts"
            for grouped in (False, True):
                network = RBFNetRegressor(random_state=0)
                pipeline = make_compensation_pipeline(network, time=None, run=None, terms=("T",))
                params = {"regressor__groups": burst[train]} if grouped else {}
                _quiet_fit(pipeline, X[train], Y[axis][train], **params)
                residual = Y[axis][~train].to_numpy() - pipeline.predict(X[~train])
                means = np.bincount(burst[~train], weights=residual) / np.maximum(
                    np.bincount(burst[~train]), 1
                )
                name = "RBFNet (burst groups)" if grouped else "RBFNet"
                scores.setdefault(key, {})[name] = {
                    "msd": float(np.mean(means[held_out] ** 2)),
                    "units": int(network.centers_.shape[0]),
                }
    return scores


def thermal_summary(folds):
    cells = defaultdict(list)
    for record in folds:
        cells[record["physics"], record["period"], record["seed"]].append(record)
    rows = []
    for (physics, period, seed), records in sorted(cells.items()):
        floor = sum(r["floor"] for r in records)
        excess = {
            name: sum(r[name]["msd"] - r["floor"] for r in records) / floor for name in MODELS
        }
        units = {name: sum(r[name]["units"] > 0 for r in records) for name in MODELS[:2]}
        rows.append(
            {
                "physics": physics,
                "period": period,
                "seed": seed,
                "n_folds": len(records),
                "excess": excess,
                "folds_with_units": units,
            }
        )
    return rows


def markdown(result, command, elapsed):
    lines = [
        "# Whole runs held out inside RBFNetRegressor (groups) against row blocks",
        "",
        f"Command: `{command}` ({elapsed / 60:.1f} min). See the script's docstring for the "
        "settings.",
        "",
        "## Thermal-state folds",
        "",
        "Pooled excess (MSD - floor) / floor of each campaign, and its ratio to the linear "
        "Ridge's; folds keeping a Gaussian unit.",
        "",
        "| physics | period | seed | Ridge excess | RBFNet / Ridge | RBFNet (run groups) / "
        "Ridge | folds with units (row blocks; run groups) |",
        "|---|---|---|---|---|---|---|",
    ]
    pooled = defaultdict(lambda: defaultdict(float))
    for row in result["thermal"]:
        e = row["excess"]
        u = row["folds_with_units"]
        lines.append(
            f"| {row['physics']} | {row['period']:g} s | {row['seed']} | {e['Ridge']:.4f} | "
            f"{e['RBFNet'] / e['Ridge']:.3f} | {e['RBFNet (run groups)'] / e['Ridge']:.3f} | "
            f"{u['RBFNet']} of {row['n_folds']}; {u['RBFNet (run groups)']} of "
            f"{row['n_folds']} |"
        )
        for name in MODELS:
            pooled[row["physics"], row["period"]][name] += e[name] / len(result["seeds"])
    lines += [
        "",
        "Mean over seeds of the campaigns' excess:",
        "",
        "| physics | period | RBFNet | RBFNet (run groups) | Ridge |",
        "|---|---|---|---|---|",
    ]
    for (physics, period), values in pooled.items():
        lines.append(
            f"| {physics} | {period:g} s | "
            + " | ".join(f"{values[name]:.4f}" for name in MODELS)
            + " |"
        )
    lines += [
        "",
        "## Refinement on held-out runs",
        "",
        "Held-out MSD of the refined network over the unrefined one (10 fixed units); "
        "`+`: the refinement was kept; `*`: the guard rejected it (the unrefined network is "
        "kept, ratio 1); neither: no iterate beat the start.",
        "",
        "| case | "
        + " | ".join(f"{m} (row blocks) | {m} (run groups)" for m in REFINE_MODES)
        + " |",
        "|---|" + "---|---|" * len(REFINE_MODES),
    ]
    for record in result["refine"]:
        cells = []
        for mode in REFINE_MODES:
            for key in ("row blocks", "run groups"):
                value = record[key][mode]
                mark = "+" if value["kept"] else "*" if value["rejected"] else ""
                cells.append(f"{value['ratio']:.3f}{mark}")
        lines.append(f"| {record['physics']} seed {record['seed']} | " + " | ".join(cells) + " |")
    lines += ["", "Worst ratio, and cases kept and rejected, per mode:", ""]
    for mode in REFINE_MODES:
        parts = []
        for key in ("row blocks", "run groups"):
            values = [record[key][mode] for record in result["refine"]]
            parts.append(
                f"{key} worst {max(v['ratio'] for v in values):.3f}, kept "
                f"{sum(v['kept'] for v in values)}, rejected {sum(v['rejected'] for v in values)}"
                f" of {len(values)}"
            )
        lines.append(f"- {mode}: " + "; ".join(parts))
    lines += [
        "",
        "## Real recording, alternate bursts",
        "",
        "Mean of the squared held-out burst-mean residuals, (deg/h)^2 (units kept).",
        "",
        "| split | RBFNet | RBFNet (burst groups) |",
        "|---|---|---|",
    ]
    for split, cell in result["real"].items():
        lines.append(
            f"| {split} | {cell['RBFNet']['msd']:.2f} ({cell['RBFNet']['units']}) | "
            f"{cell['RBFNet (burst groups)']['msd']:.2f} "
            f"({cell['RBFNet (burst groups)']['units']}) |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI smoke run: one seed, two folds")
    parser.add_argument("--n-jobs", type=int, default=1)
    add_out_argument(parser)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    seeds = SEEDS["rbf_run_folds_check"]["tuning"]
    if args.quick:
        seeds, periods, physics, n_folds = seeds[:1], (300.0,), ("lumped", "layered_glass"), 1
        cases, axes, parities, step = RBF_REFINE_CASES[:1], REAL_AXES[:1], (0,), REAL_QUICK_STEP
    else:
        periods, physics, n_folds = (10.0, 60.0), PHYSICS, 4
        cases, axes, parities, step = RBF_REFINE_CASES, REAL_AXES, (0, 1), 1
    jobs = [
        delayed(thermal_fold)(seed, name, period, fold)
        for name in physics
        for period in periods
        for seed in seeds
        for fold in range(n_folds)
    ]
    jobs += [delayed(refine_case)(name, seed) for name, seed in cases]
    done = Parallel(n_jobs=args.n_jobs)(jobs)
    result = {
        "seeds": list(seeds),
        "thermal": thermal_summary(done[: len(done) - len(cases)]),
        "thermal_folds": done[: len(done) - len(cases)],
        "refine": done[len(done) - len(cases) :],
        "real": real_scores(axes, parities, step),
    }
    elapsed = time.perf_counter() - start
    command = command_line(__file__, argv)
    stem = "rbf_run_folds_quick" if args.quick else "rbf_run_folds"
    text = markdown(result, command, elapsed)
    write_results(args.out, stem, text, result, script=__file__, command=command, seconds=elapsed)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
