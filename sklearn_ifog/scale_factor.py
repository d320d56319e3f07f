"""Scale factor over temperature: the drift a gyro multiplies, learnt beside the one it adds.

On a rate table the gyro output is ``rate = Ω (1 + s(x)) + b(x) + noise``: the bias ``b``
(what a static campaign sees) and the scale-factor error ``s`` (dimensionless, reported in
ppm), both functions of the same thermal features ``x``. The drift target ``y = rate - Ω``
is then ``b(x) + Ω s(x)``, linear in the weights of any model with a linear output layer
``b(x) = Φ(x) w_b``, ``s(x) = Φ(x) w_s``: the *product basis* ``[Φ(x), Ω Φ(x)]``, solved by
one weighted least-squares fit (:func:`fit_product_layer`).

The fitted regressor predicts two outputs, ``[b(x), s(x)]``; the drift at an input rate is
:func:`drift_of` and the input rate a gyro output stands for is :func:`input_rate_estimate`,
``Ω̂ = (rate - b(x)) / (1 + s(x))``. :class:`~sklearn_ifog.CompensationPipeline` with
``input_rate`` calls these; they are plain functions so that streaming and the exports
compute the same numbers.

The rows' noise grows with the input rate (what a thermal model of ``s`` leaves, times
``Ω``), so the fit weighs every row by ``1 / (σ₀² + κ² Ω²)``, with ``σ₀`` (deg/h) and ``κ``
learnt from the residuals (:func:`rate_noise`): the bias is learnt where it is seen best (at
low input rates), the scale factor where it is (at high ones).
"""

from typing import NamedTuple

import numpy as np
from scipy.linalg import lstsq
from scipy.optimize import nnls

from sklearn_ifog import _table
from sklearn_ifog._output_layer import read_layer
from sklearn_ifog._tuning import INPUT_RATE_SLACK

__all__ = [
    "INPUT_RATE_UNIT",
    "MAX_SCALE_FACTOR_ERROR",
    "MIN_OBSERVABLE_RATE",
    "PreliminaryFit",
    "ProductFit",
    "RateNoise",
    "beyond_input_rates",
    "check_input_rate",
    "drift_of",
    "fit_product_layer",
    "input_rate_estimate",
    "input_rate_of",
    "layer_penalty",
    "preliminary_fit",
    "proxy_targets",
    "rate_noise",
    "with_input_rate",
]

#: The unit the input rate must be given in: the gyro output's (deg/h).
INPUT_RATE_UNIT = "deg/h"
#: Below this largest input rate (1 deg/s, in deg/h) a scale factor is not observable: at
#: 100 ppm it would move the output by at most 0.36 deg/h, within a navigation gyro's bias
#: variation over a thermal test.
MIN_OBSERVABLE_RATE = 3600.0
#: A gyro's scale factor is within a few hundred ppm of its nominal; an apparent error
#: beyond 5 % means the input rate is not in the output's unit (rad/s or deg/s read as
#: deg/h differ by factors of 206,265 and 3,600).
MAX_SCALE_FACTOR_ERROR = 0.05
# Reweighted solves at most (each re-learns the rate noise; they settle in 3-8).
_PRELIMINARY_ITERATIONS = 10
_LAYER_ITERATIONS = 10


class RateNoise(NamedTuple):
    """The rows' noise model: variance ``sigma0**2 + (kappa * input_rate)**2``.

    Parameters
    ----------
    sigma0 : float
        The noise at zero input rate, deg/h (the bias noise).
    kappa : float
        How the noise grows with the input rate (dimensionless: deg/h per deg/h), what a
        thermal model of the scale factor leaves of it.

    Examples
    --------
    >>> noise = RateNoise(sigma0=0.01, kappa=1e-6)  # at 1e4 deg/h the variance doubles
    >>> noise.weights([0.0, 1e4]).round(3).tolist()
    [1.333, 0.667]
    """

    sigma0: float
    kappa: float

    def weights(self, omega):
        """Row weights ``1 / variance``, scaled to mean 1.

        Parameters
        ----------
        omega : array-like of shape (n_samples,)
            The rows' input rates, deg/h.

        Returns
        -------
        weights : ndarray of shape (n_samples,)

        Examples
        --------
        >>> RateNoise(sigma0=1.0, kappa=1e-3).weights([0.0, 1e3]).tolist()
        [1.3333333333333333, 0.6666666666666666]
        """
        variance = self.sigma0**2 + (self.kappa * np.asarray(omega, dtype=np.float64)) ** 2
        weights = 1.0 / variance
        return weights / weights.mean()


def _weighted_solve(D, y, weights, penalty=None):
    """Weighted (ridge) least squares: ``argmin Σ w_i (y_i - D_i θ)² + Σ_j p_j θ_j²``."""
    root = np.sqrt(weights)[:, None]
    A, b = D * root, y * root[:, 0]
    if penalty is not None and np.any(penalty > 0):
        rows = np.flatnonzero(penalty > 0)
        extra = np.zeros((rows.size, D.shape[1]))
        extra[np.arange(rows.size), rows] = np.sqrt(penalty[rows])
        A, b = np.vstack([A, extra]), np.concatenate([b, np.zeros(rows.size)])
    return lstsq(A, b, lapack_driver="gelsd")[0]


def _omega_scale(omega):
    """The input rates' root mean square (1 when all are 0), to keep the design balanced."""
    scale = float(np.sqrt(np.mean(np.square(omega))))
    return scale if scale > 0 else 1.0


class ProductFit(NamedTuple):
    """A fitted output layer of ``b(x) + Ω s(x) + a |Ω|`` (:func:`fit_product_layer`).

    Parameters
    ----------
    weights : ndarray of shape (n_columns, 2)
        ``b``'s weights, then ``s``'s (dimensionless), in
        :func:`~sklearn_ifog._output_layer.layer_weights`' order.
    asymmetry : float
        The constant ``a`` (dimensionless).
    noise : RateNoise
        The noise model of its residuals.

    Examples
    --------
    >>> import numpy as np
    >>> ProductFit(np.zeros((3, 2)), 1e-5, RateNoise(0.01, 0.0)).asymmetry
    1e-05
    """

    weights: np.ndarray
    asymmetry: float
    noise: "RateNoise"


class PreliminaryFit(NamedTuple):
    """:func:`preliminary_fit`'s result.

    Parameters
    ----------
    bias : ndarray of shape (n_samples,)
        ``b0`` at every row, deg/h.
    scale_factor : ndarray of shape (n_samples,)
        ``s0`` at every row (dimensionless).
    asymmetry : float
        The constant ``a`` (dimensionless).
    noise : RateNoise
        The noise model of its residuals.

    Examples
    --------
    >>> import numpy as np
    >>> PreliminaryFit(np.zeros(2), np.full(2, 1e-4), 0.0, RateNoise(0.01, 0.0)).bias.shape
    (2,)
    """

    bias: np.ndarray
    scale_factor: np.ndarray
    asymmetry: float
    noise: "RateNoise"


def _product_design(Phi, omega):
    """``[Φ, Ω Φ, |Ω|]`` with Ω divided by its root mean square, and that scale."""
    scale = _omega_scale(omega)
    unit = omega / scale
    return np.hstack([Phi, Phi * unit[:, None], np.abs(unit)[:, None]]), scale


def _product_solve(Phi, y, omega, noise, penalty=None):
    """One weighted solve of the product basis: (W (n_columns, 2), asymmetry)."""
    D, scale = _product_design(Phi, omega)
    weights = np.ones(y.size) if noise is None else noise.weights(omega)
    full_penalty = None
    if penalty is not None:
        # Each column's penalty in proportion to what the weighted rows say of it (the
        # diagonal of Dᵀ W D): with equal weights and a unit-variance column that is α n,
        # the network's own α; a scale-factor column, whose rows of high input rate weigh
        # little, is then not shrunk by a penalty the bias columns' rows set.
        information = np.einsum("ij,ij,i->j", D, D, weights)
        full_penalty = np.concatenate([np.tile(penalty, 2), [0.0]]) * information
    theta = _weighted_solve(D, y, weights, full_penalty)
    width = Phi.shape[1]
    W = np.column_stack([theta[:width], theta[width : 2 * width] / scale])
    return W, float(theta[-1] / scale)


def _iterate(Phi, y, omega, penalty, n_iter):
    """Reweighted solves: each learns the rows' noise from the last one's residuals.

    The first is unweighted; the rate noise then decides how much each row says of the
    bias and of the scale factor. Stops when ``σ₀`` and ``κ`` change by less than 1 %.
    """
    noise = None
    for _ in range(n_iter):
        W, asymmetry = _product_solve(Phi, y, omega, noise, penalty)
        residual = y - drift_of(Phi @ W, omega, asymmetry)
        new = rate_noise(residual, omega)
        settled = noise is not None and np.allclose(new, noise, rtol=0.01, atol=0.0)
        noise = new
        if settled:
            break
    return W, asymmetry, noise


def preliminary_fit(features, y, omega):
    """A first bias, scale factor and asymmetry, linear in the features.

    Parameters
    ----------
    features : ndarray of shape (n_samples, n_features)
        The thermal features (standardised).
    y : ndarray of shape (n_samples,)
        The drift target ``rate - input_rate``, deg/h.
    omega : ndarray of shape (n_samples,)
        The input rate, deg/h.

    Returns
    -------
    fit : PreliminaryFit
        ``bias`` ``b0`` (deg/h) and ``scale_factor`` ``s0`` (dimensionless) at every row,
        the ``asymmetry`` and the rows' ``noise``, after reweighted solves
        (:func:`rate_noise`).

    Examples
    --------
    >>> import numpy as np
    >>> T = np.linspace(-1, 1, 40)[:, None]
    >>> omega = np.tile([0.0, 1e5, -1e5, 3e5], 10)
    >>> y = 0.5 * T[:, 0] + omega * 1e-4 * (1 + T[:, 0]) + 2e-5 * np.abs(omega)
    >>> fit = preliminary_fit(T, y, omega)
    >>> bool(
    ...     np.allclose(fit.bias, 0.5 * T[:, 0])
    ...     and np.allclose(fit.scale_factor, 1e-4 * (1 + T[:, 0]))
    ... )
    True
    >>> round(fit.asymmetry * 1e6, 6)
    20.0
    """
    Phi = np.hstack([features, np.ones((features.shape[0], 1))])
    W, asymmetry, noise = _iterate(Phi, y, omega, None, _PRELIMINARY_ITERATIONS)
    return PreliminaryFit(Phi @ W[:, 0], Phi @ W[:, 1], asymmetry, noise)


def _rate_levels(magnitude):
    """Group label of every row by its input-rate magnitude: the distinct magnitudes of a
    rate table's steps (to a part in a million of the largest), else 20 quantile bins."""
    rounded = np.round(magnitude / max(float(magnitude.max()), 1e-300) * 1e6)
    levels, labels = np.unique(rounded, return_inverse=True)
    if levels.size <= 50:
        return labels.ravel()
    edges = np.quantile(magnitude, np.linspace(0.0, 1.0, 21)[1:-1])
    return np.searchsorted(edges, magnitude, side="right")


def rate_noise(residual, omega):
    """The noise model of residuals that grow with the input rate (:class:`RateNoise`).

    The residuals' mean square at each input-rate magnitude (each step of a rate table, or
    20 quantile bins of a continuous input) is fitted by ``σ₀² + κ² Ω²`` with non-negative
    coefficients, every level counted in proportion to its own size (a relative fit), so
    the large residuals of the fastest rates do not decide ``σ₀``. ``σ₀`` is floored at a
    millionth of the residuals' root mean square, so no row weighs infinitely.

    Parameters
    ----------
    residual : ndarray of shape (n_samples,)
        Residuals of a fit, deg/h.
    omega : ndarray of shape (n_samples,)
        The input rate, deg/h.

    Returns
    -------
    noise : RateNoise

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> omega = np.repeat([0.0, 1e4, 1e5, -1e5], 20000)
    >>> residual = rng.normal(0.0, np.sqrt(0.01**2 + (1e-6 * omega) ** 2))
    >>> noise = rate_noise(residual, omega)
    >>> round(noise.sigma0, 3), round(noise.kappa * 1e6, 2)
    (0.01, 1.0)
    """
    square = np.square(residual)
    magnitude = np.abs(omega)
    labels = _rate_levels(magnitude)
    counts = np.bincount(labels)
    kept = counts > 0
    level_square = (np.bincount(labels, weights=square)[kept]) / counts[kept]
    level_rate = np.sqrt(np.bincount(labels, weights=magnitude**2)[kept] / counts[kept])
    scale = _omega_scale(omega)
    rms = float(np.sqrt(square.mean())) if square.any() else 1.0
    size = np.maximum(level_square, (1e-6 * rms) ** 2)
    design = np.column_stack([np.ones_like(level_rate), (level_rate / scale) ** 2]) / size[:, None]
    coef = nnls(design, np.ones_like(size))[0]
    return RateNoise(
        sigma0=max(float(np.sqrt(coef[0])), 1e-6 * rms), kappa=float(np.sqrt(coef[1]) / scale)
    )


def check_input_rate(omega, y, column):
    """Refuse an input rate in another unit than the output's, or too small to observe.

    The unit is never guessed: the drift target ``y = rate - Ω`` of a gyro moves with the
    input rate by its scale-factor error, a few hundred ppm; an input rate in rad/s or
    deg/s read as deg/h makes it move by a factor of 206,265 or 3,600 instead.

    Parameters
    ----------
    omega : ndarray of shape (n_samples,)
        The input rate, deg/h.
    y : ndarray of shape (n_samples,)
        The drift target ``rate - input_rate``, deg/h.
    column : str or int
        The input rate's column, for messages.

    Raises
    ------
    ValueError
        If ``y``'s least-squares slope on the input rate exceeds
        :data:`MAX_SCALE_FACTOR_ERROR` (the input rate is not in deg/h), or no input rate
        reaches :data:`MIN_OBSERVABLE_RATE`.

    Examples
    --------
    >>> import numpy as np
    >>> check_input_rate(np.array([0.0, 3600.0]), np.array([0.1, 0.46]), "reference")
    >>> omega = np.array([0.0, 5.0])
    >>> check_input_rate(omega, omega * 206264.8 - omega, "reference")
    Traceback (most recent call last):
    ...
    ValueError: The gyro output differs from input_rate column 'reference' by a factor of ...
    """
    largest = float(np.max(np.abs(omega)))
    spread = float(np.var(omega))
    if spread <= (1e-9 * largest) ** 2:  # one input rate, to round-off
        spread = 0.0
    if spread > 0:
        slope = float(np.mean((omega - omega.mean()) * (y - y.mean())) / spread)
        if abs(slope) > MAX_SCALE_FACTOR_ERROR:
            raise ValueError(
                f"The gyro output differs from input_rate column {column!r} by a factor of "
                f"about {1 + slope:.6g}: a scale-factor error of {slope:.3g}, where a gyro's "
                f"is within {MAX_SCALE_FACTOR_ERROR:.0%}. The input rate must be in the "
                f"output's unit, {INPUT_RATE_UNIT} (rad/s reads 206,265 times smaller, deg/s "
                "3,600 times)."
            )
    if largest < MIN_OBSERVABLE_RATE or spread == 0:
        raise ValueError(
            f"input_rate column {column!r} reaches only {largest:.4g} {INPUT_RATE_UNIT}"
            f"{' and never changes' if spread == 0 else ''}: a scale factor is not observable "
            f"below {MIN_OBSERVABLE_RATE:.0f} {INPUT_RATE_UNIT} (1 deg/s) or at one input "
            "rate. Calibrate on a rate table, or pass input_rate=None to fit the bias alone."
        )


def proxy_targets(y, omega, first):
    """Two per-row targets, ``[bias, scale factor]``, for choosing a model's basis.

    Where the input rate is low (its noise ``κ|Ω|`` within ``σ₀``) the row shows the bias,
    ``y - Ω s0 - a|Ω|``, and the scale factor is the first estimate ``s0``; where it is high
    the row shows the scale factor, ``(y - b0 - a|Ω|) / Ω``, and the bias is ``b0``. A
    regressor fitted on these two outputs places its units where either varies; the weights
    are then solved on the product basis (:func:`fit_product_layer`).

    Parameters
    ----------
    y, omega : ndarray of shape (n_samples,)
        The drift target and the input rate, deg/h.
    first : PreliminaryFit
        :func:`preliminary_fit`'s result.

    Returns
    -------
    Y : ndarray of shape (n_samples, 2)

    Examples
    --------
    >>> import numpy as np
    >>> omega = np.array([0.0, 1e6])
    >>> first = PreliminaryFit(np.zeros(2), np.full(2, 1e-4), 0.0, RateNoise(0.01, 1e-7))
    >>> proxy_targets(np.array([0.5, 110.0]), omega, first).tolist()
    [[0.5, 0.0001], [0.0, 0.00011]]
    """
    noise = first.noise
    low = np.abs(noise.kappa * omega) <= noise.sigma0
    shown = y - first.asymmetry * np.abs(omega)
    ratio = np.divide(shown - first.bias, omega, out=np.zeros_like(y), where=~low)
    return np.column_stack(
        [
            np.where(low, shown - omega * first.scale_factor, first.bias),
            np.where(low, first.scale_factor, ratio),
        ]
    )


def fit_product_layer(Phi, y, omega, penalty=None):
    """Solve the output layer of ``y = Φ w_b + Ω Φ w_s + a |Ω|`` by weighted least squares.

    The rows are weighed by their rate noise ``1 / (σ₀² + κ² Ω²)``, learnt from the
    residuals of the previous solve (reweighted until it settles, at most 10 solves): the
    bias is learnt where it is seen best, at low input rates, and the scale factor at high
    ones. ``a`` is a constant asymmetry between positive and negative input rates, which no
    ``b + Ω s`` holds and which would otherwise leak into the bias.

    Parameters
    ----------
    Phi : ndarray of shape (n_samples, n_columns)
        The output layer's design (:func:`sklearn_ifog._output_layer.layer_design`).
    y : ndarray of shape (n_samples,)
        The drift target, deg/h.
    omega : ndarray of shape (n_samples,)
        The input rate, deg/h.
    penalty : ndarray of shape (n_columns,), default=None
        Relative ridge penalty per column of ``Φ``, for both blocks: column ``j`` of the
        design is penalised by ``penalty[j]`` times its weighted sum of squares (with equal
        weights and a standardised column, ``α n``: the network's ``alpha`` convention);
        None: none.

    Returns
    -------
    fit : ProductFit
        The ``weights`` (n_columns, 2), the ``asymmetry`` and the rows' ``noise``.

    Examples
    --------
    >>> import numpy as np
    >>> T = np.linspace(-1, 1, 30)
    >>> Phi = np.column_stack([T, np.ones(30)])
    >>> omega = np.tile([0.0, 2e5, -2e5], 10)
    >>> y = 0.3 * T + omega * (2e-4 * T + 1e-4)
    >>> fit = fit_product_layer(Phi, y, omega)
    >>> W = fit.weights
    >>> np.round(W[:, 0], 8).tolist(), np.round(W[:, 1] * 1e6, 4).tolist()
    ([0.3, 0.0], [200.0, 100.0])
    """
    if penalty is not None:
        penalty = np.asarray(penalty, dtype=np.float64)
    W, asymmetry, noise = _iterate(Phi, y, omega, penalty, _LAYER_ITERATIONS)
    return ProductFit(W, asymmetry, noise)


def drift_of(prediction, omega, asymmetry=0.0):
    """The drift at the input rate ``omega``: ``b + Ω s + a |Ω|`` from a ``[b, s]`` prediction.

    Parameters
    ----------
    prediction : array-like of shape (n_samples, 2)
        The bias ``b`` (deg/h) and the scale-factor error ``s`` of every row.
    omega : array-like of shape (n_samples,)
        The input rates, deg/h.
    asymmetry : float, default=0.0
        The constant asymmetry ``a``.

    Returns
    -------
    drift : ndarray of shape (n_samples,)
        deg/h.

    Examples
    --------
    >>> import numpy as np
    >>> drift_of(np.array([[0.5, 1e-4]]), np.array([3.6e5])).round(6).tolist()
    [36.5]
    >>> drift_of(np.array([[0.5, 1e-4]]), np.array([-3.6e5]), asymmetry=1e-5).round(6).tolist()
    [-31.9]
    """
    prediction = np.asarray(prediction, dtype=np.float64).reshape(-1, 2)
    omega = np.asarray(omega, dtype=np.float64)
    return prediction[:, 0] + omega * prediction[:, 1] + asymmetry * np.abs(omega)


def input_rate_estimate(prediction, rate, asymmetry=0.0):
    """The input rate a gyro output stands for: ``Ω̂ = (rate - b) / (1 + s + a sign(rate - b))``.

    The inverse of :func:`drift_of`: ``rate - b = Ω (1 + s + a sign Ω)``, and ``rate - b``
    has the sign of ``Ω`` (``1 + s ± a`` is positive).

    Parameters
    ----------
    prediction : array-like of shape (n_samples, 2)
        The bias ``b`` (deg/h) and the scale-factor error ``s`` of every row.
    rate : array-like of shape (n_samples,)
        The gyro outputs, deg/h.
    asymmetry : float, default=0.0
        The constant asymmetry ``a``.

    Returns
    -------
    input_rate : ndarray of shape (n_samples,)
        deg/h.

    Examples
    --------
    >>> import numpy as np
    >>> input_rate_estimate(np.array([[0.5, 1e-4]]), np.array([36.5 + 3.6e5])).round(6).tolist()
    [360000.0]
    >>> input_rate_estimate(np.array([[0.5, 1e-4]]), np.array([-31.9 - 3.6e5]), 1e-5).round(6)
    array([-360000.])
    """
    prediction = np.asarray(prediction, dtype=np.float64).reshape(-1, 2)
    excess = np.asarray(rate, dtype=np.float64) - prediction[:, 0]
    return excess / (1.0 + prediction[:, 1] + asymmetry * np.sign(excess))


def beyond_input_rates(omega, low, high, slack=INPUT_RATE_SLACK):
    """Whether input rates lie beyond the calibrated ``[low, high]`` (deg/h).

    Beyond by more than ``slack`` times the larger calibrated magnitude (``omega < low - d``
    or ``omega > high + d``): the rule of
    :meth:`~sklearn_ifog.pipeline.CompensationPipeline.outside_calibration` with
    ``input_rate``, of streaming and, in the same arithmetic, of the C export.

    Parameters
    ----------
    omega : float or ndarray
        Input rates, deg/h.
    low, high : float
        The calibrated input rates' extremes, deg/h (``input_rate_range_``).
    slack : float, default=0.05
        Share of ``max(|low|, |high|)`` that still counts as calibrated.

    Returns
    -------
    beyond : bool or ndarray of bool
        In the shape of ``omega``.

    Examples
    --------
    >>> import numpy as np
    >>> beyond_input_rates(np.array([0.0, 1.1e6, 1.2e6, -1.2e6]), -1.08e6, 1.08e6).tolist()
    [False, False, True, True]
    """
    margin = slack * max(abs(low), abs(high))
    return (omega < low - margin) | (omega > high + margin)


def input_rate_of(X, column):
    """The input-rate column ``column`` of ``X`` as float64 (deg/h), checked.

    Parameters
    ----------
    X : {ndarray, pandas.DataFrame, polars.DataFrame}
        The rows.
    column : str or int
        The column's name or position.

    Returns
    -------
    omega : ndarray of shape (n_samples,)

    Raises
    ------
    ValueError
        If ``X`` has no such column (naming it and the columns there are) or it holds NaN
        or inf.
    TypeError
        If the column is not numeric.

    Examples
    --------
    >>> import pandas as pd
    >>> input_rate_of(pd.DataFrame({"reference": [0, 3600]}), "reference")
    array([   0., 3600.])
    """
    return _table.numeric_column(
        _table.as_table(X),
        column,
        param="input_rate",
        hint=f"It must hold the true input rate in {INPUT_RATE_UNIT} (predict and fit need it; "
        "compensate(X, rate) estimates it from the output).",
    )


def layer_penalty(final):
    """The ridge penalty of every output-layer column of a fitted final regressor.

    An RBF network's Gaussian weights take its ``alpha``, its tail's its ``tail_alpha`` (its
    ``alpha`` when that is ``"auto"``), the intercept none; a linear model's columns none.
    In :func:`fit_product_layer`'s convention (relative to each column's information).

    Parameters
    ----------
    final : RBFNetRegressor or linear regressor
        Fitted.

    Returns
    -------
    penalty : ndarray of shape (n_columns,)
        In the order of :func:`~sklearn_ifog._output_layer.layer_design`.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> X = np.arange(6.0).reshape(3, 2)
    >>> layer_penalty(LinearRegression().fit(X, X[:, 0])).tolist()
    [0.0, 0.0, 0.0]
    """
    layer = read_layer(final)
    if layer.kind != "rbf_network":
        return np.zeros(layer.coef.shape[1] + 1)
    alpha = float(final.alpha)
    tail_alpha = alpha if isinstance(final.tail_alpha, str) else float(final.tail_alpha)
    n_tail = layer.tail_coef.shape[1] if layer.fitted_tail_degree > 0 else 0
    return np.concatenate(
        [np.full(layer.coef.shape[1], alpha), np.full(n_tail, tail_alpha), [0.0]]
    )


def with_input_rate(X, column, values, fitted_names, n_fitted):
    """``X`` with the input-rate column, added (as ``values``) where it is missing.

    The thermal features never read the input rate, but a fitted feature step checks that
    its input has the columns of its fit: rows to compensate, which have no input rate yet,
    get ``values`` (the output, standing in for it) at the column's fitted place.

    Parameters
    ----------
    X : {ndarray, pandas.DataFrame, polars.DataFrame}
        Rows, with or without the column.
    column : str or int
        The input-rate column.
    values : ndarray of shape (n_samples,)
        What to put there when it is missing.
    fitted_names : sequence of str or None
        The feature step's ``feature_names_in_`` (None: it was fitted on an array).
    n_fitted : int
        Its ``n_features_in_``.

    Returns
    -------
    X : same type
        ``X`` itself when it has the column (a copy with it otherwise).

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> X = pd.DataFrame({"time": [0.0], "temperature": [20.0]})
    >>> with_input_rate(X, "reference", np.array([5.0]), ["time", "reference", "temperature"], 3)
       time  reference  temperature
    0   0.0        5.0         20.0
    >>> with_input_rate(np.zeros((1, 2)), 1, np.array([5.0]), None, 3)
    array([[0., 5., 0.]])
    """
    kind = _table.frame_kind(X)
    if kind is not None:
        if column in list(X.columns) or fitted_names is None or column not in fitted_names:
            return X
        names = list(fitted_names)
        if kind == "pandas":
            out = X.copy()
            out.insert(names.index(column), column, values)
            return out
        import polars as pl

        return X.with_columns(pl.Series(column, values)).select(
            [name for name in names if name in X.columns or name == column]
        )
    X = np.asarray(X)
    if X.ndim == 2 and X.shape[1] == n_fitted - 1 and isinstance(column, int):
        return np.insert(X.astype(np.result_type(X, np.float64)), column, values, axis=1)
    return X
