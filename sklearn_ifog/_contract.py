"""The feature contract: term names, time units and sensor keys, defined once.

:class:`~sklearn_ifog.ThermalFeatures` computes its terms from this registry, and the
streaming compensator, the exporters (C and JSON) and the plots read the same tables, so a
term or a unit is added in one place:

- :data:`TERMS`: every term by name, with its output column name, how it is computed from a
  sensor's raw temperature and rate, its C expression and whether it needs the rate (the
  last temperature and time stamp carried between samples);
- :data:`TERM_FAMILIES`: terms with a parameter in their name, such as the thermal-state
  term ``T_lag600s`` (the excess ``T - lag_600s(T)`` of the temperature over its first-order
  lag at 600 s); :func:`get_term` reads a name against :data:`TERMS`, then these patterns;
- :data:`SECONDS_PER_UNIT` and :func:`seconds_per_unit`: the time units of ``rate_unit`` (and
  of the plots' time axis);
- :func:`sensor_keys`: the temperature column(s) of a ``temperature`` parameter, as a list;
- :data:`DEFAULT_TERMS` (the paper's), :data:`DEFAULT_ROW_TERMS`, :data:`DEFAULT_STATE_TERMS`,
  :data:`DEFAULT_SMOOTHING` and :func:`resolve_defaults`: what ThermalFeatures'
  ``terms="auto"`` and ``smoothing="auto"`` mean, with and without a time column;
  :func:`resolved_settings` reads them off a ThermalFeatures (for the schema, the stream
  and the comparison harness) and :func:`traditional_terms` drops the paper's T·ΔT term.
"""

import re
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from sklearn_ifog import _transition

__all__ = [
    "DEFAULT_ROW_TERMS",
    "DEFAULT_SMOOTHING",
    "DEFAULT_STATE_TERMS",
    "DEFAULT_TERMS",
    "SECONDS_PER_UNIT",
    "TERMS",
    "TERM_FAMILIES",
    "VALID_TERMS",
    "SensorInputs",
    "Term",
    "TermFamily",
    "check_needs_time",
    "format_seconds",
    "get_term",
    "lag_time_constants",
    "resolve_defaults",
    "seconds_per_unit",
    "sensor_keys",
    "state_time_constants",
    "uses_rate",
    "valid_terms_text",
]

#: The reference paper's feature set (T, dT, T·dT): its modified model (without ``"TdT"``:
#: its traditional model).
DEFAULT_TERMS = ("T", "dT", "TdT")

#: ``terms="auto"`` without a time column: the paper's terms and T², the static bias being
#: quadratic in T (the default network's tail is linear, so the square is a feature).
DEFAULT_ROW_TERMS = ("T", "dT", "TdT", "T2")

#: The thermal-state feature set, ``terms="auto"`` with a time column: the paper's terms, T²,
#: and the excess of T over its first-order lags at 900 s and 3600 s with their products
#: with T (the coil's Shupe and stress coefficients vary with T, as the paper's T·dT says
#: for dT). These are the physics' terms, so a linear model on them extrapolates; a model
#: with every square and cross product of them fits slowly varying gyro noise instead.
#: Measured against :data:`DEFAULT_TERMS` and the same set without the products over
#: physics presets, seeds and sample periods by ``python benchmarks/bench_thermal_state.py``.
DEFAULT_STATE_TERMS = (
    "T",
    "dT",
    "TdT",
    "T2",
    "T_lag900s",
    "TT_lag900s",
    "T_lag3600s",
    "TT_lag3600s",
)

#: Smoothing time constant of dT, s, of ``smoothing="auto"`` with a time column and thermal-state
#: (lag) terms, measured with :data:`DEFAULT_STATE_TERMS` by the same benchmark.
DEFAULT_SMOOTHING = 120.0

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
    lag: dict | None = None
    """Deficit ``T - lag_tau(T)`` of the sensor by time constant ``tau`` (s), for lag terms."""


class Term(NamedTuple):
    """One feature term of ThermalFeatures."""

    name: str
    """The name given in ``terms=``."""
    output: str
    """Output column name (one sensor; several sensors prefix it with the sensor's name)."""
    compute: Callable[[SensorInputs], np.ndarray]
    """The column of one sensor from its :class:`SensorInputs`."""
    c_expression: str
    """The same in C, from ``raw``, ``delta``, ``temperature[0]`` and ``deficit[{lag}]`` (the
    export's names; ``{lag}`` is replaced by the index of the term's time constant in
    :func:`lag_time_constants`)."""
    uses_rate: bool
    """True if the term needs the rate: the last temperature and time as state."""
    first_sensor: bool = True
    """False if the first sensor has no column of this term (identically zero)."""
    time_constants: tuple = ()
    """Time constants (s) of the first-order lags the term reads, in the order of the
    ``{lag0}``, ``{lag1}`` fields of ``c_expression``: a term with one needs a time column
    and carries each lag's deficit as state."""
    parameters: dict | None = None
    """What a parametrised term's name says, for the exports (a transition term's shape,
    centre, width, lag and multiplier); None for the fixed terms and the lag terms."""

    @property
    def time_constant(self):
        """The first of :attr:`time_constants` (the lag a lag term reads), or None."""
        return self.time_constants[0] if self.time_constants else None

    def expression(self, time_constants):
        """:attr:`c_expression` with each lag field replaced by its index in
        ``time_constants`` (the carried deficits' order)."""
        indices = [list(time_constants).index(tau) for tau in self.time_constants]
        return self.c_expression.format(**{f"lag{k}": index for k, index in enumerate(indices)})


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


def format_seconds(seconds):
    """A time constant in seconds as a term name writes it: ``600``, ``90.5``.

    Parameters
    ----------
    seconds : float
        A finite number of seconds.

    Returns
    -------
    text : str
        The integer without a decimal point, otherwise Python's shortest ``repr``.

    Examples
    --------
    >>> from sklearn_ifog._contract import format_seconds
    >>> format_seconds(600.0), format_seconds(90.5)
    ('600', '90.5')
    """
    seconds = float(seconds)
    return str(int(seconds)) if seconds.is_integer() else repr(seconds)


class TermFamily(NamedTuple):
    """Terms with a parameter in their name (e.g. a time constant), read by a pattern."""

    pattern: re.Pattern
    """The full name, with groups for the parameters."""
    form: str
    """The name's form, for error messages (e.g. ``"T_lag<tau>s"``)."""
    examples: tuple
    """Valid names, for error messages."""
    make: Callable[[re.Match], Term]
    """The :class:`Term` of a matching name; raises ValueError on a bad parameter."""
    rule: str = "with tau in seconds, an integer or decimal number > 0"
    """What the name's parameters are, for error messages."""


def _time_constant(match):
    tau = float(match.group(1))
    if not (np.isfinite(tau) and tau > 0):
        raise ValueError(
            f"Term {match.group(0)!r}: the time constant must be > 0 seconds, got {tau!r}."
        )
    return tau


def _lag_term(match):
    tau = _time_constant(match)
    return Term(
        name=match.group(0),
        output=f"T_lag{format_seconds(tau)}s",
        compute=lambda s: s.lag[tau],
        c_expression="deficit[{lag0}]",
        uses_rate=False,
        time_constants=(tau,),
    )


def _lag_product_term(match):
    tau = _time_constant(match)
    return Term(
        name=match.group(0),
        output=f"T_T_lag{format_seconds(tau)}s",
        compute=lambda s: s.T * s.lag[tau],
        c_expression="raw * deficit[{lag0}]",
        uses_rate=False,
        time_constants=(tau,),
    )


def _transition_term(match):
    shape, centre, width, lag, multiplier, multiplier_lag = match.groups()
    centre, width, lag = float(centre), float(width), float(lag)
    name = match.group(0)
    if not (np.isfinite(width) and width > 0):
        raise ValueError(f"Term {name!r}: the transition's width must be > 0 degC, got {width!r}.")
    if not (np.isfinite(lag) and lag > 0):
        raise ValueError(f"Term {name!r}: the transition's lag must be > 0 seconds, got {lag!r}.")
    output = _transition.transition_name(shape, centre, width, lag)
    inner = "raw - deficit[{lag0}]"
    expression = _transition.step_c_expression(shape, inner, centre, width)

    def step_of(s):
        return _transition.step(shape, s.T - s.lag[lag], centre, width)

    time_constants = (lag,)
    compute = step_of
    uses_rate = False
    if multiplier == "dT":
        output += "_dT"
        expression = f"{expression} * delta"
        uses_rate = True

        def compute(s):
            return step_of(s) * s.dT

    elif multiplier is not None:
        tau = float(multiplier_lag)
        if not (np.isfinite(tau) and tau > 0):
            raise ValueError(f"Term {name!r}: the time constant must be > 0 seconds, got {tau!r}.")
        output += f"_T_lag{format_seconds(tau)}s"
        expression = f"{expression} * deficit[{{lag1}}]"
        time_constants = (lag, tau)

        def compute(s):
            return step_of(s) * s.lag[tau]

    return Term(
        name=name,
        output=output,
        compute=compute,
        c_expression=expression,
        uses_rate=uses_rate,
        time_constants=time_constants,
        parameters={
            "shape": shape,
            "centre": centre,
            "width": width,
            "lag": lag,
            "multiplier": multiplier if multiplier in (None, "dT") else "T_lag",
            "multiplier_lag": None if multiplier_lag is None else float(multiplier_lag),
        },
    )


_NUMBER = r"([0-9]+(?:\.[0-9]+)?)"

#: Parametrised terms: ``T_lag<tau>s`` is the excess ``T - lag_tau(T)`` of the temperature
#: over its causal first-order lag at time constant ``tau`` seconds (an integer or decimal
#: number), exact between samples for a temperature linear between them, 0 at a run's first
#: row (see :mod:`sklearn_ifog._lags`). ``TT_lag<tau>s`` is ``T * (T - lag_tau(T))``: what
#: ``TdT`` is to ``dT``, since the coil's Shupe and stress coefficients vary with T, so each
#: thermal-state term acts with a temperature-dependent gain (output name ``T_T_lag<tau>s``).
#:
#: ``<shape><c>C_w<w>C_lag<tau>s`` is a transition term (:mod:`sklearn_ifog._transition`): a
#: smooth step of shape ``logistic``, ``erf`` or ``hinge`` (softplus), centre ``c`` and width
#: ``w`` degC, of the inner temperature ``T - (T - lag_tau(T))`` (the sensor's lag at ``tau``
#: seconds); ``..._dT`` is that step times the rate, ``..._T_lag<tau2>s`` times the lag excess
#: at ``tau2`` (a coating's stiffness step times the coil's radial gradient).
TERM_FAMILIES = (
    TermFamily(
        pattern=re.compile(r"T_lag([0-9]+(?:\.[0-9]+)?)s"),
        form="T_lag<tau>s",
        examples=("T_lag600s", "T_lag90.5s"),
        make=_lag_term,
    ),
    TermFamily(
        pattern=re.compile(r"TT_lag([0-9]+(?:\.[0-9]+)?)s"),
        form="TT_lag<tau>s",
        examples=("TT_lag600s",),
        make=_lag_product_term,
    ),
    TermFamily(
        pattern=re.compile(
            "("
            + "|".join(_transition.TRANSITION_SHAPES)
            + ")"
            + r"(-?[0-9]+(?:\.[0-9]+)?)C_w"
            + _NUMBER
            + "C_lag"
            + _NUMBER
            + "s"
            + r"(?:_(dT|T_lag"
            + _NUMBER
            + "s))?"
        ),
        form="<shape><c>C_w<w>C_lag<tau>s[_dT|_T_lag<tau>s]",
        examples=("logistic20C_w2C_lag900s_T_lag3600s", "erf-5.5C_w3C_lag600s_dT"),
        make=_transition_term,
        rule=(
            f"with <shape> one of {list(_transition.TRANSITION_SHAPES)}, the centre <c> and "
            "width <w> > 0 in degC and the inner temperature's lag <tau> > 0 in seconds: a "
            "smooth step, alone or times dT or a lag excess"
        ),
    ),
)


def valid_terms_text():
    """The valid term names and forms, as error messages list them.

    Returns
    -------
    text : str
        The fixed names, then each parametrised form with examples.

    Examples
    --------
    >>> from sklearn_ifog._contract import valid_terms_text
    >>> print(valid_terms_text())  # doctest: +NORMALIZE_WHITESPACE
    ['T', 'dT', 'TdT', 'T2', 'gradient'], or 'T_lag<tau>s' with tau in seconds, an integer or
    decimal number > 0 (e.g. 'T_lag600s', 'T_lag90.5s'); 'TT_lag<tau>s' with tau in
    seconds, an integer or decimal number > 0 (e.g. 'TT_lag600s');
    '<shape><c>C_w<w>C_lag<tau>s[_dT|_T_lag<tau>s]' with <shape> one of ['logistic', 'erf',
    'hinge'], the centre <c> and width <w> > 0 in degC and the inner temperature's lag <tau>
    > 0 in seconds: a smooth step, alone or times dT or a lag excess (e.g.
    'logistic20C_w2C_lag900s_T_lag3600s', 'erf-5.5C_w3C_lag600s_dT')
    """
    forms = "; ".join(
        f"{family.form!r} {family.rule} (e.g. "
        + ", ".join(repr(example) for example in family.examples)
        + ")"
        for family in TERM_FAMILIES
    )
    return f"{list(VALID_TERMS)}, or {forms}"


def get_term(name):
    """The :class:`Term` called ``name``.

    Parameters
    ----------
    name : str
        A term name: one of :data:`VALID_TERMS` or of the forms of :data:`TERM_FAMILIES`.

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
    >>> get_term("T_lag600.0s").output, get_term("T_lag600.0s").time_constant
    ('T_lag600s', 600.0)
    """
    if isinstance(name, str):
        if name in TERMS:
            return TERMS[name]
        for family in TERM_FAMILIES:
            match = family.pattern.fullmatch(name)
            if match:
                return family.make(match)
    raise ValueError(f"Unknown term {name!r}; valid terms are {valid_terms_text()}.")


def lag_time_constants(terms):
    """The distinct time constants (s) of the lag terms among ``terms``, sorted.

    Parameters
    ----------
    terms : sequence of str
        Term names.

    Returns
    -------
    time_constants : tuple of float
        Sorted, without duplicates; empty when no term is a lag.

    Examples
    --------
    >>> from sklearn_ifog._contract import lag_time_constants
    >>> lag_time_constants(["T", "T_lag3600s", "dT", "T_lag600s"])
    (600.0, 3600.0)
    """
    taus = {tau for term in terms for tau in get_term(term).time_constants}
    return tuple(sorted(taus))


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


def state_time_constants(terms, smoothing=0.0):
    """Every first-order lag (s) ThermalFeatures carries per sensor: lag terms and smoothing.

    The lag terms' time constants and, when ``smoothing > 0``, the smoothing time constant
    (``dT`` is then the smoothed rate, the deficit at that constant over it), sorted, without
    duplicates. Streaming, C and JSON carry one deficit per sensor and per entry.

    Parameters
    ----------
    terms : sequence of str
        Term names.
    smoothing : float, default=0.0
        Smoothing time constant, s (0: none).

    Returns
    -------
    time_constants : tuple of float
        Sorted, distinct; empty when nothing is lagged.

    Examples
    --------
    >>> from sklearn_ifog._contract import state_time_constants
    >>> state_time_constants(["T", "dT", "T_lag600s"], smoothing=60.0)
    (60.0, 600.0)
    """
    taus = set(lag_time_constants(terms))
    if smoothing > 0:
        taus.add(float(smoothing))
    return tuple(sorted(taus))


def check_needs_time(terms, smoothing, has_time):
    """Raise unless the terms and the smoothing have the time column they need.

    Time constants are in seconds; a lag or a smoothing counted in rows would change with
    the sample period, so without a time column they are refused.

    Parameters
    ----------
    terms : sequence of str
        Term names.
    smoothing : float
        Smoothing time constant, s (0: none).
    has_time : bool
        Whether a time column is given.

    Raises
    ------
    ValueError
        If a lag term or ``smoothing > 0`` comes without a time column.

    Examples
    --------
    >>> from sklearn_ifog._contract import check_needs_time
    >>> check_needs_time(["T", "dT"], 0.0, has_time=False)
    >>> check_needs_time(["T_lag600s"], 0.0, has_time=False)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: The lag term(s) ['T_lag600s'] need a time column (time=...): ...
    """
    if has_time:
        return
    lags = [term for term in terms if get_term(term).time_constants]
    if lags:
        raise ValueError(
            f"The lag term(s) {lags} need a time column (time=...): their time constants are "
            "in seconds, and a lag counted in rows would change with the sample period."
        )
    if smoothing > 0:
        raise ValueError(
            f"smoothing={smoothing!r} is a time constant in seconds and needs a time column "
            "(time=...); without one, use smoothing=0."
        )


def resolve_defaults(terms, smoothing, has_time):
    """What ``terms="auto"`` and ``smoothing="auto"`` of ThermalFeatures mean.

    - ``terms="auto"``: :data:`DEFAULT_STATE_TERMS` with a time column,
      :data:`DEFAULT_ROW_TERMS` (the paper's terms and T²) without one (rows only: no time
      constant can be honoured);
    - ``smoothing="auto"``: :data:`DEFAULT_SMOOTHING` seconds with a time column when the
      (resolved) terms hold a thermal-state term ``T_lag<tau>s``, as measured; otherwise 0
      (no smoothing: the paper's backward difference, so ``terms=DEFAULT_TERMS`` is exactly
      the paper's feature set).

    Any other value is returned as given (a sequence of terms as a tuple, smoothing as a
    float; a string of terms other than ``"auto"`` unchanged, for the caller's validation to
    name).

    Parameters
    ----------
    terms : "auto" or sequence of str
        The ``terms`` parameter.
    smoothing : "auto" or float
        The ``smoothing`` parameter, s.
    has_time : bool
        Whether a time column is given.

    Returns
    -------
    terms : tuple of str
        The terms to compute.
    smoothing : float
        The smoothing time constant, s (0: none).

    Examples
    --------
    >>> from sklearn_ifog._contract import resolve_defaults
    >>> resolve_defaults("auto", "auto", has_time=True)  # doctest: +NORMALIZE_WHITESPACE
    (('T', 'dT', 'TdT', 'T2', 'T_lag900s', 'TT_lag900s', 'T_lag3600s', 'TT_lag3600s'),
     120.0)
    >>> resolve_defaults("auto", "auto", has_time=False)
    (('T', 'dT', 'TdT', 'T2'), 0.0)
    >>> resolve_defaults(("T", "dT", "TdT"), "auto", has_time=True)
    (('T', 'dT', 'TdT'), 0.0)
    """
    if isinstance(terms, str) and terms == "auto":
        terms = DEFAULT_STATE_TERMS if has_time else DEFAULT_ROW_TERMS
    if not isinstance(terms, str):
        terms = tuple(terms)
    if isinstance(smoothing, str) and smoothing == "auto":
        state = has_time and bool(lag_time_constants(terms)) if _all_known(terms) else False
        smoothing = DEFAULT_SMOOTHING if state else 0.0
    return terms, float(smoothing)


def _all_known(terms):
    """True if every entry of ``terms`` names a term (bad names are reported elsewhere)."""
    if isinstance(terms, str):
        return False
    try:
        for term in terms:
            get_term(term)
    except ValueError:
        return False
    return True


def resolved_settings(features):
    """``(terms, smoothing)`` of a ThermalFeatures, with ``"auto"`` resolved.

    Its fitted ``terms_`` and ``smoothing_`` after ``fit``; before it, its parameters read
    through :func:`resolve_defaults`. The export schema, the stream and the comparison
    harness read a transformer's settings through this one function.

    Parameters
    ----------
    features : ThermalFeatures
        The transformer, fitted or not.

    Returns
    -------
    terms : tuple of str
        Its terms.
    smoothing : float or None
        Its smoothing time constant, s.

    Examples
    --------
    >>> from sklearn_ifog import ThermalFeatures
    >>> resolved_settings(ThermalFeatures(time=None))[0] == DEFAULT_ROW_TERMS
    True
    """
    if hasattr(features, "terms_"):
        return features.terms_, features.smoothing_
    return resolve_defaults(features.terms, features.smoothing, features.time is not None)


#: The term the reference paper adds to its "traditional" model (T, ΔT) to get its
#: "modified" one (T, ΔT, T·ΔT).
INTERACTION_TERM = "TdT"


def traditional_terms(terms):
    """``terms`` without the T·ΔT term: the reference paper's traditional model.

    Parameters
    ----------
    terms : sequence of str
        Term names.

    Returns
    -------
    terms : tuple of str
        The same without ``"TdT"``, in their order.

    Examples
    --------
    >>> traditional_terms(("T", "dT", "TdT"))
    ('T', 'dT')
    """
    return tuple(term for term in terms if term != INTERACTION_TERM)
