"""The sklearn-ifog command line: round trip, bad input, export, demo."""

import io
import json
import re
import subprocess
import sys
import time
import warnings

import numpy as np
import pandas as pd
import pytest

import sklearn_ifog
from sklearn_ifog import (
    CompensationPipeline,
    RBFNetRegressor,
    _version,
    make_compensation_pipeline,
)
from sklearn_ifog.cli import main
from sklearn_ifog.cli._progress import Progress
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.metrics import mean_squared_deviation
from sklearn_ifog.persistence import load_model, save_model

pytest.importorskip("matplotlib", reason="the report draws figures with matplotlib")

FIT_ARGS = ["--temperature", "temperature", "--time", "time", "--run", "run"]
INPUT_COLUMNS = ["temperature", "time", "run"]


@pytest.fixture(scope="module")
def campaign_csv(tmp_path_factory):
    """A tiny simulated campaign as CSV, without the simulator's true 'drift' column."""
    campaign = make_thermal_campaign(
        n_units=1, n_runs=2, azimuths=(0.0, 90.0), sampling_period=120.0, random_state=1
    )
    path = tmp_path_factory.mktemp("data") / "campaign.csv"
    campaign.frame.drop(columns="drift").to_csv(path, index=False)
    return path


@pytest.fixture(scope="module")
def fitted_model(campaign_csv, tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "model.joblib"
    assert main(["fit", str(campaign_csv), *FIT_ARGS, "-o", str(path)]) == 0
    return path


def _python_api_pipeline(frame):
    """What the CLI's fit promises to be: the documented pipeline, on rate - reference."""
    pipeline = make_compensation_pipeline(
        RBFNetRegressor(random_state=0), temperature="temperature", time="time", run="run"
    )
    return pipeline.fit(frame[INPUT_COLUMNS], frame["rate"] - frame["reference"])


def _read(path):
    return pd.read_csv(path)


def _listing(directory):
    return sorted(path.name for path in directory.iterdir())


def test_fit_compensate_report_round_trip(campaign_csv, fitted_model, tmp_path, capsys):
    """Fit, compensate and report agree with the Python API, and the model cuts the MSD.

    The cut (at least 5x) held for ``campaign_csv`` on campaign seeds 1-10 (checked once).
    """
    frame = _read(campaign_csv)
    out_csv = tmp_path / "out.csv"
    assert main(["compensate", str(fitted_model), str(campaign_csv), "-o", str(out_csv)]) == 0
    result = _read(out_csv)

    # every input column and row kept, in order, plus the two new columns
    assert list(result.columns) == [
        *frame.columns,
        "drift",
        "compensated",
        "outside_calibration",
        "calibration_distance",
    ]
    pd.testing.assert_frame_equal(result[frame.columns], frame)
    expected_drift = _python_api_pipeline(frame).predict(frame[INPUT_COLUMNS])
    np.testing.assert_allclose(result["drift"], expected_drift, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        result["compensated"], frame["rate"] - expected_drift, rtol=0, atol=1e-12
    )
    # and the saved model is that pipeline, with the columns it reads in its metadata
    model, metadata = load_model(fitted_model, return_metadata=True)
    np.testing.assert_array_equal(model.predict(frame[INPUT_COLUMNS]), expected_drift)
    assert metadata["extra"]["columns"]["rate"] == "rate"
    assert metadata["feature_columns"] == INPUT_COLUMNS

    report_dir = tmp_path / "report"
    capsys.readouterr()
    assert main(["report", str(fitted_model), str(campaign_csv), "--out", str(report_dir)]) == 0
    assert "Wrote the report" in capsys.readouterr().out
    assert _listing(report_dir) == [
        "allan_deviation.png",
        "compensation_1.png",
        "compensation_2.png",
        "compensation_3.png",
        "compensation_4.png",
        "report.html",
        "report.md",
    ]
    error = frame["rate"] - frame["reference"]
    msd_before = mean_squared_deviation(error, np.zeros(len(frame)))
    msd_after = mean_squared_deviation(error, expected_drift)
    markdown = (report_dir / "report.md").read_text()
    assert f"Overall MSD: {msd_before:.3g} before, {msd_after:.3g} after" in markdown
    assert msd_after < msd_before / 5
    assert "![Run 0" in markdown
    html = (report_dir / "report.html").read_text()
    assert html.count('src="data:image/png;base64,') == 5


def test_earth_rate_reference_gives_the_same_model(campaign_csv, fitted_model, tmp_path):
    # the simulator's reference is the Earth rate at 45 deg latitude
    by_latitude = tmp_path / "latitude.joblib"
    args = ["--latitude", "45", "--azimuth", "azimuth", "-o", str(by_latitude)]
    assert main(["fit", str(campaign_csv), *FIT_ARGS, *args]) == 0
    frame = _read(campaign_csv)[INPUT_COLUMNS]
    np.testing.assert_allclose(
        load_model(by_latitude).predict(frame),
        load_model(fitted_model).predict(frame),
        rtol=0,
        atol=1e-12,
    )


def test_fit_with_cross_validation_prints_and_stores_it(campaign_csv, tmp_path, capsys):
    """``--cv`` prints and stores the cross-validated MSD, which the model lowers.

    The MSD fell for ``campaign_csv`` on campaign seeds 1-10 (checked once).
    """
    model = tmp_path / "cv.joblib"
    args = ["--cv", "azimuth", "--model", "linear", "-o", str(model)]
    assert main(["fit", str(campaign_csv), *FIT_ARGS, *args]) == 0
    printed = capsys.readouterr().out
    assert "Cross-validated MSD" in printed
    _, metadata = load_model(model, return_metadata=True)
    cv = metadata["extra"]["cross_validation"]
    assert cv["kind"] == "azimuth"
    assert cv["n_folds"] == 2  # azimuths 0 and 90
    assert cv["msd_after"] < cv["msd_before"]


def _bad_csvs(frame):
    """(name, CSV text, words the one-line message must hold)."""
    text_in_number = frame.astype({"temperature": object})
    text_in_number.loc[4, "temperature"] = "hot"
    unsorted = frame.copy()
    unsorted.loc[[6, 7], "time"] = unsorted.loc[[7, 6], "time"].to_numpy()
    missing_value = frame.copy()
    missing_value.loc[3, "rate"] = np.nan
    return [
        ("missing_column", frame.drop(columns="temperature").to_csv(index=False),
         ["no column 'temperature'", "--temperature"]),
        ("text_in_number", text_in_number.to_csv(index=False),
         ["line 6", "'temperature'", "'hot'", "not a number"]),
        ("unsorted_time", unsorted.to_csv(index=False),
         ["line 9", "'time'", "does not increase", "run"]),
        ("missing_value", missing_value.to_csv(index=False), ["line 5", "'rate'", "empty"]),
        ("empty_file", "", ["is empty"]),
        ("header_only", ",".join(frame.columns) + "\n", ["no data rows"]),
    ]  # fmt: skip


@pytest.fixture(scope="module")
def bad_csv_cases(campaign_csv):
    return _bad_csvs(_read(campaign_csv))


@pytest.mark.parametrize("case", range(6))
@pytest.mark.parametrize("command", ["fit", "compensate", "report"])
def test_bad_csv_exits_2_with_one_line_and_no_output(
    command, case, bad_csv_cases, fitted_model, tmp_path, capsys
):
    name, text, words = bad_csv_cases[case]
    data = tmp_path / f"{name}.csv"
    data.write_text(text)
    output = tmp_path / "output"
    argv = {
        "fit": ["fit", str(data), *FIT_ARGS, "-o", str(output)],
        "compensate": ["compensate", str(fitted_model), str(data), "-o", str(output)],
        "report": ["report", str(fitted_model), str(data), "--out", str(output)],
    }[command]
    capsys.readouterr()
    assert main(argv) == 2
    captured = capsys.readouterr()
    message = captured.err
    assert message.endswith("\n"), message
    assert message.count("\n") == 1, message
    assert message.startswith(f"sklearn-ifog {command}: error: ")
    assert "Traceback" not in message
    for word in words:
        assert word in message
    assert _listing(tmp_path) == [data.name]  # no output, no temporary file left


def test_missing_files_exit_2(campaign_csv, fitted_model, tmp_path, capsys):
    cases = [
        (["fit", str(tmp_path / "nope.csv"), *FIT_ARGS, "-o", str(tmp_path / "m")], "nope.csv"),
        (["compensate", str(tmp_path / "m.joblib"), str(campaign_csv), "-o", "x.csv"],
         "no such model file"),
        (["compensate", str(fitted_model), str(tmp_path / "d.csv"), "-o", "x.csv"],
         "d.csv: no such file"),
        (["fit", str(campaign_csv), *FIT_ARGS, "-o", str(tmp_path / "no" / "m.joblib")],
         "does not exist"),
    ]  # fmt: skip
    for argv, words in cases:
        assert main(argv) == 2
        message = capsys.readouterr().err
        assert message.count("\n") == 1, message
        assert words in message
    assert _listing(tmp_path) == []


def test_not_a_model_and_existing_column_exit_2(campaign_csv, fitted_model, tmp_path, capsys):
    fake = tmp_path / "fake.joblib"
    fake.write_text("not a model")
    assert main(["compensate", str(fake), str(campaign_csv), "-o", str(tmp_path / "o")]) == 2
    assert "cannot load the model" in capsys.readouterr().err

    with_drift = tmp_path / "with_drift.csv"
    _read(campaign_csv).assign(drift=0.0).to_csv(with_drift, index=False)
    out = tmp_path / "o.csv"
    assert main(["compensate", str(fitted_model), str(with_drift), "-o", str(out)]) == 2
    assert "already has a column 'drift'" in capsys.readouterr().err
    assert not out.exists()
    argv = ["compensate", str(fitted_model), str(with_drift), "-o", str(out)]
    assert main([*argv, "--drift-column", "drift_predicted"]) == 0
    assert "drift_predicted" in _read(out).columns


def test_model_from_another_version_warns_on_one_line(
    campaign_csv, fitted_model, tmp_path, monkeypatch, capsys
):
    model, metadata = load_model(fitted_model, return_metadata=True)
    old = tmp_path / "old.joblib"
    current = sklearn_ifog.__version__
    monkeypatch.setattr(_version, "__version__", "0.0.1")
    save_model(model, old, metadata=metadata["extra"])
    monkeypatch.setattr(_version, "__version__", current)
    assert main(["compensate", str(old), str(campaign_csv), "-o", str(tmp_path / "o.csv")]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("sklearn-ifog: warning:")
    assert "0.0.1" in lines[0]
    assert current in lines[0]


def test_export_writes_c_and_json(fitted_model, tmp_path):
    pytest.importorskip("sklearn_ifog.export")
    assert main(["export", str(fitted_model), "--json", str(tmp_path / "model.json")]) == 0
    spec = json.loads((tmp_path / "model.json").read_text())
    assert spec["schema_version"] == 9
    assert main(["export", str(fitted_model), "--c", str(tmp_path / "c")]) == 0
    assert _listing(tmp_path / "c") == ["ifog.c", "ifog.h"]
    assert main(["export", str(fitted_model)]) == 2  # --c or --json is required


def test_usage_errors_exit_2(campaign_csv, tmp_path, capsys):
    assert main(["fit", str(campaign_csv), "-o", str(tmp_path / "m")]) == 2  # no --temperature
    assert "--temperature" in capsys.readouterr().err
    argv = ["fit", str(campaign_csv), *FIT_ARGS, "--reference", "reference", "--latitude", "45"]
    assert main([*argv, "-o", str(tmp_path / "m")]) == 2
    assert "not both" in capsys.readouterr().err
    assert _listing(tmp_path) == []


def test_python_dash_m_runs_the_cli():
    completed = subprocess.run(
        [sys.executable, "-m", "sklearn_ifog", "--version"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert completed.returncode == 0
    assert completed.stdout.strip() == f"sklearn-ifog {sklearn_ifog.__version__}"


def test_demo_writes_what_it_says(tmp_path, capsys):
    # The test suite runs the hidden "tiny" size (same steps as --quick and the full demo on a
    # smaller campaign and model set); `demo --quick` prints how long it took.
    out = tmp_path / "demo"
    assert main(["demo", "--size", "tiny", "--n-jobs", "1", "--out", str(out)]) == 0
    captured = capsys.readouterr()

    said = {
        line.split(": ", 1)[0].strip(): line.split(": ", 1)[1].split(", ")
        for line in captured.out.splitlines()
        if line.startswith("  ") and ": " in line
    }
    listed = sorted(name for names in said.values() for name in names)
    assert listed == _listing(out)
    assert {"report.html", "report.md", "model.joblib", "campaign.csv"} <= set(listed)
    assert sum(name.endswith(".png") for name in listed) >= 4
    for step in range(1, 8):
        assert f"[{step}/7]" in captured.err
    assert "Table 2" in captured.out
    assert "rbf_modified" in captured.out
    assert "Noise floor: a perfect model of the simulated thermal drift" in captured.out
    # after_over_floor is msd_after over the floor: for "raw" (no compensation), the
    # largest possible reduction the floor line states.
    header = next(line for line in captured.out.splitlines() if "after_over_floor" in line)
    raw_row = next(line for line in captured.out.splitlines() if line.startswith("raw "))
    column = header.split().index("after_over_floor")
    bound = re.search(r"a reduction of at most ([0-9.e+-]+)x", captured.out).group(1)
    assert float(raw_row.split()[1 + column]) == pytest.approx(float(bound), rel=1e-2)
    markdown = (out / "report.md").read_text()
    assert "## The reference paper's experiments" in markdown
    # the model it saved compensates the campaign it wrote
    out_csv = tmp_path / "compensated.csv"
    argv = ["compensate", str(out / "model.joblib"), str(out / "campaign.csv")]
    assert main([*argv, "--drift-column", "drift_predicted", "-o", str(out_csv)]) == 0
    assert len(_read(out_csv)) == len(_read(out / "campaign.csv"))


def test_skops_model_file_round_trip(campaign_csv, tmp_path):
    skops_model, joblib_model = tmp_path / "m.skops", tmp_path / "m.joblib"
    for path in (skops_model, joblib_model):
        argv = ["fit", str(campaign_csv), *FIT_ARGS, "--model", "linear", "-o", str(path)]
        assert main(argv) == 0
    outputs = []
    for path in (skops_model, joblib_model):
        out = tmp_path / f"{path.suffix[1:]}.csv"
        assert main(["compensate", str(path), str(campaign_csv), "-o", str(out)]) == 0
        outputs.append(_read(out))
    pd.testing.assert_frame_equal(outputs[0], outputs[1])


def test_cross_validation_needs_two_groups(campaign_csv, tmp_path, capsys):
    # the campaign has a single unit: leave-one-unit-out cannot work
    argv = ["fit", str(campaign_csv), *FIT_ARGS, "--cv", "unit", "-o", str(tmp_path / "m")]
    assert main(argv) == 2
    message = capsys.readouterr().err
    assert "column 'unit' needs at least two distinct values, found 1" in message
    assert _listing(tmp_path) == []


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_redraws_a_live_line_on_a_terminal_and_logs_otherwise():
    terminal = _Terminal()
    progress = Progress(n_steps=2, stream=terminal)
    with progress.step("fitting", total=4) as advance:
        advance(2)
        time.sleep(0.6)  # long enough for at least one redraw (every 0.25 s)
    with pytest.raises(RuntimeError), progress.step("failing"):
        raise RuntimeError
    shown = terminal.getvalue()
    assert "\r[1/2] fitting [##########----------] 2/4" in shown
    assert "\r[1/2] fitting: done in 0." in shown
    assert "\r[2/2] failing: failed after 0.0 s" in shown

    log = io.StringIO()
    progress = Progress(n_steps=1, stream=log)
    with progress.step("comparing", total=2) as advance:
        advance()
        advance()
    assert log.getvalue().splitlines()[:3] == [
        "[1/1] comparing ...",
        "    [1/1] comparing: 1/2",
        "    [1/1] comparing: 2/2",
    ]
    assert "\r" not in log.getvalue()


def test_compensate_writes_input_columns_back_verbatim(campaign_csv, fitted_model, tmp_path):
    frame = _read(campaign_csv)
    text = frame.assign(
        serial=np.where(np.arange(len(frame)) % 2 == 0, "007", "010"),
        note=np.where(np.arange(len(frame)) == 3, "door opened", ""),
    )
    data = tmp_path / "data.csv"
    text.to_csv(data, index=False)
    out = tmp_path / "out.csv"
    assert main(["compensate", str(fitted_model), str(data), "-o", str(out)]) == 0
    source_lines = data.read_text().splitlines()
    output_lines = out.read_text().splitlines()
    assert len(output_lines) == len(source_lines)
    for source, output in zip(source_lines, output_lines, strict=True):
        kept, added = output.rsplit(",", 4)[0], output.rsplit(",", 4)[1:]
        assert kept == source
        assert len(added) == 4
    assert output_lines[0].endswith(",drift,compensated,outside_calibration,calibration_distance")


def test_interleaved_runs_are_accepted_and_compensated_row_by_row(
    campaign_csv, fitted_model, tmp_path
):
    frame = _read(campaign_csv)
    # interleave the runs' rows, each run still in time order
    rank = frame.groupby("run").cumcount().to_numpy()
    order = np.lexsort((frame["run"].to_numpy(), rank))
    interleaved = frame.iloc[order].reset_index(drop=True)
    assert not interleaved["run"].is_monotonic_increasing
    data = tmp_path / "interleaved.csv"
    interleaved.to_csv(data, index=False)
    straight_out, interleaved_out = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["compensate", str(fitted_model), str(campaign_csv), "-o", str(straight_out)]) == 0
    assert main(["compensate", str(fitted_model), str(data), "-o", str(interleaved_out)]) == 0
    np.testing.assert_allclose(
        _read(interleaved_out)["drift"], _read(straight_out)["drift"].to_numpy()[order],
        rtol=0, atol=1e-12,
    )  # fmt: skip


# -- exit statuses of errors that are not the user's --------------------------------------


def _raise(error):
    def raiser(*args, **kwargs):
        raise error

    return raiser


def test_internal_error_exits_1_and_debug_reraises(
    campaign_csv, fitted_model, tmp_path, monkeypatch, capsys
):
    out = tmp_path / "out.csv"
    argv = ["compensate", str(fitted_model), str(campaign_csv), "-o", str(out)]
    monkeypatch.setattr(CompensationPipeline, "predict", _raise(RuntimeError("boom")))
    assert main(argv) == 1
    message = capsys.readouterr().err
    assert message.count("\n") == 1, message
    assert "compensate: internal error: RuntimeError: boom" in message
    assert "--debug" in message
    with pytest.raises(RuntimeError, match="boom"):
        main(["--debug", *argv])
    assert _listing(tmp_path) == []


def test_interrupt_exits_130_and_writes_nothing(
    campaign_csv, fitted_model, tmp_path, monkeypatch, capsys
):
    out = tmp_path / "out.csv"
    monkeypatch.setattr(CompensationPipeline, "predict", _raise(KeyboardInterrupt()))
    assert main(["compensate", str(fitted_model), str(campaign_csv), "-o", str(out)]) == 130
    assert capsys.readouterr().err == "sklearn-ifog compensate: interrupted\n"
    assert _listing(tmp_path) == []


def test_unexpected_error_while_loading_a_model_is_internal_not_bad_input(
    campaign_csv, fitted_model, tmp_path, monkeypatch, capsys
):
    import joblib

    # a bug (or a broken installation) inside loading is not the user's file's fault
    monkeypatch.setattr(joblib, "load", _raise(RuntimeError("unexpected state")))
    out = tmp_path / "out.csv"
    assert main(["compensate", str(fitted_model), str(campaign_csv), "-o", str(out)]) == 1
    message = capsys.readouterr().err
    assert "internal error: RuntimeError: unexpected state" in message
    assert "cannot load the model" not in message
    # while a file that is not a model stays bad input
    monkeypatch.undo()
    truncated = tmp_path / "truncated.joblib"
    truncated.write_bytes(fitted_model.read_bytes()[:100])
    assert main(["compensate", str(truncated), str(campaign_csv), "-o", str(out)]) == 2
    assert "cannot load the model" in capsys.readouterr().err
    assert _listing(tmp_path) == ["truncated.joblib"]


def test_export_of_a_model_it_cannot_export_exits_2(campaign_csv, tmp_path, capsys):
    from sklearn.neighbors import KNeighborsRegressor

    from sklearn_ifog import make_compensation_pipeline

    frame = _read(campaign_csv)
    model = make_compensation_pipeline(KNeighborsRegressor())
    model.fit(frame[INPUT_COLUMNS], frame["rate"] - frame["reference"])
    path = tmp_path / "knn.joblib"
    save_model(model, path, metadata={"columns": {"temperature": ["temperature"]}})
    for option, target in (("--c", tmp_path / "c"), ("--json", tmp_path / "knn.json")):
        assert main(["export", str(path), option, str(target)]) == 2
        message = capsys.readouterr().err
        assert message.count("\n") == 1, message
        assert "cannot export" in message
        assert "KNeighborsRegressor" in message
    assert _listing(tmp_path) == ["knn.joblib"]


def test_export_of_an_untrusted_skops_file_exits_2(campaign_csv, tmp_path, capsys):
    import operator

    from sklearn.compose import TransformedTargetRegressor
    from sklearn.linear_model import LinearRegression

    from sklearn_ifog import make_compensation_pipeline

    pytest.importorskip("skops")
    frame = _read(campaign_csv)
    regressor = TransformedTargetRegressor(
        LinearRegression(), func=operator.pos, inverse_func=operator.pos, check_inverse=False
    )
    model = make_compensation_pipeline(regressor)
    model.fit(frame[INPUT_COLUMNS], frame["rate"] - frame["reference"])
    path = tmp_path / "untrusted.skops"
    save_model(model, path)
    assert main(["export", str(path), "--json", str(tmp_path / "m.json")]) == 2
    message = capsys.readouterr().err
    assert message.count("\n") == 1, message
    assert "cannot load the model" in message
    assert "operator.pos" in message
    assert _listing(tmp_path) == ["untrusted.skops"]


# -- multi-file outputs: all or nothing ----------------------------------------------------


def _snapshot(directory):
    return {path.name: path.read_bytes() for path in directory.iterdir()}


def _failing_after(function, n_calls, error):
    """``function``, raising ``error`` from its call number ``n_calls + 1`` on."""
    calls = []

    def wrapper(*args, **kwargs):
        calls.append(1)
        if len(calls) > n_calls:
            raise error
        return function(*args, **kwargs)

    return wrapper


def test_report_failing_half_way_leaves_the_old_report_unchanged(
    campaign_csv, fitted_model, tmp_path, monkeypatch, capsys
):
    from sklearn_ifog import plotting

    out = tmp_path / "report"
    argv = ["report", str(fitted_model), str(campaign_csv), "--out", str(out)]
    assert main(argv) == 0
    (out / "notes.txt").write_text("the user's own file")
    before = _snapshot(out)
    assert {"report.md", "report.html", "compensation_1.png", "notes.txt"} <= set(before)
    capsys.readouterr()

    # the second figure fails: the first one is already written (in the staging directory)
    monkeypatch.setattr(
        plotting, "save_figure", _failing_after(plotting.save_figure, 1, OSError("disk full"))
    )
    assert main(argv) == 1
    assert "OSError: disk full" in capsys.readouterr().err
    assert _snapshot(out) == before
    assert _listing(tmp_path) == ["report"]  # no staging directory left

    fresh = tmp_path / "fresh"
    monkeypatch.setattr(
        plotting, "save_figure", _failing_after(plotting.save_figure, 1, OSError("disk full"))
    )
    assert main([*argv[:-1], str(fresh)]) == 1
    assert _listing(tmp_path) == ["report"]  # no partial directory


def test_demo_failing_half_way_leaves_nothing(tmp_path, monkeypatch, capsys):
    from sklearn.dummy import DummyRegressor

    from sklearn_ifog.cli import _demo as demo

    # two cheap models; the failure comes at the last step, every other file being written
    monkeypatch.setattr(
        demo,
        "_regressors",
        lambda settings: {
            "raw": DummyRegressor(strategy="constant", constant=0.0),
            "bias": DummyRegressor(),
        },
    )
    monkeypatch.setattr(demo, "_write_campaign", _raise(OSError("disk full")))
    out = tmp_path / "demo"
    out.mkdir()
    (out / "campaign.csv").write_text("an older campaign")
    before = _snapshot(out)
    assert main(["demo", "--size", "tiny", "--n-jobs", "1", "--out", str(out)]) == 1
    assert "[7/7] writing the campaign as CSV: failed after" in capsys.readouterr().err
    assert _snapshot(out) == before
    assert _listing(tmp_path) == ["demo"]


def test_fit_and_compensate_with_interval(campaign_csv, fitted_model, tmp_path, capsys):
    model_path = tmp_path / "conformal.joblib"
    args = ["fit", str(campaign_csv), *FIT_ARGS, "--model", "linear", "--interval", "0.9"]
    assert main([*args, "-o", str(model_path)]) == 0
    model = load_model(model_path)
    assert type(model).__name__ == "ConformalRegressor"
    out = tmp_path / "out.csv"
    assert (
        main(
            ["compensate", str(model_path), str(campaign_csv), "-o", str(out), "--interval", "0.9"]
        )
        == 0
    )
    table = _read(out)
    assert {"drift_lower", "drift_upper"} <= set(table.columns)
    assert (table["drift_lower"] < table["drift_upper"]).all()
    # The written bounds are the model's own band on the same rows (read back from the CSV,
    # where floats keep round-trip precision), and the drift its point prediction.
    frame = _read(campaign_csv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        band = model.predict_interval(frame[INPUT_COLUMNS], coverage=0.9)
        drift = model.predict(frame[INPUT_COLUMNS])
    np.testing.assert_allclose(table["drift_lower"], band[:, 0], rtol=1e-15, atol=0)
    np.testing.assert_allclose(table["drift_upper"], band[:, 1], rtol=1e-15, atol=0)
    np.testing.assert_allclose(table["drift"], drift, rtol=1e-15, atol=0)
    wider = tmp_path / "wider.csv"
    assert (
        main(
            [
                "compensate",
                str(model_path),
                str(campaign_csv),
                "-o",
                str(wider),
                "--interval",
                "0.99",
            ]
        )
        == 0
    )
    wide = _read(wider)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        wide_band = model.predict_interval(frame[INPUT_COLUMNS], coverage=0.99)
    np.testing.assert_allclose(wide[["drift_lower", "drift_upper"]], wide_band, rtol=1e-15, atol=0)
    assert (
        (wide["drift_upper"] - wide["drift_lower"])
        >= (table["drift_upper"] - table["drift_lower"]) - 1e-12
    ).all()
    assert ((wide["drift_upper"] - wide["drift_lower"]) > (band[:, 1] - band[:, 0])).any()
    report = tmp_path / "report"
    assert main(["report", str(model_path), str(campaign_csv), "--out", str(report)]) == 0
    assert "coverage" in (report / "report.md").read_text()
    capsys.readouterr()
    # a plain model has no intervals; a coverage outside (0, 1) is refused; no output
    bad = tmp_path / "bad.csv"
    assert (
        main(
            [
                "compensate",
                str(fitted_model),
                str(campaign_csv),
                "-o",
                str(bad),
                "--interval",
                "0.9",
            ]
        )
        == 2
    )
    assert "fit ... --interval" in capsys.readouterr().err
    assert (
        main(
            ["compensate", str(model_path), str(campaign_csv), "-o", str(bad), "--interval", "1.5"]
        )
        == 2
    )
    assert "(0, 1)" in capsys.readouterr().err
    assert not bad.exists()


# -- a production lot: --unit ----------------------------------------------------------------


@pytest.fixture(scope="module")
def lot_csv(tmp_path_factory):
    """Three similar units, two runs each, as CSV."""
    campaign = make_thermal_campaign(
        n_units=3,
        n_runs=2,
        azimuths=(0.0,),
        sampling_period=300.0,
        lot_spread=0.15,
        random_state=2,
    )
    path = tmp_path_factory.mktemp("lot") / "lot.csv"
    campaign.frame.drop(columns="drift").to_csv(path, index=False)
    return path


def test_fit_warns_when_a_unit_column_holds_several_units(lot_csv, tmp_path, capsys):
    model = tmp_path / "one.joblib"
    args = ["fit", str(lot_csv), *FIT_ARGS, "--model", "linear", "-o", str(model)]
    assert main(args) == 0
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert len(warnings) == 1
    assert "column 'unit'" in warnings[0]
    assert "3 units" in warnings[0]
    assert "--unit" in warnings[0]
    # one unit's rows: no warning
    one = tmp_path / "unit0.csv"
    _read(lot_csv).query("unit == 0").to_csv(one, index=False)
    assert main(["fit", str(one), *FIT_ARGS, "--model", "linear", "-o", str(model)]) == 0
    assert "warning" not in capsys.readouterr().err


def test_fit_per_unit_then_compensate_report_export(lot_csv, tmp_path, capsys):
    from sklearn_ifog import UnitwiseRegressor

    model_path = tmp_path / "lot.joblib"
    args = ["fit", str(lot_csv), *FIT_ARGS, "--unit", "unit", "--model", "linear"]
    assert main([*args, "-o", str(model_path)]) == 0
    captured = capsys.readouterr()
    assert "warning" not in captured.err
    assert "[UnitwiseRegressor] lot model fitted on 3 units" in captured.err  # progress
    assert "per unit" in captured.out
    table_lines = [line for line in captured.out.splitlines() if "linear (partial)" in line]
    assert len(table_lines) == 3  # one row per unit
    model, metadata = load_model(model_path, return_metadata=True)
    assert isinstance(model, UnitwiseRegressor)
    assert model.pooling == "partial"
    assert model.verbose == 0  # the progress was for the command line only
    assert model.units_.tolist() == [0, 1, 2]
    assert metadata["extra"]["columns"]["unit"] == "unit"
    assert sorted(metadata["extra"]["cross_validation"]["units"]) == ["0", "1", "2"]

    frame = _read(lot_csv)
    out_csv = tmp_path / "out.csv"
    assert main(["compensate", str(model_path), str(lot_csv), "-o", str(out_csv)]) == 0
    result = _read(out_csv)
    expected = model.predict(frame[["unit", "temperature", "time", "run"]])
    np.testing.assert_allclose(result["drift"], expected, rtol=0, atol=1e-12)

    capsys.readouterr()
    assert main(["report", str(model_path), str(lot_csv), "--out", str(tmp_path / "r")]) == 0
    out = capsys.readouterr().out
    assert "MSD per unit" in out
    assert "per-unit" in (tmp_path / "r" / "report.md").read_text().lower()

    assert main(["export", str(model_path), "--c", str(tmp_path / "c")]) == 0
    assert _listing(tmp_path / "c") == [
        f"ifog_unit_{unit}.{ext}" for unit in range(3) for ext in ("c", "h")
    ]
    assert main(["export", str(model_path), "--json", str(tmp_path / "lot.json")]) == 0
    document = json.loads((tmp_path / "lot.json").read_text())
    assert [entry["unit"] for entry in document["units"]] == [0, 1, 2]


def test_unit_errors_are_one_line(lot_csv, tmp_path, capsys):
    model_path = tmp_path / "lot.joblib"
    base = ["fit", str(lot_csv), *FIT_ARGS, "--model", "linear", "-o", str(model_path)]
    assert main([*base, "--unit", "gyro"]) == 2
    assert "no column 'gyro' (given by --unit)" in capsys.readouterr().err
    assert main([*base, "--unit", "unit", "--cv", "run"]) == 2
    assert "drop --cv" in capsys.readouterr().err
    assert main([*base, "--pooling", "none"]) == 2
    assert "give --unit COL" in capsys.readouterr().err
    assert main([*base, "--unit", "unit", "--pooling", "none"]) == 0
    progress = [line for line in capsys.readouterr().err.splitlines() if "fitted (" in line]
    assert [line.split("fitted ")[1].split(",")[0] for line in progress] == [
        "(1 of 3)",
        "(2 of 3)",
        "(3 of 3)",
    ]
    other = tmp_path / "other.csv"
    _read(lot_csv).assign(unit=7).to_csv(other, index=False)
    out_csv = tmp_path / "out.csv"
    assert main(["compensate", str(model_path), str(other), "-o", str(out_csv)]) == 2
    err = capsys.readouterr().err
    assert "unit 7" in err
    assert "not seen in fit" in err
    assert len(err.strip().splitlines()) == 1
    assert not out_csv.exists()


def test_fit_per_unit_with_intervals_saves_a_quiet_model(lot_csv, tmp_path, capsys):
    from sklearn_ifog import ConformalRegressor, UnitwiseRegressor

    model_path = tmp_path / "lot.joblib"
    args = ["fit", str(lot_csv), *FIT_ARGS, "--unit", "unit", "--model", "linear"]
    assert main([*args, "--pooling", "none", "--interval", "0.9", "-o", str(model_path)]) == 0
    err = capsys.readouterr().err
    assert "[UnitwiseRegressor] unit 2 fitted (3 of 3)" in err
    model = load_model(model_path)
    assert isinstance(model, ConformalRegressor)
    assert isinstance(model.estimator, UnitwiseRegressor)
    assert model.estimator.verbose == 0
    assert model.estimator_.verbose == 0
    # the saved lot with intervals compensates, bounds per row
    out_csv = tmp_path / "out.csv"
    assert (
        main(
            ["compensate", str(model_path), str(lot_csv), "-o", str(out_csv), "--interval", "0.9"]
        )
        == 0
    )
    result = _read(out_csv)
    frame = _read(lot_csv)
    bounds = model.predict_interval(frame[["unit", "temperature", "time", "run"]])
    np.testing.assert_allclose(result["drift_lower"], bounds[:, 0], rtol=0, atol=1e-12)
