"""Model selection of a Gaussian RBF network: the number of centres, the width, the tail.

For every width of a grid (and every tail degree tried), centres are chosen from a candidate
pool by orthogonal least squares (``_ols``), every prefix of the path is re-solved, and a
criterion picks one (width, number of centres) pair: held-out errors on contiguous blocks
(one split, or cross-validated over contiguous folds) through the one-standard-error rule,
or an information criterion, minimised. Plain numpy in, numpy out: the targets are already
standardised and the inputs are ``Z``, standardised too.
"""

import copy
import warnings
from typing import NamedTuple

import numpy as np

from sklearn_ifog._statistics import within_one_standard_error
from sklearn_ifog._table import run_codes
from sklearn_ifog.rbf._basis import (
    WIDTH_LIMITS,
    Network,
    n_tail_features,
    squared_distances,
    tail_features,
    transformed,
)
from sklearn_ifog.rbf._ols import (
    Workspace,
    candidate_pool,
    contiguous_validation_mask,
    ols_forward_select,
    path_criterion,
    prefix_fits,
    width_grid,
)
from sklearn_ifog.rbf._tail_penalty import tail_transform

# Largest number of centres when ``n_centers="auto"``; the criterion picks along the path.
AUTO_MAX_CENTERS = 40
# Shared-width grid, in multiples of the candidates' median nearest-neighbour distance.
WIDTH_MULTIPLES = (2.0, 4.0, 8.0, 16.0)
# Below this many held-out rows a validation error ranks nothing: no held-out blocks.
MIN_VALIDATION_ROWS = 10
# Held-out blocks per fit (fewer when there are few rows: at least 5 rows per block).
N_VALIDATION_BLOCKS = 2
MIN_BLOCK_ROWS = 5
# At most this many cross-validation folds of whole groups (one group per fold up to it).
MAX_GROUP_FOLDS = 10
# Tail degrees tried for each value of ``tail``.
TAIL_DEGREES = {False: (0,), True: (1,), "linear": (1,), "quadratic": (2,), "auto": (1, 2)}
# The quadratic tail's weights are not penalised: it needs at least this many selection rows
# per tail column, otherwise the linear tail is used (with a warning).
MIN_ROWS_PER_TAIL_COLUMN = 10
# The criteria of ``select_network`` ("cv" and the ones of ``_ols.path_criterion``).
SELECTION_CRITERIA = ("cv", "holdout", "gcv", "bic", "aicc")


# Relative ridge penalties on the tail weights tried when ``tail_alpha="auto"``.
TAIL_ALPHA_GRID = (0.0, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1)


def tail_alphas_tried(tail_alpha, degree):
    """Relative tail penalties to try: the grid for ``"auto"``, else the one given.

    Examples
    --------
    >>> tail_alphas_tried("auto", 2)
    (0.0, 1e-05, 0.0001, 0.001, 0.01, 0.1)
    >>> tail_alphas_tried(0.5, 0)
    (0.0,)
    """
    if degree == 0:
        return (0.0,)
    if tail_alpha == "auto":
        return TAIL_ALPHA_GRID
    return (float(tail_alpha),)


class _WidthPath(NamedTuple):
    """The selection path at one width: its OLS path, prefix fits and criterion values."""

    width: float
    tail_alpha: float
    path: object  # _ols.OLSPath
    fits: object  # _ols.PrefixFits
    values: np.ndarray


class SelectionRecord(NamedTuple):
    """What the selection at one tail degree records (``RBFNetRegressor.selection_path_``).

    The fields are the keys of ``selection_path_`` that the selection at the chosen tail
    degree fills, in its order; see :func:`selection_path`, which assembles the whole record.
    """

    err: np.ndarray
    tail_err: float
    train_mse: np.ndarray
    val_mse: np.ndarray
    dof: np.ndarray
    criterion: np.ndarray
    criterion_name: str
    n_centers: int
    widths_tried: np.ndarray
    width_scores: np.ndarray
    tail_alpha: float
    tail_alphas_tried: np.ndarray
    tail_transform: object  # ndarray (n_tail, n_tail) or None: _tail_penalty.tail_transform


class _Trial(NamedTuple):
    """The network chosen with one tail degree, its record and its criterion value."""

    score: float
    degree: int
    network: Network
    record: SelectionRecord
    random_state: np.random.RandomState


class Selection(NamedTuple):
    """Result of :func:`select_network`.

    Attributes
    ----------
    network : Network
        The chosen network, on the standardised targets.
    record : SelectionRecord
        The selection's record at the chosen tail degree.
    tail_degree : int
        The chosen tail degree.
    tail_scores : dict
        Criterion value of the chosen network for each tail degree tried.
    random_state : numpy.random.RandomState
        The random state the chosen network was selected with, after selection (what the
        refinement draws its seed from).
    """

    network: Network
    record: SelectionRecord
    tail_degree: int
    tail_scores: dict
    random_state: np.random.RandomState


def selection_path(selection, *, refined, refine_rejected=None):
    """``RBFNetRegressor.selection_path_``: the one place where that dict is assembled.

    Parameters
    ----------
    selection : Selection
        What :func:`select_network` chose.
    refined : bool
        Whether the refinement was kept.
    refine_rejected : bool or None, default=None
        After a refinement: whether it was discarded for a held-out gain within one
        standard error. None when no refinement ran (the key is then absent).

    Returns
    -------
    path : dict
        The fields of ``selection.record``, then ``"tail_degree"``, ``"tail_scores"``,
        ``"refine_rejected"`` (after a refinement) and ``"refined"``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog import RBFNetRegressor
    >>> from sklearn_ifog.rbf._options import FitOptions
    >>> options = FitOptions(**RBFNetRegressor(criterion="holdout").get_params())
    >>> Z = np.linspace(-2, 2, 200)[:, None]
    >>> Y, sw, rng = np.sin(2 * Z), np.ones(200), np.random.RandomState(0)
    >>> train, val = split_rows(sw, 0.2, needs_blocks=True)
    >>> selection = select_network(
    ...     Z, Y, sw, train, val, np.ones(1), rng, degrees=(1,), options=options
    ... )
    >>> list(selection_path(selection, refined=False))[-5:]
    ['tail_alphas_tried', 'tail_transform', 'tail_degree', 'tail_scores', 'refined']
    """
    path = selection.record._asdict()
    path["tail_degree"] = selection.tail_degree
    path["tail_scores"] = selection.tail_scores
    if refine_rejected is not None:
        path["refine_rejected"] = refine_rejected
    path["refined"] = refined
    return path


def group_codes(groups, n_samples):
    """Integer code of every row's group, numbered in order of first appearance.

    Parameters
    ----------
    groups : array-like of shape (n_samples,)
        Group label (recording run) of every row.
    n_samples : int
        Number of rows the labels must match.

    Returns
    -------
    codes : ndarray of int of shape (n_samples,)
        0 for the first group seen, 1 for the next, ...

    Examples
    --------
    >>> group_codes(["b", "b", "a", "c", "a"], 5).tolist()
    [0, 0, 1, 2, 1]
    """
    labels = np.asarray(groups)
    if labels.ndim != 1 or labels.shape[0] != n_samples:
        raise ValueError(
            f"groups must be one label per row of X, of shape ({n_samples},); "
            f"got shape {labels.shape}."
        )
    if labels.dtype.kind == "f" and np.isnan(labels).any():
        row = int(np.flatnonzero(np.isnan(labels))[0])
        raise ValueError(f"groups: missing run id (NaN) at row {row}; every row needs one.")
    try:
        codes = run_codes(labels)  # the runs as ThermalFeatures reads them
    except ValueError as exc:
        raise ValueError(f"groups: {exc}") from exc
    _, first = np.unique(codes, return_index=True)
    rank = np.empty(first.shape[0], dtype=int)
    rank[np.argsort(first, kind="stable")] = np.arange(first.shape[0])
    return rank[codes]


def cv_folds(n_samples, validation_fraction, groups=None):
    """The cross-validation folds: (training rows, held-out rows) pairs.

    Without groups (or with a single one) the rows are cut into
    ``round(1 / validation_fraction)`` contiguous folds (2 to 10). With groups, every fold
    holds out whole groups: one group per fold up to ``MAX_GROUP_FOLDS`` groups, then
    consecutive groups (in order of first appearance) share a fold. Holding out whole runs
    measures what the model is for, a run it never saw, where a block cut inside a run
    leaves the run's other rows (its offset, its conditions) in the training set.

    Parameters
    ----------
    n_samples : int
        Number of rows.
    validation_fraction : float
        Fraction of the rows per fold without groups.
    groups : ndarray of int of shape (n_samples,), default=None
        Group codes (:func:`group_codes`).

    Returns
    -------
    folds : list of (ndarray, ndarray)
        Training and held-out rows of every fold, each in row order.

    Examples
    --------
    >>> import numpy as np
    >>> [out.tolist() for _, out in cv_folds(6, 0.5)]
    [[0, 1, 2], [3, 4, 5]]
    >>> [out.tolist() for _, out in cv_folds(6, 0.5, np.array([0, 0, 1, 1, 2, 2]))]
    [[0, 1], [2, 3], [4, 5]]
    """
    n_groups = 0 if groups is None else int(groups.max()) + 1
    if n_groups < 2:
        n_folds = int(np.clip(round(1.0 / validation_fraction), 2, 10))
        bounds = np.linspace(0, n_samples, n_folds + 1).round().astype(int)
        fold = np.repeat(np.arange(n_folds), np.diff(bounds))
    else:
        n_folds = min(n_groups, MAX_GROUP_FOLDS)
        fold = (np.arange(n_groups) * n_folds // n_groups)[groups]
    return [(np.flatnonzero(fold != k), np.flatnonzero(fold == k)) for k in range(n_folds)]


def split_rows(sample_weight, validation_fraction, *, needs_blocks, groups=None):
    """Training rows and held-out contiguous blocks (None when too few rows or not needed).

    Parameters
    ----------
    sample_weight : ndarray of shape (n_samples,)
        Non-negative weights.
    validation_fraction : float
        Fraction of the rows held out.
    needs_blocks : bool
        Whether held-out blocks are wanted at all (a held-out criterion or a refinement).
    groups : ndarray of int of shape (n_samples,), default=None
        Group codes (:func:`group_codes`). With two groups or more, the held-out rows are
        ``round(validation_fraction * n_groups)`` whole groups (at least one), spread
        evenly over the groups' order, instead of row blocks.

    Returns
    -------
    train : ndarray of int
        Training rows, in order.
    val : ndarray of int or None
        Held-out rows, in order; None without blocks (then ``train`` is every row).

    Examples
    --------
    >>> import numpy as np
    >>> train, val = split_rows(np.ones(100), 0.2, needs_blocks=True)
    >>> val.tolist()[:3], val.shape[0], train.shape[0]
    ([20, 21, 22], 20, 80)
    """
    n_samples = sample_weight.shape[0]
    n_held = round(validation_fraction * n_samples)
    if not needs_blocks or n_held < MIN_VALIDATION_ROWS:
        return np.arange(n_samples), None
    n_groups = 0 if groups is None else int(groups.max()) + 1
    if n_groups >= 2:
        n_held_groups = int(np.clip(round(validation_fraction * n_groups), 1, n_groups - 1))
        held = (np.arange(n_held_groups) * 2 + 1) * n_groups // (2 * n_held_groups)
        mask = np.isin(groups, held)
    else:
        n_blocks = max(1, min(N_VALIDATION_BLOCKS, n_held // MIN_BLOCK_ROWS))
        mask = contiguous_validation_mask(n_samples, validation_fraction, n_blocks)
    if not (sample_weight[mask].sum() > 0 and sample_weight[~mask].sum() > 0):
        return np.arange(n_samples), None
    return np.flatnonzero(~mask), np.flatnonzero(mask)


def subsample(rows, size, random_state):
    """At most ``size`` of ``rows``, drawn without replacement and kept in order.

    Examples
    --------
    >>> import numpy as np
    >>> subsample(np.arange(10), 4, np.random.RandomState(0)).tolist()
    [2, 4, 8, 9]
    """
    if rows.shape[0] <= size:
        return rows
    return np.sort(random_state.choice(rows, size=size, replace=False))


def tail_degrees(tail, n_features, n_rows):
    """Tail degrees to try; the quadratic one only with enough rows per tail column.

    Examples
    --------
    >>> tail_degrees("auto", 3, 1000)
    (1, 2)
    """
    degrees = TAIL_DEGREES[tail]
    needed = MIN_ROWS_PER_TAIL_COLUMN * (n_tail_features(n_features, 2) + 1)
    if 2 in degrees and n_rows < needed:
        warnings.warn(
            f"RBFNetRegressor: tail={tail!r} needs at least {needed} selection rows "
            f"for the {n_tail_features(n_features, 2)} unpenalised columns of a quadratic "
            f"tail on {n_features} features, got {n_rows}; a linear tail is used.",
            UserWarning,
            stacklevel=4,
        )
        degrees = (1,)
    return degrees


def select_network(
    Z,
    Y,
    sample_weight,
    sel_rows,
    val_rows,
    y_scale,
    random_state,
    *,
    degrees,
    options,
    groups=None,
):
    """Select the network: OLS paths over the width grid, for every tail degree.

    Each tail degree is selected from a copy of the same random state (when there are
    several), so they are scored on the same candidates, folds and rows (a paired
    comparison); the lower criterion value wins, a tie keeps the lower degree.

    Parameters
    ----------
    Z : ndarray of shape (n_samples, n_features)
        Standardised inputs, all rows.
    Y : ndarray of shape (n_samples, n_outputs)
        Standardised targets.
    sample_weight : ndarray of shape (n_samples,)
        Non-negative weights.
    sel_rows : ndarray of int
        Rows the paths are run on.
    val_rows : ndarray of int or None
        Held-out rows (None: information criteria only).
    y_scale : ndarray of shape (n_outputs,)
        Standard deviations the targets were divided by (for the recorded errors).
    random_state : numpy.random.RandomState
        Seeds the candidate pool and the cross-validation subsamples.
    degrees : tuple of int
        Tail degrees to try (:func:`tail_degrees`).
    options : ~sklearn_ifog.rbf._options.FitOptions
        The remaining settings (those of the selection are read).
    groups : ndarray of int of shape (n_samples,), default=None
        Group code of every row (:func:`group_codes`): the cross-validation folds hold out
        whole groups (:func:`cv_folds`). None: contiguous row blocks.

    Returns
    -------
    selection : Selection
        The chosen network, its record and the random state it was selected with.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.RandomState(0)
    >>> Z = np.linspace(-2, 2, 200)[:, None]
    >>> Y = np.sin(2 * Z)
    >>> train, val = split_rows(np.ones(200), 0.2, needs_blocks=True)
    >>> from sklearn_ifog import RBFNetRegressor
    >>> from sklearn_ifog.rbf._options import FitOptions
    >>> options = FitOptions(**RBFNetRegressor(criterion="holdout").get_params())
    >>> sel = select_network(
    ...     Z, Y, np.ones(200), train, val, np.ones(1), rng, degrees=(1,), options=options
    ... )
    >>> sel.record.criterion_name, sel.network.tail_degree
    ('holdout', 1)
    """
    trials = []
    for degree in degrees:
        rng = copy.deepcopy(random_state) if len(degrees) > 1 else random_state
        network, record, score = _select_at_degree(
            Z, Y, sample_weight, sel_rows, val_rows, y_scale, rng, degree, options, groups
        )
        trials.append(
            _Trial(score=score, degree=degree, network=network, record=record, random_state=rng)
        )
    best = min(trials, key=lambda trial: (trial.score, trial.degree))
    return Selection(
        network=best.network,
        record=best.record,
        tail_degree=best.degree,
        tail_scores={trial.degree: trial.score for trial in trials},
        random_state=best.random_state,
    )


def _select_at_degree(Z, Ys, sw, sel_rows, val_rows, y_scale, rng, degree, options, groups):
    """OLS paths over the width grid, with a polynomial tail of degree ``degree``.

    Returns the chosen network, its :class:`SelectionRecord` and its criterion value (lower
    is better; comparable between tail degrees selected from the same random state).
    """
    Z_sel, Y_sel, sw_sel = Z[sel_rows], Ys[sel_rows], sw[sel_rows]
    candidates = candidate_pool(
        Z_sel,
        sample_weight=sw_sel,
        max_candidates=options.max_candidates,
        method=options.candidates,
        random_state=rng,
    )
    max_centers = _max_centers(options.n_centers, candidates.shape[0])
    widths_tried = _widths_tried(options.width, candidates)
    has_val = val_rows is not None
    criterion = _criterion_used(options.criterion, has_val)
    validation = None
    if has_val:
        Z_val, sw_val = Z[val_rows], sw[val_rows]
        validation = (squared_distances(Z_val, candidates), Ys[val_rows], sw_val)
    fixed_size = options.criterion is None and options.goal is None
    tail_alphas = tail_alphas_tried(options.tail_alpha, degree)
    T_sel = tail_features(Z_sel, degree) if degree else None
    # The penalty's shape, as a reparametrisation of the tail (a free tail keeps its own).
    M = tail_transform(T_sel, sw_sel, options.tail_penalty) if any(tail_alphas) else None
    if validation is not None:
        D2_val, Y_val, sw_val = validation
        T_val = transformed(tail_features(Z_val, degree), M) if degree else None
        validation = (D2_val, T_val, Y_val, sw_val)
    paths = _width_paths(
        squared_distances(Z_sel, candidates),
        Y_sel,
        transformed(T_sel, M),
        sw_sel,
        options.alpha * sw_sel.sum(),
        max_centers,
        widths_tried=widths_tried,
        tail_alphas=tail_alphas,
        validation=validation,
        criterion="holdout" if criterion == "cv" else criterion,
    )
    losses = None
    if criterion == "cv":
        losses, sw_losses = _cross_validated_losses(
            Z,
            Ys,
            sw,
            candidates,
            widths_tried,
            max_centers,
            fixed_size,
            rng,
            degree,
            options,
            groups,
            tail_basis=M,
        )
    if losses is not None:
        paths, choice, score = _choice_by_cross_validation(paths, losses, sw_losses, fixed_size)
    else:
        sw_chosen = sw_val if has_val else None
        choice, score = _choice_on_paths(paths, criterion, fixed_size, sw_chosen)
    chosen = paths[choice[0]]
    path, fits, values = chosen.path, chosen.fits, chosen.values
    k = choice[1]
    config_scores = np.array([p.values[-1] if fixed_size else p.values.min() for p in paths])
    # Paths are width-major: the score of a width is its best over the tail penalties.
    width_scores = config_scores.reshape(len(widths_tried), len(tail_alphas)).min(axis=1)
    train_mse = (fits.train_mse * np.square(y_scale)).mean(axis=1)
    if options.goal is not None:
        reached = np.flatnonzero(train_mse <= options.goal)
        k = int(reached[0]) if reached.size else len(path.selected)
    n_tail = n_tail_features(Z.shape[1], degree)
    W = fits.weights[k]
    network = Network(
        centers=candidates[path.selected[:k]],
        widths=np.full(k, chosen.width),
        coef=W[1 + n_tail :].T,
        tail_coef=(W[1 : 1 + n_tail] if M is None else M @ W[1 : 1 + n_tail]).T,
        intercept=W[0],
    )
    val_mse = (
        (fits.val_mse * np.square(y_scale)).mean(axis=1)
        if has_val
        else np.full(len(values), np.nan)
    )
    record = SelectionRecord(
        err=path.err,
        tail_err=path.tail_err,
        train_mse=train_mse,
        val_mse=val_mse,
        dof=fits.dof,
        criterion=values,
        criterion_name=criterion,
        n_centers=k,
        widths_tried=widths_tried,
        width_scores=np.asarray(width_scores),
        tail_alpha=chosen.tail_alpha,
        tail_alphas_tried=np.asarray(tail_alphas),
        # The penalty's shape, for the solves that follow; none when the strength is 0.
        tail_transform=M if chosen.tail_alpha > 0 else None,
    )
    return network, record, score


def _choice_by_cross_validation(paths, losses, sw_losses, fixed_size):
    """The (width, size) chosen by the cross-validated losses, its score, and the paths
    with their values replaced by the cross-validated error of each prefix."""
    choice = _choose_by_losses(losses, sw_losses, fixed_size, paths)
    i_cv = choice[0]
    k_cv = min(choice[1], losses[i_cv].shape[0] - 1)
    score = float(losses[i_cv][k_cv] @ sw_losses / sw_losses.sum())
    # Record the cross-validated error of each prefix (of the final paths' length).
    paths = [
        p._replace(values=(loss @ sw_losses / sw_losses.sum())[: len(p.path.selected) + 1])
        for p, loss in zip(paths, losses, strict=True)
    ]
    return paths, choice, score


def _choice_on_paths(paths, criterion, fixed_size, sw_val):
    """The (width, size) chosen by the paths' own criterion, and its score (the held-out
    error with ``"holdout"``, else the criterion's value)."""
    choice = _choose(paths, criterion, fixed_size, sw_val)
    chosen = paths[choice[0]]
    k = choice[1]
    if criterion == "holdout":
        return choice, float(chosen.fits.val_sq[k] @ sw_val / sw_val.sum())
    return choice, float(chosen.values[k])


def _max_centers(n_centers, n_candidates):
    """Largest number of centres of a path: ``n_centers`` capped by the candidate pool."""
    if n_centers == "auto":
        return min(AUTO_MAX_CENTERS, n_candidates)
    if n_centers > n_candidates:
        warnings.warn(
            f"n_centers={n_centers} but only {n_candidates} distinct candidate "
            f"rows are available; at most {n_candidates} centres will be used.",
            UserWarning,
            stacklevel=6,  # the estimator's fit (the frame that called it)
        )
    return min(n_centers, n_candidates)


def _widths_tried(width, candidates):
    """The shared widths to try: the grid for ``"auto"``, else ``width``; within limits."""
    if width == "auto":
        widths = width_grid(candidates, WIDTH_MULTIPLES)
    else:
        widths = np.array([float(width)])
    return np.clip(widths, *WIDTH_LIMITS)


def _criterion_used(criterion, has_val):
    """The criterion after its fallback: without held-out rows, ``"gcv"``.

    ``None`` (a fixed number of centres) still ranks the widths, on the held-out rows when
    there are some.
    """
    if criterion is None:
        return "holdout" if has_val else "gcv"
    if criterion in ("holdout", "cv") and not has_val:
        return "gcv"
    return criterion


def _width_paths(
    D2,
    Y,
    T,
    sample_weight,
    alpha,
    max_centers,
    *,
    widths_tried,
    tail_alphas,
    validation,
    criterion,
):
    """The selection path at every width and relative tail penalty, with its criterion.

    One :class:`_WidthPath` per (width, penalty), width-major; ``criterion`` is that of
    :func:`~sklearn_ifog.rbf._ols.path_criterion` (``"holdout"`` scores the held-out rows of
    ``validation``). The other arguments are those of :func:`_select_and_score`, with
    ``tail_alphas`` relative (to the total weight).
    """
    paths = []
    workspace = Workspace()
    for width in widths_tried:
        path, fits_list = _select_and_score(
            width,
            D2,
            Y,
            T,
            sample_weight,
            alpha,
            max_centers,
            validation=validation,
            tail_alphas=[ta * sample_weight.sum() for ta in tail_alphas],
            workspace=workspace,
        )
        for ta, fits in zip(tail_alphas, fits_list, strict=True):
            values = path_criterion(fits, criterion, sample_weight.sum())
            paths.append(
                _WidthPath(width=width, tail_alpha=ta, path=path, fits=fits, values=values)
            )
    return paths


def _select_and_score(
    width,
    D2,
    Y,
    T,
    sample_weight,
    alpha,
    max_centers,
    *,
    validation=None,
    tail_alphas=(0.0,),
    workspace=None,
):
    """OLS path at one width, and the fit of every prefix (scored on held-out rows if given).

    ``D2`` are the squared distances of the selection rows to the candidates; ``validation``
    is ``(D2_val, T_val, Y_val, sample_weight_val)`` or None. The path is ranked once, with
    the tail free; the prefixes are fitted once per absolute tail penalty of
    ``tail_alphas``. Returns the path and the list of prefix fits, one per penalty.
    ``workspace`` (:class:`~sklearn_ifog.rbf._ols.Workspace`) holds the candidate matrix
    and the selection's scratch arrays between widths.
    """
    workspace = Workspace() if workspace is None else workspace
    P = np.multiply(D2, -0.5 / width**2, out=workspace.array("candidates", D2.shape))
    np.exp(P, out=P)
    path = ols_forward_select(
        P,
        Y,
        T=T,
        sample_weight=sample_weight,
        alpha=alpha,
        max_selected=max_centers,
        workspace=workspace,
    )
    chosen = path.selected
    D2_val, T_val, Y_val, sw_val = validation if validation is not None else (None,) * 4
    Phi_val = None if D2_val is None else np.exp(D2_val[:, chosen] * (-0.5 / width**2))
    fits = [
        prefix_fits(
            P[:, chosen],
            Y,
            T=T,
            sample_weight=sample_weight,
            alpha=alpha,
            tail_alpha=tail_alpha,
            Phi_val=Phi_val,
            T_val=T_val,
            Y_val=Y_val,
            sample_weight_val=sw_val,
        )
        for tail_alpha in tail_alphas
    ]
    return path, fits


def _cross_validated_losses(
    Z,
    Ys,
    sw,
    candidates,
    widths_tried,
    max_centers,
    fixed_size,
    rng,
    degree,
    options,
    groups=None,
    tail_basis=None,
):
    """Held-out squared errors of every (width, tail penalty, prefix) over contiguous folds.

    The rows are cut into ``round(1 / validation_fraction)`` contiguous folds; each fold
    is held out in turn, the selection paths are run on the other rows and every prefix
    is scored on the fold. The candidate pool is the final one (centre locations only,
    no held-out target is used), so the folds cost no extra seeding. Returns
    ``losses[i * n_penalties + j]`` of shape (max_centers + 1, n_scored) for width ``i``
    and tail penalty ``j`` of :func:`tail_alphas_tried` (the order of the final paths; a
    path that stopped early repeats its last prefix) and the weights of the scored rows,
    which are in row order.
    """
    folds = cv_folds(Z.shape[0], options.validation_fraction, groups)
    n_folds = len(folds)
    tail_alphas = tail_alphas_tried(options.tail_alpha, degree)
    n_ta = len(tail_alphas)
    losses = [[] for _ in range(len(widths_tried) * n_ta)]
    weights = []
    workspace = Workspace()
    for rows_in, rows_out in folds:
        if not (sw[rows_in].sum() > 0 and sw[rows_out].sum() > 0):
            continue
        rows_in = subsample(rows_in, options.max_samples, rng)
        rows_out = subsample(rows_out, options.max_samples // n_folds, rng)
        Z_in, Y_in, sw_in = Z[rows_in], Ys[rows_in], sw[rows_in]
        alpha_in = options.alpha * sw_in.sum()
        T_in = transformed(tail_features(Z_in, degree), tail_basis) if degree else None
        T_out = transformed(tail_features(Z[rows_out], degree), tail_basis) if degree else None
        D2_in = squared_distances(Z_in, candidates)
        D2_out = squared_distances(Z[rows_out], candidates)
        for i, width in enumerate(widths_tried):
            path, fits_list = _select_and_score(
                width,
                D2_in,
                Y_in,
                T_in,
                sw_in,
                alpha_in,
                max_centers,
                validation=(D2_out, T_out, Ys[rows_out], sw[rows_out]),
                tail_alphas=[ta * sw_in.sum() for ta in tail_alphas],
                workspace=workspace,
            )
            chosen = path.selected
            for j, fits in enumerate(fits_list):
                padded = np.empty((max_centers + 1, rows_out.shape[0]))
                padded[: len(chosen) + 1] = fits.val_sq
                padded[len(chosen) + 1 :] = fits.val_sq[-1]
                losses[i * n_ta + j].append(padded[-1:] if fixed_size else padded)
        weights.append(sw[rows_out])
    if not weights:  # no fold with weight on both sides: score on the one split
        return None, None
    return [np.hstack(loss) for loss in losses], np.concatenate(weights)


def _smoothest_within_one_standard_error(options, losses, sample_weight):
    """The (width index, prefix) of the smoothest network within one standard error.

    ``options`` lists (width index, number of centres) pairs, ``losses`` their squared
    held-out errors row by row. Widths are tried in increasing order, so the smoothest is
    the widest width, then the fewest centres: the simplest network the held-out rows cannot
    tell apart from the best one.
    """
    within = within_one_standard_error(losses, sample_weight)
    return max(
        (option for option, ok in zip(options, within, strict=True) if ok),
        key=lambda option: (option[0], -option[1]),
    )


def _choose_by_losses(losses, sw_losses, fixed_size, paths):
    """(path index, prefix) from cross-validated losses, capped to the final paths."""
    options = [(i, k) for i, loss in enumerate(losses) for k in range(loss.shape[0])]
    i, k = _smoothest_within_one_standard_error(options, np.vstack(losses), sw_losses)
    n_final = len(paths[i].path.selected)
    return i, n_final if fixed_size else min(k, n_final)


def _choose(paths, criterion, fixed_size, sw_val):
    """(width index, prefix) from the paths of every width and their criterion values.

    Held-out errors go through the one-standard-error rule; information criteria are
    minimised.
    """
    options = [
        (i, k)
        for i, p in enumerate(paths)
        for k in ([len(p.path.selected)] if fixed_size else range(len(p.path.selected) + 1))
    ]
    if criterion == "holdout":
        losses = np.vstack([paths[i].fits.val_sq[k] for i, k in options])
        return _smoothest_within_one_standard_error(options, losses, sw_val)
    values = [paths[i].values[k] for i, k in options]
    return options[int(np.argmin(values))]
