"""Transitions: whether searching a coating's transition on the calibration earns its terms.

Issue 45's targets, on held-out runs and azimuths of the simulator's physics presets and on
the shipped recording. Each campaign is one gyro (``make_thermal_campaign(n_units=1,
n_runs=5, azimuths=(0, 90, 180, 270), profile="mix")``, 60-s samples): the pipeline is
calibrated on the first three runs of every azimuth but one and predicts the last two runs of
that azimuth (four folds). Models, all through ``make_compensation_pipeline`` (the README's
entry point, its calibration domain and blend included; the default network seeded, so that
a search that keeps nothing gives today's model exactly):

- ``today``: the default pipeline (``transition=None``);
- ``search``: the same with ``transition="auto"`` (ThermalFeatures searches shape, centre,
  width and lag on the calibration runs, and keeps the terms only when held-out runs say so);
- ``oracle`` (glass presets only): today's terms plus the unit's *true* transition given by
  hand (a logistic step at the simulated Tg with the simulated width, of the sensor's lag at
  900 s, alone, times dT and times the 900-s and 3600-s lag excesses, and a hinge at Tg): what
  the family could give if the search found the simulated transition. It is a bound of this
  family, not a peer a user could run;
- ``linear``: ``LinearRegression`` in place of the network, with its own search: the linear
  model on the same features (WIN/TIE/LOSS lines, not a target; added after the judged run,
  so ``transition_judged.md`` has no such line).

Targets (issue 45's, as the constants below): on every glass preset the search's MSD at most
``GLASS_RATIO`` times today's; on the smooth presets ("lumped", "layered") at most
``SMOOTH_RATIO`` times; the recording (interleaved bursts, per second, gyro x and y) at most
``REAL_RATIO`` times; the found centre within ``CENTRE_TOLERANCE`` degC of the simulated Tg
on a share ``CENTRE_SHARE`` of the folds of the presets whose Tg does not move
("layered_glass", "layered_glass_asymmetric" and "layered_glass_two"'s first transition); the
fit time at most ``FIT_TIME_RATIO`` times today's.

Run: ``python benchmarks/bench_transition.py --n-jobs 2`` (tuning seeds of the register),
``--seeds ... --tag judged`` (the judged set, once), ``--quick`` (CI).
"""

import argparse
import sys
import time
import warnings

import numpy as np
from joblib import Parallel, delayed
from sklearn.linear_model import LinearRegression

from sklearn_ifog import RBFNetRegressor, ThermalFeatures, make_compensation_pipeline
from sklearn_ifog._contract import DEFAULT_STATE_TERMS
from sklearn_ifog.datasets._simulator import noise_floor

from _cases import SEEDS, make_thermal_campaign, real_per_second  # isort: skip
from _results import add_out_argument, command_line, publish  # isort: skip
from _verdict import comparison_line, exit_code, verdict_line  # isort: skip

GLASS = (
    "layered_glass",
    "layered_glass_asymmetric",
    "layered_glass_two",
    "layered_glass_hysteresis",
)
SMOOTH = ("lumped", "layered")
#: Presets whose Tg is one number (the hysteresis' moves with the rate's sign).
FIXED_TG = ("layered_glass", "layered_glass_asymmetric", "layered_glass_two")
GLASS_RATIO = 0.6
SMOOTH_RATIO = 1.02
REAL_RATIO = 1.05
CENTRE_TOLERANCE = 2.0
CENTRE_SHARE = 0.8
FIT_TIME_RATIO = 3.0
CALIBRATION_RUNS = 3
FULL = {"n_runs": 5, "azimuths": (0.0, 90.0, 180.0, 270.0)}
QUICK = {"n_runs": 3, "azimuths": (0.0, 90.0)}
QUICK_CALIBRATION_RUNS = 2
PERIOD = 60.0
ORACLE_LAG = 900.0


def oracle_terms(unit):
    centre, width = unit["glass_temperature"], unit["glass_width"]
    step = f"logistic{centre:.2f}C_w{width:.2f}C_lag{ORACLE_LAG:g}s"
    hinge = f"hinge{centre:.2f}C_w{width:.2f}C_lag{ORACLE_LAG:g}s"
    return (
        *DEFAULT_STATE_TERMS,
        step,
        step + "_dT",
        step + "_T_lag900s",
        step + "_T_lag3600s",
        hinge,
    )


def network():
    """The default network, seeded: a model whose search kept nothing is then today's, bit
    for bit (unseeded, two fits of the same rows differ by a few per cent)."""
    return RBFNetRegressor(random_state=0)


def models_of(physics, unit):
    models = {
        "today": lambda: make_compensation_pipeline(network()),
        "search": lambda: make_compensation_pipeline(network(), transition="auto"),
        # The linear model on the same features (the search's, found on its own fit).
        "linear": lambda: make_compensation_pipeline(LinearRegression(), transition="auto"),
    }
    if physics in GLASS:
        terms = oracle_terms(unit)
        models["oracle"] = lambda: make_compensation_pipeline(network(), terms=terms)
    return models


def folds(X, n_calibration):
    """Calibrate on the first runs of every azimuth but one; test that one's later runs."""
    runs, azimuth = X["run"].to_numpy(), X["azimuth"].to_numpy()
    rank = np.empty(runs.size, dtype=int)
    for value in np.unique(azimuth):
        at = azimuth == value
        labels = np.unique(runs[at])
        rank[at] = np.searchsorted(labels, runs[at])
    for value in np.unique(azimuth):
        train = np.flatnonzero((rank < n_calibration) & (azimuth != value))
        test = np.flatnonzero((rank >= n_calibration) & (azimuth == value))
        yield float(value), train, test


def run_campaign(physics, seed, quick):
    sizes = QUICK if quick else FULL
    campaign = make_thermal_campaign(
        n_units=1,
        profile="mix",
        sampling_period=PERIOD,
        physics=physics,
        random_state=seed,
        **sizes,
    )
    X, y = campaign.data, np.asarray(campaign.target)
    drift = campaign.frame["drift"].to_numpy()
    unit = campaign.unit_params[0]
    n_calibration = QUICK_CALIBRATION_RUNS if quick else CALIBRATION_RUNS
    clean = None
    if physics in FIXED_TG:
        # The same gyro and runs with noise=False (no gyro or sensor noise): whether the
        # search finds the simulated Tg when nothing but the drift is in the target.
        clean = make_thermal_campaign(
            n_units=1,
            profile="mix",
            sampling_period=PERIOD,
            physics=physics,
            random_state=seed,
            noise=False,
            **sizes,
        )
    rows = []
    for azimuth, train, test in folds(X, n_calibration):
        floor = noise_floor(campaign.frame, test)
        row = {"physics": physics, "seed": seed, "azimuth": azimuth, "floor": floor}
        if physics in GLASS:
            row["true_centre"] = float(unit["glass_temperature"])
        if clean is not None:
            features = ThermalFeatures(time="time", run="run", transition="auto")
            features.fit(clean.data.iloc[train], clean.frame["drift"].to_numpy()[train])
            found = features.transition_
            row["found_noise_free"] = None if found is None else found._asdict()
        for name, make in models_of(physics, unit).items():
            model = make()
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model.fit(X.iloc[train], y[train])
            seconds = time.perf_counter() - start
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                predicted = model.predict(X.iloc[test])
            row[name] = {
                "msd": float(np.mean((y[test] - predicted) ** 2)),
                "residual": float(np.mean((predicted - drift[test]) ** 2)),
                "fit_s": seconds,
            }
            if name == "search":
                found = model.steps[0][1].transition_
                row["found"] = None if found is None else found._asdict()
        rows.append(row)
    return rows


def run_recording(quick):
    """Interleaved bursts of the recording, per second: even -> odd and odd -> even."""
    table = real_per_second(("gyro_x", "gyro_y"))
    burst = table["burst"].to_numpy()
    X = table[["time", "temperature", "run"]]
    rows = []
    for parity in (0,) if quick else (0, 1):
        train, test = burst % 2 == parity, burst % 2 != parity
        for axis in ("gyro_x",) if quick else ("gyro_x", "gyro_y"):
            y = table[axis].to_numpy()
            row = {"split": f"{'even' if parity == 0 else 'odd'} -> other bursts", "axis": axis}
            for name, make in (
                ("today", lambda: make_compensation_pipeline(network())),
                ("search", lambda: make_compensation_pipeline(network(), transition="auto")),
            ):
                model = make()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    model.fit(X[train], y[train])
                    predicted = model.predict(X[test])
                row[name] = float(np.mean((y[test] - predicted) ** 2))
                if name == "search":
                    found = model.steps[0][1].transition_
                    row["kept"] = bool(found is not None and found.terms)
            rows.append(row)
    return rows


def summarise(rows):
    summary = {}
    for physics in dict.fromkeys(row["physics"] for row in rows):
        mine = [row for row in rows if row["physics"] == physics]
        cell = {"folds": len(mine), "floor": float(np.mean([row["floor"] for row in mine]))}
        for name in ("today", "search", "linear", "oracle"):
            if name not in mine[0]:
                continue
            cell[name] = float(np.mean([row[name]["msd"] for row in mine]))
            cell[f"{name}/floor"] = float(
                np.mean([row[name]["msd"] / row["floor"] for row in mine])
            )
            cell[f"{name} residual/floor"] = float(
                np.mean([row[name]["residual"] / row["floor"] for row in mine])
            )
            cell[f"{name} fit s"] = float(np.mean([row[name]["fit_s"] for row in mine]))
        cell["kept"] = sum(bool(row["found"] and row["found"]["terms"]) for row in mine)
        if physics in FIXED_TG:
            errors = [
                abs(row["found"]["centre"] - row["true_centre"]) if row["found"] else np.inf
                for row in mine
            ]
            cell["centre within 2 degC"] = sum(error <= CENTRE_TOLERANCE for error in errors)
            clean = [
                abs(row["found_noise_free"]["centre"] - row["true_centre"])
                if row["found_noise_free"]
                else np.inf
                for row in mine
            ]
            cell["noise-free centre within 2 degC"] = sum(e <= CENTRE_TOLERANCE for e in clean)
            cell["noise-free kept"] = sum(
                bool(row["found_noise_free"] and row["found_noise_free"]["terms"]) for row in mine
            )
        summary[physics] = cell
    return summary


def checks_of(summary, recording, quick):
    verdicts, passed = [], []

    def add(ok, text, guard=False):
        """``guard``: a regression guard, judged in --quick too (the gate must not fire on
        smooth physics or the recording)."""
        judged = guard or not quick
        verdicts.append(verdict_line(ok, text, judged=judged))
        if judged:
            passed.append(ok)

    for physics, cell in summary.items():
        ratio = cell["search"] / cell["today"]
        if physics in GLASS:
            add(
                ratio <= GLASS_RATIO,
                f"search MSD <= {GLASS_RATIO} x today's: {physics} ({ratio:.3f})",
            )
        else:
            add(
                ratio <= SMOOTH_RATIO,
                f"search MSD within 2 % of today's: {physics} ({ratio:.3f}; kept on "
                f"{cell['kept']} of {cell['folds']} folds)",
                guard=True,
            )
        verdicts.append(
            comparison_line("search", "linear", cell["search"], cell["linear"], f"MSD, {physics}")
        )
        if "oracle" in cell:
            verdicts.append(
                comparison_line(
                    "oracle", "today", cell["oracle"], cell["today"], f"MSD, {physics}"
                )
            )
    found = [cell for physics, cell in summary.items() if physics in FIXED_TG]
    if found:
        within = sum(cell["centre within 2 degC"] for cell in found)
        total = sum(cell["folds"] for cell in found)
        add(
            within >= CENTRE_SHARE * total,
            f"found centre within {CENTRE_TOLERANCE:g} degC of the simulated Tg on >= 80 % of "
            f"the folds: {within} of {total}",
        )
    fit_ratio = np.mean([cell["search fit s"] / cell["today fit s"] for cell in summary.values()])
    add(fit_ratio <= FIT_TIME_RATIO, f"fit time <= {FIT_TIME_RATIO:g} x today's ({fit_ratio:.2f})")
    for row in recording:
        ratio = row["search"] / row["today"]
        add(
            ratio <= REAL_RATIO,
            f"recording, search MSD within 5 % of today's: {row['axis']}, {row['split']} "
            f"({ratio:.3f})",
            guard=True,
        )
    return verdicts, passed


def markdown(summary, recording, command, seeds, elapsed, verdicts):
    lines = [
        "# Transitions: the opt-in search against today's default",
        "",
        f"Command: `{command}` ({elapsed:.0f} s).",
        "",
        f"Seeds {seeds}; one gyro per preset and seed, {PERIOD:g}-s samples, profile 'mix'; "
        "calibrated on the first runs of three azimuths, tested on the later runs of the "
        "fourth (every azimuth in turn). MSD in (deg/h)², means over the folds; "
        "'residual' is the mean squared difference to the simulated drift.",
        "",
        "'floor / today' is the lowest MSD ratio to today's any model can reach (a perfect "
        "drift model leaves the noise floor).",
        "",
        "| preset | folds | today MSD/floor | search MSD/floor | oracle MSD/floor | search / "
        "today | oracle / today | floor / today | kept | centre within 2 degC | today fit s | "
        "search fit s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for physics, cell in summary.items():
        oracle = cell.get("oracle")
        lines.append(
            f"| {physics} | {cell['folds']} | {cell['today/floor']:.3f} | "
            f"{cell['search/floor']:.3f} | "
            + (f"{cell['oracle/floor']:.3f}" if oracle else "-")
            + f" | {cell['search'] / cell['today']:.3f} | "
            + (f"{oracle / cell['today']:.3f}" if oracle else "-")
            + f" | {cell['floor'] / cell['today']:.3f}"
            + f" | {cell['kept']} | {cell.get('centre within 2 degC', '-')} | "
            f"{cell['today fit s']:.2f} | {cell['search fit s']:.2f} |"
        )
    lines += [
        "",
        "## The search on the drift alone (the same gyros and runs, noise=False: no gyro or "
        "sensor noise)",
        "",
        "| preset | folds | centre within 2 degC | kept |",
        "|---|---|---|---|",
    ]
    for physics, cell in summary.items():
        if "noise-free kept" in cell:
            lines.append(
                f"| {physics} | {cell['folds']} | {cell['noise-free centre within 2 degC']} | "
                f"{cell['noise-free kept']} |"
            )
    lines += [
        "",
        "## The linear model on the same features",
        "",
        '`make_compensation_pipeline(LinearRegression(), transition="auto")`: its own '
        "search, its own fit.",
        "",
        "| preset | linear MSD/floor | search / linear |",
        "|---|---|---|",
    ]
    for physics, cell in summary.items():
        lines.append(
            f"| {physics} | {cell['linear/floor']:.3f} | {cell['search'] / cell['linear']:.3f} |"
        )
    lines += [
        "",
        "## Thermal residual / floor",
        "",
        "| preset | today | search | oracle |",
        "|---|---|---|---|",
    ]
    for physics, cell in summary.items():
        oracle = cell.get("oracle residual/floor")
        lines.append(
            f"| {physics} | {cell['today residual/floor']:.3f} | "
            f"{cell['search residual/floor']:.3f} | "
            + ("-" if oracle is None else f"{oracle:.3f}")
            + " |"
        )
    lines += [
        "",
        "## Shipped recording, interleaved bursts (per second)",
        "",
        "| axis | split | today MSD | search MSD | search / today | kept |",
        "|---|---|---|---|---|---|",
    ]
    for row in recording:
        lines.append(
            f"| {row['axis']} | {row['split']} | {row['today']:.4g} | {row['search']:.4g} | "
            f"{row['search'] / row['today']:.3f} | {row['kept']} |"
        )
    lines += ["", "## Verdicts", ""] + [f"- {line}" for line in verdicts]
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="seed 0, two presets (CI)")
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=None,
        help="seeds (default: the register's tuning seeds "
        f"{list(SEEDS['bench_transition']['tuning'])})",
    )
    parser.add_argument("--tag", default=None, help="results file suffix")
    parser.add_argument("--n-jobs", type=int, default=1, help="parallel processes")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    register = SEEDS["bench_transition"]
    seeds = [register["tuning"][0]] if args.quick else (args.seeds or list(register["tuning"]))
    presets = ("lumped", "layered_glass") if args.quick else SMOOTH + GLASS
    command = command_line(__file__, argv)
    start = time.perf_counter()
    cases = [(physics, seed) for physics in presets for seed in seeds]
    found = Parallel(n_jobs=args.n_jobs)(
        delayed(run_campaign)(physics, seed, args.quick) for physics, seed in cases
    )
    rows = [row for part in found for row in part]
    summary = summarise(rows)
    recording = run_recording(args.quick)
    verdicts, passed = checks_of(summary, recording, args.quick)
    elapsed = time.perf_counter() - start
    stem = "transition" + ("_quick" if args.quick else "") + (f"_{args.tag}" if args.tag else "")
    publish(
        args.out,
        stem,
        markdown(summary, recording, command, seeds, elapsed, verdicts),
        {"seeds": seeds, "summary": summary, "folds": rows, "recording": recording},
        script=__file__,
        command=command,
        seconds=elapsed,
        verdicts=verdicts,
    )
    return exit_code(passed)


if __name__ == "__main__":
    sys.exit(main())
