"""A real thermal-chamber gyro recording, shipped with the package (MIT licence).

Source: pathfinder-for-autonomous-navigation/psim, commit
91d70adf87fe7d8d10d36dbec424fb48896fc45c, ``MATLAB/sensor_models/`` (``TVCtest3_7_20.csv``,
``ETUColdTest3_7_20.csv``); the licence travels beside the data in
``data/psim_tvc_2020_03_07/LICENSE``.
"""

import csv
from importlib import resources

import numpy as np
from sklearn.utils import Bunch

from sklearn_ifog._compat import StrOptions, validate_params

__all__ = ["load_psim_tvc"]

DATA_FOLDER = "psim_tvc_2020_03_07"
RECORDING_FILE = "TVCtest3_7_20.csv"
CHAMBER_LOG_FILE = "ETUColdTest3_7_20.csv"

# Facts from the source repository's analysis script (see the data's README.md).
GYRO_DRIVER_FACTOR = 0.5  # the gyro driver doubled the reading at recording time
SPIKE_THRESHOLD = -0.08  # rad/s, raw gyrox: rows at or below are spikes
BURST_GAP = 1.0  # s: a time step longer than this starts a new burst
RAD_PER_S_TO_DEG_PER_H = np.rad2deg(1.0) * 3600.0
ALIGNMENT_STEP = 10.0  # s, grid of the clock offset searched when mapping counts to deg C

FEATURE_NAMES = ["burst", "time", "temperature"]
TARGET_NAMES = ["gyro_x", "gyro_y", "gyro_z"]
FRAME_COLUMNS = [
    "time",
    "burst",
    "temperature_counts",
    "temperature",
    "gyro_x",
    "gyro_y",
    "gyro_z",
    "spike",
]
CHAMBER_LOG_COLUMNS = ["clock", "log_time", "time", "F2_degF", "F3_degF", "F4_degF", "C1_degC"]

_DESCR_TEMPLATE = """\
Real thermal-chamber gyro recording (MEMS, cold thermal-vacuum test, 2020-03-07)
--------------------------------------------------------------------------------

One MEMS gyro on a spacecraft engineering unit, held static while a thermal-vacuum chamber
cooled; it is not an IFOG. Use it as a real-world check of the workflow, not as a benchmark of
IFOG accuracy. Source: public repository pathfinder-for-autonomous-navigation/psim, commit
91d70adf87fe7d8d10d36dbec424fb48896fc45c, folder MATLAB/sensor_models/. MIT licence,
Copyright (c) 2020 Pathfinder for Autonomous Navigation (PAN); the licence text ships beside
the data (sklearn_ifog/datasets/data/psim_tvc_2020_03_07/LICENSE) and must stay with any copy.

Recording (TVCtest3_7_20.csv): 6,250 samples at 50 Hz in 25 bursts of 250 samples (5 s), one
burst every 300 s, about 2.03 h in all. A burst starts where the time step exceeds 1 s.

Frame columns
  time                s on the recording's own clock (its "time (ms)" / 1000; starts at 15.352)
  burst               burst index 0..24: the natural run/group column
  temperature_counts  the unit's own raw temperature reading, counts (65,249 falling to 63,123)
  temperature         deg C, temperature_counts mapped linearly (approximate, see below)
  gyro_x/y/z          rate, deg/h: the recorded rad/s times 0.5 (a driver error at recording
                      time, per the source's analysis script) times 180/pi*3600
  spike               True on rows whose raw gyrox <= -0.08 rad/s (the source's spike rule).
                      {n_spikes} rows match (rows 2340, 2570 and 3223, one sample each in bursts
                      9, 10 and 12; the source's script speaks of two spikes). They are kept and
                      marked unless drop_spikes=True, which removes them ({spike_note}).
The magnetometer columns of the source file are not loaded.

data: {feature_names}.
target: {target_names} (deg/h).
The gyro was static: the true rate is a constant (its own bias plus the unknown Earth-rate
component), so the thermal drift is measured against a constant; a model with an intercept
absorbs it.

Temperature in deg C (approximate)
  The recording's temperature is in raw counts; the chamber log (ETUColdTest3_7_20.csv,
  bunch.chamber_log) holds thermocouples read by hand every 5 minutes, 15:45 to 18:30 (F2, F3,
  F4 in deg F, C1 in deg C; its 14 trailing empty rows are not loaded). The two clocks are not
  tied, so the map is fitted: for each clock offset on a {step:g} s grid (log time =
  recording time + offset, both ends of the recording inside the log), the reference
  thermocouple ({reference}), linearly interpolated at the 25 burst-mean times, is regressed on
  the burst-mean counts by least squares; the offset with the smallest residual is kept. The
  offset absorbs both the unknown start time and the unit's thermal lag behind the
  thermocouple.
  This load: offset {offset:.0f} s, temperature = {intercept:.3f} + {slope:.6g} * counts
  ({counts_per_degree:.1f} counts per deg C), residual {rms:.2f} deg C RMS over the 25 bursts
  ({max_residual:.2f} deg C at worst); the temperature column runs from {t_first:.1f} to
  {t_last:.1f} deg C.
  The scale is only as good as that fit. C1 (the default) leaves a systematic
  S-shaped residual of about +/-0.4 deg C (0.29 deg C RMS); the unit's counts follow the mean
  of F2 and F3 (read in whole deg F) more closely, 0.09 deg C RMS
  (temperature_reference="F2F3", 237 instead of 173 counts per deg C, 20.6 to 11.8 deg C).
  The counts themselves are the unit's real sensor reading; only the deg C
  scale is approximate. The fitted values are in bunch.temperature_calibration.
"""


def _data_path(name):
    return resources.files("sklearn_ifog.datasets").joinpath("data", DATA_FOLDER, name)


def _read_recording():
    """Raw recording columns: time (s), gyro x/y/z (rad/s, as recorded), temperature counts."""
    with resources.as_file(_data_path(RECORDING_FILE)) as path:
        table = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64)
    time = table[:, 0] / 1000.0
    return time, table[:, 4:7], table[:, 7]


def _read_chamber_log():
    """Chamber log rows that hold readings: clock strings and the four thermocouples."""
    text = _data_path(CHAMBER_LOG_FILE).read_text(encoding="utf-8-sig")
    rows = list(csv.reader(text.splitlines()))
    header, body = rows[0], rows[1:]
    expected = ["Time", "F2 (F)", "F3 (F)", "F4 (F)", "C1 (C)"]
    if header[:5] != expected:
        raise ValueError(f"{CHAMBER_LOG_FILE}: expected columns {expected}, got {header[:5]}.")
    readings = [row[:5] for row in body if any(cell.strip() for cell in row[1:5])]
    clock = [row[0] for row in readings]
    values = np.array([[float(cell) for cell in row[1:5]] for row in readings])
    hours, minutes = np.array([[int(part) for part in c.split(":")] for c in clock]).T
    seconds = 3600.0 * hours + 60.0 * minutes
    return clock, seconds - seconds[0], values


def _burst_index(time):
    return np.concatenate([[0], np.cumsum(np.diff(time) > BURST_GAP)])


def _fit_counts_to_celsius(burst_time, burst_counts, log_time, log_temperature):
    """Fit the linear map counts -> deg C and the clock offset, as documented in DESCR.

    Returns the offset (s, log time = recording time + offset), intercept, slope and the
    residuals (deg C) at the burst means.
    """
    lowest = np.ceil((log_time[0] - burst_time[0]) / ALIGNMENT_STEP) * ALIGNMENT_STEP
    highest = log_time[-1] - burst_time[-1]
    offsets = np.arange(lowest, highest + 1e-9, ALIGNMENT_STEP)
    if offsets.size == 0:
        raise ValueError("The chamber log is shorter than the recording: cannot align them.")
    design = np.column_stack([np.ones_like(burst_counts), burst_counts])
    # One least-squares problem per candidate offset, all with the same design matrix.
    reference = np.interp(
        burst_time[np.newaxis, :] + offsets[:, np.newaxis], log_time, log_temperature
    )
    coefficients = np.linalg.lstsq(design, reference.T, rcond=None)[0]  # (2, n_offsets)
    residuals = reference.T - design @ coefficients
    best = int(np.argmin(np.sum(residuals**2, axis=0)))
    intercept, slope = coefficients[:, best]
    return float(offsets[best]), float(intercept), float(slope), residuals[:, best]


@validate_params(
    {
        "as_frame": ["boolean"],
        "return_X_y": ["boolean"],
        "drop_spikes": ["boolean"],
        "temperature_reference": [StrOptions({"C1", "F2F3"})],
    },
    prefer_skip_nested_validation=True,
)
def load_psim_tvc(
    *, as_frame=True, return_X_y=False, drop_spikes=False, temperature_reference="C1"
):
    """Load a real gyro + temperature thermal-chamber recording (MEMS, MIT licence).

    One static MEMS gyro on a spacecraft engineering unit, logged with its own temperature
    sensor while a thermal-vacuum chamber cooled (thermocouple C1: 21.5 to 8.8 deg C, 2020-03-07):
    6,250 samples at 50 Hz in 25 bursts of 5 s, one burst every 300 s, plus the chamber's
    hand-written thermocouple log. It is not an IFOG: use it to check the workflow on real
    data, not as a benchmark. The full description, the unit conversions and how approximate
    the deg C scale is are in ``DESCR``.

    Parameters
    ----------
    as_frame : bool, default=True
        If True, ``data`` and ``frame`` are pandas DataFrames, ``target`` a DataFrame and
        ``chamber_log`` a DataFrame (pandas needed). If False, NumPy arrays, ``frame`` None,
        ``chamber_log`` a Bunch of arrays.
    return_X_y : bool, default=False
        If True, return ``(data, target)`` instead of a Bunch.
    drop_spikes : bool, default=False
        If False, every row is kept and spikes are marked in the ``spike`` column (and
        ``bunch.spike``). If True, the rows marked as spikes are removed (3 rows);
        ``bunch.n_spikes_dropped`` says how many.
    temperature_reference : {"C1", "F2F3"}, default="C1"
        Chamber-log thermocouple that gives the raw counts a deg C scale: ``"C1"`` (deg C
        column) or ``"F2F3"`` (mean of F2 and F3, converted from deg F). See ``DESCR``.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with attributes:

        - ``frame``: DataFrame of shape (n_samples, 8), columns time (s), burst,
          temperature_counts, temperature (deg C), gyro_x, gyro_y, gyro_z (deg/h), spike
          (bool); the index is the row number in the recording. None if
          ``as_frame=False``.
        - ``data``: columns burst, time, temperature, shape (n_samples, 3).
        - ``target``: columns gyro_x, gyro_y, gyro_z (deg/h), shape (n_samples, 3).
        - ``spike``: boolean array, True on spike rows (all False after ``drop_spikes``).
        - ``n_spikes_dropped``: number of rows removed by ``drop_spikes``.
        - ``chamber_log``: the chamber log's 34 readings: clock ("HH:MM"), log_time (s from
          15:45), time (s on the recording's clock, by the fitted offset), F2_degF, F3_degF,
          F4_degF, C1_degC.
        - ``temperature_calibration``: Bunch with reference, offset (s), intercept (deg C),
          slope (deg C per count), rms_residual and max_residual (deg C).
        - ``feature_names``, ``target_names``: column names of ``data`` and ``target``.
        - ``DESCR``: description of the data set, its licence and its processing.
    (data, target) : tuple if ``return_X_y`` is True
        ``data`` of shape (n_samples, 3) and ``target`` of shape (n_samples, 3).

    Examples
    --------
    >>> from sklearn_ifog.datasets._real import load_psim_tvc
    >>> bunch = load_psim_tvc()
    >>> bunch.frame.shape
    (6250, 8)
    >>> int(bunch.frame["burst"].nunique()), int(bunch.frame["spike"].sum())
    (25, 3)
    >>> X, y = load_psim_tvc(return_X_y=True, drop_spikes=True)
    >>> X.shape, list(y.columns)
    ((6247, 3), ['gyro_x', 'gyro_y', 'gyro_z'])
    """
    time, gyro_raw, counts = _read_recording()
    burst = _burst_index(time)
    spike = gyro_raw[:, 0] <= SPIKE_THRESHOLD
    n_spikes = int(spike.sum())
    gyro = gyro_raw * (GYRO_DRIVER_FACTOR * RAD_PER_S_TO_DEG_PER_H)

    clock, log_time, log_values = _read_chamber_log()
    if temperature_reference == "C1":
        log_temperature = log_values[:, 3]
    else:
        log_temperature = (0.5 * (log_values[:, 0] + log_values[:, 1]) - 32.0) / 1.8
    n_bursts = burst[-1] + 1
    samples_per_burst = np.bincount(burst)
    burst_time = np.bincount(burst, weights=time) / samples_per_burst
    burst_counts = np.bincount(burst, weights=counts) / samples_per_burst
    offset, intercept, slope, residuals = _fit_counts_to_celsius(
        burst_time, burst_counts, log_time, log_temperature
    )
    temperature = intercept + slope * counts
    calibration = Bunch(
        reference=temperature_reference,
        offset=offset,
        intercept=intercept,
        slope=slope,
        rms_residual=float(np.sqrt(np.mean(residuals**2))),
        max_residual=float(np.max(np.abs(residuals))),
        n_bursts=int(n_bursts),
    )

    keep = ~spike if drop_spikes else np.ones_like(spike)
    n_dropped = int(n_spikes - spike[keep].sum())
    columns = {
        "time": time[keep],
        "burst": burst[keep],
        "temperature_counts": counts[keep].astype(np.int64),
        "temperature": temperature[keep],
        "gyro_x": gyro[keep, 0],
        "gyro_y": gyro[keep, 1],
        "gyro_z": gyro[keep, 2],
        "spike": spike[keep],
    }
    log_columns = {
        "clock": np.array(clock),
        "log_time": log_time,
        "time": log_time - offset,
        "F2_degF": log_values[:, 0],
        "F3_degF": log_values[:, 1],
        "F4_degF": log_values[:, 2],
        "C1_degC": log_values[:, 3],
    }
    descr = _DESCR_TEMPLATE.format(
        n_spikes=n_spikes,
        spike_note=(
            f"this load dropped {n_dropped} rows" if drop_spikes else "this load kept them"
        ),
        feature_names=", ".join(FEATURE_NAMES),
        target_names=", ".join(TARGET_NAMES),
        step=ALIGNMENT_STEP,
        reference=temperature_reference,
        offset=offset,
        intercept=intercept,
        slope=slope,
        counts_per_degree=1.0 / slope,
        rms=calibration.rms_residual,
        max_residual=calibration.max_residual,
        t_first=temperature[0],
        t_last=temperature[-1],
    )

    if as_frame:
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - pandas is in the tests extra
            raise ImportError(
                "load_psim_tvc(as_frame=True) needs pandas (pip install "
                "'sklearn-ifog[pandas]'); or pass as_frame=False."
            ) from exc
        # Rows keep the row number of the recording as their label, so that dropped spikes
        # leave visible gaps.
        frame = pd.DataFrame(columns, index=np.flatnonzero(keep))[FRAME_COLUMNS]
        data = frame[FEATURE_NAMES]
        target = frame[TARGET_NAMES]
        chamber_log = pd.DataFrame(log_columns)[CHAMBER_LOG_COLUMNS]
    else:
        frame = None
        data = np.column_stack([columns[name] for name in FEATURE_NAMES]).astype(np.float64)
        target = np.column_stack([columns[name] for name in TARGET_NAMES])
        chamber_log = Bunch(**log_columns)

    if return_X_y:
        return data, target
    return Bunch(
        frame=frame,
        data=data,
        target=target,
        spike=columns["spike"],
        n_spikes_dropped=n_dropped,
        chamber_log=chamber_log,
        temperature_calibration=calibration,
        feature_names=list(FEATURE_NAMES),
        target_names=list(TARGET_NAMES),
        DESCR=descr,
    )
