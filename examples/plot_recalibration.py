"""
Recalibrating an aged gyro online, from one run at rest
=======================================================

A thermal calibration ages: between the chamber and the field, a gyro's bias shifts and its
thermal sensitivity changes (storage, shocks, the coil's potting creeping). A navigation
system knows the true rate now and then — at rest during alignment, on a turntable — and
:class:`~sklearn_ifog.streaming.StreamingCompensator` can use those samples to update the
model's output layer online, by recursive least squares with forgetting, without refitting
it. Here: calibrate a new unit, age it, recalibrate on one run at rest, then compensate a
later run with the fitted model and with the recalibrated one.
"""

# %%
# Calibrate the new unit
# ----------------------
# One simulated unit, four calibration runs (the "cycle" chamber programme: low, high, low)
# and, later, two more runs.
import matplotlib.pyplot as plt
import numpy as np

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.datasets import age_campaign, make_thermal_campaign
from sklearn_ifog.metrics import mean_squared_deviation
from sklearn_ifog.streaming import StreamingCompensator

campaign = make_thermal_campaign(
    n_units=1, n_runs=6, azimuths=[0.0], profile="cycle", random_state=0
)
runs = campaign.frame["run"].unique()
calibration, recalibration, later = runs[:4], runs[4], runs[5]
new = campaign.frame
train = new[new["run"].isin(calibration)]
model = make_compensation_pipeline(RBFNetRegressor(random_state=0))
model.fit(train, train["rate"] - train["reference"])

# %%
# Age it
# ------
# :func:`~sklearn_ifog.datasets.age_campaign` shifts the bias of the runs recorded after the
# calibration by 0.05 deg/h and makes their thermal drift 20 % stronger.
aged = age_campaign(campaign, bias_shift=0.05, sensitivity_change=0.2, runs=runs[4:]).frame
at_rest = aged[aged["run"] == recalibration]
test = aged[aged["run"] == later]

# %%
# Recalibrate on one run at rest
# ------------------------------
# The unit sits still through one run, so its true rate (the Earth-rate component) is known:
# each sample is first compensated, then its ``rate - reference`` updates the output layer
# (``adapt="output"``: the network's Gaussian and tail weights and its intercept; the
# centres, widths and scalers stay as fitted). In the field this is
# ``compensator.step(time, temperature, rate, reference=true_rate)``, sample by sample.
compensator = StreamingCompensator(model, adapt="output", forgetting=0.999)
compensator.update(at_rest, at_rest["rate"], reference=at_rest["reference"])
print(f"{compensator.get_state()['rls']['n_updates']} references used")

# %%
# Compensate a later run
# ----------------------
# Without references now: the recalibrated weights carry over to the new run (a new run
# restarts the thermal features, not the recalibration).
fixed = test["rate"] - model.predict(test)
recalibrated, _ = compensator.update(test, test["rate"])
truth = test["reference"].to_numpy()
before_ageing = new[new["run"] == later]
as_new = before_ageing["rate"] - model.predict(before_ageing)

results = {
    "new unit, fitted model": as_new,
    "aged unit, fitted model": fixed,
    "aged unit, recalibrated online": recalibrated,
}
for name, compensated in results.items():
    msd = mean_squared_deviation(truth, np.asarray(compensated))
    print(f"{name:32s} MSD = {msd:.2e} (deg/h)²")

# %%
# Plot the three
# --------------
hours = test["time"].to_numpy() / 3600
fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, height_ratios=(2, 1))
for (name, compensated), colour in zip(results.items(), ("C2", "C3", "C0"), strict=True):
    error = np.asarray(compensated) - truth
    top.plot(hours, error, color=colour, lw=0.8, label=name)
top.axhline(0.0, color="k", lw=0.5)
top.set_ylabel("compensated − true rate, deg/h")
top.set_title(f"Run {later}, after the ageing")
top.legend(loc="upper left", fontsize=8)
bottom.plot(hours, test["temperature"], color="C1")
bottom.set_xlabel("time, h")
bottom.set_ylabel("temperature, °C")
fig.tight_layout()

# %%
# The fitted model leaves the aged unit's bias shift and the extra 20 % of thermal drift;
# one run at rest brings the recalibrated compensator back to about what the model did on
# the new unit. The update is bounded and exportable: ``to_c(model, directory,
# adapt="output")`` writes the same recursion in C (see :ref:`deployment`).
plt.show()
