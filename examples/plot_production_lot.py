"""
A production lot: one model per gyro
====================================

A production engineer tests a lot of gyros of one design together and needs one
compensation model per unit. :class:`~sklearn_ifog.UnitwiseRegressor` fits them in one
call, dispatched by the ``unit`` column of X. How much the units share is ``pooling``:
``"none"`` (independent models), ``"full"`` (one model for the lot) or ``"partial"`` (each
unit's output layer shrunk towards the lot's, the strength chosen per unit by empirical
Bayes, the most likely spread of the unit around the lot). Partial pooling is what lets a
unit calibrated on a single run borrow what the lot knows: chamber time is the expensive
part of a gyro's calibration.
"""

# %%
# A simulated lot
# ---------------
# Six units of one design (``lot_spread=0.15``: every coefficient of a unit scatters by about
# 15 % around the design's), four runs each at one azimuth. Every unit is calibrated on its
# first run or its first two, and tested on its last two runs.
import matplotlib.pyplot as plt
import numpy as np
from sklearn.linear_model import LinearRegression

from sklearn_ifog import UnitwiseRegressor, make_compensation_pipeline
from sklearn_ifog.datasets import make_thermal_campaign, noise_floor

campaign = make_thermal_campaign(
    n_units=6,
    n_runs=4,
    azimuths=[0.0],
    sampling_period=300.0,
    lot_spread=0.15,
    random_state=0,
)
frame, X, y = campaign.frame, campaign.data, campaign.target.to_numpy()
order = frame.groupby("unit")["run"].rank(method="dense").to_numpy()
test = order > 2
print(f"{frame['unit'].nunique()} units, {frame['run'].nunique()} runs, {len(frame)} rows")

# %%
# Three poolings, two calibration sizes
# -------------------------------------
# The drift model is the package's pipeline (thermal features, scaler, linear regressor);
# the RBF network works the same way (``partial`` keeps the lot network's centres and widths
# and re-solves each unit's output weights).
floor = noise_floor(frame, test)
results = {}
for n_runs in (1, 2):
    train = order <= n_runs
    for pooling in ("none", "full", "partial"):
        model = UnitwiseRegressor(make_compensation_pipeline(LinearRegression()), pooling=pooling)
        model.fit(X[train], y[train])
        msd = np.mean((y[test] - model.predict(X[test])) ** 2)
        results[(n_runs, pooling)] = msd
        print(f"{n_runs} run(s), {pooling:>7}: MSD {msd:.2e} ({msd / floor:.2f} x noise floor)")

# %%
# The strength each unit chose, with two calibration runs (small: nearly its own weights,
# ``inf``: the lot's):
print({unit: f"{value:.3g}" for unit, value in model.shrinkage_.items()})

# %%
# Test MSD against calibration runs
# ---------------------------------
fig, ax = plt.subplots(figsize=(6, 3.5))
for pooling, marker in (("none", "o"), ("full", "s"), ("partial", "D")):
    ax.plot(
        [1, 2],
        [results[(n, pooling)] / floor for n in (1, 2)],
        marker=marker,
        label=pooling,
    )
ax.set_xticks([1, 2])
ax.set_xlabel("calibration runs per unit")
ax.set_ylabel("test MSD / noise floor")
ax.set_title("A lot of six similar gyros")
ax.legend()
fig.tight_layout()

# %%
# A new gyro on the line
# ----------------------
# The lot is fitted once; every new gyro then gets its own calibration against it, without
# refitting the lot. Here the lot is fitted on units 0-4 (two runs each), and unit 5 arrives:
# before any calibration ``handle_unknown="lot"`` compensates it with the lot's model, and
# ``add_units`` calibrates it on its first one or two runs (its output layer shrunk towards
# the lot's, the strength by its own evidence). Its own model alone (``"none"``) is the
# alternative once it has a run.
import copy
import warnings

from sklearn_ifog.domain import OutsideCalibrationWarning

new_unit = frame["unit"] == 5
lot_rows = ~new_unit & (order <= 2)
held = new_unit & test
lot = UnitwiseRegressor(make_compensation_pipeline(LinearRegression()), handle_unknown="lot")
lot.fit(X[lot_rows], y[lot_rows])
curve = {"partial (add_units)": [], "none (its own model)": [], "full (the lot's model)": []}
# The new unit's test runs reach beyond what one or two calibration runs cover: the models
# flag those rows (OutsideCalibrationWarning) and fall back there, as they should.
warnings.simplefilter("ignore", OutsideCalibrationWarning)
for n_runs in (0, 1, 2):
    calibration = (new_unit & (order <= n_runs)).to_numpy()
    added = copy.deepcopy(lot).add_units(X[calibration], y[calibration]) if n_runs else lot
    curve["partial (add_units)"].append(np.mean((y[held] - added.predict(X[held])) ** 2))
    curve["full (the lot's model)"].append(np.mean((y[held] - lot.predict(X[held])) ** 2))
    own = np.nan
    if n_runs:
        alone = make_compensation_pipeline(LinearRegression())
        alone.fit(X[calibration].drop(columns="unit"), y[calibration])
        own = np.mean((y[held] - alone.predict(X[held].drop(columns="unit"))) ** 2)
    curve["none (its own model)"].append(own)
new_floor = noise_floor(frame, held.to_numpy())
for name, values in curve.items():
    print(f"{name:>24}: " + ", ".join(f"{value / new_floor:.3g}" for value in values))
fig, ax = plt.subplots(figsize=(6, 3.5))
for (name, values), marker in zip(curve.items(), ("D", "o", "s"), strict=True):
    ax.plot([0, 1, 2], np.array(values) / new_floor, marker=marker, label=name)
ax.set_xticks([0, 1, 2])
ax.set_yscale("log")
ax.set_xlabel("calibration runs of the new unit")
ax.set_ylabel("test MSD / noise floor")
ax.set_title("A new gyro calibrated against a fitted lot")
ax.legend(loc="lower left")
fig.tight_layout()

# %%
# The measured comparison over seeds, both physics presets, similar and independent lots and
# the RBF network is ``benchmarks/bench_unitwise.py`` (results in
# ``benchmarks/results/unitwise.md``, with the new-unit curve averaged over seeds). From the
# command line the same fit is
# ``sklearn-ifog fit lot.csv --temperature temperature --time time --run run --unit unit
# -o lot.joblib``; ``compensate``, ``report`` and ``export`` then follow the unit column.
