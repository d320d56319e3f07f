"""The scale-factor metrics (issue 44, point 3) on constructed data with known ppm."""

import numpy as np
import pytest

from sklearn_ifog.metrics import (
    residual_by_input_rate,
    scale_factor_asymmetry,
    scale_factor_error,
    scale_factor_linearity,
    scale_factor_peak_to_peak,
)

pytest.importorskip("pandas")

RATES = np.array([0.0, 1.0, -1.0, 10.0, -10.0, 100.0, -100.0, 300.0, -300.0]) * 3600.0
EDGES = [-40.0, -10.0, 20.0, 50.0, 80.0]
# A known scale-factor error per bin (ppm) and bias per bin (deg/h), per run.
PPM = {"a": [-150.0, -20.0, 90.0, 310.0], "b": [-140.0, -10.0, 100.0, 320.0]}
BIAS = {"a": [0.3, -0.2, 0.1, 0.5], "b": [1.3, 0.8, -0.9, 0.2]}


def _campaign(rng=None):
    """Two runs over four bins, every input rate in every bin; error exactly b + Ω s."""
    columns = {"omega": [], "error": [], "temperature": [], "run": []}
    centres = (np.array(EDGES[:-1]) + np.array(EDGES[1:])) / 2.0
    for run in ("a", "b"):
        for k, centre in enumerate(centres):
            omega = np.repeat(RATES, 3)
            temperature = centre + np.linspace(-10.0, 10.0, omega.size)
            error = BIAS[run][k] + omega * PPM[run][k] * 1e-6
            if rng is not None:
                error = error + rng.normal(0.0, 0.01, omega.size)
            columns["omega"].append(omega)
            columns["error"].append(error)
            columns["temperature"].append(temperature)
            columns["run"].append(np.full(omega.size, run))
    return {name: np.concatenate(values) for name, values in columns.items()}


def test_scale_factor_error_recovers_each_bins_slope_per_run():
    data = _campaign()
    table = scale_factor_error(
        data["omega"], data["error"], data["temperature"], run=data["run"], bins=EDGES
    )
    assert table["run"].tolist() == ["a"] * 4 + ["b"] * 4 + ["(all runs)"] * 4
    np.testing.assert_allclose(table["temperature"].to_numpy()[:4], [-25.0, 5.0, 35.0, 65.0])
    np.testing.assert_allclose(table["T_low"].to_numpy()[:4], EDGES[:-1])
    np.testing.assert_allclose(table["T_high"].to_numpy()[:4], EDGES[1:])
    for run in ("a", "b"):
        ppm = table.loc[table["run"] == run, "ppm"].to_numpy()
        np.testing.assert_allclose(ppm, PPM[run], rtol=1e-10)
    # pooled with one intercept per run: the runs' biases (1 deg/h apart) do not bend it,
    # the slope is the mean of the runs' (equal rows, equal rate spread)
    pooled = table.loc[table["run"] == "(all runs)", "ppm"].to_numpy()
    np.testing.assert_allclose(pooled, np.mean([PPM["a"], PPM["b"]], axis=0), rtol=1e-10)
    assert table["samples"].tolist() == [27] * 8 + [54] * 4


def test_scale_factor_error_zero_rate_bin_is_nan_not_zero():
    data = _campaign()
    omega = data["omega"].copy()
    cold = data["temperature"] < -10.0
    omega[cold] = 0.0  # the coldest bin sees no rotation
    error = np.where(cold, 0.3, data["error"])
    table = scale_factor_error(omega, error, data["temperature"], bins=EDGES)
    ppm = table["ppm"].to_numpy()
    assert np.isnan(ppm[0])
    np.testing.assert_allclose(ppm[1:], np.mean([PPM["a"], PPM["b"]], axis=0)[1:], rtol=1e-10)
    assert table["run"].tolist() == ["(all runs)"] * 4
    # a single non-zero rate in a bin (no spread, no slope) is NaN as well
    omega[cold] = 3600.0
    assert np.isnan(scale_factor_error(omega, error, data["temperature"], bins=EDGES)["ppm"][0])


def test_scale_factor_error_bins_and_empty_bins():
    data = _campaign()
    # integer bins: equal bins over the rows' range; the hottest edge is in the last bin
    table = scale_factor_error(data["omega"], data["error"], data["temperature"], bins=2)
    assert table["samples"].sum() == data["omega"].size
    np.testing.assert_allclose(table["T_low"], [-35.0, 20.0])
    # edges beyond the data: a bin with no row has NaN and 0 samples; rows outside are out
    table = scale_factor_error(
        data["omega"], data["error"], data["temperature"], bins=[-100.0, -50.0, -10.0]
    )
    assert table["samples"].tolist() == [0, 54]
    assert np.isnan(table["ppm"][0])


def test_peak_to_peak_linearity_asymmetry_known_values():
    data = _campaign()
    args = data["omega"], data["error"], data["temperature"]
    pooled = np.mean([PPM["a"], PPM["b"]], axis=0)
    assert scale_factor_peak_to_peak(*args, run=data["run"], bins=EDGES) == pytest.approx(
        np.ptp(pooled), rel=1e-10
    )
    # one bin with a scale factor: no peak-to-peak to read
    assert np.isnan(scale_factor_peak_to_peak(*args, bins=[-40.0, -10.0]))

    omega = np.repeat(RATES, 5)
    linear = 0.4 + omega * 120e-6
    assert scale_factor_linearity(omega, linear) == pytest.approx(0.0, abs=1e-9)
    assert scale_factor_asymmetry(omega, linear) == pytest.approx(0.0, abs=1e-9)
    # a cubic bend: the per-rate means leave the best line by a known amount
    bent = linear + 2e-15 * omega**3
    levels = np.unique(omega)
    means = 0.4 + levels * 120e-6 + 2e-15 * levels**3
    line = np.polyval(np.polyfit(levels, means, 1), levels)
    expected = 1e6 * np.max(np.abs(means - line)) / np.max(np.abs(levels))
    assert expected > 10.0
    assert scale_factor_linearity(omega, bent) == pytest.approx(expected, rel=1e-9)
    # 150 ppm for positive inputs, 100 for negative: 50 ppm
    asymmetric = 0.4 + omega * np.where(omega > 0, 150e-6, 100e-6)
    assert scale_factor_asymmetry(omega, asymmetric) == pytest.approx(50.0, rel=1e-9)
    # one sign only, or no rotation: no asymmetry and no linearity to read
    assert np.isnan(scale_factor_asymmetry(np.abs(omega), asymmetric))
    assert np.isnan(scale_factor_linearity(np.zeros(5), np.ones(5)))


def test_residual_by_input_rate_rms_per_rate_and_resolution():
    omega = np.repeat(RATES, 4)
    residual = np.tile([1.0, -1.0, 3.0, -3.0], RATES.size) * (1.0 + np.abs(omega) / 3600.0)
    table = residual_by_input_rate(omega, residual)
    np.testing.assert_array_equal(table.index.to_numpy(), np.sort(RATES))
    np.testing.assert_allclose(table["rms"], np.sqrt(5.0) * (1.0 + np.abs(np.sort(RATES)) / 3600))
    np.testing.assert_allclose(table["mean"], 0.0, atol=1e-12)
    assert table["samples"].tolist() == [4] * RATES.size
    # a measured reference: rates within the resolution are one rate
    noisy = omega + np.tile([0.2, -0.2, 0.1, -0.1], RATES.size)
    assert residual_by_input_rate(noisy, residual).shape[0] == omega.size
    grouped = residual_by_input_rate(noisy, residual, resolution=10.0)
    np.testing.assert_allclose(grouped["rms"], table["rms"])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"error": np.ones(3)}, "error has 3 values, input_rate has 4"),
        ({"temperature": [1.0, np.nan, 2.0, 3.0]}, "temperature"),
        ({"run": ["a", "b"]}, "run has shape"),
        ({"bins": 0}, "bins must be a positive number of bins"),
        ({"bins": [10.0]}, "bins as edges must be at least two"),
        ({"bins": [10.0, 0.0]}, "bins as edges must increase strictly"),
    ],
)
def test_scale_factor_error_bad_input_names_the_parameter(kwargs, message):
    args = {
        "input_rate": np.array([0.0, 3600.0, -3600.0, 0.0]),
        "error": np.zeros(4),
        "temperature": np.array([1.0, 2.0, 3.0, 4.0]),
    }
    keywords = {}
    for name, value in kwargs.items():
        (args if name in args else keywords)[name] = value
    with pytest.raises(ValueError, match=message):
        scale_factor_error(args["input_rate"], args["error"], args["temperature"], **keywords)


def test_bad_bins_type_and_resolution():
    omega, error = np.array([0.0, 3600.0]), np.zeros(2)
    with pytest.raises(TypeError, match="bins must be a number of bins"):
        scale_factor_error(omega, error, [1.0, 2.0], bins=2.5)
    with pytest.raises(ValueError, match="resolution must be a positive"):
        residual_by_input_rate(omega, error, resolution=0.0)
    with pytest.raises(ValueError, match="input_rate"):
        scale_factor_linearity([[0.0, 1.0]], error)


def test_plot_scale_factor_draws_the_pooled_ppm_before_and_after():
    pytest.importorskip("matplotlib")
    from sklearn_ifog.plotting import plot_scale_factor

    data = _campaign()
    args = data["omega"], data["temperature"]
    after = data["error"] - data["omega"] * 1e-6 * np.interp(
        data["temperature"], [-25.0, 5.0, 35.0, 65.0], np.mean([PPM["a"], PPM["b"]], axis=0)
    )
    ax = plot_scale_factor(*args, data["error"], after, run=data["run"], bins=EDGES)
    assert ax.get_legend_handles_labels()[1] == ["before", "after"]
    lines = {line.get_label(): line for line in ax.get_lines()}
    np.testing.assert_allclose(lines["before"].get_xdata(), [-25.0, 5.0, 35.0, 65.0])
    np.testing.assert_allclose(
        lines["before"].get_ydata(), np.mean([PPM["a"], PPM["b"]], axis=0), rtol=1e-10
    )
    expected = scale_factor_error(*args[:1], after, args[1], run=data["run"], bins=EDGES)
    np.testing.assert_allclose(
        lines["after"].get_ydata(), expected["ppm"].to_numpy()[-4:], rtol=1e-10
    )
    with pytest.raises(ValueError, match="No temperature bin has a scale factor"):
        plot_scale_factor(np.zeros(4), np.arange(4.0), np.ones(4))
