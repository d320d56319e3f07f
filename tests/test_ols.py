"""Orthogonal-least-squares selection and the output-weight solves (plain functions)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from sklearn_ifog._statistics import within_one_standard_error
from sklearn_ifog.rbf import _basis
from sklearn_ifog.rbf._basis import (
    gaussian_design,
    guarded_lstsq,
    solve_output_weights,
    solve_output_weights_chunked,
)
from sklearn_ifog.rbf._ols import (
    PrefixFits,
    candidate_pool,
    contiguous_validation_mask,
    median_nn_distance,
    ols_forward_select,
    path_criterion,
    prefix_fits,
)


def _lstsq_sse(columns, Y, sw):
    """Weighted residual sum of squares of the least-squares fit with an intercept."""
    A = np.column_stack([np.ones(Y.shape[0]), *columns]) if columns else np.ones((len(Y), 1))
    root = np.sqrt(sw)[:, None]
    W = np.linalg.lstsq(A * root, Y * root, rcond=None)[0]
    return float(np.sum(sw[:, None] * np.square(Y - A @ W)))


def _brute_force_greedy(P, Y, T, sw, n_steps):
    """Greedy selection by exhaustive refits: at each step the column whose addition gives
    the smallest residual sum of squares."""
    chosen = []
    base = list(T.T)
    for _ in range(n_steps):
        remaining = [j for j in range(P.shape[1]) if j not in chosen]
        sse = [_lstsq_sse(base + [P[:, c] for c in [*chosen, j]], Y, sw) for j in remaining]
        chosen.append(remaining[int(np.argmin(sse))])
    return chosen


@pytest.fixture
def tiny():
    rng = np.random.default_rng(3)
    Z = rng.normal(size=(40, 2))
    Y = np.column_stack([np.sin(2 * Z[:, 0]) + Z[:, 1] ** 2, np.cos(Z[:, 1])])
    Y += 0.05 * rng.normal(size=Y.shape)
    P = gaussian_design(Z, Z[::3], 0.8)
    sw = rng.integers(1, 4, size=40).astype(float)
    return Z, Y, P, sw


def test_greedy_order_equals_brute_force(tiny):
    Z, Y, P, sw = tiny
    path = ols_forward_select(P, Y, T=Z, sample_weight=sw, max_selected=6)
    assert_array_equal(path.selected, _brute_force_greedy(P, Y, Z, sw, 6))


def test_sse_and_err_match_refits(tiny):
    Z, Y, P, sw = tiny
    path = ols_forward_select(P, Y, T=Z, sample_weight=sw, max_selected=5)
    for k in range(6):
        columns = list(Z.T) + [P[:, j] for j in path.selected[:k]]
        assert_allclose(path.sse[k], _lstsq_sse(columns, Y, sw), rtol=1e-9)
    total = _lstsq_sse([], Y, sw)
    # Error-reduction ratios partition the explained variance.
    assert_allclose(path.tail_err + path.err.sum(), 1 - path.sse[-1] / total, rtol=1e-9)
    assert_allclose(path.err, -np.diff(path.sse) / total, rtol=1e-9)


def test_regularised_err_penalises_weak_columns(tiny):
    Z, Y, P, sw = tiny
    plain = ols_forward_select(P, Y, T=Z, sample_weight=sw, max_selected=5)
    ridge = ols_forward_select(P, Y, T=Z, sample_weight=sw, max_selected=5, alpha=1e3)
    # The ridge term shrinks every ratio; the first choice explains the most either way.
    assert np.all(ridge.err < plain.err[: len(ridge.err)] + 1e-12)
    assert ridge.err[0] < plain.err[0]


def test_collinear_candidates_never_selected():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(60, 1))
    base = gaussian_design(x, np.array([[-0.5], [0.0], [0.5]]), 0.4)
    P = np.column_stack(
        [
            base,
            base[:, 0],  # exact duplicate of column 0
            base[:, 1] * (1 + 1e-9 * rng.normal(size=60)),  # duplicate up to round-off
            0.3 * base[:, 0] - 2.0 * base[:, 2],  # combination of two others
            np.full(60, 0.7),  # constant: collinear with the intercept
            2.0 * x[:, 0] + 1.0,  # affine: collinear with the tail
        ]
    )
    y = np.sin(3 * x) + 0.1 * rng.normal(size=(60, 1))
    path = ols_forward_select(P, y, T=x, max_selected=P.shape[1])
    chosen = set(path.selected.tolist())
    # Of each collinear group at most the independent part is chosen, and the selection
    # does not run out of candidates before rejecting the rest.
    assert len(chosen & {0, 3}) <= 1
    assert len(chosen & {1, 4}) <= 1
    assert len(chosen & {0, 2, 5}) <= 2
    assert not chosen & {6, 7}
    assert path.n_rejected >= 4
    design = np.column_stack([np.ones(60), x, P[:, path.selected]])
    assert np.linalg.cond(design) < 1e5


def test_constant_target_selects_nothing(tiny):
    Z, _, P, sw = tiny
    path = ols_forward_select(P, np.full((40, 1), 3.5), T=Z, sample_weight=sw)
    assert path.selected.size == 0
    assert path.tail_err == 0.0


def test_prefix_weights_equal_lstsq(tiny):
    Z, Y, P, sw = tiny
    Phi = P[:, [4, 1, 7]]
    fits = prefix_fits(Phi, Y, T=Z, sample_weight=sw)
    root = np.sqrt(sw)[:, None]
    for k in range(4):
        A = np.column_stack([np.ones(40), Z, Phi[:, :k]])
        expected = np.linalg.lstsq(A * root, Y * root, rcond=None)[0]
        assert_allclose(fits.weights[k], expected, rtol=1e-8, atol=1e-10)
        assert_allclose(fits.dof[k], 3 + k, rtol=1e-10)
        residual = Y - A @ expected
        assert_allclose(fits.train_mse[k], sw @ np.square(residual) / sw.sum(), rtol=1e-9)


def test_prefix_ridge_matches_solve_output_weights(tiny):
    Z, Y, P, sw = tiny
    Phi = P[:, [4, 1, 7, 9]]
    alpha = 2.5
    fits = prefix_fits(Phi, Y, T=Z, sample_weight=sw, alpha=alpha)
    coef, tail, intercept = solve_output_weights(Phi, Z, Y, sample_weight=sw, alpha=alpha)
    W = fits.weights[4]
    assert_allclose(W[0], intercept, rtol=1e-8)
    assert_allclose(W[1:3].T, tail, rtol=1e-8)
    assert_allclose(W[3:].T, coef, rtol=1e-8)
    # Ridge shrinks the degrees of freedom below the column count.
    assert 3 < fits.dof[4] < 7


def test_prefix_validation_error(tiny):
    Z, Y, P, _ = tiny
    fits = prefix_fits(
        P[:30, :3], Y[:30], T=Z[:30], Phi_val=P[30:, :3], T_val=Z[30:], Y_val=Y[30:]
    )
    A = np.column_stack([np.ones(10), Z[30:], P[30:, :2]])
    expected = np.mean(np.square(Y[30:] - A @ fits.weights[2]), axis=0)
    assert_allclose(fits.val_mse[2], expected, rtol=1e-10)
    assert_allclose(fits.val_sq[2], np.square(Y[30:] - A @ fits.weights[2]).sum(axis=1))


def test_path_criteria_formulas():
    mse = np.array([[2.0], [1.0], [0.9]])
    dof = np.array([1.0, 3.0, 9.0])
    fits = PrefixFits([], mse, dof, np.array([[3.0], [1.5], [2.0]]))
    n = 10.0
    assert_allclose(path_criterion(fits, "gcv", n), mse[:, 0] / (1 - dof / n) ** 2)
    assert_allclose(path_criterion(fits, "bic", n), n * np.log(mse[:, 0]) + dof * np.log(n))
    aicc = path_criterion(fits, "aicc", n)
    assert_allclose(
        aicc[:2],
        n * np.log(mse[:2, 0]) + 2 * dof[:2] + 2 * dof[:2] * (dof[:2] + 1) / (n - dof[:2] - 1),
    )
    assert aicc[2] == np.inf  # n - dof - 1 = 0
    assert_allclose(path_criterion(fits, "holdout", n), [3.0, 1.5, 2.0])
    with pytest.raises(ValueError, match="criterion must be one of"):
        path_criterion(fits, "aic", n)


def test_candidate_pool_distinct_positive_weight_rows():
    Z = np.array([[0.0, 1.0], [2.0, 2.0], [0.0, 1.0], [5.0, 5.0], [3.0, 1.0]])
    sw = np.array([1.0, 0.0, 2.0, 1.0, 1.0])
    pool = candidate_pool(Z, sample_weight=sw)
    assert_array_equal(pool, [[0.0, 1.0], [3.0, 1.0], [5.0, 5.0]])


@pytest.mark.parametrize("method", ["kmeans++", "random"])
def test_candidate_pool_thinned_deterministically(method):
    rng = np.random.default_rng(0)
    Z = rng.normal(size=(500, 3))
    first = candidate_pool(Z, max_candidates=40, method=method, random_state=7)
    again = candidate_pool(Z, max_candidates=40, method=method, random_state=7)
    other = candidate_pool(Z, max_candidates=40, method=method, random_state=8)
    assert first.shape == (40, 3)
    assert_array_equal(first, again)
    assert not np.array_equal(first, other)
    # Every candidate is a training row.
    assert all(np.any(np.all(c == Z, axis=1)) for c in first)


def test_median_nn_distance():
    C = np.array([[0.0, 0.0], [0.0, 1.0], [0.0, 3.0], [10.0, 0.0]])
    # Nearest neighbours: 1, 1, 2, 10.
    assert median_nn_distance(C) == 1.5
    assert median_nn_distance(C[:1]) == 1.0


@pytest.mark.parametrize(
    ("n", "fraction", "blocks"), [(100, 0.2, 2), (1000, 0.1, 5), (37, 0.3, 3)]
)
def test_contiguous_validation_mask(n, fraction, blocks):
    mask = contiguous_validation_mask(n, fraction, blocks)
    assert mask.sum() == round(fraction * n)
    starts = np.flatnonzero(np.diff(mask.astype(int)) == 1)
    assert len(starts) == blocks  # one run of True per block, none touching the ends
    assert not mask[0]
    assert not mask[-1]


def test_within_one_standard_error():
    noise = np.random.default_rng(0).normal(size=2000) ** 2
    # Chunk means of the difference to model 0: 0.001 +- 0.01, so the standard error
    # (0.0023) exceeds the mean difference; model 2 is worse by a constant 1.
    wobble = np.repeat(0.001 + 0.01 * (-1.0) ** np.arange(20), 100)
    losses = np.vstack([noise, noise + wobble, noise + 1.0])
    assert within_one_standard_error(losses, n_chunks=20).tolist() == [True, True, False]
    # Weight only on odd chunks: model 1 is better everywhere by a constant 0.009.
    weights = np.repeat(np.arange(20) % 2, 100).astype(float)
    assert within_one_standard_error(losses, weights, n_chunks=20).tolist() == [False, True, False]


@pytest.mark.parametrize("chunk_rows", [7, 64, None])
def test_chunked_solve_equals_direct_solve(tiny, chunk_rows):
    Z, Y, _, sw = tiny
    centers, widths = Z[:6], np.linspace(0.5, 1.5, 6)
    Phi = gaussian_design(Z, centers, widths)
    direct = solve_output_weights(Phi, Z, Y, sample_weight=sw, alpha=0.3)
    chunked = solve_output_weights_chunked(
        Z, Y, centers, widths, sample_weight=sw, alpha=0.3, chunk_rows=chunk_rows
    )
    for a, b in zip(direct, chunked, strict=True):
        assert_allclose(a, b, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("tail_alpha", [0.0, 0.2])
def test_chunked_solve_gram_and_qr_agree(tiny, monkeypatch, tail_alpha):
    # A well-conditioned design: the Gram (Cholesky) factor and the tall-skinny QR give
    # the same weights; forcing the QR (a limit below any condition number) changes nothing.
    Z, Y, _, sw = tiny
    centers, widths = Z[:6], np.linspace(0.5, 1.5, 6)
    args = dict(sample_weight=sw, alpha=0.3, tail_alpha=tail_alpha, chunk_rows=16)
    gram = solve_output_weights_chunked(Z, Y, centers, widths, **args)
    monkeypatch.setattr(_basis, "GRAM_CONDITION_LIMIT", 0.0)
    qr = solve_output_weights_chunked(Z, Y, centers, widths, **args)
    for a, b in zip(gram, qr, strict=True):
        assert_allclose(a, b, rtol=1e-9, atol=1e-12)


def test_chunked_solve_ill_conditioned_keeps_qr_accuracy(monkeypatch):
    # Wide, overlapping Gaussians make a design conditioned near 2e7: the normal equations
    # square that, so the solve must take the QR and match a direct least-squares solve of
    # the whole design; the Gram factor forced on it (no limit) does visibly worse.
    rng = np.random.default_rng(5)
    Z = rng.uniform(-1, 1, size=(3000, 1))
    centers = np.linspace(-1, 1, 6)[:, None]
    widths = np.full(6, 1.2)
    y = np.sin(3 * Z[:, 0]) + 0.01 * rng.normal(size=3000)
    design = np.column_stack([np.ones(3000), Z, gaussian_design(Z, centers, widths)])
    assert np.linalg.cond(design) > 100 * _basis.GRAM_CONDITION_LIMIT
    exact = np.linalg.lstsq(design, y, rcond=None)[0]

    def relative_error():
        coef, tail, intercept = solve_output_weights_chunked(
            Z, y[:, None], centers, widths, chunk_rows=500
        )
        found = np.r_[intercept, tail[0], coef[0]]
        return np.linalg.norm(found - exact) / np.linalg.norm(exact)

    assert relative_error() < 1e-7
    monkeypatch.setattr(_basis, "GRAM_CONDITION_LIMIT", np.inf)
    assert relative_error() > 1e-6


def test_chunked_solve_rank_deficient_is_finite(tiny):
    Z, Y, _, _ = tiny
    Z = np.column_stack([Z, np.zeros(40)])  # a constant (zero) feature in the tail
    centers = np.vstack([Z[:3], Z[:3]])  # every centre twice
    coef, tail, intercept = solve_output_weights_chunked(Z, Y, centers, np.ones(6))
    assert np.all(np.isfinite(coef))
    assert np.all(np.isfinite(intercept))
    assert_allclose(tail[:, 2], 0.0, atol=1e-12)
    # Minimum-norm: duplicated centres share their weight equally.
    assert_allclose(coef[:, :3], coef[:, 3:], rtol=1e-6)


def test_guarded_lstsq_rejects_non_finite():
    with pytest.raises(ValueError, match="Non-finite"):
        guarded_lstsq(np.array([[np.nan]]), np.array([[1.0]]))
    assert_array_equal(guarded_lstsq(np.zeros((2, 2)), np.ones((2, 1))), np.zeros((2, 1)))
