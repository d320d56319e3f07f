"""Thermal state: how much drift models leave on the paper's and on thermal-state features.

Run (about 20-30 min on two cores; ``--quick`` for CI, well under a minute)::

    python benchmarks/bench_thermal_state.py --n-jobs 2

For every seed, physics preset ({lumped, layered, layered_glass}) and sample period, one
simulated campaign (``make_thermal_campaign``, sizes in the output) is split leave one
azimuth out within each unit (``LeaveOneAzimuthOut``). Every model is a pipeline
``features -> StandardScaler -> regressor`` for two feature sets:

- ``paper``: ``ThermalFeatures(time="time", run="run", terms=("T", "dT", "TdT"))``;
- ``state``: ``ThermalFeatures(time="time", run="run")``, the package's default features
  (thermal-state terms ``T_lag<tau>s`` = T - lag_tau(T) and dT smoothed over a time
  constant); ``--taus`` and ``--smoothing`` give other sets to explore.

Metrics per held-out fold: MSD / noise floor (floor = mean squared gyro noise of the held-out
rows, :func:`sklearn_ifog.datasets.noise_floor`) and the thermal residual
mean((predicted - true drift)²) / floor, both pooled over folds (sum over rows / sum of the
floor over rows). The model comparisons (targets 2 and 3, and the WIN/TIE/LOSS lines) are on
the thermal residual: it is what a model gets wrong of the drift, non-negative and free of
the gyro noise. The excess MSD/floor - 1 that they used before estimates the same thing but
adds twice the held-out noise's correlation with the residual, so near the floor it can be
negative (target 1's MSD/floor is below 1 on some campaigns), and a ratio of two such
excesses can change sign or blow up for noise alone.

Targets (exit 1 when one fails):

1. the default pipeline (RBFNetRegressor() on the ``--default-features`` set, i.e.
   ``make_compensation_pipeline()``) has a pooled
   MSD <= 1.25 x floor on "layered" and <= 3 x floor on "layered_glass", for every seed and
   sample period;
2. with RBFNetRegressor, the thermal residual of the state features is at least 2 x
   smaller than the paper features' on "layered", and never larger on "lumped", for every
   seed and sample period.

3. the default network against its peers on the default features (issue 12): the pooled
   thermal residual of RBFNet at most 0.8 x the best of the linear Ridge, poly2 Ridge,
   poly3 Ridge, MLP(20), MLP(50,50), HistGB and KernelRidge on "layered" and
   "layered_glass", and at most 1.02 x the best of them on "lumped", for every seed and
   sample period (only when every one of those models is in the run). The linear Ridge is
   a peer on every preset: with the default features, whose squares and products are the
   physics', it is the model to beat, so where the network only ties it the target fails;
4. Gaussian units in use (``centers_`` not empty) in most folds of the default network on
   "layered" and "layered_glass", per sample period (counted over seeds; only when RBFNet
   is in the run);
5. on the shipped real recording (``load_psim_tvc``, alternate bursts, gyro x and y): the
   default network's held-out burst-mean MSD at most 1.02 x the best other model's,
   "linear in T" included (see :func:`real_recording`).

Verdicts against every model of the table: per campaign (physics, period, seed), one
WIN/TIE/LOSS line of RBFNet on the default feature set against each other model on the same
features, on the pooled thermal residual over the floor (a tie is within the relative
margin of ``benchmarks/_verdict.py``). They are reported, not targets. Besides the peers of
target 3 the table holds ``RBFNet (quadratic tail)``, the network with the tail it had by
default before, and ``RBFNet (refine=None)``, the selected network without refinement.

The default seeds (0-2, the ``tuning`` seeds of ``_cases.SEEDS["bench_thermal_state"]``)
are the campaigns on which the default features (terms, lags, smoothing) were chosen; the
same run on its ``judged`` seeds, on which no default was chosen, writes
``thermal_state_heldout.*``::

    python benchmarks/bench_thermal_state.py --seeds 4241 4242 4243 --tag heldout --n-jobs 2

The campaigns are ``_cases.thermal_state_campaign``. ``--quick`` (CI, well under a minute
of CPU): one seed, 120 s samples, four models, one run per (unit, azimuth), only the first
azimuth of each campaign held out (``QUICK_FOLDS``), and on the real recording gyro x on
every fourth sample (``_cases.REAL_QUICK_STEP``) with the even bursts training only; target
1's floor ratios print as ``INFO`` there (one run per azimuth cannot be held to them), targets
2, 4 and 5 are judged. Writes
``benchmarks/results/thermal_state[_quick].md`` and ``.json`` (``--out DIR`` elsewhere).
"""

import argparse
import re
import sys
import time
import warnings

import numpy as np
from joblib import Parallel, delayed
from sklearn.compose import TransformedTargetRegressor
from sklearn.ensemble import HistGradientBoostingRegressor
from sklearn.exceptions import ConvergenceWarning
from sklearn.kernel_ridge import KernelRidge
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.neural_network import MLPRegressor
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

from sklearn_ifog import RBFNetRegressor, ThermalFeatures, make_compensation_pipeline
from sklearn_ifog.comparison import SubsampledRegressor
from sklearn_ifog.datasets import noise_floor
from sklearn_ifog.model_selection import LeaveOneAzimuthOut

import _cases  # isort: skip
from _cases import (  # isort: skip
    PHYSICS,
    SEEDS,
    THERMAL_STATE_FULL,
    THERMAL_STATE_QUICK,
    thermal_state_campaign,
)
from _results import add_out_argument, command_line, publish  # isort: skip
from _verdict import comparison_line, exit_code, verdict_line  # isort: skip

TARGET_RATIO = {"layered": 1.25, "layered_glass": 3.0}
STATE_GAIN = 2.0  # thermal residual, paper / state, on "layered"


def feature_sets(taus, smoothing, terms=None):
    """The paper's (T, dT, T·dT) and the thermal-state features, both from ThermalFeatures.

    ``taus=None`` and ``terms=None`` mean ThermalFeatures' own default (what a user gets
    untuned); a list of ``taus`` gives the paper's terms and ``T_lag<tau>s`` explicitly, and
    ``terms`` any explicit set, with ``smoothing`` seconds, to explore other sets.
    """
    if terms is not None:
        state = {"terms": tuple(terms), "smoothing": smoothing}
    elif taus is None:
        state = {}
    else:
        lags = tuple(f"T_lag{tau:g}s" for tau in taus)
        state = {"terms": ("T", "dT", "TdT", *lags), "smoothing": smoothing}
    return {
        "paper": lambda: ThermalFeatures(time="time", run="run", terms=("T", "dT", "TdT")),
        "state": lambda: ThermalFeatures(time="time", run="run", **state),
    }


TAIL_SWEEP = re.compile(r"^RBFNet \(tail_alpha=(?P<alpha>[0-9.eE+-]+)\)$")


def swept_tail_alphas(models):
    """The tail penalty strengths named in ``models`` ("RBFNet (tail_alpha=<value>)")."""
    return [float(m["alpha"]) for m in map(TAIL_SWEEP.match, models) if m is not None]


def regressors(seed, max_kernel_samples=600, max_mlp_samples=3000, tail_alphas=()):
    def scaled(regressor):
        return TransformedTargetRegressor(regressor=regressor, transformer=StandardScaler())

    def poly(degree):
        return Pipeline(
            [("poly", PolynomialFeatures(degree, include_bias=False)), ("ridge", Ridge(1e-3))]
        )

    def mlp(sizes):
        # lbfgs on every row of 10 s data takes minutes per fit: the MLPs, like the kernel
        # model, are fitted on a random subsample (the rows are strongly autocorrelated).
        return SubsampledRegressor(
            scaled(
                MLPRegressor(
                    hidden_layer_sizes=sizes,
                    solver="lbfgs",
                    alpha=1e-3,
                    max_iter=500,
                    random_state=seed,
                )
            ),
            max_samples=max_mlp_samples,
            random_state=seed,
        )

    # The default network at other tail penalty strengths (the sweep that chose the
    # default, issue 41), asked for by name: --models "RBFNet (tail_alpha=0)" ...
    sweep = {
        f"RBFNet (tail_alpha={alpha:g})": (
            lambda alpha=alpha: RBFNetRegressor(tail_alpha=alpha, random_state=seed)
        )
        for alpha in tail_alphas
    }
    return {
        **sweep,
        "RBFNet": lambda: RBFNetRegressor(random_state=seed),
        "RBFNet (quadratic tail)": lambda: RBFNetRegressor(tail="quadratic", random_state=seed),
        "RBFNet (refine=None)": lambda: RBFNetRegressor(refine=None, random_state=seed),
        "Ridge": lambda: Ridge(1e-3),
        "poly2 Ridge": lambda: poly(2),
        "poly3 Ridge": lambda: poly(3),
        "MLP(20)": lambda: mlp((20,)),
        "MLP(50,50)": lambda: mlp((50, 50)),
        "HistGB": lambda: HistGradientBoostingRegressor(random_state=seed),
        "KernelRidge": lambda: SubsampledRegressor(
            scaled(KernelRidge(kernel="rbf", alpha=0.1, gamma=0.05)),
            max_samples=max_kernel_samples,
            random_state=seed,
        ),
    }


QUICK_MODELS = ("RBFNet", "Ridge", "poly2 Ridge", "HistGB")
QUICK_FOLDS = 1  # --quick holds out the first azimuth of each campaign only (CI time)
# The peers of target 3 (issue 12), on the default features, on every preset: the linear
# Ridge first, since on features that hold the physics' squares and products it is the
# model a network has to beat.
PEERS = ("Ridge", "poly2 Ridge", "poly3 Ridge", "MLP(20)", "MLP(50,50)", "HistGB", "KernelRidge")
PEER_RATIO = 0.8  # RBFNet's thermal residual over the best peer's, layered presets
LUMPED_RATIO = 1.02  # the same on "lumped"


def _evaluate_fold(seed, physics, period, sizes, fold, models, sets_spec):
    campaign = thermal_state_campaign(seed, physics, period, sizes)
    X, y = campaign.data, np.asarray(campaign.target)
    drift = campaign.frame["drift"].to_numpy()
    train, test = list(LeaveOneAzimuthOut().split(X))[fold]
    floor = noise_floor(campaign.frame, test)
    sets = feature_sets(*sets_spec)
    record = {
        "seed": seed,
        "physics": physics,
        "period": period,
        "fold": fold,
        "unit": int(X["unit"].iloc[test[0]]),
        "azimuth": float(X["azimuth"].iloc[test[0]]),
        "n_train": int(train.size),
        "n_test": int(test.size),
        "floor": floor,
        "results": {},
    }
    for set_name, make_features in sets.items():
        for model_name, make_model in regressors(
            seed, tail_alphas=swept_tail_alphas(models)
        ).items():
            if model_name not in models:
                continue
            pipeline = Pipeline(
                [
                    ("features", make_features()),
                    ("scale", StandardScaler()),
                    ("regressor", make_model()),
                ]
            )
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                pipeline.fit(X.iloc[train], y[train])
            predicted = pipeline.predict(X.iloc[test])
            msd = float(np.mean(np.square(y[test] - predicted)))
            residual = float(np.mean(np.square(predicted - drift[test])))
            result = {"msd": msd, "residual": residual, "fit_s": time.perf_counter() - start}
            network = pipeline[-1]
            if isinstance(network, RBFNetRegressor):
                result["n_centers"] = int(network.centers_.shape[0])
            record["results"][f"{set_name}|{model_name}"] = result
    return record


REAL_AXES = ("gyro_x", "gyro_y")  # the axes with a thermal drift (gyro z has none to model)


def real_recording(models, seed=0, axes=REAL_AXES, parities=(0, 1), step=1):
    """The shipped real recording: alternate bursts, burst-mean MSD of each model.

    ``load_psim_tvc``: 25 bursts of 5 s, 300 s apart; even bursts train and odd ones test,
    then the reverse (``parities``: 0, even bursts train; ``--quick``: that split only).
    Within 5 s the temperature reading moves by noise only, so the model sees
    ``terms=("T",)`` (as the gallery's real-recording example explains); "linear in T"
    is a LinearRegression on it. The score per held-out burst is its mean residual (the
    white noise of one sample, about 55 deg/h, averages down by sqrt(250)): the mean of the
    squared burst-mean residuals, per axis of ``axes`` (``REAL_AXES``; ``--quick``: gyro x,
    and every ``step``-th sample only).
    """
    X, Y = _cases.real_recording_xy(step)
    burst = X["burst"].to_numpy()
    candidates = {
        **regressors(seed, tail_alphas=swept_tail_alphas(models)),
        "linear in T": LinearRegression,
    }
    scores = {}
    for parity in parities:
        train = burst % 2 == parity
        for model_name, make_model in candidates.items():
            if model_name not in models and model_name != "linear in T":
                continue
            pipeline = make_compensation_pipeline(make_model(), time=None, run=None, terms=("T",))
            for axis in axes:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", ConvergenceWarning)
                    pipeline.fit(X[train], Y[axis][train])
                residual = Y[axis][~train].to_numpy() - pipeline.predict(X[~train])
                means = np.bincount(burst[~train], weights=residual) / np.maximum(
                    np.bincount(burst[~train]), 1
                )
                held_out = np.unique(burst[~train])
                key = f"{axis}, test {'odd' if parity == 0 else 'even'} bursts"
                scores.setdefault(key, {})[model_name] = float(np.mean(means[held_out] ** 2))
    return scores


def real_checks(scores):
    """RBFNet's burst-mean MSD at most 1.02 x the best other model's, per axis and split."""
    checks = []
    for split, cell in scores.items():
        if "RBFNet" not in cell:
            continue
        others = {name: value for name, value in cell.items() if not name.startswith("RBFNet")}
        best_name = min(others, key=others.get)
        ratio = cell["RBFNet"] / others[best_name]
        checks.append(
            {
                "target": f"real recording, RBFNet burst-mean MSD <= {LUMPED_RATIO:g} x the "
                f"best other model's ({best_name}): {split}",
                "value": float(ratio),
                "pass": bool(ratio <= LUMPED_RATIO),
            }
        )
    return checks


def real_markdown(scores):
    names = list(dict.fromkeys(name for cell in scores.values() for name in cell))
    lines = [
        "## Real recording (load_psim_tvc), alternate bursts",
        "",
        "Mean of the squared held-out burst-mean residuals, (deg/h)², terms=('T',) (no "
        "rate is measurable within a 5 s burst); see real_recording() in the script.",
        "",
        "| model | " + " | ".join(scores) + " |",
        "|---|" + "---|" * len(scores),
    ]
    for name in names:
        lines.append(
            f"| {name} | " + " | ".join(f"{cell[name]:.2f}" for cell in scores.values()) + " |"
        )
    return "\n".join(lines) + "\n"


def run(seeds, physics_list, periods, sizes, models, sets_spec, n_jobs, max_folds=None):
    """Every fold's record; ``max_folds``: the first folds of each campaign only (--quick)."""
    tasks = []
    for seed in seeds:
        for physics in physics_list:
            for period in periods:
                campaign = thermal_state_campaign(seed, physics, period, sizes)
                n_folds = LeaveOneAzimuthOut().get_n_splits(campaign.data)
                tasks += [(seed, physics, period, fold) for fold in range(n_folds)][:max_folds]
    print(f"{len(tasks)} folds to fit", file=sys.stderr, flush=True)
    started = time.perf_counter()
    records = []
    parallel = Parallel(n_jobs=n_jobs, return_as="generator")
    jobs = (
        delayed(_evaluate_fold)(seed, physics, period, sizes, fold, models, sets_spec)
        for seed, physics, period, fold in tasks
    )
    for done, record in enumerate(parallel(jobs), start=1):
        records.append(record)
        elapsed = time.perf_counter() - started
        print(
            f"[{done}/{len(tasks)} {elapsed:6.0f}s] seed {record['seed']} {record['physics']} "
            f"{record['period']:g}s fold {record['fold']}: "
            + ", ".join(
                f"{key} {value['msd'] / record['floor']:.2f}"
                for key, value in record["results"].items()
                if key.endswith("RBFNet")
            ),
            file=sys.stderr,
            flush=True,
        )
    return records


def _pooled(records, key, field="msd"):
    """Sum of squared errors over the folds' rows / sum of squared noise: pooled ratio."""
    errors = sum(r["results"][key][field] * r["n_test"] for r in records)
    noise = sum(r["floor"] * r["n_test"] for r in records)
    return errors / noise


def summarize(records, default_features):
    keys = list(records[0]["results"])
    summary = {}
    campaigns = sorted({(r["physics"], r["period"], r["seed"]) for r in records})
    for physics, period, seed in campaigns:
        subset = [
            r for r in records if (r["physics"], r["period"], r["seed"]) == (physics, period, seed)
        ]
        summary[f"{physics}|{period:g}|{seed}"] = {
            key: {
                "msd_over_floor": _pooled(subset, key),
                "residual_over_floor": _pooled(subset, key, "residual"),
            }
            for key in keys
        }
    checks = []
    default_key = f"{default_features}|RBFNet"
    for physics, period, seed in campaigns:
        cell = summary[f"{physics}|{period:g}|{seed}"]
        label = f"{physics}, {period:g} s, seed {seed}"
        if physics in TARGET_RATIO and default_key in cell:
            ratio = cell[default_key]["msd_over_floor"]
            checks.append(
                {
                    "target": f"default pipeline ({default_key}) MSD/floor <= "
                    f"{TARGET_RATIO[physics]:g}: {label}",
                    "value": ratio,
                    "pass": bool(ratio <= TARGET_RATIO[physics]),
                    "kind": "floor",
                }
            )
        if "paper|RBFNet" in cell and "state|RBFNet" in cell:
            paper = cell["paper|RBFNet"]["residual_over_floor"]
            state = cell["state|RBFNet"]["residual_over_floor"]
            if physics == "layered":
                gain = paper / state if state > 0 else np.inf
                checks.append(
                    {
                        "target": f"RBFNet thermal residual paper/state >= {STATE_GAIN:g}: "
                        f"{label}",
                        "value": float(gain),
                        "pass": bool(gain >= STATE_GAIN),
                    }
                )
            elif physics == "lumped":
                checks.append(
                    {
                        "target": f"RBFNet thermal residual state <= paper (x floor): {label}",
                        "value": [float(state), float(paper)],
                        "pass": bool(state <= paper),
                    }
                )
    checks += _baseline_checks(records, summary, campaigns, default_features)
    return summary, checks


def _baseline_checks(records, summary, campaigns, default_features):
    """Targets 3 and 4: the default network against its peers, and its Gaussian units."""
    checks = []
    ours = f"{default_features}|RBFNet"
    peers = [f"{default_features}|{name}" for name in PEERS]
    for physics, period, seed in campaigns:
        cell = summary[f"{physics}|{period:g}|{seed}"]
        if ours not in cell or not all(key in cell for key in peers):
            continue
        bound = LUMPED_RATIO if physics == "lumped" else PEER_RATIO
        best_key = min(peers, key=lambda key: cell[key]["residual_over_floor"])
        best = cell[best_key]["residual_over_floor"]
        residual = cell[ours]["residual_over_floor"]
        ratio = residual / best if best > 0 else np.inf
        checks.append(
            {
                "target": f"RBFNet thermal residual <= {bound:g} x the best peer's "
                f"({best_key.split('|')[1]}): {physics}, {period:g} s, seed {seed}",
                "value": float(ratio),
                "pass": bool(ratio <= bound),
            }
        )
    for physics in dict.fromkeys(r["physics"] for r in records):
        if physics == "lumped":
            continue
        for period in dict.fromkeys(r["period"] for r in records):
            counts = [
                r["results"][ours]["n_centers"]
                for r in records
                if (r["physics"], r["period"]) == (physics, period) and ours in r["results"]
            ]
            if not counts:
                continue
            in_use = sum(count > 0 for count in counts)
            checks.append(
                {
                    "target": f"RBFNet uses Gaussian units in most folds: {physics}, "
                    f"{period:g} s ({in_use} of {len(counts)} folds)",
                    "value": in_use / len(counts),
                    "pass": bool(in_use > len(counts) / 2),
                }
            )
    return checks


def comparisons(summary, default_features):
    """RBFNet against every other model on the default feature set, per campaign.

    The score is the pooled thermal residual mean((predicted - true drift)²) / floor, which
    is non-negative and free of the held-out gyro noise.
    """
    lines = []
    ours = f"{default_features}|RBFNet"
    for campaign, cell in summary.items():
        if ours not in cell:
            continue
        physics, period, seed = campaign.split("|")
        residual = cell[ours]["residual_over_floor"]
        for key, value in cell.items():
            if key == ours or not key.startswith(f"{default_features}|"):
                continue
            lines.append(
                comparison_line(
                    "RBFNet",
                    key.split("|")[1],
                    residual,
                    value["residual_over_floor"],
                    f"thermal residual/floor on '{default_features}' features, {physics}, "
                    f"{period} s, seed {seed}",
                )
            )
    return lines


def markdown(records, summary, checks, header):
    keys = list(records[0]["results"])
    sets = list(dict.fromkeys(key.split("|")[0] for key in keys))
    models = list(dict.fromkeys(key.split("|")[1] for key in keys))
    lines = [*header, ""]
    for physics in dict.fromkeys(r["physics"] for r in records):
        for period in dict.fromkeys(r["period"] for r in records):
            subset = [r for r in records if (r["physics"], r["period"]) == (physics, period)]
            if not subset:
                continue
            floors = [r["floor"] for r in subset]
            seeds = sorted({r["seed"] for r in subset})
            lines += [
                f"## {physics}, {period:g} s samples",
                "",
                f"Noise floor (mean squared gyro noise of the held-out rows), (deg/h)²: mean "
                f"{np.mean(floors):.3e}, range {min(floors):.3e}-{max(floors):.3e}; seeds "
                f"{seeds}, {len(subset)} folds.",
                "",
                "Per feature set: MSD/floor pooled over every fold and seed; the worst fold's "
                "MSD/floor; the thermal residual mean((predicted - true drift)²)/floor, pooled.",
                "",
                "| model | " + " | ".join(f"{s} MSD/floor | {s} worst | {s} resid." for s in sets),
                "|---|" + "---|---|---|" * len(sets),
            ]
            for model in models:
                cells = []
                for feature_set in sets:
                    key = f"{feature_set}|{model}"
                    worst = max(r["results"][key]["msd"] / r["floor"] for r in subset)
                    cells += [
                        f"{_pooled(subset, key):.3f}",
                        f"{worst:.3f}",
                        f"{_pooled(subset, key, 'residual'):.3f}",
                    ]
                lines.append(f"| {model} | " + " | ".join(cells) + " |")
            units = []
            for key in keys:
                if "n_centers" not in subset[0]["results"][key]:
                    continue
                counts = [r["results"][key]["n_centers"] for r in subset]
                units.append(
                    f"{key}: {sum(count > 0 for count in counts)} of {len(counts)} folds "
                    f"(median {np.median(counts):g} units)"
                )
            if units:
                lines += ["", "Folds with Gaussian units in use: " + "; ".join(units) + "."]
            lines.append("")
    lines += ["## Targets", ""]
    lines += [f"- {_check_line(check)}" for check in checks]
    judged = [check for check in checks if check.get("judged", True)]
    n_fail = sum(not check["pass"] for check in judged)
    lines += ["", f"{len(judged) - n_fail} of {len(judged)} judged targets pass."]
    return "\n".join(lines) + "\n"


def _check_line(check):
    value = check["value"]
    shown = (
        f"{value:.3f}"
        if isinstance(value, float)
        else f"state {value[0]:.3f} vs paper {value[1]:.3f}"
    )
    return verdict_line(check["pass"], f"{check['target']} ({shown})", check.get("judged", True))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI mode: small and fast")
    parser.add_argument(
        "--seeds", type=int, nargs="+", help="campaign seeds (default: the tuning seeds, 0 1 2)"
    )
    parser.add_argument("--physics", nargs="+", choices=PHYSICS, help="presets (default all)")
    parser.add_argument("--periods", type=float, nargs="+", help="sample periods, s")
    parser.add_argument("--models", nargs="+", help="model names (default all)")
    parser.add_argument(
        "--taus",
        type=float,
        nargs="+",
        default=None,
        help="time constants of the state features' T_lag<tau>s terms, s (default: "
        "ThermalFeatures' default terms and smoothing)",
    )
    parser.add_argument(
        "--state-terms",
        nargs="+",
        default=None,
        help="explicit terms of the state features (overrides --taus), e.g. T dT TdT T2 "
        "T_lag900s T_lag3600s",
    )
    parser.add_argument(
        "--smoothing",
        type=float,
        default=120.0,
        help="smoothing of dT (state features, with --taus), s",
    )
    parser.add_argument(
        "--default-features",
        default="state",
        choices=("paper", "state"),
        help="feature set of the default pipeline in target 1",
    )
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--tag", default="", help="suffix of the result file names")
    add_out_argument(parser)
    args = parser.parse_args(argv)

    quick = args.quick
    # The default run is on the seeds the default features were chosen on (the register's
    # "tuning"); --seeds 4241 4242 4243 --tag heldout judges them on its "judged" seeds.
    tuning = list(SEEDS["bench_thermal_state"]["tuning"])
    seeds = args.seeds or (tuning[:1] if quick else tuning)
    physics_list = args.physics or list(PHYSICS)
    periods = args.periods or ([120.0] if quick else [10.0, 60.0])
    models = args.models or (list(QUICK_MODELS) if quick else list(regressors(0)))
    unknown = sorted(set(models) - set(regressors(0, tail_alphas=swept_tail_alphas(models))))
    if unknown:
        parser.error(f"unknown model(s) {unknown}; choose from {list(regressors(0))}")
    sizes = THERMAL_STATE_QUICK if quick else THERMAL_STATE_FULL
    command = command_line(__file__, argv)
    started = time.perf_counter()
    records = run(
        seeds,
        physics_list,
        periods,
        sizes,
        models,
        (args.taus, args.smoothing, args.state_terms),
        args.n_jobs,
        QUICK_FOLDS if quick else None,
    )
    records.sort(key=lambda r: (PHYSICS.index(r["physics"]), r["period"], r["seed"], r["fold"]))
    summary, checks = summarize(records, args.default_features)
    real = real_recording(
        models,
        axes=REAL_AXES[:1] if quick else REAL_AXES,
        parities=(0,) if quick else (0, 1),
        step=_cases.REAL_QUICK_STEP if quick else 1,
    )
    checks += real_checks(real)
    if quick:
        # Target 1's floor ratios hold a calibration of three runs per azimuth; one run per
        # azimuth and one fold cannot be judged against them (INFO). Targets 2, 4 and 5 stay
        # judged: a broken default (or feature set) fails them at any size.
        for check in checks:
            if check.get("kind") == "floor":
                check["judged"] = False
    elapsed = time.perf_counter() - started
    explicit = args.taus is not None or args.state_terms is not None
    state = feature_sets(args.taus, args.smoothing, args.state_terms)["state"]().fit(
        thermal_state_campaign(0, "lumped", 60.0, THERMAL_STATE_QUICK).data
    )
    # The resolved terms and smoothing (fitted attributes when the parameters say "auto").
    terms = list(getattr(state, "terms_", state.terms))
    smoothing = getattr(state, "smoothing_", state.smoothing)
    state_text = (
        "ThermalFeatures(time='time', run='run'"
        + (", " if explicit else ") with its default ")
        + f"terms={terms}, smoothing={smoothing:g}"
        + (")" if explicit else "")
    )
    header = [
        "# Thermal state: paper features against thermal-state features",
        "",
        f"Command: `{command}` ({elapsed:.0f} s, n_jobs={args.n_jobs}).",
        "",
        f"Campaigns: make_thermal_campaign(n_units={sizes['n_units']}, "
        f"n_runs={sizes['n_runs']}, azimuths={list(sizes['azimuths'])}, profile='mix', "
        f"physics=..., sampling_period=..., random_state=seed), leave one azimuth out within "
        f"each unit. Feature sets: paper = ThermalFeatures(time='time', run='run', "
        f"terms=('T', 'dT', 'TdT')); state = {state_text}. Each "
        f"pipeline: features -> StandardScaler -> model; KernelRidge on a random 600-row and "
        f"the MLPs on a random 3000-row subsample of each training fold (SubsampledRegressor). "
        f"Default pipeline in the targets: "
        f"RBFNetRegressor() on '{args.default_features}'.",
    ]
    lines = comparisons(summary, args.default_features)
    text = markdown(records, summary, checks, header) + "\n" + real_markdown(real)
    text += (
        "\n## Against every model of the table\n\n"
        "RBFNet on the default features against each other model on the same features, per "
        "campaign, on the pooled thermal residual mean((predicted - true drift)²)/floor (lower "
        "is better; the gyro noise is not in it).\n\n" + "".join(f"- {line}\n" for line in lines)
    )
    stem = "thermal_state" + ("_quick" if quick else "") + (f"_{args.tag}" if args.tag else "")
    payload = {
        "sizes": {
            key: list(value) if isinstance(value, tuple) else value for key, value in sizes.items()
        },
        "taus": args.taus,
        "state_terms": args.state_terms,
        "smoothing": args.smoothing,
        "default_features": args.default_features,
        "summary": summary,
        "real_recording": real,
        "checks": checks,
        "comparisons": lines,
        "folds": records,
    }
    verdicts = [_check_line(check) for check in checks] + lines
    publish(
        args.out,
        stem,
        text,
        payload,
        script=__file__,
        command=command,
        seconds=elapsed,
        verdicts=verdicts,
    )
    return exit_code(check["pass"] for check in checks if check.get("judged", True))


if __name__ == "__main__":
    sys.exit(main())
