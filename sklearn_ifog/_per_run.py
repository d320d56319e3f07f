"""The per-run tables' shared pieces: the whole-data row's label, the inputs checked to one
shape, the sampling period of a run.

Serves :func:`sklearn_ifog.metrics.per_run_metrics` and the report
(:mod:`sklearn_ifog.report`), which reads the same arrays for its figures and the Allan
deviation.
"""

import numpy as np

__all__ = ["ALL_RUNS", "compensation_arrays", "sample_period"]

# Label of the whole-data row of the per-run table (parenthesised so no run label collides).
ALL_RUNS = "(all runs)"


def sample_period(time_values):
    """Median sampling interval, and whether sampling is uniform (within 1 %)."""
    if time_values is None or time_values.size < 2:
        return 1.0, time_values is None
    steps = np.diff(time_values)
    period = float(np.median(steps))
    uniform = period > 0 and bool(np.all(np.abs(steps - period) <= 0.01 * period))
    return period, uniform


def compensation_arrays(rate, drift, reference, temperature, time):
    """The inputs of ``per_run_metrics`` as float arrays of one shape; time defaulted."""
    rate = np.asarray(rate, dtype=float)
    n_samples = rate.shape[0]
    drift = np.asarray(drift, dtype=float)
    reference = np.broadcast_to(np.asarray(reference, dtype=float), rate.shape)
    temperature = np.asarray(temperature, dtype=float)
    time_values = (
        np.arange(n_samples, dtype=float) if time is None else np.asarray(time, dtype=float)
    )
    for name, values in (("drift", drift), ("temperature", temperature), ("time", time_values)):
        if values.shape != rate.shape:
            raise ValueError(f"{name} has shape {values.shape}, rate has shape {rate.shape}.")
    return rate, drift, reference, temperature, time_values
