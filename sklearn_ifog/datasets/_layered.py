"""The "layered" and "layered_glass" physics of the thermal-test simulator.

Per run (one recording of one unit at one azimuth)::

    chamber air (set-point + controller fluctuation)
      -> housing  -> coil layer 0 (outer) <-> layer 1 <-> ... <-> layer N-1 (inner)
      -> temperature sensor on the housing (lag, offset, 0.01 degC)
    drift = b(Tm) + sum_i w_i k(T_i) dT_i/dt + s(Tm) E(Tm) (T_0 - T_{N-1})

with ``Tm`` the mean coil temperature, ``k(T) = 1 + k1 (T - T0)``, ``w_i = G x_i + a / N``
(``x_i`` from +1 at the outer layer to -1 at the inner one), ``s(T) = s0 (1 + s1 (T - T0))``,
``E`` the potting's relative stiffness (1 without a glass transition) and ``b`` the static
bias (plus ``beta_g w softplus((Tm - Tg) / w)`` with a glass transition; the transitions
that are not one logistic step are in :mod:`sklearn_ifog.datasets._transitions`). The heat
network is :mod:`sklearn_ifog.datasets._thermal`; everything is computed on a fine grid
(step <= 1 s) and the gyro rate is the mean over each sample period (the Shupe term exactly,
as a difference of its potential; the others by the trapezoidal rule).

Per-unit coefficients, drawn uniformly ("±": random sign). *Typical* = representative of a
navigation-grade IFOG (coil ~1 km on a ~100 mm spool, potted, in a housing) rather than taken
from one device.

=========================  ==========================  =======================================
coefficient                range                       source / justification
=========================  ==========================  =======================================
N (radial layers)          5                           thermal lumps of the winding (each
                                                       holds many fibre layers)
tau_housing                15-40 min                   typical: chamber air to housing, "tens
                                                       of minutes" (reference paper, s. 4)
tau_contact                10-30 min                   typical: coil as one lump against the
                                                       housing (mount, air gap, shield)
tau_diffusion              3-8 min                     radial diffusion through ~10 mm of
                                                       potted fibre, diffusivity ~1.5e-7 m²/s
                                                       (L²/alpha ~ 10 min; slowest mode
                                                       4 L² / (pi² alpha))
C_coil / C_housing         0.2-0.5                     typical
slowest mode (result)      ~15-70 min                  Lefèvre, *The Fiber-Optic Gyroscope*,
                                                       ch. on thermal transients: coil
                                                       responses of tens of minutes
tau_sensor                 0.5-2 min                   typical thermistor on the housing/mount
sensor_offset              ±0.1 degC                   typical calibration error
sensor resolution          0.01 degC                   reference paper, s. 4
G (shupe_gradient)         ±0.1-0.3 deg/h per degC/min quadrupole residual on the radial
                                                       distribution of dT/dt (Shupe 1980;
                                                       Lefèvre ch. 3: the quadrupole winding
                                                       cancels the uniform term to first
                                                       order only)
a (shupe_asymmetry)        ±0.02-0.1 deg/h per         residual winding asymmetry: drift of a
                           degC/min                    uniform rate; with G gives 0.01-0.3
                                                       deg/h in ramps, cf. the paper's Fig. 3
k1                         0.01-0.025 /degC            temperature dependence of dn/dT and of
                                                       the potting (hence T·dT, paper Eq. 13)
T0                         15 degC                     middle of the -10..40 degC range
s0 (stress_coefficient)    ±0.005-0.02 deg/h per degC  elasto-optic bias of a radial thermal
                                                       gradient (Mohr & Schadt 2004); gives
                                                       0.005-0.1 deg/h for 1-5 degC gradients
s1 (stress_k1)             0.01-0.03 /degC             typical: potting modulus vs temperature
b0, b1, b2                 ±0.05-0.15 deg/h,           typical bias temperature sensitivity
                           ±(2-4)e-3 deg/h/degC,       (as the lumped physics)
                           ±(1-5)e-5 deg/h/degC²
Tg                         10-25 degC                  glass transition of a soft potting or
                                                       coating inside the test range (Mohr &
                                                       Schadt; Lefèvre on potting compounds)
w (glass_width)            1.5-4 degC                  typical breadth of a polymer transition
E_rubbery / E_glassy       0.1-0.4                     typical drop of the modulus across Tg
beta_g (glass_bias_slope)  ±(3-8)e-3 deg/h/degC        chosen of the order of b1
m (glass_exponent)         exp(±u), u in ln 2..ln 5    "layered_glass_asymmetric": Richards
                           (0.2-0.5 or 2-5)            (generalised logistic) step; polymer
                                                       relaxations are asymmetric in T
                                                       (Kohlrausch-Williams-Watts stretched
                                                       kinetics; Ferry, *Viscoelastic
                                                       Properties of Polymers*)
Tg2 (glass_temperature_2)  -5..35 degC, >= 4 max(w,    "layered_glass_two": a second coating
                           w2) from Tg                 or potting layer, or a secondary
                                                       (beta) relaxation (Ferry; dual-coated
                                                       fibre: soft primary, hard secondary)
w2 (glass_width_2)         1.5-4 degC                  as w
r2 (rubbery_ratio_2)       0.4-0.8                     typical: a smaller drop than the main
                                                       transition's
dH (glass_hysteresis)      2-6 degC                    "layered_glass_hysteresis": Tg on
                                                       heating minus Tg on cooling (DSC/DMA
                                                       of epoxies and acrylates: the measured
                                                       Tg shifts by a few degC with the
                                                       direction and rate of the scan)
delta (glass_memory)       0.5-1.5 degC                typical: temperature travel over which
                                                       the state forgets the last direction
ARW, bias instability,     as the lumped physics       IEEE Std 952-1997 (navigation grade)
turn-on, quantum
=========================  ==========================  =======================================

References: D. M. Shupe, Applied Optics 19(5), 654-655, 1980; F. Mohr and F. Schadt, "Bias
error in fiber optic gyroscopes due to elasto-optic interactions in the sensor fiber", Proc.
SPIE 5502, 410-413, 2004, doi:10.1117/12.566654 (and F. Mohr, J. Lightwave Technol. 14(1),
1996, on thermo-optically induced bias drift); H. C. Lefèvre, *The Fiber-Optic Gyroscope*,
2nd ed., Artech House, 2014.
"""

import numpy as np

from sklearn_ifog.datasets._gyro import (
    CHAMBER_FLUCTUATION,
    CHAMBER_FLUCTUATION_TIME,
    SENSOR_RESOLUTION,
    draw_static_bias,
    first_order_lag,
    gauss_markov,
    gyro_output,
    signed_uniform,
)
from sklearn_ifog.datasets._thermal import (
    block_average,
    conduction_network,
    modal_response,
    simulate_network,
)

__all__ = [
    "LAYERED_COMPONENT_COLUMNS",
    "draw_layered_params",
    "glass_stiffness",
    "layered_thermal",
    "shupe_weights",
    "simulate_layered_run",
]

N_LAYERS = 5
MAX_FINE_STEP = 1.0  # s: internal integration step of the thermal state and the averages
CHAMBER_GRID_STEP = 1.0  # s: grid of the chamber controller's fluctuation
_SECONDS_PER_MINUTE = 60.0

LAYERED_COMPONENT_COLUMNS = (
    "coil_outer",
    "coil_inner",
    "coil_mean",
    "coil_rate",
    "static_bias",
    "shupe",
    "stress",
    "housing",
    "sensor",
    *(f"layer_{index}" for index in range(N_LAYERS)),
    "turn_on_bias",
    "bias_instability",
    "angle_random_walk",
    "quantisation",
)


def shupe_weights(n_layers, gradient, asymmetry):
    """Shupe weight of each radial layer, outermost first, deg/h per (degC/min).

    ``w_i = gradient * x_i + asymmetry / n_layers`` with ``x_i`` the layer's signed distance
    from the winding's mid-radius, from +1 (outer layer) to -1 (inner layer). A quadrupole
    winding makes the uniform part cancel (``sum_i x_i = 0``): what is left responds to the
    radial *distribution* of the temperature rate (``gradient``) plus the unit's residual
    winding asymmetry (``asymmetry`` = the drift per degC/min of a uniform rate).

    Parameters
    ----------
    n_layers : int
        Number of layers.
    gradient : float
        Weight of the outer layer's rate relative to the mid-radius, deg/h per (degC/min).
    asymmetry : float
        Sum of the weights, deg/h per (degC/min).

    Returns
    -------
    weights : ndarray of shape (n_layers,)

    Examples
    --------
    >>> shupe_weights(3, 0.2, 0.06)
    array([ 0.22,  0.02, -0.18])
    """
    position = np.linspace(1.0, -1.0, n_layers) if n_layers > 1 else np.zeros(1)
    return gradient * position + asymmetry / n_layers


def glass_stiffness(temperature, glass_temperature, width, rubbery_ratio):
    """Relative stiffness of the potting: 1 in the glassy state, ``rubbery_ratio`` above Tg.

    ``E(T) / E_glassy = r + (1 - r) / (1 + exp((T - Tg) / width))``, a logistic step.

    Parameters
    ----------
    temperature : ndarray
        Temperature, degC.
    glass_temperature : float
        Tg, degC.
    width : float
        Width of the transition, degC.
    rubbery_ratio : float
        Stiffness above the transition relative to below it.

    Returns
    -------
    stiffness : ndarray

    Examples
    --------
    >>> glass_stiffness([0.0, 15.0, 30.0], 15.0, 2.0, 0.2).round(3)
    array([1. , 0.6, 0.2])
    """
    x = (np.asarray(temperature, dtype=np.float64) - glass_temperature) / width
    return rubbery_ratio + (1.0 - rubbery_ratio) * 0.5 * (1.0 - np.tanh(0.5 * x))


def _softplus(x):
    return np.logaddexp(0.0, x)


def draw_layered_params(rng, unit, reference_temperature, turn_on_bias_repeatability):
    """One unit's coefficients for the layered physics (a fixed number of draws, in order).

    The glass-transition coefficients are drawn for "layered" too, so that "layered" and
    "layered_glass" with the same seed share every other coefficient and every run.
    """
    return {
        "unit": unit,
        "n_layers": N_LAYERS,
        "tau_housing": float(rng.uniform(15.0, 40.0)) * _SECONDS_PER_MINUTE,
        "tau_contact": float(rng.uniform(10.0, 30.0)) * _SECONDS_PER_MINUTE,
        "tau_diffusion": float(rng.uniform(3.0, 8.0)) * _SECONDS_PER_MINUTE,
        "coil_capacity_ratio": float(rng.uniform(0.2, 0.5)),
        "tau_sensor": float(rng.uniform(0.5, 2.0)) * _SECONDS_PER_MINUTE,
        "sensor_offset": float(rng.uniform(-0.1, 0.1)),
        "shupe_gradient": signed_uniform(rng, 0.1, 0.3),
        "shupe_asymmetry": signed_uniform(rng, 0.02, 0.1),
        "k1": float(rng.uniform(0.01, 0.025)),
        "stress_coefficient": signed_uniform(rng, 0.005, 0.02),
        "stress_k1": float(rng.uniform(0.01, 0.03)),
        "bias_coefficients": draw_static_bias(rng),
        "glass_temperature": float(rng.uniform(10.0, 25.0)),
        "glass_width": float(rng.uniform(1.5, 4.0)),
        "rubbery_ratio": float(rng.uniform(0.1, 0.4)),
        "glass_bias_slope": signed_uniform(rng, 3e-3, 8e-3),
        "angle_random_walk": float(rng.uniform(0.001, 0.003)),
        "bias_instability": float(rng.uniform(0.002, 0.005)),
        "bias_correlation_time": float(rng.uniform(300.0, 1000.0)),
        "turn_on_bias_repeatability": turn_on_bias_repeatability,
        "reference_temperature": reference_temperature,
    }


def _shupe_potential(temperature, k1, reference_temperature):
    """``F(T) = (T - T0) + k1 (T - T0)² / 2``: ``dF/dt = (1 + k1 (T - T0)) dT/dt``."""
    delta = temperature - reference_temperature
    return delta + 0.5 * k1 * delta**2


def layered_drift(p, layers, coil_mean, glass, transition=None):
    """Non-Shupe drift terms on any grid: static bias and thermo-elastic stress, deg/h.

    Parameters
    ----------
    p : dict
        The unit's coefficients.
    layers : ndarray of shape (n_layers, n)
        Layer temperatures, outermost first, degC.
    coil_mean : ndarray of shape (n,)
        Mean coil temperature, degC.
    glass : bool
        Whether the potting has a glass transition.
    transition : dict or None, default=None
        With ``glass``, a transition other than the logistic at Tg: arrays of shape (n,)
        ``glass_temperature`` (where the bias bends) and ``stiffness``, from
        :func:`sklearn_ifog.datasets._transitions.transition_state`.

    Returns
    -------
    bias, stress : ndarray of shape (n,)
    """
    T0 = p["reference_temperature"]
    delta = coil_mean - T0
    bias = np.polynomial.polynomial.polyval(delta, p["bias_coefficients"])
    stiffness = 1.0
    if glass:
        width, Tg = p["glass_width"], p["glass_temperature"]
        if transition is not None:
            Tg = transition["glass_temperature"]
        bias = bias + p["glass_bias_slope"] * width * _softplus((coil_mean - Tg) / width)
        if transition is None:
            stiffness = glass_stiffness(coil_mean, Tg, width, p["rubbery_ratio"])
        else:
            stiffness = transition["stiffness"]
    gradient = layers[0] - layers[-1]
    stress = p["stress_coefficient"] * (1.0 + p["stress_k1"] * delta) * stiffness * gradient
    return bias, stress


def simulate_layered_run(
    p, breakpoint_times, breakpoint_temperatures, reference, sampling_period, noise, glass, rng
):
    """Arrays of one run under the layered physics.

    Draws two seeds from ``rng`` (thermal history, gyro noise), so the number of draws from
    ``rng`` does not depend on the run's length or the sample period: the same campaign seed
    gives the same chamber history and temperatures at every sample period.
    """
    n_samples = reference.shape[0]
    thermal_seed, noise_seed = rng.randint(np.iinfo(np.int32).max, size=2)
    parts = layered_thermal(
        p,
        breakpoint_times,
        breakpoint_temperatures,
        n_samples,
        sampling_period,
        noise,
        glass,
        thermal_seed,
    )
    noise_rng = np.random.RandomState(noise_seed)
    parts.update(gyro_output(reference, parts["drift"], sampling_period, p, noise, noise_rng))
    return parts


def layered_thermal(
    p,
    breakpoint_times,
    breakpoint_temperatures,
    n_samples,
    sampling_period,
    noise,
    glass,
    thermal_seed,
    transition=None,
):
    """The thermal part of one layered run: temperatures, sensor reading and drift terms.

    Everything :func:`simulate_layered_run` returns but the gyro output and its noise
    (``thermal_seed`` seeds the chamber fluctuation), so that a caller can change the input
    rate the gyro sees (the rate-table simulator's scale factor) before the output is drawn.
    ``transition`` (with ``glass``), a function ``(coil_mean, step) -> state`` on the fine
    grid, replaces the logistic step (see :func:`layered_drift`); the returned parts then
    add the ``stiffness`` and ``glass_temperature`` at each sample.
    """
    per_block = int(np.ceil(sampling_period / MAX_FINE_STEP - 1e-9))
    step = sampling_period / per_block
    # Fine grid from one sample period before the first sample: block n (the gyro's n-th
    # sample) spans (t_n - sampling_period, t_n].
    fine_time = (np.arange(n_samples * per_block + 1) - per_block) * step
    chamber = np.interp(fine_time, breakpoint_times, breakpoint_temperatures)
    if noise:
        thermal_rng = np.random.RandomState(thermal_seed)
        grid = np.arange(int(np.ceil(breakpoint_times[-1] / CHAMBER_GRID_STEP)) + 2)
        grid = grid * CHAMBER_GRID_STEP
        fluctuation = gauss_markov(
            thermal_rng.standard_normal(grid.shape[0]),
            CHAMBER_GRID_STEP,
            CHAMBER_FLUCTUATION_TIME,
            CHAMBER_FLUCTUATION,
            thermal_rng.normal(0.0, CHAMBER_FLUCTUATION),
        )
        # Before the run the chamber has soaked at its first value (np.interp holds it).
        chamber = chamber + np.interp(fine_time, grid, fluctuation)

    A, b, capacity = conduction_network(
        p["n_layers"],
        p["tau_housing"],
        p["tau_contact"],
        p["tau_diffusion"],
        p["coil_capacity_ratio"],
    )
    time_constants, weights = modal_response(A, b, capacity)
    states, _ = simulate_network(chamber, step, time_constants, weights)
    housing, layers = states[0], states[1:]
    coil_mean = layers.mean(axis=0)
    sensor = first_order_lag(housing, step, p["tau_sensor"], housing[0])

    # Shupe drift, averaged exactly over each sample: sum_i w_i k(T_i) dT_i/dt is the time
    # derivative of sum_i w_i k0 F(T_i), so its mean over a block is a difference.
    T0 = p["reference_temperature"]
    w = shupe_weights(p["n_layers"], p["shupe_gradient"], p["shupe_asymmetry"])
    potential = w @ _shupe_potential(layers[:, ::per_block], p["k1"], T0)
    shupe = np.diff(potential) / sampling_period * _SECONDS_PER_MINUTE
    state = None if transition is None else transition(coil_mean, step)
    bias_fine, stress_fine = layered_drift(p, layers, coil_mean, glass, state)
    bias = block_average(bias_fine, per_block)
    stress = block_average(stress_fine, per_block)
    drift = bias + shupe + stress

    at_samples = slice(per_block, None, per_block)
    reading = sensor[at_samples] + p["sensor_offset"]
    temperature = np.round(reading / SENSOR_RESOLUTION) * SENSOR_RESOLUTION
    coil_rate = np.diff(coil_mean[::per_block]) / sampling_period * _SECONDS_PER_MINUTE
    parts = {
        "temperature": temperature,
        "drift": drift,
        "chamber_temperature": chamber[at_samples],
        "coil_outer": layers[0, at_samples],
        "coil_inner": layers[-1, at_samples],
        "coil_mean": coil_mean[at_samples],
        "coil_rate": coil_rate,
        "static_bias": bias,
        "shupe": shupe,
        "stress": stress,
        "housing": housing[at_samples],
        "sensor": sensor[at_samples],
    }
    for index in range(p["n_layers"]):
        parts[f"layer_{index}"] = layers[index, at_samples]
    if state is not None:
        parts.update({name: values[at_samples] for name, values in state.items()})
    return parts
