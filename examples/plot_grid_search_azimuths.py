"""
Tuning with GridSearchCV across azimuths
========================================

Plain scikit-learn model selection on a thermal-test campaign: a
:class:`~sklearn.model_selection.GridSearchCV` over feature and network settings, scored by
the mean squared deviation (MSD), where every fold holds out all the runs at one azimuth.
The run id travels inside ``X``, so ΔT restarts at every run in every fold.
"""

# %%
# One gyro, four azimuths
# -----------------------
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from sklearn_ifog.datasets import make_thermal_campaign

X, y = make_thermal_campaign(n_units=1, n_runs=3, random_state=2, return_X_y=True)
print(X.groupby("azimuth")["run"].unique())
# sphinx_gallery_thumbnail_number = 2

# %%
# The search
# ----------
# ``LeaveOneGroupOut`` with ``groups=X["azimuth"]``: four folds, each testing on the three
# runs at one azimuth. No run can straddle two folds, because a run has one azimuth. The
# grid compares the paper's two feature sets and two ways for the RBF network to choose its
# size: the default cross-validation over *contiguous blocks* of samples (``"cv"``), and
# generalised cross-validation (``"gcv"``), which assumes independent errors.
from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog.metrics import neg_mean_squared_deviation_scorer

# Steps "features", "scale" and "regressor": their parameters are named after them.
pipe = make_compensation_pipeline(RBFNetRegressor(random_state=0))
grid = {
    "features__terms": [("T", "dT"), ("T", "dT", "TdT")],
    "regressor__criterion": ["cv", "gcv"],
}
search = GridSearchCV(
    pipe, grid, cv=LeaveOneGroupOut(), scoring=neg_mean_squared_deviation_scorer, n_jobs=2
)
search.fit(X, y, groups=X["azimuth"])
print("best:", search.best_params_)

# %%
# The results
# -----------
# ``cv_results_`` holds every candidate's score on every fold (minus the MSD, since
# scikit-learn maximises scores).
results = pd.DataFrame(search.cv_results_)
fold_columns = [f"split{i}_test_score" for i in range(search.n_splits_)]
table = pd.DataFrame(
    {
        "terms": results["param_features__terms"].map(", ".join),
        "criterion": results["param_regressor__criterion"],
        "mean MSD": -results["mean_test_score"],
        "worst fold MSD": -results[fold_columns].min(axis=1),
    }
)
print(table.to_string(float_format="{:.3g}".format))

# %%
# Per fold, for every candidate: each azimuth held out in turn.
fig, ax = plt.subplots(figsize=(8, 3.5))
labels = [f"{row.terms}\n{row.criterion}" for row in table.itertuples()]
for fold, column in enumerate(fold_columns):
    ax.plot(labels, -results[column], "o", label=f"fold {fold}", alpha=0.8)
ax.plot(labels, table["mean MSD"], "k_", markersize=30, label="mean")
ax.set_yscale("log")
ax.set_ylabel("held-out MSD, (deg/h)²")
ax.legend(ncol=5, fontsize="small")
fig.tight_layout()

# %%
# How many centres each criterion picks
# -------------------------------------
# Fit the best feature set with each criterion on all runs and look at the selection path
# (the dotted lines mark the chosen size). On autocorrelated thermal data a criterion that
# assumes independent errors tends to keep more units than the held-out blocks do; with
# held-out blocks the network also takes the smallest size within one standard error of the
# best, not the bare minimum.
best_terms = search.best_params_["features__terms"]
fig, ax = plt.subplots(figsize=(7, 3.5))
for criterion in ("cv", "gcv"):
    model = pipe.set_params(features__terms=best_terms, regressor__criterion=criterion)
    network = model.fit(X, y)[-1]
    path = network.selection_path_
    scores = np.asarray(path["criterion"])
    ax.plot(np.arange(scores.size), scores / scores.min(), label=criterion)
    ax.axvline(path["n_centers"], ls=":", color=ax.lines[-1].get_color())
    print(f"{criterion}: {network.centers_.shape[0]} centres")
ax.set_yscale("log")
ax.set_xlabel("number of Gaussian units along the selection path")
ax.set_ylabel("criterion / its minimum")
ax.legend()
fig.tight_layout()

# %%
# The package's own splitter
# --------------------------
# :class:`~sklearn_ifog.model_selection.LeaveOneAzimuthOut` reads the ``azimuth`` (and
# ``unit``) columns from ``X`` itself, holds out one azimuth *within each unit* on
# multi-unit campaigns, and checks that no run straddles two folds. On this one-unit
# campaign its folds are those of ``LeaveOneGroupOut`` above:
from sklearn_ifog.model_selection import LeaveOneAzimuthOut

ours = [test.tolist() for _, test in LeaveOneAzimuthOut().split(X)]
plain = [test.tolist() for _, test in LeaveOneGroupOut().split(X, y, groups=X["azimuth"])]
print("same folds:", ours == plain)
plt.show()
