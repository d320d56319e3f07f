"""Exact behaviour of ``sklearn_ifog.scale_factor``'s helpers, written where mutation testing
(``tools/mutation.sh scale_factor``) found that no test would notice a change: the input-rate
levels of the noise model, its continuous-input path, the unit and observability checks at
their boundaries, the proxy targets, the inserted input-rate column and the layer penalty.
"""

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression

from sklearn_ifog import RBFNetRegressor
from sklearn_ifog import scale_factor as sf
from sklearn_ifog._output_layer import layer_design


def test_rate_levels_group_equal_magnitudes_of_either_sign():
    magnitude = np.abs(np.array([0.0, 3600.0, -3600.0, 36000.0, -36000.0, 3600.0]))
    labels = sf._rate_levels(magnitude)
    assert labels.tolist() == [0, 1, 1, 2, 2, 1]


def test_rate_levels_tell_tiny_magnitudes_apart():
    """The magnitudes are read relative to the largest, whatever their unit's size."""
    assert sf._rate_levels(np.array([1e-7, 2e-7, 2e-7])).tolist() == [0, 1, 1]


def test_rate_levels_keep_fifty_steps_and_bin_more_in_twenty_quantiles():
    fifty = np.repeat(np.arange(1.0, 51.0), 4)
    assert np.unique(sf._rate_levels(fifty)).size == 50
    rng = np.random.default_rng(0)
    continuous = rng.uniform(0.0, 1e6, 4000)
    labels = sf._rate_levels(continuous)
    counts = np.bincount(labels)
    assert counts.size == 20
    assert counts.min() >= 195  # quantile bins: 200 rows each
    order = np.argsort(continuous)
    assert np.all(np.diff(labels[order]) >= 0)  # bins follow the magnitude


def test_rate_noise_on_a_continuous_input_and_at_large_contrast():
    rng = np.random.default_rng(1)
    # a continuous input (more than 50 magnitudes: 20 quantile bins), a quarter at rest,
    # where the bias noise shows alone
    omega = rng.uniform(-1e6, 1e6, 200000) * (rng.uniform(size=200000) > 0.25)
    residual = rng.normal(0.0, np.sqrt(0.01**2 + (1e-5 * omega) ** 2))
    noise = sf.rate_noise(residual, omega)
    # the fastest rows' residuals are 1000 times sigma0: a fit of the squares in absolute
    # terms would leave sigma0 to their noise (0 or tenths of a deg/h); the relative fit per
    # level finds its size (the bins' own spread of input rates blurs it within a factor 2)
    assert 0.005 < noise.sigma0 < 0.02
    assert noise.kappa == pytest.approx(1e-5, rel=0.05)


def test_rate_noise_of_zero_residuals_is_floored():
    noise = sf.rate_noise(np.zeros(6), np.array([0.0, 1.0, 2.0, 0.0, 1.0, 2.0]) * 3600)
    assert noise.sigma0 == pytest.approx(1e-6, rel=1e-12)
    assert noise.kappa == pytest.approx(0.0, abs=1e-15)
    weights = noise.weights(np.array([0.0, 3600.0]))
    np.testing.assert_allclose(weights, [1.0, 1.0])


def test_rate_noise_weights_have_mean_one():
    weights = sf.RateNoise(0.02, 3e-6).weights(np.linspace(-1e6, 1e6, 101))
    assert weights.mean() == pytest.approx(1.0, rel=1e-12)
    assert weights[50] == weights.max()  # zero input weighs most


@pytest.mark.parametrize(
    ("slope", "raises"), [(0.049, False), (0.05, False), (0.051, True), (-0.051, True)]
)
def test_the_unit_check_at_its_boundary(slope, raises):
    omega = np.tile([0.0, 3600.0, -3600.0], 10)
    y = 0.1 + slope * omega
    if raises:
        with pytest.raises(ValueError, match="206,265 times smaller, deg/s 3,600 times"):
            sf.check_input_rate(omega, y, "table")
    else:
        sf.check_input_rate(omega, y, "table")


def test_the_observability_check_at_its_boundary():
    sf.check_input_rate(np.array([0.0, 3600.0, -3600.0]), np.zeros(3), "table")
    with pytest.raises(ValueError, match=r"reaches only 3599 deg/h: a scale factor"):
        sf.check_input_rate(np.array([0.0, 3599.0, -3599.0]), np.zeros(3), "table")
    # one input rate (a static campaign at the Earth rate), to round-off
    constant = np.full(5, 1e4) + np.array([0.0, 1e-12, 0.0, -1e-12, 0.0])
    with pytest.raises(ValueError, match=r"and never changes: .*input_rate=None"):
        sf.check_input_rate(constant, np.zeros(5), "table")


def test_proxy_targets_row_by_row():
    omega = np.array([0.0, 1e4, -1e6])
    y = np.array([0.5, 0.5 + 1e4 * 2e-4 + 1e4 * 1e-5, 0.4 + -1e6 * 3e-4 + 1e6 * 1e-5])
    first = sf.PreliminaryFit(
        bias=np.array([0.45, 0.45, 0.4]),
        scale_factor=np.array([1e-4, 1e-4, 1e-4]),
        asymmetry=1e-5,
        noise=sf.RateNoise(sigma0=0.1, kappa=1e-5),  # kappa |omega| = 0, 0.1, 10
    )
    Y = sf.proxy_targets(y, omega, first)
    # rows 0 and 1 show the bias (kappa |omega| <= sigma0, the boundary included): y minus
    # the first scale factor and the asymmetry; their scale factor is the first one
    np.testing.assert_allclose(Y[0], [0.5, 1e-4])
    np.testing.assert_allclose(Y[1], [0.5 + 1e4 * 1e-4, 1e-4])
    # row 2 shows the scale factor: (y - a|omega| - b0) / omega; its bias is b0
    np.testing.assert_allclose(Y[2], [0.4, 3e-4])


def test_with_input_rate_inserts_at_the_fitted_place():
    names = ["time", "reference", "temperature"]
    X = pd.DataFrame({"time": [0.0, 1.0], "temperature": [20.0, 21.0]})
    out = sf.with_input_rate(X, "reference", np.array([5.0, 6.0]), names, 3)
    assert list(out.columns) == names
    assert out["reference"].tolist() == [5.0, 6.0]
    assert list(X.columns) == ["time", "temperature"]  # the caller's frame is not changed
    full = X.assign(reference=1.0)
    assert sf.with_input_rate(full, "reference", np.zeros(2), names, 3) is full
    assert sf.with_input_rate(X, "reference", np.zeros(2), None, 3) is X
    pl = pytest.importorskip("polars")
    polars_out = sf.with_input_rate(pl.from_pandas(X), "reference", np.array([5.0, 6.0]), names, 3)
    assert polars_out.columns == names
    assert polars_out["reference"].to_list() == [5.0, 6.0]
    array = np.array([[0.0, 20.0], [1.0, 21.0]])
    np.testing.assert_array_equal(
        sf.with_input_rate(array, 1, np.array([5.0, 6.0]), None, 3),
        [[0.0, 5.0, 20.0], [1.0, 6.0, 21.0]],
    )
    three = np.zeros((2, 3))
    assert sf.with_input_rate(three, 1, np.ones(2), None, 3) is not None
    np.testing.assert_array_equal(sf.with_input_rate(three, 1, np.ones(2), None, 3), three)


def test_layer_penalty_of_a_network_and_of_a_linear_model():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(300, 2))
    y = np.sin(2 * X[:, 0]) + X[:, 1]
    network = RBFNetRegressor(n_centers=5, alpha=1e-3, tail_alpha=1e-2, random_state=0)
    network.fit(X, y)
    penalty = sf.layer_penalty(network)
    n_centers = network.centers_.shape[0]
    assert penalty.shape == (layer_design(network, X).shape[1],)
    np.testing.assert_array_equal(penalty[:n_centers], 1e-3)
    np.testing.assert_array_equal(penalty[n_centers:-1], 1e-2)
    assert penalty[-1] == 0.0  # the intercept is never penalised
    auto = RBFNetRegressor(n_centers=5, alpha=1e-3, tail_alpha="auto", random_state=0)
    np.testing.assert_array_equal(sf.layer_penalty(auto.fit(X, y))[n_centers:-1], 1e-3)
    untailed = RBFNetRegressor(n_centers=5, alpha=1e-3, tail=False, random_state=0).fit(X, y)
    assert sf.layer_penalty(untailed).shape == (layer_design(untailed, X).shape[1],)
    linear = sf.layer_penalty(LinearRegression().fit(X, y))
    np.testing.assert_array_equal(linear, np.zeros(3))


def test_the_weighted_solve_is_weighted_ridge():
    rng = np.random.default_rng(2)
    D = rng.normal(size=(50, 3))
    y = rng.normal(size=50)
    w = rng.uniform(0.5, 2.0, 50)
    p = np.array([0.0, 0.5, 5.0])
    theta = sf._weighted_solve(D, y, w, p)
    expected = np.linalg.solve(D.T @ (w[:, None] * D) + np.diag(p), D.T @ (w * y))
    np.testing.assert_allclose(theta, expected, rtol=1e-10)
    small = np.array([0.0, 0.5, 0.5])  # every penalty below 1 is a penalty too
    expected = np.linalg.solve(D.T @ (w[:, None] * D) + np.diag(small), D.T @ (w * y))
    np.testing.assert_allclose(sf._weighted_solve(D, y, w, small), expected, rtol=1e-10)
    plain = np.linalg.lstsq(np.sqrt(w)[:, None] * D, np.sqrt(w) * y, rcond=None)[0]
    np.testing.assert_allclose(sf._weighted_solve(D, y, w), plain, rtol=1e-10)


def test_the_input_rate_and_the_drift_take_the_asymmetry_by_sign():
    pair = np.array([[1.0, 1e-4], [1.0, 1e-4], [1.0, 1e-4]])
    omega = np.array([1e6, -1e6, 0.0])
    drift = sf.drift_of(pair, omega, asymmetry=2e-5)
    np.testing.assert_allclose(drift, [1.0 + 100.0 + 20.0, 1.0 - 100.0 + 20.0, 1.0])
    rate = omega + drift
    np.testing.assert_allclose(sf.input_rate_estimate(pair, rate, 2e-5), omega, atol=1e-9)
    # an output equal to the bias stands for no input rate at all
    assert sf.input_rate_estimate(pair[:1], np.array([1.0]), 2e-5).tolist() == [0.0]


def test_beyond_input_rates_at_the_slack():
    low, high = -1e6, 1e6
    edge = 1e6 * 1.05
    flags = sf.beyond_input_rates(np.array([edge, np.nextafter(edge, 2e6), -edge]), low, high)
    assert flags.tolist() == [False, True, False]
    asymmetric = sf.beyond_input_rates(np.array([-0.6e6]), -0.5e6, 1e6)  # slack 5 % of 1e6
    assert asymmetric.tolist() == [True]


def _heteroscedastic(seed):
    """Rows whose noise grows with the input rate: 0.01 deg/h at rest, 10 deg/h at 1e6."""
    rng = np.random.default_rng(seed)
    omega = rng.choice([0.0, 1e4, -1e4, 1e5, -1e5, 1e6, -1e6], 9000)
    T = rng.uniform(-1.0, 1.0, omega.size)
    noise = rng.normal(0.0, 0.01 + 1e-5 * np.abs(omega))
    y = 0.3 * T + 0.1 + omega * (1e-4 + 2e-5 * T) + noise
    return np.column_stack([T, np.ones_like(T)]), y, omega


def test_the_rows_are_weighed_by_their_rate_noise():
    """What the model cannot hold at fast rates (here an even nonlinearity, 1e-11 Ω² (1 + T):
    10 deg/h at 1e6 deg/h, a thousandth of that at 1e4) must not leak into the bias: weighed
    by their rate noise, the fast rows say little of it and the bias is found to about a
    hundredth of a deg/h; rows of equal weight would leave it off by tenths."""
    for seed in (0, 1, 2):
        rng = np.random.default_rng(seed)
        omega = rng.choice([0.0, 1e4, -1e4, 1e5, -1e5, 1e6, -1e6], 9000)
        T = rng.uniform(-1.0, 1.0, omega.size)
        y = 0.3 * T + 0.1 + omega * (1e-4 + 2e-5 * T) + 1e-11 * omega**2 * (1 + T)
        y = y + rng.normal(0.0, 0.01, omega.size)
        Phi = np.column_stack([T, np.ones_like(T)])
        fit = sf.fit_product_layer(Phi, y, omega)
        np.testing.assert_allclose(fit.weights[:, 0], [0.3, 0.1], atol=0.02)
        assert fit.noise.kappa > 1e-6  # the nonlinearity is seen as rate noise
        equal = sf._product_solve(Phi, y, omega, None)[0]
        assert np.abs(equal[:, 0] - [0.3, 0.1]).max() > 0.1


def test_the_scale_factor_of_noisy_fast_rows():
    Phi, y, omega = _heteroscedastic(5)
    fit = sf.fit_product_layer(Phi, y, omega)
    np.testing.assert_allclose(fit.weights[:, 0], [0.3, 0.1], atol=0.003)
    np.testing.assert_allclose(fit.weights[:, 1], [2e-5, 1e-4], atol=1e-6)  # 3 sd
    assert fit.noise.kappa == pytest.approx(1e-5, rel=0.2)


def test_the_penalty_shrinks_the_layer():
    Phi, y, omega = _heteroscedastic(3)
    free = sf.fit_product_layer(Phi, y, omega, np.zeros(2))
    shrunk = sf.fit_product_layer(Phi, y, omega, np.array([10.0, 0.0]))
    # the penalised slope columns (T and Ω T) move towards 0, the intercepts stay free
    assert abs(shrunk.weights[0, 0]) < 0.2 * abs(free.weights[0, 0])
    assert abs(shrunk.weights[0, 1]) < 0.2 * abs(free.weights[0, 1])
    np.testing.assert_allclose(shrunk.weights[1], free.weights[1], rtol=0.05)


def test_a_modelled_asymmetry_is_no_rate_noise():
    Phi, _, omega = _heteroscedastic(4)
    rng = np.random.default_rng(4)
    clean = 0.3 * Phi[:, 0] + 0.1 + omega * 1e-4 + rng.normal(0.0, 0.01, omega.size)
    fit = sf.fit_product_layer(Phi, clean + 2e-5 * np.abs(omega), omega)
    assert fit.asymmetry == pytest.approx(2e-5, rel=1e-3)
    assert fit.noise.kappa < 1e-8  # what is left does not grow with the input rate


def test_the_unit_message_gives_the_factor():
    omega = np.tile([0.0, 3600.0, -3600.0], 10)
    with pytest.raises(
        ValueError, match=r"by a factor of about 1\.06: a scale-factor error of 0\.06"
    ):
        sf.check_input_rate(omega, 0.06 * omega, "table")
