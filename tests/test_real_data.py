"""Tests of the shipped real recording and its loader (sklearn_ifog.datasets._real)."""

from importlib import resources

import numpy as np
import pandas as pd
import pytest

from sklearn_ifog.datasets._real import _fit_counts_to_celsius, load_psim_tvc

DEG_PER_H_PER_RAD_PER_S = 180.0 / np.pi * 3600.0
DATA = resources.files("sklearn_ifog.datasets").joinpath("data", "psim_tvc_2020_03_07")
SPIKE_ROWS = [2340, 2570, 3223]


@pytest.fixture(scope="module")
def raw():
    """The shipped CSV read independently of the loader."""
    with resources.as_file(DATA.joinpath("TVCtest3_7_20.csv")) as path:
        return pd.read_csv(path)


@pytest.fixture(scope="module")
def bunch():
    return load_psim_tvc()


def test_licence_and_readme_ship_beside_the_data():
    licence = DATA.joinpath("LICENSE").read_text(encoding="utf-8")
    assert licence.startswith("MIT License")
    assert "Pathfinder for Autonomous Navigation (PAN)" in licence
    assert "shall be included in all" in licence
    assert "91d70adf87fe7d8d10d36dbec424fb48896fc45c" in DATA.joinpath("README.md").read_text()


def test_frame_layout(bunch, raw):
    frame = bunch.frame
    assert frame.shape == (6250, 8)
    assert list(frame.columns) == [
        "time",
        "burst",
        "temperature_counts",
        "temperature",
        "gyro_x",
        "gyro_y",
        "gyro_z",
        "spike",
    ]
    assert frame["spike"].dtype == bool
    np.testing.assert_allclose(frame["time"], raw["time (ms)"] / 1000.0, rtol=0, atol=1e-12)
    assert frame["time"].iloc[0] == pytest.approx(15.352)
    assert frame["time"].iloc[-1] == pytest.approx(7339.962)
    np.testing.assert_array_equal(frame["temperature_counts"], raw["temp"])
    pd.testing.assert_frame_equal(bunch.data, frame[["burst", "time", "temperature"]])
    pd.testing.assert_frame_equal(bunch.target, frame[["gyro_x", "gyro_y", "gyro_z"]])
    assert bunch.feature_names == ["burst", "time", "temperature"]
    assert bunch.target_names == ["gyro_x", "gyro_y", "gyro_z"]


def test_bursts(bunch):
    frame = bunch.frame
    np.testing.assert_array_equal(np.bincount(frame["burst"]), np.full(25, 250))
    np.testing.assert_array_equal(frame["burst"], np.repeat(np.arange(25), 250))
    steps = np.diff(frame["time"].to_numpy())
    new_burst = np.diff(frame["burst"].to_numpy()) == 1
    assert np.all(steps[~new_burst] <= 0.025)  # 50 Hz inside a burst
    starts = frame.groupby("burst")["time"].first().to_numpy()
    assert np.all((np.diff(starts) > 300.0) & (np.diff(starts) < 310.0))


def test_gyro_units_and_driver_factor(bunch, raw):
    for axis in "xyz":
        expected = raw[f"gyro{axis} rad/s"].to_numpy() * 0.5 * DEG_PER_H_PER_RAD_PER_S
        np.testing.assert_allclose(bunch.frame[f"gyro_{axis}"], expected, rtol=1e-14)
    # First row: gyrox -6.53e-02 rad/s recorded, i.e. -0.03265 rad/s = -6734.5 deg/h.
    assert bunch.frame["gyro_x"].iloc[0] == pytest.approx(-6734.546, abs=1e-3)


def test_spikes_marked_not_dropped(bunch, raw):
    spike = bunch.frame["spike"].to_numpy()
    np.testing.assert_array_equal(np.flatnonzero(spike), SPIKE_ROWS)
    np.testing.assert_array_equal(spike, raw["gyrox rad/s"].to_numpy() <= -0.08)
    np.testing.assert_array_equal(bunch.spike, spike)
    assert bunch.n_spikes_dropped == 0
    spike_rate = -0.102 * 0.5 * DEG_PER_H_PER_RAD_PER_S
    np.testing.assert_allclose(bunch.frame.loc[spike, "gyro_x"], spike_rate)
    # Well clear of the rule: the other rows reach -0.0754 rad/s at most (raw).
    assert bunch.frame.loc[~spike, "gyro_x"].min() > -0.077 * 0.5 * DEG_PER_H_PER_RAD_PER_S
    assert "3 rows match" in bunch.DESCR
    assert "this load kept them" in bunch.DESCR


def test_drop_spikes_is_explicit(bunch):
    dropped = load_psim_tvc(drop_spikes=True)
    assert dropped.frame.shape == (6247, 8)
    assert dropped.n_spikes_dropped == 3
    assert not dropped.frame["spike"].any()
    # Rows keep their label (the row number in the recording).
    expected = bunch.frame.drop(index=SPIKE_ROWS)
    pd.testing.assert_frame_equal(dropped.frame, expected)
    assert 2340 not in dropped.frame.index
    assert dropped.frame.index[2340] == 2341
    assert "this load dropped 3 rows" in dropped.DESCR


def test_temperature_falls_and_matches_the_chamber_log(bunch):
    frame = bunch.frame
    calibration = bunch.temperature_calibration
    assert calibration.reference == "C1"
    assert calibration.offset == 460.0
    assert calibration.slope > 0.0
    assert 1.0 / calibration.slope == pytest.approx(172.8, abs=0.1)  # counts per deg C
    assert calibration.rms_residual == pytest.approx(0.285, abs=0.005)
    np.testing.assert_allclose(
        frame["temperature"],
        calibration.intercept + calibration.slope * frame["temperature_counts"],
        rtol=1e-12,
    )
    burst_mean = frame.groupby("burst")["temperature"].mean().to_numpy()
    assert np.all(np.diff(burst_mean) < 0)  # falls at every burst
    assert 22.0 < burst_mean[0] < 23.0
    assert 10.0 < burst_mean[-1] < 11.0
    # At the fitted alignment every burst is within 0.5 deg C of the interpolated C1 log.
    log = bunch.chamber_log
    burst_time = frame.groupby("burst")["time"].mean().to_numpy()
    c1 = np.interp(burst_time, log["time"], log["C1_degC"])
    assert np.max(np.abs(burst_mean - c1)) < 0.5
    assert f"offset {calibration.offset:.0f} s" in bunch.DESCR
    assert f"residual {calibration.rms_residual:.2f} deg C RMS" in bunch.DESCR


def test_f2f3_reference_fits_closer():
    bunch = load_psim_tvc(temperature_reference="F2F3")
    calibration = bunch.temperature_calibration
    assert calibration.rms_residual < 0.1  # DESCR says 0.09
    assert 1.0 / calibration.slope == pytest.approx(237.4, abs=0.5)  # DESCR says 237
    burst_mean = bunch.frame.groupby("burst")["temperature"].mean().to_numpy()
    assert burst_mean[0] == pytest.approx(20.6, abs=0.05)
    assert burst_mean[-1] == pytest.approx(11.8, abs=0.05)
    # Only the deg C scale changes.
    np.testing.assert_array_equal(
        bunch.frame["temperature_counts"], load_psim_tvc().frame["temperature_counts"]
    )


def test_chamber_log(bunch):
    log = bunch.chamber_log
    assert list(log.columns) == [
        "clock",
        "log_time",
        "time",
        "F2_degF",
        "F3_degF",
        "F4_degF",
        "C1_degC",
    ]
    assert len(log) == 34
    assert (log["clock"].iloc[0], log["clock"].iloc[-1]) == ("15:45", "18:30")
    np.testing.assert_array_equal(log["log_time"], 300.0 * np.arange(34))
    np.testing.assert_array_equal(log["time"], log["log_time"] - 460.0)
    assert (log["C1_degC"].iloc[0], log["C1_degC"].iloc[-1]) == (21.5, 8.8)
    assert log["F4_degF"].min() == -45.0
    assert not log.isna().any().any()


def test_numpy_output(bunch):
    arrays = load_psim_tvc(as_frame=False)
    assert arrays.frame is None
    assert arrays.data.dtype == np.float64
    np.testing.assert_array_equal(arrays.data, bunch.data.to_numpy(dtype=np.float64))
    np.testing.assert_array_equal(arrays.target, bunch.target.to_numpy())
    assert list(arrays.chamber_log["clock"][:2]) == ["15:45", "15:50"]
    X, y = load_psim_tvc(as_frame=False, return_X_y=True, drop_spikes=True)
    assert X.shape == (6247, 3)
    assert y.shape == (6247, 3)


def test_return_X_y(bunch):
    X, y = load_psim_tvc(return_X_y=True)
    pd.testing.assert_frame_equal(X, bunch.data)
    pd.testing.assert_frame_equal(y, bunch.target)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"temperature_reference": "F4"}, "'temperature_reference' parameter of load_psim_tvc"),
        ({"drop_spikes": "yes"}, "'drop_spikes' parameter"),
        ({"as_frame": None}, "'as_frame' parameter"),
    ],
)
def test_parameter_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        load_psim_tvc(**kwargs)


def test_alignment_fit_recovers_a_known_map():
    log_time = 300.0 * np.arange(20)
    log_temperature = 20.0 - 8.0 * np.sin(np.linspace(0.0, 2.0, 20))  # curved, not linear
    burst_time = 100.0 + 300.0 * np.arange(12)
    true_offset = 1230.0
    true_temperature = np.interp(burst_time + true_offset, log_time, log_temperature)
    counts = (true_temperature + 300.0) / 0.005  # temperature = -300 + 0.005 * counts
    offset, intercept, slope, residuals = _fit_counts_to_celsius(
        burst_time, counts, log_time, log_temperature
    )
    assert offset == true_offset
    assert intercept == pytest.approx(-300.0, rel=1e-8)
    assert slope == pytest.approx(0.005, rel=1e-8)
    np.testing.assert_allclose(residuals, 0.0, atol=1e-8)
    with pytest.raises(ValueError, match="chamber log is shorter than the recording"):
        _fit_counts_to_celsius(burst_time, counts, log_time[:5], log_temperature[:5])
