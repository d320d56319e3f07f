"""First-order recursions and the gyro's noise and output, shared by every physics preset."""

import numpy as np
from scipy.signal import lfilter

__all__ = ["first_order_lag", "gauss_markov", "gyro_output"]

SENSOR_RESOLUTION = 0.01  # degC, reference paper section 4
OUTPUT_ANGLE_QUANTUM = 0.05 / 3600.0  # deg (0.05 arcsec), typical closed-loop IFOG LSB
CHAMBER_FLUCTUATION = 0.05  # degC std, reference paper section 4: control accuracy 0.1 degC
CHAMBER_FLUCTUATION_TIME = 300.0  # s, typical chamber controller cycle
TURN_ON_BIAS_REPEATABILITY = 0.003  # deg/h std per run, typical navigation grade


def first_order_lag(u, sampling_period, time_constant, initial):
    """Response of ``tau * dy/dt = u - y`` to ``u`` sampled every ``sampling_period`` seconds.

    First-order-hold discretisation (exact when ``u`` is linear between samples, as a
    chamber ramp is), run by :func:`scipy.signal.lfilter`; ``y[0] = initial``.

    Parameters
    ----------
    u : ndarray of shape (n_samples,)
        Input, sampled on a uniform grid.
    sampling_period : float
        Sample spacing, seconds.
    time_constant : float
        Time constant tau, seconds.
    initial : float
        State at the first sample.

    Returns
    -------
    y : ndarray of shape (n_samples,)
        Lagged signal.
    """
    pole = np.exp(-sampling_period / time_constant)
    gain_ratio = (1.0 - pole) * time_constant / sampling_period
    numerator = [1.0 - gain_ratio, gain_ratio - pole]
    y = np.empty_like(u, dtype=np.float64)
    y[0] = initial
    if u.shape[0] > 1:
        # Direct-form-II-transposed state after the first sample (input u[0], output y[0]).
        state = [numerator[1] * u[0] + pole * initial]
        y[1:], _ = lfilter(numerator, [1.0, -pole], u[1:], zi=state)
    return y


def gauss_markov(white, sampling_period, correlation_time, sigma, initial):
    """First-order Gauss–Markov sequence with stationary std ``sigma``.

    ``x[n] = phi * x[n-1] + sigma * sqrt(1 - phi**2) * white[n]``, ``phi =
    exp(-sampling_period / correlation_time)``, started from ``x[-1] = initial``.

    Parameters
    ----------
    white : ndarray of shape (n_samples,)
        Standard normal innovations.
    sampling_period : float
        Sample spacing, seconds.
    correlation_time : float
        Correlation time, seconds.
    sigma : float
        Stationary standard deviation.
    initial : float
        State before the first sample (draw it from N(0, sigma**2) for a stationary start).

    Returns
    -------
    x : ndarray of shape (n_samples,)
        The sequence.
    """
    phi = np.exp(-sampling_period / correlation_time)
    drive = sigma * np.sqrt(1.0 - phi**2) * white
    x, _ = lfilter([1.0], [1.0, -phi], drive, zi=[phi * initial])
    return x


def gyro_output(reference, drift, sampling_period, p, noise, rng):
    """Gyro output of one run: reference + drift + noise, quantised.

    Draws, in this order: turn-on bias, bias-instability innovations and initial state,
    angle-random-walk samples, quantiser phase (nothing when ``noise`` is False).

    Parameters
    ----------
    reference, drift : ndarray of shape (n_samples,)
        Input rate and true drift (sample means), deg/h.
    sampling_period : float
        Seconds.
    p : dict
        The unit's coefficients (``angle_random_walk``, ``bias_instability``,
        ``bias_correlation_time``, ``turn_on_bias_repeatability``).
    noise : bool
        Whether to add noise and quantise.
    rng : RandomState
        Source of the draws.

    Returns
    -------
    parts : dict of ndarray
        ``rate`` and the noise components ``turn_on_bias``, ``bias_instability``,
        ``angle_random_walk``, ``quantisation``.
    """
    n_samples = drift.shape[0]
    zeros = np.zeros(n_samples)
    if noise:
        turn_on = np.full(n_samples, rng.normal(0.0, p["turn_on_bias_repeatability"]))
        instability = gauss_markov(
            rng.standard_normal(n_samples),
            sampling_period,
            p["bias_correlation_time"],
            p["bias_instability"],
            rng.normal(0.0, p["bias_instability"]),
        )
        # IEEE Std 952-1997: white rate noise of PSD N^2 averaged over dt has std N / sqrt(dt);
        # N in deg/sqrt(h) -> N * 60 / sqrt(dt[s]) in deg/h.
        arw = p["angle_random_walk"] * 60.0 / np.sqrt(sampling_period)
        white = arw * rng.standard_normal(n_samples)
        unquantised = reference + drift + turn_on + instability + white
        # The output counts whole angle quanta; the rate is the counted angle per sample.
        angle = np.cumsum(unquantised) * (sampling_period / 3600.0)
        phase = rng.uniform(0.0, OUTPUT_ANGLE_QUANTUM)
        counted = np.round((angle + phase) / OUTPUT_ANGLE_QUANTUM)
        counted_before = np.concatenate(([np.round(phase / OUTPUT_ANGLE_QUANTUM)], counted[:-1]))
        rate = (counted - counted_before) * OUTPUT_ANGLE_QUANTUM * (3600.0 / sampling_period)
        quantisation = rate - unquantised
    else:
        turn_on = instability = white = quantisation = zeros
        rate = reference + drift
    return {
        "rate": rate,
        "turn_on_bias": turn_on,
        "bias_instability": instability,
        "angle_random_walk": white,
        "quantisation": quantisation,
    }


def signed_uniform(rng, low, high):
    """A magnitude drawn uniformly in [low, high] with a random sign (two draws, in order)."""
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(low, high))


def draw_static_bias(rng):
    """Coefficients (b0, b1, b2) of the static bias polynomial, deg/h per degC**k.

    Three signed draws in a fixed order; both physics presets share the ranges.
    """
    return (
        signed_uniform(rng, 0.05, 0.15),
        signed_uniform(rng, 2e-3, 4e-3),
        signed_uniform(rng, 1e-5, 5e-5),
    )
