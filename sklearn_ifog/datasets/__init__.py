"""Data sets: the thermal-test simulator and shipped recordings."""

from sklearn_ifog.datasets._ageing import age_campaign
from sklearn_ifog.datasets._real import load_psim_tvc
from sklearn_ifog.datasets._simulator import make_thermal_campaign, noise_floor

__all__ = ["age_campaign", "load_psim_tvc", "make_thermal_campaign", "noise_floor"]
