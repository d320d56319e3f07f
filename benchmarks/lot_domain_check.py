"""A lot calibrated on one run per unit: partial pooling around the default pipeline or a bare one.

Run (a few minutes)::

    python benchmarks/lot_domain_check.py --jobs 2

``--quick`` (CI): one seed, lumped physics. Writes ``benchmarks/results/lot_domain[_quick].md``
and ``.json`` (``--out DIR`` elsewhere).

Issue 41 measured that ``UnitwiseRegressor(pooling="partial")`` around the README's entry
point (``make_compensation_pipeline``: features, scaler, network, the calibration domain
and its fallback) can leave several times the MSD of the same lot around a bare
``ThermalFeatures -> StandardScaler -> RBFNetRegressor`` on smooth physics (the domain
flagging rows the network had right), while on the glass transition the domain helps. Its
target: the default at most 1.2 x the bare pipeline on smooth physics, no worse than before
on the glass transition. This script measures both on ``bench_unitwise``'s "similar" lot
(six units, six runs each, the last two tested), every unit calibrated on its first run,
for the network with its default tail penalty and with a free tail (``tail_alpha=0``, the
default before issue 41). Tuning seeds only (``SEEDS["lot_domain_check"]``, bench_unitwise's
tuning lots): an investigation, not a verdict; the judged lot is ``bench_unitwise.py``'s.

A second table says where partial pooling's result comes from, around the bare pipeline:
the same lot with ``pooling="none"`` (every unit its own model) and ``"full"`` (the lot's
model), the strength ``lam`` the single-run units share, ``n lam`` against the far-unit limit
``1 / OWN_MODEL_SPREAD²`` (at or below it every unit keeps its own model), and the units that
kept their own models.
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import (
    RBFNetRegressor,
    ThermalFeatures,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog._shrinkage import pick_strength
from sklearn_ifog.unitwise import OWN_MODEL_SPREAD

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _cases import SEEDS, UNITWISE_N_TEST, UNITWISE_N_UNITS, unitwise_lot
from _results import add_out_argument, command_line, publish

TAILS = {"default tail penalty": {}, "free tail": {"tail_alpha": 0.0}}


def pipelines(seed, tail):
    """The two pipelines around which the lot is pooled, with the network's ``tail``."""
    network = RBFNetRegressor(random_state=seed, **TAILS[tail])
    bare = Pipeline(
        [
            ("features", ThermalFeatures(time="time", run="run")),
            ("scale", StandardScaler()),
            ("regressor", network),
        ]
    )
    return {"default pipeline": make_compensation_pipeline(network), "bare pipeline": bare}


def case(physics, seed, tail):
    """Test MSD of partial pooling around each pipeline, calibrated on one run per unit."""
    campaign = unitwise_lot(physics, "similar", seed)
    frame, X, y = campaign.frame, campaign.data, campaign.target.to_numpy()
    runs = {u: sorted(frame.loc[frame.unit == u, "run"].unique()) for u in range(UNITWISE_N_UNITS)}
    test = frame["run"].isin([r for u in runs for r in runs[u][-UNITWISE_N_TEST:]]).to_numpy()
    train = frame["run"].isin([runs[u][0] for u in runs]).to_numpy()
    record = {"physics": physics, "seed": seed, "tail": tail}
    for name, pipeline in pipelines(seed, tail).items():
        model, record[name] = _pooled(pipeline, "partial", X, y, train, test)
        if name == "bare pipeline":
            # the strength the single-run units share (shrinkage_ is None for a unit that
            # then kept its own model): the largest evidence of their summed log-evidences
            single = [u for u, folds in model.n_folds_.items() if folds == 0]
            total = sum(model.shrinkage_evidence_[u] for u in single)
            record["shared strength"] = pick_strength(-total, model.shrinkage_grid_)
            record["rows per unit"] = int(train.sum()) / UNITWISE_N_UNITS
            record["own models"] = sum(s is None for s in model.shrinkage_.values())
    bare = pipelines(seed, tail)["bare pipeline"]
    for pooling in ("none", "full"):
        record[f"bare, {pooling}"] = _pooled(bare, pooling, X, y, train, test)[1]
    return record


def _pooled(pipeline, pooling, X, y, train, test):
    """``UnitwiseRegressor(pipeline, pooling)`` fitted on the ``train`` rows: the model and
    its test MSD."""
    model = UnitwiseRegressor(pipeline, pooling=pooling)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(X[train], y[train])
        prediction = np.asarray(model.predict(X[test]), dtype=np.float64)
    return model, float(np.mean(np.square(y[test] - prediction)))


def markdown(records, command, seconds):
    out = [
        "# A lot calibrated on one run per unit: partial pooling around the default pipeline",
        "",
        f"Command: `{command}` ({seconds:.0f} s). Test MSD, (deg/h)², of "
        "`UnitwiseRegressor(pooling='partial')` around `make_compensation_pipeline` (the "
        "default) and around a bare features -> scaler -> network pipeline, on the 'similar' "
        "lot of bench_unitwise, every unit calibrated on its first run; the ratio is the "
        "default's over the bare one's.",
        "",
        "| physics | seed | tail | default pipeline | bare pipeline | ratio |",
        "|---|---|---|---|---|---|",
    ]
    for r in records:
        ratio = r["default pipeline"] / r["bare pipeline"]
        out.append(
            f"| {r['physics']} | {r['seed']} | {r['tail']} | {r['default pipeline']:.4g} | "
            f"{r['bare pipeline']:.4g} | {ratio:.3f} |"
        )
    limit = OWN_MODEL_SPREAD**-2
    out += [
        "",
        "Where partial pooling's result comes from, around the bare pipeline: test MSD of "
        "every unit its own model (`none`), of the lot's model (`full`) and of `partial`; the "
        "strength lam the single-run units share, n lam (n: the mean calibration rows per "
        "unit; the rule reads each unit's own) against the "
        f"far-unit limit 1 / OWN_MODEL_SPREAD² = {limit:.3f}, and the units (of "
        f"{UNITWISE_N_UNITS}) that kept their own models.",
        "",
        "| physics | seed | tail | none | full | partial | lam | n lam | own models |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in records:
        lam = r["shared strength"]
        n_lam = f"{lam * r['rows per unit']:.3f}"
        out.append(
            f"| {r['physics']} | {r['seed']} | {r['tail']} | {r['bare, none']:.4g} | "
            f"{r['bare, full']:.4g} | {r['bare pipeline']:.4g} | "
            f"{lam:.3g} | {n_lam} | {r['own models']} |"
        )
    return "\n".join(out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI mode: one seed, lumped")
    parser.add_argument("--jobs", type=int, default=1, help="parallel processes")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    register = SEEDS["lot_domain_check"]
    seeds = register["tuning"][:1] if args.quick else register["tuning"]
    physics = register["physics"][:1] if args.quick else register["physics"]
    started = time.perf_counter()
    jobs = [(p, s, t) for p in physics for s in seeds for t in TAILS]
    records = Parallel(n_jobs=args.jobs)(delayed(case)(*job) for job in jobs)
    seconds = time.perf_counter() - started
    command = command_line(__file__, argv)
    publish(
        args.out,
        "lot_domain" + ("_quick" if args.quick else ""),
        markdown(records, command, seconds),
        records,
        script=__file__,
        command=command,
        seconds=seconds,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
