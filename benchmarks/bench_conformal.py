"""Coverage and width of run-wise adaptive conformal intervals against MAPIE (rows, runs).

Usage (from the repository root)::

    nice -n 10 python benchmarks/bench_conformal.py           # full: 3 presets x 6 seeds + real
    nice -n 10 python benchmarks/bench_conformal.py --quick   # one preset, one seed (0)

Every held-out fold is one (unit, azimuth) pair of a simulated campaign
(:class:`~sklearn_ifog.model_selection.LeaveOneAzimuthOut`, within each unit); the three
methods are calibrated on the fold's training runs only, with the same drift model, the
:func:`~sklearn_ifog.make_compensation_pipeline` with its default features and
``RBFNetRegressor(refine=None, criterion="holdout")`` inside (no refinement and a one-split
choice of centres and width: about five times cheaper to fit, for speed), at 90 % nominal
coverage, on campaigns of one unit, four azimuths, three runs each, 300 s samples, for each
physics preset (lumped, layered, layered_glass) and seeds 0, 1, 2 and 4211, 4212, 4213
(``_cases.conformal_campaign``, ``_cases.SEEDS["bench_conformal"]``; the judged seeds are
fresh in issue 42, 8-10 judged before and are retired). A seed draws
the gyro: ConformalRegressor's difficulty model, its reference and ``run_probability``
were chosen on seeds 0-2 (``benchmarks/conformal_difficulty_check.py``) and the calibration
domain's margin and blend on seeds 0-7 (``benchmarks/bench_extrapolation.py --tune``), so
seeds 4211-4213 are held out from every choice (the two groups are summarised apart). The
methods:

- ``ours``: :class:`~sklearn_ifog.ConformalRegressor` (run-wise, adaptive, CV+),
  ``cv=GroupKFold(5)`` over the training runs (the same folds as MAPIE by run; with
  ``--ours-cv runs``, the estimator's default ``cv=None``, one fold per run; with
  ``--ours-cv headings``, the splits of ``LeaveOneAzimuthOut`` on the training runs, a
  whole heading held out per fold as in the test, the runs still the scoring groups; the
  real recording, which has no heading, keeps ``GroupKFold(5)``);
- ``ours_flat``: the same with ``adaptive=False`` (run-wise, absolute scores);
- ``ours_c08``: ``ours`` with ``run_probability=0.8`` (the per-run promise of the issue on a lot
  and its intervals);
- ``mapie_rows``: MAPIE ``CrossConformalRegressor(cv=KFold(5, shuffle))``, CV+;
- ``mapie_runs``: MAPIE ``CrossConformalRegressor(cv=GroupKFold(5))`` with the runs as groups.

The oracle width of a fold is the 5-95 % range of the same method's residuals on the held-out
runs themselves (no method can know it in advance); ``width/oracle`` is the mean over folds of
the ratio. Out of range: a second split per campaign calibrates on the runs whose coldest
reading is above the campaign's median and tests on the others, which all go colder than
anything calibrated. The real recording (``load_psim_tvc``, gyro_x, one cooling run) is split
into 5 blocks of 5 bursts, each held out in turn, the bursts being the calibration groups.

Outside the calibration domain: every test row is also flagged inside or outside the
calibration domain of the model fitted on that split's calibration runs
(``CompensationPipeline.outside_calibration``; the domain depends on the feature step and the
calibration rows only, so the same pipeline with a linear regressor gives the final model's
flags at little cost), and coverage and mean width are reported for the two sets of rows
separately: pooled over the held-out folds, on the out-of-range split, and on two
calibrate-warm / predict-elsewhere splits per campaign: the campaign's unit (same seed)
calibrated on ``make_thermal_campaign(..., temperature_range=(10.0, 40.0))`` and tested on
``temperature_range=(-10.0, 40.0)`` (``warm->cold``) or on ``profile="cycle"`` at the
calibration's range (``warm->cycle``: cooling ramps, thermal states the heating-only
calibration never had).

Targets (on ``ours``, every preset, every seed): mean coverage in [0.87, 0.95], every held-out
fold >= 0.85, mean width <= 1.2 x oracle, out-of-range coverage >= 0.85 pooled and on every
run group (each cold run of the out-of-range split; the worst one is printed, and any below
fails), and coverage on rows outside the domain >= coverage - 0.05 (0.85) on every split with
at least MIN_OUTSIDE_ROWS such rows. The issue on a lot and its intervals adds, per seed group
(:func:`lot_interval_targets`): with ``run_probability=0.8`` at least 95 % of the held-out runs
covered >= 0.85, and ``ours``' mean width over the held-out folds <= 1.15 x the oracle's on
smooth physics (lumped) and <= 1.3 x on nonlinear physics (layered, layered_glass).
Results go to ``benchmarks/results/conformal[_quick][_cvruns|_cvheadings].md`` and
``.json`` (``--out DIR`` elsewhere); exit 1 if a target fails.
"""

import argparse
import sys
import time
import warnings

import numpy as np
from sklearn.base import clone
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GroupKFold, KFold

from sklearn_ifog import ConformalRegressor, RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog._io import write_text_files
from sklearn_ifog.metrics import interval_coverage, mean_interval_width
from sklearn_ifog.model_selection import LeaveOneAzimuthOut

from _cases import (  # isort: skip
    CONFORMAL_ELSEWHERE as ELSEWHERE,
    CONFORMAL_WARM as WARM,
    PHYSICS,
    SEEDS,
    conformal_campaign,
    conformal_real,
)
from _results import add_out_argument, command_line, publish, read_results  # isort: skip
from _verdict import target_line, verdict_line  # isort: skip

NOMINAL = 0.9
# Coverage on rows outside the calibration domain may fall this far below NOMINAL.
OUTSIDE_TOLERANCE = 0.05
# A split's outside rows enter the target when there are at least this many (half a run of
# the campaigns' 300-s samples): fewer say little about a coverage.
MIN_OUTSIDE_ROWS = 30
METHODS = ("ours", "ours_flat", "ours_c08", "mapie_rows", "mapie_runs")
# The issue on a lot and its intervals states the per-run promise as a probability over runs:
# with run_probability=0.8, at least RUN_SHARE of the held-out runs covered >= RUN_COVERAGE; and
# the mean width over the held-out folds at most WIDTH_LIMITS times the oracle's (smooth
# physics: the lumped preset; nonlinear: layered and layered_glass), per seed group.
LOT_RUN_PROBABILITY = 0.8
RUN_COVERAGE = 0.85
RUN_SHARE = 0.95
WIDTH_LIMITS = {"lumped": 1.15, "layered": 1.3, "layered_glass": 1.3}
# How ``ours`` splits its calibration runs: GroupKFold(5) (the folds of MAPIE by run, the
# default here) or, with ``--ours-cv runs``, the estimator's own default (one fold per run).
OURS_CV = {
    "groupkfold5": lambda X: GroupKFold(5),
    "runs": lambda X: None,
    "headings": lambda X: (
        list(LeaveOneAzimuthOut().split(X)) if "azimuth" in X.columns else GroupKFold(5)
    ),
}
SETTINGS = {"ours_cv": "groupkfold5"}
# A seed of make_thermal_campaign draws the gyro itself. ConformalRegressor's difficulty
# model, reference and run_probability were chosen on seeds 0-2 of these campaigns
# (benchmarks/conformal_difficulty_check.py), the calibration domain's margin and blend on
# seeds 0-7 (benchmarks/bench_extrapolation.py --tune): seeds 4211-4213 judge them on gyros none
# of that saw. Both groups are run and reported apart; every target holds on every campaign.
CHOSEN_SEEDS = SEEDS["bench_conformal"]["tuning"]
HELD_OUT_SEEDS = SEEDS["bench_conformal"]["judged"]


def pipeline(**kwargs):
    regressor = RBFNetRegressor(refine=None, criterion="holdout", random_state=0)
    return make_compensation_pipeline(regressor, **kwargs)


def fit_predict(method, X_train, y_train, groups, X_test, base):
    """(point prediction, bounds) of one method on the test rows."""
    if method in ("ours", "ours_flat", "ours_c08"):
        model = ConformalRegressor(
            base,
            coverage=NOMINAL,
            cv=OURS_CV[SETTINGS["ours_cv"]](X_train),
            adaptive=method != "ours_flat",
            **({"run_probability": LOT_RUN_PROBABILITY} if method == "ours_c08" else {}),
        )
        model.fit(X_train, y_train, groups=groups)
        return model.predict(X_test), model.predict_interval(X_test)
    from mapie.regression import CrossConformalRegressor

    if method == "mapie_rows":
        cv = KFold(5, shuffle=True, random_state=0)
        fit_groups = None
    else:
        cv, fit_groups = GroupKFold(5), groups
    model = CrossConformalRegressor(base, confidence_level=NOMINAL, cv=cv, method="plus")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit_conformalize(X_train, y_train, groups=fit_groups)
        point, bounds = model.predict_interval(X_test)
    return np.asarray(point), np.asarray(bounds)[:, :, 0]


def outside_flags(base, X_train, y_train, X_test):
    """Rows of ``X_test`` outside the calibration domain of ``base`` fitted on the train rows.

    The domain is learnt from the feature step's output on the calibration rows, whatever the
    regressor: the same pipeline with a linear regressor gives the final model's flags.
    """
    model = clone(base).set_params(regressor=LinearRegression())
    return model.fit(X_train, y_train).outside_calibration(X_test)


def domain_counts(y, bounds, outside):
    """Rows, rows covered, rows above the band and summed width, inside and outside the
    domain (to be pooled)."""
    covered = (bounds[:, 0] <= y) & (y <= bounds[:, 1])
    above = y > bounds[:, 1]
    width = bounds[:, 1] - bounds[:, 0]
    return {
        f"{where}_{what}": float(value)
        for where, rows in (("inside", ~outside), ("outside", outside))
        for what, value in (
            ("rows", rows.sum()),
            ("covered", covered[rows].sum()),
            ("above", above[rows].sum()),
            ("width_sum", width[rows].sum()),
        )
    }


def pooled_domain(rows):
    """Coverage, mean width and the share of the misses above the band, inside and outside
    the domain, pooled over ``rows`` (splits).

    The misses' side tells a bias from a band too narrow: misses all on one side mean the
    prediction is off in one direction there (None without misses).
    """
    result = {}
    for where in ("inside", "outside"):
        n_rows = sum(row[f"{where}_rows"] for row in rows)
        covered = sum(row[f"{where}_covered"] for row in rows)
        above = sum(row[f"{where}_above"] for row in rows)
        width = sum(row[f"{where}_width_sum"] for row in rows)
        missed = n_rows - covered
        result[f"{where}_rows"] = int(n_rows)
        result[f"{where}_coverage"] = covered / n_rows if n_rows else float("nan")
        result[f"{where}_width"] = width / n_rows if n_rows else float("nan")
        result[f"{where}_misses_above"] = above / missed if missed else None
    return result


def score_fold(y, point, bounds, runs, outside):
    residual = y - point
    oracle = float(np.quantile(residual, 0.95) - np.quantile(residual, 0.05))
    run_ids = np.unique(runs)
    per_run = [interval_coverage(y[runs == run], bounds[runs == run]) for run in run_ids]
    worst = int(np.argmin(per_run))
    return {
        "coverage": interval_coverage(y, bounds),
        "width": mean_interval_width(bounds),
        "oracle": oracle,
        "ratio": mean_interval_width(bounds) / oracle,
        "worst_run": float(per_run[worst]),
        "worst_run_id": run_ids[worst].item(),
        "run_coverage": [[run.item(), float(c)] for run, c in zip(run_ids, per_run, strict=True)],
        **domain_counts(y, bounds, outside),
    }


def evaluate(method, X_train, y_train, runs_train, X_test, y_test, runs_test, base, outside):
    point, bounds = fit_predict(method, X_train, y_train, runs_train, X_test, base)
    return score_fold(y_test, point, bounds, runs_test, outside)


def evaluate_split(method, X, y, runs, train, test, base, outside):
    X_train, X_test = X.iloc[train], X.iloc[test]
    return evaluate(
        method, X_train, y[train], runs[train], X_test, y[test], runs[test], base, outside
    )


def run_campaign(physics, seed, methods):
    X, y = conformal_campaign(physics, seed)
    runs = X["run"].to_numpy()
    base = pipeline()
    result = {}
    folds = list(LeaveOneAzimuthOut().split(X))
    # Out of range: calibrate on the warm runs, test on the cold ones.
    coldest = X.groupby("run")["temperature"].min()
    cold_runs = coldest.index[coldest < coldest.median()].to_numpy()
    cold = np.isin(runs, cold_runs)
    cold_split = (np.flatnonzero(~cold), np.flatnonzero(cold))
    flags = [outside_flags(base, X.iloc[tr], y[tr], X.iloc[te]) for tr, te in [*folds, cold_split]]
    # Calibrate warm, predict elsewhere: the same unit (seed), other chamber conditions.
    X_warm, y_warm = conformal_campaign(physics, seed, **WARM)
    runs_warm = X_warm["run"].to_numpy()
    elsewhere = {}
    for name, kwargs in ELSEWHERE.items():
        X_other, y_other = conformal_campaign(physics, seed, **kwargs)
        other_flags = outside_flags(base, X_warm, y_warm, X_other)
        elsewhere[name] = (X_other, y_other, X_other["run"].to_numpy(), other_flags)
    for method in methods:
        rows = [
            evaluate_split(method, X, y, runs, tr, te, base, outside)
            for (tr, te), outside in zip(folds, flags[:-1], strict=True)
        ]
        cold_row = evaluate_split(method, X, y, runs, *cold_split, base, flags[-1])
        domain = {
            "held-out folds": pooled_domain(rows),
            "out of range": pooled_domain([cold_row]),
        }
        for name, (X_other, y_other, runs_other, other_flags) in elsewhere.items():
            row = evaluate(
                method, X_warm, y_warm, runs_warm, X_other, y_other, runs_other, base, other_flags
            )
            domain[name] = {**pooled_domain([row]), "coverage": row["coverage"]}
        result[method] = {
            "domain": domain,
            "folds": rows,
            "mean_coverage": float(np.mean([r["coverage"] for r in rows])),
            "worst_fold": float(min(r["coverage"] for r in rows)),
            "worst_run": float(min(r["worst_run"] for r in rows)),
            "width_ratio": float(np.mean([r["ratio"] for r in rows])),
            "mean_width": float(np.mean([r["width"] for r in rows])),
            "out_of_range_coverage": cold_row["coverage"],
            "out_of_range_worst_run": cold_row["worst_run"],
            "out_of_range_worst_run_id": cold_row["worst_run_id"],
            "out_of_range_run_coverage": cold_row["run_coverage"],
            "out_of_range_ratio": cold_row["ratio"],
        }
    return result


def run_real(methods):
    X, y, bursts = conformal_real("gyro_x")
    block = bursts // 5
    base = pipeline(time=None, run=None, terms=("T",))
    result = {}
    splits = [
        (np.flatnonzero(block != held), np.flatnonzero(block == held)) for held in np.unique(block)
    ]
    flags = [outside_flags(base, X.iloc[tr], y[tr], X.iloc[te]) for tr, te in splits]
    for method in methods:
        rows = [
            evaluate_split(method, X, y, bursts, train, test, base, outside)
            for (train, test), outside in zip(splits, flags, strict=True)
        ]
        result[method] = {
            "domain": {"held-out blocks": pooled_domain(rows)},
            "folds": rows,
            "mean_coverage": float(np.mean([r["coverage"] for r in rows])),
            "worst_fold": float(min(r["coverage"] for r in rows)),
            "worst_run": float(min(r["worst_run"] for r in rows)),
            "width_ratio": float(np.mean([r["ratio"] for r in rows])),
            "mean_width": float(np.mean([r["width"] for r in rows])),
        }
    return result


def check_targets(results):
    failures = []
    for key, result in results.items():
        if key.startswith("real"):
            continue
        ours = result["ours"]
        if not 0.87 <= ours["mean_coverage"] <= 0.95:
            failures.append(
                f"{key}: mean coverage {ours['mean_coverage']:.3f} not in [0.87, 0.95]"
            )
        if ours["worst_fold"] < 0.85:
            failures.append(f"{key}: worst held-out fold {ours['worst_fold']:.3f} < 0.85")
        if ours["width_ratio"] > 1.2:
            failures.append(f"{key}: width/oracle {ours['width_ratio']:.3f} > 1.2")
        if ours["out_of_range_coverage"] < 0.85:
            failures.append(
                f"{key}: out-of-range coverage {ours['out_of_range_coverage']:.3f} < 0.85"
            )
    return failures


def out_of_range_target(results):
    """Out-of-range coverage of ``ours`` on every run group: (failures, lowest, its run).

    The pooled out-of-range coverage can hold while one cold run is badly covered; the
    promise is for each run group (each held-out run of the out-of-range split).
    """
    failures, lowest, where = [], float("inf"), "no out-of-range split"
    for key, result in results.items():
        if key.startswith("real"):
            continue
        ours = result["ours"]
        coverage = ours["out_of_range_worst_run"]
        run = ours.get("out_of_range_worst_run_id")
        label = f"{key}, run {run}" if run is not None else key
        if coverage < lowest:
            lowest, where = coverage, label
        if coverage < 0.85:
            failures.append(
                f"{label}: out-of-range coverage of the worst run group {coverage:.3f} < 0.85"
            )
    return failures, lowest, where


def domain_target(results):
    """The outside-the-domain target on ``ours``: (failures, lowest coverage, its split)."""
    floor = NOMINAL - OUTSIDE_TOLERANCE
    failures, lowest, where = [], float("inf"), "no split with enough rows outside"
    for key, result in results.items():
        if key.startswith("real"):
            continue
        for split, row in result["ours"].get("domain", {}).items():
            if row["outside_rows"] < MIN_OUTSIDE_ROWS:
                continue
            coverage = row["outside_coverage"]
            if coverage < lowest:
                lowest, where = coverage, f"{key}, {split}"
            if coverage < floor:
                failures.append(
                    f"{key}, {split}: coverage {coverage:.3f} on the {row['outside_rows']} rows "
                    f"outside the calibration domain < {floor:.2f}"
                )
    return failures, lowest, where


def domain_lines(results):
    """Coverage and width inside and outside the calibration domain, per split."""
    lines = [
        "## Inside and outside the calibration domain",
        "",
        "Rows flagged by the calibration domain of the model fitted on the split's "
        "calibration runs. Held-out folds: pooled over the folds. Warm->cold and "
        "warm->cycle: the campaign's unit calibrated on temperature_range=(10, 40), tested "
        "on (-10, 40) and on the cycle profile at (10, 40). Target (ours): coverage outside "
        f">= {NOMINAL - OUTSIDE_TOLERANCE:.2f} where at least {MIN_OUTSIDE_ROWS} rows are "
        "outside. Misses above: the share of the rows outside the band that lie above it "
        "(1 or 0: every miss on one side, the prediction biased there; '-': no miss).",
        "",
        "| data | split | method | rows inside | coverage inside | width inside | rows outside "
        "| coverage outside | width outside | width outside / inside | misses above, outside |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for key, result in results.items():
        splits = next(iter(result.values())).get("domain", {})
        for split in splits:
            for method, row in result.items():
                d = row["domain"][split]
                ratio = d["outside_width"] / d["inside_width"]
                lines.append(
                    f"| {key} | {split} | {method} | {d['inside_rows']} | "
                    f"{d['inside_coverage']:.3f} | {d['inside_width']:.4g} | "
                    f"{d['outside_rows']} | {d['outside_coverage']:.3f} | "
                    f"{d['outside_width']:.4g} | {ratio:.2f} | "
                    f"{_side(d['outside_misses_above'])} |"
                )
    return lines


def _side(share):
    return "-" if share is None else f"{share:.2f}"


def _seed_of(key):
    return int(key.rsplit(" ", 1)[1])


def _physics_of(key):
    return key.rsplit(" seed ", 1)[0]


def lot_interval_targets(results, quick=False):
    """The issue's targets on a lot's intervals, per seed group: (lines, verdicts).

    With ``run_probability=0.8`` (``ours_c08``), the share of the held-out runs (every run of
    every held-out fold) covered at least RUN_COVERAGE; and, per physics, the mean over the
    held-out folds of ``ours``' width over the oracle's against WIDTH_LIMITS. With
    ``quick`` the share is not judged (INFO): one campaign's 12 runs cannot resolve a 95 %
    rate (one miss is 92 %).
    """
    campaigns = {key: value for key, value in results.items() if not key.startswith("real")}
    lines = [
        "## A lot's intervals: the per-run promise and the width",
        "",
        f"Held-out runs covered >= {RUN_COVERAGE} (every run of every held-out fold) with "
        f"`ours` (run_probability 0.6, the default) and `ours_c08` (run_probability "
        f"{LOT_RUN_PROBABILITY}); "
        "mean width over the held-out folds / oracle, per physics (target: "
        + ", ".join(f"{physics} <= {limit}" for physics, limit in WIDTH_LIMITS.items())
        + f"; runs: >= {RUN_SHARE:.0%} with ours_c08).",
        "",
        "| seeds | physics | runs | ours: runs >= 0.85 | ours_c08: runs >= 0.85 "
        "| ours width / oracle | ours_c08 width / oracle |",
        "|---|---|---|---|---|---|---|",
    ]
    verdicts = []
    for seeds in (CHOSEN_SEEDS, HELD_OUT_SEEDS):
        group = {key: value for key, value in campaigns.items() if _seed_of(key) in seeds}
        if not group or "ours_c08" not in next(iter(group.values())):
            continue
        label = ", ".join(str(seed) for seed in sorted({_seed_of(key) for key in group}))
        pooled = {"ours": [], "ours_c08": []}
        for physics in dict.fromkeys(_physics_of(key) for key in group):
            rows = [value for key, value in group.items() if _physics_of(key) == physics]
            shares, widths = {}, {}
            for method in ("ours", "ours_c08"):
                runs = [
                    coverage
                    for row in rows
                    for fold in row[method]["folds"]
                    for _, coverage in fold["run_coverage"]
                ]
                pooled[method] += runs
                shares[method] = np.mean(np.array(runs) >= RUN_COVERAGE)
                widths[method] = float(
                    np.mean([fold["ratio"] for row in rows for fold in row[method]["folds"]])
                )
            lines.append(
                f"| {label} | {physics} | {len(runs)} | {shares['ours']:.3f} | "
                f"{shares['ours_c08']:.3f} | {widths['ours']:.3f} | {widths['ours_c08']:.3f} |"
            )
            limit = WIDTH_LIMITS[physics]
            verdicts.append(
                target_line(
                    widths["ours"] <= limit,
                    f"seeds {label}, {physics}: ours mean width / oracle <= {limit} "
                    f"({widths['ours']:.3f})",
                )
            )
        share = float(np.mean(np.array(pooled["ours_c08"]) >= RUN_COVERAGE))
        verdicts.append(
            verdict_line(
                share >= RUN_SHARE,
                f"seeds {label}: with run_probability={LOT_RUN_PROBABILITY}, held-out runs "
                f"covered >= {RUN_COVERAGE}: {share:.3f} of {len(pooled['ours_c08'])} >= "
                f"{RUN_SHARE}",
                not quick,
            )
        )
    return lines, verdicts


def summary_lines(results):
    """Per method and seed group: ranges, failing folds, lowest out-of-range coverage."""
    campaigns = {key: value for key, value in results.items() if not key.startswith("real")}
    if not campaigns:
        return []
    lines = []
    for seeds, note in (
        (CHOSEN_SEEDS, "the seeds the conformal rules were chosen on"),
        (HELD_OUT_SEEDS, "held out: nothing measured here was chosen on them"),
    ):
        group = {key: value for key, value in campaigns.items() if _seed_of(key) in seeds}
        if not group:
            continue
        lines += [
            f"Summary over the {len(group)} simulated campaign(s) of seed(s) "
            f"{', '.join(str(seed) for seed in sorted({_seed_of(key) for key in group}))} "
            f"({note}):",
            "",
            "| method | mean coverage (range) | folds below 0.85 | width / oracle (range; mean) "
            "| out-of-range coverage (lowest) | out-of-range worst run group (lowest) "
            "| out-of-range run groups below 0.85 |",
            "|---|---|---|---|---|---|---|",
        ]
        for method in next(iter(group.values())):
            rows = [campaign[method] for campaign in group.values()]
            means = [row["mean_coverage"] for row in rows]
            ratios = [row["width_ratio"] for row in rows]
            folds = [fold["coverage"] for row in rows for fold in row["folds"]]
            below = sum(coverage < 0.85 for coverage in folds)
            run_groups = [
                coverage
                for row in rows
                for _, coverage in row.get(
                    "out_of_range_run_coverage", [[None, row["out_of_range_worst_run"]]]
                )
            ]
            lines.append(
                f"| {method} | {min(means):.3f}-{max(means):.3f} | {below} of {len(folds)} | "
                f"{min(ratios):.2f}-{max(ratios):.2f}; {np.mean(ratios):.2f} | "
                f"{min(row['out_of_range_coverage'] for row in rows):.3f} | "
                f"{min(run_groups):.3f} | "
                f"{sum(c < 0.85 for c in run_groups)} of {len(run_groups)} |"
            )
        lines.append("")
    return lines[:-1]


def markdown(results, failures, command, elapsed, lot_lines=()):
    lines = [
        "# Conformal intervals: ours vs MAPIE row-wise vs MAPIE by run",
        "",
        f"Command: `{command}` ({elapsed:.0f} s). 90 % nominal; held-out folds: leave one "
        "azimuth out within each unit; drift model: make_compensation_pipeline (default "
        "features) with RBFNetRegressor(refine=None, criterion='holdout'). Oracle: 5-95 % "
        "range of the "
        "method's own held-out residuals. Out of range: calibrated on the warmer half of the "
        "runs, tested on the colder half; its run groups are those cold runs. Real: "
        "load_psim_tvc gyro_x, 5 blocks of 5 bursts held out in turn. Seeds "
        f"{', '.join(str(seed) for seed in CHOSEN_SEEDS)}: the conformal rules were chosen "
        f"on them; seeds {', '.join(str(seed) for seed in HELD_OUT_SEEDS)}: held out from "
        "every choice (see the docstring).",
        "",
        "| data | method | mean coverage | worst fold | worst run | width / oracle | "
        "out-of-range coverage | out-of-range worst run |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for key, result in results.items():
        for method, row in result.items():
            oor = row.get("out_of_range_coverage")
            oor_run = row.get("out_of_range_worst_run")
            lines.append(
                f"| {key} | {method} | {row['mean_coverage']:.3f} | {row['worst_fold']:.3f} | "
                f"{row['worst_run']:.3f} | {row['width_ratio']:.3f} | "
                + ("-" if oor is None else f"{oor:.3f}")
                + " | "
                + ("-" if oor_run is None else f"{oor_run:.3f}")
                + " |"
            )
    lines += ["", *summary_lines(results)]
    if any("domain" in row for result in results.values() for row in result.values()):
        lines += ["", *domain_lines(results)]
    if lot_lines:
        lines += ["", *lot_lines]
    lines += ["", "## Verdict", ""]
    lines += [f"- FAIL {f}" for f in failures] or ["- PASS: every target on every campaign."]
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one preset, one seed")
    parser.add_argument("--no-mapie", action="store_true", help="only ours")
    add_out_argument(parser)
    parser.add_argument(
        "--rewrite",
        action="store_true",
        help="re-render results/conformal[_quick][_cv...].md from its .json (no new measurement)",
    )
    parser.add_argument(
        "--ours-cv",
        choices=tuple(OURS_CV),
        default="groupkfold5",
        help="how ours splits its calibration runs: GroupKFold(5), as MAPIE by run "
        "(default), one fold per run (the estimator's default cv=None), or one heading "
        "held out per fold (LeaveOneAzimuthOut)",
    )
    args = parser.parse_args(argv)
    SETTINGS["ours_cv"] = args.ours_cv
    if args.rewrite:
        stem = ("conformal_quick" if args.quick else "conformal") + (
            "" if args.ours_cv == "groupkfold5" else f"_cv{args.ours_cv}"
        )
        record = read_results(args.out / f"{stem}.json")
        elapsed = record.get("elapsed", float("nan"))
        lot_lines, _ = lot_interval_targets(record["results"])
        text = markdown(
            record["results"], record["failures"], record["command"], elapsed, lot_lines
        )
        write_text_files({args.out / f"{stem}.md": text})
        print(text)
        return 1 if record["failures"] else 0
    # 300-s samples leave too few selection rows for a quadratic tail on some folds; the
    # network says so and falls back to a linear tail (the same for every method).
    warnings.filterwarnings("ignore", message=".*quadratic tail.*")
    methods = ("ours",) if args.no_mapie else METHODS
    if not args.no_mapie:
        try:
            import mapie  # noqa: F401
        except ImportError:
            print("MAPIE is not installed (pip install 'sklearn-ifog[conformal]').")
            return 2
    presets = PHYSICS[:1] if args.quick else PHYSICS
    seeds = CHOSEN_SEEDS[:1] if args.quick else CHOSEN_SEEDS + HELD_OUT_SEEDS
    start = time.perf_counter()
    results = {}
    for physics in presets:
        for seed in seeds:
            key = f"{physics} seed {seed}"
            results[key] = run_campaign(physics, seed, methods)
            row = results[key]["ours"]
            outside = ", ".join(
                f"{split} {d['outside_coverage']:.3f} ({d['outside_rows']} rows)"
                for split, d in row["domain"].items()
            )
            print(
                f"{key}: ours mean {row['mean_coverage']:.3f} worst {row['worst_fold']:.3f} "
                f"ratio {row['width_ratio']:.3f} out-of-range {row['out_of_range_coverage']:.3f}"
                f"; outside the domain: {outside} ({time.perf_counter() - start:.0f} s)",
                flush=True,
            )
    if not args.quick:
        results["real psim_tvc gyro_x"] = run_real(methods)
    elapsed = time.perf_counter() - start
    failures = check_targets(results)
    run_failures, lowest_run, worst_run = out_of_range_target(results)
    outside_failures, lowest, where = domain_target(results)
    lot_lines, lot_verdicts = lot_interval_targets(results, args.quick)
    command = command_line(__file__, argv)
    all_failures = (
        failures
        + run_failures
        + outside_failures
        + [line.removeprefix("FAIL: ") for line in lot_verdicts if line.startswith("FAIL")]
    )
    text = markdown(results, all_failures, command, elapsed, lot_lines)
    stem = ("conformal_quick" if args.quick else "conformal") + (
        "" if args.ours_cv == "groupkfold5" else f"_cv{args.ours_cv}"
    )
    verdicts = [target_line(False, failure) for failure in failures]
    if not failures:
        verdicts.append(
            target_line(True, "coverage, width and pooled out-of-range targets on every campaign")
        )
    verdicts += [
        target_line(
            not run_failures,
            "ours: out-of-range coverage >= 0.85 on every run group of every campaign "
            f"(worst {lowest_run:.3f}: {worst_run})",
        ),
        target_line(
            not outside_failures,
            "ours: coverage on rows outside the calibration domain >= coverage - "
            f"{OUTSIDE_TOLERANCE} ({NOMINAL - OUTSIDE_TOLERANCE:.2f}) on every split with at "
            f"least {MIN_OUTSIDE_ROWS} such rows (lowest {lowest:.3f}: {where})",
        ),
        *lot_verdicts,
    ]
    # The record keeps the command and duration beside the envelope's, so that --rewrite
    # re-renders the Markdown from read_results alone.
    record = {
        "command": command,
        "elapsed": elapsed,
        "results": results,
        "failures": all_failures,
    }
    publish(
        args.out,
        stem,
        text,
        record,
        script=__file__,
        command=command,
        seconds=elapsed,
        verdicts=verdicts,
    )
    return 1 if all_failures else 0


if __name__ == "__main__":
    sys.exit(main())
