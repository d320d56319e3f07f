"""Behaviour of the thermal features that mutation testing found unguarded (issue 42,
point 5).

Each test here kills mutants of :mod:`sklearn_ifog.features` that survived
``tests/test_features.py`` and ``tests/test_lags.py`` (``tools/mutation.sh features``); the
docstrings say which.
"""

import numpy as np
import pandas as pd
import pytest

from sklearn_ifog import ThermalFeatures
from sklearn_ifog._table import TableError
from sklearn_ifog.features import (
    assemble_terms,
    causal_rate,
    compute_thermal_features,
    validate_terms,
)


def test_bad_terms_and_run_starts_are_named():
    """The messages name the parameter and what was expected (kills the mutants that
    replaced them by None)."""
    with pytest.raises(ValueError, match=r"terms must be a list or tuple .* \('T',\)\?"):
        validate_terms("T", 1)
    with pytest.raises(ValueError, match=r"run_starts must have shape \(5,\), got \(4,\)"):
        causal_rate(np.arange(5.0), run_starts=np.zeros(4, dtype=bool))
    t = np.linspace(20.0, 30.0, 6)
    with pytest.raises(
        ValueError,
        match=r"\['T_lag900s'\] need their deficit.*\(got time constants \[\]\)",
    ):
        assemble_terms(t, np.zeros(6), ["T", "T_lag900s"])


def test_the_defaults_give_a_rate_per_minute_without_smoothing():
    """:func:`compute_thermal_features` by default: ``dT`` in degrees per minute of a time in
    seconds (kills ``seconds_per_unit=61.0``), not smoothed (kills ``smoothing=1.0``)."""
    time = np.arange(0.0, 600.0, 30.0)
    temperature = 20.0 + np.where(time < 300.0, 0.0, (time - 300.0) / 60.0)  # 1 degC/min
    features = compute_thermal_features(temperature, time=time, terms=["dT"])[:, 0]
    assert features[time <= 300.0].tolist() == [0.0] * 11
    np.testing.assert_allclose(features[time > 300.0], 1.0, rtol=1e-12)


def test_a_smoothing_below_one_second_still_smooths():
    """``smoothing`` is a time constant in seconds: 0.5 s is a (short) smoothing, not none
    (kills ``smoothing > 1``)."""
    time = np.arange(0.0, 10.0, 0.25)
    temperature = 20.0 + np.where(time < 5.0, 0.0, time - 5.0)  # 1 degC/s from 5 s on
    raw = compute_thermal_features(temperature, time=time, terms=["dT"])[:, 0]
    smoothed = compute_thermal_features(temperature, time=time, terms=["dT"], smoothing=0.5)
    assert not np.allclose(raw, smoothed[:, 0])
    # The smoothed rate lags the raw one and reaches it (60 degC/min) within 1e-4 after ten
    # time constants (exp(-10) = 4.5e-5).
    onset = np.searchsorted(time, 5.0)
    assert smoothed[onset + 1, 0] < raw[onset + 1]
    assert smoothed[-1, 0] == pytest.approx(60.0, rel=1e-4)


def test_a_time_error_names_the_column_and_keeps_its_rows():
    """A DataFrame's time column that goes back: the error names the column and keeps the
    row, its time, the row it does not follow and the run (kills the mutants of the
    re-raise in ``ThermalFeatures._features``)."""
    X = pd.DataFrame(
        {
            "temperature": [20.0, 21.0, 22.0, 23.0, 24.0],
            "seconds": [0.0, 60.0, 120.0, 90.0, 180.0],
            "run": ["a"] * 5,
        }
    )
    features = ThermalFeatures(time="seconds", run="run", terms=["T", "dT"])
    with pytest.raises(TableError, match=r"^time column 'seconds': time must increase") as caught:
        features.fit_transform(X)
    error = caught.value
    assert (error.row, error.previous_row, error.value, error.run) == (3, 2, 90.0, "a")


def test_a_temperature_position_beyond_the_input_features_is_named():
    """Kills the mutant that replaced the message of that error by None, and ``>`` for
    ``>=``."""
    features = ThermalFeatures(temperature=[0, 5], terms=["T"])
    with pytest.raises(ValueError, match=r"temperature position 5 is out of range .* length 2"):
        features.get_feature_names_out(["a", "b"])
    # The first position past the end is out of range too (kills ``key > len(...)``).
    with pytest.raises(ValueError, match=r"temperature position 2 is out of range .* length 2"):
        ThermalFeatures(temperature=[0, 2], terms=["T"]).get_feature_names_out(["a", "b"])
