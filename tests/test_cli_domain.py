"""The command line flags the rows outside a model's calibration domain, row by row and run
by run, and leaves every other contract (exit status, atomic outputs) as it was."""

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import ThermalFeatures
from sklearn_ifog.cli import main
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.persistence import load_model, save_model

pytest.importorskip("matplotlib", reason="the report draws figures with matplotlib")

FIT_ARGS = ["--temperature", "temperature", "--time", "time", "--run", "run"]
INPUT_COLUMNS = ["temperature", "time", "run"]
ADDED = ["drift", "compensated", "outside_calibration", "calibration_distance"]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A calibration CSV (10-40 degC chamber), a model fitted on it by the CLI, and a CSV
    of the same runs with the second half of run 1 made 30 degC colder."""
    directory = tmp_path_factory.mktemp("domain")
    campaign = make_thermal_campaign(
        n_units=1,
        n_runs=2,
        azimuths=[0.0],
        sampling_period=120.0,
        temperature_range=(10.0, 40.0),
        random_state=0,
    )
    frame = campaign.frame.drop(columns="drift")
    calibration = directory / "calibration.csv"
    frame.to_csv(calibration, index=False)
    run_1 = np.flatnonzero(frame["run"].to_numpy() == 1)
    colder = frame.copy()
    colder.loc[run_1[run_1.size // 2 :], "temperature"] -= 30.0
    partly_cold = directory / "partly_cold.csv"
    colder.to_csv(partly_cold, index=False)
    model = directory / "model.joblib"
    assert main(["fit", str(calibration), *FIT_ARGS, "--model", "linear", "-o", str(model)]) == 0
    return {"calibration": calibration, "partly_cold": partly_cold, "model": model}


def _listing(directory):
    return sorted(path.name for path in directory.iterdir())


def test_compensate_writes_the_models_flag_and_distance_row_for_row(files, tmp_path, capsys):
    out = tmp_path / "out.csv"
    capsys.readouterr()
    argv = ["compensate", str(files["model"]), str(files["partly_cold"]), "-o", str(out)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert captured.err == ""  # told run by run below, not as a Python warning
    frame = pd.read_csv(files["partly_cold"])
    written = pd.read_csv(out)
    assert list(written.columns) == [*frame.columns, *ADDED]
    model = load_model(files["model"])
    X = frame[INPUT_COLUMNS]
    outside = model.outside_calibration(X)
    distance = model.calibration_distance(X)
    assert written["outside_calibration"].dtype == bool
    np.testing.assert_array_equal(written["outside_calibration"], outside)
    np.testing.assert_allclose(written["calibration_distance"], distance, rtol=1e-15, atol=0)
    runs = frame["run"].to_numpy()
    assert not outside[runs == 0].any()
    assert 0 < outside[runs == 1].mean() < 1

    lines = captured.out.splitlines()
    assert lines[1].startswith(
        f"{outside.sum()} of {outside.size} rows lie outside the calibration domain of the model"
    )
    (run_line,) = [line for line in lines if line.startswith("  run ")]  # run 1 only
    rows = runs == 1
    column = model.fallback_.column
    coldest = model.domain_.data_min_[column]
    below = coldest - frame["temperature"][rows].min()
    # The 30 degC step down reads as a steep cooling rate at the step: beyond the rates too.
    rate_column = list(model.feature_names_out_).index("dT")
    rate = model[:1].transform(X)[rows, rate_column]
    slowest = model.domain_.data_min_[rate_column]
    fastest = model.domain_.data_max_[rate_column]
    assert rate.max() <= fastest
    assert run_line == (
        f"  run 1: {outside[rows].sum()} of {rows.sum()} rows ({outside[rows].mean():.1%}) "
        f"outside, largest distance {_number(distance[rows].max())} sd, temperature up to "
        f"{below:.3g} degC below the coldest calibrated temperature ({coldest:.4g} to "
        f"{model.domain_.data_max_[column]:.4g} degC), rate dT up to "
        f"{slowest - rate.min():.3g} below the slowest calibrated rate ({slowest:.3g} to "
        f"{fastest:.3g})"
    )


def _number(value):
    return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"


def test_compensate_all_inside_says_so_and_writes_all_false(files, tmp_path, capsys):
    out = tmp_path / "out.csv"
    capsys.readouterr()
    argv = ["compensate", str(files["model"]), str(files["calibration"]), "-o", str(out)]
    assert main(argv) == 0
    written = pd.read_csv(out)
    assert not written["outside_calibration"].any()
    assert (written["calibration_distance"] == 0).all()
    lines = capsys.readouterr().out.splitlines()
    assert lines[1:] == [
        f"All {len(written)} rows lie inside the calibration domain of the model."
    ]


def test_report_shows_the_per_run_table_and_the_shaded_figure(files, tmp_path, capsys):
    out = tmp_path / "report"
    capsys.readouterr()
    argv = ["report", str(files["model"]), str(files["partly_cold"]), "--out", str(out)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    frame = pd.read_csv(files["partly_cold"])
    model = load_model(files["model"])
    outside = model.outside_calibration(frame[INPUT_COLUMNS])
    runs = frame["run"].to_numpy()
    printed = captured.out.split("Rows outside the calibration domain per run", 1)[1]
    table = printed.split("\n\n", 1)[0].splitlines()
    share_1 = f"{outside[runs == 1].mean():.3g}"
    assert [line.split()[:4] for line in table[-3:]] == [
        ["0", str((runs == 0).sum()), "0", "0"],
        ["1", str((runs == 1).sum()), str(outside[runs == 1].sum()), share_1],
        ["(all", "runs)", str(runs.size), str(outside.sum())],
    ]
    markdown = (out / "report.md").read_text()
    assert "### Calibration domain" in markdown
    assert "| run | samples | rows_outside | outside_share |" in markdown
    assert "![Run 1: raw (grey) and compensated output, reference (dashed) and temperature" in (
        markdown
    )
    assert markdown.count("shaded where the rows lie outside the calibration domain") == 2
    assert _listing(out) == [
        "allan_deviation.png",
        "compensation_1.png",
        "compensation_2.png",
        "report.html",
        "report.md",
    ]


def test_an_existing_flag_column_is_an_error_and_writes_nothing(files, tmp_path, capsys):
    data = tmp_path / "data.csv"
    pd.read_csv(files["calibration"]).assign(calibration_distance=1.0).to_csv(data, index=False)
    out = tmp_path / "out.csv"
    capsys.readouterr()
    assert main(["compensate", str(files["model"]), str(data), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "already has a column 'calibration_distance'" in err
    assert _listing(tmp_path) == ["data.csv"]
    # an option naming one of those columns is the same conflict
    argv = ["compensate", str(files["model"]), str(files["calibration"]), "-o", str(out)]
    assert main([*argv, "--drift-column", "outside_calibration"]) == 2
    assert "'outside_calibration'" in capsys.readouterr().err
    assert _listing(tmp_path) == ["data.csv"]


def test_a_model_without_a_domain_gets_no_flag_columns(files, tmp_path, capsys):
    frame = pd.read_csv(files["calibration"])
    plain = Pipeline(
        [
            ("features", ThermalFeatures(temperature="temperature", time="time", run="run")),
            ("scale", StandardScaler()),
            ("regressor", LinearRegression()),
        ]
    ).fit(frame[INPUT_COLUMNS], frame["rate"] - frame["reference"])
    model = tmp_path / "plain.joblib"
    columns = {"temperature": ["temperature"], "time": "time", "run": "run"}
    save_model(plain, model, metadata={"columns": {**columns, "reference": "reference"}})
    out = tmp_path / "out.csv"
    capsys.readouterr()
    assert main(["compensate", str(model), str(files["partly_cold"]), "-o", str(out)]) == 0
    written = pd.read_csv(out)
    assert list(written.columns)[-2:] == ["drift", "compensated"]
    assert "calibration domain" not in capsys.readouterr().out
    report = tmp_path / "report"
    assert main(["report", str(model), str(files["partly_cold"]), "--out", str(report)]) == 0
    assert "The model carries no calibration domain" in (report / "report.md").read_text()


def test_a_lot_is_flagged_by_each_units_model(tmp_path, capsys):
    campaign = make_thermal_campaign(
        n_units=2,
        n_runs=2,
        azimuths=[0.0],
        sampling_period=120.0,
        temperature_range=(10.0, 40.0),
        lot_spread=0.2,
        random_state=0,
    )
    frame = campaign.frame.drop(columns="drift")
    lot, colder = tmp_path / "lot.csv", tmp_path / "colder.csv"
    frame.to_csv(lot, index=False)
    unit_1 = (frame["unit"] == 1).to_numpy()
    frame.loc[unit_1, "temperature"] -= 30.0  # unit 1 only: far below its calibration
    frame.to_csv(colder, index=False)
    model_path, out = tmp_path / "lot.joblib", tmp_path / "out.csv"
    fit = ["fit", str(lot), *FIT_ARGS, "--unit", "unit", "--pooling", "none", "--model", "linear"]
    assert main([*fit, "-o", str(model_path)]) == 0
    capsys.readouterr()
    assert main(["compensate", str(model_path), str(colder), "-o", str(out)]) == 0
    written = pd.read_csv(out)
    model = load_model(model_path)
    for unit, rows in ((0, ~unit_1), (1, unit_1)):
        own = model.estimators_[unit]
        X = frame.loc[rows, INPUT_COLUMNS]
        np.testing.assert_array_equal(
            written["outside_calibration"][rows], own.outside_calibration(X)
        )
        np.testing.assert_allclose(
            written["calibration_distance"][rows], own.calibration_distance(X), rtol=1e-15
        )
    assert written["outside_calibration"][unit_1].all()
    assert not written["outside_calibration"][~unit_1].any()
    run_lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("  ")]
    runs_of_unit_1 = frame.loc[unit_1, "run"].unique()
    assert [line.split(":")[0] for line in run_lines] == [
        f"  unit 1, run {run}" for run in runs_of_unit_1
    ]


def test_fit_counts_the_folds_whose_held_out_rows_were_outside(tmp_path, capsys):
    from sklearn_ifog import make_compensation_pipeline

    lot = make_thermal_campaign(
        n_units=2,
        n_runs=2,
        azimuths=[0.0],
        sampling_period=120.0,
        temperature_range=(10.0, 40.0),
        lot_spread=0.2,
        random_state=0,
    ).frame.drop(columns="drift")
    data = tmp_path / "lot.csv"
    lot.to_csv(data, index=False)
    capsys.readouterr()
    argv = ["fit", str(data), *FIT_ARGS, "--model", "linear", "--cv", "run"]
    assert main([*argv, "-o", str(tmp_path / "model.joblib")]) == 0
    captured = capsys.readouterr()
    assert "OutsideCalibrationWarning" not in captured.err
    # each fold: the model fitted on the other runs, flagging the held-out run's rows
    X, y = lot[INPUT_COLUMNS], (lot["rate"] - lot["reference"]).to_numpy()
    runs = lot["run"].to_numpy()
    outside_folds = 0
    for run in np.unique(runs):
        model = make_compensation_pipeline(
            LinearRegression(), temperature="temperature", time="time", run="run"
        ).fit(X[runs != run], y[runs != run])
        outside_folds += bool(model.outside_calibration(X[runs == run]).any())
    line = (
        f"In {outside_folds} of the {np.unique(runs).size} folds, held-out rows lay outside "
        "the calibration domain of the model fitted without them"
    )
    assert (line in captured.out) == (outside_folds > 0)
    assert outside_folds > 0  # the case this test is about
