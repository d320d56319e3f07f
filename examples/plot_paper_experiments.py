"""
Reproducing the reference paper's experiments on the simulator
===============================================================

The reference paper trains a Gaussian RBF network on a gyro's thermal runs at one heading
and checks it on five runs at another: Table 2 (one unit, trained at azimuth 0°, tested at
90°: the MSD before and after compensation) and Tables 3–4 (two other units, tested at 45°
and 135°: the raw output, the "traditional" model on (T, ΔT) and the "modified" model on
(T, ΔT, T·ΔT)). Here the same design runs on a simulated campaign, with
:func:`sklearn_ifog.paper.run_paper_experiments`, and the package's models are then
compared with the usual baselines by :func:`sklearn_ifog.comparison.compare_regressors`.

MSD is the mean squared deviation of the output from the known input rate, in (deg/h)².
"""

# %%
# A simulated campaign
# --------------------
# Three gyros ("units"), each with five thermal runs at azimuth 0° (the training set) and
# five at its test azimuth (90°, 45°, 135°), as in the paper.
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from sklearn_ifog.comparison import compare_regressors
from sklearn_ifog.compensation import compensate
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.model_selection import LeaveOneAzimuthOut
from sklearn_ifog.paper import run_paper_experiments

campaign = make_thermal_campaign(random_state=0)
frame = campaign.frame
print(frame.groupby(["unit", "azimuth"])["run"].nunique().rename("runs").to_frame())

# %%
# Table 2: one unit, trained at 0°, tested at 90°
# -----------------------------------------------
result = run_paper_experiments(campaign, n_jobs=-1, verbose=1)
with pd.option_context("display.float_format", "{:.3e}".format):
    print(result.table2)

# %%
# Tables 3 and 4: traditional (T, ΔT) against modified (T, ΔT, T·ΔT)
# ------------------------------------------------------------------
with pd.option_context("display.float_format", "{:.3e}".format):
    print(result.table3)
    print(result.table4)

tables = result.runs
print(
    f"MSD cut by the modified model: {tables['raw'].mean() / tables['modified'].mean():.0f}x; "
    f"it beats the traditional model on {(tables['modified'] < tables['traditional']).sum()} "
    f"of {len(tables)} test runs."
)

# %%
# The compensated output of one test run (the paper's Fig. 10)
# ------------------------------------------------------------
unit = tables["unit"].iloc[0]
run = tables["run"].iloc[0]
run_frame = frame[frame["run"] == run]
hours = run_frame["time"] / 3600.0
models = result.models[unit]
error = run_frame["rate"] - run_frame["reference"]

fig, (ax_rate, ax_temperature) = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
ax_rate.plot(hours, error, color="0.6", lw=0.8, label="raw")
for name, color in (("traditional", "tab:orange"), ("modified", "tab:blue")):
    ax_rate.plot(
        hours, compensate(models[name], run_frame, error), color=color, lw=0.8, label=name
    )
ax_rate.set_ylabel("output − input rate (deg/h)")
ax_rate.legend(loc="upper right")
ax_temperature.plot(hours, run_frame["temperature"], color="tab:red")
ax_temperature.set_ylabel("coil temperature (°C)")
ax_temperature.set_xlabel("time (h)")
fig.suptitle(f"Unit {unit}, run {run}")
fig.tight_layout()

# %%
# MSD per test run, all three experiments
# ---------------------------------------
fig, ax = plt.subplots(figsize=(8, 3.5))
positions = np.arange(len(tables))
for offset, (name, color) in zip(
    (-0.27, 0.0, 0.27),
    (("raw", "0.6"), ("traditional", "tab:orange"), ("modified", "tab:blue")),
    strict=True,
):
    ax.bar(positions + offset, tables[name], width=0.27, color=color, label=name)
ax.set_yscale("log")
labels = [f"u{u} r{r}" for u, r in zip(tables["unit"], tables["run"], strict=True)]
ax.set_xticks(positions, labels)
ax.tick_params(axis="x", labelrotation=90)
ax.set_ylabel("MSD ((deg/h)²)")
ax.legend()
fig.tight_layout()

# %%
# The package's models against baselines
# --------------------------------------
# Leave one azimuth out, on the first unit: every model is trained on the unit's runs at
# three headings and tested on the fourth. ``"raw"`` is no compensation, ``"bias"``
# subtracts the training mean; the rest are pipelines ThermalFeatures → StandardScaler →
# regressor (:func:`~sklearn_ifog.comparison.default_regressors`).
first_unit = (campaign.data["unit"] == unit).to_numpy()
X, y = campaign.data[first_unit], campaign.target[first_unit]
summary = compare_regressors(X, y, cv=LeaveOneAzimuthOut(), n_jobs=-1, verbose=1)
with pd.option_context("display.float_format", "{:.3g}".format):
    print(summary)

plt.show()
