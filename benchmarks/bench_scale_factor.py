"""Scale factor over temperature: what the default leaves of a gyro's scale-factor error.

Run (about 5-10 minutes on two shared cores; ``--quick`` for CI, well under a minute)::

    python benchmarks/bench_scale_factor.py --n-jobs 2

The judged run (issue 44, once at its end) is on the register's judged seeds::

    python benchmarks/bench_scale_factor.py --seeds 4451 4452 4453 --tag judged --n-jobs 2

For every scale-factor preset of the rate-table simulator ("coil", "coil_source",
"asymmetric": ``make_rate_table_campaign``, a lot of 3 units of 3 runs,
``_cases.rate_table_campaign``) and seed, the rows are held out two ways: **by run** (each
run of each unit in turn, the model fitted on that unit's other runs) and **by unit** (each
unit in turn, the model fitted on the other units). Every model is fitted on the same rows:

- ``default``: ``make_compensation_pipeline(input_rate="reference")``, the package's
  default (RBF network, default features) learning ``b(x) + Ω s(x) + a|Ω|``;
- ``linear``: the same pipeline with a linear regressor on the same features,
  ``make_compensation_pipeline(LinearRegression(), input_rate="reference")`` (a peer
  reported by WIN/TIE/LOSS lines, not a target: added after the judged run of issue 44,
  whose file has no such column);
- ``no scale factor``: ``make_compensation_pipeline()`` (the bias alone) fitted on the
  zero-rate rows: the scale-factor error left uncompensated, and the bias-only model the
  bias at zero input is compared with;
- ``constant``, ``line in T``, ``cubic in T``: the firmware practice, a scale factor that
  is a polynomial of that degree in the coil sensor's temperature, beside a bias linear in
  the default thermal features and a constant asymmetry ``|Ω|``, all by one least-squares
  fit (:class:`FirmwareScaleFactor`).

Metrics on the held-out rows (pooled per preset and split: the mean over folds and seeds):

- **SF p-p**: the residual scale-factor error's peak-to-peak over temperature, ppm: per
  held-out run and 5 degC bin of the coil sensor, the least-squares slope of the residual
  ``y - prediction`` on the input rate (:func:`sklearn_ifog.metrics.scale_factor_error`),
  its peak-to-peak over the bins of the run, the largest over the held-out runs;
- **bias at 0**: the MSD of the residual on the held-out zero-rate rows, deg²/h²;
- **residual by rate**: the RMS residual at each table rate, deg/h (a table);
- **lot floor** (held out by unit): the SF p-p of the held-out unit's true scale factor
  minus the training units' mean true one at the same states and input rates (the
  simulator's truth): the units of a lot differ (``lot_spread``), and no model fitted on the
  other units can go below it.

Targets (exit 1 when one fails), per preset and split:

1. the default's SF p-p <= 0.1 x the uncompensated one's (``no scale factor``);
2. the default's SF p-p <= 0.5 x the cubic in T's;
3. the default's bias at zero input <= 1.02 x the bias-only model's;
4. a lot of 100 units (``_cases.rate_table_lot``, 2 runs each) fitted by
   ``UnitwiseRegressor(make_compensation_pipeline(input_rate="reference"),
   pooling="none")`` in at most 5 minutes (``--n-jobs`` processes).

``--quick`` (CI): seed 0, 2 units of 2 runs at one sample a minute, a lot of 3 units;
target 1 held out by run is judged (a broken scale factor fails it at any size); held out
by unit (one unit to learn from) and targets 2-4 print as ``INFO``.
That the static campaigns are unchanged is shown by ``benchmarks/check_unchanged.py``
(every quantity of the package against the commit before issue 44), not here. Writes
``benchmarks/results/scale_factor[_quick|_<tag>].md`` and ``.json`` (``--out DIR``
elsewhere).
"""

import argparse
import sys
import time
import warnings

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.linear_model import LinearRegression

from sklearn_ifog import ThermalFeatures, UnitwiseRegressor, make_compensation_pipeline
from sklearn_ifog.datasets._rate_table import scale_factor_terms
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.metrics import scale_factor_error

from _cases import SEEDS, rate_table_campaign, rate_table_lot  # isort: skip
from _results import add_out_argument, command_line, publish  # isort: skip
from _verdict import comparison_line, exit_code, verdict_line  # isort: skip

PRESETS = ("coil", "coil_source", "asymmetric")
SPLITS = ("runs", "units")
MODELS = ("default", "linear", "no scale factor", "constant", "line in T", "cubic in T")
FIRMWARE_DEGREES = {"constant": 0, "line in T": 1, "cubic in T": 3}
BIN_WIDTH = 5.0  # degC
UNCOMPENSATED_RATIO = 0.1
CUBIC_RATIO = 0.5
BIAS_RATIO = 1.02
LOT_UNITS, LOT_SECONDS = 100, 300.0
QUICK_LOT_UNITS = 3


class FirmwareScaleFactor(RegressorMixin, BaseEstimator):
    """The firmware practice: a scale factor polynomial in the coil temperature.

    ``y = F(x) w + c + Ω Σ_k s_k T^k + a |Ω|`` by ordinary least squares: ``F`` the default
    thermal features (standardised), ``T`` the coil sensor's temperature (centred on 15 degC,
    in units of 50 degC, for conditioning), ``Ω`` the column ``input_rate``.
    """

    def __init__(self, degree=3, input_rate="reference", temperature="temperature"):
        self.degree = degree
        self.input_rate = input_rate
        self.temperature = temperature

    def _design(self, X):
        features = (self.features_.transform(X) - self.mean_) / self.scale_
        omega = X[self.input_rate].to_numpy(dtype=float)
        T = (X[self.temperature].to_numpy(dtype=float) - 15.0) / 50.0
        powers = [omega * T**k for k in range(self.degree + 1)]
        return np.column_stack([features, np.ones_like(T), *powers, np.abs(omega)])

    def fit(self, X, y):
        self.features_ = ThermalFeatures().fit(X)
        raw = self.features_.transform(X)
        self.mean_, self.scale_ = raw.mean(axis=0), raw.std(axis=0)
        self.scale_[self.scale_ == 0] = 1.0
        self.model_ = LinearRegression(fit_intercept=False).fit(self._design(X), y)
        return self

    def predict(self, X):
        return self.model_.predict(self._design(X))


def make_model(name):
    """A fresh, unfitted model of the table."""
    if name == "default":
        return make_compensation_pipeline(input_rate="reference")
    if name == "linear":
        return make_compensation_pipeline(LinearRegression(), input_rate="reference")
    if name == "no scale factor":
        return make_compensation_pipeline()
    return FirmwareScaleFactor(degree=FIRMWARE_DEGREES[name])


def peak_to_peak(frame, residual):
    """The residual scale-factor error's peak-to-peak over temperature, ppm: per run, over
    its 5 degC bins of the coil sensor (:func:`~sklearn_ifog.metrics.scale_factor_error`),
    the largest over the runs."""
    temperature = frame["temperature"].to_numpy()
    edges = np.arange(
        np.floor(temperature.min() / BIN_WIDTH) * BIN_WIDTH,
        temperature.max() + BIN_WIDTH,
        BIN_WIDTH,
    )
    table = scale_factor_error(
        frame["reference"].to_numpy(),
        residual,
        temperature,
        run=frame["run"].to_numpy(),
        bins=edges,
    )
    per_run = table[table["run"] != "(all runs)"]
    spans = per_run.groupby("run")["ppm"].agg(lambda ppm: np.nanmax(ppm) - np.nanmin(ppm))
    return float(spans.max())


def folds(frame, split):
    """``(train, test)`` boolean masks of one split: each run of each unit held out within
    its unit, or each unit held out."""
    units, runs = frame["unit"].to_numpy(), frame["run"].to_numpy()
    if split == "units":
        for unit in np.unique(units):
            yield units != unit, units == unit
        return
    for unit in np.unique(units):
        for run in np.unique(runs[units == unit]):
            yield (units == unit) & (runs != run), runs == run


def run_fold(frame, X, y, train, test):
    """Every model fitted on ``train`` and measured on ``test``: SF p-p, bias at 0, and the
    RMS residual per table rate."""
    zero = frame["table_rate"].to_numpy() == 0.0
    rates = frame["table_rate"].to_numpy()
    found = {}
    for name in MODELS:
        model = make_model(name)
        rows = train & zero if name == "no scale factor" else train
        started = time.perf_counter()
        with warnings.catch_warnings():
            # a held-out run or unit may reach past the calibration: the domain says so,
            # and the default's answer there is part of what is measured
            warnings.simplefilter("ignore", OutsideCalibrationWarning)
            model.fit(X[rows], y[rows])
            fit_seconds = time.perf_counter() - started
            predicted = model.predict(X[test])
        residual = y[test] - predicted
        test_zero = zero[test]
        found[name] = {
            "sf_pp": peak_to_peak(frame[test], residual),
            "bias_msd": float(np.mean(residual[test_zero] ** 2)),
            "by_rate": {
                float(rate): float(np.sqrt(np.mean(residual[rates[test] == rate] ** 2)))
                for rate in np.unique(rates[test])
            },
            "fit_seconds": fit_seconds,
        }
    return found


def lot_floor(bunch, train, test):
    """The SF p-p no model fitted on the training units can go below on the held-out one:
    the held-out unit's true scale factor minus the training units' mean true scale factor
    at the same states and input rates (the simulator's truth), as a residual."""
    frame, parts = bunch.frame, bunch.components
    states = (
        parts["coil_mean"].to_numpy()[test],
        parts["coil_gradient"].to_numpy()[test],
        parts["source_temp_true"].to_numpy()[test],
        frame["reference"].to_numpy()[test],
    )
    units = np.unique(frame["unit"].to_numpy()[train])
    lot = np.mean(
        [sum(scale_factor_terms(bunch.unit_params[unit], *states).values()) for unit in units],
        axis=0,
    )
    truth = frame["scale_factor_error"].to_numpy()[test]
    return peak_to_peak(frame[test], states[3] * (truth - lot) * 1e-6)


def run_case(preset, seed, split, quick):
    """All folds of one (preset, seed, split)."""
    bunch = rate_table_campaign(preset, seed, quick)
    frame, X, y = bunch.frame, bunch.data, bunch.target.to_numpy()
    return [
        {
            "preset": preset,
            "seed": seed,
            "split": split,
            "fold": index,
            "models": run_fold(frame, X, y, train, test),
            "lot_floor": lot_floor(bunch, train, test) if split == "units" else None,
        }
        for index, (train, test) in enumerate(folds(frame, split))
    ]


def summarise(rows):
    """Per (preset, split) and model: the mean over folds and seeds of each metric."""
    summary = {}
    for preset in PRESETS:
        for split in SPLITS:
            cell = [row for row in rows if row["preset"] == preset and row["split"] == split]
            if not cell:
                continue
            entry = {}
            for name in MODELS:
                found = [row["models"][name] for row in cell]
                rates = sorted(found[0]["by_rate"])
                entry[name] = {
                    "sf_pp": float(np.mean([one["sf_pp"] for one in found])),
                    "bias_msd": float(np.mean([one["bias_msd"] for one in found])),
                    "by_rate": {
                        rate: float(np.mean([one["by_rate"][rate] for one in found]))
                        for rate in rates
                    },
                    "fit_seconds": float(np.mean([one["fit_seconds"] for one in found])),
                }
            floors = [row["lot_floor"] for row in cell if row["lot_floor"] is not None]
            summary[(preset, split)] = {
                "n_folds": len(cell),
                "models": entry,
                "lot_floor": float(np.mean(floors)) if floors else None,
            }
    return summary


def time_lot(n_units, seed, n_jobs):
    """Seconds to fit a lot of ``n_units`` with one scale-factor model per unit."""
    X, y = rate_table_lot(n_units, seed)
    model = UnitwiseRegressor(
        make_compensation_pipeline(input_rate="reference"), pooling="none", n_jobs=n_jobs
    )
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        model.fit(X, y)
    return time.perf_counter() - started, len(X)


def checks_of(summary, lot, quick):
    """The target lines and the comparison lines."""
    verdicts, passed = [], []
    for (preset, split), cell in summary.items():
        models = cell["models"]
        ours = models["default"]
        where = f"{preset}, held out by {split[:-1]}"
        for target, peer, ratio, judged in (
            (1, "no scale factor", UNCOMPENSATED_RATIO, not quick or split == "runs"),
            (2, "cubic in T", CUBIC_RATIO, not quick),
        ):
            theirs = models[peer]["sf_pp"]
            ok = ours["sf_pp"] <= ratio * theirs
            if judged:
                passed.append(ok)
            floor = cell["lot_floor"]
            note = "" if floor is None else f"; the lot floor is {floor:.3g} ppm"
            verdicts.append(
                verdict_line(
                    ok,
                    f"target {target}, {where}: the default's SF p-p {ours['sf_pp']:.3g} ppm "
                    f"<= {ratio} x {peer}'s {theirs:.4g} ppm (ratio {ours['sf_pp'] / theirs:.3f})"
                    + note,
                    judged,
                )
            )
        theirs = models["no scale factor"]["bias_msd"]
        ok = ours["bias_msd"] <= BIAS_RATIO * theirs
        if not quick:
            passed.append(ok)
        verdicts.append(
            verdict_line(
                ok,
                f"target 3, {where}: the default's bias at zero input, MSD "
                f"{ours['bias_msd']:.4g} <= {BIAS_RATIO} x the bias-only model's "
                f"{theirs:.4g} (ratio {ours['bias_msd'] / theirs:.3f})",
                not quick,
            )
        )
        for peer in MODELS[1:]:
            verdicts.append(
                comparison_line(
                    "default", peer, ours["sf_pp"], models[peer]["sf_pp"], f"SF p-p, {where}"
                )
            )
    seconds, units = lot["seconds"], lot["units"]
    ok = seconds <= LOT_SECONDS
    if not quick:
        passed.append(ok)
    verdicts.append(
        verdict_line(
            ok,
            f"target 4: a lot of {units} units ({lot['rows']} rows) fitted in {seconds:.1f} s "
            f"<= {LOT_SECONDS:.0f} s",
            not quick,
        )
    )
    return verdicts, passed


def markdown(summary, lot, command, seeds, elapsed, verdicts):
    lines = [
        "# Scale factor over temperature (issue 44)",
        "",
        f"Command: `{command}` ({elapsed:.0f} s).",
        "",
        f"Seeds {', '.join(map(str, seeds))}; rate-table lots of `_cases.rate_table_campaign`. "
        "SF p-p: the residual scale-factor error's peak-to-peak over 5 degC bins of the coil "
        "sensor, per held-out run (the largest over them), ppm; bias at 0: the MSD on the "
        "held-out zero-rate rows, deg²/h²; both the mean over folds and seeds. Lot floor "
        "(held out by unit): the SF p-p of the held-out unit's true scale factor minus the "
        "training units' mean true scale factor at the same states, what no model fitted "
        "on the other units can go below.",
        "",
        "## SF p-p (ppm) and bias at zero input",
        "",
        "| preset | held out by | folds | "
        + " | ".join(f"{name} SF p-p" for name in MODELS)
        + " | lot floor SF p-p | default bias at 0 | bias-only bias at 0 |",
        "|" + "---|" * (len(MODELS) + 6),
    ]
    for (preset, split), cell in summary.items():
        models = cell["models"]
        lines.append(
            f"| {preset} | {split[:-1]} | {cell['n_folds']} | "
            + " | ".join(f"{models[name]['sf_pp']:.4g}" for name in MODELS)
            + (" | -" if cell["lot_floor"] is None else f" | {cell['lot_floor']:.4g}")
            + f" | {models['default']['bias_msd']:.4g} | "
            f"{models['no scale factor']['bias_msd']:.4g} |"
        )
    lines += ["", "## Residual by table rate (RMS, deg/h), held out by run", ""]
    for (preset, split), cell in summary.items():
        if split != "runs":
            continue
        rates = sorted(cell["models"]["default"]["by_rate"])
        lines += [
            f"Preset {preset}:",
            "",
            "| model | " + " | ".join(f"{rate:g} deg/s" for rate in rates) + " |",
            "|" + "---|" * (len(rates) + 1),
        ]
        for name in MODELS:
            by_rate = cell["models"][name]["by_rate"]
            lines.append(
                f"| {name} | " + " | ".join(f"{by_rate[rate]:.3g}" for rate in rates) + " |"
            )
        lines.append("")
    lines += [
        "## A lot",
        "",
        f"{lot['units']} units, {lot['rows']} rows: `UnitwiseRegressor(pooling='none')` of the "
        f"default scale-factor pipeline fitted in {lot['seconds']:.1f} s "
        f"({lot['n_jobs']} processes).",
        "",
        "## Verdicts",
        "",
        *(f"- {line}" for line in verdicts),
        "",
    ]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="seed 0, small lots (CI)")
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=None,
        help="seeds (default: the register's tuning seeds "
        f"{list(SEEDS['bench_scale_factor']['tuning'])})",
    )
    parser.add_argument("--tag", default=None, help="results file suffix")
    parser.add_argument("--n-jobs", type=int, default=1, help="parallel processes")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    register = SEEDS["bench_scale_factor"]
    seeds = [register["tuning"][0]] if args.quick else (args.seeds or list(register["tuning"]))
    command = command_line(__file__, argv)
    start = time.perf_counter()
    cases = [(p, s, split) for p in PRESETS for s in seeds for split in SPLITS]
    found = Parallel(n_jobs=args.n_jobs)(
        delayed(run_case)(preset, seed, split, args.quick) for preset, seed, split in cases
    )
    rows = [row for part in found for row in part]
    summary = summarise(rows)
    units = QUICK_LOT_UNITS if args.quick else LOT_UNITS
    seconds, n_rows = time_lot(units, seeds[0], args.n_jobs)
    lot = {"units": units, "rows": n_rows, "seconds": seconds, "n_jobs": args.n_jobs}
    verdicts, passed = checks_of(summary, lot, args.quick)
    elapsed = time.perf_counter() - start
    stem = "scale_factor" + ("_quick" if args.quick else "") + (f"_{args.tag}" if args.tag else "")
    results = {
        "seeds": seeds,
        "summary": [
            {"preset": preset, "split": split, **cell} for (preset, split), cell in summary.items()
        ],
        "folds": rows,
        "lot": lot,
    }
    publish(
        args.out,
        stem,
        markdown(summary, lot, command, seeds, elapsed, verdicts),
        results,
        script=__file__,
        command=command,
        seconds=elapsed,
        verdicts=verdicts,
    )
    return exit_code(passed)


if __name__ == "__main__":
    sys.exit(main())
