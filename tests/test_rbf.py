"""RBFNetRegressor: the network formula, selection choices, weights, robustness, persistence."""

import ast
import dataclasses
import io
import itertools
import re
import warnings
from pathlib import Path

import joblib
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from sklearn.exceptions import ConvergenceWarning, NotFittedError
from sklearn.linear_model import LinearRegression
from sklearn.preprocessing import PolynomialFeatures

from sklearn_ifog import RBFNetRegressor
from sklearn_ifog.rbf import _network as network_module
from sklearn_ifog.rbf._basis import (
    gaussian_design,
    n_tail_features,
    predict_network,
    tail_features,
)
from sklearn_ifog.rbf._layer import network_of
from sklearn_ifog.rbf._ols import width_grid
from sklearn_ifog.rbf._select import WIDTH_MULTIPLES


def _smooth(n, seed=0, noise=0.05):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, size=(n, 3))
    f = np.sin(3 * X[:, 0]) + X[:, 1] * X[:, 2] + 0.5 * np.cos(2 * X[:, 2])
    return X, f + noise * rng.normal(size=n), f


def _formula(model, X):
    """The contract's prediction formula, written out from the fitted attributes."""
    Z = (X - model.x_mean_) / model.x_scale_
    D2 = ((Z[:, None, :] - model.centers_[None]) ** 2).sum(axis=2)
    Phi = np.exp(-D2 / (2 * model.widths_**2))
    # Degree 0 keeps a zero linear tail (the export contract); degree 2 is sklearn's ordering.
    T = (
        PolynomialFeatures(2, include_bias=False).fit_transform(Z)
        if model.tail_degree_ == 2
        else Z
    )
    return Phi @ model.coef_.T + T @ model.tail_coef_.T + model.intercept_


@pytest.fixture(scope="module")
def smooth_model():
    X, y, _ = _smooth(600)
    return RBFNetRegressor(refine=None, random_state=0).fit(X, y), X, y


def test_prediction_follows_contract_formula(smooth_model):
    model, X, _ = smooth_model
    X_new = np.random.default_rng(5).uniform(-2, 2, size=(50, 3))
    assert_allclose(model.predict(X_new), _formula(model, X_new), rtol=1e-10, atol=1e-12)
    assert model.centers_.shape == (model.widths_.shape[0], 3)
    assert model.coef_.shape == model.widths_.shape
    assert model.tail_coef_.shape == (n_tail_features(3, model.tail_degree_),)
    assert isinstance(model.intercept_, float)
    assert_allclose(model.x_mean_, X.mean(axis=0))
    assert_allclose(model.x_scale_, X.std(axis=0))


def test_parameters_are_keyword_only():
    with pytest.raises(TypeError, match="positional"):
        RBFNetRegressor(10)
    assert RBFNetRegressor(n_centers=10).n_centers == 10


@pytest.mark.parametrize("n_outputs", [1, 2])
def test_fitted_network_value_is_what_predict_evaluates(n_outputs):
    X, y, _ = _smooth(300, seed=2)
    Y = y if n_outputs == 1 else np.column_stack([y, 2 * y - X[:, 0]])
    model = RBFNetRegressor(refine=None, tail="linear", random_state=0).fit(X, Y)
    network = network_of(model)
    assert network.coef.shape == (n_outputs, model.widths_.shape[0])
    assert network.tail_coef.shape == (n_outputs, 3)
    assert network.intercept.shape == (n_outputs,)
    assert network.tail_degree == model.tail_degree_ == 1
    X_new = np.random.default_rng(6).uniform(-1.5, 1.5, size=(40, 3))
    Z_new = (X_new - model.x_mean_) / model.x_scale_
    expected = network.predict(Z_new)
    assert_array_equal(model.predict(X_new), expected[:, 0] if n_outputs == 1 else expected)
    # The record's fields are predict_network's arguments, by name.
    assert_array_equal(predict_network(Z_new, **network._asdict()), expected)


def test_network_of_an_unfitted_regressor_raises():
    with pytest.raises(NotFittedError):
        network_of(RBFNetRegressor())


def test_fit_options_hold_every_parameter_by_name():
    """The record the estimator hands to the numerics is its parameters, none dropped."""
    params = dict(
        n_centers=7,
        width=0.5,
        refine="lm",
        alpha=0.1,
        tail_alpha="auto",
        tail_penalty="ridge",
        criterion="bic",
        goal=0.2,
        tail="quadratic",
        max_candidates=30,
        candidates="random",
        max_samples=50,
        validation_fraction=0.3,
        max_iter=3,
        tol=1e-3,
        learning_rate=0.2,
        random_state=4,
    )
    model = RBFNetRegressor(**params)
    assert set(params) == set(model.get_params())  # every parameter has a non-default above
    options = model._fit_options()
    assert {f.name: getattr(options, f.name) for f in dataclasses.fields(options)} == params
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.alpha = 1.0


@pytest.mark.parametrize("refine", ["varpro", None])
def test_selection_path_has_the_documented_keys_in_order(refine):
    X, y, _ = _smooth(300)
    model = RBFNetRegressor(refine=refine, random_state=0).fit(X, y)
    keys = list(model.selection_path_)
    refined = ["refine_rejected", "refined"] if refine else ["refined"]
    assert keys == [
        "err",
        "tail_err",
        "train_mse",
        "val_mse",
        "dof",
        "criterion",
        "criterion_name",
        "n_centers",
        "widths_tried",
        "width_scores",
        "tail_alpha",
        "tail_alphas_tried",
        "tail_transform",
        "tail_degree",
        "tail_scores",
        *refined,
    ]
    assert model.selection_path_["tail_degree"] == model.tail_degree_


# Names that hold a Network (or FittedNetwork) in sklearn_ifog/rbf, and the functions that
# return one: what must never be unpacked or splatted by position there.
_NETWORK_NAMES = re.compile(r"network|^net$|^start$|^original$|^candidate$|^_unpack$", re.I)


def _holds_a_network(node):
    if isinstance(node, ast.Name):
        return bool(_NETWORK_NAMES.search(node.id))
    if isinstance(node, ast.Attribute):
        return bool(_NETWORK_NAMES.search(node.attr))
    if isinstance(node, ast.Call):
        return _holds_a_network(node.func)
    return False


def _positional_network_reads(source):
    """Lines of ``source`` that splat, unpack or iterate a network by position."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Starred) and _holds_a_network(node.value):
            lines.append(node.lineno)
        elif isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Tuple):
            if _holds_a_network(node.value):
                lines.append(node.lineno)
        elif isinstance(node, (ast.For, ast.comprehension)) and _holds_a_network(node.iter):
            lines.append(getattr(node, "lineno", getattr(node.iter, "lineno", 0)))
    return lines


def test_network_records_are_read_by_name_in_rbf():
    offenders = {
        path.name: lines
        for path in sorted(Path(network_module.__file__).parent.glob("*.py"))
        if (lines := _positional_network_reads(path.read_text()))
    }
    assert offenders == {}
    # The check itself catches the forms it is for.
    for bad in (
        "predict_network(Z, *network)",
        "y = f(Z, *self._fitted_network())",
        "centers, widths, coef, tail, b = network",
        "centers, _, coef, tail, b = _unpack(theta, K, d, m, n_tail)",
        "[a for a in start]",
    ):
        assert _positional_network_reads(bad), bad


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fits_a_smooth_function_and_refinement_helps(seed):
    """The OLS network removes nearly all of what a linear model misses; refinement then
    brings the error below the noise variance.

    Checked once on seeds 0-9 (data seeds ``2 seed`` and ``2 seed + 1``, model seed
    ``seed``; the suite runs 0-2): the OLS network's test MSE was 4.7e-3 to 1.01e-2, at
    most 3.0 % of the linear model's (0.31 to 0.34), and the refined one's 7.7e-4 to
    1.3e-3. An absolute bound of four noise variances on the OLS network (1e-2, the
    earlier claim) fails on seed 8; the claim relative to the linear peer holds on each.
    """
    X, y, _ = _smooth(1000, seed=2 * seed)
    X_test, _, f_test = _smooth(2000, seed=2 * seed + 1)
    ols = RBFNetRegressor(refine=None, random_state=seed).fit(X, y)
    refined = RBFNetRegressor(random_state=seed).fit(X, y)
    mse_ols = np.mean((ols.predict(X_test) - f_test) ** 2)
    mse_refined = np.mean((refined.predict(X_test) - f_test) ** 2)
    mse_linear = np.mean((LinearRegression().fit(X, y).predict(X_test) - f_test) ** 2)
    # The function's variance is 0.7 and a linear model leaves about 0.34 of it; the noise
    # variance is 0.0025. The network's job is the nonlinear part, so the OLS network is
    # judged against the linear peer (it must remove at least 95 % of what the peer
    # leaves), and the refined one against the noise (below one noise variance).
    assert mse_ols < 0.05 * mse_linear
    assert mse_refined < 2e-3
    assert mse_refined < mse_ols
    assert refined.selection_path_["refined"]
    assert 0 < ols.centers_.shape[0] <= 40


def test_output_weights_equal_lstsq_on_selected_columns():
    X, y, _ = _smooth(300)
    for tail, n_tail in (("linear", 3), ("quadratic", 9)):
        model = RBFNetRegressor(
            refine=None, alpha=0.0, tail_alpha=0.0, tail=tail, random_state=0
        ).fit(X, y)
        Z = (X - model.x_mean_) / model.x_scale_
        A = np.column_stack(
            [
                np.ones(300),
                tail_features(Z, model.tail_degree_),
                gaussian_design(Z, model.centers_, model.widths_),
            ]
        )
        weights = np.linalg.lstsq(A, y, rcond=None)[0]
        assert_allclose(model.intercept_, weights[0], rtol=1e-7)
        assert_allclose(model.tail_coef_, weights[1 : 1 + n_tail], rtol=1e-7, atol=1e-9)
        assert_allclose(model.coef_, weights[1 + n_tail :], rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("tail_alpha", [1e-3, 0.1])
@pytest.mark.parametrize("alpha", [0.0, 1e-3])
def test_tail_penalty_is_the_stated_ridge_problem(alpha, tail_alpha):
    # The fitted output layer minimises, on standardised targets,
    # mean squared error + alpha ||coef||^2 + tail_alpha ||tail_coef||^2: solved here
    # independently, as a least-squares problem on the design stacked over penalty rows.
    X, y, _ = _smooth(400, seed=3)
    model = RBFNetRegressor(
        refine=None,
        alpha=alpha,
        tail_alpha=tail_alpha,
        tail_penalty="ridge",
        tail="quadratic",
        random_state=0,
    ).fit(X, y)
    Z = (X - model.x_mean_) / model.x_scale_
    y_mean, y_std = y.mean(), y.std()
    T = tail_features(Z, 2)
    Phi = gaussian_design(Z, model.centers_, model.widths_)
    n, n_tail, k = 400, T.shape[1], Phi.shape[1]
    A = np.vstack(
        [
            np.column_stack([np.ones(n), T, Phi]),
            np.column_stack(
                [np.zeros(n_tail), np.sqrt(tail_alpha * n) * np.eye(n_tail), np.zeros((n_tail, k))]
            ),
            np.column_stack([np.zeros((k, 1 + n_tail)), np.sqrt(alpha * n) * np.eye(k)]),
        ]
    )
    b = np.concatenate([(y - y_mean) / y_std, np.zeros(n_tail + k)])
    weights = np.linalg.lstsq(A, b, rcond=None)[0] * y_std
    assert model.selection_path_["tail_alpha"] == tail_alpha
    assert_allclose(model.tail_coef_, weights[1 : 1 + n_tail], rtol=1e-6, atol=1e-9)
    assert_allclose(model.coef_, weights[1 + n_tail :], rtol=1e-6, atol=1e-8)
    assert_allclose(model.intercept_, weights[0] + y_mean, rtol=1e-9)


@pytest.mark.parametrize("tail_alpha", [1e-5, 1e-2])
def test_spread_tail_penalty_is_the_stated_generalised_ridge(tail_alpha):
    # tail_penalty="spread": the tail weights w pay tail_alpha * w' C^-1 w, C the covariance
    # of the tail features over the selection rows (all rows here: "bic" holds none out).
    # Solved here independently, with penalty rows sqrt(tail_alpha n) C^(-1/2).
    X, y, _ = _smooth(400, seed=3)
    X = np.column_stack([X, X[:, 0] + 1e-3 * np.sin(40 * X[:, 1])])  # a near-copy
    model = RBFNetRegressor(
        refine=None, criterion="bic", alpha=1e-3, tail_alpha=tail_alpha, random_state=0
    ).fit(X, y)
    Z = (X - model.x_mean_) / model.x_scale_
    y_mean, y_std = y.mean(), y.std()
    spread, directions = np.linalg.eigh(np.cov(Z.T, bias=True))
    assert spread.min() < 1e-5 * spread.max()  # the near-copy makes a thin direction
    root = (directions / np.sqrt(spread)).T  # ||root w||^2 = w' C^-1 w
    Phi = gaussian_design(Z, model.centers_, model.widths_)
    n, n_tail, k = 400, Z.shape[1], Phi.shape[1]
    A = np.vstack(
        [
            np.column_stack([np.ones(n), Z, Phi]),
            np.column_stack(
                [np.zeros(n_tail), np.sqrt(tail_alpha * n) * root, np.zeros((n_tail, k))]
            ),
            np.column_stack([np.zeros((k, 1 + n_tail)), np.sqrt(1e-3 * n) * np.eye(k)]),
        ]
    )
    b = np.concatenate([(y - y_mean) / y_std, np.zeros(n_tail + k)])
    weights = np.linalg.lstsq(A, b, rcond=None)[0] * y_std
    M = model.selection_path_["tail_transform"]
    assert_allclose(M @ M.T, np.cov(Z.T, bias=True), rtol=1e-9, atol=1e-12)
    assert_allclose(model.tail_coef_, weights[1 : 1 + n_tail], rtol=1e-6, atol=1e-9)
    assert_allclose(model.coef_, weights[1 + n_tail :], rtol=1e-6, atol=1e-8)
    assert_allclose(model.intercept_, weights[0] + y_mean, rtol=1e-9)


def test_spread_tail_penalty_keeps_a_near_copy_of_a_feature_from_moving_the_prediction():
    # Two features that move together over the calibration (a temperature and its lag): a
    # free tail sets their difference's weight by noise, so shifting one of them by five
    # times their calibrated difference can move the prediction far; the default penalty
    # shrinks that direction away and the prediction moves as the drift's slope says
    # (2 * 5e-4 spread over both features: about 5e-4), on every seed. Over 40 seeds the
    # free tail moved more than ten times as far on 31 (``noise-driven``: a rate).
    moves = {"free": [], "default": []}
    for seed in range(20):
        rng = np.random.default_rng(seed)
        t = np.linspace(-1, 1, 600)
        X = np.column_stack([t, t + 1e-4 * rng.standard_normal(600)])
        y = 2.0 * t + 0.1 * rng.standard_normal(600)
        shifted = X.copy()
        shifted[:, 1] += 5e-4
        for name, tail_alpha in (("free", 0.0), ("default", 1e-5)):
            model = RBFNetRegressor(refine=None, tail_alpha=tail_alpha, random_state=0)
            model.fit(X, y)
            moves[name].append(np.abs(model.predict(shifted) - model.predict(X)).mean())
    free, default = np.array(moves["free"]), np.array(moves["default"])
    assert np.all(default < 6e-4), default
    assert np.mean(free > 10 * default) >= 0.5, free / default


def test_tail_penalty_shrinks_the_tail_and_zero_is_the_free_tail():
    X, y, _ = _smooth(400, seed=4)
    params = {"refine": None, "criterion": None, "n_centers": 10, "random_state": 0}
    # Without a strength the penalty's shape is moot: both shapes are the free tail.
    free = RBFNetRegressor(tail_alpha=0.0, tail_penalty="ridge", **params).fit(X, y)
    explicit = RBFNetRegressor(tail_alpha=0.0, **params).fit(X, y)
    assert_array_equal(free.predict(X), explicit.predict(X))
    assert explicit.selection_path_["tail_transform"] is None
    params["tail_penalty"] = "ridge"
    norms = [
        np.linalg.norm(RBFNetRegressor(tail_alpha=ta, **params).fit(X, y).tail_coef_)
        for ta in (0.0, 1e-3, 1e-1, 10.0, 1e4)
    ]
    assert all(a > b for a, b in itertools.pairwise(norms)), norms
    assert norms[-1] < 1e-3 * norms[0]


def test_tail_penalty_auto_is_chosen_from_the_grid_and_recorded():
    X, y, _ = _smooth(500, seed=5, noise=0.3)
    model = RBFNetRegressor(refine=None, tail_alpha="auto", random_state=0).fit(X, y)
    tried = model.selection_path_["tail_alphas_tried"]
    assert_array_equal(tried, [0.0, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1])
    assert model.selection_path_["tail_alpha"] in tried
    # The penalty's shape is recorded exactly when a strength was chosen (the default shape).
    chosen_penalised = model.selection_path_["tail_alpha"] > 0
    assert chosen_penalised == (model.selection_path_["tail_transform"] is not None)
    assert model.selection_path_["width_scores"].shape == (4,)
    # without a tail there is nothing to penalise
    no_tail = RBFNetRegressor(refine=None, tail=False, tail_alpha="auto", random_state=0)
    assert no_tail.fit(X, y).selection_path_["tail_alpha"] == 0.0


@pytest.mark.parametrize("bad", [-1.0, "strong", np.nan])
def test_tail_penalty_rejects_bad_values(bad):
    X, y, _ = _smooth(50)
    with pytest.raises(ValueError, match="tail_alpha"):
        RBFNetRegressor(tail_alpha=bad).fit(X, y)
    with pytest.raises(ValueError, match="tail_penalty"):
        RBFNetRegressor(tail_penalty="lasso").fit(X, y)


def test_selection_path_is_recorded():
    X, y, _ = _smooth(400)
    model = RBFNetRegressor(refine=None, alpha=0.0, random_state=0).fit(X, y)
    path = model.selection_path_
    k = path["n_centers"]
    assert k == model.centers_.shape[0]
    assert path["criterion_name"] == "cv"
    assert len(path["train_mse"]) == len(path["criterion"]) == len(path["err"]) + 1
    # Without ridge, training error never rises along a least-squares path.
    assert np.all(np.diff(path["train_mse"]) <= 1e-12)
    assert np.all(path["err"] > 0)
    assert np.all(np.isfinite(path["val_mse"]))
    assert path["widths_tried"].shape == path["width_scores"].shape


@pytest.mark.parametrize("criterion", ["gcv", "bic", "aicc"])
def test_information_criteria_choose_their_minimum(criterion):
    X, y, _ = _smooth(300)
    model = RBFNetRegressor(refine=None, criterion=criterion, random_state=0).fit(X, y)
    path = model.selection_path_
    assert path["criterion_name"] == criterion
    assert path["n_centers"] == int(np.argmin(path["criterion"]))
    assert np.all(np.isnan(path["val_mse"]))


def test_fixed_number_of_centres_and_width():
    X, y, _ = _smooth(300)
    model = RBFNetRegressor(
        n_centers=7, criterion=None, width=0.9, refine=None, random_state=0
    ).fit(X, y)
    assert model.centers_.shape == (7, 3)
    assert_array_equal(model.widths_, np.full(7, 0.9))
    # Centres are training rows (standardised).
    Z = (X - model.x_mean_) / model.x_scale_
    assert all(np.any(np.all(np.isclose(c, Z), axis=1)) for c in model.centers_)


def test_width_grid_reaches_the_radius_of_clustered_rows():
    """Rows in tight clusters (a held temperature, a quantised sensor): the nearest-neighbour
    spacing is the within-cluster one; the grid doubles on until the data's radius."""
    even = np.linspace(-1.0, 1.0, 41)[:, None]
    assert_allclose(width_grid(even, WIDTH_MULTIPLES), 0.05 * np.asarray(WIDTH_MULTIPLES))
    clusters = np.concatenate([c + 1e-3 * np.arange(5) for c in np.linspace(-1, 1, 9)])[:, None]
    widths = width_grid(clusters, WIDTH_MULTIPLES)
    assert_allclose(widths[:4], 1e-3 * np.asarray(WIDTH_MULTIPLES))
    assert_allclose(widths[4:] / widths[3:-1], 2.0)
    radius = 0.5 * np.median(np.abs(clusters - clusters.T)[np.triu_indices(45, 1)])
    assert widths[-2] < radius <= widths[-1]
    # Nearly duplicated rows: at most six widths more, the last one the radius itself.
    twins = np.concatenate([c + 1e-9 * np.arange(2) for c in np.linspace(-1, 1, 9)])[:, None]
    widths = width_grid(twins, WIDTH_MULTIPLES)
    assert widths.shape == (len(WIDTH_MULTIPLES) + 6,)
    assert np.all(np.diff(widths) > 0)
    radius = 0.5 * np.median(np.abs(twins - twins.T)[np.triu_indices(18, 1)])
    assert widths[-1] == pytest.approx(radius)


@pytest.mark.parametrize("seed", range(6))
def test_clustered_rows_are_interpolated_between_clusters(seed):
    """Twelve clusters of one input (a gyro read at held temperatures): the network must
    follow the curve between them, not fit one narrow unit per cluster as it does at the
    widest multiple of the nearest-neighbour spacing (the grid before it was extended).

    Checked once on seeds 0-9 (holds on each); the suite runs 0-5."""
    rng = np.random.RandomState(seed)
    levels = np.linspace(-2.0, 2.0, 12)
    X = (np.repeat(levels, 100) + 0.003 * rng.normal(size=1200))[:, None]

    def curve(t):
        return np.sin(1.5 * t) + 0.3 * t**2

    y = curve(X[:, 0]) + 0.3 * rng.normal(size=1200)
    between = ((levels[:-1] + levels[1:]) / 2)[:, None]

    def error(model):
        return np.mean((model.predict(between) - curve(between[:, 0])) ** 2)

    model = RBFNetRegressor(random_state=seed).fit(X, y)
    widest_multiple = float(model.selection_path_["widths_tried"][len(WIDTH_MULTIPLES) - 1])
    narrow = RBFNetRegressor(width=widest_multiple, random_state=seed).fit(X, y)
    assert error(model) < 0.02 < error(narrow)


def test_goal_stops_at_first_prefix_reaching_it():
    X, y, _ = _smooth(300)
    goal = 0.01
    model = RBFNetRegressor(goal=goal, refine=None, random_state=0).fit(X, y)
    path = model.selection_path_
    k = path["n_centers"]
    assert path["train_mse"][k] <= goal
    assert np.all(path["train_mse"][:k] > goal)


def test_linear_target_gives_exact_affine_model_and_extrapolates():
    rng = np.random.default_rng(0)
    X = rng.uniform(0, 1, size=(200, 2))
    y = 3.0 * X[:, 0] - 2.0 * X[:, 1] + 1.0
    X_far = np.array([[10.0, -5.0], [-3.0, 4.0]])
    expected = 3.0 * X_far[:, 0] - 2.0 * X_far[:, 1] + 1.0
    # A free tail is exact; the default penalty shrinks each direction of the (well-spread)
    # inputs by the factor lambda^2 / (lambda^2 + tail_alpha), lambda ~ 1: a 1e-4 relative error.
    model = RBFNetRegressor(refine=None, tail_alpha=0.0, random_state=0).fit(X, y)
    assert_allclose(model.predict(X_far), expected, atol=1e-6)
    default = RBFNetRegressor(refine=None, random_state=0).fit(X, y)
    assert_allclose(default.predict(X_far), expected, rtol=1e-3)
    assert not np.allclose(default.predict(X_far), expected, rtol=1e-7)


def test_tail_extrapolates_linearly_far_from_the_data():
    X, y, _ = _smooth(400)
    model = RBFNetRegressor(refine=None, tail="linear", random_state=0).fit(X, y)
    assert model.tail_degree_ == 1
    X_far = np.array([[30.0, -30.0, 30.0], [-40.0, 0.0, 50.0]])
    Z_far = (X_far - model.x_mean_) / model.x_scale_
    # Far away every Gaussian unit is zero: the prediction is the affine tail.
    assert_allclose(model.predict(X_far), Z_far @ model.tail_coef_ + model.intercept_)
    no_tail = RBFNetRegressor(refine=None, tail=False, random_state=0).fit(X, y)
    assert no_tail.tail_degree_ == 0
    assert_array_equal(no_tail.tail_coef_, np.zeros(3))
    assert_allclose(no_tail.predict(X_far), no_tail.intercept_)


def test_same_seed_same_model_bit_for_bit():
    X, y, _ = _smooth(1500)
    params = dict(max_candidates=50, max_samples=500, random_state=3)
    first = RBFNetRegressor(**params).fit(X, y)
    second = RBFNetRegressor(**params).fit(X, y)
    assert_array_equal(first.centers_, second.centers_)
    assert_array_equal(first.predict(X), second.predict(X))
    other = RBFNetRegressor(**{**params, "random_state": 4}).fit(X, y)
    assert not np.array_equal(first.centers_, other.centers_)


def test_joblib_round_trip_identical(smooth_model):
    model, X, _ = smooth_model
    buffer = io.BytesIO()
    joblib.dump(model, buffer)
    buffer.seek(0)
    restored = joblib.load(buffer)
    assert_array_equal(restored.predict(X), model.predict(X))


def test_integer_weights_equal_repeated_rows():
    X, y, _ = _smooth(60)
    weights = np.random.default_rng(1).integers(0, 4, size=60)
    # GCV ranks the path (no row-order dependence), so the two fits must agree.
    params = dict(criterion="gcv", refine=None, random_state=0)
    weighted = RBFNetRegressor(**params).fit(X, y, sample_weight=weights)
    repeated = RBFNetRegressor(**params).fit(np.repeat(X, weights, axis=0), np.repeat(y, weights))
    assert weighted.centers_.shape == repeated.centers_.shape
    X_test = _smooth(100, seed=2)[0]
    assert_allclose(weighted.predict(X_test), repeated.predict(X_test), rtol=1e-7, atol=1e-9)


def test_zero_weight_rows_are_ignored():
    X, y, _ = _smooth(80)
    weights = np.ones(80)
    weights[::4] = 0.0
    y_corrupt = y.copy()
    y_corrupt[::4] = 1e3
    params = dict(criterion="gcv", refine=None, random_state=0)
    weighted = RBFNetRegressor(**params).fit(X, y_corrupt, sample_weight=weights)
    dropped = RBFNetRegressor(**params).fit(X[weights > 0], y[weights > 0])
    assert_allclose(weighted.predict(X), dropped.predict(X), rtol=1e-7, atol=1e-9)


def test_float32_input_is_computed_in_float64():
    X, y, _ = _smooth(300)
    model64 = RBFNetRegressor(refine=None, random_state=0).fit(X.astype(np.float32), y)
    model32 = RBFNetRegressor(refine=None, random_state=0).fit(
        X.astype(np.float32), y.astype(np.float32)
    )
    assert model64.centers_.dtype == np.float64
    pred = model32.predict(X.astype(np.float32))
    assert pred.dtype == np.float64
    assert_allclose(pred, model64.predict(X.astype(np.float32)), rtol=1e-5, atol=1e-6)


def test_multi_output_equals_single_output_fits_for_scaled_targets():
    X, y, _ = _smooth(300)
    Y = np.column_stack([y, -2.0 * y + 5.0])
    multi = RBFNetRegressor(refine=None, random_state=0).fit(X, Y)
    single = RBFNetRegressor(refine=None, random_state=0).fit(X, y)
    assert multi.coef_.shape == (2, single.coef_.shape[0])
    assert multi.tail_coef_.shape == (2, n_tail_features(3, multi.tail_degree_))
    assert multi.intercept_.shape == (2,)
    # Targets are standardised per output: an affine copy selects the same network.
    assert_array_equal(multi.centers_, single.centers_)
    pred = multi.predict(X)
    assert pred.shape == (300, 2)
    assert_allclose(pred[:, 0], single.predict(X), rtol=1e-8, atol=1e-10)
    assert_allclose(pred[:, 1], -2.0 * single.predict(X) + 5.0, rtol=1e-8, atol=1e-9)


def test_multi_output_shares_centres_across_outputs():
    """Checked once on data seeds 0-9 (``_smooth(300, seed)``; holds on each)."""
    X, y, _ = _smooth(300)
    Y = np.column_stack([y, np.cos(2 * X[:, 1])])
    model = RBFNetRegressor(refine=None, random_state=0).fit(X, Y)
    assert model.coef_.shape == (2, model.centers_.shape[0])
    residual = Y - model.predict(X)
    assert np.all(np.mean(residual**2, axis=0) < 0.1 * Y.var(axis=0))


def test_column_vector_target_keeps_two_dimensions():
    X, y, _ = _smooth(200)
    model = RBFNetRegressor(refine=None, random_state=0).fit(X, y[:, None])
    assert model.coef_.ndim == 2
    assert model.predict(X).shape == (200, 1)


@pytest.mark.parametrize(
    "case",
    ["duplicate_rows", "constant_feature", "constant_target", "tiny_width", "huge_width"],
)
def test_degenerate_inputs_give_finite_models(case):
    X, y, _ = _smooth(120)
    params = dict(refine=None, random_state=0)
    if case == "duplicate_rows":
        X, y = np.repeat(X[:30], 4, axis=0), np.repeat(y[:30], 4)
    elif case == "constant_feature":
        X[:, 1] = 7.0
    elif case == "constant_target":
        y = np.full(120, -2.5)
    elif case == "tiny_width":
        params["width"] = 1e-9
    else:
        params["width"] = 1e9
    model = RBFNetRegressor(**params).fit(X, y)
    X_test = np.vstack([X, 100 * np.random.default_rng(0).normal(size=(10, 3))])
    pred = model.predict(X_test)
    assert np.all(np.isfinite(pred))
    for name in ("centers_", "widths_", "coef_", "tail_coef_", "intercept_"):
        assert np.all(np.isfinite(getattr(model, name)))
    if case == "constant_target":
        assert_allclose(pred, -2.5, atol=1e-12)
        assert model.centers_.shape[0] == 0
    if case == "constant_feature":
        assert model.x_scale_[1] == 1.0
        # Every tail column with feature 1 in it is zero: minimum-norm weights are zero.
        probe = np.ones((2, 3))
        probe[1, 1] = 2.0
        T = tail_features(probe, model.tail_degree_)
        touches_feature_1 = T[0] != T[1]
        assert touches_feature_1.sum() == (1 if model.tail_degree_ == 1 else 4)
        assert_allclose(model.tail_coef_[touches_feature_1], 0.0, atol=1e-12)
    if case == "huge_width":
        # Units as wide as that are constant columns: collinear with the intercept.
        assert model.centers_.shape[0] == 0


def test_fewer_rows_than_centres_warns():
    X, y, _ = _smooth(12)
    with pytest.warns(UserWarning, match="only 12 distinct candidate rows"):
        model = RBFNetRegressor(n_centers=50, refine=None, random_state=0).fit(X, y)
    assert model.centers_.shape[0] <= 12
    assert np.all(np.isfinite(model.predict(X)))


def test_two_rows_fit():
    model = RBFNetRegressor(refine=None, tail_alpha=0.0).fit([[0.0], [1.0]], [1.0, 3.0])
    assert_allclose(model.predict([[0.5], [2.0]]), [2.0, 5.0], atol=1e-8)


def test_negative_weights_rejected():
    X, y, _ = _smooth(30)
    with pytest.raises(ValueError, match=r"[Nn]egative"):
        RBFNetRegressor(refine=None).fit(X, y, sample_weight=-np.ones(30))


@pytest.mark.parametrize("method", ["varpro", "lm", "gd"])
def test_refinement_starts_from_ols_and_falls_back_cleanly(method):
    X, y, _ = _smooth(800)
    params = dict(max_iter=15, random_state=0, n_centers=8)
    base = RBFNetRegressor(refine=None, **params).fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        refined = RBFNetRegressor(refine=method, **params).fit(X, y)
    assert np.all(np.isfinite(refined.predict(X)))
    assert refined.n_iter_ >= 1
    assert base.n_iter_ == 0
    # Refinement starts from the OLS network: same selection path either way.
    assert_array_equal(refined.selection_path_["err"], base.selection_path_["err"])
    if refined.selection_path_["refined"]:
        assert not np.array_equal(refined.centers_, base.centers_)
    else:
        # Clean fallback: the OLS network's centres and widths, unchanged.
        assert_array_equal(refined.centers_, base.centers_)
        assert_array_equal(refined.widths_, base.widths_)


def test_refinement_at_max_iter_warns():
    X, y, _ = _smooth(600)
    with pytest.warns(ConvergenceWarning, match="max_iter=1"):
        model = RBFNetRegressor(refine="lm", max_iter=1, random_state=0).fit(X, y)
    assert model.n_iter_ == 1


def test_single_row_predict_matches_batch(smooth_model):
    model, X, _ = smooth_model
    batch = model.predict(X[:5])
    rows = np.array([model.predict(X[i : i + 1])[0] for i in range(5)])
    assert_allclose(rows, batch, rtol=1e-12)


def test_holdout_criterion_and_its_fallback_on_few_rows():
    X, y, _ = _smooth(400)
    model = RBFNetRegressor(criterion="holdout", refine=None, random_state=0).fit(X, y)
    path = model.selection_path_
    assert path["criterion_name"] == "holdout"
    assert_allclose(path["criterion"], path["val_mse"] / np.var(y), rtol=1e-6)
    # 40 rows: 8 would be held out, fewer than the 10 a held-out error needs.
    few = RBFNetRegressor(criterion="holdout", refine="varpro", random_state=0)
    few.fit(X[:40], y[:40])
    assert few.selection_path_["criterion_name"] == "gcv"
    assert few.n_iter_ == 0
    assert not few.selection_path_["refined"]


def test_tail_features_order_equals_polynomial_features():
    Z = np.random.default_rng(3).normal(size=(7, 4))
    expected = PolynomialFeatures(2, include_bias=False).fit_transform(Z)
    assert_array_equal(tail_features(Z, 2), expected)
    assert tail_features(Z, 1) is Z
    assert tail_features(Z, 0).shape == (7, 0)
    assert [n_tail_features(4, degree) for degree in (0, 1, 2)] == [0, 4, 14]
    with pytest.raises(ValueError, match="tail degree must be 0, 1 or 2"):
        tail_features(Z, 3)


def _quadratic_and_linear_targets(n=500, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(loc=[20.0, 0.0, 5.0], scale=[10.0, 0.3, 4.0], size=(n, 3))
    quadratic = 0.3 + 0.02 * X[:, 0] - 0.004 * X[:, 0] ** 2 + 0.5 * X[:, 0] * X[:, 1]
    linear = 0.3 + 0.02 * X[:, 0] - 1.5 * X[:, 1] + 0.1 * X[:, 2]
    return X, quadratic, linear + 0.01 * rng.normal(size=n)


def test_quadratic_tail_fits_a_quadratic_target_exactly_without_centres():
    X, y, _ = _quadratic_and_linear_targets()
    # A free tail: the default penalty would (rightly) trade exactness for stability.
    model = RBFNetRegressor(tail="quadratic", tail_alpha=0.0, random_state=0).fit(X, y)
    assert model.tail_degree_ == 2
    assert model.centers_.shape[0] == 0
    assert model.tail_coef_.shape == (9,)
    # Far outside the data the quadratic is still reproduced (no Gaussian unit is left).
    X_far = np.array([[80.0, 3.0, -40.0], [-60.0, -2.0, 30.0]])
    expected = (
        0.3 + 0.02 * X_far[:, 0] - 0.004 * X_far[:, 0] ** 2 + 0.5 * X_far[:, 0] * X_far[:, 1]
    )
    assert_allclose(model.predict(X), y, rtol=0, atol=1e-10)
    assert_allclose(model.predict(X_far), expected, rtol=1e-9)
    # The same target needs many units and still misses with a linear tail.
    linear = RBFNetRegressor(tail="linear", refine=None, random_state=0).fit(X, y)
    assert linear.tail_degree_ == 1
    assert np.mean((linear.predict(X) - y) ** 2) > 1e-6 * np.var(y)


def test_auto_tail_picks_quadratic_on_quadratic_data_and_linear_on_linear_data():
    X, quadratic, linear = _quadratic_and_linear_targets()
    on_quadratic = RBFNetRegressor(tail="auto", refine=None, random_state=0).fit(X, quadratic)
    on_linear = RBFNetRegressor(tail="auto", refine=None, random_state=0).fit(X, linear)
    assert on_quadratic.tail_degree_ == 2
    assert on_quadratic.tail_coef_.shape == (9,)
    assert on_linear.tail_degree_ == 1
    assert on_linear.tail_coef_.shape == (3,)
    for model in (on_quadratic, on_linear):
        scores = model.selection_path_["tail_scores"]
        assert set(scores) == {1, 2}
        assert model.selection_path_["tail_degree"] == min(scores, key=scores.get)
        assert np.all(np.isfinite(model.predict(X)))
    # The linear fit's selection is the same as tail="linear" with the same seed.
    explicit = RBFNetRegressor(tail="linear", refine=None, random_state=0).fit(X, linear)
    assert_array_equal(on_linear.predict(X), explicit.predict(X))


def test_quadratic_tail_single_row_and_batch_predictions_agree():
    X, y, _ = _smooth(400)
    model = RBFNetRegressor(tail="quadratic", refine=None, random_state=0).fit(X, y)
    X_new = np.random.default_rng(7).uniform(-3, 3, size=(40, 3))
    batch = model.predict(X_new)
    rows = np.array([model.predict(x[None])[0] for x in X_new])
    assert np.all(np.isfinite(batch))
    assert_allclose(rows, batch, rtol=1e-12, atol=1e-12)
    assert_allclose(batch, _formula(model, X_new), rtol=1e-10, atol=1e-12)


def test_quadratic_tail_falls_back_to_linear_on_too_few_rows():
    X, y, _ = _smooth(60)
    with pytest.warns(UserWarning, match="needs at least 100 selection rows .* linear tail"):
        model = RBFNetRegressor(tail="quadratic", refine=None, random_state=0).fit(X, y)
    assert model.tail_degree_ == 1
    assert model.tail_coef_.shape == (3,)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        linear = RBFNetRegressor(tail="linear", refine=None, random_state=0).fit(X, y)
    assert_array_equal(model.predict(X), linear.predict(X))


def test_small_plain_input_is_predicted_as_validated_input(smooth_model):
    # A few C-ordered float64 rows skip validate_data; the same rows given as a list are
    # validated and must give the very same predictions (F-ordered rows, and more rows than
    # the small path takes, are computed in another memory order: equal to round-off).
    model, X, _ = smooth_model
    rows = np.ascontiguousarray(X[:5])
    fast = model.predict(rows)
    assert_array_equal(fast, model.predict(rows.tolist()))
    assert_allclose(fast, model.predict(np.asfortranarray(rows)), rtol=1e-12, atol=1e-14)
    assert_allclose(fast, model.predict(np.vstack([rows] * 10))[:5], rtol=1e-12, atol=1e-14)
    assert_allclose(fast, _formula(model, rows), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_small_plain_input_with_non_finite_value_raises(smooth_model, bad):
    model, X, _ = smooth_model
    row = X[:1].copy()
    row[0, 1] = bad
    with pytest.raises(ValueError, match=r"NaN|infinity"):
        model.predict(row)


def test_small_plain_input_of_wrong_width_raises(smooth_model):
    model = smooth_model[0]
    with pytest.raises(ValueError, match="3 features"):
        model.predict(np.zeros((1, 4)))


def test_small_array_after_fit_on_named_columns_warns(smooth_model):
    pd = pytest.importorskip("pandas")
    _, X, y = smooth_model
    model = RBFNetRegressor(refine=None, random_state=0).fit(
        pd.DataFrame(X, columns=["a", "b", "c"]), y
    )
    with pytest.warns(UserWarning, match="feature names"):
        model.predict(X[:1].copy())


@pytest.mark.parametrize("tail_alpha", [0.0, 1e-3])
def test_prefix_fits_fast_path_equals_svd_path(monkeypatch, tail_alpha):
    # Well-conditioned paths are scored from triangular solves and the ridge rows; the
    # general path (SVD solves, explicit Q) must give the same errors and dof, and the
    # weights handed on are the SVD path's in both.
    from sklearn_ifog.rbf import _ols

    rng = np.random.default_rng(3)
    Z = rng.uniform(-1, 1, size=(300, 2))
    Phi = gaussian_design(Z, Z[:12], 0.6)
    Y = np.column_stack([np.sin(3 * Z[:, 0]), Z[:, 1] ** 2]) + 0.01 * rng.normal(size=(300, 2))
    sw = rng.uniform(0.5, 2.0, size=300)
    Z_val = rng.uniform(-1, 1, size=(80, 2))
    kwargs = dict(
        T=Z,
        sample_weight=sw,
        alpha=0.05,
        tail_alpha=tail_alpha,
        Phi_val=gaussian_design(Z_val, Z[:12], 0.6),
        T_val=Z_val,
        Y_val=np.column_stack([np.sin(3 * Z_val[:, 0]), Z_val[:, 1] ** 2]),
        sample_weight_val=np.ones(80),
    )
    assert _ols._well_conditioned(np.linalg.qr(np.hstack([np.ones((300, 1)), Z, Phi]), "r"))
    fast = _ols.prefix_fits(Phi, Y, **kwargs)
    monkeypatch.setattr(_ols, "_well_conditioned", lambda R: False)
    general = _ols.prefix_fits(Phi, Y, **kwargs)
    assert_allclose(fast.train_mse, general.train_mse, rtol=1e-10)
    assert_allclose(fast.val_mse, general.val_mse, rtol=1e-10)
    assert_allclose(fast.val_sq, general.val_sq, rtol=1e-9, atol=1e-14)
    assert_allclose(fast.dof, general.dof, rtol=1e-10)
    assert len(fast.weights) == len(general.weights) == 13
    for k in range(13):
        assert_array_equal(fast.weights[k], general.weights[k])
    assert 3.0 < fast.dof[-1] < 3.0 + 12.0
