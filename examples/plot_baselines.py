"""
The RBF network against baseline regressors
===========================================

Is a Gaussian RBF network worth it for thermal compensation? One call of
:func:`~sklearn_ifog.comparison.compare_regressors` cross-validates it against the
models a gyro engineer would otherwise reach for — no compensation, a bias calibration, a
linear thermal model, polynomial ridge regression, a multi-layer perceptron, kernel methods
— plus an imitation of MATLAB's ``newrb``, all on the same features and the same folds.
"""

# %%
# Data and models
# ---------------
# Two simulated gyros, two runs per azimuth; every fold holds out one azimuth of one gyro
# and trains on the same gyro's other azimuths.
import matplotlib.pyplot as plt
import numpy as np

from sklearn_ifog.comparison import default_regressors
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.model_selection import LeaveOneAzimuthOut

X, y = make_thermal_campaign(n_units=2, n_runs=2, random_state=3, return_X_y=True)
print(f"{len(X)} samples, {X['run'].nunique()} runs")
# sphinx_gallery_thumbnail_number = 1

# %%
# :func:`~sklearn_ifog.comparison.default_regressors` returns the default set as a
# dict, to edit. Every entry but the two dummies is a Pipeline ThermalFeatures →
# StandardScaler → regressor (kernel methods fitted on a subsample). Add a ``newrb``-like
# network: a width fixed by hand (``spread`` = 1 standard deviation), centres added until
# the *training* error reaches a goal, no polynomial tail, no refinement, no regularisation
# (see :ref:`rbf`).
from sklearn.base import clone

from sklearn_ifog import RBFNetRegressor

regressors = default_regressors(random_state=0)
newrb_like = clone(regressors["rbf_modified"]).set_params(
    regressor=RBFNetRegressor(
        n_centers=40,
        goal=1e-4,
        width=1.0 / np.sqrt(2 * np.log(2)),
        tail=False,
        refine=None,
        alpha=1e-10,
        random_state=0,
    )
)
regressors["newrb_like"] = newrb_like
print(list(regressors))

# %%
# Cross-validate them all
# -----------------------
# Every (model, fold) pair is an independent joblib task.
from sklearn_ifog.comparison import compare_regressors

summary, folds = compare_regressors(
    X, y, regressors=regressors, cv=LeaveOneAzimuthOut(), n_jobs=2, return_folds=True
)
columns = ["msd_after", "reduction", "worst_fold_reduction", "fit_time", "predict_time"]
print(summary[columns].sort_values("msd_after").to_string(float_format="{:.3g}".format))

# %%
# The MSD after compensation per model: bars are the mean over folds, dots the folds.
from sklearn_ifog.plotting import plot_msd_by_model

per_model = {
    name: group["msd_after"].to_numpy() for name, group in folds.groupby("model", sort=False)
}
fig, ax = plt.subplots(figsize=(9, 4))
plot_msd_by_model(per_model, ax=ax, title="Held-out MSD per model (leave one azimuth out)")
ax.tick_params(axis="x", labelrotation=45)
fig.tight_layout()

# %%
# Accuracy against cost
# ---------------------
fig, ax = plt.subplots(figsize=(7, 4))
for name, row in summary.drop(index=["raw", "bias"]).iterrows():
    ax.scatter(row["fit_time"], row["msd_after"])
    ax.annotate(name, (row["fit_time"], row["msd_after"]), fontsize="small")
ax.set_xscale("log")
ax.set_yscale("log")
ax.set_xlabel("mean fit time per fold (s)")
ax.set_ylabel("mean held-out MSD, (deg/h)²")
fig.tight_layout()

# %%
# Reading the table
# -----------------
# ``reduction`` is the MSD before over the MSD after (higher is better) and
# ``worst_fold_reduction`` the same on the worst fold: a compensation that fails on one
# heading fails in the field. The ``"bias"`` row is the bar any thermal model must clear.
# The ranking is computed when this page is built; on this small campaign the differences
# between the better models are small next to the gyro's noise, which no model removes.
best = summary.drop(index=["raw", "bias"])["msd_after"].idxmin()
ratio = summary.loc["rbf_modified", "msd_after"] / summary.loc[best, "msd_after"]
print(f"lowest mean MSD: {best}; the default RBF network's MSD is {ratio:.2f}x that")
print(
    "newrb-like / default RBF network MSD: "
    f"{summary.loc['newrb_like', 'msd_after'] / summary.loc['rbf_modified', 'msd_after']:.2f}"
)
plt.show()
