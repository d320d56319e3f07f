"""Whether a blend weighed per kind of novelty could meet issue 41's cost and safety targets.

Run (about 1 min on two cores)::

    python benchmarks/blend_kinds_check.py --jobs 2

``--quick`` (CI): one tuning seed of one preset. Writes
``benchmarks/results/blend_kinds[_quick].md`` and ``.json`` (``--out DIR`` elsewhere).

Issue 41 asks the default to cost nothing where calibration and use share profiles
(``bench_extrapolation.py``'s 'mix' campaigns, leave one azimuth out: the default's MSD
<= 1.02 x ``uncalibrated="none"``'s on every campaign) and to stay safe where they do not (its
case 1: a heating-only calibration used on cycling and cooling runs). In the 'mix' campaigns
the cost arises on flagged rows inside the calibrated temperatures (thermal states and rates
beyond the calibrated ones), where the network alone beats its fallback; in case 1 the
same kinds of rows need the fallback. This check asks whether the blend's weight alone can
tell them apart: it fits the default pipeline once per case on the tuning gyros of
``bench_extrapolation`` (seeds 0-7 of every preset; ``_cases.SEEDS``), keeps per row the
network alone, the fallback, the model at the projected row (``"clip"``), the distance and
the kind of novelty, and re-weighs them offline under other rules:

- ``blend w``: today's rule (:func:`~sklearn_ifog.policy.fallback_weight` over a width
  ``w``, the default 1) for every kind;
- ``per kind t/r/s``: widths ``t`` beyond the calibrated temperatures, ``r`` beyond the
  calibrated rates (inside the temperatures), ``s`` for thermal states (``-``: the fallback
  never weighs in on them, the rows are only flagged);
- ``clip inside T``: beyond the calibrated temperatures the blend, inside them the
  network at the projected row in place of the fallback.

For each rule, the failures of each target of ``bench_extrapolation.py`` it can be scored
on here: the 'mix' cost (24 campaigns), outside T (<= 1.5 x the best of uncompensated, the
line in T and the held line; 48 cases), the first rule (<= 1.05 x uncompensated, on the rows
outside T and at new rates; 96), new rates (<= 1.2 x the line in T; 48), with the worst
ratio of each. No verdicts: a diagnostic on tuning gyros, for the choice issue 41 leaves
open.
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed
from sklearn.linear_model import LinearRegression

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.policy import BlendWithFallback, fallback_weight

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _cases import (
    EXTRAPOLATION_PROFILES,
    SEEDS,
    extrapolation_calibration,
    extrapolation_mixed_profiles,
    extrapolation_operation,
    extrapolation_sizes,
)
from _results import add_out_argument, command_line, publish

# The targets of bench_extrapolation.py this check scores (its constants of the same names).
UNCHANGED_RATIO = 1.02
OUTSIDE_RATIO = 1.5
NEVER_WORSE = 1.05
RATE_RATIO = 1.2
# (rule name, kind of the rule, widths beyond T / beyond the rates / thermal states).
RULES = [
    ("blend 1 (default)", "blend", (BlendWithFallback().width,) * 3),
    ("blend 3", "blend", (3.0, 3.0, 3.0)),
    ("blend 10", "blend", (10.0, 10.0, 10.0)),
    ("per kind 1/1/10", "blend", (1.0, 1.0, 10.0)),
    ("per kind 1/1/-", "blend", (1.0, 1.0, None)),
    ("per kind 1/3/-", "blend", (1.0, 3.0, None)),
    ("per kind 3/3/-", "blend", (3.0, 3.0, None)),
    ("per kind 1/-/-", "blend", (1.0, None, None)),
    ("clip inside T", "clip inside T", (1.0, 1.0, 1.0)),
    ("clip", "clip", (1.0, 1.0, 1.0)),
]
TARGETS = ("'mix' cost", "outside T", "first rule", "new rates")


def _predictions(model, X):
    """Per row of ``X``: the network alone, the fallback, the clip policy's prediction, the
    distance's excess over the threshold and the kind of novelty (beyond the calibrated
    temperatures, beyond the calibrated rates inside them, or a thermal state)."""
    features = model.steps[0][1].transform(X)
    domain = model.domain_
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outputs = {}
        for policy in ("none", "clip"):
            model.set_params(uncalibrated=policy)
            outputs[policy] = np.ravel(model.predict(X))
        model.set_params(uncalibrated="blend")
    rates = features[:, domain.rate_columns_]
    low, high = domain.data_min_[domain.rate_columns_], domain.data_max_[domain.rate_columns_]
    beyond_t = domain.temperature_excess(features) > 0
    beyond_rates = np.any((rates < low) | (rates > high), axis=1)
    return {
        "none": outputs["none"],
        "clip": outputs["clip"],
        "fallback": model.fallback_.predict(features)[:, 0],
        "excess": domain.distance(features) - domain.threshold_,
        "outside": model.outside_calibration(X),
        "beyond T": beyond_t,
        "new rates": beyond_rates & ~beyond_t,
        "rates beyond": beyond_rates,
    }


def _network():
    return RBFNetRegressor(random_state=0)


def mix_case(physics, seed, sampling_period, n_runs):
    """bench_extrapolation's 'mix' campaign, leave one azimuth out: rows of every fold."""
    mixed = extrapolation_mixed_profiles(physics, seed, sampling_period, n_runs)
    X, y = mixed.data, mixed.target.to_numpy()
    folds = []
    for azimuth in np.unique(X["azimuth"]):
        held = (X["azimuth"] == azimuth).to_numpy()
        model = make_compensation_pipeline(_network()).fit(X[~held], y[~held])
        folds.append({**_predictions(model, X[held]), "y": y[held]})
    return folds


def heating_case(physics, seed, sampling_period, n_runs):
    """bench_extrapolation's case 1: the rows of each operating profile and the peers' MSDs
    on its rows beyond the calibrated temperatures and at new rates."""
    calibration = extrapolation_calibration(physics, seed, sampling_period, n_runs)
    X_cal, y_cal = calibration.data, calibration.target.to_numpy()
    model = make_compensation_pipeline(_network()).fit(X_cal, y_cal)
    t_cal = X_cal[["temperature"]]
    line = LinearRegression().fit(t_cal, y_cal)
    low, high = float(t_cal.min().iloc[0]), float(t_cal.max().iloc[0])
    profiles = {}
    for profile in EXTRAPOLATION_PROFILES:
        operation = extrapolation_operation(profile, physics, seed, sampling_period, n_runs)
        X, y = operation.data, operation.target.to_numpy()
        rows = _predictions(model, X)
        t = X[["temperature"]]
        peers = {
            "uncompensated": np.full(len(y), float(np.mean(y_cal))),
            "line in T": line.predict(t),
            "held line in T": line.predict(t.clip(low, high)),
        }
        groups = {
            "outside T": ((t < low) | (t > high)).to_numpy().ravel(),
        }
        groups["new rates"] = rows["rates beyond"] & ~groups["outside T"]
        profiles[profile] = {
            **rows,
            "y": y,
            "groups": groups,
            "peers": {
                group: {name: float(np.mean((y - p)[mask] ** 2)) for name, p in peers.items()}
                for group, mask in groups.items()
            },
        }
    return profiles


def reweigh(rows, rule):
    """The prediction of every row under ``rule`` (a row of ``RULES``)."""
    _, kind, widths = rule
    if kind == "clip":
        return rows["clip"]
    masks = (
        rows["beyond T"],
        rows["new rates"],
        ~rows["beyond T"] & ~rows["new rates"],
    )
    weight = np.zeros_like(rows["excess"])
    for mask, width in zip(masks, widths, strict=True):
        if width is not None:
            # the package's blend weight, over the excess beyond the threshold
            weight[mask] = fallback_weight(rows["excess"][mask], 0.0, width)
    weight[~rows["outside"]] = 0.0
    target = rows["fallback"]
    if kind == "clip inside T":
        target = np.where(rows["beyond T"], rows["fallback"], rows["clip"])
    return (1.0 - weight) * rows["none"] + weight * target


def score(mix, heating, rule):
    """Failures and worst ratio of every target under ``rule``."""
    ratios = {target: [] for target in TARGETS}
    for folds in mix.values():
        error = sum(np.sum((f["y"] - reweigh(f, rule)) ** 2) for f in folds)
        free = sum(np.sum((f["y"] - f["none"]) ** 2) for f in folds)
        ratios["'mix' cost"].append((error / free, UNCHANGED_RATIO))
    for profiles in heating.values():
        for rows in profiles.values():
            prediction = reweigh(rows, rule)
            for group, mask in rows["groups"].items():
                if not mask.any():
                    continue
                msd = float(np.mean((rows["y"] - prediction)[mask] ** 2))
                peers = rows["peers"][group]
                ratios["first rule"].append((msd / peers["uncompensated"], NEVER_WORSE))
                if group == "outside T":
                    best = min(peers.values())
                    ratios["outside T"].append((msd / best, OUTSIDE_RATIO))
                else:
                    ratios["new rates"].append((msd / peers["line in T"], RATE_RATIO))
    return {
        target: {
            "failures": sum(ratio > bound for ratio, bound in values),
            "cases": len(values),
            "worst": max(ratio for ratio, _ in values),
        }
        for target, values in ratios.items()
    }


def markdown(scores, n_mix, n_heating, command, seconds):
    out = [
        "# A blend weighed per kind of novelty: issue 41's cost and safety targets",
        "",
        f"Command: `{command}` ({seconds:.0f} s). The default pipeline fitted once per case on "
        f"bench_extrapolation's tuning gyros ({n_mix} 'mix' campaigns, leave one azimuth out; "
        f"{n_heating} heating-only calibrations, each used on cycling and cooling runs), its "
        "rows re-weighed offline under each rule (see the script's docstring). Each cell: "
        "failures of the target / cases, and the worst ratio.",
        "",
        "| rule | " + " | ".join(TARGETS) + " |",
        "|---|" + "---|" * len(TARGETS),
    ]
    for name, record in scores.items():
        cells = [
            f"{record[t]['failures']} of {record[t]['cases']} ({record[t]['worst']:.3f})"
            for t in TARGETS
        ]
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI mode: one seed, one preset")
    parser.add_argument("--jobs", type=int, default=1, help="cases fitted in parallel")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    register = SEEDS["blend_kinds_check"]
    physics = register["physics"][-1:] if args.quick else register["physics"]
    seeds = register["tuning"][:1] if args.quick else register["tuning"]
    sampling_period, n_runs = extrapolation_sizes(args.quick)
    cases = [(p, s) for p in physics for s in seeds]
    jobs = [delayed(mix_case)(p, s, sampling_period, n_runs) for p, s in cases]
    jobs += [delayed(heating_case)(p, s, sampling_period, n_runs) for p, s in cases]
    results = Parallel(n_jobs=args.jobs)(jobs)
    mix = dict(zip(cases, results[: len(cases)], strict=True))
    heating = dict(zip(cases, results[len(cases) :], strict=True))
    scores = {rule[0]: score(mix, heating, rule) for rule in RULES}
    seconds = time.perf_counter() - started
    command = command_line(__file__, argv)
    publish(
        args.out,
        "blend_kinds" + ("_quick" if args.quick else ""),
        markdown(scores, len(mix), len(heating), command, seconds),
        scores,
        script=__file__,
        command=command,
        seconds=seconds,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
