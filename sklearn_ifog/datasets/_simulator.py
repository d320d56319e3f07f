"""Thermal-test simulator (placeholder until the simulator work lands; being written now)."""


def make_thermal_campaign(*args, **kwargs):
    """Placeholder."""
    raise NotImplementedError
