"""Texts that quote the code (default terms, constants, round-off) say what the code does
(issue 42): the CLI's help, the unitwise rule's numbers, the words for a rate beyond its
calibrated range."""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.utils import Bunch

from sklearn_ifog import ThermalFeatures, UnitwiseRegressor, make_compensation_pipeline
from sklearn_ifog._tuning import ROUNDOFF_SHARE
from sklearn_ifog.cli import main
from sklearn_ifog.cli._compensate import _outside_lines
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.report import per_run_calibration
from sklearn_ifog.report._sections import _rate_clause
from sklearn_ifog.report._words import rate_beyond_text
from sklearn_ifog.unitwise import OWN_MODEL_SPREAD

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _help(capsys, *argv):
    assert main([*argv, "--help"]) == 0
    return " ".join(capsys.readouterr().out.split())


@pytest.fixture(scope="module")
def campaign():
    return make_thermal_campaign(
        n_units=1, n_runs=2, azimuths=[0.0], sampling_period=120.0, random_state=0
    ).data


def test_fit_help_lists_the_default_terms_the_code_resolves(capsys, campaign):
    """What ThermalFeatures(terms="auto") resolves to, with and without a time column, and
    the smoothing it then uses, as ``sklearn-ifog fit --help`` words them."""
    with_time = ThermalFeatures(temperature="temperature", time="time", run="run").fit(campaign)
    without_time = ThermalFeatures(temperature="temperature", run="run").fit(campaign)
    text = _help(capsys, "fit")
    expected = (
        f"terms='auto': {' '.join(with_time.terms_)}, dT smoothed over "
        f"{with_time.smoothing_:g} s, with a time column; {' '.join(without_time.terms_)} "
        "without one;"
    )
    assert expected in text
    # the default set has T2 and the products with T, which the help once left out
    assert {"T2", "TT_lag900s", "TT_lag3600s"} <= set(with_time.terms_)
    assert "T2" in without_time.terms_
    # and it is the set the fit command's pipeline resolves (terms=None)
    pipeline = make_compensation_pipeline(
        LinearRegression(), temperature="temperature", time="time", run="run", terms=None
    ).fit(campaign, np.zeros(campaign.shape[0]))
    assert pipeline.steps[0][1].terms_ == with_time.terms_


def test_the_own_model_rule_quotes_its_constant():
    """The unitwise rule's numbers in its docstring and the user guide are
    OWN_MODEL_SPREAD's (3: nine, not the two standard deviations a test once said)."""
    words = {2.0: "two", 3.0: "three", 4.0: "four"}
    threshold = f"1 / {OWN_MODEL_SPREAD**2:g}"
    doc = " ".join(UnitwiseRegressor.__doc__.split())
    assert f"n_u lam_u <= {threshold}" in doc
    assert f"{words[OWN_MODEL_SPREAD]} noise standard deviations or more" in doc
    guide = " ".join((DOCS / "user_guide" / "unitwise.rst").read_text().split())
    assert f"n_u · lam_u ≤ {threshold.replace(' ', '')}" in guide
    assert f"{words[OWN_MODEL_SPREAD]} noise standard deviations or more" in guide
    tests = Path(__file__).with_name("test_unitwise.py").read_text()
    assert not re.search(r"\btwo noise standard\s+deviations", tests)


def test_a_rate_round_off_is_not_worded_as_a_rate_beyond():
    """1.47e-14 below a soak's rate 0 is round-off: 1e-9 of the calibrated range is the
    line (ROUNDOFF_SHARE), in any unit of dT; an excess above it is still worded."""
    assert rate_beyond_text(1.47e-14, 0.0, 0.0, 0.5) == ""
    assert rate_beyond_text(0.0, 1.47e-14, 0.0, 0.5) == ""
    # the same round-off in degC per second (a range 60 times smaller) is round-off too
    assert rate_beyond_text(1.47e-14 / 60, 0.0, 0.0, 0.5 / 60) == ""
    # just past the tolerance, and a real excess, are words
    assert rate_beyond_text(2 * ROUNDOFF_SHARE * 0.5, 0.0, 0.0, 0.5) == "1e-09 below the slowest"
    assert rate_beyond_text(0.02, 0.3, 0.0, 0.5) == (
        "0.02 below the slowest and 0.3 above the fastest"
    )
    # an absolute tolerance would fail the other way: 1e-9 degC/min on a tiny rate range
    assert rate_beyond_text(1e-9, 0.0, 0.0, 1e-4) == "1e-09 below the slowest"


def _status(rate_excess, outside=None):
    """A calibration status of 4 rows: temperature beyond on rows 1-2, the given rate
    excess, a calibrated rate range 0 to 0.5 and temperatures 10 to 40."""
    n = len(rate_excess)
    return Bunch(
        outside=np.ones(n, dtype=bool) if outside is None else outside,
        distance=np.full(n, 3.0),
        temperature_excess=np.array([0.0, -2.0, -4.0, 0.0]),
        temperature_min=np.full(n, 10.0),
        temperature_max=np.full(n, 40.0),
        rate_excess=np.asarray(rate_excess, dtype=float),
        rate_min=np.zeros(n),
        rate_max=np.full(n, 0.5),
        policy=np.full(n, "blend", dtype=object),
        fallback=np.full(n, "plane", dtype=object),
        adjusted=np.ones(n, dtype=bool),
    )


def test_cli_and_report_leave_a_rate_round_off_out():
    runs = np.array(["a", "a", "b", "b"])
    roundoff = _status([0.0, -1.47e-14, 0.0, 1.1e-15])
    lines = _outside_lines(roundoff, runs, "run")
    assert len(lines) == 3
    assert all("slowest" not in line and "fastest" not in line for line in lines)
    assert "temperature up to 2 degC below the coldest" in lines[1]
    assert _rate_clause(per_run_calibration(roundoff, runs), roundoff) == ""
    real = _status([0.0, -0.03, 0.0, 0.0])
    lines = _outside_lines(real, runs, "run")
    assert "rate dT up to 0.03 below the slowest calibrated rate (0 to 0.5)" in lines[1]
    assert "slowest" not in lines[2]
    assert "went 0.03 below the slowest calibrated rate" in _rate_clause(
        per_run_calibration(real, runs), real
    )


def test_the_outside_warning_leaves_a_rate_round_off_out(campaign):
    """The pipeline's OutsideCalibrationWarning follows the same rule."""
    model = make_compensation_pipeline(
        LinearRegression(), temperature="temperature", time="time", run="run"
    ).fit(campaign, np.zeros(campaign.shape[0]))
    rates = list(model.domain_.rate_columns_)
    assert rates
    column = rates[0]
    low, high = model.domain_.data_min_[column], model.domain_.data_max_[column]
    rows = np.tile(model.domain_.center_, (3, 1))
    outside = np.array([True, True, False])
    beyond = np.zeros(3)
    distance = np.full(3, 5.0)
    for excess, worded in ((1.47e-14, False), (0.05 * (high - low), True)):
        rows[0, column] = low - excess
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model._warn_outside(distance, beyond, outside, rows)
        (message,) = [str(w.message) for w in caught if w.category is OutsideCalibrationWarning]
        assert ("beyond the calibrated dT" in message) is worded, message
