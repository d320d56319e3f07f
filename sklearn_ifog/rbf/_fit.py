"""The numerics of ``RBFNetRegressor.fit``: standardise, select, refine, solve on all rows."""

import warnings
from typing import NamedTuple

import numpy as np
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils import check_random_state

from sklearn_ifog._statistics import within_one_standard_error
from sklearn_ifog.rbf._basis import (
    Network,
    solve_output_weights_chunked,
    standardisation,
    tail_features,
)
from sklearn_ifog.rbf._refine import refine_network
from sklearn_ifog.rbf._select import (
    select_network,
    selection_path,
    split_rows,
    subsample,
    tail_degrees,
)
from sklearn_ifog.rbf._threads import single_blas_thread


def beats_beyond_noise(candidate, start, Z_val, Y_val, sw_val):
    """Whether ``candidate`` beats ``start`` on held-out rows by more than one standard error.

    The paired difference of their squared held-out errors (summed over outputs) is judged
    by :func:`~sklearn_ifog._statistics.within_one_standard_error`, the rule the selection
    uses: a refined network that the held-out rows cannot tell from the OLS network it
    started from is not kept, since its moved centres and widths were chosen on those same
    rows (early stopping) and the gain is within their noise.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.rbf._basis import Network
    >>> Z = np.linspace(-1, 1, 200)[:, None]
    >>> def net(w):
    ...     return Network(
    ...         centers=np.zeros((1, 1)),
    ...         widths=np.ones(1),
    ...         coef=np.array([[w]]),
    ...         tail_coef=np.zeros((1, 1)),
    ...         intercept=np.zeros(1),
    ...     )
    >>> Y = np.exp(-0.5 * Z**2)
    >>> bool(beats_beyond_noise(net(1.0), net(0.0), Z, Y, np.ones(200)))
    True
    >>> bool(beats_beyond_noise(net(0.0), net(0.0), Z, Y, np.ones(200)))
    False
    """
    losses = np.vstack(
        [np.square(Y_val - network.predict(Z_val)).sum(axis=1) for network in (start, candidate)]
    )
    return not within_one_standard_error(losses, sw_val)[0]


class FittedNetwork(NamedTuple):
    """Result of :func:`fit_network`.

    Attributes
    ----------
    network : Network
        The network on standardised inputs, in target units: ``coef`` (n_outputs,
        n_centers), ``tail_coef`` (n_outputs, n_tail; zeros of width ``n_features`` without
        a tail) and ``intercept`` (n_outputs,).
    tail_degree : int
        Degree of the tail (0: none).
    x_mean, x_scale : ndarray of shape (n_features,)
        The input standardisation ``z = (x - x_mean) / x_scale``.
    n_iter : int
        Refinement iterations run.
    path : dict
        The selection record (``RBFNetRegressor.selection_path_``).
    """

    network: Network
    tail_degree: int
    x_mean: np.ndarray
    x_scale: np.ndarray
    n_iter: int
    path: dict


class _Refinement(NamedTuple):
    """Outcome of :func:`_refine_selected`."""

    network: Network
    n_iter: int
    refined: bool
    rejected: bool


def fit_network(X, Y, sample_weight, options, *, groups=None):
    """Fit a Gaussian RBF network: selection, refinement, output weights on all rows.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        Inputs, float64, finite.
    Y : ndarray of shape (n_samples, n_outputs)
        Targets, float64, finite.
    sample_weight : ndarray of shape (n_samples,)
        Non-negative weights with a positive sum.
    options : ~sklearn_ifog.rbf._options.FitOptions
        The settings, as :class:`~sklearn_ifog.RBFNetRegressor`'s parameters of the same
        names (the one place their defaults are given and what each does), validated.
    groups : ndarray of int of shape (n_samples,), default=None
        Group codes (``_select.group_codes``): held-out rows and folds are whole groups.

    Returns
    -------
    fitted : FittedNetwork
        The network and its record.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog import RBFNetRegressor
    >>> from sklearn_ifog.rbf._options import FitOptions
    >>> X = np.linspace(-1, 1, 200)[:, None]
    >>> options = FitOptions(**RBFNetRegressor(refine=None, random_state=0).get_params())
    >>> fitted = fit_network(X, 2 * X + 1, np.ones(200), options)
    >>> fitted.tail_degree, fitted.network.tail_coef.shape
    (1, (1, 1))
    """
    sw = sample_weight
    x_mean, x_scale = standardisation(X, sw)
    y_mean, y_scale = standardisation(Y, sw)
    Z = np.subtract(X, x_mean)
    Z /= x_scale
    Ys = np.subtract(Y, y_mean)
    Ys /= y_scale
    rng = check_random_state(options.random_state)
    needs_blocks = options.criterion in ("holdout", "cv", None) or options.refine is not None
    train, val = split_rows(
        sw, options.validation_fraction, needs_blocks=needs_blocks, groups=groups
    )
    sel_rows = subsample(train, options.max_samples, rng)
    val_rows = subsample(val, options.max_samples, rng) if val is not None else None
    degrees = tail_degrees(options.tail, X.shape[1], sel_rows.shape[0])
    # Selection, refinement and the blocked solve work on small or skinny matrices, where
    # a multi-threaded BLAS spends more time synchronising than computing (3 to 20 times
    # slower on a loaded machine).
    with single_blas_thread():
        selection = select_network(
            Z,
            Ys,
            sw,
            sel_rows,
            val_rows,
            y_scale,
            rng,
            degrees=degrees,
            options=options,
            groups=groups,
        )
        network = selection.network
        n_iter, refined, rejected = 0, False, None
        if options.refine is not None and val_rows is not None and network.centers.shape[0]:
            refinement = _refine_selected(selection, Z, Ys, sw, sel_rows, val_rows, options)
            network, n_iter = refinement.network, refinement.n_iter
            refined, rejected = refinement.refined, refinement.rejected
        coef, tail_coef, intercept = solve_output_weights_chunked(
            Z,
            Ys,
            network.centers,
            network.widths,
            tail=selection.tail_degree,
            sample_weight=sw,
            alpha=options.alpha * sw.sum(),
            tail_alpha=selection.record.tail_alpha * sw.sum(),
            tail_transform=selection.record.tail_transform,
        )
    tail_coef = tail_coef * y_scale[:, None]
    if selection.tail_degree == 0:
        # The export contract: no tail is a zero linear tail.
        tail_coef = np.zeros((Y.shape[1], X.shape[1]))
    network = network._replace(
        coef=coef * y_scale[:, None], tail_coef=tail_coef, intercept=intercept * y_scale + y_mean
    )
    return FittedNetwork(
        network=network,
        tail_degree=selection.tail_degree,
        x_mean=x_mean,
        x_scale=x_scale,
        n_iter=n_iter,
        path=selection_path(selection, refined=refined, refine_rejected=rejected),
    )


def _refine_selected(selection, Z, Ys, sw, sel_rows, val_rows, options):
    """Refine the selected network; keep it only if it beats it beyond the held-out noise.

    Refines on the selection rows, stopped early on the held-out rows (standardised targets
    ``Ys``). Returns the network to solve the output weights of (the refined one, or the
    selected one when the refinement moved nothing or was rejected), the iterations run,
    whether the refinement was kept and whether it was rejected.
    """
    network = selection.network
    sw_sel = sw[sel_rows]
    Y_sel, Y_val, start = Ys[sel_rows], Ys[val_rows], network
    if selection.record.tail_alpha > 0 and network.tail_coef.size:
        # The refiners know a penalty on the Gaussian weights only: a penalised tail is held
        # at its selected weights while the units move (the targets carry it), so that the
        # refinement cannot buy its fit along directions the penalty shrinks; the solve on
        # all rows then fits every output weight together, penalty and all.
        degree = selection.tail_degree
        Y_sel = Y_sel - tail_features(Z[sel_rows], degree) @ network.tail_coef.T
        Y_val = Y_val - tail_features(Z[val_rows], degree) @ network.tail_coef.T
        start = network._replace(tail_coef=np.zeros((network.tail_coef.shape[0], 0)))
    result = refine_network(
        Z[sel_rows],
        Y_sel,
        start,
        method=options.refine,
        sample_weight=sw_sel,
        alpha=options.alpha * sw_sel.sum(),
        Z_val=Z[val_rows],
        Y_val=Y_val,
        sample_weight_val=sw[val_rows],
        max_iter=options.max_iter,
        tol=options.tol,
        learning_rate=options.learning_rate,
        max_samples=None,
        random_state=selection.random_state.randint(np.iinfo(np.int32).max),
    )
    # A best iterate at the starting centres and widths differs only in its output
    # weights, which the solve on all rows replaces: nothing was refined.
    moved = not (
        np.array_equal(result.network.centers, network.centers)
        and np.array_equal(result.network.widths, network.widths)
    )
    refined = bool(result.improved) and moved
    # Early stopping picked the refined iterate on the held-out rows themselves, so
    # it must beat the OLS network there by more than their noise to be kept.
    rejected = refined and not beats_beyond_noise(
        result.network, start, Z[val_rows], Y_val, sw[val_rows]
    )
    if not result.converged and not rejected:
        warnings.warn(
            f"RBFNetRegressor: {options.refine!r} refinement stopped at "
            f"max_iter={options.max_iter} before converging; the best iterate was kept.",
            ConvergenceWarning,
            stacklevel=4,  # the estimator's fit (the frame that called it)
        )
    return _Refinement(
        network=network if rejected else result.network,
        n_iter=int(result.n_iter),
        refined=refined and not rejected,
        rejected=rejected,
    )
