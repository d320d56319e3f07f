"""
Outside the calibration: calibrated warm, used cold
===================================================

A drift model is calibrated on the thermal tests someone had time to run. Here they were
heating runs, the reference paper's profile; then the gyro is used on a run that starts
cold, goes colder than anything calibrated, and cools. Every row of that run lies outside
what the model was calibrated on, and a flexible model fitted on strongly correlated thermal
features can return anything there: sometimes a fair extrapolation, sometimes worse than no
compensation at all. This example shows how :class:`~sklearn_ifog.CompensationPipeline`
finds those rows (its calibration domain), what its three ``uncalibrated`` policies predict
there, and how the user is told. The user guide explains the why:
:ref:`outside_calibration`.
"""

# %%
# Calibrate on heating runs
# -------------------------
# One simulated gyro, two runs of the reference paper's profile (soak low, ramp up, soak
# high: heating only) with the chamber between 10 and 40 °C, one sample every 2 minutes.
# :func:`~sklearn_ifog.make_compensation_pipeline` builds the default model (the
# thermal-state features, a scaler, the RBF network); at ``fit`` it also learns where it was
# calibrated (``domain_``, a :class:`~sklearn_ifog.CalibrationDomain`) and a conservative
# fallback (``fallback_``).
import textwrap
import warnings

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from sklearn.linear_model import LinearRegression

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.metrics import mean_squared_deviation

SETTINGS = dict(n_units=1, azimuths=[0.0], sampling_period=120.0)
calibration = make_thermal_campaign(
    n_runs=2, profile="paper", temperature_range=(10.0, 40.0), random_state=0, **SETTINGS
)
X, y = calibration.data, calibration.target
model = make_compensation_pipeline(RBFNetRegressor(random_state=0)).fit(X, y)

T = list(model.feature_names_out_).index("T")  # the temperature among the features
T_MIN, T_MAX = model.domain_.data_min_[T], model.domain_.data_max_[T]
print("features:", list(model.feature_names_out_))
print(f"calibrated temperatures: {T_MIN:.2f} to {T_MAX:.2f} degC")
print("fallback:", model.fallback_)

# %%
# With several calibration runs that repeat it, the fallback is a plane in T and the rate dT
# (its rate clipped to the calibrated magnitude), going on beyond a calibrated extreme only
# where it extrapolated there when that extreme was held out, and held flat from the edge
# otherwise (``hold_below`` / ``hold_above``). With one run it is a line in T only where its
# slope extrapolates at the calibration's own extremes; otherwise its slope is 0 and it is
# the calibration's mean drift: exactly no thermal compensation.
#
# A run of the same gyro that goes colder, and cools
# --------------------------------------------------
# The same ``random_state`` draws the same unit; the ``"cycle"`` profile goes low, high and
# low again, with the chamber down to −10 °C. The run starts cold: the gyro is switched on
# at a temperature the calibration never started from, so its thermal-state features (the
# lags of T) start from a value the calibration never paired with that temperature.
new = make_thermal_campaign(
    n_runs=1, profile="cycle", temperature_range=(-10.0, 40.0), random_state=0, **SETTINGS
)
X_new, y_new = new.data, new.target
distance = model.calibration_distance(X_new)
outside = model.outside_calibration(X_new)
print(f"new run: {X_new['temperature'].min():.2f} to {X_new['temperature'].max():.2f} degC")
print(f"rows outside the calibration domain: {outside.sum()} of {outside.size}")
print(f"largest distance: {distance.max():.3g} (threshold {model.domain_.threshold_:.3g})")

# %%
# Predicting there gives one :class:`~sklearn_ifog.OutsideCalibrationWarning` per call. It
# is an ordinary Python warning: record it to read it, and filter it with the
# :mod:`warnings` module once it has been read (here, for the rest of the example).
from sklearn_ifog import OutsideCalibrationWarning

with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    model.predict(X_new)
print(textwrap.fill(f"{caught[0].category.__name__}: {caught[0].message}", 70))
warnings.simplefilter("ignore", OutsideCalibrationWarning)

# %%
# The three policies
# ------------------
# ``uncalibrated`` is an ordinary parameter read at ``predict``: ``set_params`` switches it
# without refitting. ``"none"`` is the network's own extrapolation, ``"clip"`` the network at
# the nearest point of the domain, ``"blend"`` (the default) moves smoothly from the network
# to the fallback as a row lies farther out. Their MSD on the new run, (deg/h)², next to no
# thermal compensation (the calibration's mean drift removed) and to what gyro firmware does
# (PX4, ArduPilot): a line in T fitted on the calibration and evaluated at the temperature
# held to the calibrated ``[TMIN, TMAX]`` (``held line in T``):
POLICIES = ("none", "clip", "blend")


def held_line(X_calibration, y_calibration, X_new):
    """The firmware peer: a line in T, its temperature clamped to the calibrated range."""
    t_cal = X_calibration[["temperature"]].to_numpy()
    line = LinearRegression().fit(t_cal, y_calibration)
    held = X_new[["temperature"]].to_numpy().clip(t_cal.min(), t_cal.max())
    return line.predict(held)


def compensate(model, X_new, y_new, X_calibration, y_calibration, scored=None):
    """Every policy's prediction, and the MSD of each, of uncompensated and of the held line
    in T on ``scored``."""
    default = model.uncalibrated
    predictions = {}
    for policy in POLICIES:
        predictions[policy] = model.set_params(uncalibrated=policy).predict(X_new)
    model.set_params(uncalibrated=default)
    scored = np.ones(len(y_new), dtype=bool) if scored is None else scored
    y_scored = np.asarray(y_new)[scored]
    msd = {"uncompensated": mean_squared_deviation(y_scored, 0 * y_scored + y_calibration.mean())}
    firmware = held_line(X_calibration, y_calibration, X_new)
    msd["held line in T"] = mean_squared_deviation(y_scored, firmware[scored])
    for policy, prediction in predictions.items():
        msd[policy] = mean_squared_deviation(y_scored, prediction[scored])
    return predictions, pd.Series(msd)


def msd_table(msd):
    table = pd.DataFrame({"MSD": msd, "MSD / uncompensated": msd / msd["uncompensated"]})
    return table.to_string(float_format="{:.3g}".format)


predictions, msd = compensate(model, X_new, y_new, X, y)
print(msd_table(msd))


# %%
# Drift, predictions and distance against time. The shaded stretches are the rows outside
# the domain (contiguous runs of ``outside_calibration``, found with :func:`numpy.diff`);
# the grey band in the top panel is the calibrated temperature range, the firmware's usual
# ``[TMIN, TMAX]``.
def shade(ax, time, mask):
    """Shade every contiguous stretch of ``mask`` (one bool per row) along ``time``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        ax.axvspan(time[start], time[stop - 1], color="tab:red", alpha=0.12, lw=0)


hours = (X_new["time"] / 3600).to_numpy()
fig, (ax_t, ax_drift, ax_d) = plt.subplots(3, 1, sharex=True, figsize=(8, 7.5))
ax_t.axhspan(T_MIN, T_MAX, color="0.85", label="calibrated")
ax_t.plot(hours, X_new["temperature"], color="tab:red", label="sensor")
ax_t.set_ylabel("temperature (°C)")
ax_t.legend(loc="lower right", fontsize="small")
ax_drift.plot(hours, y_new, color="0.6", lw=0.8, label="measured drift")
for policy, prediction in predictions.items():
    ax_drift.plot(hours, prediction, lw=1.5, label=f'uncalibrated="{policy}"')
ax_drift.set_ylabel("drift (deg/h)")
ax_drift.legend(fontsize="small", ncol=4, loc="upper left")
ax_d.semilogy(hours, np.maximum(distance, 1e-3), color="k")
ax_d.axhline(model.domain_.threshold_, color="tab:red", ls="--", label="threshold")
ax_d.set_ylabel("calibration distance")
ax_d.set_xlabel("time (h)")
ax_d.legend(fontsize="small")
for ax in (ax_t, ax_drift, ax_d):
    shade(ax, hours, outside)
fig.tight_layout()

# %%
# The warm rows are shaded too. While it heats through the calibrated temperatures the gyro
# still carries its cold start: its slow lags are farther behind T than in any calibration
# run. From the top of the cycle on it *cools*, which the heating calibration never did.
# Neither shows on a thermometer.
#
# What a range check sees
# -----------------------
# :meth:`~sklearn_ifog.CalibrationDomain.excess` gives, for every feature, how far a row
# lies beyond that feature's own calibrated range, in the feature's units: for ``T``,
# degrees below the coldest (negative) or above the warmest (positive) calibrated
# temperature. A :class:`~sklearn_ifog.CalibrationDomain` fitted on the temperature column
# alone is the firmware's ``[TMIN, TMAX]`` check; it sees only the cold rows.
from sklearn_ifog import CalibrationDomain

features = np.asarray(model[:1].transform(X_new))  # the raw thermal features
excess = model.domain_.excess(features)
range_only = CalibrationDomain(temperature=0).fit(X[["temperature"]])
range_flags = range_only.predict(X_new[["temperature"]]) == -1
print(f"coldest row: {-excess[:, T].min():.2f} degC below the calibrated range")
print(f"rows outside [TMIN, TMAX]:              {range_flags.sum()}")
print(f"rows outside some feature's own range:  {(excess != 0).any(axis=1).sum()}")
print(f"rows outside the decorrelated domain:   {outside.sum()} of {outside.size}")


# %%
# On this run a range check on *every* feature catches the warm rows too (compare the
# counts above): the lag excesses of a cold start and of a cooling run leave their
# heating-only ranges. That is not always so: the two-sensor example of
# :ref:`outside_calibration` is a combination that passes every per-feature check. The
# excess of T, with the rows outside ``[TMIN, TMAX]`` shaded:
fig, ax = plt.subplots(figsize=(8, 2.8))
ax.plot(hours, excess[:, T], color="tab:blue")
ax.axhline(0.0, color="0.5", lw=0.8)
shade(ax, hours, range_flags)
ax.set_xlabel("time (h)")
ax.set_ylabel("T beyond its range (°C)")
ax.set_title("excess of T; shaded: outside [TMIN, TMAX]")
fig.tight_layout()

# %%
# Other units
# -----------
# One unit is one draw. The same experiment on the first eight simulated units (the seed
# draws the unit), each calibrated on its own heating runs and used on its own cold cycle;
# MSD over the uncompensated MSD (below 1: better than no thermal compensation).
ratios = {}
for seed in range(8):
    cal = make_thermal_campaign(
        n_runs=2, profile="paper", temperature_range=(10.0, 40.0), random_state=seed, **SETTINGS
    )
    run = make_thermal_campaign(
        n_runs=1, profile="cycle", temperature_range=(-10.0, 40.0), random_state=seed, **SETTINGS
    )
    unit_model = make_compensation_pipeline(RBFNetRegressor(random_state=0))
    unit_model.fit(cal.data, cal.target)
    _, unit_msd = compensate(unit_model, run.data, run.target, cal.data, cal.target)
    ratios[seed] = unit_msd[[*POLICIES, "held line in T"]] / unit_msd["uncompensated"]
ratios = pd.DataFrame(ratios).T.rename_axis("unit (seed)")
print(ratios.to_string(float_format="{:.2f}".format))
print("units worse than uncompensated:")
print((ratios > 1).sum().to_string())

# %%
# The real recording
# ------------------
# :func:`~sklearn_ifog.datasets.load_psim_tvc` is a real (MEMS) gyro logged through a
# cooling thermal-vacuum test: 25 bursts of 5 s, 300 s apart. Averaged to one row per second
# and taken as one run, it is calibrated on the first 12 bursts (the warmer ones) and
# compensated, on gyro x, on the others (colder than anything calibrated). The model
# predicts the whole run, so that the features of the later bursts keep their thermal
# history; only the later bursts are scored. The gyro was static: its true rate is a
# constant, which the calibration mean absorbs.
from sklearn_ifog.datasets import load_psim_tvc

frame = load_psim_tvc(drop_spikes=True).frame
seconds = (
    frame.groupby(np.floor(frame["time"]))
    .agg(
        burst=("burst", "first"),
        time=("time", "mean"),
        temperature=("temperature", "mean"),
        gyro_x=("gyro_x", "mean"),
    )
    .reset_index(drop=True)
    .assign(run=0)
)
X_real, y_real = seconds[["run", "time", "temperature"]], seconds["gyro_x"]
train = (seconds["burst"] <= 11).to_numpy()
real_model = make_compensation_pipeline(RBFNetRegressor(random_state=0))
real_model.fit(X_real[train], y_real[train])
real_predictions, real_msd = compensate(
    real_model, X_real, y_real, X_real[train], y_real[train], scored=~train
)
real_outside = real_model.outside_calibration(X_real)
print("fallback:", real_model.fallback_)
print(f"compensated rows outside the domain: {real_outside[~train].mean():.0%}")
print(msd_table(real_msd))

real_hours = (seconds["time"] / 3600).to_numpy()
offset = y_real[train].mean()
fig, ax = plt.subplots(figsize=(8, 3.5))
ax.plot(real_hours, y_real - offset, "o", color="0.6", ms=6, mfc="none", label="measured")
for policy in ("none", "blend"):
    ax.plot(
        real_hours, real_predictions[policy] - offset, ".", ms=3, label=f'uncalibrated="{policy}"'
    )
shade(ax, real_hours, real_outside)
ax.set_xlabel("time (h)")
ax.set_ylabel("gyro x − calibration mean (deg/h)")
ax.legend(fontsize="small")
fig.tight_layout()

# %%
# What the numbers show
# ---------------------
# The tables are computed when this page is built. Reading them:
#
# * outside its calibration the network's own extrapolation (``uncalibrated="none"``) is a
#   gamble: on some simulated units it still helps (the first one, above, is such a unit),
#   on others it is worse than no thermal compensation at all, and on the real recording,
#   whose later bursts are colder than anything calibrated, it is far worse;
# * the default ``"blend"`` stays at or below the uncompensated MSD in these tables: far
#   outside it is the fallback: a plane in T and dT that the calibration runs repeat (the
#   simulated units, each calibrated on two runs), a line in T whose slope was checked to
#   extrapolate (the real recording, one run: see its fallback's slope), or the
#   calibration's mean drift (exactly the uncompensated figure). Where
#   the network happened to extrapolate well, the blend gives that gain up: it is the safe
#   policy, not the best one on every run;
# * ``"clip"`` holds the network at the edge of the domain: it keeps the network's
#   calibrated shape, but a drift that keeps changing beyond the edge is not followed, and
#   nothing bounds it by the uncompensated figure; compare its column with the others;
# * the ``held line in T`` is the firmware's answer to the same question: it never
#   extrapolates a slope, so it is safe where the drift bends beyond the calibration and
#   gives up the slope where the drift goes on; the default's fallback holds its line flat
#   beyond an extreme only where the calibration's held-out extremes ask for it. Compare
#   the two columns unit by unit: neither wins everywhere;
# * a temperature range check alone sees only the cold rows; the decorrelated domain also
#   flags the warm rows of a cold start and of a cooling run, thermal states the calibration
#   never showed.
#
# These are a few runs, for illustration. The measurement over physics presets, seeds,
# cooling and cycling runs and the real recording's three axes is
# ``python benchmarks/bench_extrapolation.py`` (its results are on the
# :ref:`outside_calibration` page).
plt.show()
