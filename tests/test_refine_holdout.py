"""Refinement at the estimator level: on held-out runs, never worse than the OLS network.

Each refine mode ("varpro", "lm", "gd") is fitted on small simulated campaigns (one unit,
azimuths 0°, 90°, 180°, two runs each, 60 s samples; lumped and layered physics, campaign
seeds 0-4) on the runs at 0° and 180° and scored on the runs at 90°, against the same
pipeline with ``refine=None`` and the same seed. The network has a fixed number of Gaussian
units (``n_centers=10, criterion=None``): the default selection often keeps none on these
data, and then there is nothing to refine.

"Never worse" allows the tie margin the benchmarks use (``TIE_MARGIN``, 2%: the issue's
"no worse than 1.02x"): the refinement's early stopping guards the error on held-out blocks
of the *training* runs, the final weights are re-solved on all training rows, and a held-out
azimuth is a different recording, so an exact "<=" on it is not implied by the algorithm;
a loss beyond the margin is a refinement that generalises worse than the network it
started from, which is what these tests catch. The held-out MSD includes the gyro noise,
which every model pays alike, so the margin is relative to a common floor, as in the
benchmarks' verdicts.

Each mode is checked twice: with the network's default held-out rows (contiguous blocks of
the training rows) and with the training runs passed as ``groups`` (whole runs held out, for
the early stopping and for the guard that keeps a refinement only when it beats the OLS
network there by more than one standard error).

The refined fits that lose beyond the margin are listed in ``KNOWN_LOSSES`` with their ratios,
as ``python benchmarks/rbf_run_folds_check.py`` measures them (its "Refinement on held-out
runs" table, the same cases; issue 12): those cases may lose, by at most 5 % more than the
measured ratio (a regression beyond that fails), and every other case must stay within the
margin. (They were strict xfails until layered seed 4's 1.029, 0.9 % past the margin, came
out within it on another machine's floating point: a case that close to the margin cannot
be a strict expectation either way.)
"""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline

# The cases are the ones benchmarks/rbf_run_folds_check.py measures (KNOWN_LOSSES quotes it).
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from rbf_run_folds_check import refine_split

sys.path.pop(0)

TIE_MARGIN = 0.02
MODES = ("varpro", "lm", "gd")
CASES = [(physics, seed) for physics in ("lumped", "layered") for seed in range(5)]
N_CENTERS = 10
# Held-out MSD refined / OLS measured at 3688b23 (n_centers=10, criterion=None); the current
# results (benchmarks/results/rbf_run_folds.md) are at or below these.
SPLITS = ("row blocks", "run groups")
KNOWN_LOSSES = {
    ("varpro", "row blocks"): {("lumped", 3): 2.716, ("lumped", 4): 1.522},
    ("lm", "row blocks"): {("layered", 2): 1.089, ("layered", 4): 1.031},
    ("varpro", "run groups"): {("layered", 4): 1.029},
}
KNOWN_LOSS_SLACK = 1.05  # a known loss may come out up to 5 % worse than measured
# The tail is free here, as when the known losses were measured: these tests judge the
# refinement of the Gaussian units. With the default penalised tail (held at its selected
# weights while the units move) the same cases were measured once at this end
# (issue 41): layered seed 2 with run groups then loses 7.7 % (varpro) and 9.0 % (lm), and
# varpro with row blocks keeps its refinement in 1 of 10 cases; left open in the note.
TAIL_ALPHA = 0.0


def _fit(refine, seed, X, y, split="row blocks"):
    network = RBFNetRegressor(
        refine=refine,
        n_centers=N_CENTERS,
        criterion=None,
        tail_alpha=TAIL_ALPHA,
        random_state=seed,
    )
    params = {"regressor__groups": X["run"].to_numpy()} if split == "run groups" else {}
    with warnings.catch_warnings():
        # A refinement stopped by max_iter warns; the held-out error is what is judged.
        warnings.simplefilter("ignore", ConvergenceWarning)
        return make_compensation_pipeline(network).fit(X, y, **params)


@pytest.fixture(scope="module")
def fits():
    """Per split and case: the data, the OLS pipeline's held-out MSD, network, predictions."""
    out = {split: {} for split in SPLITS}
    for physics, seed in CASES:
        X_train, y_train, X_test, y_test = refine_split(physics, seed)
        for split in SPLITS:
            ols = _fit(None, seed, X_train, y_train, split)
            predicted = ols.predict(X_test)
            out[split][physics, seed] = {
                "data": (X_train, y_train, X_test, y_test),
                "ols": ols[-1],
                "ols_predicted": predicted,
                "ols_msd": float(np.mean(np.square(y_test - predicted))),
            }
    return out


@pytest.fixture(scope="module")
def refined(fits):
    """Per (mode, split, case): held-out MSD ratio to OLS, the network, its predictions."""
    cache = {}

    def get(mode, split):
        if (mode, split) not in cache:
            rows = {}
            for (physics, seed), base in fits[split].items():
                X_train, y_train, X_test, y_test = base["data"]
                model = _fit(mode, seed, X_train, y_train, split)
                predicted = model.predict(X_test)
                msd = float(np.mean(np.square(y_test - predicted)))
                rows[physics, seed] = {
                    "ratio": msd / base["ols_msd"],
                    "network": model[-1],
                    "predicted": predicted,
                }
            cache[mode, split] = rows
        return cache[mode, split]

    return get


@pytest.mark.parametrize("split", SPLITS)
@pytest.mark.parametrize("mode", MODES)
def test_refined_network_never_worse_than_ols_on_held_out_runs(refined, mode, split):
    known = KNOWN_LOSSES.get((mode, split), {})
    ratios = {case: row["ratio"] for case, row in refined(mode, split).items()}
    bounds = {case: known.get(case, 1.0 + TIE_MARGIN) for case in ratios}
    bounds = {
        case: bound * KNOWN_LOSS_SLACK if case in known else bound
        for case, bound in bounds.items()
    }
    losses = {case: round(r, 4) for case, r in ratios.items() if r > bounds[case]}
    assert not losses, (
        f"refine={mode!r} ({split}) worse than OLS beyond its bound (the {TIE_MARGIN:.0%} "
        f"margin, or a known loss ({known}) x {KNOWN_LOSS_SLACK}): {losses}"
    )


@pytest.mark.parametrize("split", SPLITS)
@pytest.mark.parametrize("mode", MODES)
def test_refinement_runs_and_is_kept_in_some_cases(fits, refined, mode, split):
    rows = refined(mode, split)
    kept = [case for case, row in rows.items() if row["network"].selection_path_["refined"]]
    # A mode that always falls back to the OLS network would be caught here: on these
    # campaigns every mode keeps its refinement in 2 to 8 of the 10 cases with either
    # split (python benchmarks/rbf_run_folds_check.py, the cases marked "+").
    assert len(kept) >= 2, f"refine={mode!r} kept its refinement in {len(kept)} of {len(rows)}"
    for case, row in rows.items():
        network, ols = row["network"], fits[split][case]["ols"]
        assert network.n_iter_ > 0
        assert ols.n_iter_ == 0
        moved = not (
            np.array_equal(network.centers_, ols.centers_)
            and np.array_equal(network.widths_, ols.widths_)
        )
        if case in kept:
            # Kept: the refined parameters are not the OLS ones.
            assert moved, f"{case}: refined=True but centres and widths are the OLS ones"
        else:
            # Discarded: the model is the OLS network, weights re-solved alike.
            np.testing.assert_allclose(network.centers_, ols.centers_, rtol=0, atol=0)
            np.testing.assert_allclose(
                row["predicted"], fits[split][case]["ols_predicted"], rtol=1e-9, atol=1e-12
            )
