"""Data sets: the thermal-test and rate-table simulators and shipped recordings."""

from sklearn_ifog.datasets import _rate_table
from sklearn_ifog.datasets._ageing import age_campaign
from sklearn_ifog.datasets._rate_table import make_rate_table_campaign
from sklearn_ifog.datasets._real import load_psim_tvc
from sklearn_ifog.datasets._simulator import make_thermal_campaign, noise_floor

__all__ = [
    "DEFAULT_RATES",
    "RATE_TABLE_PRESETS",
    "age_campaign",
    "load_psim_tvc",
    "make_rate_table_campaign",
    "make_thermal_campaign",
    "noise_floor",
]

#: Turntable rates of :func:`make_rate_table_campaign`, deg/s: zero, then both signs of each
#: decade up to 300 deg/s, a navigation gyro's usual scale-factor test range.
DEFAULT_RATES = _rate_table.DEFAULT_RATES
#: The scale-factor models of :func:`make_rate_table_campaign` (its ``preset``), each adding
#: terms to the one before: ``"coil"`` (the coil's temperature and thermal state),
#: ``"coil_source"`` (plus the light source's own temperature) and ``"asymmetric"`` (plus a
#: rate asymmetry and an odd nonlinearity).
RATE_TABLE_PRESETS = _rate_table.RATE_TABLE_PRESETS
