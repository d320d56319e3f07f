r"""The reference paper's Tables 2-4 on small simulated campaigns.

The campaign: the simulator's default size (3 units, 5 runs per (unit, azimuth), azimuths
0/45/90/135, 60 s samples, about 16 000 rows) on its ``"lumped"`` physics, one coil
temperature and its rate, the physics the paper's features describe (the default
``"layered"`` physics is where they fall short: see ``bench_thermal_state.py``); each unit
is trained on its five runs at 0° and tested on five runs at 90° (Table 2), 45° (Table 3)
or 135° (Table 4). The layout and arithmetic tests use campaign seed 0; every statistical
claim is asserted on several campaign seeds (``SEEDS`` for the RBF network,
``LINEAR_SEEDS`` for the cheap linear model), with a threshold that held on every one of
campaign seeds 0-7 as measured by the committed command
(the same default network and linear model as here)::

    python benchmarks/paper_claim_check.py --seeds 8 --regressors 'RBF default' \
        'linear thermal model' --noise-only --physics lumped --tag default

(results in ``benchmarks/results/paper_claim_default.md``; "over seeds 0-7" below quotes
it):

- the modified RBF model cuts the mean MSD 33-72x against the raw output (the paper: > 10x),
  the traditional one at least 32x; the worst of the three tables is cut at least 14x, and a
  table is asserted at least 4x;
- the traditional (T, ΔT) and modified (T, ΔT, T·ΔT) RBF networks tie or either wins with the
  seed (traditional/modified mean-MSD ratio 0.96-1.32; the modified one wins most runs on 4
  of 8 seeds): a flexible network learns the T·ΔT product from (T, ΔT) by itself, so neither
  "modified beats traditional" nor a parity bound is asserted for it (with the quadratic
  tail of earlier releases the ratio went down to 0.47 on seed 3);
- for the linear thermal model (the IEEE Std 952 style least-squares model) T·ΔT does carry
  what (T, ΔT) lacks: the modified model wins 11-15 of 15 runs on every seed (ratio
  1.09-1.71, raw cut 33-70x). That is asserted;
- trained on the error set (each run's mean-removed output) the default network cuts the
  mean-removed MSD 6.45x (seed 4) to 11.1x: asserted at least 5x, the script's own target.
"""

import numpy as np
import pytest
from sklearn.dummy import DummyRegressor
from sklearn.linear_model import LinearRegression

from sklearn_ifog import ThermalFeatures
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.paper import run_paper_experiments

# Campaign seeds of the statistical claims (each a few seconds of fitting per seed).
SEEDS = (0, 1, 2)
LINEAR_SEEDS = (0, 1, 2, 3, 4)


@pytest.fixture(scope="module")
def campaign():
    return make_thermal_campaign(physics="lumped", random_state=0)


@pytest.fixture(scope="module")
def result(campaign):
    return run_paper_experiments(campaign)


@pytest.fixture(scope="module")
def error_set_result(campaign):
    return run_paper_experiments(campaign, target="error_set")


def _campaign(seed, campaign):
    if seed == 0:
        return campaign
    return make_thermal_campaign(physics="lumped", random_state=seed)


@pytest.fixture(scope="module", params=SEEDS, ids=lambda seed: f"seed{seed}")
def seeded(request, campaign):
    """(seed, runs of the default network, runs of the default network on the error set)."""
    seed = request.param
    campaign = _campaign(seed, campaign)
    if seed == 0:
        return (
            seed,
            request.getfixturevalue("result").runs,
            (request.getfixturevalue("error_set_result").runs),
        )
    return (
        seed,
        run_paper_experiments(campaign).runs,
        run_paper_experiments(campaign, target="error_set").runs,
    )


def _run_msd(frame, run, values=None):
    rows = frame[frame["run"] == run]
    error = (rows["rate"] - rows["reference"]).to_numpy()
    if values is not None:
        error = error - values
    return np.mean(error**2)


def test_tables_follow_the_paper_layout(campaign, result):
    frame = campaign.frame
    assert list(result.table2.columns) == ["run", "msd_before", "msd_after"]
    for name in ("table3", "table4"):
        assert list(result[name].columns) == ["run", "raw", "traditional", "modified"]
    for name, (unit, azimuth) in zip(
        ("table2", "table3", "table4"), [(0, 90.0), (1, 45.0), (2, 135.0)], strict=True
    ):
        table = result[name]
        assert list(table.index) == [1, 2, 3, 4, 5]
        expected_runs = frame.loc[
            (frame["unit"] == unit) & (frame["azimuth"] == azimuth), "run"
        ].unique()
        assert sorted(table["run"]) == sorted(expected_runs)
    assert len(result.runs) == 15
    assert set(result.models) == {0, 1, 2}
    modified = result.models[0]["modified"]
    traditional = result.models[0]["traditional"]
    assert tuple(modified.named_steps["features"].terms) == ("T", "dT", "TdT")
    assert tuple(traditional.named_steps["features"].terms) == ("T", "dT")


def test_msd_values_are_the_papers_eq_24(campaign, result):
    frame = campaign.frame
    for _, row in result.table2.iterrows():
        run_frame = frame[frame["run"] == row["run"]]
        drift = result.models[0]["modified"].predict(run_frame)
        assert row["msd_before"] == pytest.approx(_run_msd(frame, row["run"]), rel=1e-12)
        assert row["msd_after"] == pytest.approx(_run_msd(frame, row["run"], drift), rel=1e-9)
    row = result.table4.iloc[2]
    drift = result.models[2]["traditional"].predict(frame[frame["run"] == row["run"]])
    assert row["traditional"] == pytest.approx(_run_msd(frame, row["run"], drift), rel=1e-9)


def test_models_are_trained_on_the_training_azimuth_only(campaign):
    frame = campaign.frame
    result = run_paper_experiments(campaign, regressor=DummyRegressor())
    for unit, table in zip((0, 1, 2), ("table2", "table3", "table4"), strict=True):
        train = frame[(frame["unit"] == unit) & (frame["azimuth"] == 0.0)]
        mean_drift = (train["rate"] - train["reference"]).mean()
        first_run = result[table]["run"].iloc[0]
        expected = _run_msd(frame, first_run, mean_drift)
        column = "msd_after" if table == "table2" else "modified"
        assert result[table][column].iloc[0] == pytest.approx(expected, rel=1e-12)


def test_both_models_cut_msd_tenfold_on_every_seed(seeded):
    _, runs, _ = seeded
    # Worst over seeds 0-7 (paper_claim_check): modified 33x, traditional 32x, a table 14x.
    assert runs["raw"].mean() / runs["modified"].mean() >= 10.0
    assert runs["raw"].mean() / runs["traditional"].mean() >= 10.0
    per_table = runs.groupby("table")[["raw", "modified"]].mean()
    assert (per_table["raw"] / per_table["modified"] >= 4.0).all()


@pytest.mark.parametrize("seed", LINEAR_SEEDS)
def test_product_term_beats_traditional_for_the_linear_thermal_model(seed, campaign):
    # The paper's claim, where it holds on the simulator: a linear model of the drift cannot
    # build T·ΔT from T and ΔT, and the Shupe coefficient varies with T.
    campaign = _campaign(seed, campaign)
    runs = run_paper_experiments(campaign, regressor=LinearRegression()).runs
    wins = int((runs["modified"] < runs["traditional"]).sum())
    assert wins > len(runs) / 2  # 11-15 of 15 over campaign seeds 0-7
    assert runs["traditional"].mean() / runs["modified"].mean() > 1.05  # 1.09-1.71
    assert runs["raw"].mean() / runs["modified"].mean() >= 10.0  # 33x at worst


def test_error_set_training(campaign, error_set_result):
    runs = error_set_result.runs
    # Error-set MSDs are those of the mean-removed outputs: check one against the frame.
    first = runs.iloc[0]
    rows = campaign.frame[campaign.frame["run"] == first["run"]]
    error = (rows["rate"] - rows["reference"]).to_numpy()
    assert first["raw"] == pytest.approx(np.var(error), rel=1e-12)
    drift = error_set_result.models[0]["modified"].predict(rows)
    assert first["modified"] == pytest.approx(np.var(error - drift), rel=1e-9)


def test_error_set_cut_on_every_seed(seeded):
    _, _, runs = seeded
    # The mean-removed raw MSD is smaller, so is the cut: 6.45-11.1x over seeds 0-7
    # (paper_claim_check's error-set table).
    assert runs["raw"].mean() / runs["modified"].mean() >= 5.0


def test_explicit_experiments_and_frame_input(campaign):
    result = run_paper_experiments(
        campaign.frame, experiments=[(1, 45.0, 135.0)], regressor=DummyRegressor()
    )
    assert set(result) >= {"table2", "runs", "models"}
    assert "table3" not in result
    assert (result.runs["test_azimuth"] == 135.0).all()
    assert (result.runs["unit"] == 1).all()


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"experiments": [(0, 0.0, 60.0)]}, ValueError, r"Unit 0 has no run at azimuth 60 deg"),
        ({"experiments": [(0, 0.0)]}, ValueError, r"\(unit, train_azimuth, test_azimuth\)"),
        ({"target": "mean"}, ValueError, "target must be"),
        (
            {"features": ThermalFeatures(terms=("T", "dT"))},
            ValueError,
            "has no 'TdT' term",
        ),
    ],
)
def test_bad_arguments_are_explained(campaign, kwargs, error, match):
    with pytest.raises(error, match=match):
        run_paper_experiments(campaign, regressor=DummyRegressor(), **kwargs)


def test_too_few_units_or_columns(campaign):
    frame = campaign.frame
    with pytest.raises(ValueError, match=r"needs 3 units, the campaign has 2"):
        run_paper_experiments(frame[frame["unit"] < 2], regressor=DummyRegressor())
    with pytest.raises(ValueError, match=r"no column\(s\) \['reference'\]"):
        run_paper_experiments(frame.drop(columns="reference"))
    with pytest.raises(TypeError, match="campaign must be a DataFrame"):
        run_paper_experiments(np.zeros((3, 3)))
