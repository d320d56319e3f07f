"""The columns of a compensated thermal test, one record, checked once.

:class:`RunColumns` holds what :func:`~sklearn_ifog.report.compensation_report` measures: the
gyro output, the predicted drift, the reference, the coil temperature and, optionally, the
time, run and unit of every sample. It checks them when it is made, naming the field.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["RunColumns"]


def _numbers(name, values):
    """``values`` as a float array; a ValueError naming the field if they are not numbers."""
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"RunColumns: {name} must be numeric; {exc}") from exc


def _labels(name, values, n_samples):
    """``values`` as an array of one label per sample; a ValueError naming the field if not."""
    labels = np.asarray(values)
    if labels.ndim != 1 or labels.shape[0] != n_samples:
        raise ValueError(
            f"RunColumns: {name} has shape {labels.shape}, rate has shape ({n_samples},); "
            f"give one {name} label per sample."
        )
    return labels


@dataclass(frozen=True, eq=False)
class RunColumns:
    """The columns of a compensated thermal test: one value per sample.

    The record :func:`~sklearn_ifog.report.compensation_report` measures. Every field is
    checked when the record is made (a ``ValueError`` names the field) and held as a numpy
    array: the numbers as floats, the labels as given.

    Parameters
    ----------
    rate : array-like of shape (n_samples,)
        Gyro output, deg/h.
    drift : array-like of shape (n_samples,)
        Predicted drift, deg/h; the compensated output is ``rate - drift``.
    reference : float or array-like of shape (n_samples,)
        True input rate, deg/h (one value for all samples, or one per sample).
    temperature : array-like of shape (n_samples,)
        Coil temperature, deg C.
    time : array-like of shape (n_samples,), default=None
        Time, seconds (None: the sample index, at an assumed 1 s period).
    run : array-like of shape (n_samples,), default=None
        Run label of each row; None means one run. Rows of a run are in time order; runs
        may be interleaved.
    unit : array-like of shape (n_samples,), default=None
        Unit (gyro) label of each row, e.g. for a :class:`~sklearn_ifog.UnitwiseRegressor`
        (None: no per-unit table).

    Raises
    ------
    ValueError
        If ``rate`` is not one-dimensional, a number field is not numeric, ``drift``,
        ``temperature`` or ``time`` does not have the shape of ``rate``, ``reference`` is
        neither one value nor one per sample, or ``run`` or ``unit`` does not have one
        label per sample.

    See Also
    --------
    compensation_report : The report of these columns.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.report import RunColumns
    >>> temperature = np.array([20.0, 21.0, 22.0])
    >>> columns = RunColumns(
    ...     rate=[7.6, 7.62, 7.64], drift=[0.1, 0.12, 0.14], reference=7.5, temperature=temperature
    ... )
    >>> columns.rate - columns.drift
    array([7.5, 7.5, 7.5])
    >>> RunColumns(rate=[1.0, 2.0], drift=[0.0], reference=0.0, temperature=[20.0, 21.0])
    Traceback (most recent call last):
    ...
    ValueError: RunColumns: drift has shape (1,), rate has shape (2,).
    """

    rate: Any
    drift: Any
    reference: Any
    temperature: Any
    time: Any = None
    run: Any = None
    unit: Any = None

    def __post_init__(self):
        rate = _numbers("rate", self.rate)
        if rate.ndim != 1:
            raise ValueError(
                f"RunColumns: rate must be one-dimensional (one value per sample), got shape "
                f"{rate.shape}."
            )
        checked = {"rate": rate}
        for name in ("drift", "temperature", "time"):
            values = getattr(self, name)
            if name == "time" and values is None:
                continue
            checked[name] = _numbers(name, values)
            if checked[name].shape != rate.shape:
                raise ValueError(
                    f"RunColumns: {name} has shape {checked[name].shape}, rate has shape "
                    f"{rate.shape}."
                )
        checked["reference"] = _numbers("reference", self.reference)
        if checked["reference"].shape not in ((), rate.shape):
            raise ValueError(
                f"RunColumns: reference has shape {checked['reference'].shape}, rate has shape "
                f"{rate.shape}; give one reference for all samples or one per sample."
            )
        for name in ("run", "unit"):
            if getattr(self, name) is not None:
                checked[name] = _labels(name, getattr(self, name), rate.shape[0])
        for name, values in checked.items():
            object.__setattr__(self, name, values)

    @property
    def n_samples(self):
        """Number of samples (rows)."""
        return self.rate.shape[0]
