"""The feature contract: term names, time units and sensor keys, defined once.

:class:`~sklearn_ifog.ThermalFeatures` computes its terms from this registry, and the
streaming compensator, the exporters (C and JSON) and the plots read the same tables, so a
term or a unit is added in one place:

- :data:`TERMS`: every term by name, with its output column name, how it is computed from a
  sensor's raw temperature and rate, its C expression and whether it needs the rate (the
  smoothed temperature and the last time stamp carried between samples);
- :data:`SECONDS_PER_UNIT` and :func:`seconds_per_unit`: the time units of ``rate_unit`` (and
  of the plots' time axis);
- :func:`sensor_keys`: the temperature column(s) of a ``temperature`` parameter, as a list.
"""

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

__all__ = [
    "SECONDS_PER_UNIT",
    "TERMS",
    "VALID_TERMS",
    "SensorInputs",
    "Term",
    "get_term",
    "seconds_per_unit",
    "sensor_keys",
    "uses_rate",
]

#: Seconds in one time unit, by name (``rate_unit`` of ThermalFeatures, plots' time axis).
SECONDS_PER_UNIT = {"s": 1.0, "min": 60.0, "h": 3600.0}


class SensorInputs(NamedTuple):
    """What a term is computed from, for one sensor (arrays of shape (n_samples,))."""

    T: np.ndarray
    """Raw temperature of the sensor, deg C."""
    dT: np.ndarray
    """Its causal rate (of the smoothed temperature), see ``features.causal_rate``."""
    first: np.ndarray
    """Raw temperature of the first sensor."""


class Term(NamedTuple):
    """One feature term of ThermalFeatures."""

    name: str
    """The name given in ``terms=``."""
    output: str
    """Output column name (one sensor; several sensors prefix it with the sensor's name)."""
    compute: Callable[[SensorInputs], np.ndarray]
    """The column of one sensor from its :class:`SensorInputs`."""
    c_expression: str
    """The same in C, from ``raw``, ``delta`` and ``temperature[0]`` (the export's names)."""
    uses_rate: bool
    """True if the term needs the rate: the smoothed temperature and last time as state."""
    first_sensor: bool = True
    """False if the first sensor has no column of this term (identically zero)."""


#: Every term ThermalFeatures knows, by name, in the order the documentation lists them.
TERMS = {
    term.name: term
    for term in (
        Term("T", "T", lambda s: s.T, "raw", uses_rate=False),
        Term("dT", "dT", lambda s: s.dT, "delta", uses_rate=True),
        Term("TdT", "T_dT", lambda s: s.T * s.dT, "raw * delta", uses_rate=True),
        Term("T2", "T2", lambda s: s.T * s.T, "raw * raw", uses_rate=False),
        Term(
            "gradient",
            "gradient",
            lambda s: s.T - s.first,
            "raw - temperature[0]",
            uses_rate=False,
            first_sensor=False,
        ),
    )
}

#: The names of :data:`TERMS`, in order.
VALID_TERMS = tuple(TERMS)


def get_term(name):
    """The :class:`Term` called ``name``.

    Parameters
    ----------
    name : str
        A term name, one of :data:`VALID_TERMS`.

    Returns
    -------
    term : Term
        Its definition.

    Raises
    ------
    ValueError
        If no term has that name.

    Examples
    --------
    >>> from sklearn_ifog._contract import get_term
    >>> get_term("TdT").output, get_term("TdT").uses_rate
    ('T_dT', True)
    """
    try:
        return TERMS[name]
    except (KeyError, TypeError):
        raise ValueError(f"Unknown term {name!r}; valid terms are {list(VALID_TERMS)}.") from None


def uses_rate(terms):
    """True if any of ``terms`` needs the rate (and so the smoothing and time state).

    Parameters
    ----------
    terms : sequence of str
        Term names.

    Returns
    -------
    uses_rate : bool
        Whether a term of the sequence is computed from the rate.

    Examples
    --------
    >>> from sklearn_ifog._contract import uses_rate
    >>> uses_rate(["T", "T2"]), uses_rate(["T", "TdT"])
    (False, True)
    """
    return any(get_term(term).uses_rate for term in terms)


def seconds_per_unit(unit):
    """Seconds in one time unit: a name of :data:`SECONDS_PER_UNIT` or a number of seconds.

    Parameters
    ----------
    unit : {"s", "min", "h"} or float
        The unit (``rate_unit`` of ThermalFeatures), or its length in seconds.

    Returns
    -------
    seconds : float
        Seconds per unit.

    Raises
    ------
    ValueError
        If ``unit`` is a string that names no unit.

    Examples
    --------
    >>> from sklearn_ifog._contract import seconds_per_unit
    >>> seconds_per_unit("min"), seconds_per_unit(0.5)
    (60.0, 0.5)
    """
    if isinstance(unit, str):
        if unit not in SECONDS_PER_UNIT:
            raise ValueError(
                f"Unknown time unit {unit!r}; expected one of {list(SECONDS_PER_UNIT)} or "
                "a number of seconds."
            )
        return SECONDS_PER_UNIT[unit]
    return float(unit)


def sensor_keys(temperature):
    """The temperature column key(s) of a ``temperature`` parameter, as a list.

    Parameters
    ----------
    temperature : str, int, list or tuple
        One column (name or position) or a list/tuple of them, one per sensor.

    Returns
    -------
    keys : list
        The columns, one per sensor, in order.

    Raises
    ------
    ValueError
        If the list is empty.

    Examples
    --------
    >>> from sklearn_ifog._contract import sensor_keys
    >>> sensor_keys("coil"), sensor_keys(("coil", "case"))
    (['coil'], ['coil', 'case'])
    """
    keys = list(temperature) if isinstance(temperature, list | tuple) else [temperature]
    if not keys:
        raise ValueError("temperature is empty; give at least one temperature column.")
    return keys
