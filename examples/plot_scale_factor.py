"""
Scale factor over temperature on a rate table
=============================================

A static thermal test shows a gyro's bias; what the gyro *multiplies* its input rate by, the
scale factor, needs a rate table. Here one simulated gyro is recorded three times on a
turntable inside a thermal chamber; a model learns its bias and its scale-factor error over
temperature from two runs, and compensates the third: the scale-factor error against
temperature before and after, the residual at every input rate, and the gyro outputs turned
back into the input rates they stand for. The user guide's :ref:`scale_factor` explains
each step.
"""

# %%
# A rate-table campaign
# ---------------------
# :func:`~sklearn_ifog.datasets.make_rate_table_campaign` simulates the test: the chamber
# cycles (default ``profile="cycle"``, heating and cooling in every run) while the table
# steps through 0, ±1, ±10, ±100 and ±300 deg/s. The ``reference`` column is the true input
# rate in deg/h, the gyro output's unit (300 deg/s is 1,080,000 deg/h); the target is the
# drift ``rate - reference``. The simulator also gives the true scale-factor error of every
# row (``scale_factor_error``, ppm), which a real test never does.
import matplotlib.pyplot as plt
import numpy as np

from sklearn_ifog.datasets import make_rate_table_campaign

campaign = make_rate_table_campaign(n_units=1, n_runs=3, random_state=0)
frame, X, y = campaign.frame, campaign.data, campaign.target.to_numpy()
print(list(X.columns))
print(frame.groupby("run")["temperature"].agg(["min", "max"]).round(1))
print("table rates (deg/s):", sorted(frame["table_rate"].unique().tolist()))
# sphinx_gallery_thumbnail_number = 1

# %%
# Calibrate on two runs, test on the third
# ----------------------------------------
# ``input_rate="reference"`` names the input-rate column: the model learns the drift as
# ``b(x) + Ω s(x) + a |Ω|``, a bias ``b`` and a scale-factor error ``s`` over the same
# thermal features, and a constant asymmetry ``a`` between positive and negative rates.
# The held-out run 0 stays within the temperatures of runs 1 and 2, so no row of it lies
# outside the calibration.
from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline

test = (frame["run"] == 0).to_numpy()
model = make_compensation_pipeline(RBFNetRegressor(random_state=0), input_rate="reference")
model.fit(X[~test], y[~test])
drift = model.predict(X[test])  # b + Ω s + a|Ω| at each row's input rate
print(f"asymmetry a: {model.asymmetry_ * 1e6:.3g} ppm")
low, high = model.input_rate_range_
print(f"calibrated input rates: {low / 3600:.1f} to {high / 3600:.1f} deg/s")
print(f"outside the calibration: {model.outside_calibration(X[test]).mean():.1%} of the rows")

# %%
# The scale-factor error against temperature
# ------------------------------------------
# In each temperature bin the scale-factor error is the least-squares slope of the error on
# the input rate, in ppm (:func:`~sklearn_ifog.metrics.scale_factor_error`). Before
# compensation the error is ``y = rate - reference``; after, ``y - model.predict(X)``,
# drawn again in the lower panel on its own scale.
from sklearn_ifog.metrics import (
    residual_by_input_rate,
    scale_factor_asymmetry,
    scale_factor_error,
    scale_factor_peak_to_peak,
)
from sklearn_ifog.plotting import plot_scale_factor

held = frame[test]
omega, temperature = held["reference"].to_numpy(), held["temperature"].to_numpy()
before, after = y[test], y[test] - drift
fig, (ax, ax_after) = plt.subplots(2, 1, sharex=True, figsize=(7, 6), height_ratios=(2, 1))
plot_scale_factor(omega, temperature, before, after, ax=ax, title="Held-out run")
ax.set_xlabel("")
left = scale_factor_error(omega, after, temperature)
ax_after.plot(left["temperature"], left["ppm"], marker="o", color="tab:blue")
ax_after.axhline(0.0, color="black", linewidth=0.6)
ax_after.set_ylabel("after (ppm)")
ax_after.set_xlabel("temperature (°C)")
ax_after.grid(True, alpha=0.3)
fig.tight_layout()

for name, error in (("before", before), ("after", after)):
    peak = scale_factor_peak_to_peak(omega, error, temperature)
    asymmetry = scale_factor_asymmetry(omega, error)
    print(f"{name:>6}: peak-to-peak {peak:8.3g} ppm, asymmetry {asymmetry:8.3g} ppm")

# %%
# The residual at every input rate
# --------------------------------
# Uncompensated, the error grows with the input rate: the scale-factor error times the
# rate. After, what is left at the fastest rates is the model's scale-factor residual times
# the rate (the rate noise ``κ |Ω|`` the fit weighs the rows by, ``model.rate_noise_``).
by_rate = residual_by_input_rate(omega, before)[["rms"]].rename(columns={"rms": "before"})
by_rate["after"] = residual_by_input_rate(omega, after)["rms"]
by_rate.index = (by_rate.index / 3600).round(1).rename("input rate (deg/s)")
print(by_rate.to_string(float_format="{:.3g}".format))

# %%
# From gyro output to input rate
# ------------------------------
# In the field the input rate is what is unknown: ``model.compensate(X, rate)`` takes rows
# without the ``reference`` column and the gyro output, and returns the estimated input
# rate ``(rate - b) / (1 + s ± a)``. Its error against the true input rate, over the
# held-out run:
rate = held["rate"].to_numpy()
estimate = model.compensate(X[test].drop(columns="reference"), rate)
raw_error, compensated_error = rate - omega, estimate - omega
print(f"output - input rate:   RMS {np.sqrt(np.mean(raw_error**2)):.3g} deg/h")
print(f"estimate - input rate: RMS {np.sqrt(np.mean(compensated_error**2)):.3g} deg/h")

hours = held["time"].to_numpy() / 3600
fig, (ax_error, ax_temperature) = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
ax_error.plot(hours, raw_error, color="0.6", lw=0.8, label="output − input rate")
ax_error.plot(hours, compensated_error, color="tab:blue", lw=0.8, label="estimate − input rate")
ax_error.set_yscale("symlog", linthresh=1.0)
ax_error.set_ylabel("error (deg/h)")
ax_error.legend(fontsize="small")
ax_temperature.plot(hours, temperature, color="tab:red")
ax_temperature.set_ylabel("coil temperature (°C)")
ax_temperature.set_xlabel("time (h)")
fig.tight_layout()

# %%
# The measured comparison over presets and seeds, held out by run and by unit, against no
# scale-factor compensation and firmware polynomials in T, is
# ``benchmarks/bench_scale_factor.py``. From the command line the same fit is
# ``sklearn-ifog fit rate_table.csv --run run --time time --input-rate reference -o
# sf.joblib``; ``compensate`` then writes the estimated input rate and ``report`` adds a
# "Scale factor" section.
