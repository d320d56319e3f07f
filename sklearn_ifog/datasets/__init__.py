"""Data sets: the thermal-test and rate-table simulators and shipped recordings."""

from sklearn_ifog.datasets._ageing import age_campaign
from sklearn_ifog.datasets._rate_table import (
    DEFAULT_RATES,
    RATE_TABLE_PRESETS,
    make_rate_table_campaign,
)
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
