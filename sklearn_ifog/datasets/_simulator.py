"""Physics-based simulator of an IFOG thermal-test campaign.

The chain, per run (one recording of one unit at one azimuth)::

    chamber set-point profile (+ controller fluctuation)
      -> outer coil layer      (first-order lag, tau_outer)
      -> inner coil layer      (first-order lag of the outer layer, tau_inner)
      -> temperature sensor    (first-order lag of the outer layer, tau_sensor, offset, 0.01 degC)
    drift = static_bias(T_coil) + k(T_coil) * (dT_coil/dt + gamma * d(T_outer - T_inner)/dt)
    rate  = quantise(reference + drift + turn-on bias + bias instability + angle random walk)

Every recursion runs through :func:`scipy.signal.lfilter`; the only Python loop is over runs.
"""

from numbers import Integral, Real
from typing import NamedTuple

import numpy as np
import pandas as pd
from sklearn.utils import Bunch, check_random_state

from sklearn_ifog._compat import Interval, StrOptions, validate_params
from sklearn_ifog.datasets._gyro import (
    CHAMBER_FLUCTUATION,
    CHAMBER_FLUCTUATION_TIME,
    OUTPUT_ANGLE_QUANTUM,  # noqa: F401 (re-exported: tests and users import it here)
    SENSOR_RESOLUTION,
    TURN_ON_BIAS_REPEATABILITY,
    draw_static_bias,
    first_order_lag,
    gauss_markov,
    gyro_output,
)
from sklearn_ifog.datasets._layered import (
    LAYERED_COMPONENT_COLUMNS,
    draw_layered_params,
    layered_thermal,
)
from sklearn_ifog.datasets._transitions import (
    TRANSITION_COMPONENT_COLUMNS,
    TRANSITION_PRESETS,
    draw_transition_params,
    transition_rng,
    transition_state,
)
from sklearn_ifog.metrics import earth_rate

__all__ = ["make_thermal_campaign", "noise_floor"]

# The profiles "mix" draws from (unchanged, so that mixed campaigns stay bit for bit), and
# every profile: "cooling" is the paper's profile run downwards (an operating profile that
# a heating-only calibration never showed).
MIX_PROFILES = ("paper", "cycle", "staircase")
PROFILES = (*MIX_PROFILES, "cooling")
PHYSICS = ("lumped", "layered", "layered_glass", *TRANSITION_PRESETS)
FRAME_COLUMNS = (
    "unit",
    "run",
    "azimuth",
    "time",
    "temperature",
    "rate",
    "reference",
    "drift",
    "chamber_temperature",
)
FEATURE_NAMES = ("unit", "run", "azimuth", "time", "temperature")
TARGET_NAME = "drift_measured"
COMPONENT_COLUMNS = (
    "coil_outer",
    "coil_inner",
    "coil_mean",
    "coil_rate",
    "static_bias",
    "shupe",
    "turn_on_bias",
    "bias_instability",
    "angle_random_walk",
    "quantisation",
)
# The hidden per-row truth (``components``) each physics returns.
_PHYSICS_COMPONENTS = {
    "lumped": COMPONENT_COLUMNS,
    "layered": LAYERED_COMPONENT_COLUMNS,
    "layered_glass": LAYERED_COMPONENT_COLUMNS,
    **{
        name: (*LAYERED_COMPONENT_COLUMNS, *TRANSITION_COMPONENT_COLUMNS)
        for name in TRANSITION_PRESETS
    },
}

# Reference temperature of the Shupe coefficient and of the static-bias polynomial: the middle
# of the usual -10..40 degC test range (reference paper, section 2.1).
REFERENCE_TEMPERATURE = 15.0
_SECONDS_PER_MINUTE = 60.0

_DESCR = """\
Simulated IFOG thermal-test campaign
------------------------------------

Each unit (its own coefficients) is held static at a known azimuth in a thermal chamber while
the chamber follows a temperature profile; each row is one sample of one run.

Columns: unit, run (unique across the campaign), azimuth (deg), time (s from the start of the
run), temperature (coil sensor reading, degC, 0.01 degC resolution), rate (gyro output, deg/h),
reference (Earth-rate component, deg/h), drift (true thermal drift, noise-free, deg/h),
chamber_temperature (degC).

Target: drift_measured = rate - reference (thermal drift plus gyro noise).

Physics: coil layers lag the chamber (first-order), the Shupe drift is driven by the coil's
temperature rates with a temperature-dependent coefficient k(T) = k0 (1 + k1 (T - T0)), plus a
static temperature bias, turn-on bias, bias instability, angle random walk and output
quantisation. The true coefficients of each unit are in ``unit_params``.
"""


def shupe_coefficient(temperature, k0, k1, reference_temperature=REFERENCE_TEMPERATURE):
    """Temperature-dependent Shupe coefficient ``k(T) = k0 * (1 + k1 * (T - T0))``.

    Parameters
    ----------
    temperature : ndarray
        Coil temperature, degC.
    k0 : float
        Coefficient at ``reference_temperature``, deg/h per (degC/min).
    k1 : float
        Relative change per degC, 1/degC.
    reference_temperature : float, default=15.0
        T0, degC.

    Returns
    -------
    k : ndarray
        Coefficient, deg/h per (degC/min).
    """
    return k0 * (1.0 + k1 * (temperature - reference_temperature))


def static_bias(temperature, coefficients, reference_temperature=REFERENCE_TEMPERATURE):
    """Static temperature bias ``b0 + b1 * (T - T0) + b2 * (T - T0)**2`` in deg/h.

    Parameters
    ----------
    temperature : ndarray
        Coil temperature, degC.
    coefficients : sequence of float
        ``(b0, b1, b2)``: deg/h, deg/h/degC, deg/h/degC².
    reference_temperature : float, default=15.0
        T0, degC.

    Returns
    -------
    bias : ndarray
        Static bias, deg/h.
    """
    return np.polynomial.polynomial.polyval(temperature - reference_temperature, coefficients)


def _draw_unit_params(rng, unit):
    """One unit's true coefficients (a fixed number of draws, in a fixed order)."""
    return {
        "unit": unit,
        "tau_outer": float(rng.uniform(15.0, 30.0)) * _SECONDS_PER_MINUTE,
        "tau_inner": float(rng.uniform(5.0, 15.0)) * _SECONDS_PER_MINUTE,
        "tau_sensor": float(rng.uniform(1.0, 3.0)) * _SECONDS_PER_MINUTE,
        "sensor_offset": float(rng.uniform(-0.1, 0.1)),
        "k0": float(rng.uniform(0.1, 0.3)),
        "k1": float(rng.uniform(0.01, 0.025)),
        "gradient_weight": float(rng.uniform(-0.5, 0.5)),
        "bias_coefficients": draw_static_bias(rng),
        "angle_random_walk": float(rng.uniform(0.001, 0.003)),
        "bias_instability": float(rng.uniform(0.002, 0.005)),
        "bias_correlation_time": float(rng.uniform(300.0, 1000.0)),
        "turn_on_bias_repeatability": TURN_ON_BIAS_REPEATABILITY,
        "reference_temperature": REFERENCE_TEMPERATURE,
    }


# Coefficients a lot's units share exactly with the design (not scattered).
_SHARED_PARAMS = frozenset(
    {"unit", "n_layers", "reference_temperature", "turn_on_bias_repeatability"}
)


def scatter_unit_params(design, unit, spread, rng):
    """One unit of a lot: every numeric coefficient of ``design`` times ``exp(spread N(0,1))``.

    Parameters
    ----------
    design : dict
        The design's coefficients (as a unit's, from the physics' draw function).
    unit : int
        The unit's id.
    spread : float
        Standard deviation of the log of the ratio unit / design (>= 0).
    rng : numpy.random.RandomState
        The campaign's generator (one normal draw per scattered coefficient, in key order).

    Returns
    -------
    params : dict
        The unit's coefficients; signs and the shared keys are the design's.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.datasets._simulator import scatter_unit_params
    >>> design = {"unit": None, "k0": 0.2, "bias_coefficients": (0.1, -2e-3, 3e-5)}
    >>> unit = scatter_unit_params(design, 4, 0.0, np.random.RandomState(0))
    >>> unit == {**design, "unit": 4}
    True
    """
    params = {}
    for key, value in design.items():
        if key in _SHARED_PARAMS:
            params[key] = value
        elif isinstance(value, tuple):
            factors = np.exp(spread * rng.standard_normal(len(value)))
            params[key] = tuple(float(v * f) for v, f in zip(value, factors, strict=True))
        else:
            params[key] = float(value * np.exp(spread * rng.standard_normal()))
    params["unit"] = unit
    return params


def _draw_ramp_rate(rng, ramp_rate):
    if np.ndim(ramp_rate) == 0:
        return float(ramp_rate)
    low, high = ramp_rate
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))


def _chamber_profile(profile, rng, ramp_rate, temperature_range):
    """Breakpoints (seconds, degC) of a piecewise-linear chamber set-point."""
    low_limit, high_limit = temperature_range
    span = high_limit - low_limit
    rate = _draw_ramp_rate(rng, ramp_rate) / _SECONDS_PER_MINUTE  # degC/s
    if profile in ("paper", "cooling"):
        # Reference paper, section 4: soak 1 h at the low level, ramp up, soak 2 h at the top;
        # "cooling" runs the same levels and soaks the other way round.
        low = rng.uniform(low_limit, low_limit + 0.4 * span)
        high = rng.uniform(high_limit - 0.3 * span, high_limit)
        levels = [low, high]
        soaks = [rng.uniform(45.0, 75.0), rng.uniform(100.0, 140.0)]
        if profile == "cooling":
            levels, soaks = levels[::-1], soaks[::-1]
    elif profile == "cycle":
        low = rng.uniform(low_limit, low_limit + 0.2 * span)
        high = rng.uniform(high_limit - 0.2 * span, high_limit)
        n_cycles = int(rng.randint(1, 3))
        levels = [low] + [high, low] * n_cycles
        soaks = list(rng.uniform(30.0, 60.0, size=len(levels)))
    else:  # staircase
        low = rng.uniform(low_limit, low_limit + 0.2 * span)
        high = rng.uniform(high_limit - 0.2 * span, high_limit)
        n_steps = int(rng.randint(3, 6))
        levels = list(np.linspace(low, high, n_steps + 1))
        if rng.uniform() < 0.5:
            levels = levels[::-1]
        soaks = list(rng.uniform(30.0, 60.0, size=len(levels)))
    times, temperatures = [0.0], [levels[0]]
    for index, (level, soak) in enumerate(zip(levels, soaks, strict=True)):
        if index > 0:
            times.append(times[-1] + abs(level - temperatures[-1]) / rate)
            temperatures.append(level)
        times.append(times[-1] + soak * _SECONDS_PER_MINUTE)
        temperatures.append(level)
    return np.asarray(times), np.asarray(temperatures), rate * _SECONDS_PER_MINUTE


def _lumped_thermal(unit_params, chamber_setpoint, sampling_period, noise, rng):
    """Arrays of one lumped run but the gyro output: temperatures and drift components."""
    n_samples = chamber_setpoint.shape[0]
    p = unit_params
    if noise:
        fluctuation = gauss_markov(
            rng.standard_normal(n_samples),
            sampling_period,
            CHAMBER_FLUCTUATION_TIME,
            CHAMBER_FLUCTUATION,
            rng.normal(0.0, CHAMBER_FLUCTUATION),
        )
        chamber = chamber_setpoint + fluctuation
    else:
        chamber = chamber_setpoint.copy()
    # The run starts after a soak: coil and sensor in equilibrium with the chamber.
    outer = first_order_lag(chamber, sampling_period, p["tau_outer"], chamber[0])
    inner = first_order_lag(outer, sampling_period, p["tau_inner"], chamber[0])
    sensor = first_order_lag(outer, sampling_period, p["tau_sensor"], chamber[0])
    temperature = np.round((sensor + p["sensor_offset"]) / SENSOR_RESOLUTION) * SENSOR_RESOLUTION
    # Exact derivatives of the continuous lag equations at the samples, degC/min.
    outer_rate = (chamber - outer) / p["tau_outer"] * _SECONDS_PER_MINUTE
    inner_rate = (outer - inner) / p["tau_inner"] * _SECONDS_PER_MINUTE
    coil_mean = 0.5 * (outer + inner)
    coil_rate = 0.5 * (outer_rate + inner_rate) + p["gradient_weight"] * (outer_rate - inner_rate)
    shupe = shupe_coefficient(coil_mean, p["k0"], p["k1"], p["reference_temperature"]) * coil_rate
    bias = static_bias(coil_mean, p["bias_coefficients"], p["reference_temperature"])
    drift = bias + shupe
    return {
        "temperature": temperature,
        "drift": drift,
        "chamber_temperature": chamber,
        "coil_outer": outer,
        "coil_inner": inner,
        "coil_mean": coil_mean,
        "coil_rate": coil_rate,
        "static_bias": bias,
        "shupe": shupe,
    }


def simulate_thermal(physics, params, times, setpoints, n_samples, sampling_period, noise, rng):
    """The thermal part of one run of any physics, and the generator of its gyro noise.

    Parameters
    ----------
    physics : str
        Thermal model, one of ``PHYSICS``.
    params : dict
        The unit's coefficients (from the physics' draw).
    times, setpoints : ndarray
        Breakpoints of the chamber set-point, seconds and degC.
    n_samples : int
        Samples of the run, at ``0, sampling_period, ...``.
    sampling_period : float
        Seconds.
    noise : bool
        Whether to add the chamber fluctuation (and, later, the gyro noise).
    rng : numpy.random.RandomState
        The campaign's generator; the draws are those the physics always made, in order.

    Returns
    -------
    parts : dict of ndarray
        Temperature reading, drift, chamber temperature and the physics' hidden components
        (all but the gyro output and its noise).
    output_rng : numpy.random.RandomState
        The generator :func:`~sklearn_ifog.datasets._gyro.gyro_output` must draw the run's
        noise from next (``rng`` itself for "lumped", the run's noise seed for the layered
        physics), so that output = thermal part + :func:`gyro_output` is the run bit for bit.
    """
    if physics == "lumped":
        time = np.arange(n_samples) * sampling_period
        setpoint = np.interp(time, times, setpoints)
        return _lumped_thermal(params, setpoint, sampling_period, noise, rng), rng
    thermal_seed, noise_seed = rng.randint(np.iinfo(np.int32).max, size=2)
    transition = None
    if physics in TRANSITION_PRESETS:

        def transition(coil_mean, step):
            return transition_state(params, coil_mean, TRANSITION_PRESETS[physics], step)

    parts = layered_thermal(
        params,
        times,
        setpoints,
        n_samples,
        sampling_period,
        noise,
        physics == "layered_glass" or transition is not None,
        thermal_seed,
        transition,
    )
    return parts, np.random.RandomState(noise_seed)


def _check_profile(profile):
    if isinstance(profile, str):
        names = list(MIX_PROFILES) if profile == "mix" else [profile]
    else:
        names = list(profile)
        if not names:
            raise ValueError("profile must name at least one profile, got an empty list.")
    unknown = [name for name in names if name not in PROFILES]
    if unknown:
        raise ValueError(
            f"profile must be one of {list(PROFILES)} or 'mix' (or a list of them), "
            f"got {unknown[0]!r}."
        )
    return names


def _check_azimuths(azimuths):
    try:
        values = np.asarray(azimuths, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"azimuths must be numbers in degrees, got {azimuths!r}.") from exc
    values = np.atleast_1d(values)
    if values.ndim != 1 or values.size == 0:
        raise ValueError(f"azimuths must be a non-empty 1-D list of degrees, got {azimuths!r}.")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"azimuths must be finite, got {azimuths!r}.")
    return values


def _check_range(value, name, lower=None):
    """A positive float, or a (low, high) pair with low <= high."""
    if np.ndim(value) == 0:
        return float(value)
    pair = np.asarray(value, dtype=np.float64)
    if pair.shape != (2,) or not np.all(np.isfinite(pair)) or pair[0] > pair[1]:
        raise ValueError(f"{name} must be a number or a (low, high) pair, got {value!r}.")
    if lower is not None and pair[0] <= lower:
        raise ValueError(f"{name} must be > {lower}, got {value!r}.")
    return (float(pair[0]), float(pair[1]))


@validate_params(
    {
        "n_units": [Interval(Integral, 1, None, closed="left")],
        "n_runs": [Interval(Integral, 1, None, closed="left")],
        "azimuths": ["array-like", Real],
        "latitude": [Interval(Real, -90.0, 90.0, closed="both")],
        "profile": [StrOptions({*PROFILES, "mix"}), list, tuple],
        "sampling_period": [Interval(Real, 0.1, 600.0, closed="both")],
        "ramp_rate": [Interval(Real, 0.0, None, closed="neither"), tuple, list],
        "temperature_range": [tuple, list],
        "noise": ["boolean"],
        "physics": [StrOptions(set(PHYSICS))],
        "lot_spread": [Interval(Real, 0.0, None, closed="left"), None],
        "random_state": ["random_state"],
        "as_frame": ["boolean"],
        "return_X_y": ["boolean"],
    },
    prefer_skip_nested_validation=True,
)
def make_thermal_campaign(
    n_units=3,
    n_runs=5,
    azimuths=(0.0, 45.0, 90.0, 135.0),
    latitude=45.0,
    profile="paper",
    *,
    sampling_period=60.0,
    ramp_rate=(0.1, 2.0),
    temperature_range=(-10.0, 40.0),
    noise=True,
    physics="layered",
    lot_spread=None,
    random_state=None,
    as_frame=True,
    return_X_y=False,
):
    """Simulate a thermal-test campaign of navigation-grade IFOGs.

    Every unit (gyro) has its own coefficients, drawn from ``random_state``, and is recorded
    ``n_runs`` times at each azimuth while the thermal chamber follows a temperature profile.
    Runs differ in ramp rate, soak lengths and temperature levels, so some runs reach
    temperatures that others do not (as held-out runs do in practice). The ``"lumped"``
    physics, per run (the default ``"layered"`` physics replaces steps 2 to 5 by a coil of
    several layers read by a sensor on its housing: see ``physics``):

    1. chamber set-point, piecewise linear (profile below), plus a controller fluctuation
       (first-order Gauss–Markov);
    2. outer coil layer: first-order lag of the chamber (``tau_outer``); inner layer:
       first-order lag of the outer layer (``tau_inner``), hence a radial gradient while the
       temperature changes; coil temperature ``T = (T_outer + T_inner) / 2``;
    3. Shupe drift ``k(T) * (dT/dt + gamma * d(T_outer - T_inner)/dt)`` (rates in degC/min) with
       ``k(T) = k0 * (1 + k1 * (T - T0))``: the drift follows the coil's temperature rate, and
       the temperature dependence of ``k`` is why a T·ΔT term helps (reference paper, Eq. 13);
    4. static bias ``b0 + b1 (T - T0) + b2 (T - T0)²``; ``drift`` = static bias + Shupe drift;
    5. temperature sensor: first-order lag of the outer layer (``tau_sensor``), calibration
       offset, 0.01 degC resolution;
    6. gyro output: reference + drift + turn-on bias (per run) + bias instability
       (first-order Gauss–Markov) + angle random walk (white rate noise), quantised by counting
       whole output angle quanta;
    7. reference: the Earth-rate component Ω_e·cos(latitude)·cos(azimuth), computed by
       :func:`sklearn_ifog.metrics.earth_rate` (Ω_e = 15.041067 deg/h).

    Parameters
    ----------
    n_units : int, default=3
        Number of gyros, each with its own coefficients.
    n_runs : int, default=5
        Runs per unit and azimuth (the reference paper tests each gyro five times).
    azimuths : float or array-like of float, default=(0.0, 45.0, 90.0, 135.0)
        Azimuths of the sensitive axis from true north, degrees.
    latitude : float, default=45.0
        Latitude of the test site, degrees.
    profile : {"paper", "cycle", "staircase", "cooling", "mix"} or list of str, \
default="paper"
        Chamber profile of every run. ``"paper"``: the reference paper's sequence (soak about
        1 h at a low level, ramp up, soak about 2 h at the top: heating only);
        ``"cooling"``: the same run downwards (soak about 2 h at the top, ramp down, soak
        about 1 h at the low level: cooling only); ``"cycle"``: one or two low-high-low
        cycles with soaks of 30-60 min; ``"staircase"``: 3-5 equal steps up or down with
        soaks of 30-60 min. A list draws each run's profile uniformly from the list;
        ``"mix"`` is the list of "paper", "cycle" and "staircase". Levels are drawn per run
        inside ``temperature_range``: paper and cooling: low in the bottom 40 % of the range,
        top in the top 30 %; cycle and staircase: bottom 20 % and top 20 %.
    sampling_period : float, default=60.0
        Sample spacing, seconds, in [0.1, 600]. One-minute samples are the usual resolution
        of thermal-drift modelling (thermal time constants are tens of minutes; shorter
        samples mostly add angle random walk). The default campaign has about 17,000 rows;
        rows (and memory, about 200 bytes a row with the components) scale as
        1/sampling_period.
    ramp_rate : float or (float, float), default=(0.1, 2.0)
        Chamber ramp rate, degC/min: one value for every run, or a range from which each run
        draws its rate (log-uniformly).
    temperature_range : (float, float), default=(-10.0, 40.0)
        Lowest and highest chamber temperature, degC.
    noise : bool, default=True
        Whether to add the chamber fluctuation, turn-on bias, bias instability, angle random
        walk and output quantisation. With ``noise=False`` the output is exactly
        ``reference + drift`` (the temperature reading stays quantised).
    physics : {"lumped", "layered", "layered_glass", "layered_glass_asymmetric", \
"layered_glass_two", "layered_glass_hysteresis"}, default="layered"
        Thermal model. ``"lumped"``: the two-lag model described above (unchanged, bit for
        bit; the coil the reference paper's features describe). ``"layered"``, the default
        because a navigation-grade coil is wound in many layers, potted, and read by a
        sensor outside it: chamber air -> housing (first-order lag) -> a coil of 5 radial
        layers with heat diffusion between neighbours (a linear network solved exactly by
        modal decomposition); Shupe drift from each layer's own rate with quadrupole
        weights (signed by distance from the mid-radius, plus a per-unit residual
        asymmetry) times ``k(T) = 1 + k1 (T - T0)``; a thermo-elastic stress term on the
        radial gradient (outer minus inner layer) with a temperature-dependent coefficient
        (Mohr & Schadt); a static bias polynomial in the mean coil temperature; the sensor
        on the housing, outside the coil; gyro samples are means over the sample period
        (internal step <= 1 s). ``"layered_glass"``: as "layered", plus a glass transition of
        the potting at Tg (10-25 degC): the stress coefficient falls to the rubbery stiffness
        (logistic step) and the bias slope changes above Tg. Three transitions that no
        logistic describes: ``"layered_glass_asymmetric"``, an asymmetric (generalised
        logistic) step, sharp on one side of Tg and slow on the other, its exponent drawn
        per unit; ``"layered_glass_two"``, two transitions at two temperatures (-5..35
        degC, at least four widths apart), each with its own stiffness drop;
        ``"layered_glass_hysteresis"``, a Tg higher on heating than on cooling by 2-6 degC,
        following the sign of the coil's temperature rate and kept through a soak. The
        layered presets draw two seeds per run, so a seed gives the same thermal history at
        every sample period, and every layered preset shares every unit and run with
        "layered" (the three transitions draw their extra coefficients from a stream of
        their own). Their coefficients and sources are listed under
        ``sklearn_ifog.datasets._layered`` (see :ref:`physics` and
        :ref:`glass_transitions`).
    lot_spread : float or None, default=None
        None: every unit is drawn independently (its coefficients anywhere in the ranges of
        the Notes table). A float: the units form a production *lot* of one design: the
        design is drawn like one unit, and every numeric coefficient of every unit (time
        constants, sensor offset, Shupe, stress, glass-transition and static-bias
        coefficients, noise levels) is the design's times ``exp(lot_spread * N(0, 1))``,
        an independent lognormal scatter that keeps each coefficient's sign (0: identical
        units, 0.1: about ±10 %). The design is returned as ``design_params``.
    random_state : int, RandomState instance or None, default=None
        Seed of every random draw (unit coefficients first, then runs); an int gives the same
        campaign bit for bit.
    as_frame : bool, default=True
        Return pandas objects (``frame``, ``data`` as DataFrames, ``target`` as a Series).
        Unlike scikit-learn's ``fetch_*`` functions the default is True: the run and time
        columns make a table the natural form. False gives numpy arrays and ``frame=None``.
    return_X_y : bool, default=False
        Return ``(data, target)`` instead of a Bunch.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with attributes:

        frame : DataFrame or None
            Columns unit (int), run (int, unique across the campaign), azimuth (deg), time
            (s, from 0 in each run), temperature (sensor reading, degC), rate (gyro output,
            deg/h), reference (deg/h), drift (true thermal drift, deg/h) and
            chamber_temperature (degC). Rows grouped by run, in time order.
        data : DataFrame or ndarray of shape (n_samples, 5)
            Columns unit, run, azimuth, time, temperature.
        target : Series or ndarray of shape (n_samples,)
            ``drift_measured = rate - reference``.
        feature_names : list of str
            Names of the data columns.
        target_names : list of str
            ``["drift_measured"]``.
        unit_params : list of dict
            True coefficients of each unit (keys as in the Notes table; times in seconds).
        design_params : dict or None
            With ``lot_spread``: the lot's design, the coefficients the units scatter
            around; None without.
        run_params : DataFrame or list of dict
            Per run: unit, run, azimuth, profile, ramp_rate (degC/min), duration (s),
            min_setpoint and max_setpoint (degC), breakpoint_times (s) and
            breakpoint_temperatures (degC) of the chamber set-point.
        components : DataFrame or dict of ndarray
            Per row, the hidden truth: coil_outer, coil_inner, coil_mean (degC), coil_rate
            (the rate driving the Shupe drift, degC/min), static_bias, shupe, turn_on_bias,
            bias_instability, angle_random_walk, quantisation (deg/h). The layered presets
            add stress (deg/h), housing, sensor (true sensor temperature, before offset and
            quantisation) and layer_0 (outer) .. layer_4 (inner), degC; their coil_rate
            and drift terms are means over the sample period, temperatures instantaneous.
            The three transition presets add stiffness (the potting's relative stiffness)
            and glass_temperature (the transition temperature in force, degC), at the
            sample time.
        DESCR : str
            Description of the data set.

    (data, target) : tuple if ``return_X_y`` is True
        ``data`` and ``target`` as above.

    See Also
    --------
    sklearn_ifog.metrics.earth_rate : The reference column's formula.

    Notes
    -----
    Per-unit coefficients are drawn uniformly from the ranges below ("±" draws the sign too).
    Values marked *typical* are representative of navigation-grade IFOGs rather than taken
    from a specific device.

    ============================  ============================  ===================================
    coefficient                   default                       source / justification
    ============================  ============================  ===================================
    tau_outer (chamber->coil)     15-30 min                     typical; the reference paper (s. 4)
                                                                notes the chamber air gap slows heat
                                                                transfer ("tens of minutes")
    tau_inner (outer->inner)      5-15 min                      typical radial diffusion time of a
                                                                potted coil
    tau_sensor                    1-3 min                       typical thermistor on the coil spool
    sensor_offset                 ±0.1 degC                     typical calibration error
    sensor resolution             0.01 degC                     reference paper, s. 4
    k0 (Shupe)                    0.05-0.15 deg/h per degC/min  order of the Shupe effect of a ~1 km
                                                                quadrupole coil (Shupe 1980;
                                                                Lefèvre, *The Fiber-Optic
                                                                Gyroscope*); gives 0.01-0.3 deg/h
                                                                at 0.1-2 degC/min, cf. the paper's
                                                                Fig. 3 (> 0.2 deg/h)
    k1                            0.01-0.025 /degC              chosen so that T·ΔT matters (paper
                                                                Eq. 13); physically the temperature
                                                                dependence of the thermo-optic and
                                                                coating/potting (elasto-optic)
                                                                terms
    T0                            15 degC                       middle of the -10..40 degC range
    gamma (gradient weight)       -0.5..0.5                     chosen: winding asymmetry between
                                                                outer and inner layers
    b0, b1, b2 (static bias)      ±0.1 deg/h, ±(1-3)e-3 deg/h/  typical bias temperature
                                  degC, ±(1-5)e-5 deg/h/degC²   sensitivity of navigation-grade
                                                                IFOGs
    angle random walk N           0.001-0.003 deg/sqrt(h)       IEEE Std 952-1997 noise term N;
                                                                navigation grade (typical)
    bias instability              0.002-0.005 deg/h std,        IEEE Std 952-1997 term B (modelled
                                  correlation 300-1000 s        as first-order Gauss–Markov, a
                                                                common approximation; typical)
    turn-on bias repeatability    0.003 deg/h std per run       typical
    output angle quantum          0.05 arcsec                   typical closed-loop IFOG LSB
    chamber fluctuation           0.05 degC std, 300 s          paper s. 4: control accuracy 0.1 degC
    Ω_e                           15.041067 deg/h               WGS 84 / IERS, 7.292115e-5 rad/s
    ============================  ============================  ===================================

    The white rate noise of angle random walk N (deg/sqrt(h)) averaged over a sample of
    ``dt`` seconds has std ``N * 60 / sqrt(dt)`` deg/h (IEEE Std 952-1997, Annex C). The
    first-order lags are discretised with a first-order hold (exact for linear ramps); the
    ``coil_rate`` component is the exact derivative of the continuous lag equations.

    References
    ----------
    .. [1] D. M. Shupe, "Thermally induced nonreciprocity in the fiber-optic interferometer",
       Applied Optics 19(5), 654-655, 1980.
    .. [2] H. C. Lefèvre, *The Fiber-Optic Gyroscope*, 2nd ed., Artech House, 2014.
    .. [3] IEEE Std 952-1997, IEEE Standard Specification Format Guide and Test Procedure for
       Single-Axis Interferometric Fiber Optic Gyros.

    Examples
    --------
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> campaign = make_thermal_campaign(n_units=1, n_runs=1, azimuths=[0.0], random_state=0)
    >>> list(campaign.frame.columns)
    ['unit', 'run', 'azimuth', 'time', 'temperature', 'rate', 'reference', 'drift', 'chamber_temperature']
    >>> round(float(campaign.frame["reference"].iloc[0]), 4)
    10.6357
    >>> X, y = make_thermal_campaign(n_units=2, n_runs=1, random_state=0, return_X_y=True)
    >>> sorted(X["unit"].unique().tolist()), y.name
    ([0, 1], 'drift_measured')
    """  # noqa: E501
    azimuth_values = _check_azimuths(azimuths)
    profile_names = _check_profile(profile)
    ramp = _check_range(ramp_rate, "ramp_rate", lower=0.0)
    if np.ndim(ramp) == 0 and ramp <= 0:
        raise ValueError(f"ramp_rate must be > 0, got {ramp_rate!r}.")
    low_high = _check_range(temperature_range, "temperature_range")
    if np.ndim(low_high) == 0 or low_high[0] >= low_high[1]:
        raise ValueError(
            f"temperature_range must be a (low, high) pair with low < high, "
            f"got {temperature_range!r}."
        )

    rng = check_random_state(random_state)
    unit_params, design_params = _draw_units(physics, n_units, lot_spread, rng)
    runs = []
    for params in unit_params:
        for azimuth in azimuth_values:
            reference_value = earth_rate(latitude, azimuth)
            for _ in range(n_runs):
                run = _simulate_campaign_run(
                    params,
                    len(runs),
                    azimuth,
                    reference_value,
                    profile=profile_names[int(rng.randint(len(profile_names)))],
                    ramp_rate=ramp,
                    temperature_range=low_high,
                    sampling_period=sampling_period,
                    noise=noise,
                    physics=physics,
                    rng=rng,
                )
                runs.append(run)
    return campaign_bunch(
        runs,
        _PHYSICS_COMPONENTS[physics],
        unit_params=unit_params,
        design_params=design_params,
        as_frame=as_frame,
        return_X_y=return_X_y,
    )


def campaign_bunch(
    runs,
    component_columns,
    *,
    unit_params,
    design_params,
    as_frame,
    return_X_y,
    frame_columns=FRAME_COLUMNS,
    feature_names=FEATURE_NAMES,
    descr=_DESCR,
):
    """A simulated campaign's runs concatenated into its Bunch (or ``(X, y)``).

    ``runs``: per run, ``(columns, components, params)`` (a ``_CampaignRun`` or a tuple in
    that order): the columns of ``frame_columns``, the hidden per-row truth of
    ``component_columns`` and the run's parameters. The target is ``rate - reference``.
    Shared by :func:`make_thermal_campaign` and the rate-table simulator.
    """
    columns = {name: np.concatenate([run[0][name] for run in runs]) for name in frame_columns}
    components = {
        name: np.concatenate([run[1][name] for run in runs]) for name in component_columns
    }
    run_params = [run[2] for run in runs]
    target_values = columns["rate"] - columns["reference"]

    if as_frame:
        frame = pd.DataFrame(columns, columns=list(frame_columns))
        data = frame[list(feature_names)]
        target = pd.Series(target_values, name=TARGET_NAME)
        components = pd.DataFrame(components, columns=list(component_columns))
        run_params = pd.DataFrame(run_params)
    else:
        frame = None
        data = np.column_stack([columns[name].astype(np.float64) for name in feature_names])
        target = target_values

    if return_X_y:
        return data, target
    return Bunch(
        frame=frame,
        data=data,
        target=target,
        feature_names=list(feature_names),
        target_names=[TARGET_NAME],
        unit_params=unit_params,
        design_params=design_params,
        run_params=run_params,
        components=components,
        DESCR=descr,
    )


def _draw_units(physics, n_units, lot_spread, rng):
    """Every unit's true coefficients, and the lot's design (None without ``lot_spread``).

    Independent units are drawn one after the other; a lot draws its design like one unit,
    then scatters every unit around it (:func:`scatter_unit_params`).
    """
    if physics == "lumped":

        def draw(unit):
            return _draw_unit_params(rng, unit)

    else:

        def draw(unit):
            return draw_layered_params(
                rng, unit, REFERENCE_TEMPERATURE, TURN_ON_BIAS_REPEATABILITY
            )

    if lot_spread is None:
        unit_params, design_params = [draw(unit) for unit in range(n_units)], None
    else:
        design_params = draw(None)
        unit_params = [
            scatter_unit_params(design_params, unit, lot_spread, rng) for unit in range(n_units)
        ]
    if physics in TRANSITION_PRESETS:
        unit_params, design_params = _add_transition_params(unit_params, design_params, lot_spread)
    return unit_params, design_params


def _add_transition_params(unit_params, design_params, lot_spread):
    """The transition presets' extra coefficients, after every draw of the campaign's rng.

    Each unit (or the lot's design) draws them from its own stream
    (:func:`~sklearn_ifog.datasets._transitions.draw_transition_params`); a lot's units
    scatter the design's like the others, from the unit's stream.
    """
    if design_params is None:
        return [{**p, **draw_transition_params(p)} for p in unit_params], None
    extra = draw_transition_params(design_params)
    units = []
    for params in unit_params:
        scattered = scatter_unit_params(extra, params["unit"], lot_spread, transition_rng(params))
        del scattered["unit"]
        units.append({**params, **scattered})
    return units, {**design_params, **extra}


class _CampaignRun(NamedTuple):
    """One simulated run: its rows (``FRAME_COLUMNS``), hidden components and parameters."""

    columns: dict
    components: dict
    params: dict


def _simulate_campaign_run(
    params,
    run_id,
    azimuth,
    reference_value,
    *,
    profile,
    ramp_rate,
    temperature_range,
    sampling_period,
    noise,
    physics,
    rng,
):
    """One run of one unit at one azimuth: its chamber profile, physics and gyro output.

    ``profile`` is the run's profile name (already drawn), ``ramp_rate`` and
    ``temperature_range`` are checked; ``rng`` continues the campaign's draws.
    """
    times, setpoints, rate_used = _chamber_profile(profile, rng, ramp_rate, temperature_range)
    n_samples = int(np.floor(times[-1] / sampling_period)) + 1
    time = np.arange(n_samples) * sampling_period
    reference = np.full(n_samples, reference_value)
    arrays, output_rng = simulate_thermal(
        physics, params, times, setpoints, n_samples, sampling_period, noise, rng
    )
    arrays.update(
        gyro_output(reference, arrays["drift"], sampling_period, params, noise, output_rng)
    )
    columns = {
        "unit": np.full(n_samples, params["unit"], dtype=np.int64),
        "run": np.full(n_samples, run_id, dtype=np.int64),
        "azimuth": np.full(n_samples, azimuth),
        "time": time,
        "temperature": arrays["temperature"],
        "rate": arrays["rate"],
        "reference": reference,
        "drift": arrays["drift"],
        "chamber_temperature": arrays["chamber_temperature"],
    }
    run_params = {
        "unit": params["unit"],
        "run": run_id,
        "azimuth": float(azimuth),
        "profile": profile,
        "ramp_rate": rate_used,
        "duration": float(time[-1]),
        "min_setpoint": float(setpoints.min()),
        "max_setpoint": float(setpoints.max()),
        "breakpoint_times": times,
        "breakpoint_temperatures": setpoints,
    }
    components = {key: arrays[key] for key in _PHYSICS_COMPONENTS[physics]}
    return _CampaignRun(columns=columns, components=components, params=run_params)


def noise_floor(frame, rows=None):
    """Mean squared gyro noise of a simulated campaign: the MSD of a perfect drift model.

    The noise is ``rate - reference - drift`` (turn-on bias, bias instability, angle random
    walk, quantisation): what no thermal model can remove. A model's mean squared deviation
    divided by this floor is 1 for a perfect model.

    Parameters
    ----------
    frame : DataFrame or mapping of str to array-like
        A campaign's ``frame`` (columns ``rate``, ``reference`` and ``drift``).
    rows : array-like of bool or int, default=None
        Rows to average over (a boolean mask or positions, e.g. a test fold); None means all.

    Returns
    -------
    floor : float
        Mean of the squared noise, (deg/h)².

    Examples
    --------
    >>> from sklearn_ifog.datasets import make_thermal_campaign, noise_floor
    >>> campaign = make_thermal_campaign(n_units=1, n_runs=1, azimuths=[0.0], random_state=0)
    >>> floor = noise_floor(campaign.frame)
    >>> bool(1e-5 < floor < 1e-2)
    True
    >>> quiet = make_thermal_campaign(n_units=1, n_runs=1, noise=False, random_state=0)
    >>> bool(noise_floor(quiet.frame) < 1e-20)
    True
    """
    missing = [name for name in ("rate", "reference", "drift") if name not in frame]
    if missing:
        raise ValueError(
            f"frame must have the columns rate, reference and drift of a simulated campaign; "
            f"missing {missing}."
        )
    noise = np.asarray(frame["rate"], dtype=np.float64) - np.asarray(
        frame["reference"], dtype=np.float64
    )
    noise = noise - np.asarray(frame["drift"], dtype=np.float64)
    if rows is not None:
        noise = noise[np.asarray(rows)]
    if noise.size == 0:
        raise ValueError("rows selects no row: the noise floor of no sample is undefined.")
    return float(np.mean(np.square(noise)))
