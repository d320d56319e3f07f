"""Rate-table campaigns: the scale factor of an IFOG over temperature (issue 44, point 1).

A rate-table thermal test mounts the gyro with its input axis vertical on a turntable inside
the thermal chamber. The chamber follows the thermal simulator's profiles while the table
steps through input rates, so the gyro's output holds both its bias (what
:func:`~sklearn_ifog.datasets.make_thermal_campaign` simulates) and its *scale-factor error*
``s``, the relative error of what it multiplies::

    reference = table_rate * 3600 + Ω_e sin(latitude)                       (deg/h)
    rate      = reference * (1 + s) + drift + noise                         (deg/h)
    s         = s_coil + s_source + s_asymmetry + s_nonlinearity            (x 1e-6: ppm)
    s_coil    = a1 (Tm - T0) + a2 (Tm - T0)² + g (T_outer - T_inner)
    s_source  = c (Ts - T0),   Ts = lag_{tau_source}(chamber) + self-heating
    s_asymmetry     = (δ / 2) sign(reference)
    s_nonlinearity  = ν (reference / 300 deg/s)²

``drift`` and ``noise`` are the thermal simulator's, unchanged in kind (any of its physics);
``Tm``, ``T_outer`` and ``T_inner`` are its coil temperatures. The Sagnac scale factor is
``K = 2 π L D / (λ c)`` (Lefèvre, ch. 2), so ``s`` follows the coil's geometry ``L·D``
(``s_coil``) and the source's mean wavelength ``λ`` (``s_source``).

Per-unit coefficients, drawn uniformly ("±": random sign) in a fixed order, the same for
every preset (a preset zeroes the terms it leaves out, so the same seed gives the same units,
runs and bias at every preset). *Typical* = representative of a navigation-grade IFOG rather
than taken from one device.

========================  =====================  ==============================================
coefficient               range                  source / justification
========================  =====================  ==============================================
a1 (sf_coil_linear)       3-6 ppm/degC           thermal expansion of the coil (fibre on its
                                                 spool, through the potting) grows L·D: a few
                                                 ppm/degC, hundreds of ppm over -40..70 degC,
                                                 as published uncompensated FOG scale factors
                                                 (e.g. 835 ppm peak-to-peak over the full
                                                 range, the GSA-LSTM work quoted in issue 44)
a2 (sf_coil_quadratic)    ±0.005-0.02 ppm/degC²  typical: the potting's modulus and expansion
                                                 change with temperature (15-60 ppm at ±55 degC)
g (sf_coil_gradient)      ±0.5-3 ppm/degC        chosen: outer turns enclose more area and the
                                                 radial gradient strains the winding
                                                 (thermo-elastic, Mohr & Schadt 2004), so
                                                 heating and cooling differ at one Tm
T0                        15 degC                middle of the -40..70 degC range
tau_source                5-20 min               typical: source module against the chamber
source_self_heating       1-5 degC               typical: drive current of the source (and its
                                                 cooler) above its surroundings
tau_source_sensor         0.5-2 min              typical thermistor on the source module
source_sensor_offset      ±0.1 degC              as the coil sensor; 0.01 degC resolution
c (sf_source)             1-3 ppm/degC           mean-wavelength shift of a broadband source
                                                 (Wysocki et al. 1994: erbium superfluorescent
                                                 sources, a few ppm/degC; a semiconductor
                                                 source drifts ~300 ppm/degC and is therefore
                                                 temperature-controlled); drawn with the coil's
                                                 sign, so the terms add (the sign depends on
                                                 the source's design)
δ (sf_asymmetry)          ±3-20 ppm              scale-factor asymmetry, s(+Ω) - s(-Ω) (IEEE
                                                 Std 952-1997 term; closed-loop FOGs specify a
                                                 few to tens of ppm); preset "asymmetric"
ν (sf_nonlinearity)       ±2-10 ppm at 300 deg/s  scale-factor nonlinearity, an output odd in Ω
                                                 (IEEE Std 952-1997; typical); "asymmetric"
========================  =====================  ==============================================

References: H. C. Lefèvre, *The Fiber-Optic Gyroscope*, 2nd ed., Artech House, 2014 (scale
factor, source wavelength); IEEE Std 952-1997 (scale factor, asymmetry, nonlinearity and
their temperature sensitivity); P. F. Wysocki, M. J. F. Digonnet, B. Y. Kim and H. J. Shaw,
"Characteristics of erbium-doped superfluorescent fiber sources for interferometric sensor
applications", J. Lightwave Technol. 12(3), 550-567, 1994; F. Mohr and F. Schadt, Proc. SPIE
5502, 410-413, 2004.
"""

from numbers import Integral, Real

import numpy as np
from sklearn.utils import check_random_state

from sklearn_ifog._compat import Interval, StrOptions, validate_params
from sklearn_ifog.datasets._gyro import (
    SENSOR_RESOLUTION,
    first_order_lag,
    gyro_output,
    signed_uniform,
)
from sklearn_ifog.datasets._simulator import (
    _PHYSICS_COMPONENTS,
    PHYSICS,
    PROFILES,
    _chamber_profile,
    _check_profile,
    _check_range,
    _draw_units,
    campaign_bunch,
    scatter_unit_params,
    simulate_thermal,
)
from sklearn_ifog.metrics import EARTH_ROTATION_RATE

__all__ = [
    "DEFAULT_RATES",
    "RATE_TABLE_PRESETS",
    "make_rate_table_campaign",
    "scale_factor_terms",
]

# Turntable rates of a scale-factor test, deg/s: zero, then both signs of each decade up to
# 300 deg/s (documented where the package exports it, sklearn_ifog.datasets).
DEFAULT_RATES = (0.0, 1.0, -1.0, 10.0, -10.0, 100.0, -100.0, 300.0, -300.0)
# The scale-factor presets, each adding terms to the one before.
RATE_TABLE_PRESETS = ("coil", "coil_source", "asymmetric")
MAX_TABLE_RATE = 1000.0  # deg/s: beyond any navigation gyro's range
NONLINEARITY_FULL_SCALE = 300.0  # deg/s: the rate at which s_nonlinearity = ν
PPM = 1e-6
_SECONDS_PER_MINUTE = 60.0
_SECONDS_PER_HOUR = 3600.0

FRAME_COLUMNS = (
    "unit",
    "run",
    "time",
    "temperature",
    "source_temperature",
    "table_rate",
    "reference",
    "rate",
    "drift",
    "scale_factor_error",
    "chamber_temperature",
)
FEATURE_NAMES = ("unit", "run", "time", "temperature", "source_temperature", "reference")
TARGET_NAME = "drift_measured"
SCALE_FACTOR_COMPONENTS = (
    "coil_gradient",
    "source_temp_true",
    "source_sensor",
    "scale_factor_coil",
    "scale_factor_source",
    "scale_factor_asymmetry",
    "scale_factor_nonlinearity",
)
# The terms each preset keeps (the others' coefficients are set to zero).
_PRESET_TERMS = {
    "coil": frozenset(),
    "coil_source": frozenset({"sf_source"}),
    "asymmetric": frozenset({"sf_source", "sf_asymmetry", "sf_nonlinearity"}),
}

_DESCR = """\
Simulated IFOG rate-table campaign
----------------------------------

Each unit (its own bias and scale-factor coefficients) sits with its input axis vertical on a
turntable in a thermal chamber; the chamber follows a temperature profile while the table
steps through input rates (a fresh random order each cycle through the list, each rate held
for a dwell); each row is one sample of one run.

Columns: unit, run (unique across the campaign), time (s from the start of the run),
temperature (coil sensor, degC, 0.01 degC resolution), source_temperature (light-source
sensor, degC, 0.01 degC resolution), table_rate (commanded, deg/s), reference (true input
rate, table_rate * 3600 + Earth rate * sin(latitude), deg/h), rate (gyro output, deg/h),
drift (true bias part, noise-free, deg/h), scale_factor_error (true scale-factor error at the
row, ppm), chamber_temperature (degC).

Target: drift_measured = rate - reference = reference * s + drift + noise.

Physics: the thermal simulator's bias physics and noise; a scale-factor error from the coil
(linear and quadratic in its mean temperature plus its radial gradient), the light source's
own temperature (a lag of the chamber plus self-heating) and, in preset "asymmetric", a
difference between positive and negative inputs and an odd nonlinearity. The true
coefficients of each unit are in ``unit_params``.
"""


def _draw_scale_factor_params(rng, unit):
    """One unit's scale-factor and source coefficients (a fixed number of draws, in order)."""
    return {
        "unit": unit,
        "sf_coil_linear": float(rng.uniform(3.0, 6.0)),
        "sf_coil_quadratic": signed_uniform(rng, 0.005, 0.02),
        "sf_coil_gradient": signed_uniform(rng, 0.5, 3.0),
        "tau_source": float(rng.uniform(5.0, 20.0)) * _SECONDS_PER_MINUTE,
        "source_self_heating": float(rng.uniform(1.0, 5.0)),
        "tau_source_sensor": float(rng.uniform(0.5, 2.0)) * _SECONDS_PER_MINUTE,
        "source_sensor_offset": float(rng.uniform(-0.1, 0.1)),
        "sf_source": float(rng.uniform(1.0, 3.0)),
        "sf_asymmetry": signed_uniform(rng, 3.0, 20.0),
        "sf_nonlinearity": signed_uniform(rng, 2.0, 10.0),
    }


def _draw_rate_table_units(physics, preset, n_units, lot_spread, rng):
    """Every unit's bias and scale-factor coefficients, and the lot's design (or None)."""
    bias_params, bias_design = _draw_units(physics, n_units, lot_spread, rng)
    if lot_spread is None:
        scale_params = [_draw_scale_factor_params(rng, unit) for unit in range(n_units)]
        scale_design = None
    else:
        scale_design = _draw_scale_factor_params(rng, None)
        scale_params = [
            scatter_unit_params(scale_design, unit, lot_spread, rng) for unit in range(n_units)
        ]
    dropped = {"sf_source", "sf_asymmetry", "sf_nonlinearity"} - _PRESET_TERMS[preset]
    units = [
        {**bias, **scale, **dict.fromkeys(dropped, 0.0)}
        for bias, scale in zip(bias_params, scale_params, strict=True)
    ]
    design = None
    if lot_spread is not None:
        design = {**bias_design, **scale_design, **dict.fromkeys(dropped, 0.0)}
    return units, design


def scale_factor_terms(params, coil_mean, coil_gradient, source_temperature, reference):
    """The four terms of a unit's scale-factor error, ppm, at given states and input rates.

    Parameters
    ----------
    params : dict
        The unit's coefficients (``sf_coil_linear``, ``sf_coil_quadratic``,
        ``sf_coil_gradient``, ``sf_source``, ``sf_asymmetry``, ``sf_nonlinearity``,
        ``reference_temperature``), as in ``make_rate_table_campaign(...).unit_params``.
    coil_mean : array-like
        Mean coil temperature Tm, degC.
    coil_gradient : array-like
        Radial gradient of the coil, outer minus inner layer, degC.
    source_temperature : array-like
        True temperature of the light source Ts, degC.
    reference : array-like
        True input rate, deg/h.

    Returns
    -------
    terms : dict of ndarray
        ``scale_factor_coil``, ``scale_factor_source``, ``scale_factor_asymmetry`` and
        ``scale_factor_nonlinearity``, ppm; their sum is the scale-factor error.

    Examples
    --------
    >>> from sklearn_ifog.datasets import make_rate_table_campaign
    >>> from sklearn_ifog.datasets._rate_table import scale_factor_terms
    >>> campaign = make_rate_table_campaign(
    ...     n_units=1, n_runs=1, preset="asymmetric", random_state=0
    ... )
    >>> unit = campaign.unit_params[0]
    >>> # +-100 deg/s, coil and source at T0, no gradient: only the rate terms are left
    >>> terms = scale_factor_terms(unit, 15.0, 0.0, 15.0, [3.6e5, -3.6e5])
    >>> terms["scale_factor_coil"], terms["scale_factor_source"]
    (array([0., 0.]), array([0., 0.]))
    >>> asymmetry = terms["scale_factor_asymmetry"]
    >>> bool(asymmetry[0] - asymmetry[1] == unit["sf_asymmetry"])
    True
    """
    p = params
    delta = np.asarray(coil_mean, dtype=np.float64) - p["reference_temperature"]
    gradient = np.asarray(coil_gradient, dtype=np.float64)
    source = np.asarray(source_temperature, dtype=np.float64) - p["reference_temperature"]
    reference = np.asarray(reference, dtype=np.float64)
    coil = p["sf_coil_linear"] * delta + p["sf_coil_quadratic"] * delta**2
    coil = coil + p["sf_coil_gradient"] * gradient
    full_scale = NONLINEARITY_FULL_SCALE * _SECONDS_PER_HOUR
    shape = np.broadcast(delta, gradient, source, reference).shape
    return {
        "scale_factor_coil": np.broadcast_to(coil, shape).copy(),
        "scale_factor_source": np.broadcast_to(p["sf_source"] * source, shape).copy(),
        "scale_factor_asymmetry": np.broadcast_to(
            0.5 * p["sf_asymmetry"] * np.sign(reference), shape
        ).copy(),
        "scale_factor_nonlinearity": np.broadcast_to(
            p["sf_nonlinearity"] * (reference / full_scale) ** 2, shape
        ).copy(),
    }


def _source_temperatures(p, chamber, sampling_period):
    """True source temperature, its sensor's true and quantised readings, degC."""
    true = first_order_lag(chamber, sampling_period, p["tau_source"], chamber[0])
    true = true + p["source_self_heating"]
    sensor = first_order_lag(true, sampling_period, p["tau_source_sensor"], true[0])
    reading = np.round((sensor + p["source_sensor_offset"]) / SENSOR_RESOLUTION)
    return true, sensor, reading * SENSOR_RESOLUTION


def _table_sequence(rates, per_dwell, n_profile_samples, rng):
    """Commanded rate per sample: whole cycles, each a fresh permutation of ``rates``."""
    cycle = per_dwell * rates.shape[0]
    n_cycles = max(1, int(np.ceil(n_profile_samples / cycle)))
    order = np.argsort(rng.random_sample((n_cycles, rates.shape[0])), axis=1, kind="stable")
    sequence = rates[order].ravel()
    return sequence, np.repeat(sequence, per_dwell)


def _simulate_table_run(params, run_id, *, profile, settings, rng):
    """One run of one unit on the rate table: chamber, table, physics, scale factor, output."""
    sampling_period = settings["sampling_period"]
    times, setpoints, ramp_used = _chamber_profile(
        profile, rng, settings["ramp_rate"], settings["temperature_range"]
    )
    n_profile = int(np.floor(times[-1] / sampling_period)) + 1
    sequence, table_rate = _table_sequence(
        settings["rates"], settings["per_dwell"], n_profile, rng
    )
    n_samples = table_rate.shape[0]
    time = np.arange(n_samples) * sampling_period
    if time[-1] > times[-1]:
        # The table finishes its last cycle: the chamber holds its last set-point meanwhile.
        times, setpoints = np.append(times, time[-1]), np.append(setpoints, setpoints[-1])
    parts, output_rng = simulate_thermal(
        settings["physics"],
        params,
        times,
        setpoints,
        n_samples,
        sampling_period,
        settings["noise"],
        rng,
    )
    source_true, source_sensor, source_reading = _source_temperatures(
        params, parts["chamber_temperature"], sampling_period
    )
    reference = table_rate * _SECONDS_PER_HOUR + settings["vertical_earth_rate"]
    gradient = parts["coil_outer"] - parts["coil_inner"]
    terms = scale_factor_terms(params, parts["coil_mean"], gradient, source_true, reference)
    error = (
        terms["scale_factor_coil"]
        + terms["scale_factor_source"]
        + terms["scale_factor_asymmetry"]
        + terms["scale_factor_nonlinearity"]
    )
    sensed = reference * (1.0 + error * PPM)
    noise_parts = gyro_output(
        sensed, parts["drift"], sampling_period, params, settings["noise"], output_rng
    )
    parts.update(noise_parts)
    columns = {
        "unit": np.full(n_samples, params["unit"], dtype=np.int64),
        "run": np.full(n_samples, run_id, dtype=np.int64),
        "time": time,
        "temperature": parts["temperature"],
        "source_temperature": source_reading,
        "table_rate": table_rate,
        "reference": reference,
        "rate": parts["rate"],
        "drift": parts["drift"],
        "scale_factor_error": error,
        "chamber_temperature": parts["chamber_temperature"],
    }
    components = {
        **{key: parts[key] for key in _PHYSICS_COMPONENTS[settings["physics"]]},
        "coil_gradient": gradient,
        "source_temp_true": source_true,
        "source_sensor": source_sensor,
        **terms,
    }
    run_params = {
        "unit": params["unit"],
        "run": run_id,
        "profile": profile,
        "ramp_rate": ramp_used,
        "duration": float(time[-1]),
        "min_setpoint": float(setpoints.min()),
        "max_setpoint": float(setpoints.max()),
        "n_cycles": int(sequence.shape[0] // settings["rates"].shape[0]),
        "rate_sequence": sequence,
        "breakpoint_times": times,
        "breakpoint_temperatures": setpoints,
    }
    return columns, components, run_params


def _check_rates(rates):
    try:
        values = np.atleast_1d(np.asarray(rates, dtype=np.float64))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"rates must be numbers in deg/s, got {rates!r}.") from exc
    if values.ndim != 1 or values.size == 0:
        raise ValueError(f"rates must be a non-empty 1-D list of deg/s, got {rates!r}.")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"rates must be finite (deg/s), got {rates!r}.")
    if not np.any(values != 0.0):
        raise ValueError(
            f"rates must hold at least one non-zero rate (deg/s): the scale factor is "
            f"unobservable at zero input; got {rates!r}."
        )
    if np.any(np.abs(values) > MAX_TABLE_RATE):
        raise ValueError(
            f"rates must be within ±{MAX_TABLE_RATE:g} deg/s (a table rate in deg/s, not "
            f"deg/h), got {float(values[np.abs(values) > MAX_TABLE_RATE][0])!r}."
        )
    return values


def _check_dwell(dwell, sampling_period):
    """Samples per dwell: ``dwell`` must be a whole number of sample periods."""
    ratio = float(dwell) / float(sampling_period)
    per_dwell = round(ratio)
    if per_dwell < 1 or abs(ratio - per_dwell) > 1e-9 * max(1.0, ratio):
        raise ValueError(
            f"dwell must be a positive multiple of sampling_period ({sampling_period!r} s) so "
            f"that the table steps on sample boundaries, got dwell={dwell!r} s."
        )
    return per_dwell


def _check_settings(rates, dwell, sampling_period, profile, ramp_rate, temperature_range):
    """The checked rates, samples per dwell, profile names, ramp rate and range."""
    rate_values = _check_rates(rates)
    per_dwell = _check_dwell(dwell, sampling_period)
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
    return rate_values, per_dwell, profile_names, ramp, low_high


@validate_params(
    {
        "n_units": [Interval(Integral, 1, None, closed="left")],
        "n_runs": [Interval(Integral, 1, None, closed="left")],
        "rates": ["array-like"],
        "profile": [StrOptions({*PROFILES, "mix"}), list, tuple],
        "preset": [StrOptions(set(RATE_TABLE_PRESETS))],
        "dwell": [Interval(Real, 0.0, None, closed="neither")],
        "sampling_period": [Interval(Real, 0.1, 600.0, closed="both")],
        "temperature_range": [tuple, list],
        "ramp_rate": [Interval(Real, 0.0, None, closed="neither"), tuple, list],
        "latitude": [Interval(Real, -90.0, 90.0, closed="both")],
        "physics": [StrOptions(set(PHYSICS))],
        "noise": ["boolean"],
        "lot_spread": [Interval(Real, 0.0, None, closed="left"), None],
        "random_state": ["random_state"],
        "as_frame": ["boolean"],
        "return_X_y": ["boolean"],
    },
    prefer_skip_nested_validation=True,
)
def make_rate_table_campaign(
    n_units=3,
    n_runs=2,
    rates=DEFAULT_RATES,
    profile="cycle",
    *,
    preset="coil_source",
    dwell=120.0,
    sampling_period=30.0,
    temperature_range=(-40.0, 70.0),
    ramp_rate=(0.5, 2.0),
    latitude=45.0,
    physics="lumped",
    noise=True,
    lot_spread=None,
    random_state=None,
    as_frame=True,
    return_X_y=False,
):
    """Simulate a rate-table thermal campaign: bias and scale factor over temperature.

    Every unit (gyro) sits with its input axis vertical on a turntable inside the thermal
    chamber and is recorded ``n_runs`` times. In each run the chamber follows one of the
    thermal simulator's profiles (:func:`make_thermal_campaign`: soaks, ramps up and down,
    levels drawn per run, so runs reach different temperatures) while the table steps
    through ``rates``: each cycle through the list is a fresh random permutation, each rate
    held for ``dwell`` seconds, steps on sample boundaries, and the run lasts a whole number
    of cycles (the chamber holds its last set-point until the table's last cycle ends). The
    gyro senses::

        reference = table_rate * 3600 + Ω_e sin(latitude)       (deg/h)
        rate      = reference * (1 + s) + drift + noise

    with ``drift`` and ``noise`` the thermal simulator's bias physics and gyro noise
    (``physics``; turn-on bias, bias instability, angle random walk, quantisation) and ``s``
    the unit's scale-factor error (reported in ppm, ``s * 1e6``) from ``preset``:

    - ``"coil"``: the coil alone, ``s = a1 (Tm - T0) + a2 (Tm - T0)² + g (T_outer -
      T_inner)``: thermal expansion of the coil's length and diameter (the Sagnac scale
      factor is ``2 π L D / (λ c)``), linear and quadratic in the mean coil temperature
      ``Tm`` (a few ppm/degC, hundreds of ppm over -40..70 degC), plus a thermal-state term
      on the radial gradient (outer minus inner layer), so heating and cooling give
      different ``s`` at the same coil temperature. The source term is zero.
    - ``"coil_source"`` (default): plus the light source, ``c (Ts - T0)`` with ``Ts`` the
      source's own temperature, a first-order lag of the chamber (5-20 min) plus a
      self-heating offset; its mean wavelength shifts by 1-3 ppm/degC. A second sensor,
      ``source_temperature``, reads it with its own lag (0.5-2 min), offset and 0.01 degC
      resolution, so it leads or trails the coil sensor during ramps.
    - ``"asymmetric"``: plus a rate asymmetry, ``(δ / 2) sign(reference)`` (positive and
      negative inputs differ by ``δ``, 3-20 ppm), and a small odd nonlinearity of the
      output, ``ν (reference / 300 deg/s)²`` (2-10 ppm at 300 deg/s).

    The coefficient table with the source of every value is in the module
    ``sklearn_ifog/datasets/_rate_table.py`` and in :ref:`physics`.

    Parameters
    ----------
    n_units : int, default=3
        Number of gyros, each with its own coefficients.
    n_runs : int, default=2
        Runs per unit.
    rates : array-like of float, default=(0, 1, -1, 10, -10, 100, -100, 300, -300)
        Table rates, deg/s (:data:`DEFAULT_RATES`): finite, at least one non-zero, each
        within ±1000 deg/s. Each cycle visits every entry once, in a random order.
    profile : {"paper", "cycle", "staircase", "cooling", "mix"} or list of str, \
default="cycle"
        Chamber profile of every run, as in :func:`make_thermal_campaign` (``"cycle"``: one
        or two low-high-low cycles, so every run heats and cools).
    preset : {"coil", "coil_source", "asymmetric"}, default="coil_source"
        Scale-factor model (:data:`RATE_TABLE_PRESETS`), described above.
    dwell : float, default=120.0
        Seconds each rate is held; a whole multiple of ``sampling_period``.
    sampling_period : float, default=30.0
        Sample spacing, seconds, in [0.1, 600]. The default campaign has 4,000-8,000 rows
        (it depends on the drawn profiles); rows scale as 1/sampling_period.
    temperature_range : (float, float), default=(-40.0, 70.0)
        Lowest and highest chamber temperature, degC (a navigation gyro's full range).
    ramp_rate : float or (float, float), default=(0.5, 2.0)
        Chamber ramp rate, degC/min: one value, or a range each run draws from
        (log-uniformly).
    latitude : float, default=45.0
        Latitude of the test site, degrees: the vertical Earth-rate component
        ``Ω_e sin(latitude)`` is part of every input.
    physics : {"lumped", "layered", "layered_glass", "layered_glass_asymmetric", \
"layered_glass_two", "layered_glass_hysteresis"}, default="lumped"
        Thermal model of the coil and of the bias drift, as in :func:`make_thermal_campaign`
        (the coil's outer and inner layers give the scale factor's gradient term).
    noise : bool, default=True
        Whether to add the chamber fluctuation and the gyro noise. With ``noise=False``
        ``rate == reference * (1 + scale_factor_error * 1e-6) + drift`` exactly; the
        temperature readings stay quantised.
    lot_spread : float or None, default=None
        None: independent units. A float: a production lot; the design (bias and
        scale-factor coefficients) is drawn like one unit and every numeric coefficient of
        every unit is the design's times ``exp(lot_spread * N(0, 1))`` (signs kept), as in
        :func:`make_thermal_campaign`. The design is returned as ``design_params``.
    random_state : int, RandomState instance or None, default=None
        Seed of every draw (units first, then runs); an int gives the same campaign bit for
        bit. The draws do not depend on ``preset``: one seed gives the same units, runs,
        temperatures and bias at every preset.
    as_frame : bool, default=True
        Return pandas objects; False gives numpy arrays and ``frame=None``.
    return_X_y : bool, default=False
        Return ``(data, target)`` instead of a Bunch.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with attributes:

        frame : DataFrame or None
            Columns unit, run (unique across the campaign), time (s, from 0 in each run),
            temperature (coil sensor, degC), source_temperature (source sensor, degC),
            table_rate (commanded, deg/s), reference (true input, deg/h), rate (gyro
            output, deg/h), drift (true bias part, noise-free, deg/h), scale_factor_error
            (true ``s`` at the row and its input, ppm) and chamber_temperature (degC).
        data : DataFrame or ndarray of shape (n_samples, 6)
            Columns unit, run, time, temperature, source_temperature, reference.
        target : Series or ndarray of shape (n_samples,)
            ``drift_measured = rate - reference``.
        feature_names : list of str
            Names of the data columns.
        target_names : list of str
            ``["drift_measured"]``.
        unit_params : list of dict
            True coefficients of each unit: the bias physics' and ``sf_coil_linear`` (a1,
            ppm/degC), ``sf_coil_quadratic`` (a2, ppm/degC²), ``sf_coil_gradient`` (g,
            ppm/degC), ``sf_source`` (c, ppm/degC), ``sf_asymmetry`` (δ, ppm),
            ``sf_nonlinearity`` (ν, ppm at 300 deg/s), ``tau_source``,
            ``tau_source_sensor`` (s), ``source_self_heating``, ``source_sensor_offset``
            (degC); a preset's unused terms are 0.
        design_params : dict or None
            With ``lot_spread``: the lot's design; None without.
        run_params : DataFrame or list of dict
            Per run: unit, run, profile, ramp_rate (degC/min), duration (s), min_setpoint
            and max_setpoint (degC), n_cycles, rate_sequence (deg/s, one entry per dwell),
            breakpoint_times (s) and breakpoint_temperatures (degC) of the chamber.
        components : DataFrame or dict of ndarray
            Per row, the hidden truth: the bias physics' components (coil_outer,
            coil_inner, coil_mean, ..., as in :func:`make_thermal_campaign`), coil_gradient
            (outer minus inner, degC), source_temp_true, source_sensor (true sensor
            temperature before offset and quantisation, degC), scale_factor_coil,
            scale_factor_source, scale_factor_asymmetry and scale_factor_nonlinearity
            (ppm; their sum is scale_factor_error).
        DESCR : str
            Description of the data set.

    (data, target) : tuple if ``return_X_y`` is True
        ``data`` and ``target`` as above.

    See Also
    --------
    make_thermal_campaign : The static thermal test: bias only, Earth rate at azimuths.

    Notes
    -----
    The scale-factor coefficients are drawn uniformly per unit (the module docstring has the
    table with sources): a1 3-6 ppm/degC; a2 ±0.005-0.02 ppm/degC²; g ±0.5-3 ppm/degC of
    gradient; c 1-3 ppm/degC (drawn with the coil's sign); source lag 5-20 min, self-heating
    1-5 degC, source sensor lag 0.5-2 min and offset ±0.1 degC; δ ±3-20 ppm; ν ±2-10 ppm;
    T0 = 15 degC. Published uncompensated FOG scale factors move by hundreds of ppm over the
    full temperature range (issue 44 quotes 835 ppm peak-to-peak); IEEE Std 952-1997 defines
    the scale factor's temperature sensitivity, asymmetry and nonlinearity. The scale-factor
    error is evaluated at each sample's instantaneous state; the bias physics' sample means
    are unchanged.

    References
    ----------
    .. [1] H. C. Lefèvre, *The Fiber-Optic Gyroscope*, 2nd ed., Artech House, 2014.
    .. [2] IEEE Std 952-1997, IEEE Standard Specification Format Guide and Test Procedure for
       Single-Axis Interferometric Fiber Optic Gyros.
    .. [3] P. F. Wysocki, M. J. F. Digonnet, B. Y. Kim and H. J. Shaw, "Characteristics of
       erbium-doped superfluorescent fiber sources for interferometric sensor
       applications", J. Lightwave Technol. 12(3), 550-567, 1994.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.datasets import make_rate_table_campaign
    >>> campaign = make_rate_table_campaign(n_units=1, n_runs=1, random_state=0)
    >>> list(campaign.frame.columns)  # doctest: +NORMALIZE_WHITESPACE
    ['unit', 'run', 'time', 'temperature', 'source_temperature', 'table_rate', 'reference',
     'rate', 'drift', 'scale_factor_error', 'chamber_temperature']
    >>> sorted(campaign.frame["table_rate"].unique().tolist())
    [-300.0, -100.0, -10.0, -1.0, 0.0, 1.0, 10.0, 100.0, 300.0]
    >>> quiet = make_rate_table_campaign(n_units=1, n_runs=1, noise=False, random_state=0)
    >>> f = quiet.frame
    >>> expected = f["reference"] * (1 + f["scale_factor_error"] * 1e-6) + f["drift"]
    >>> bool(np.allclose(f["rate"], expected, rtol=0, atol=1e-9))
    True
    >>> X, y = make_rate_table_campaign(n_units=2, n_runs=1, random_state=0, return_X_y=True)
    >>> list(X.columns), y.name
    (['unit', 'run', 'time', 'temperature', 'source_temperature', 'reference'], 'drift_measured')
    """
    rate_values, per_dwell, profile_names, ramp, low_high = _check_settings(
        rates, dwell, sampling_period, profile, ramp_rate, temperature_range
    )
    settings = {
        "rates": rate_values,
        "per_dwell": per_dwell,
        "sampling_period": float(sampling_period),
        "ramp_rate": ramp,
        "temperature_range": low_high,
        "physics": physics,
        "noise": noise,
        "vertical_earth_rate": EARTH_ROTATION_RATE * np.sin(np.deg2rad(latitude)),
    }
    rng = check_random_state(random_state)
    unit_params, design_params = _draw_rate_table_units(physics, preset, n_units, lot_spread, rng)
    runs = []
    for params in unit_params:
        for _ in range(n_runs):
            profile_name = profile_names[int(rng.randint(len(profile_names)))]
            runs.append(
                _simulate_table_run(
                    params, len(runs), profile=profile_name, settings=settings, rng=rng
                )
            )
    return campaign_bunch(
        runs,
        (*_PHYSICS_COMPONENTS[physics], *SCALE_FACTOR_COMPONENTS),
        unit_params=unit_params,
        design_params=design_params,
        as_frame=as_frame,
        return_X_y=return_X_y,
        frame_columns=FRAME_COLUMNS,
        feature_names=FEATURE_NAMES,
        descr=_DESCR,
    )
