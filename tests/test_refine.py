"""Tests of the RBF network refinement (sklearn_ifog.rbf._refine and its method modules)."""

import warnings

import numpy as np
import pytest
from sklearn.utils import check_random_state

from sklearn_ifog.rbf import _varpro
from sklearn_ifog.rbf._basis import (
    WIDTH_LIMITS,
    Network,
    gaussian_design,
    n_tail_features,
    predict_network,
    solve_output_weights,
    tail_features,
)
from sklearn_ifog.rbf._lm import full_jacobian, full_residuals
from sklearn_ifog.rbf._refine import refine_network
from sklearn_ifog.rbf._refine_core import WIDTH_RANGE
from sklearn_ifog.rbf._varpro import varpro_jacobian, varpro_residuals

METHODS = ["varpro", "lm", "gd"]
# "gd" is a first-order method: its tests use a learning rate suited to its mini-batches.
LEARNING_RATE = {"varpro": 0.01, "lm": 0.01, "gd": 0.3}


def smooth_problem(n=400, n_outputs=1, seed=0):
    """The issue's smooth function on [-1, 1]^3, standardised inputs."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, size=(n, 3))
    y = np.sin(3 * X[:, 0]) + X[:, 1] * X[:, 2] + 0.5 * np.cos(2 * X[:, 2])
    Y = np.column_stack([y + 0.05 * rng.normal(size=n) for _ in range(n_outputs)])
    Y[:, 1:] *= np.arange(2, n_outputs + 1)  # distinct scales per output
    Z = (X - X.mean(axis=0)) / X.std(axis=0)
    return Z, Y


def starting_network(Z, Y, n_centers=8, width=1.0, tail=True, alpha=0.0, seed=1):
    """A deliberately poor start: random training rows as centres, one fixed width."""
    rng = np.random.default_rng(seed)
    centers = Z[rng.choice(Z.shape[0], n_centers, replace=False)].copy()
    widths = np.full(n_centers, float(width))
    T = Z if tail else Z[:, :0]
    coef, tail_coef, intercept = solve_output_weights(
        gaussian_design(Z, centers, widths), T, Y, alpha=alpha
    )
    return Network(
        centers=centers, widths=widths, coef=coef, tail_coef=tail_coef, intercept=intercept
    )


def loss(Z, Y, network, alpha=0.0, sample_weight=None):
    sw = np.ones(Z.shape[0]) if sample_weight is None else sample_weight
    pred = network.predict(Z)
    return (sw @ np.square(pred - Y).sum(axis=1) + alpha * np.sum(network.coef**2)) / sw.sum()


def assert_same_arrays(got, expected):
    """Every array of two networks equal, field by field."""
    for name in Network._fields:
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name))


def central_difference(fun, theta, step=1e-6):
    columns = []
    for k in range(theta.size):
        delta = np.zeros_like(theta)
        delta[k] = step
        columns.append((fun(theta + delta) - fun(theta - delta)) / (2 * step))
    return np.column_stack(columns)


def assert_relative_close(J, J_fd, rtol=1e-6):
    scale = np.abs(J_fd).max()
    assert np.abs(J - J_fd).max() <= rtol * scale


@pytest.fixture
def jacobian_problem():
    rng = np.random.default_rng(3)
    n, d, K, m = 30, 2, 4, 2
    Z = rng.normal(size=(n, d))
    Y = rng.normal(size=(n, m))
    sample_weight = rng.uniform(0.5, 2.0, n)
    centers = rng.normal(size=(K, d))
    widths = rng.uniform(0.6, 1.5, K)
    return Z, Y, sample_weight, centers, widths


@pytest.mark.parametrize("alpha", [0.0, 0.3])
@pytest.mark.parametrize("tail", [0, 1, 2])
def test_varpro_jacobian_matches_finite_differences(jacobian_problem, alpha, tail):
    Z, Y, sw, centers, widths = jacobian_problem
    K, d = centers.shape

    def residuals(theta):
        return varpro_residuals(
            Z,
            Y,
            theta[: K * d].reshape(K, d),
            np.exp(theta[K * d :]),
            tail=tail,
            sample_weight=sw,
            alpha=alpha,
        )

    theta = np.concatenate([centers.ravel(), np.log(widths)])
    J = varpro_jacobian(Z, Y, centers, widths, tail=tail, sample_weight=sw, alpha=alpha)
    assert J.shape == (Y.shape[1] * (Z.shape[0] + (K if alpha else 0)), K * (d + 1))
    assert_relative_close(J, central_difference(residuals, theta))


def test_kaufman_equals_golub_pereyra_at_zero_residual(jacobian_problem):
    # Kaufman drops the term -(A⁺)ᵀ (∂A)ᵀ r, which vanishes when the residual does.
    Z, _, sw, centers, widths = jacobian_problem
    coef = np.array([[1.0, -2.0, 0.5, 3.0]])
    Y = predict_network(Z, centers, widths, coef, np.array([[0.3, -0.1]]), np.array([2.0]))
    exact = varpro_jacobian(Z, Y, centers, widths, sample_weight=sw)
    kaufman = varpro_jacobian(Z, Y, centers, widths, sample_weight=sw, kaufman=True)
    assert np.abs(varpro_residuals(Z, Y, centers, widths, sample_weight=sw)).max() < 1e-10
    assert_relative_close(kaufman, exact, rtol=1e-8)
    # ... and it is only an approximation when the residual is large.
    Y_noisy = Y + np.random.default_rng(0).normal(size=Y.shape)
    exact = varpro_jacobian(Z, Y_noisy, centers, widths, sample_weight=sw)
    kaufman = varpro_jacobian(Z, Y_noisy, centers, widths, sample_weight=sw, kaufman=True)
    assert np.abs(kaufman - exact).max() > 1e-3 * np.abs(exact).max()


@pytest.mark.parametrize("alpha", [0.0, 0.3])
@pytest.mark.parametrize("tail", [0, 1, 2])
def test_full_jacobian_matches_finite_differences(jacobian_problem, alpha, tail):
    Z, Y, sw, centers, widths = jacobian_problem
    K, d = centers.shape
    m = Y.shape[1]
    rng = np.random.default_rng(4)
    n_tail = n_tail_features(d, tail)
    coef = rng.normal(size=(m, K))
    tail_coef = rng.normal(size=(m, n_tail))
    intercept = rng.normal(size=m)
    sizes = np.cumsum([K * d, K, m * K, m * n_tail])

    def unpack(theta):
        c, lw, w, t, b = np.split(theta, sizes)
        return Network(
            centers=c.reshape(K, d),
            widths=np.exp(lw),
            coef=w.reshape(m, K),
            tail_coef=t.reshape(m, n_tail),
            intercept=b,
        )

    def residuals(theta):
        return full_residuals(Z, Y, unpack(theta), sample_weight=sw, alpha=alpha)

    theta = np.concatenate(
        [centers.ravel(), np.log(widths), coef.ravel(), tail_coef.ravel(), intercept]
    )
    J = full_jacobian(Z, unpack(theta), sample_weight=sw, alpha=alpha)
    assert J.shape == (m * (Z.shape[0] + (K if alpha else 0)), theta.size)
    assert_relative_close(J, central_difference(residuals, theta))


def test_residual_norms_are_the_loss(jacobian_problem):
    Z, Y, sw, centers, widths = jacobian_problem
    alpha = 0.2
    coef, tail_coef, intercept = solve_output_weights(
        gaussian_design(Z, centers, widths), Z, Y, sample_weight=sw, alpha=alpha
    )
    network = Network(
        centers=centers, widths=widths, coef=coef, tail_coef=tail_coef, intercept=intercept
    )
    expected = loss(Z, Y, network, alpha=alpha, sample_weight=sw) * sw.sum()
    r_full = full_residuals(Z, Y, network, sample_weight=sw, alpha=alpha)
    r_varpro = varpro_residuals(Z, Y, centers, widths, sample_weight=sw, alpha=alpha)
    np.testing.assert_allclose(r_full @ r_full, expected, rtol=1e-10)
    # The projected residual is the full one at the ridge-optimal weights.
    np.testing.assert_allclose(r_varpro, r_full, atol=1e-10)


@pytest.mark.parametrize("method", METHODS)
def test_refinement_reduces_training_loss_from_a_poor_start(method):
    """Every method at least halves the training loss of a poor start.

    Checked once on problem seeds 0-9, each with start seed one more (holds on each; "gd"
    ends at 0.14 to 0.50 of the start loss, 0.4997 on seed 9). Rerun on problem seeds 0-39
    (issue 42): "varpro" and "lm" hold on each (at most 0.027 and 0.215 of the start loss,
    the last iterate within 5 % of the best); "gd" halves the loss on 39 of 40 (0.515 at
    worst) and its last mini-batch iterate is within 5 % of its best on 29 of 40 only, so
    that check is for the two deterministic methods (the test runs seed 0).
    """
    Z, Y = smooth_problem()
    start = starting_network(Z, Y, width=0.3)
    result = refine_network(
        Z,
        Y,
        start,
        method=method,
        max_iter=60,
        learning_rate=LEARNING_RATE[method],
        random_state=0,
    )
    start_loss = loss(Z, Y, start)
    final_loss = loss(Z, Y, result.network)
    assert result.improved
    assert final_loss < 0.5 * start_loss
    assert result.history["train_loss"][0] == pytest.approx(start_loss)
    if method != "gd":
        assert result.history["train_loss"][-1] == pytest.approx(
            min(result.history["train_loss"]), rel=0.05
        )
    assert len(result.history["train_loss"]) == result.n_iter + 1
    assert result.history["val_loss"] == []


def test_varpro_with_subspace_trust_region_steps(monkeypatch):
    # Large problems take least_squares' LSMR steps instead of exact ones: force that path.
    """Checked once on problem seeds 0-9, each with start seed one more (holds on each)."""
    Z, Y = smooth_problem()
    start = starting_network(Z, Y, width=0.3)
    exact = refine_network(Z, Y, start, method="varpro", max_iter=30, random_state=0)
    monkeypatch.setattr(_varpro, "EXACT_TRUST_REGION_MAX_ENTRIES", 0)
    subspace = refine_network(Z, Y, start, method="varpro", max_iter=30, random_state=0)
    assert not np.array_equal(subspace.network.centers, exact.network.centers)
    assert loss(Z, Y, subspace.network) < 0.5 * loss(Z, Y, start)


@pytest.mark.parametrize("method", METHODS)
def test_quadratic_tail(method):
    """Checked once on problem seeds 0-9, each with start seed one more (holds on each)."""
    Z, Y = smooth_problem()
    start = starting_network(Z, Y, width=0.3)
    coef, tail_coef, intercept = solve_output_weights(
        gaussian_design(Z, start.centers, start.widths), tail_features(Z, 2), Y
    )
    start = start._replace(coef=coef, tail_coef=tail_coef, intercept=intercept)
    # The quadratic columns are larger than the inputs: "gd" needs a smaller step.
    result = refine_network(
        Z, Y, start, method=method, max_iter=30, learning_rate=0.1, random_state=0
    )
    assert result.network.tail_coef.shape == (1, 9)
    assert result.improved
    assert loss(Z, Y, result.network) < loss(Z, Y, start)


@pytest.mark.parametrize("method", METHODS)
def test_early_stopping_never_worse_on_validation(method):
    Z, Y = smooth_problem(n=500)
    Z_train, Y_train, Z_val, Y_val = Z[:350], Y[:350], Z[350:], Y[350:]
    start = starting_network(Z_train, Y_train, n_centers=10, width=0.3)
    result = refine_network(
        Z_train,
        Y_train,
        start,
        method=method,
        Z_val=Z_val,
        Y_val=Y_val,
        max_iter=40,
        learning_rate=LEARNING_RATE[method],
        random_state=0,
    )
    start_val = loss(Z_val, Y_val, start)
    final_val = loss(Z_val, Y_val, result.network)
    assert final_val <= start_val
    assert result.history["val_loss"][0] == pytest.approx(start_val)
    # The returned network is the best iterate by validation loss.
    assert final_val <= min(result.history["val_loss"]) * (1 + 1e-9)
    assert result.improved == (final_val < start_val)


@pytest.mark.parametrize("method", METHODS)
def test_falls_back_to_the_start_when_nothing_improves(method):
    Z, Y = smooth_problem(n=300)
    start = starting_network(Z, Y, width=0.5)
    # Validation targets that the starting network fits exactly: nothing can beat it.
    Z_val = Z[:100] + 0.1
    Y_val = start.predict(Z_val)
    result = refine_network(
        Z, Y, start, method=method, Z_val=Z_val, Y_val=Y_val, max_iter=10, random_state=0
    )
    assert not result.improved
    for name in Network._fields:
        got, expected = getattr(result.network, name), getattr(start, name)
        np.testing.assert_array_equal(got, expected)
        assert got is not expected


def test_converged_false_when_stopped_by_max_iter():
    Z, Y = smooth_problem()
    start = starting_network(Z, Y, width=3.0)
    for method in METHODS:
        result = refine_network(Z, Y, start, method=method, max_iter=2, tol=0.0, random_state=0)
        assert result.n_iter == 2
        assert not result.converged


@pytest.mark.parametrize("method", METHODS)
def test_deterministic(method):
    Z, Y = smooth_problem(n=600)
    start = starting_network(Z, Y)
    kwargs = dict(
        method=method,
        Z_val=Z[:100],
        Y_val=Y[:100],
        max_iter=8,
        max_samples=400,
        learning_rate=LEARNING_RATE[method],
    )
    first = refine_network(Z, Y, start, random_state=7, **kwargs)
    second = refine_network(Z, Y, start, random_state=7, **kwargs)
    assert_same_arrays(first.network, second.network)
    assert first.history == second.history


def _multi_output_refinement(method, seed):
    """Refine a poor start on two outputs of different scales (problem seed `seed`, start
    seed one more); return the loss ratio, refined over start."""
    Z, Y = smooth_problem(n_outputs=2, seed=seed)
    start = starting_network(Z, Y, width=0.3, seed=seed + 1)
    result = refine_network(
        Z,
        Y,
        start,
        method=method,
        max_iter=30,
        learning_rate=LEARNING_RATE[method],
        random_state=0,
    )
    assert result.network.coef.shape == (2, 8)
    assert result.network.tail_coef.shape == (2, 3)
    assert result.network.intercept.shape == (2,)
    return loss(Z, Y, result.network) / loss(Z, Y, start)


@pytest.mark.parametrize("seed", range(10))
@pytest.mark.parametrize("method", ["varpro", "lm"])
def test_multi_output(method, seed):
    """Two outputs of different scales: the refinement cuts the loss by 30 % or more.

    On problem seeds 0-9, each with start seed one more. "lm" used to stop on seed 6 after
    two iterations, far above the bound: its second step, accepted only after the damping
    had been raised by orders of magnitude (a poorly conditioned JᵀJ), gained almost
    nothing, and its stopping rule took that small gain for convergence. A small gain now
    counts only at a step near Gauss-Newton's (damping at most 1); this test fails on seed 6
    with the earlier rule. Holds on all 380 problem seeds checked (0-19 + 1000 k,
    k = 0-18): worst ratio 0.464 for "lm", 0.167 for "varpro". ("gd", a stochastic
    first-order method, is held to a rate in `test_multi_output_gd_rate`.)
    """
    assert _multi_output_refinement(method, seed) < 0.7


def test_multi_output_gd_rate():
    """Two outputs, method "gd": 30 iterations of mini-batch descent cut the loss by 30 % or
    more on most problems, and by a good part on every one.

    Measured on 380 problem seeds (0-19 + 1000 k, k = 0-18; random_state 0): ratio below
    0.7 on 98.9 % (at most 1 of any 20; median 0.32, worst 0.770 on seed 11019; 0.737 on
    1003, 0.717 on 3003, which failed the earlier per-seed check). Asserted on seeds 0-19:
    below 0.7 on at least 95 %, and below 0.85 on each.
    """
    ratios = []
    for seed in range(20):
        ratio = _multi_output_refinement("gd", seed)
        assert ratio < 0.85, (seed, ratio)
        ratios.append(ratio)
    assert np.mean(np.array(ratios) < 0.7) >= 0.95


def test_identical_outputs_get_identical_weights():
    Z, Y = smooth_problem()
    Y2 = np.hstack([Y, Y])
    start = starting_network(Z, Y2, width=3.0)
    for method in ("varpro", "lm"):
        result = refine_network(Z, Y2, start, method=method, max_iter=10, random_state=0)
        np.testing.assert_allclose(
            result.network.coef[0], result.network.coef[1], rtol=1e-7, atol=1e-9
        )


@pytest.mark.parametrize("method", ["varpro", "lm"])
def test_integer_weights_equal_duplicated_rows(method):
    Z, Y = smooth_problem(n=200)
    sw = np.tile([1.0, 2.0], 100)
    start = starting_network(Z, Y, width=2.0)
    weighted = refine_network(
        Z, Y, start, method=method, sample_weight=sw, max_iter=3, random_state=0
    )
    rows = np.repeat(np.arange(200), sw.astype(int))
    duplicated = refine_network(Z[rows], Y[rows], start, method=method, max_iter=3, random_state=0)
    for name in Network._fields:
        np.testing.assert_allclose(
            getattr(weighted.network, name),
            getattr(duplicated.network, name),
            rtol=1e-6,
            atol=1e-8,
        )


def test_max_samples_refines_on_the_documented_subsample():
    Z, Y = smooth_problem(n=2000)
    start = starting_network(Z, Y)
    result = refine_network(Z, Y, start, method="lm", max_iter=1, max_samples=150, random_state=5)
    rows = np.sort(check_random_state(5).choice(2000, size=150, replace=False))
    assert result.history["train_loss"][0] == pytest.approx(loss(Z[rows], Y[rows], start))
    assert result.history["train_loss"][0] != pytest.approx(loss(Z, Y, start))


@pytest.mark.parametrize("method", METHODS)
def test_widths_stay_within_bounds(method):
    Z, Y = smooth_problem()
    start = starting_network(Z, Y, width=5e-3)
    result = refine_network(
        Z,
        Y,
        start,
        method=method,
        max_iter=20,
        learning_rate=LEARNING_RATE[method],
        random_state=0,
    )
    assert np.all(result.network.widths >= WIDTH_LIMITS[0] * (1 - 1e-12))
    assert np.all(result.network.widths <= 5e-3 * WIDTH_RANGE * (1 + 1e-12))


def nasty_cases():
    Z, Y = smooth_problem(n=120)
    duplicated_Z = np.repeat(Z[:30], 4, axis=0)
    duplicated_Y = np.repeat(Y[:30], 4, axis=0)
    return {
        "duplicate rows": (duplicated_Z, duplicated_Y, 1.0),
        "near-zero widths": (Z, Y, 1e-8),
        "huge widths": (Z, Y, 1e8),
        "constant target": (Z, np.full_like(Y, 3.5), 1.0),
        "constant feature": (np.column_stack([Z[:, :2], np.zeros(120)]), Y, 1.0),
    }


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", list(nasty_cases()))
def test_nasty_inputs_give_finite_networks(method, case):
    Z, Y, width = nasty_cases()[case]
    # Centres on duplicated rows make the design rank deficient.
    centers = np.vstack([Z[:4], Z[:2]])
    widths = np.full(6, width)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the start itself may be degenerate
        coef, tail_coef, intercept = solve_output_weights(
            gaussian_design(Z, centers, widths), Z, Y
        )
    start = Network(
        centers=centers, widths=widths, coef=coef, tail_coef=tail_coef, intercept=intercept
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = refine_network(
            Z,
            Y,
            start,
            method=method,
            Z_val=Z[::3],
            Y_val=Y[::3],
            max_iter=15,
            learning_rate=LEARNING_RATE[method],
            random_state=0,
        )
        for name in Network._fields:
            assert np.all(np.isfinite(getattr(result.network, name)))
        assert np.all(np.isfinite(result.network.predict(Z)))
    assert np.all(np.isfinite(result.history["train_loss"]))
    assert loss(Z[::3], Y[::3], result.network) <= loss(Z[::3], Y[::3], start) + 1e-12


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("scale", [1e-6, 1e6])
def test_units_of_the_target_do_not_matter(method, scale):
    Z, Y = smooth_problem()
    start = starting_network(Z, Y, width=0.3)
    scaled_start = start._replace(
        coef=start.coef * scale,
        tail_coef=start.tail_coef * scale,
        intercept=start.intercept * scale,
    )
    kwargs = dict(method=method, max_iter=10, learning_rate=LEARNING_RATE[method], random_state=0)
    plain = refine_network(Z, Y, start, **kwargs)
    scaled = refine_network(Z, Y * scale, scaled_start, **kwargs)
    assert plain.n_iter == scaled.n_iter
    np.testing.assert_allclose(scaled.network.centers, plain.network.centers, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(scaled.network.widths, plain.network.widths, rtol=1e-6)
    np.testing.assert_allclose(
        scaled.network.coef, plain.network.coef * scale, rtol=1e-6, atol=1e-8 * scale
    )
    np.testing.assert_allclose(
        scaled.history["train_loss"],
        np.multiply(plain.history["train_loss"], scale**2),
        rtol=1e-6,
    )


@pytest.mark.parametrize("method", METHODS)
def test_network_without_gaussian_units(method):
    Z, Y = smooth_problem(n=200)
    result = refine_network(
        Z,
        Y,
        Network(
            centers=np.zeros((0, 3)),
            widths=np.zeros(0),
            coef=np.zeros((1, 0)),
            tail_coef=np.zeros((1, 3)),
            intercept=np.zeros(1),
        ),
        method=method,
        Z_val=Z[:50],
        Y_val=Y[:50],
        max_iter=5,
        learning_rate=LEARNING_RATE[method],
        random_state=0,
    )
    assert result.network.centers.shape == (0, 3)
    assert result.network.coef.shape == (1, 0)
    assert np.all(np.isfinite(result.network.tail_coef))
    assert result.history["val_loss"][-1] <= result.history["val_loss"][0]


def test_one_dimensional_target_is_accepted():
    Z, Y = smooth_problem(n=200)
    start = starting_network(Z, Y)
    one_d = refine_network(Z, Y[:, 0], start, method="varpro", max_iter=3, random_state=0)
    two_d = refine_network(Z, Y, start, method="varpro", max_iter=3, random_state=0)
    np.testing.assert_array_equal(one_d.network.centers, two_d.network.centers)
    assert one_d.network.coef.shape == (1, 8)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"method": "newton"}, "method must be one of"),
        ({"Y": np.zeros((5, 1))}, "Y has 5 rows"),
        ({"widths": np.zeros(8)}, "widths must be 8 positive"),
        ({"coef": np.zeros((2, 8))}, r"coef must have shape \(1, 8\)"),
        ({"tail_coef": np.zeros((1, 2))}, "tail_coef must have shape"),
        ({"Z_val": np.zeros((3, 3))}, "Z_val and Y_val must be given together"),
        ({"sample_weight": -np.ones(200)}, "sample_weight must be finite, non-negative"),
        ({"max_samples": 0}, "max_samples must be a positive integer"),
        ({"alpha": -1.0}, "alpha must be a finite non-negative"),
        ({"Z": np.full((200, 3), np.nan)}, "Z contains NaN"),
    ],
)
def test_bad_input_raises(change, match):
    Z, Y = smooth_problem(n=200)
    start = starting_network(Z, Y)
    network_change = {key: change.pop(key) for key in Network._fields if key in change}
    kwargs = dict(Z=Z, Y=Y, network=start._replace(**network_change), method="lm")
    kwargs.update(change)
    with pytest.raises(ValueError, match=match):
        refine_network(**kwargs)
