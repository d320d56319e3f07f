"""Plots: what is drawn is the data given, on the right axes and scales."""

import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="plotting needs the optional matplotlib")

from sklearn_ifog.plotting import (
    new_figure,
    plot_allan_deviation,
    plot_compensation,
    plot_msd_by_model,
    save_figure,
)


@pytest.fixture
def run():
    time = np.arange(0.0, 4 * 3600.0, 60.0)
    temperature = 10.0 + 30.0 * np.clip((time - 3600.0) / 7200.0, 0.0, 1.0)
    drift = 0.002 * (temperature - 25.0)
    rate = 7.5 + drift
    return time, temperature, rate, drift


def test_plot_compensation_draws_the_given_series(run):
    time, temperature, rate, drift = run
    traditional, modified = rate - 0.9 * drift, rate - drift
    ax, temperature_ax = plot_compensation(
        time,
        rate,
        {"traditional": traditional, "modified": modified},
        temperature,
        reference=7.5,
        title="run 3",
    )
    lines = {line.get_label(): line for line in ax.get_lines()}
    assert list(lines) == ["raw", "traditional", "modified", "_reference"]
    np.testing.assert_allclose(lines["raw"].get_xdata(), time / 3600.0)
    np.testing.assert_allclose(lines["raw"].get_ydata(), rate)
    np.testing.assert_allclose(lines["modified"].get_ydata(), modified)
    np.testing.assert_allclose(lines["_reference"].get_ydata(), np.full(time.shape, 7.5))
    assert lines["_reference"].get_linestyle() == "--"
    (temperature_line,) = temperature_ax.get_lines()
    np.testing.assert_allclose(temperature_line.get_ydata(), temperature)
    assert temperature_ax.get_ylabel() == "temperature (°C)"
    assert ax.get_xlabel() == "time (h)"
    assert ax.get_title() == "run 3"
    legend = [text.get_text() for text in ax.get_legend().get_texts()]
    assert legend == ["raw", "traditional", "modified", "temperature"]


def test_plot_compensation_without_temperature_and_in_minutes(run):
    time, _, rate, drift = run
    ax, temperature_ax = plot_compensation(time, rate, rate - drift, time_unit="min")
    assert temperature_ax is None
    np.testing.assert_allclose(ax.get_lines()[0].get_xdata(), time / 60.0)


def test_plot_compensation_rejects_bad_input(run):
    time, temperature, rate, _ = run
    with pytest.raises(ValueError, match=r"compensated\['modified'\] has shape \(3,\)"):
        plot_compensation(time, rate, {"modified": rate[:3]}, temperature)
    with pytest.raises(ValueError, match="temperature has shape"):
        plot_compensation(time, rate, rate, temperature[:-1])
    with pytest.raises(ValueError, match="time_unit must be one of"):
        plot_compensation(time, rate, rate, time_unit="days")


def test_plot_allan_deviation_is_log_log_and_drops_non_positive_points():
    taus = np.array([1.0, 2.0, 4.0, 8.0])
    raw = np.array([0.1, 0.07, 0.05, 0.06])
    compensated = np.array([0.1, 0.07, 0.0, 0.03])  # a zero cannot be drawn on a log axis
    ax = plot_allan_deviation({"raw": (taus, raw), "compensated": (taus, compensated)})
    assert (ax.get_xscale(), ax.get_yscale()) == ("log", "log")
    raw_line, compensated_line = ax.get_lines()
    np.testing.assert_allclose(raw_line.get_ydata(), raw)
    np.testing.assert_allclose(compensated_line.get_xdata(), [1.0, 2.0, 8.0])
    with pytest.raises(ValueError, match="curve 'x': taus has shape"):
        plot_allan_deviation({"x": (taus, raw[:2])})
    with pytest.raises(ValueError, match="no positive Allan deviation"):
        plot_allan_deviation({"x": (taus, np.zeros(4))})


def test_plot_msd_by_model_bars_are_means_with_raw_first():
    ax = plot_msd_by_model({"linear": [1e-3, 3e-3], "rbf": 2e-4}, before=[1e-2, 3e-2])
    heights = [patch.get_height() for patch in ax.patches]
    np.testing.assert_allclose(heights, [2e-2, 2e-3, 2e-4])
    assert [label.get_text() for label in ax.get_xticklabels()] == ["raw", "linear", "rbf"]
    assert ax.get_yscale() == "log"
    dots = [line.get_ydata() for line in ax.get_lines()]  # one dot per fold, multi-fold only
    np.testing.assert_allclose(np.concatenate(dots), [1e-2, 3e-2, 1e-3, 3e-3])
    with pytest.raises(ValueError, match="MSD of 'rbf' must be positive"):
        plot_msd_by_model({"rbf": [1e-3, 0.0]})
    with pytest.raises(ValueError, match="msd is empty"):
        plot_msd_by_model({})


def test_save_figure_writes_png_atomically(tmp_path):
    figure, axes = new_figure(1, 2)
    assert axes.shape == (2,)
    plot_msd_by_model({"rbf": 1e-4}, before=1e-2, ax=axes[0])
    path = save_figure(figure, tmp_path / "figure.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figure.png"]
    with pytest.raises(ValueError, match="no suffix"):
        save_figure(figure, tmp_path / "figure")
    with pytest.raises(ValueError, match="Format 'nope' is not supported"):
        save_figure(figure, tmp_path / "figure.nope")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figure.png"]


def test_plots_never_touch_pyplot():
    code = (
        "import sys; from sklearn_ifog.plotting import plot_msd_by_model, save_figure; "
        "import tempfile, pathlib; d = tempfile.mkdtemp(); "
        "save_figure(plot_msd_by_model({'a': 1.0}), pathlib.Path(d) / 'a.png'); "
        "print('matplotlib.pyplot' in sys.modules)"
    )
    completed = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    assert completed.stdout.strip() == "False"


def test_missing_matplotlib_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ImportError, match=r"sklearn-ifog\[plot\]"):
        plot_msd_by_model({"rbf": 1e-4})


def test_plot_msd_by_model_draws_the_noise_floor():
    ax = plot_msd_by_model({"rbf": 2e-4}, before=1e-2, floor=1e-4)
    (floor_line,) = [line for line in ax.get_lines() if line.get_label() == "noise floor"]
    np.testing.assert_allclose(floor_line.get_ydata(), [1e-4, 1e-4])
    assert floor_line.get_linestyle() == "--"
    with pytest.raises(ValueError, match="floor must be positive"):
        plot_msd_by_model({"rbf": 2e-4}, floor=0.0)
