"""
Compensating a simulated thermal-test campaign, step by step
============================================================

The whole workflow on one simulated gyro: simulate a thermal-test campaign, look at the
drift, build the features, fit a drift model on some runs, compensate a run it has never
seen and measure what changed. Every later example builds on these steps.
"""

# %%
# A thermal-test campaign
# -----------------------
# :func:`~sklearn_ifog.datasets.make_thermal_campaign` simulates navigation-grade IFOGs in a
# thermal chamber: each unit (gyro) is recorded several times ("runs") at several azimuths
# while the chamber ramps between soaks. One unit, three runs per azimuth, is enough here.
import matplotlib.pyplot as plt
import numpy as np

from sklearn_ifog.datasets import make_thermal_campaign

campaign = make_thermal_campaign(n_units=1, n_runs=3, random_state=0)
frame = campaign.frame
columns = ["unit", "run", "azimuth", "time", "temperature", "rate", "reference", "drift"]
print(frame[columns].head().to_string())
print(frame.groupby("azimuth")["run"].unique())
# sphinx_gallery_thumbnail_number = 2

# %%
# Each row is one sample (one minute here) of one run: the coil temperature sensor's
# reading, the gyro output ``rate`` and the ``reference``, the Earth-rate component the
# static gyro should read at that azimuth. The simulator also gives the true ``drift``,
# which a real test never does; we keep it aside to check the model at the end.
#
# The drift the model must learn is what the gyro reads beyond the reference. Look at one
# run, with the two parts of the true drift that the simulator keeps in ``components``: a
# static thermal bias that follows the temperature itself, and the Shupe drift, driven by
# the coil's *rate* of change of temperature, which appears only while the chamber ramps.
run = frame[frame["run"] == 0]
parts = campaign.components.loc[run.index]
hours = run["time"] / 3600

fig, (ax_drift, ax_temperature) = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
ax_drift.plot(hours, run["rate"] - run["reference"], color="0.6", lw=0.8, label="measured")
ax_drift.plot(hours, run["drift"], color="k", lw=1.5, label="true thermal drift")
ax_drift.plot(hours, parts["static_bias"], "--", color="tab:purple", label="static bias part")
ax_drift.plot(hours, parts["shupe"], "--", color="tab:green", label="Shupe part (rate)")
ax_drift.set_ylabel("rate − reference (deg/h)")
ax_drift.legend(fontsize="small", ncol=2)
ax_temperature.plot(hours, run["temperature"], color="tab:red")
ax_temperature.set_ylabel("coil temperature (°C)")
ax_temperature.set_xlabel("time (h)")
fig.tight_layout()

# %%
# The features: T, ΔT and T·ΔT, run by run
# ----------------------------------------
# :class:`~sklearn_ifog.ThermalFeatures` computes the temperature, its rate (here in °C per
# minute, from the ``time`` column) and their product. ``run="run"`` makes ΔT restart at
# every run: the jump between the end of one recording and the start of the next is not a
# temperature rate.
from sklearn_ifog import ThermalFeatures

features = ThermalFeatures(temperature="temperature", time="time", run="run")
features.set_output(transform="pandas")
print(features.fit_transform(campaign.data).describe().round(3))

# %%
# A drift model
# -------------
# The model is a Pipeline: features, a scaler, and the RBF network, as
# :func:`~sklearn_ifog.make_compensation_pipeline` builds it (its defaults read the
# ``temperature``, ``time`` and ``run`` columns, as above). Train it on the runs at
# azimuths 0°, 45° and 135°, and keep the runs at 90° to test it: a model calibrated at some
# headings must hold at another. The target is the measured drift, ``rate − reference``.
from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline

X, y = campaign.data, campaign.target  # y = rate - reference
test = (X["azimuth"] == 90.0).to_numpy()

model = make_compensation_pipeline(RBFNetRegressor(random_state=0))
model.fit(X[~test], y[~test])
network = model[-1]
print(
    f"{network.centers_.shape[0]} Gaussian units, width chosen by the "
    f"{network.selection_path_['criterion_name']!r} criterion, "
    f"refinement kept: {network.selection_path_['refined']}"
)

# %%
# The network may keep few Gaussian units, or none: its polynomial tail (quadratic in the
# standardised features by default) is always in the model, and units are added only where
# the error on held-out blocks of the training runs justifies them (see :ref:`rbf`).
#
# Compensate the held-out runs
# ----------------------------
#
# The compensated rate is the output minus the predicted drift
# (:func:`~sklearn_ifog.compensation.compensate` does the subtraction).
from sklearn_ifog.compensation import compensate
from sklearn_ifog.plotting import plot_compensation

test_frame = frame[test]
compensated = compensate(model, X[test], test_frame["rate"])

first_run = test_frame["run"].iloc[0]
in_run = (test_frame["run"] == first_run).to_numpy()
fig, ax = plt.subplots(figsize=(8, 4))
plot_compensation(
    test_frame["time"][in_run],
    test_frame["rate"][in_run],
    compensated[in_run],
    test_frame["temperature"][in_run],
    reference=test_frame["reference"][in_run],
    ax=ax,
    title=f"Held-out run {first_run} (azimuth 90°)",
)
fig.tight_layout()

# %%
# Measure
# -------
# The mean squared deviation (MSD) from the reference, before and after, per held-out run
# (:func:`~sklearn_ifog.metrics.mean_squared_deviation`, the reference paper's Eq. 24). The
# simulator also tells us the *noise floor*: the MSD a perfect thermal model would leave
# (angle random walk, bias instability and the run's turn-on bias, which no thermal model
# can know).
import pandas as pd

from sklearn_ifog.metrics import mean_squared_deviation

rows = []
for run_id, rows_of_run in test_frame.groupby("run"):
    after = compensated[rows_of_run.index]
    reference = rows_of_run["reference"]
    rows.append(
        {
            "run": run_id,
            "msd_before": mean_squared_deviation(reference, rows_of_run["rate"]),
            "msd_after": mean_squared_deviation(reference, after),
            "noise_floor": mean_squared_deviation(
                reference, rows_of_run["rate"] - rows_of_run["drift"]
            ),
        }
    )
table = pd.DataFrame(rows).set_index("run")
table["reduction"] = table["msd_before"] / table["msd_after"]
print(table.to_string(float_format="{:.3g}".format))

# %%
# The compensated MSD sits close to the noise floor: what remains is mostly the gyro's own
# noise, not temperature. How close, run by run:
print((table["msd_after"] / table["noise_floor"]).round(2).to_string())

# %%
# Against the truth
# -----------------
# Only a simulator can show this: the predicted drift against the true thermal drift on the
# held-out run.
predicted = model.predict(X[test])[in_run]
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot(test_frame["time"][in_run] / 3600, test_frame["drift"][in_run], "k", label="true")
ax.plot(test_frame["time"][in_run] / 3600, predicted, "tab:blue", label="predicted")
ax.set_xlabel("time (h)")
ax.set_ylabel("drift (deg/h)")
ax.legend()
fig.tight_layout()
rms_error = np.sqrt(np.mean((predicted - test_frame["drift"][in_run]) ** 2))
print(f"RMS error of the predicted drift: {rms_error:.4f} deg/h")

plt.show()
