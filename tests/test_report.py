"""Reports: the Markdown/HTML document and the compensation report's numbers."""

import base64

import numpy as np
import pandas as pd
import pytest

from sklearn_ifog.metrics import allan_deviation, bias_stability, mean_squared_deviation
from sklearn_ifog.report import Report, RunColumns, compensation_report

pytest.importorskip("matplotlib", reason="the compensation report draws figures")


def test_report_renders_markdown_and_escaped_html(tmp_path):
    figure = tmp_path / "plot.png"
    figure.write_bytes(b"\x89PNG fake bytes")
    report = Report("Test <1>")
    report.add_heading("Results & notes")
    report.add_paragraph("MSD < 1e-3 | good")
    table = pd.DataFrame(
        {"msd": [1.23456e-4, np.nan], "n": [10, 20], "ok": [True, False]},
        index=pd.Index(["a|b", "c"], name="run"),
    )
    report.add_table(table, caption="Per run.")
    report.add_figure(figure, "A figure")

    markdown = report.to_markdown(tmp_path)
    assert markdown.splitlines()[:5] == [
        "# Test <1>",
        "",
        "## Results & notes",
        "",
        "MSD < 1e-3 | good",
    ]
    assert "| run | msd | n | ok |" in markdown
    assert "| a\\|b | 0.0001235 | 10 | True |" in markdown
    assert "| c | n/a | 20 | False |" in markdown
    assert "![A figure](plot.png)" in markdown

    page = report.to_html(tmp_path)
    assert "<h1>Test &lt;1&gt;</h1>" in page
    assert "<p>MSD &lt; 1e-3 | good</p>" in page
    assert "<td>a|b</td><td>0.0001235</td><td>10</td><td>True</td>" in page
    encoded = base64.b64encode(figure.read_bytes()).decode()
    assert f'src="data:image/png;base64,{encoded}"' in page
    assert 'src="plot.png"' in report.to_html(tmp_path, embed_figures=False)

    paths = report.write(tmp_path, name="summary")
    assert paths["markdown"].read_text() == markdown
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plot.png", "summary.html", "summary.md"]
    with pytest.raises(ValueError, match="level must be 2, 3 or 4"):
        report.add_heading("x", level=1)


def test_report_tables_from_dicts_and_rows():
    report = Report("t")
    report.add_table([{"a": 1, "b": 2.5}, {"a": 3, "c": "x"}])
    assert "| a | b | c |\n| --- | --- | --- |\n| 1 | 2.5 |  |\n| 3 |  | x |" in (
        report.to_markdown()
    )
    with pytest.raises(ValueError, match="differ in length"):
        report.add_table({"a": [1, 2], "b": [1]})


def _two_interleaved_runs():
    rng = np.random.default_rng(0)
    n = 1200  # 1200 s per run at 1 s
    time = np.tile(np.arange(n, dtype=float), 2)
    run = np.repeat(["A", "B"], n)
    temperature = np.where(run == "A", 20.0, 30.0) + 5.0 * np.sin(time / 200.0)
    reference = np.where(run == "A", 10.0, -5.0)
    true_drift = 0.01 * (temperature - 25.0)
    rate = reference + true_drift + rng.normal(0.0, 0.002, 2 * n)
    drift = 0.9 * true_drift
    # interleave the runs' rows; each run stays in time order
    order = np.argsort(np.concatenate([np.arange(n) * 2, np.arange(n) * 2 + 1]), kind="stable")
    return {
        "rate": rate[order],
        "drift": drift[order],
        "reference": reference[order],
        "temperature": temperature[order],
        "time": time[order],
        "run": run[order],
    }


def test_compensation_report_numbers_match_the_metrics(tmp_path):
    """The reduction above 10 held on noise seeds 0-9 (checked once)."""
    data = _two_interleaved_runs()
    result = compensation_report(tmp_path, RunColumns(**data), max_runs=1)
    table = result.table
    assert list(table.index) == ["A", "B", "(all runs)"]
    for label in ("A", "B"):
        rows = data["run"] == label
        error = data["rate"][rows] - data["reference"][rows]
        compensated = error - data["drift"][rows]
        before = mean_squared_deviation(error, np.zeros(rows.sum()))
        after = mean_squared_deviation(compensated, np.zeros(rows.sum()))
        assert table.loc[label, "msd_before"] == pytest.approx(before, rel=1e-12)
        assert table.loc[label, "msd_after"] == pytest.approx(after, rel=1e-12)
        assert table.loc[label, "reduction"] == pytest.approx(before / after, rel=1e-12)
        assert table.loc[label, "samples"] == 1200
        assert table.loc[label, "bias_stab_before"] == pytest.approx(
            bias_stability(error, sample_period=1.0, window=100.0), rel=1e-12
        )
        assert table.loc[label, "bias_stab_after"] == pytest.approx(
            bias_stability(compensated, sample_period=1.0, window=100.0), rel=1e-12
        )
    everything = data["rate"] - data["reference"]
    assert table.loc["(all runs)", "msd_before"] == pytest.approx(
        np.mean(everything**2), rel=1e-12
    )
    assert table.loc["(all runs)", "reduction"] > 10

    # one run drawn (max_runs=1) plus the Allan deviation
    assert [path.name for path in result.figures] == ["compensation_1.png", "allan_deviation.png"]
    markdown = result.paths["markdown"].read_text()
    assert "The first 1 of 2 runs are drawn." in markdown
    assert "(run A, the longest; sample period 1 s)" in markdown
    taus, _ = allan_deviation(everything[data["run"] == "A"], sample_period=1.0)
    assert taus[0] == 1.0


def test_compensation_report_without_uniform_sampling_says_so(tmp_path):
    time = np.cumsum(np.r_[0.0, np.tile([1.0, 3.0], 300)])
    n = time.size
    columns = RunColumns(
        rate=np.full(n, 1.0) + 0.01 * np.sin(time / 50.0),
        drift=0.01 * np.sin(time / 50.0),
        reference=1.0,
        temperature=np.linspace(10.0, 30.0, n),
        time=time,
    )
    result = compensation_report(tmp_path, columns)
    assert np.isnan(result.table.loc["(all runs)", "bias_stab_before"])
    assert np.isnan(result.table.loc["(all runs)", "bias_stab_after"])
    assert [path.name for path in result.figures] == ["compensation_1.png"]
    markdown = result.paths["markdown"].read_text()
    assert "Not computed: run (all runs) is not uniformly sampled" in markdown
    assert list(result.table.index) == ["(all runs)"]
    assert "| (all runs) | 601 |" in markdown


def test_compensation_report_rejects_mismatched_lengths(tmp_path):
    with pytest.raises(ValueError, match=r"drift has shape \(9,\), rate has shape \(10,\)"):
        compensation_report(
            tmp_path,
            RunColumns(rate=np.ones(10), drift=np.ones(9), reference=0.0, temperature=np.ones(10)),
        )
    assert list(tmp_path.iterdir()) == []


def _columns(n=10, **changes):
    fields = {
        "rate": np.ones(n),
        "drift": np.zeros(n),
        "reference": 1.0,
        "temperature": np.linspace(10.0, 30.0, n),
    }
    return {**fields, **changes}


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"rate": np.ones((10, 2))}, r"rate must be one-dimensional .* got shape \(10, 2\)"),
        ({"rate": ["a"] * 10}, "rate must be numeric"),
        ({"drift": ["x"] * 10}, "drift must be numeric"),
        ({"temperature": np.ones(9)}, r"temperature has shape \(9,\), rate has shape \(10,\)"),
        ({"time": np.arange(11.0)}, r"time has shape \(11,\), rate has shape \(10,\)"),
        ({"reference": np.ones(3)}, r"reference has shape \(3,\), rate has shape \(10,\)"),
        ({"reference": "north"}, "reference must be numeric"),
        ({"run": np.zeros(9)}, r"run has shape \(9,\), rate has shape \(10,\)"),
        ({"unit": np.zeros((10, 2))}, r"unit has shape \(10, 2\), rate has shape \(10,\)"),
    ],
)
def test_run_columns_name_the_bad_field(changes, message):
    with pytest.raises(ValueError, match=f"^RunColumns: {message}"):
        RunColumns(**_columns(**changes))


def test_run_columns_hold_arrays():
    columns = RunColumns(
        **_columns(4, rate=[1.0, 2.0, 3.0, 4.0], run=pd.Series(["a", "a", "b", "b"]), time=None)
    )
    assert columns.rate.dtype == np.float64
    np.testing.assert_array_equal(columns.rate, [1.0, 2.0, 3.0, 4.0])
    assert columns.reference.shape == ()
    assert columns.time is None
    assert columns.unit is None
    assert columns.run.tolist() == ["a", "a", "b", "b"]
    assert columns.n_samples == 4
    with pytest.raises(AttributeError):
        columns.rate = np.zeros(4)  # frozen: checked once, kept as checked


def test_compensation_report_title_and_report(tmp_path):
    rate = 1.0 + np.random.default_rng(0).normal(0.0, 0.01, 600)
    columns = RunColumns(**_columns(600, rate=rate, time=np.arange(600.0)))
    assert compensation_report(tmp_path, columns).report.title == "Thermal compensation report"
    titled = compensation_report(tmp_path, columns, title="Gyro 7")
    assert titled.paths["markdown"].read_text().startswith("# Gyro 7\n")
    mine = Report("My lot")
    mine.add_paragraph("Before the compensation.")
    (tmp_path / "appended").mkdir()
    appended = compensation_report(tmp_path / "appended", columns, report=mine, heading="Gyro 7")
    assert appended.report is mine
    markdown = appended.paths["markdown"].read_text()
    assert markdown.startswith("# My lot\n\nBefore the compensation.\n\n## Gyro 7\n")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match=r"title and report were both given.*\('My lot'\)"):
        compensation_report(empty, columns, title="Gyro 8", report=mine)
    assert list(empty.iterdir()) == []


def test_compensation_report_wants_run_columns(tmp_path):
    with pytest.raises(TypeError, match=r"columns must be a RunColumns .* got dict"):
        compensation_report(tmp_path, _columns())
    assert list(tmp_path.iterdir()) == []
