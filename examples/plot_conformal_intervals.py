"""
How sure is the compensation: a drift band that holds run by run
=================================================================

After compensation a navigation engineer must budget what is left: "the thermal drift stays
within ± x deg/h, 90 % of the time, on runs like these". :class:`~sklearn_ifog.ConformalRegressor`
wraps the drift model and calibrates such a band on the model's out-of-fold errors, with the
*run* as the unit (rows of one run are correlated, runs are not) and a width that follows a
difficulty estimate (rows far from the calibrated conditions, such as faster ramps or colder
temperatures than any calibration run, get a wider band). Here one gyro of the hardest
simulated physics (a layered coil whose coating passes its glass transition, chamber runs
drawn from several profiles) is calibrated at three headings and its band is checked at the
fourth, a heading it never saw.
"""

# %%
# A campaign, and a held-out heading
# ----------------------------------
import matplotlib.pyplot as plt
import numpy as np

from sklearn_ifog import ConformalRegressor, RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.conformal import knn_distance
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.metrics import interval_coverage, mean_interval_width
from sklearn_ifog.plotting import plot_compensation

campaign = make_thermal_campaign(
    n_units=1,
    n_runs=3,
    sampling_period=300.0,
    physics="layered_glass",
    profile="mix",
    random_state=2,
)
frame, X, y = campaign.frame, campaign.data, campaign.target.to_numpy()
test = (X["azimuth"] == 135.0).to_numpy()
print(f"{X['run'].nunique()} runs; calibrating on {X['run'][~test].nunique()}")

# %%
# The band
# --------
# The drift model is the package's default pipeline (without the network's refinement, to
# keep this example fast). ``cv=5`` splits the calibration runs into five folds of whole
# runs; ``coverage=0.9`` asks for a band holding the drift 90 % of each run's time.
drift_model = make_compensation_pipeline(
    RBFNetRegressor(refine=None, criterion="holdout", random_state=0)
)
model = ConformalRegressor(drift_model, coverage=0.9, cv=5).fit(X[~test], y[~test])
bounds = model.predict_interval(X[test])

for run in np.unique(X["run"][test]):
    rows = (X["run"][test] == run).to_numpy()
    print(
        f"run {run}: coverage {interval_coverage(y[test][rows], bounds[rows]):.2f}, "
        f"mean width {mean_interval_width(bounds[rows]):.3f} deg/h"
    )

# %%
# The band widens where the held-out heading leaves the calibrated conditions: its width
# against the distance from each row to its nearest calibration rows, in the drift model's
# standardised features (the difficulty model's input, see :ref:`conformal`).
features = model.estimator_[:-1].transform(X[test])
distance = knn_distance(
    model.calibration_features_, (features - model.feature_mean_) / model.feature_scale_
)
width = bounds[:, 1] - bounds[:, 0]
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.scatter(distance, width, s=6)
ax.set_xlabel("distance to the calibration rows (standardised features)")
ax.set_ylabel("band width (°/h)")
fig.tight_layout()

# %%
# The same band against the coil's temperature rate, the regime a gyro engineer reads first.
# Rows at the rates the calibration runs covered get the narrow band; the rows the drift
# model has to extrapolate to (a rate or a thermal state no calibration run had, outside its
# calibration domain, see :ref:`outside_calibration`) get a wider one, so that the band
# keeps its coverage there too.
held_out = frame[test]
temperature_rate = np.empty(len(held_out))
for run in np.unique(held_out["run"]):
    rows = (held_out["run"] == run).to_numpy()
    temperature_rate[rows] = 60.0 * np.gradient(
        held_out["temperature"].to_numpy()[rows], held_out["time"].to_numpy()[rows]
    )
outside = model.estimator_.outside_calibration(X[test])
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.scatter(temperature_rate[~outside], width[~outside], s=6, label="inside the domain")
ax.scatter(temperature_rate[outside], width[outside], s=6, label="outside the domain")
ax.set_xlabel("temperature rate (°C/min)")
ax.set_ylabel("band width (°/h)")
ax.legend(loc="upper left")
fig.tight_layout()
print(
    f"mean band width: {width[~outside].mean():.4f} deg/h inside the calibration domain "
    f"({(~outside).sum()} rows), {width[outside].mean():.4f} outside ({outside.sum()} rows)"
)

# %%
# One held-out run, compensated, with its band: the true input rate should lie in the shaded
# band ``[rate - upper, rate - lower]`` 90 % of the time.
first = (X["run"] == X["run"][test].iloc[0]).to_numpy()
rows = first[test]
ax, _ = plot_compensation(
    frame["time"][first],
    frame["rate"][first],
    frame["rate"][first] - model.predict(X[first]),
    frame["temperature"][first],
    reference=frame["reference"][first],
    interval=bounds[rows],
    title="held-out heading, 90 % band",
)
plt.show()

# %%
# How well this holds across presets, seeds and headings, against MAPIE row-wise and MAPIE
# grouped by run, is measured by ``benchmarks/bench_conformal.py`` (see :ref:`conformal`).
