"""Small campaigns with a drift the tests know exactly, shared by several test modules.

Imported by name (``from _campaigns import ...``): pytest puts ``tests/`` on the import path
of its test modules (the default ``prepend`` import mode; ``tests`` is not a package).
"""

import numpy as np

from sklearn_ifog.datasets import make_thermal_campaign

#: The drift's gain on the rate of change, (deg/h) per (degC/min).
RATE_GAIN = 0.05


def rate_drift_table(seed, temperature_range):
    """A campaign's thermal columns with a known drift: a line in T, a term in the rate of
    change (degC/min), white noise.

    One lumped unit, four runs at each of two azimuths, a sample every 300 s, temperatures
    within ``temperature_range``. The regressor's features hold all of the drift, a fallback
    line in T only the line, so beyond the calibrated temperatures the fallback's error is
    its rate term, as on the calibration runs.
    """
    X = make_thermal_campaign(
        n_units=1,
        n_runs=4,
        azimuths=[0.0, 90.0],
        sampling_period=300.0,
        temperature_range=temperature_range,
        physics="lumped",
        random_state=seed,
    ).data
    rate = X.groupby("run")["temperature"].diff().fillna(0.0).to_numpy() / 5.0  # per minute
    noise = np.random.default_rng(seed).normal(0.0, 0.003, X.shape[0])
    return X, 0.1 + 0.003 * X["temperature"].to_numpy() + RATE_GAIN * rate + noise


def small_glass_campaign():
    """One "layered_glass" unit, two runs at each of two azimuths, profile "mix", 60-s samples
    (seed 3): long enough for ThermalFeatures(transition="auto") to search (it needs 200 rows
    and two held-out folds), short enough for a unit test."""
    return make_thermal_campaign(
        n_units=1,
        n_runs=2,
        azimuths=(0.0, 90.0),
        profile="mix",
        physics="layered_glass",
        random_state=3,
    )
