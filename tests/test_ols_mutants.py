"""Behaviour of the OLS selection path that mutation testing found unguarded (issue 42,
point 5).

Each test here kills mutants of :mod:`sklearn_ifog.rbf._ols` that survived
``tests/test_ols.py`` (``tools/mutation.sh ols``); the docstrings say which.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from sklearn_ifog._statistics import within_one_standard_error
from sklearn_ifog.rbf._ols import (
    PrefixFits,
    Workspace,
    _well_conditioned,
    candidate_pool,
    contiguous_validation_mask,
    median_nn_distance,
    ols_forward_select,
    path_criterion,
    prefix_fits,
)


@pytest.fixture
def columns():
    """Nine rows, three independent candidate columns and an exact target of two of them."""
    x = np.linspace(-1.0, 1.0, 9)
    P = np.column_stack([x**2, np.abs(x) ** 3, np.cos(3 * x)])
    return x, P


def _ridge(A, Y, penalties, sw=None):
    """Least squares of Y on A with ``penalties[j] * w_j²`` added, by an augmented solve."""
    sw = np.ones(A.shape[0]) if sw is None else sw
    root = np.sqrt(sw)[:, None]
    rows = np.diag(np.sqrt(penalties))
    augmented = np.vstack([A * root, rows])
    target = np.vstack([Y * root, np.zeros((A.shape[1], Y.shape[1]))])
    return np.linalg.lstsq(augmented, target, rcond=None)[0]


# -- prefix_fits ------------------------------------------------------------------------


def test_prefix_fits_with_unit_weights_and_no_tail(columns):
    """The unit-weight branch (the estimator's default) without a tail: every prefix is the
    least-squares fit on the intercept and its columns. Kills the mutants of that branch
    (the intercept column set to 2 or written in column 1, the branch condition) and of
    ``n_tail`` when ``T`` is None."""
    x, P = columns
    Y = np.column_stack([1.0 + 2.0 * x**2 - np.cos(3 * x), x])
    fits = prefix_fits(P, Y)
    assert len(fits.weights) == 4
    for k in range(4):
        A = np.column_stack([np.ones(9), P[:, :k]])
        expected = np.linalg.lstsq(A, Y, rcond=None)[0]
        assert_allclose(fits.weights[k], expected, rtol=1e-9, atol=1e-9)
        assert_allclose(
            fits.train_mse[k], np.mean(np.square(Y - A @ expected), axis=0), atol=1e-20
        )
        assert fits.dof[k] == pytest.approx(1 + k)
    assert_allclose(fits.weights[3][:, 0], [1.0, 2.0, 0.0, -1.0], atol=1e-10)
    # Slices and negative indices of the lazily solved weights.
    assert [w.shape for w in fits.weights[1:3]] == [(2, 2), (3, 2)]
    assert_array_equal(fits.weights[-1], fits.weights[3])
    with pytest.raises(IndexError):
        fits.weights[4]


@pytest.mark.parametrize("alpha", [0.5, 3.0])
@pytest.mark.parametrize("tail_alpha", [0.0, 0.25, 2.0])
def test_prefix_fits_ridge_on_units_and_tail(columns, alpha, tail_alpha):
    """``alpha`` penalises the units' weights and ``tail_alpha`` the tail's, both below 1
    too; the intercept is never penalised; the degrees of freedom are the trace of the hat
    matrix. Kills the mutants of ``tail_alpha > 0``, ``alpha > 0``, the penalty rows' places
    and sizes and ``n_pen``."""
    x, P = columns
    T = np.column_stack([x, x**3])
    Y = (np.sin(2 * x) + 0.3 * x**2)[:, None]
    sw = np.linspace(1.0, 2.0, 9)
    for weights in (None, sw):
        fits = prefix_fits(P, Y, T=T, sample_weight=weights, alpha=alpha, tail_alpha=tail_alpha)
        for k in range(4):
            A = np.column_stack([np.ones(9), T, P[:, :k]])
            penalties = np.r_[0.0, np.full(2, tail_alpha), np.full(k, alpha)]
            expected = _ridge(A, Y, penalties, weights)
            assert_allclose(fits.weights[k], expected, rtol=1e-8, atol=1e-10)
            root = np.sqrt(np.ones(9) if weights is None else weights)
            Aw = A * root[:, None]
            hat = Aw @ np.linalg.solve(Aw.T @ Aw + np.diag(penalties), Aw.T)
            assert fits.dof[k] == pytest.approx(np.trace(hat), rel=1e-8)


def test_prefix_fits_of_a_rank_deficient_path(columns):
    """A repeated column makes the factor singular: the general (SVD) path gives every
    prefix its least-squares fit, and a column that adds nothing adds no degree of
    freedom. Kills the mutants of that path (no test reached it) and of ``fast``."""
    x, P = columns
    Phi = np.column_stack([P[:, 0], P[:, 0], P[:, 1]])
    Y = (1.0 + x**2 + 0.5 * np.abs(x) ** 3 + 0.1 * np.sin(5 * x))[:, None]
    fits = prefix_fits(Phi, Y)
    assert_allclose(fits.dof, [1.0, 2.0, 2.0, 3.0], rtol=1e-9)
    for k in range(4):
        A = np.column_stack([np.ones(9), Phi[:, :k]])
        expected = np.linalg.lstsq(A, Y, rcond=None)[0]
        assert_allclose(fits.train_mse[k], np.mean(np.square(Y - A @ expected)), rtol=1e-8)
        assert_allclose(A @ fits.weights[k], A @ expected, rtol=1e-8)
    assert fits.train_mse[1, 0] == pytest.approx(fits.train_mse[2, 0], rel=1e-9)


def test_prefix_fits_weighted_validation_error(columns):
    """``sample_weight_val`` weighs the validation rows (kills its mutants)."""
    x, P = columns
    Y = (x + x**2)[:, None]
    w_val = np.array([1.0, 3.0, 0.5])
    fits = prefix_fits(
        P[:6], Y[:6], Phi_val=P[6:], Y_val=Y[6:], sample_weight_val=w_val, alpha=0.1
    )
    for k in range(4):
        A = np.column_stack([np.ones(3), P[6:, :k]])
        squared = np.square(Y[6:] - A @ fits.weights[k])[:, 0]
        assert fits.val_mse[k, 0] == pytest.approx(w_val @ squared / w_val.sum(), rel=1e-10)
        assert_allclose(fits.val_sq[k], squared, rtol=1e-10)
    unweighted = prefix_fits(P[:6], Y[:6], Phi_val=P[6:], Y_val=Y[6:], alpha=0.1)
    assert not np.allclose(unweighted.val_mse, fits.val_mse)


def test_well_conditioned():
    """The switch between the triangular and the SVD solve (kills its mutants)."""
    assert _well_conditioned(np.eye(3))
    assert _well_conditioned(np.diag([1.0, 1.0, 1e-7]))
    assert not _well_conditioned(np.diag([1.0, 1e-7, 1.0]), max_condition=1e6)
    assert not _well_conditioned(np.diag([1.0, 1.0, 1e-9]))
    assert not _well_conditioned(np.diag([2.0, 1.0, 0.0]))
    assert not _well_conditioned(np.array([[1.0, np.nan], [0.0, 1.0]]))
    assert not _well_conditioned(np.array([[1.0, np.inf], [0.0, 1.0]]))
    assert not _well_conditioned(np.zeros((0, 0)))
    # The ratio of the extreme singular values decides, not the first two.
    assert _well_conditioned(np.diag([100.0, 1.0, 1e-5]))
    assert not _well_conditioned(np.diag([1e9, 1e8, 1.0]))


# -- ols_forward_select -----------------------------------------------------------------


def test_selection_without_a_tail_stops_when_the_target_is_explained(columns):
    """No tail: an exact target of one candidate selects it alone (the stop on a
    negligible error reduction, which returned nothing under a mutant) and counts the
    collinear copy as rejected, not the chosen column (kills ``n_tail`` when ``T`` is
    None, ``return`` for ``break``, ``rejected[selected] = True``)."""
    x, P = columns
    Pd = np.column_stack([P, P[:, 1]])
    path = ols_forward_select(Pd, (3.0 * np.abs(x) ** 3 - 1.0)[:, None])
    assert path.selected.tolist() in ([1], [3])
    assert path.n_rejected == 1
    assert_allclose(path.err, [1.0])
    assert path.tail_err == 0.0
    assert_allclose(path.sse[-1], 0.0, atol=1e-20)


@pytest.mark.parametrize("amplitude", [1e-4, 1e4])
def test_selection_at_any_amplitude(columns, amplitude):
    """Scaling the target (by 1e-4 or 1e4) scales nothing else: the same columns, the same
    error-reduction ratios and the tail's share (kills ``total > 1`` in the loop and in
    ``tail_err``, and a tail column of norm below 1 dropped by ``norm > 1``)."""
    x, P = columns
    T = 1e-3 * x[:, None]
    Y = (np.cos(3 * x) + 0.5 * x + 0.2 * x**2)[:, None]
    reference = ols_forward_select(P, Y, T=T)
    scaled = ols_forward_select(P, amplitude * Y, T=T)
    assert scaled.selected.tolist() == reference.selected.tolist()
    assert_allclose(scaled.err, reference.err, rtol=1e-8)
    atol = 1e-12 * amplitude**2 * reference.sse[0]  # the last is round-off
    assert_allclose(scaled.sse, amplitude**2 * reference.sse, rtol=1e-8, atol=atol)
    assert scaled.tail_err == pytest.approx(reference.tail_err, rel=1e-10)
    # The tail (0.5 x) explains its share: the line's part of the target's variance.
    Yc = Y - Y.mean()
    xc = x - x.mean()
    line = xc * (xc @ Yc[:, 0]) / (xc @ xc)
    assert reference.tail_err == pytest.approx(np.sum(line**2) / np.sum(Yc**2), rel=1e-10)


def test_a_repeated_tail_column_counts_once(columns):
    """A tail column repeated adds nothing: the path is the one with the column once
    (kills ``norm > rtol * ref or norm > 0``, which took the round-off left of the copy as a
    direction)."""
    x, P = columns
    Y = (np.cos(3 * x) + x + 0.3 * np.sin(7 * x))[:, None]
    once = ols_forward_select(P, Y, T=x[:, None])
    twice = ols_forward_select(P, Y, T=np.column_stack([x, x, 2.0 * x]))
    assert twice.selected.tolist() == once.selected.tolist()
    assert_allclose(twice.sse, once.sse, rtol=1e-9)
    assert twice.tail_err == pytest.approx(once.tail_err, rel=1e-12)


def test_collinearity_threshold_is_rtol_of_the_column_norm(columns):
    """A candidate whose part off the other column is 1e-3 of its norm is still chosen;
    at 1e-7 it is rejected (below ``rtol`` = 1e-5). Kills ``rtol**3``, ``rtol * 2`` and
    ``rtol**2 / reference`` in the floor."""
    x, P = columns
    base = P[:, 0]
    off = np.sin(9 * x)
    off -= off @ base / (base @ base) * base
    off /= np.linalg.norm(off)
    norm = np.linalg.norm(base)
    for share, chosen in [(1e-3, True), (1e-7, False)]:
        near = 1e3 * (base + share * norm * off)  # a large column: a floor in its own scale
        Y = (base + 0.5 * off)[:, None]
        path = ols_forward_select(np.column_stack([base, near]), Y)
        assert len(path.selected) == (2 if chosen else 1), share
        assert path.n_rejected == (0 if chosen else 1), share


# -- the other pieces -------------------------------------------------------------------


def test_path_criterion_edges():
    """GCV is infinite from ``dof == n`` on (not only beyond); a perfect fit's log is floored
    at 1e-12 of the first prefix's error; AICc is infinite where ``n - dof - 1 <= 0`` and
    finite at 0 < spare <= 1. Kills the mutants of those edges."""
    fits = PrefixFits([], np.array([[4.0], [1.0], [0.0]]), np.array([1.0, 8.5, 10.0]), None)
    n = 10.0
    gcv = path_criterion(fits, "gcv", n)
    assert gcv[2] == np.inf
    assert gcv[1] == pytest.approx(1.0 / (1 - 8.5 / n) ** 2)
    bic = path_criterion(fits, "bic", n)
    assert bic[2] == pytest.approx(n * np.log(4e-12) + 10.0 * np.log(n))
    aicc = path_criterion(fits, "aicc", n)
    spare = n - 8.5 - 1.0
    assert aicc[1] == pytest.approx(n * np.log(1.0) + 2 * 8.5 + 2 * 8.5 * 9.5 / spare)
    assert aicc[2] == np.inf
    # The floor follows the first prefix's error when it is below 1.
    small = PrefixFits([], np.array([[0.01], [0.0]]), np.array([1.0, 2.0]), None)
    assert path_criterion(small, "bic", n)[1] == pytest.approx(n * np.log(1e-14) + 2.0 * np.log(n))


def test_within_one_standard_error_by_chunks_and_weights():
    """The standard error is that of chunk means of the paired difference (ddof 1, over
    sqrt(chunks)); weights weigh rows; chunks of zero weight are left out; with one chunk
    left only the best is within. Kills the mutants of the chunking, the weights and the
    fallback rule."""
    rng = np.random.default_rng(1)
    base = rng.normal(size=200) ** 2
    step = np.repeat(np.tile([0.2, 0.0], 10), 10)
    losses = np.vstack([base, base + step])
    # Hand computation: 20 chunks of 10 rows.
    chunk = step.reshape(20, 10).mean(axis=1)
    se = chunk.std(ddof=1) / np.sqrt(20)
    within = within_one_standard_error(losses)
    assert within.tolist() == [True, step.mean() <= se]
    assert within_one_standard_error(losses, n_chunks=20).tolist() == within.tolist()
    # A margin just above / below one standard error.
    for margin, inside in [(0.99, True), (1.01, False)]:
        shifted = np.vstack([base, base + step - step.mean() + margin * se])
        assert within_one_standard_error(shifted).tolist() == [True, inside], margin
    # Weights: the rows of zero weight do not count, in means and in chunks.
    weights = np.r_[np.ones(100), np.zeros(100)]
    heavy = np.vstack([base, base + np.r_[np.zeros(100), np.full(100, 50.0)]])
    assert within_one_standard_error(heavy, weights).tolist() == [True, True]
    assert within_one_standard_error(heavy).tolist() == [True, False]
    # Weighted chunk means: rows weighted 3 count three times.
    w = np.tile([3.0, 1.0], 100)
    diff = np.tile([0.0, 1.0], 100) * rng.uniform(0.5, 1.5, 200)
    pair = np.vstack([base, base + diff])
    chunks = (diff * w).reshape(20, 10).sum(axis=1) / w.reshape(20, 10).sum(axis=1)
    mean = diff @ w / w.sum()
    se_w = chunks.std(ddof=1) / np.sqrt(20)
    assert within_one_standard_error(pair, w)[1] == (mean <= se_w)
    assert mean > se_w  # the case is clear-cut
    # Two rows: two chunks of one row each; one row: the best alone.
    assert within_one_standard_error(np.array([[1.0, 1.0], [1.5, 1.5]])).tolist() == [
        True,
        False,
    ]
    assert within_one_standard_error(np.array([[1.0], [1.0], [2.0]])).tolist() == [
        True,
        True,
        False,
    ]


def test_candidate_pool_draws_by_weight():
    """Weights steer the thinned pool (both methods), the random draw has no repeats, and
    a pool exactly ``max_candidates`` large is returned whole. Kills the mutants of the
    pooled weights, ``method == "random"`` and ``replace=False``."""
    Z = np.arange(200.0)[:, None]
    weights = np.r_[np.full(100, 1e-6), np.ones(100)]
    for method in ("kmeans++", "random"):
        pool = candidate_pool(
            Z, sample_weight=weights, max_candidates=20, method=method, random_state=0
        )
        assert len(np.unique(pool)) == 20, method
        assert np.mean(pool >= 100) >= 0.8, method
    # The two methods draw differently from the same seed.
    drawn = [
        candidate_pool(Z, max_candidates=20, method=m, random_state=0).ravel().tolist()
        for m in ("kmeans++", "random")
    ]
    assert drawn[0] != drawn[1]
    assert_array_equal(candidate_pool(Z[:20], max_candidates=20), Z[:20])
    # Duplicated rows pool their weight: a row repeated 50 times is drawn before the others.
    repeated = np.r_[np.full(1000, 7.0), np.arange(100.0, 150.0)][:, None]
    for seed in range(5):
        pool = candidate_pool(repeated, max_candidates=2, method="random", random_state=seed)
        assert 7.0 in pool.ravel()


def test_median_nn_distance_small_and_duplicated():
    """Two candidates have a spacing (kills ``< 3`` and ``<= 2``); the nearest *other*
    candidate counts (kills ``k=3``); a median of 0 (duplicates) gives 1.0 (kills the
    guard's mutants)."""
    assert median_nn_distance(np.array([[0.0], [0.25]])) == 0.25
    assert median_nn_distance(np.array([[0.0], [0.5], [3.0]])) == 0.5
    assert median_nn_distance(np.array([[0.0], [0.0], [0.0], [4.0]])) == 1.0
    assert median_nn_distance(np.array([[0.0], [0.1], [0.3], [0.6]])) == pytest.approx(0.15)


@pytest.mark.parametrize(
    ("n", "fraction", "blocks", "expected"),
    [
        (10, 0.2, 1, [4, 5]),
        (20, 0.2, 2, [4, 5, 14, 15]),
        (12, 0.25, 3, [2, 6, 10]),
        (30, 0.1, 3, [4, 14, 24]),
    ],
)
def test_contiguous_validation_mask_places_each_block_mid_segment(n, fraction, blocks, expected):
    """Each block sits in the middle of its segment (kills edges from 1 and ``/ 3``)."""
    mask = contiguous_validation_mask(n, fraction, blocks)
    assert mask.dtype == bool
    assert mask.nonzero()[0].tolist() == expected


def test_workspace_reuses_an_array_only_while_its_shape_holds():
    """Kills the mutants of :meth:`Workspace.array`."""
    work = Workspace()
    a = work.array("a", (2, 3))
    assert a.shape == (2, 3)
    assert a.dtype == np.float64
    assert work.array("a", [2, 3]) is a
    b = work.array("a", (3, 2))
    assert b is not a
    assert b.shape == (3, 2)
    assert work.array("a", (3, 2)) is b
    assert work.array("b", (3, 2)) is not b
