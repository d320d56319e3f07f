"""The report's scale-factor section and the command line's --input-rate (issue 44, point 3)."""

import warnings

import numpy as np
import pytest

pd = pytest.importorskip("pandas")
pytest.importorskip("matplotlib")

from sklearn.linear_model import LinearRegression  # noqa: E402

from sklearn_ifog import OutsideCalibrationWarning, make_compensation_pipeline  # noqa: E402
from sklearn_ifog.cli import main  # noqa: E402
from sklearn_ifog.datasets import make_thermal_campaign  # noqa: E402
from sklearn_ifog.metrics import (  # noqa: E402
    residual_by_input_rate,
    scale_factor_asymmetry,
    scale_factor_error,
    scale_factor_linearity,
    scale_factor_peak_to_peak,
)
from sklearn_ifog.report import RunColumns, compensation_report  # noqa: E402

RATES = np.array([0.0, 1.0, -1.0, 10.0, -10.0, 100.0, -100.0, 300.0, -300.0]) * 3600.0


@pytest.fixture(scope="module")
def rate_table():
    """A static campaign on a turntable: rates cycled two samples each, a scale-factor error
    of 4 ppm/degC about 15 degC added to the drift (the frame's rate and drift too)."""
    frame = make_thermal_campaign(
        n_units=1,
        n_runs=3,
        azimuths=[0.0],
        profile="cycle",
        sampling_period=240.0,
        temperature_range=(-40.0, 70.0),
        random_state=1,
    ).frame
    omega = RATES[(np.arange(len(frame)) // 2) % RATES.size]
    temperature = frame["temperature"].to_numpy()
    drift = frame["rate"].to_numpy() - frame["reference"].to_numpy()
    drift = drift + omega * 4e-6 * (temperature - 15.0)
    return pd.DataFrame(
        {
            "run": frame["run"].to_numpy(),
            "time": frame["time"].to_numpy(),
            "temperature": temperature,
            "reference": omega,
            "rate": omega + drift,
        }
    )


@pytest.fixture(scope="module")
def fitted(rate_table):
    X = rate_table[["run", "time", "temperature", "reference"]]
    y = (rate_table["rate"] - rate_table["reference"]).to_numpy()
    model = make_compensation_pipeline(LinearRegression(), input_rate="reference").fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        drift = model.predict(X)
    return model, X, y, drift


def _columns(rate_table, drift):
    return RunColumns(
        rate=rate_table["rate"],
        drift=drift,
        reference=rate_table["reference"],
        temperature=rate_table["temperature"],
        time=rate_table["time"],
        run=rate_table["run"],
    )


def test_report_scale_factor_section_holds_the_metrics(rate_table, fitted, tmp_path):
    model, X, y, drift = fitted
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        result = compensation_report(tmp_path, _columns(rate_table, drift), model=model, X=X)
    omega, temperature = X["reference"].to_numpy(), X["temperature"].to_numpy()
    run, after = X["run"].to_numpy(), y - drift
    summary = result.scale_factor.summary
    assert summary.loc["peak_to_peak_ppm", "before"] == pytest.approx(
        scale_factor_peak_to_peak(omega, y, temperature, run=run), rel=1e-12
    )
    # after: (rate - drift) - reference against y - drift, equal to round-off of the rates
    assert summary.loc["peak_to_peak_ppm", "after"] == pytest.approx(
        scale_factor_peak_to_peak(omega, after, temperature, run=run), abs=1e-6
    )
    assert summary.loc["linearity_ppm", "after"] == pytest.approx(
        scale_factor_linearity(omega, after), abs=1e-6
    )
    assert summary.loc["asymmetry_ppm", "before"] == pytest.approx(
        scale_factor_asymmetry(omega, y), rel=1e-12
    )
    # 4 ppm/degC over the binned range: hundreds of ppm before, compensated to a fraction
    assert summary.loc["peak_to_peak_ppm", "before"] > 200.0
    assert (
        summary.loc["peak_to_peak_ppm", "after"] < 0.01 * summary.loc["peak_to_peak_ppm", "before"]
    )
    table = result.scale_factor.table
    np.testing.assert_allclose(
        table["ppm_after"],
        scale_factor_error(omega, after, temperature, run=run)["ppm"],
        atol=1e-6,
    )
    by_rate = result.scale_factor.by_input_rate
    np.testing.assert_allclose(
        by_rate["rms_after"], residual_by_input_rate(omega, after)["rms"], rtol=1e-6
    )
    np.testing.assert_allclose(by_rate["deg_s"], np.sort(RATES) / 3600.0)

    markdown = result.paths["markdown"].read_text()
    assert "### Scale factor" in markdown
    before_text = f"{summary.loc['peak_to_peak_ppm', 'before']:.3g} ppm before"
    assert before_text in markdown
    pooled = table[table["run"] == "(all runs)"]
    assert f"| {pooled['ppm_before'].iloc[0]:.4g} |" in markdown
    assert result.figures[0].name == "scale_factor.png"
    assert (tmp_path / "scale_factor.png").read_bytes()[:4] == b"\x89PNG"
    # the figures draw the error, the input rates dwarfing the drift
    assert "compensated error (output minus input rate)" in markdown


def test_bias_only_report_unchanged_and_scale_factor_forced(rate_table, fitted, tmp_path):
    _, _, _, drift = fitted
    columns = _columns(rate_table, drift)
    (tmp_path / "plain").mkdir()
    plain = compensation_report(tmp_path / "plain", columns)
    assert plain.scale_factor is None
    markdown = plain.paths["markdown"].read_text()
    assert "Scale factor" not in markdown
    assert "raw (grey) and compensated output, reference (dashed)" in markdown
    assert "scale_factor.png" not in [path.name for path in plain.figures]

    (tmp_path / "forced").mkdir()
    forced = compensation_report(
        tmp_path / "forced", columns, scale_factor=True, temperature_bins=[-40.0, 15.0, 70.0]
    )
    assert forced.scale_factor.table["T_low"].tolist()[:2] == [-40.0, 15.0]
    with pytest.raises(ValueError, match="scale_factor must be None"):
        compensation_report(tmp_path, columns, scale_factor="yes")


def test_report_scale_factor_without_rotation_says_so(rate_table, tmp_path):
    static = RunColumns(
        rate=rate_table["rate"] - rate_table["reference"],
        drift=np.zeros(len(rate_table)),
        reference=0.0,
        temperature=rate_table["temperature"],
    )
    result = compensation_report(tmp_path, static, scale_factor=True)
    assert np.isnan(result.scale_factor.summary.to_numpy()).all()
    assert "No scale factor can be read" in result.paths["markdown"].read_text()
    assert "scale_factor.png" not in [path.name for path in result.figures]


def test_cli_input_rate_round_trip(rate_table, fitted, tmp_path, capsys):
    data = tmp_path / "table.csv"
    rate_table.to_csv(data, index=False)
    model_path = tmp_path / "model.joblib"
    common = ["--temperature", "temperature", "--time", "time", "--run", "run"]
    fit = ["fit", str(data), *common, "--input-rate", "reference", "--model", "linear"]
    status = main([*fit, "-o", str(model_path)])
    assert status == 0
    printed = capsys.readouterr().out
    assert "Scale-factor error over temperature" in printed
    model, X = fitted[:2]

    # compensate: the field's file has no input-rate column; the output is the estimate
    field = tmp_path / "field.csv"
    rate_table.drop(columns="reference").to_csv(field, index=False)
    out = tmp_path / "out.csv"
    assert main(["compensate", str(model_path), str(field), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "'compensated' is the estimated input rate" in printed
    assert "no 'reference' column, the output stood in for it" in printed
    written = pd.read_csv(out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        expected = model.compensate(X.drop(columns="reference"), rate_table["rate"].to_numpy())
    np.testing.assert_allclose(written["compensated"], expected, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(
        written["drift"], rate_table["rate"] - expected, rtol=1e-12, atol=1e-9
    )
    # with the true input rate in the file: the same estimate (the output's alone)
    full_out = tmp_path / "full_out.csv"
    assert main(["compensate", str(model_path), str(data), "-o", str(full_out)]) == 0
    assert "stood in" not in capsys.readouterr().out
    np.testing.assert_allclose(pd.read_csv(full_out)["compensated"], written["compensated"])
    # within the noise of the input rate: the scale factor is taken out
    assert np.sqrt(np.mean((written["compensated"] - rate_table["reference"]) ** 2)) < 0.1

    # report: the scale-factor section, from the model's metadata
    report_dir = tmp_path / "report"
    assert main(["report", str(model_path), str(data), "--out", str(report_dir)]) == 0
    markdown = (report_dir / "report.md").read_text()
    assert "### Scale factor" in markdown
    assert (report_dir / "scale_factor.png").exists()


def test_cli_input_rate_errors_name_the_column(rate_table, tmp_path, capsys):
    data = tmp_path / "table.csv"
    rate_table.to_csv(data, index=False)
    model_path = tmp_path / "model.joblib"
    common = [str(data), "--temperature", "temperature", "--time", "time", "--run", "run"]
    assert main(["fit", *common, "--input-rate", "table_rate", "-o", str(model_path)]) == 2
    error = capsys.readouterr().err
    assert "no column 'table_rate' (given by --input-rate)" in error
    assert not model_path.exists()
    assert main(["fit", *common, "--input-rate", "rate", "-o", str(model_path)]) == 2
    assert "--input-rate 'rate' is also the --rate column" in capsys.readouterr().err
    args = ["fit", *common, "--input-rate", "reference", "--interval", "0.9"]
    assert main([*args, "-o", str(model_path)]) == 2
    assert "does not take --interval" in capsys.readouterr().err
    # rates in deg/s, not deg/h: the model's unit check, one line
    in_deg_s = rate_table.assign(reference=rate_table["reference"] / 3600.0)
    in_deg_s.to_csv(data, index=False)
    assert main(["fit", *common, "--input-rate", "reference", "-o", str(model_path)]) == 2
    assert "must be in the output's unit, deg/h" in capsys.readouterr().err
    # the report needs the input rate (its reference) in the file
    rate_table.to_csv(data, index=False)
    assert (
        main(
            [
                "fit",
                *common,
                "--input-rate",
                "reference",
                "--model",
                "linear",
                "-o",
                str(model_path),
            ]
        )
        == 0
    )
    capsys.readouterr()
    no_rate = tmp_path / "no_rate.csv"
    rate_table.drop(columns="reference").to_csv(no_rate, index=False)
    assert main(["report", str(model_path), str(no_rate), "--out", str(tmp_path / "r")]) == 2
    assert "no column 'reference' (read by the model as --input-rate)" in capsys.readouterr().err
