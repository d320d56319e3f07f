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
# The measured comparison over seeds, both physics presets, similar and independent lots and
# the RBF network is ``benchmarks/bench_unitwise.py`` (results in
# ``benchmarks/results/unitwise.md``). From the command line the same fit is
# ``sklearn-ifog fit lot.csv --temperature temperature --time time --run run --unit unit
# -o lot.joblib``; ``compensate``, ``report`` and ``export`` then follow the unit column.
