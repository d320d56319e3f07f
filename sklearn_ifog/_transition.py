"""Transition terms: smooth steps of an inner temperature, and their search on the calibration.

A polymer coating or potting stiffens or softens across its glass transition, so the
thermo-elastic part of the drift (a coefficient times the coil's radial gradient) changes its
gain over a few degC around a transition temperature Tg of its own. A network of isotropic
Gaussian units fitted on a few calibration runs cannot represent that oblique product; a
feature that holds it can be fitted by any model, even a linear one.

A *transition* is a smooth step ``s(u)`` of the coil's inner temperature ``u``, estimated as the
sensor's first-order lag at ``lag`` seconds (``u = T - (T - lag(T))``: the sensor minus its lag
deficit), with a centre ``c`` and a width ``w`` (degC), ``z = (u - c) / w``:

- ``"logistic"``: ``1 / (1 + exp(-z))``, written ``0.5 + 0.5 tanh(z / 2)`` (never overflows);
- ``"erf"``: the normal distribution function ``0.5 (1 + erf(z / sqrt(2)))``: a step with
  lighter tails than the logistic;
- ``"hinge"``: the softplus ``w log(1 + exp(z))`` in degC, a change of slope rather than of
  level (the static bias bending at Tg), written ``w (max(z, 0) + log1p(exp(-|z|)))``.

The transition terms are the step alone and the step times the rate ``dT`` and times each
lag excess ``T - lag_tau(T)`` (the thermal-state terms, which carry the radial gradient):
:mod:`sklearn_ifog._contract` names them ``<shape><c>C_w<w>C_lag<lag>s[_dT|_T_lag<tau>s]``.

:func:`search_transition` chooses one transition on the calibration runs only: every
candidate's terms are added to a least-squares model of the base features whose coefficients
vary smoothly with temperature, each fold of held-out runs (or contiguous blocks of one run)
predicted by the model fitted on the others. The folds are split in two halves; the candidate
chosen on one half must beat the model without it on the other half by more than one standard
error of the paired difference (the rule the network's own selection uses,
:func:`sklearn_ifog._statistics.within_one_standard_error`), both ways round: the best of
hundreds of candidates always looks better on the rows it was chosen on.
"""

from typing import NamedTuple

import numpy as np
from scipy import special

from sklearn_ifog._statistics import within_one_standard_error

__all__ = [
    "TRANSITION_SHAPES",
    "Transition",
    "search_transition",
    "step",
    "step_c_expression",
]

#: The shapes of a transition's step, by name (see the module docstring).
TRANSITION_SHAPES = ("logistic", "erf", "hinge")

_SQRT_HALF = float(np.sqrt(0.5))


def _check_shape(shape):
    if shape not in TRANSITION_SHAPES:
        raise ValueError(
            f"Unknown transition shape {shape!r}; expected one of {list(TRANSITION_SHAPES)}."
        )


def step(shape, inner, centre, width):
    """The step ``s(u)`` of a transition, vectorised.

    Parameters
    ----------
    shape : {"logistic", "erf", "hinge"}
        The step's shape (see the module docstring).
    inner : array-like
        The inner temperature ``u``, degC.
    centre : float
        The transition temperature ``c``, degC.
    width : float
        The width ``w``, degC, > 0.

    Returns
    -------
    values : ndarray of float64, shape of ``inner``
        0 to 1 for the steps (``0.5`` at the centre), degC for the hinge.

    Examples
    --------
    >>> from sklearn_ifog._transition import step
    >>> step("logistic", [10.0, 20.0, 30.0], 20.0, 2.0).round(4)
    array([0.0067, 0.5   , 0.9933])
    >>> step("erf", [18.0, 20.0], 20.0, 2.0).round(4)
    array([0.1587, 0.5   ])
    >>> step("hinge", [0.0, 40.0], 20.0, 2.0).round(3)
    array([ 0., 20.])
    """
    _check_shape(shape)
    z = (np.asarray(inner, dtype=np.float64) - centre) / width
    if shape == "logistic":
        return 0.5 + 0.5 * np.tanh(0.5 * z)
    if shape == "erf":
        return 0.5 + 0.5 * special.erf(_SQRT_HALF * z)
    return width * (np.maximum(z, 0.0) + np.log1p(np.exp(-np.abs(z))))


def _literal(value):
    return f"({float(value)!r})"


def step_c_expression(shape, inner, centre, width):
    """The step of :func:`step` as a C99 expression (valid Python with ``math``'s names too).

    Parameters
    ----------
    shape : {"logistic", "erf", "hinge"}
        The step's shape.
    inner : str
        The C expression of the inner temperature.
    centre, width : float
        The centre and width, degC.

    Returns
    -------
    expression : str
        The same operations as :func:`step`, in the same order (the exports equal it to
        rounding), from ``tanh``, ``erf``, ``fmax``, ``fabs``, ``log1p`` and ``exp``.

    Examples
    --------
    >>> from sklearn_ifog._transition import step_c_expression
    >>> step_c_expression("logistic", "u", 20.0, 2.0)
    '(0.5 + 0.5 * tanh(0.5 * (((u) - (20.0)) / (2.0))))'
    """
    _check_shape(shape)
    z = f"(({inner}) - {_literal(centre)}) / {_literal(width)}"
    if shape == "logistic":
        return f"(0.5 + 0.5 * tanh(0.5 * ({z})))"
    if shape == "erf":
        return f"(0.5 + 0.5 * erf({_SQRT_HALF!r} * ({z})))"
    return f"({_literal(width)} * (fmax({z}, 0.0) + log1p(exp(-fabs({z})))))"


class Transition(NamedTuple):
    """A transition found by :func:`search_transition` (``ThermalFeatures.transition_``)."""

    shape: str
    """The step's shape."""
    centre: float
    """Its centre, degC of the inner temperature."""
    width: float
    """Its width, degC."""
    lag: float
    """The time constant (s) of the lag that estimates the inner temperature."""
    terms: tuple
    """The term names added to the features."""
    held_out_gain: float
    """``1 - (held-out MSE with the terms) / (held-out MSE without)`` of the search's linear
    model, over the calibration's held-out folds."""
    standard_error: float
    """One standard error of that gain (the paired difference's, over chunks of rows)."""
    n_candidates: int
    """How many (shape, centre, width, lag) candidates were compared."""


#: The search's grid, ``ThermalFeatures(transition="auto")``: every shape, these widths
#: (degC) and lags (s), the centres first every ``COARSE_STEP`` degC over the calibrated inner
#: temperatures with the first shape, width and lag, then every ``FINE_STEP`` degC within
#: ``FINE_SPAN`` of the best of them with every shape, width and lag.
DEFAULT_SEARCH = {
    "shapes": TRANSITION_SHAPES,
    "centres": None,
    "widths": (1.5, 3.0, 6.0),
    "lags": (300.0, 900.0, 1800.0),
}
COARSE_STEP = 1.0
FINE_STEP = 0.5
FINE_SPAN = 3.0
#: Inner temperatures below the ``EDGE`` quantile or above ``1 - EDGE`` of the calibration's
#: are not centres: a step there has too few rows on one side to be confirmed.
EDGE = 0.02
#: The search reads at most this many rows (every k-th row of each run): its linear model's
#: held-out error is resolved long before, and the search stays a fraction of the fit.
MAX_SEARCH_ROWS = 6000
#: Relative ridge of the search's least squares (its columns are standardised).
_RIDGE = 1e-8


def multiplier_names(base_lags, has_rate=True):
    """The suffixes of one transition's terms: the step alone, times dT, times each lag."""
    suffixes = [""]
    if has_rate:
        suffixes.append("_dT")
    suffixes += [f"_T_lag{_number(tau)}s" for tau in base_lags]
    return suffixes


def _number(value):
    """A number as the feature contract writes it in a term's name."""
    # Imported here: the contract imports this module for its transition family.
    from sklearn_ifog._contract import format_seconds

    return format_seconds(value)


def transition_name(shape, centre, width, lag):
    """The name of a transition's step term (its products append a suffix).

    Examples
    --------
    >>> from sklearn_ifog._transition import transition_name
    >>> transition_name("erf", -2.5, 3.0, 900.0)
    'erf-2.5C_w3C_lag900s'
    """
    return f"{shape}{_number(centre)}C_w{_number(width)}C_lag{_number(lag)}s"


def _standardise(columns):
    centre = columns.mean(axis=0)
    scale = columns.std(axis=0)
    scale = np.where(scale > 1e-12 * (1.0 + np.abs(centre)), scale, np.inf)
    return (columns - centre) / scale


class _FoldSolver:
    """Held-out predictions of least squares on ``[base, extra]`` for every fold at once.

    The base design's per-fold Gram matrices are computed once; a candidate adds its
    columns' cross products, so each candidate costs a few passes over its own columns.
    """

    def __init__(self, base, Y, folds):
        order = np.argsort(folds, kind="stable")
        self.order = order
        folds = folds[order]
        self.starts = np.flatnonzero(np.r_[True, folds[1:] != folds[:-1]])
        self.ends = np.r_[self.starts[1:], folds.size]
        self.spans = list(zip(self.starts.tolist(), self.ends.tolist(), strict=True))
        B = np.column_stack([np.ones(folds.size), _standardise(base[order])])
        B = B[:, np.isfinite(B).all(axis=0) & (np.abs(B).sum(axis=0) > 0)]
        self.B = B
        self.Y = Y[order]
        self.BB = np.stack([B[s:e].T @ B[s:e] for s, e in self.spans])
        self.BY = np.stack([B[s:e].T @ self.Y[s:e] for s, e in self.spans])

    def losses(self, extra=None):
        """Squared held-out error of every row (in fold order), summed over the outputs."""
        B, Y = self.B, self.Y
        if extra is None:
            A, AA, AY = B, self.BB, self.BY
        else:
            E = _standardise(extra[self.order])
            E = E[:, np.isfinite(E).all(axis=0)]
            A = np.hstack([B, E])
            p = B.shape[1]
            q = A.shape[1]
            AA = np.empty((self.BB.shape[0], q, q))
            AY = np.empty((self.BB.shape[0], q, Y.shape[1]))
            AA[:, :p, :p] = self.BB
            AY[:, :p] = self.BY
            for k, (s, e) in enumerate(self.spans):
                cross = E[s:e].T @ A[s:e]
                AA[k, p:, :] = cross
                AA[k, :p, p:] = cross[:, :p].T
                AY[k, p:] = E[s:e].T @ Y[s:e]
        total_AA, total_AY = AA.sum(axis=0), AY.sum(axis=0)
        train_AA = total_AA[None] - AA
        ridge = _RIDGE * np.trace(total_AA) / total_AA.shape[0]
        train_AA = train_AA + ridge * np.eye(A.shape[1])[None]
        weights = np.linalg.solve(train_AA, total_AY[None] - AY)
        losses = np.empty(Y.shape[0])
        for k, (s, e) in enumerate(self.spans):
            losses[s:e] = np.sum((Y[s:e] - A[s:e] @ weights[k]) ** 2, axis=1)
        return losses


#: Fewer calibration rows than this: no search (nothing can be held out and confirmed).
MIN_SEARCH_ROWS = 200


def search_rows(runs, n_samples):
    """Every k-th row of each run (in the given order), at most :data:`MAX_SEARCH_ROWS`.

    Examples
    --------
    >>> from sklearn_ifog._transition import search_rows
    >>> search_rows(None, 5).tolist()
    [0, 1, 2, 3, 4]
    """
    stride = max(1, int(np.ceil(n_samples / MAX_SEARCH_ROWS)))
    if stride == 1:
        return np.arange(n_samples)
    labels = np.zeros(n_samples, dtype=np.intp) if runs is None else np.asarray(runs)
    order = np.argsort(labels, kind="stable")
    counts = np.bincount(labels)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rank = np.empty(n_samples, dtype=np.intp)
    rank[order] = np.arange(n_samples) - starts[labels[order]]
    return np.flatnonzero(rank % stride == 0)


_SEARCH_KEYS = ("shapes", "centres", "widths", "lags")


def check_search(search):
    """A ``transition`` dict of ThermalFeatures, completed with :data:`DEFAULT_SEARCH`.

    Raises
    ------
    ValueError
        On an unknown key, an unknown shape, a width or lag <= 0, or a centre range that is
        not ``(low, high)`` with ``low < high``; each names the entry.

    Examples
    --------
    >>> from sklearn_ifog._transition import check_search
    >>> check_search({"widths": (2.0,)})["widths"]
    (2.0,)
    """
    unknown = sorted(set(search) - set(_SEARCH_KEYS))
    if unknown:
        raise ValueError(
            f"transition has unknown key(s) {unknown}; expected some of {list(_SEARCH_KEYS)}."
        )
    grid = {**DEFAULT_SEARCH, **search}
    shapes = tuple(grid["shapes"]) if not isinstance(grid["shapes"], str) else (grid["shapes"],)
    bad = [shape for shape in shapes if shape not in TRANSITION_SHAPES]
    if bad or not shapes:
        raise ValueError(
            f"transition['shapes'] has unknown shape(s) {bad or shapes!r}; expected some of "
            f"{list(TRANSITION_SHAPES)}."
        )
    for key, unit in (("widths", "degC"), ("lags", "seconds")):
        values = np.atleast_1d(np.asarray(grid[key], dtype=np.float64))
        if values.size == 0 or not np.all(np.isfinite(values) & (values > 0)):
            raise ValueError(
                f"transition[{key!r}] must be numbers > 0 ({unit}); got {grid[key]!r}."
            )
        grid[key] = tuple(float(value) for value in values)
    centres = grid["centres"]
    if centres is not None:
        values = np.asarray(centres, dtype=np.float64)
        if values.shape != (2,) or not np.all(np.isfinite(values)) or values[0] >= values[1]:
            raise ValueError(
                f"transition['centres'] must be a range (low, high) in degC with low < high; "
                f"got {centres!r}."
            )
        grid["centres"] = (float(values[0]), float(values[1]))
    grid["shapes"] = shapes
    return grid


#: Spacing (degC) of the knots of the base's smooth coefficients (hat functions of T): a
#: step must beat each term's coefficient varying smoothly with temperature at this scale.
#: Chosen while developing the search on the tuning gyros (by runs not committed: with the
#: drift alone as target it placed the centre nearer the simulated Tg than a base of the
#: features' squares and products did; bench_transition.py measures the result).
KNOT_SPACING = 8.0


def _smooth_coefficients(base, temperature, multipliers):
    """The standardised base features, and each multiplier (1, dT, the lag excesses) times
    piecewise-linear hat functions of the temperature, knots every :data:`KNOT_SPACING`
    degC: a model whose coefficients vary smoothly with T, so that a broad bend of the
    drift is not taken for a transition."""
    base = _standardise(base)
    base = base[:, np.isfinite(base).all(axis=0)]
    knots = np.arange(temperature.min(), temperature.max() + KNOT_SPACING, KNOT_SPACING)
    hats = np.maximum(0.0, 1.0 - np.abs(temperature[:, None] - knots[None]) / KNOT_SPACING)
    columns = [hats if m is None else hats * m[:, None] for m in multipliers]
    return np.hstack([base, *columns])


def search_transition(
    base,
    Y,
    temperature,
    rate,
    deficit_of,
    folds,
    *,
    base_lags=(),
    shapes=TRANSITION_SHAPES,
    centres=None,
    widths=DEFAULT_SEARCH["widths"],
    lags=DEFAULT_SEARCH["lags"],
):
    """Choose one transition on held-out calibration folds, and whether it earns its terms.

    Parameters
    ----------
    base : ndarray of shape (n_samples, n_features)
        The features without a transition (ThermalFeatures' other terms); the model adds
        each multiplier times hat functions of ``temperature`` (smooth coefficients).
    Y : ndarray of shape (n_samples, n_outputs)
        The drift target(s); several outputs are each scaled to unit variance.
    temperature : ndarray of shape (n_samples,)
        The (first) sensor's raw temperature, degC.
    rate : ndarray of shape (n_samples,) or None
        Its rate ``dT`` (the ``_dT`` products), or None without one.
    deficit_of : callable
        ``deficit_of(tau)``: the deficit ``T - lag_tau(T)`` of the sensor at ``tau`` seconds,
        shape (n_samples,), for every lag of ``lags`` and of ``base_lags``.
    folds : ndarray of int of shape (n_samples,)
        The held-out fold of every row (whole runs, or contiguous blocks of one run).
    base_lags : sequence of float, default=()
        The lag excesses the step multiplies (the base features' lag terms).
    shapes, centres, widths, lags
        The grid: shapes, a centre range ``(low, high)`` in degC (None: the calibrated inner
        temperatures between their 2nd and 98th percentiles), widths in degC and lags in s.

    Returns
    -------
    transition : Transition
        The best candidate; its ``terms`` are empty unless the candidates chosen on each
        half of the folds beat the base features on the other half by more than one
        standard error. None when the centre range holds no grid point.
    """
    Y = np.asarray(Y, dtype=np.float64).reshape(base.shape[0], -1)
    spread = Y.std(axis=0)
    Y = (Y - Y.mean(axis=0)) / np.where(spread > 0, spread, 1.0)
    multipliers = [None]
    if rate is not None:
        multipliers.append(np.asarray(rate, dtype=np.float64))
    multipliers += [deficit_of(tau) for tau in base_lags]
    base = _smooth_coefficients(np.asarray(base, dtype=np.float64), temperature, multipliers)
    solver = _FoldSolver(base, Y, folds)
    base_losses = solver.losses()
    base_mean = float(base_losses.mean())
    inner_of = {float(lag): temperature - deficit_of(lag) for lag in lags}

    def candidate_losses(shape, centre, width, lag):
        values = step(shape, inner_of[lag], centre, width)
        extra = np.column_stack([values if m is None else values * m for m in multipliers])
        return solver.losses(extra)

    low, high = (-np.inf, np.inf) if centres is None else map(float, centres)

    def centre_grid(lag, start, stop, spacing):
        # Never beyond the given centre range (the fine grid around a coarse centre near
        # its edge would otherwise reach past it), nor the calibrated inner temperatures.
        start, stop = max(start, low), min(stop, high)
        if centres is None:
            inner = inner_of[lag]
            start = max(start, float(np.quantile(inner, EDGE)))
            stop = min(stop, float(np.quantile(inner, 1.0 - EDGE)))
        if stop < start:
            return np.empty(0)
        first = np.ceil(start / spacing) * spacing
        return np.arange(first, stop + 1e-9, spacing)

    lags = [float(lag) for lag in lags]
    row_losses = {}

    def losses_of(key):
        if key not in row_losses:
            row_losses[key] = candidate_losses(*key)
        return row_losses[key]

    lag0, width0, shape0 = lags[len(lags) // 2], sorted(widths)[len(widths) // 2], shapes[0]
    coarse = centre_grid(lag0, -np.inf, np.inf, COARSE_STEP)
    if coarse.size == 0:
        return None

    def best_on(rows):
        """The grid's best candidate judged on ``rows`` only (coarse, then fine)."""

        def score(shape, centre, width, lag):
            return float(
                losses_of((shape, round(float(centre), 6), float(width), lag))[rows].mean()
            )

        best_centre = min(coarse, key=lambda c: score(shape0, c, width0, lag0))
        candidates = [(shape0, round(float(c), 6), float(width0), lag0) for c in coarse]
        for lag in lags:
            fine = centre_grid(lag, best_centre - FINE_SPAN, best_centre + FINE_SPAN, FINE_STEP)
            candidates += [
                (shape, round(float(c), 6), float(width), lag)
                for shape in shapes
                for width in widths
                for c in fine
            ]
        return min(candidates, key=lambda key: score(*key))

    # The selection's own noise: a transition chosen on one half of the held-out folds must
    # beat the features without it on the other half by more than one standard error, both
    # ways round (the best of hundreds of candidates always looks better on the rows it was
    # chosen on).
    fold_of_row = np.asarray(folds)[solver.order]
    labels = np.unique(fold_of_row)
    first_half = np.isin(fold_of_row, labels[::2])
    confirmed = []
    for chosen_on in (first_half, ~first_half):
        key = best_on(chosen_on)
        judged = ~chosen_on
        pair = np.vstack([losses_of(key)[judged], base_losses[judged]])
        confirmed.append((key, not bool(within_one_standard_error(pair)[1])))
    every = np.ones(fold_of_row.size, dtype=bool)
    best = min((key for key, _ in confirmed), key=lambda key: losses_of(key)[every].mean())
    kept = all(ok for _, ok in confirmed)
    best_losses = losses_of(best)
    difference = base_losses - best_losses
    n_chunks = 20
    bounds = np.linspace(0, difference.size, n_chunks + 1).astype(int)
    chunk_means = np.add.reduceat(difference, bounds[:-1]) / np.diff(bounds)
    standard_error = float(chunk_means.std(ddof=1) / np.sqrt(n_chunks)) / base_mean
    shape, centre, width, lag = best
    name = transition_name(shape, centre, width, lag)
    suffixes = multiplier_names(base_lags, has_rate=rate is not None)
    return Transition(
        shape=shape,
        centre=float(centre),
        width=float(width),
        lag=float(lag),
        terms=tuple(name + suffix for suffix in suffixes) if kept else (),
        held_out_gain=1.0 - float(best_losses.mean()) / base_mean,
        standard_error=standard_error,
        n_candidates=len(row_losses),
    )
