"""Causal first-order lags of sampled signals at time constants in seconds, exact per step.

The thermal state of a coil is a causal linear filter of its surface temperature history; a few
first-order lags ``y`` of the measured temperature ``u`` at time constants ``tau`` (seconds,
never rows) span it::

    tau * dy/dt = u(t) - y(t)

This module integrates that equation *exactly* between samples for an input that is linear
between them (a first-order hold, FOH), for any (irregular) time steps, restarting at the first
row of every run. Everything is plain numpy, vectorised: no Python loop over samples.

Design note (for the feature, streaming and C-export code)
----------------------------------------------------------
**The state is the deficit.** Each lag is carried as its deficit ``e = u - y`` (the feature
term ``T - lag_tau(T)``), not as ``y``: the deficit is the small difference the models use, and
carrying it directly keeps its full relative precision (``u - y`` formed from two nearby
temperatures would lose about ``log10(|u| / |e|)`` digits). The lag is ``y = u - e`` and its
time derivative is exactly ``dy/dt = e / tau`` (the ODE), so the smoothed rate comes for free.

**One step** from sample 0 to sample 1, ``h = t1 - t0 > 0``, ``x = h / tau``,
``a = exp(-x)``, ``du = u1 - u0``::

    e1 = a * e0 + g * du

with ``g`` set by how the input is held between the samples (``hold``):

- ``"linear"`` (FOH, the default): ``g = (1 - a) / x = -expm1(-x) / x``. Derivation: with
  ``u(t0 + s) = u0 + du * s / h`` the ODE for ``e = u - y`` is ``e' = du/h - e/tau``, whose
  exact solution is ``e1 = a e0 + (du/h) tau (1 - a)``. Equivalently
  ``y1 = a y0 + (1 - a) u1 - du (tau (1 - a) / h - a)``.
- ``"previous"`` (zero-order hold of ``u0``, a sample-and-hold): ``g = 1``.
- ``"current"`` (``u1`` held over the step, the classic ``y += (1 - a)(u - y)``): ``g = a``.

Limits, all free of cancellation because ``-expm1(-x)`` is computed to full relative
precision: ``x -> 0`` (a short step or a long time constant): ``a -> 1``, ``g -> 1`` (the
deficit follows ``du``); ``x -> inf`` (a long step or ``tau -> 0``): ``a -> 0``, ``g -> 1/x``,
so ``e -> 0`` and ``y -> u`` (the lag degenerates to the signal). ``x == 0`` can only come from
an underflowing ``h / tau`` and is given ``g = 1``, its limit.

**Why FOH.** A sensor's samples are readings of a continuous temperature. Holding each sample
(ZOH) delays the input by half a step, so lags computed from 10 s and 60 s samples of the same
physical signal differ by ``rate * (60 - 10) / 2`` on every ramp; the FOH interpolates
linearly, its error is second order (``h**2 / 8 * max|u''|`` at most, through a filter of unit
gain) and it is exact on ramps, whatever the step. ``tests/test_lags.py::
test_sampling_invariance`` measures both.

**First row of a run.** The system starts in equilibrium: ``e = 0`` (``y = u``), and the
smoothed rate is 0, as ThermalFeatures' ``dT`` at a run's first row.

**Streaming** keeps, per run: the previous sample's time ``t0`` and value ``u0`` of every
column, and the deficit ``e`` of every column at every time constant (:class:`LagState`).
:func:`lag_step` is the step; ``first_order_lag(..., initial=state)`` continues a run from a
state; the state after a chunk is its last row (``time[-1]``, ``values[-1]``, deficit of the
last row).

**C** (one step, per column and time constant; ``exp`` and ``expm1`` from ``<math.h>``)::

    const double x = (time - state->last_time) / tau;           /* > 0 */
    const double a = exp(-x);
    const double g = (x > 0.0) ? -expm1(-x) / x : 1.0;          /* hold = "linear" */
    state->deficit[k] = a * state->deficit[k] + g * (u - state->last_value[c]);
    lag = u - state->deficit[k];  rate = state->deficit[k] / tau * seconds_per_unit;

In double this is :func:`lag_step` operation for operation, which matches the batch to within
rounding (``tests/test_lags.py::test_streaming_step_by_step_equals_batch`` asserts 1e-12 of
the deficit's size; the export target is 1e-9). For ``precision="float"`` keep at least the
time difference in double (time stamps of 1e5 s and more do not survive single precision,
and the C exporter already computes its causal front end in double); the rest of the step in
float then carries float rounding only, well inside the 1e-4 target.

**Batch algorithm.** The recursion ``e[i] = a[i] e[i-1] + b[i]`` (``b = g du``; ``a = 0`` at
a run's first row, which restarts it) is solved by a blocked parallel prefix scan: the affine
maps ``e -> a e + b`` compose associatively, ``(a2, b2) o (a1, b1) = (a2 a1, a2 b1 + b2)``, so
blocks of 64 rows are scanned by recursive doubling (6 vectorised passes), and the blocks'
end values by the same function, recursively. Products of ``a`` are formed by multiplication
(never ``exp`` of a sum of logs, never a division), so nothing overflows, an underflow to 0 is
the exact limit, and very long runs (``t / tau`` far beyond 700) need nothing special. It
matches the plain sequential recursion to within rounding
(``tests/test_lags.py::test_batch_equals_sequential_recursion`` asserts 1e-12 of the deficit's
magnitude in each run).
"""

from typing import NamedTuple

import numpy as np

__all__ = [
    "HOLDS",
    "LagState",
    "first_order_lag",
    "lag_coefficients",
    "lag_deficit",
    "lag_step",
    "lead_estimate",
    "smoothed_rate",
]

#: How the input is taken between two samples (see the module docstring).
HOLDS = ("linear", "previous", "current")

# Rows per block of the prefix scan (6 doubling passes per block).
_BLOCK = 64


class LagState(NamedTuple):
    """The end of a run's previous rows: what streaming keeps to continue the lags.

    Attributes
    ----------
    time : float
        Time of the previous sample, s.
    value : ndarray of shape (n_columns,)
        Its value of every column.
    deficit : ndarray of shape (n_columns, n_time_constants)
        Deficit ``u - lag`` of every column at every time constant after it.
    """

    time: float
    value: np.ndarray
    deficit: np.ndarray


# ---------------------------------------------------------------------------------------------
# One step: the specification of streaming and C.
# ---------------------------------------------------------------------------------------------


def _check_hold(hold):
    if hold not in HOLDS:
        raise ValueError(f"hold must be one of {list(HOLDS)}, got {hold!r}.")


def _check_time_constants(time_constants, name="time_constants"):
    tau = np.asarray(time_constants, dtype=np.float64)
    if tau.ndim > 1:
        raise ValueError(f"{name} must be a number or a 1-D sequence, got shape {tau.shape}.")
    if tau.size == 0:
        raise ValueError(f"{name} is empty; give at least one time constant in seconds.")
    bad = ~(np.isfinite(tau) & (tau > 0))
    if bad.any():
        raise ValueError(
            f"{name} must be finite and > 0 (seconds), got {tau.ravel()[bad.ravel()][0]!r}."
        )
    return tau


def lag_coefficients(h, tau, *, hold="linear"):
    """Coefficients of one exact step of a first-order lag: ``e1 = a * e0 + g * (u1 - u0)``.

    ``e = u - y`` is the deficit of the lag ``y`` (``tau dy/dt = u - y``) behind the input
    ``u``; ``x = h / tau``, ``a = exp(-x)`` and ``g`` depends on ``hold`` (see the module
    docstring): ``"linear"`` ``-expm1(-x) / x`` (exact for an input linear between samples),
    ``"previous"`` 1, ``"current"`` ``a``.

    Parameters
    ----------
    h : float or array-like
        Time steps, s, > 0.
    tau : float or array-like
        Time constants, s, > 0 (broadcast against ``h``).
    hold : {"linear", "previous", "current"}, default="linear"
        How the input is taken between the two samples.

    Returns
    -------
    a : ndarray of float64
        ``exp(-h / tau)``, the decay of the previous deficit.
    g : ndarray of float64
        Gain of the input's change ``u1 - u0``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._lags import lag_coefficients
    >>> a, g = lag_coefficients([1e-9, 60.0, 1e9], 600.0)
    >>> a
    array([1.        , 0.90483742, 0.        ])
    >>> g  # 1 for a short step, tau / h for a long one
    array([1.00000000e+00, 9.51625820e-01, 6.00000000e-07])
    """
    _check_hold(hold)
    with np.errstate(over="ignore"):  # h / tau -> inf is the limit tau -> 0, handled exactly
        x = np.divide(np.asarray(h, dtype=np.float64), np.asarray(tau, dtype=np.float64))
    a = np.exp(-x)
    if hold == "linear":
        g = np.ones_like(x)
        np.divide(-np.expm1(-x), x, out=g, where=x > 0)
    elif hold == "previous":
        g = np.ones_like(x)
    else:
        g = a.copy()
    return a, g


def lag_step(deficit, u_prev, u, h, tau, *, hold="linear"):
    """One exact step of a first-order lag, as streaming and the C export compute it.

    Parameters
    ----------
    deficit : float or array-like
        Deficit ``u_prev - y_prev`` of the lag behind the input at the previous sample.
    u_prev : float or array-like
        Input at the previous sample.
    u : float or array-like
        Input at this sample.
    h : float or array-like
        Time since the previous sample, s, > 0.
    tau : float or array-like
        Time constant(s), s, > 0.
    hold : {"linear", "previous", "current"}, default="linear"
        How the input is taken between the samples (see :func:`lag_coefficients`).

    Returns
    -------
    deficit : ndarray of float64
        ``u - y`` at this sample; the lag is ``u - deficit``, its rate ``deficit / tau``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._lags import lag_step
    >>> # A ramp of 1 degC/min from equilibrium: after one tau the deficit is
    >>> # rate * tau * (1 - exp(-1)), exactly.
    >>> e = lag_step(0.0, 20.0, 30.0, 600.0, 600.0)
    >>> bool(np.isclose(e, 10.0 * (1 - np.exp(-1.0)), rtol=1e-15))
    True
    """
    a, g = lag_coefficients(h, tau, hold=hold)
    return a * np.asarray(deficit, dtype=np.float64) + g * (
        np.asarray(u, dtype=np.float64) - np.asarray(u_prev, dtype=np.float64)
    )


# ---------------------------------------------------------------------------------------------
# The time-varying linear recursion, vectorised.
# ---------------------------------------------------------------------------------------------


def _scan(a, b):
    """Prefix scan along axis 0 of (width, m) arrays by recursive doubling, in place.

    Returns ``(a, b)`` overwritten with ``A[i]``, the product of ``a[:i+1]``, and ``X[i]``, the
    solution of ``x[i] = a[i] x[i-1] + b[i]`` started from ``x[-1] = 0``.
    """
    width = a.shape[0]
    buffer = np.empty_like(b)
    shift = 1
    while shift < width:
        # Element i takes in the map of element i - shift: (a_i, b_i) o (a_j, b_j).
        product = buffer[: width - shift]
        np.multiply(a[shift:], b[:-shift], out=product)
        b[shift:] += product
        np.multiply(a[shift:], a[:-shift], out=product)
        a[shift:] = product
        shift *= 2
        if shift < width and not a[shift:].any():
            break  # every later composition multiplies by an exact zero
    return a, b


def _solve_recurrence(a, b):
    """Solve ``x[i] = a[i] * x[i-1] + b[i]`` along axis 0 with ``x[-1] = 0``.

    ``a`` and ``b`` have shape (n, m); the ``m`` columns are independent recursions. Blocks
    of ``_BLOCK`` rows are laid side by side (block position on axis 0, contiguous rows of
    blocks behind it) and scanned together; the blocks' end values solve the same recursion
    over blocks, recursively.
    """
    n, m = a.shape
    if n <= _BLOCK:
        return _scan(a.copy(), b.copy())[1]
    n_blocks = -(-n // _BLOCK)
    pad = ((0, n_blocks * _BLOCK - n), (0, 0))

    def side_by_side(x):
        x = np.pad(x, pad).reshape(n_blocks, _BLOCK, m)
        return np.ascontiguousarray(x.transpose(1, 0, 2)).reshape(_BLOCK, n_blocks * m)

    products, partial = _scan(side_by_side(a), side_by_side(b))
    ends = _solve_recurrence(products[-1].reshape(n_blocks, m), partial[-1].reshape(n_blocks, m))
    products = products.reshape(_BLOCK, n_blocks, m)
    partial = partial.reshape(_BLOCK, n_blocks, m)
    partial[:, 1:] += products[:, 1:] * ends[None, :-1]
    return partial.transpose(1, 0, 2).reshape(n_blocks * _BLOCK, m)[:n]


def _solve_by_run(a, b, starts):
    """:func:`_solve_recurrence` with every run scanned from its own first row.

    Runs (segments starting at row 0 and at every ``starts``) are laid side by side as
    columns, one block per power-of-two class of run length (padding at most doubles the
    memory; at most ``log2(n) + 1`` classes), each starting at row 0: a run's result is then
    bit for bit the result of that run alone (and of any prefix of it), whatever the other
    runs in the batch.
    """
    n, m = a.shape
    segment_starts = np.flatnonzero(starts)
    if segment_starts.size == 0 or segment_starts[0] != 0:
        segment_starts = np.concatenate(([0], segment_starts))
    if segment_starts.size <= 1:
        return _solve_recurrence(a, b)
    lengths = np.diff(np.append(segment_starts, n))
    length_class = np.ceil(np.log2(lengths)).astype(np.intp)
    out = np.empty_like(b)
    for cls in np.unique(length_class):
        members = np.flatnonzero(length_class == cls)
        width = int(lengths[members].max())
        offsets = np.arange(width)
        rows = segment_starts[members][None, :] + offsets[:, None]  # (width, n_runs)
        valid = offsets[:, None] < lengths[members][None, :]
        rows = np.where(valid, rows, 0)
        # (width, n_runs, m): padding rows after a run's end are zero maps (never read back).
        a_block = np.where(valid[:, :, None], a[rows], 0.0).reshape(width, -1)
        b_block = np.where(valid[:, :, None], b[rows], 0.0).reshape(width, -1)
        solved = _solve_recurrence(a_block, b_block).reshape(width, members.size, m)
        out[rows[valid]] = solved[valid]
    return out


# ---------------------------------------------------------------------------------------------
# Batch lags.
# ---------------------------------------------------------------------------------------------


def _validate(values, time, run_starts, time_constants, hold, initial):
    _check_hold(hold)
    tau = _check_time_constants(time_constants)
    values = np.asarray(values, dtype=np.float64)
    if values.ndim not in (1, 2):
        raise ValueError(
            f"values must have shape (n_samples,) or (n_samples, n_columns), got {values.shape}."
        )
    if not np.all(np.isfinite(values)):
        row = int(np.flatnonzero((~np.isfinite(values.reshape(values.shape[0], -1))).any(1))[0])
        raise ValueError(f"values must be finite; row {row} holds NaN or inf.")
    n_samples = values.shape[0]
    time = np.asarray(time, dtype=np.float64)
    if time.shape != (n_samples,):
        raise ValueError(
            f"time must have shape ({n_samples},) like the rows of values, got {time.shape}."
        )
    if not np.all(np.isfinite(time)):
        row = int(np.flatnonzero(~np.isfinite(time))[0])
        raise ValueError(f"time must be finite; row {row} holds {time[row].item()!r}.")
    if run_starts is None:
        starts = np.zeros(n_samples, dtype=bool)
        if initial is None:
            starts[:1] = True
    else:
        starts = np.asarray(run_starts)
        if starts.shape != (n_samples,) or starts.dtype != bool:
            raise ValueError(
                f"run_starts must be a boolean array of shape ({n_samples},), got "
                f"{starts.dtype} of shape {starts.shape}."
            )
        starts = starts.copy()
        if initial is None:
            starts[:1] = True
    n_columns = 1 if values.ndim == 1 else values.shape[1]
    if initial is not None:
        if not isinstance(initial, LagState):
            raise TypeError(f"initial must be a LagState or None, got {type(initial).__name__}.")
        expected = {"value": (n_columns,), "deficit": (n_columns, tau.size)}
        for field, shape in expected.items():
            got = np.shape(getattr(initial, field))
            if got != shape:
                raise ValueError(
                    f"initial.{field} must have shape {shape} (columns of values, time "
                    f"constants), got {got}."
                )
    return values, time, starts, tau, n_columns


def _step_lengths(time, starts, initial):
    """Time since the previous row of the same run (1.0 at run starts, unused there)."""
    n_samples = time.shape[0]
    h = np.ones(n_samples)
    if n_samples == 0:
        return h
    h[1:] = time[1:] - time[:-1]
    if initial is not None and not starts[0]:
        h[0] = time[0] - float(initial.time)
    bad = np.flatnonzero(~starts & ~(h > 0))
    if bad.size:
        row = int(bad[0])
        previous = (
            f"{time[row - 1].item()!r} at row {row - 1}"
            if row > 0
            else f"{float(initial.time)!r} of the initial state"
        )
        raise ValueError(
            f"time must increase strictly within each run; row {row} has time "
            f"{time[row].item()!r}, not after {previous}."
        )
    h[starts] = 1.0
    return h


def lag_deficit(
    values, time, run_starts=None, time_constants=600.0, *, hold="linear", initial=None
):
    """Deficit ``u - lag_tau(u)`` of causal first-order lags, exact between samples.

    For every column ``u`` of ``values`` and every time constant ``tau`` (seconds), the lag
    ``y`` solves ``tau dy/dt = u - y`` exactly for an input linear between samples (see the
    module docstring), for any time steps, restarting at every run: ``y = u`` (deficit 0) at a
    run's first row, the system in equilibrium. The deficit is carried directly, to full
    relative precision; ``deficit / tau`` is the lag's time derivative.

    Parameters
    ----------
    values : array-like of shape (n_samples,) or (n_samples, n_columns)
        Input signal(s), finite, rows of each run contiguous and in time order.
    time : array-like of shape (n_samples,)
        Time, s, strictly increasing within each run.
    run_starts : array-like of bool of shape (n_samples,), default=None
        True at the first row of every run (the convention of
        :func:`sklearn_ifog.features.group_rows_by_run`). None: one run. Row 0 starts a run
        unless ``initial`` is given and ``run_starts[0]`` is False.
    time_constants : float or array-like of shape (n_time_constants,), default=600.0
        Time constants, s, finite and > 0.
    hold : {"linear", "previous", "current"}, default="linear"
        How the input is taken between samples; ``"linear"`` (first-order hold) is exact for
        a piecewise-linear input and sampling-invariant to second order.
    initial : LagState, default=None
        State at the end of the run's previous rows, to continue a run across chunks
        (streaming). None: row 0 starts a run.

    Returns
    -------
    deficit : ndarray of float64
        Shape (n_samples, n_time_constants) for 1-D ``values`` and
        (n_samples, n_columns, n_time_constants) for 2-D ones; the time-constant axis is
        dropped when ``time_constants`` is a number.

    Raises
    ------
    ValueError
        On non-finite values or time, time not increasing within a run, shapes that do not
        match, a bad ``hold`` or non-positive or non-finite time constants.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._lags import lag_deficit
    >>> t = np.array([0.0, 60.0, 120.0, 600.0, 0.0, 60.0])
    >>> T = np.array([20.0, 21.0, 22.0, 30.0, 25.0, 25.0])
    >>> starts = np.array([True, False, False, False, True, False])
    >>> lag_deficit(T, t, starts, 600.0)  # a 1 degC/min ramp, then the second run at rest
    array([0.        , 0.95162582, 1.81269247, 6.32120559, 0.        , 0.        ])
    """
    values, time, starts, tau, n_columns = _validate(
        values, time, run_starts, time_constants, hold, initial
    )
    n_samples = values.shape[0]
    one_d = values.ndim == 1
    u = values.reshape(n_samples, n_columns)
    h = _step_lengths(time, starts, initial)
    a, g = lag_coefficients(h[:, None], tau.ravel()[None, :], hold=hold)  # (n, k)
    du = np.zeros_like(u)
    du[1:] = u[1:] - u[:-1]
    continues = initial is not None and n_samples > 0 and not starts[0]
    if continues:
        du[0] = u[0] - np.asarray(initial.value, dtype=np.float64)
    a = np.broadcast_to(a[:, None, :], (n_samples, n_columns, tau.size)).copy()
    b = g[:, None, :] * du[:, :, None]
    if continues:
        b[0] += a[0] * np.asarray(initial.deficit, dtype=np.float64)
    a[starts] = 0.0
    b[starts] = 0.0
    width = n_columns * tau.size
    deficit = _solve_by_run(a.reshape(n_samples, width), b.reshape(n_samples, width), starts)
    deficit = deficit.reshape(n_samples, n_columns, tau.size)
    if one_d:
        deficit = deficit[:, 0]
    if np.ndim(time_constants) == 0:
        deficit = deficit[..., 0]
    return deficit


def first_order_lag(
    values, time, run_starts=None, time_constants=600.0, *, hold="linear", initial=None
):
    """Causal first-order lags ``tau dy/dt = u - y`` at time constants in seconds.

    Exact between samples for an input linear between them (first-order hold), for any time
    steps, restarting at every run with ``y = u`` (equilibrium) at its first row. Computed as
    ``u - lag_deficit(...)``; see :func:`lag_deficit` and the module docstring.

    Parameters
    ----------
    values : array-like of shape (n_samples,) or (n_samples, n_columns)
        Input signal(s), finite, rows of each run contiguous and in time order.
    time : array-like of shape (n_samples,)
        Time, s, strictly increasing within each run.
    run_starts : array-like of bool of shape (n_samples,), default=None
        True at the first row of every run. None: one run.
    time_constants : float or array-like of shape (n_time_constants,), default=600.0
        Time constants, s, finite and > 0.
    hold : {"linear", "previous", "current"}, default="linear"
        How the input is taken between samples (see :func:`lag_coefficients`).
    initial : LagState, default=None
        State to continue a run from (streaming). None: row 0 starts a run.

    Returns
    -------
    lag : ndarray of float64
        Shape of :func:`lag_deficit`'s result.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._lags import first_order_lag
    >>> t = np.array([0.0, 10.0, 70.0, 600.0])  # irregular steps
    >>> T = np.array([20.0, 20.0, 21.0, 21.0])
    >>> first_order_lag(T, t, time_constants=[60.0, 600.0])
    array([[20.        , 20.        ],
           [20.        , 20.        ],
           [20.36787944, 20.04837418],
           [20.99990784, 20.60659541]])
    """
    deficit = lag_deficit(values, time, run_starts, time_constants, hold=hold, initial=initial)
    values = np.asarray(values, dtype=np.float64)
    expand = deficit.ndim - values.ndim
    return values.reshape(values.shape + (1,) * expand) - deficit


def smoothed_rate(
    values,
    time,
    run_starts=None,
    time_constant=60.0,
    *,
    seconds_per_unit=60.0,
    hold="linear",
    initial=None,
):
    """Rate of change smoothed over a time constant: the derivative of the lagged signal.

    ``d/dt lag_tau(u) = (u - lag_tau(u)) / tau``, exactly (the ODE), so the rate is the
    deficit over the time constant: no finite difference, no half-step delay, the same at any
    sample period. It replaces smoothing by a per-row factor (which means a different time
    constant at 1 s and at 60 s). Its transfer function is ``s / (1 + s tau)``: the
    derivative, smoothed by a first-order lag of time constant ``tau``. On a ramp of rate
    ``r`` it tends to ``r`` as ``r (1 - exp(-t / tau))``. The first row of a run gives 0.

    Parameters
    ----------
    values : array-like of shape (n_samples,) or (n_samples, n_columns)
        Input signal(s), finite, rows of each run contiguous and in time order.
    time : array-like of shape (n_samples,)
        Time, s, strictly increasing within each run.
    run_starts : array-like of bool of shape (n_samples,), default=None
        True at the first row of every run. None: one run.
    time_constant : float or array-like of shape (n_time_constants,), default=60.0
        Smoothing time constant(s), s, finite and > 0.
    seconds_per_unit : float, default=60.0
        Seconds in the rate's time unit (60: per minute).
    hold : {"linear", "previous", "current"}, default="linear"
        How the input is taken between samples (see :func:`lag_coefficients`).
    initial : LagState, default=None
        State to continue a run from (streaming). None: row 0 starts a run.

    Returns
    -------
    rate : ndarray of float64
        Shape of :func:`lag_deficit`'s result, in units of ``values`` per ``seconds_per_unit``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._lags import smoothed_rate
    >>> t = np.arange(0.0, 3601.0, 600.0)
    >>> T = 20.0 + t / 60.0  # 1 degC/min
    >>> smoothed_rate(T, t, time_constant=300.0)  # degC/min
    array([0.        , 0.86466472, 0.98168436, 0.99752125, 0.99966454,
           0.9999546 , 0.99999386])
    """
    if not (np.isfinite(seconds_per_unit) and seconds_per_unit > 0):
        raise ValueError(f"seconds_per_unit must be finite and > 0, got {seconds_per_unit!r}.")
    tau = _check_time_constants(time_constant, "time_constant")
    deficit = lag_deficit(values, time, run_starts, time_constant, hold=hold, initial=initial)
    return deficit / tau * seconds_per_unit


def lead_estimate(
    values,
    time,
    run_starts=None,
    sensor_lag=60.0,
    *,
    smoothing=60.0,
    hold="linear",
    initial=None,
):
    """Lead estimate of the temperature a lagging sensor follows: ``T + tau_s * dT/dt``.

    A sensor that lags the coil by a first-order lag of time constant ``tau_s`` reads
    ``T_s``, with ``T_coil = T_s + tau_s dT_s/dt`` exactly. The derivative is taken as
    :func:`smoothed_rate` over ``smoothing`` (a raw derivative would amplify the sensor's
    quantisation), so the estimate has the transfer function
    ``1 + s tau_s / (1 + s tau_r)``: exact at rest and, after a few ``tau_r``, on ramps
    (it undoes the sensor's lag ``tau_s * rate``); its high-frequency gain is bounded by
    ``1 + tau_s / tau_r``.

    Parameters
    ----------
    values : array-like of shape (n_samples,) or (n_samples, n_columns)
        Sensor temperature(s), finite, rows of each run contiguous and in time order.
    time : array-like of shape (n_samples,)
        Time, s, strictly increasing within each run.
    run_starts : array-like of bool of shape (n_samples,), default=None
        True at the first row of every run. None: one run.
    sensor_lag : float, default=60.0
        The sensor's time constant ``tau_s``, s, finite and >= 0 (0: the raw temperature).
    smoothing : float, default=60.0
        Time constant ``tau_r`` of the rate's smoothing, s, finite and > 0.
    hold : {"linear", "previous", "current"}, default="linear"
        How the input is taken between samples (see :func:`lag_coefficients`).
    initial : LagState, default=None
        State of the rate's lag (one time constant) to continue a run from. None: row 0
        starts a run.

    Returns
    -------
    lead : ndarray of float64, same shape as ``values``
        The estimated temperature ahead of the sensor.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog._lags import lead_estimate
    >>> t = np.arange(0.0, 3601.0, 10.0)
    >>> coil = 20.0 + t / 60.0  # a 1 degC/min ramp from rest
    >>> sensor = coil - 2.0 * (1 - np.exp(-t / 120.0))  # its lag by 120 s, exactly
    >>> lead = lead_estimate(sensor, t, sensor_lag=120.0, smoothing=60.0)
    >>> np.round((sensor - coil)[::60], 4)  # every 10 min
    array([ 0.    , -1.9865, -1.9999, -2.    , -2.    , -2.    , -2.    ])
    >>> np.round((lead - coil)[::60], 4)
    array([ 0.    , -0.0134, -0.0001, -0.    , -0.    , -0.    , -0.    ])
    """
    if not (np.isfinite(sensor_lag) and sensor_lag >= 0):
        raise ValueError(f"sensor_lag must be finite and >= 0 (seconds), got {sensor_lag!r}.")
    if np.ndim(smoothing) != 0:
        raise ValueError(f"smoothing must be one time constant in seconds, got {smoothing!r}.")
    _check_time_constants(smoothing, "smoothing")
    rate = smoothed_rate(
        values, time, run_starts, smoothing, seconds_per_unit=1.0, hold=hold, initial=initial
    )
    return np.asarray(values, dtype=np.float64) + sensor_lag * rate
