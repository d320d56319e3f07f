"""Glass transitions of the layered physics that no single logistic step describes.

The "layered_glass" preset lowers the potting's relative stiffness ``E`` by a logistic step
at Tg (:func:`~sklearn_ifog.datasets._layered.glass_stiffness`). Real coatings and pottings
bend in other ways; three presets each break one property of that logistic:

``"layered_glass_asymmetric"`` (:func:`asymmetric_stiffness`)
    A generalised logistic (Richards) step, sharp on one side of Tg and slow on the other:
    ``1 - E`` rises as ``(1 + exp(-(T - Tg) / w - x0)) ** -m`` with ``x0`` chosen so that
    half the drop is reached at Tg; ``m`` (the unit's ``glass_exponent``) is 1 for the
    logistic, and here ``m = exp(±u)``, ``u`` in ``[ln 2, ln 5]``: the step's tail below Tg
    decays as ``exp(m (T - Tg) / w)``, the one above as ``exp(-(T - Tg) / w)``, so ``m > 1``
    is a sharp onset and a slow end (as the Gompertz limit), ``m < 1`` a slow onset and a
    sharp end.
``"layered_glass_two"`` (:func:`two_step_stiffness`)
    Two transitions, the potting's at Tg and a second one (a second coating/potting layer or
    a secondary relaxation) at ``glass_temperature_2``, each a logistic with its own width
    and stiffness ratio; ``E`` is their product. The two temperatures are at least
    ``4 max(w, w2)`` apart, both inside -5..35 degC.
``"layered_glass_hysteresis"`` (:func:`hysteresis_state`)
    The transition temperature depends on the coating's thermal history: on heating it is
    ``Tg + dH / 2``, on cooling ``Tg - dH / 2`` (``dH``, ``glass_hysteresis``, 2-6 degC).
    A state ``h`` in [-1, 1] relaxes towards the smoothed sign of the coil's temperature
    rate, by the temperature travelled (``dh = (tanh(rate / r) - h) |dT| / delta``), so a
    soak (no travel) keeps the last state; the effective Tg is ``Tg + h dH / 2``. Before the
    run the coil came from the laboratory's 20 degC. No function of the temperature alone
    can represent it: at one coil temperature, heating and cooling rows have different
    stiffnesses.

In every preset the static bias gains ``beta_g w softplus((Tm - Tg) / w)`` as in
"layered_glass" (with the effective Tg of the hysteresis; at the first Tg of the two
transitions). The extra coefficients are drawn from a stream of their own, seeded by the
unit's layered coefficients, after every draw of the campaign's generator: a seed gives
"layered" and each of these presets the same units (but for the extra keys) and runs. In a
lot (``lot_spread``) the design's extra coefficients are scattered like the others. Their
ranges and sources are in the coefficient table of :mod:`sklearn_ifog.datasets._layered`.
"""

import numpy as np

from sklearn_ifog.datasets._layered import glass_stiffness

__all__ = [
    "TRANSITION_COMPONENT_COLUMNS",
    "TRANSITION_PRESETS",
    "asymmetric_stiffness",
    "draw_transition_params",
    "hysteresis_state",
    "transition_rng",
    "transition_state",
    "two_step_stiffness",
]

#: Physics preset -> transition kind (the argument ``glass`` of the layered physics).
TRANSITION_PRESETS = {
    "layered_glass_asymmetric": "asymmetric",
    "layered_glass_two": "two",
    "layered_glass_hysteresis": "hysteresis",
}
#: Components the transition presets add to the layered ones (per row, at the sample time).
TRANSITION_COMPONENT_COLUMNS = ("stiffness", "glass_temperature")

ROOM_TEMPERATURE = 20.0  # degC: where the coil was before the run (the hysteresis' start)
HYSTERESIS_RATE_SCALE = 0.02  # degC/min: the rate at which the state's target is tanh(1)
_SECOND_RANGE = (-5.0, 35.0)  # degC: where the second transition may lie
_SECONDS_PER_MINUTE = 60.0


def asymmetric_stiffness(temperature, glass_temperature, width, rubbery_ratio, exponent):
    """Relative stiffness across an asymmetric (generalised logistic) transition.

    ``E = r + (1 - r) (1 - F)`` with ``F = (1 + exp(-(T - Tg) / width - x0)) ** -exponent``
    and ``x0 = -ln(2 ** (1 / exponent) - 1)``, so that ``E(Tg)`` is halfway between 1 and
    ``r`` for every exponent; ``exponent = 1`` is the logistic of
    :func:`~sklearn_ifog.datasets._layered.glass_stiffness`.

    Parameters
    ----------
    temperature : array-like
        Temperature, degC.
    glass_temperature : float
        Tg (the half-drop temperature), degC.
    width : float
        Width of the transition's logistic core, degC.
    rubbery_ratio : float
        Stiffness above the transition relative to below it.
    exponent : float
        Asymmetry ``m > 0``: above 1 the drop starts sharply and ends slowly, below 1 it
        starts slowly and ends sharply.

    Returns
    -------
    stiffness : ndarray

    Examples
    --------
    >>> asymmetric_stiffness([10.0, 15.0, 20.0], 15.0, 2.0, 0.2, 1.0).round(3)
    array([0.939, 0.6  , 0.261])
    >>> asymmetric_stiffness([10.0, 15.0, 20.0], 15.0, 2.0, 0.2, 4.0).round(3)
    array([0.993, 0.6  , 0.248])
    >>> asymmetric_stiffness([10.0, 15.0, 20.0], 15.0, 2.0, 0.2, 0.25).round(3)
    array([0.783, 0.6  , 0.345])
    """
    x = (np.asarray(temperature, dtype=np.float64) - glass_temperature) / width
    x0 = -np.log(2.0 ** (1.0 / exponent) - 1.0)
    done = np.exp(-exponent * np.logaddexp(0.0, -(x + x0)))
    return rubbery_ratio + (1.0 - rubbery_ratio) * (1.0 - done)


def two_step_stiffness(temperature, p):
    """Relative stiffness across two logistic transitions: the product of their steps.

    Parameters
    ----------
    temperature : array-like
        Temperature, degC.
    p : dict
        The unit's coefficients: ``glass_temperature``, ``glass_width``, ``rubbery_ratio``
        and ``glass_temperature_2``, ``glass_width_2``, ``rubbery_ratio_2``.

    Returns
    -------
    stiffness : ndarray

    Examples
    --------
    >>> p = {
    ...     "glass_temperature": 20.0,
    ...     "glass_width": 1.0,
    ...     "rubbery_ratio": 0.2,
    ...     "glass_temperature_2": 0.0,
    ...     "glass_width_2": 1.0,
    ...     "rubbery_ratio_2": 0.5,
    ... }
    >>> two_step_stiffness([-10.0, 10.0, 30.0], p).round(3)
    array([1. , 0.5, 0.1])
    """
    first = glass_stiffness(
        temperature, p["glass_temperature"], p["glass_width"], p["rubbery_ratio"]
    )
    second = glass_stiffness(
        temperature, p["glass_temperature_2"], p["glass_width_2"], p["rubbery_ratio_2"]
    )
    return first * second


# Decay (in memories of temperature travel) summed per block of the vectorised recursion:
# exp(2 * 300) is within float64's range.
_BLOCK = 300.0


def hysteresis_state(temperature, step, memory, rate_scale=HYSTERESIS_RATE_SCALE):
    """The coating's heating/cooling state along a temperature history, in [-1, 1].

    From ``h0 = s (1 - exp(-|T[0] - 20| / memory))`` (``s`` the sign of ``T[0] - 20``: the
    coil came from the laboratory's 20 degC), each step moves ``h`` towards
    ``tanh(rate / rate_scale)`` by the fraction ``1 - exp(-|dT| / memory)`` of the way:
    +1 after heating, -1 after cooling, unchanged while the temperature stands still.

    Parameters
    ----------
    temperature : array-like of shape (n,)
        Coil temperature on a regular grid, degC.
    step : float
        Grid step, seconds.
    memory : float
        Temperature travel over which the state forgets its past (1/e), degC.
    rate_scale : float, default=0.02
        Rate (degC/min) at which the target is ``tanh(1)``: the sign's smoothing.

    Returns
    -------
    state : ndarray of shape (n,)

    Examples
    --------
    >>> heat_soak_cool = [10.0, 12.0, 14.0, 14.0, 14.0, 12.0, 10.0]
    >>> hysteresis_state(heat_soak_cool, 60.0, 1.0).round(3)
    array([-1.   ,  0.729,  0.963,  0.963,  0.963, -0.734, -0.964])
    """
    temperature = np.asarray(temperature, dtype=np.float64)
    travel = np.diff(temperature)
    target = np.tanh(travel / step * _SECONDS_PER_MINUTE / rate_scale)
    start = temperature[0] - ROOM_TEMPERATURE
    first = float(np.sign(start) * -np.expm1(-abs(start) / memory))
    return np.concatenate([[first], _relax(first, target, np.abs(travel) / memory)])


def _relax(first, target, decay):
    """``h[k] = target[k] + (h[k-1] - target[k]) exp(-decay[k])`` from ``h[-1] = first``.

    A first-order recursion whose coefficient changes at every step, solved without a loop
    over the samples: with ``L`` the cumulative decay, ``h[k] = exp(-L[k]) (first + Σ_{j<=k}
    exp(L[j]) (1 - exp(-decay[j])) target[j])``. ``exp(L)`` is kept below ``exp(_BLOCK)``
    by restarting the sum in blocks of that much decay, each from the last state of the one
    before (the only loop, over blocks: one block for a run that travels less than
    ``_BLOCK`` memories).
    """
    gain = -np.expm1(-decay)
    cumulative = np.cumsum(decay)
    blocks = np.floor(cumulative / _BLOCK).astype(np.int64)
    state = np.empty_like(target)
    previous, origin = first, 0.0
    for block in np.unique(blocks):
        rows = np.flatnonzero(blocks == block)
        level = cumulative[rows] - origin  # in [0, 2 _BLOCK): exp stays finite
        partial = np.cumsum(np.exp(level) * gain[rows] * target[rows])
        state[rows] = np.exp(-level) * (previous + partial)
        previous, origin = state[rows[-1]], cumulative[rows[-1]]
    return state


def transition_state(p, coil_mean, kind, step):
    """Effective transition temperature and relative stiffness along a run's fine grid.

    Parameters
    ----------
    p : dict
        The unit's coefficients (layered ones plus :func:`draw_transition_params`'s).
    coil_mean : ndarray of shape (n,)
        Mean coil temperature on the fine grid, degC.
    kind : {"asymmetric", "two", "hysteresis"}
        The transition (values of :data:`TRANSITION_PRESETS`).
    step : float
        Fine-grid step, seconds.

    Returns
    -------
    state : dict of ndarray of shape (n,)
        ``glass_temperature`` (the Tg the bias bends at: the hysteresis' effective one) and
        ``stiffness``.
    """
    Tg = np.full(coil_mean.shape, p["glass_temperature"])
    if kind == "asymmetric":
        stiffness = asymmetric_stiffness(
            coil_mean, Tg, p["glass_width"], p["rubbery_ratio"], p["glass_exponent"]
        )
    elif kind == "two":
        stiffness = two_step_stiffness(coil_mean, p)
    elif kind == "hysteresis":
        state = hysteresis_state(coil_mean, step, p["glass_memory"])
        Tg = Tg + 0.5 * p["glass_hysteresis"] * state
        stiffness = glass_stiffness(coil_mean, Tg, p["glass_width"], p["rubbery_ratio"])
    else:
        raise ValueError(
            f"kind must be one of {sorted(set(TRANSITION_PRESETS.values()))}, got {kind!r}."
        )
    return {"glass_temperature": Tg, "stiffness": stiffness}


def transition_rng(params):
    """The extra coefficients' own generator, seeded by a unit's (or design's) coefficients.

    Examples
    --------
    >>> a = transition_rng({"unit": 0, "k1": 0.02, "bias_coefficients": (0.1, 2e-3)})
    >>> b = transition_rng({"unit": 1, "k1": 0.02, "bias_coefficients": (0.1, 2e-3)})
    >>> bool(a.uniform() == b.uniform())
    True
    """
    values = []
    for key in sorted(params):
        value = params[key]
        if key != "unit" and isinstance(value, (float, tuple)):
            values.extend(np.atleast_1d(np.asarray(value, dtype=np.float64)).tolist())
    words = np.asarray(values, dtype=np.float64).view(np.uint32)
    seed = np.random.SeedSequence(words.tolist()).generate_state(4)
    return np.random.RandomState(seed)


def draw_transition_params(params):
    """The extra coefficients of every transition preset, drawn from :func:`transition_rng`.

    Parameters
    ----------
    params : dict
        A unit's (or a lot design's) layered coefficients, with ``glass_temperature`` and
        ``glass_width``.

    Returns
    -------
    extra : dict
        ``glass_exponent``, ``glass_temperature_2``, ``glass_width_2``, ``rubbery_ratio_2``,
        ``glass_hysteresis`` and ``glass_memory`` (ranges in the layered module's table).
    """
    rng = transition_rng(params)
    exponent = float(np.exp(rng.choice([-1.0, 1.0]) * rng.uniform(np.log(2.0), np.log(5.0))))
    width_2 = float(rng.uniform(1.5, 4.0))
    gap = 4.0 * max(width_2, params["glass_width"])
    Tg = params["glass_temperature"]
    below = max(0.0, Tg - gap - _SECOND_RANGE[0])
    above = max(0.0, _SECOND_RANGE[1] - Tg - gap)
    u = float(rng.uniform(0.0, below + above))
    second = _SECOND_RANGE[0] + u if u < below else Tg + gap + (u - below)
    return {
        "glass_exponent": exponent,
        "glass_temperature_2": float(second),
        "glass_width_2": width_2,
        "rubbery_ratio_2": float(rng.uniform(0.4, 0.8)),
        "glass_hysteresis": float(rng.uniform(2.0, 6.0)),
        "glass_memory": float(rng.uniform(0.5, 1.5)),
    }
