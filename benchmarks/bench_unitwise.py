"""A production lot: the test error of one model per gyro, pooling "none", "full" and "partial".

Run (the committed results, ``unitwise.md`` line "Command:", took 3.1 minutes with
``--jobs 2``, which runs the cases in two processes, on a shared two-core machine)::

    nice -n 10 .venv/bin/python benchmarks/bench_unitwise.py --jobs 2

``--quick``: one seed, the lumped physics, the similar lot, the linear model only. Writes
``benchmarks/results/unitwise.md`` and ``unitwise.json`` (``unitwise_quick.*`` with
``--quick``; ``--out DIR`` elsewhere). The lots are built in ``_cases.py`` (its
``bench_unitwise`` section).

A simulated lot of ``N_UNITS`` gyros (``make_thermal_campaign``), each recorded ``N_RUNS`` times
at one azimuth; every unit is calibrated on its first 1, 2 or 4 runs and tested on its last
``N_TEST`` runs (the same test runs for every calibration size, so the columns compare). Two
kinds of lot: "similar" (units of one design, ``lot_spread=LOT_SPREAD``) and "independent"
(every unit drawn on its own, ``lot_spread=None``); two physics presets ("lumped" and
"layered_glass"). The models are the package's pipeline (``make_compensation_pipeline``,
its default features) with a linear regressor and with the RBF network (``refine=None`` for
speed, linear tail), wrapped in ``UnitwiseRegressor`` with each pooling; scikit-lego's
``GroupedPredictor`` with its shrinkage options wraps the same pipeline as a comparison (a
test-only dependency). The
RBF network with a quadratic tail (the default of earlier releases) is run too and reported
separately (see the notes in the results).

GroupedPredictor runs all three options on the linear model and "relative" on the RBF network
(time). The score is the MSD of the compensated rate on the test runs of all units (rows pooled),
averaged over seeds, also shown as a ratio to the simulator's noise floor on those rows.

Seeds. ``unitwise.OWN_MODEL_SPREAD`` and the far-unit rule (a unit the evidence puts far from
the lot keeps its own model) were chosen in ``unitwise_selection.py`` on the test runs of the
lots of seeds 0-4 (``SELECTION_SEEDS``; the earlier choices of partial pooling, on seeds 0-2
of this benchmark). The verdict is scored on seeds 4221, 4222 and 4223 (the register's
judged seeds, fresh in issue 42; 5-7 judged before and are retired), which played no part in
any choice; ``--quick`` runs seed 0, a selection seed, and says so in its output, as does any
run given a selection seed.

Every RBF row gives the number of Gaussian units its fitted networks hold (the most over
units and seeds, per pooling). A pooling whose networks hold none and a linear tail on every
seed is the linear model's pipeline, so its score is the linear row's again: the table marks
it ``=lin``, the target lines name it, and it is no separate evidence for the network.

Targets (the verdict; exit status 1 if one fails):

1. for every physics, lot, calibration size and model of the verdict, "partial" is at most
   ``1.05`` times the better of "none" and "full" (seed means);
2. on the similar lot calibrated on one run per unit, "partial" reaches the MSD of "none"
   calibrated on two runs (chamber time halved): reported as a comparison line
   (``_verdict.compare``: reached only on a WIN; a TIE, within 2 %, is not reached), as the
   issue asked ("reach it, or say how close"): it does not fail the run.

Also reported (no target): **a new unit**, the production-line case. The lot is fitted on
every unit but the last, each calibrated on its first 4 runs; the last unit is then
calibrated on its first 0, 1, 2 or 3 runs and tested on its last ``N_TEST``: with
``"partial"`` by ``add_units`` against the unrefitted lot (0 runs: ``handle_unknown="lot"``,
the lot's model), with ``"none"`` its own model on those runs alone (none with 0 runs), and
with ``"full"`` the lot's model at every count. The MSD of that unit's test runs, mean over
seeds, per physics, lot and model.
"""

import argparse
import copy
import sys
import time
import warnings

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import clone
from sklearn.linear_model import LinearRegression

from sklearn_ifog import RBFNetRegressor, UnitwiseRegressor, make_compensation_pipeline
from sklearn_ifog._output_layer import final_step
from sklearn_ifog.datasets import noise_floor

from _cases import (  # isort: skip
    SEEDS,
    UNITWISE_CALIBRATION_RUNS as CALIBRATION_RUNS,
    UNITWISE_LOT_SPREAD as LOT_SPREAD,
    UNITWISE_LOTS as LOTS,
    UNITWISE_N_RUNS as N_RUNS,
    UNITWISE_N_TEST as N_TEST,
    UNITWISE_N_UNITS as N_UNITS,
    UNITWISE_PHYSICS,
    UNITWISE_QUICK_PHYSICS,
    UNITWISE_SAMPLING_PERIOD as SAMPLING_PERIOD,
    unitwise_lot,
)
from _results import add_out_argument, command_line, publish  # isort: skip
from _verdict import compare, comparison_line, target_line  # isort: skip

POOLINGS = ("none", "full", "partial")
SKLEGO_SHRINKAGE = ("relative", "equal", "constant")
# "constant" shrinkage needs its weight of the unit's own model against the lot's.
SKLEGO_CONSTANT_ALPHA = 0.5
TOLERANCE = 1.05
# The lots OWN_MODEL_SPREAD and the far-unit rule were chosen on (unitwise_selection.py's
# seed sets, 0-2 and 3-4): the verdict is scored on the seeds after them.
SELECTION_SEEDS = SEEDS["bench_unitwise"]["tuning"]
FIRST_SEED = SEEDS["bench_unitwise"]["judged"][0]
N_SEEDS = len(SEEDS["bench_unitwise"]["judged"])


def models(seed, quick):
    """name -> (pipeline, in the verdict, GroupedPredictor shrinkage options run)."""
    found = {
        "linear": (
            make_compensation_pipeline(LinearRegression()),
            True,
            SKLEGO_SHRINKAGE,
        )
    }
    if not quick:
        # GroupedPredictor fits one more model per unit and option: on the RBF network only
        # the option the issue measured ("relative"), to keep the run short.
        found["rbf"] = (
            make_compensation_pipeline(
                RBFNetRegressor(refine=None, tail="linear", random_state=seed)
            ),
            True,
            ("relative",),
        )
        found["rbf_quadratic_tail"] = (
            make_compensation_pipeline(
                RBFNetRegressor(refine=None, tail="quadratic", random_state=seed)
            ),
            False,
            (),
        )
    return found


def _grouped(pipeline, shrinkage):
    from sklego.meta import GroupedPredictor

    kwargs = {"alpha": SKLEGO_CONSTANT_ALPHA} if shrinkage == "constant" else None
    return GroupedPredictor(
        clone(pipeline),
        groups=["unit"],
        shrinkage=shrinkage,
        check_X=False,
        shrinkage_kwargs=kwargs,
    )


def networks(model):
    """(most Gaussian units, whether every network is the linear model) of a fitted
    UnitwiseRegressor's RBF networks; (None, None) without one.

    A network with no Gaussian unit and a linear tail is an unpenalised linear fit on the
    standardised features, i.e. the linear model's pipeline.
    """
    if not isinstance(model, UnitwiseRegressor):
        return None, None
    finals = [final_step(unit_model) for unit_model in model.estimators_.values()]
    finals = [final for final in finals if isinstance(final, RBFNetRegressor)]
    if not finals:
        return None, None
    units = [int(np.shape(final.centers_)[0]) for final in finals]
    linear = all(
        n == 0 and final.tail_degree_ == 1 for n, final in zip(units, finals, strict=True)
    )
    return max(units), linear


def run_case(physics, lot, seed, quick):
    campaign = unitwise_lot(physics, lot, seed)
    frame, X, y = campaign.frame, campaign.data, campaign.target.to_numpy()
    runs = {unit: sorted(frame.loc[frame.unit == unit, "run"].unique()) for unit in range(N_UNITS)}
    test_runs = [run for unit in runs for run in runs[unit][-N_TEST:]]
    test = frame["run"].isin(test_runs).to_numpy()
    floor = noise_floor(frame, test)
    rows = []
    for n_calibration in CALIBRATION_RUNS:
        train_runs = [run for unit in runs for run in runs[unit][:n_calibration]]
        train = frame["run"].isin(train_runs).to_numpy()
        for name, (pipeline, verdict, options) in models(seed, quick).items():
            candidates = {
                pooling: UnitwiseRegressor(pipeline, pooling=pooling) for pooling in POOLINGS
            }
            for shrinkage in options:
                candidates[f"sklego_{shrinkage}"] = _grouped(pipeline, shrinkage)
            for method, model in candidates.items():
                start = time.perf_counter()
                with warnings.catch_warnings():
                    # e.g. a quadratic tail on too few rows falling back to the linear one
                    # (each row records its networks' tails through "linear_network")
                    warnings.simplefilter("ignore", UserWarning)
                    model.fit(X[train], y[train])
                    prediction = np.asarray(model.predict(X[test]), dtype=np.float64)
                msd = float(np.mean(np.square(y[test] - prediction)))
                units, linear = networks(model)
                rows.append(
                    {
                        "physics": physics,
                        "lot": lot,
                        "seed": seed,
                        "n_calibration_runs": n_calibration,
                        "model": name,
                        "in_verdict": verdict,
                        "method": method,
                        "msd": msd,
                        "noise_floor": floor,
                        "fit_time": time.perf_counter() - start,
                        "gaussian_units": units,
                        "linear_network": linear,
                        "shrinkage": (
                            {
                                str(k): None if v is None else float(v)
                                for k, v in model.shrinkage_.items()
                            }
                            if method == "partial"
                            else None
                        ),
                    }
                )
    return rows


NEW_UNIT_RUNS = (0, 1, 2, 3)
LOT_CALIBRATION_RUNS = 4


def new_unit_curve(physics, lot, seed, quick):
    """The last unit calibrated on 0-3 runs against the lot of the others (see docstring)."""
    campaign = unitwise_lot(physics, lot, seed)
    frame, X, y = campaign.frame, campaign.data, campaign.target.to_numpy()
    new_unit = N_UNITS - 1
    runs = {u: sorted(frame.loc[frame.unit == u, "run"].unique()) for u in range(N_UNITS)}
    train_runs = [run for u in range(new_unit) for run in runs[u][:LOT_CALIBRATION_RUNS]]
    train = frame["run"].isin(train_runs).to_numpy()
    test = frame["run"].isin(runs[new_unit][-N_TEST:]).to_numpy()
    rows = []
    for name, (pipeline, _, _) in models(seed, quick).items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            fitted = {
                pooling: UnitwiseRegressor(pipeline, pooling=pooling, handle_unknown="lot").fit(
                    X[train], y[train]
                )
                for pooling in ("partial", "full")
            }
            for k in NEW_UNIT_RUNS:
                calibration = frame["run"].isin(runs[new_unit][:k]).to_numpy()
                scores = {}
                for pooling, model in fitted.items():
                    if k:
                        model = _added(model, X[calibration], y[calibration])
                    scores[pooling] = float(np.mean(np.square(y[test] - model.predict(X[test]))))
                if k:
                    own = clone(pipeline).fit(X[calibration].drop(columns="unit"), y[calibration])
                    prediction = own.predict(X[test].drop(columns="unit"))
                    scores["none"] = float(np.mean(np.square(y[test] - prediction)))
                for pooling, msd in scores.items():
                    rows.append(
                        {
                            "physics": physics,
                            "lot": lot,
                            "seed": seed,
                            "model": name,
                            "runs": k,
                            "pooling": pooling,
                            "msd": msd,
                        }
                    )
    return rows


def _added(model, X, y):
    """A copy of the fitted lot ``model`` with the new unit added (the lot is not refitted)."""
    return copy.deepcopy(model).add_units(X, y)


def curve_markdown(rows):
    """Seed-mean MSD of the new unit's test runs against its calibration runs."""
    table = {}
    for row in rows:
        key = (row["physics"], row["lot"], row["model"], row["pooling"])
        table.setdefault(key, {}).setdefault(row["runs"], []).append(row["msd"])
    lines = [
        "## A new unit: test MSD against its calibration runs",
        "",
        f"The lot fitted on units 0-{N_UNITS - 2} ({LOT_CALIBRATION_RUNS} runs each); unit "
        f"{N_UNITS - 1} calibrated on its first 0-3 runs (partial: add_units against the "
        "unrefitted lot, 0 runs the lot's model; none: its own model alone; full: the lot's "
        f"model), tested on its last {N_TEST}; mean over seeds, (deg/h)^2.",
        "",
        "| physics | lot | model | pooling | "
        + " | ".join(f"{k} runs" for k in NEW_UNIT_RUNS)
        + " |",
        "|" + "---|" * (4 + len(NEW_UNIT_RUNS)),
    ]
    for (physics, lot, model, pooling), by_runs in table.items():
        cells = [f"{np.mean(by_runs[k]):.3g}" if k in by_runs else "-" for k in NEW_UNIT_RUNS]
        lines.append(f"| {physics} | {lot} | {model} | {pooling} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def summarise(rows):
    """(physics, lot, model, k) -> method -> seed-mean MSD, the floor, and the networks.

    ``units``: pooling -> the most Gaussian units of its networks over seeds; ``linear``:
    the poolings whose networks are, on every seed, the linear model (see :func:`networks`).
    """
    table = {}
    for row in rows:
        key = (row["physics"], row["lot"], row["model"], row["n_calibration_runs"])
        cell = table.setdefault(
            key, {"in_verdict": row["in_verdict"], "floor": [], "units": {}, "linear": {}}
        )
        cell.setdefault(row["method"], []).append(row["msd"])
        if row["method"] == "none":
            cell["floor"].append(row["noise_floor"])
        if row.get("gaussian_units") is not None:
            method = row["method"]
            cell["units"][method] = max(cell["units"].get(method, 0), row["gaussian_units"])
            cell["linear"][method] = cell["linear"].get(method, True) and row["linear_network"]
    kept = ("in_verdict", "units")
    return {
        key: {
            **{
                method: (values if method in kept else float(np.mean(values)))
                for method, values in cell.items()
                if method != "linear"
            },
            "linear": sorted(method for method, linear in cell["linear"].items() if linear),
        }
        for key, cell in table.items()
    }


def verdict(summary):
    checks = []
    for (physics, lot, model, k), cell in summary.items():
        if not cell["in_verdict"]:
            continue
        best = min(cell["none"], cell["full"])
        ratio = cell["partial"] / best
        checks.append(
            {
                "target": 1,
                "case": f"{physics}/{lot}/{model}/{k} run(s)",
                "value": ratio,
                "passed": bool(ratio <= TOLERANCE),
                "linear": [p for p in POOLINGS if p in cell["linear"]],
            }
        )
    for (physics, lot, model, k), cell in summary.items():
        if lot != "similar" or k != 1 or not cell["in_verdict"]:
            continue
        twice = summary[(physics, lot, model, 2)]
        # The second target is "reach it, or say how close": reported, not failed.
        # Reached only on a WIN of compare (a tie within its margin is not reached).
        outcome = compare(cell["partial"], twice["none"])
        linear = [
            name
            for name, found in (("partial@1", cell), ("none@2", twice))
            if name.split("@")[0] in found["linear"]
        ]
        checks.append(
            {
                "target": 2,
                "case": f"{physics}/{lot}/{model}",
                "partial_1": cell["partial"],
                "none_2": twice["none"],
                "value": cell["partial"] / twice["none"],
                "outcome": outcome,
                "passed": True,
                "reached": outcome == "WIN",
                "linear": linear,
            }
        )
    return checks


def _target_text(check):
    if check["target"] == 2:
        line = comparison_line(
            "partial@1",
            "none@2",
            check["partial_1"],
            check["none_2"],
            f"{check['case']} test MSD, 1 vs 2 calibration runs a unit "
            f"({'reached' if check['reached'] else 'not reached'}, reported)",
        )
    else:
        line = target_line(check["passed"], f"target 1: {check['case']}: {check['value']:.3f}")
    if check["linear"]:
        line += (
            f" [{' and '.join(check['linear'])}: 0 Gaussian units and a linear tail on every "
            "seed, the linear model's pipeline]"
        )
    return line


def markdown(summary, checks, command, seeds, elapsed):
    methods = [*POOLINGS, *(f"sklego_{s}" for s in SKLEGO_SHRINKAGE)]
    reused = sorted(set(seeds) & set(SELECTION_SEEDS))
    seeds_note = (
        f"Seeds {seeds}; OWN_MODEL_SPREAD and the far-unit rule were chosen on seeds "
        f"{list(SELECTION_SEEDS)} (unitwise_selection.py), "
        + (
            f"so this run is NOT a held-out measurement: seeds {reused} were used to choose."
            if reused
            else "none of which is scored here."
        )
    )
    lines = [
        "# Unitwise benchmark: one model per gyro of a lot",
        "",
        f"Command: `{command}` ({elapsed / 60:.1f} min). Lot of {N_UNITS} units, {N_RUNS} runs "
        f"each at one azimuth, sampled every {SAMPLING_PERIOD:g} s; calibrated on the first "
        f"1, 2 or 4 runs of every unit, tested on its last {N_TEST}. "
        f"Similar lot: lot_spread={LOT_SPREAD}; independent: every unit drawn on its own.",
        "",
        seeds_note,
        "",
        "MSD ((deg/h)^2) on the test runs, mean over seeds; in brackets the ratio to the "
        "noise floor of those rows. 'partial/best' is partial over the better of none and "
        "full (target 1: <= 1.05). sklego_*: scikit-lego's GroupedPredictor with that "
        "shrinkage (comparison only; constant with alpha=0.5). 'Gaussian units': the most "
        "held by a fitted RBF network of the row (over units and seeds) with none / full / "
        "partial. '=lin' after an RBF score: that pooling's networks hold no Gaussian unit "
        "and a linear tail on every seed, so they are the linear model's pipeline and the "
        "score is the linear row's (no evidence for the network); a row with all three is "
        "marked '(= linear)'.",
        "",
        "| physics | lot | model | runs | "
        + " | ".join(methods)
        + " | Gaussian units | partial/best | verdict |",
        "|" + "---|" * (len(methods) + 7),
    ]
    for (physics, lot, model, k), cell in summary.items():
        floor = cell["floor"]
        cells = [
            f"{cell[m]:.3g} ({cell[m] / floor:.2f}){' =lin' if m in cell['linear'] else ''}"
            if m in cell
            else "-"
            for m in methods
        ]
        units = (
            " / ".join(str(cell["units"].get(p, "-")) for p in POOLINGS) if cell["units"] else "-"
        )
        ratio = cell["partial"] / min(cell["none"], cell["full"])
        mark = ("PASS" if ratio <= TOLERANCE else "FAIL") if cell["in_verdict"] else "(info)"
        if set(POOLINGS) <= set(cell["linear"]):
            mark += " (= linear)"
        lines.append(
            f"| {physics} | {lot} | {model} | {k} | "
            + " | ".join(cells)
            + f" | {units} | {ratio:.3f} | {mark} |"
        )
    lines += [
        "",
        "## Targets",
        "",
        "Target 1 (the verdict): partial <= 1.05 x the better of none and full. Target 2 "
        "(reported): partial calibrated on 1 run a unit against none on 2; reached only on a "
        "WIN (a TIE, within 2 %, is not reached).",
        "",
    ]
    lines += [f"- {_target_text(check)}" for check in checks]
    failed = [check for check in checks if not check["passed"]]
    lines += ["", f"Verdict: {'FAIL' if failed else 'PASS'} ({len(failed)} failed)."]
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick", action="store_true", help="one seed, lumped, similar lot, linear model"
    )
    parser.add_argument(
        "--seeds", type=int, default=N_SEEDS, help=f"number of seeds (default {N_SEEDS})"
    )
    parser.add_argument(
        "--first-seed",
        type=int,
        default=FIRST_SEED,
        help=f"seeds first-seed, first-seed + 1, ... (default {FIRST_SEED}: seeds "
        f"{list(SELECTION_SEEDS)} chose OWN_MODEL_SPREAD and the far-unit rule)",
    )
    parser.add_argument(
        "--jobs", type=int, default=1, help="parallel processes over the cases (default 1)"
    )
    add_out_argument(parser)
    args = parser.parse_args(argv)
    if args.quick:
        seeds = [SELECTION_SEEDS[0]]  # a smoke run never reads a judged gyro
    else:
        seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    physics_presets = UNITWISE_QUICK_PHYSICS if args.quick else UNITWISE_PHYSICS
    lots = ("similar",) if args.quick else tuple(LOTS)
    command = command_line(__file__, argv)
    start = time.perf_counter()
    cases = [(physics, lot, seed) for physics in physics_presets for lot in lots for seed in seeds]

    def case(physics, lot, seed):
        found = run_case(physics, lot, seed, args.quick)
        found_curve = new_unit_curve(physics, lot, seed, args.quick)
        print(
            f"[bench_unitwise] {physics}/{lot}/seed {seed} done "
            f"({time.perf_counter() - start:.0f} s)",
            file=sys.stderr,
            flush=True,
        )
        return found, found_curve

    # cases are independent: run in parallel processes (same rows, same order as serial)
    results = Parallel(n_jobs=args.jobs)(delayed(case)(*one) for one in cases)
    rows = [row for found, _ in results for row in found]
    curve_rows = [row for _, found in results for row in found]
    summary = summarise(rows)
    checks = verdict(summary)
    elapsed = time.perf_counter() - start
    text = markdown(summary, checks, command, seeds, elapsed) + "\n" + curve_markdown(curve_rows)
    stem = "unitwise_quick" if args.quick else "unitwise"
    verdicts = [_target_text(check) for check in checks]
    publish(
        args.out,
        stem,
        text,
        {"rows": rows, "checks": checks, "new_unit": curve_rows},
        script=__file__,
        command=command,
        seconds=elapsed,
        verdicts=verdicts,
    )
    return 1 if any(not check["passed"] for check in checks) else 0


if __name__ == "__main__":
    sys.exit(main())
