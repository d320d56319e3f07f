"""Checks of sklearn_ifog._transition that its mutants showed missing (tools/mutation.sh).

The search's pieces are checked against what they are meant to compute, written out here:
least squares refitted on the other folds, the hat functions' partition of unity, the
gain and standard error of the returned transition from its own candidate's columns.
"""

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression

from sklearn_ifog import _transition
from sklearn_ifog._contract import DEFAULT_STATE_TERMS
from sklearn_ifog.features import compute_thermal_features

LAGS = (300.0, 900.0, 1800.0, 3600.0)


def test_step_values_at_chosen_points():
    # logistic(1) = 1 / (1 + e^-1); the normal CDF at one width; softplus(0) = w log 2.
    np.testing.assert_allclose(
        _transition.step("logistic", 22.0, 20.0, 2.0), 1.0 / (1.0 + np.exp(-1.0)), rtol=1e-15
    )
    np.testing.assert_allclose(_transition.step("erf", 21.0, 20.0, 1.0), 0.8413447460685429)
    np.testing.assert_allclose(_transition.step("hinge", 20.0, 20.0, 3.0), 3.0 * np.log(2.0))


def test_an_unknown_shape_names_the_shapes():
    with pytest.raises(
        ValueError, match=r"'bogus'; expected one of \['logistic', 'erf', 'hinge'\]"
    ):
        _transition.step("bogus", 1.0, 0.0, 1.0)


def test_multiplier_names():
    assert _transition.multiplier_names((900.0, 3600.0)) == [
        "",
        "_dT",
        "_T_lag900s",
        "_T_lag3600s",
    ]
    assert _transition.multiplier_names((90.5,), has_rate=False) == ["", "_T_lag90.5s"]


def test_check_search_completes_and_converts():
    grid = _transition.check_search({"shapes": "erf", "widths": 0.5, "centres": (1, 4)})
    assert grid["shapes"] == ("erf",)
    assert grid["widths"] == (0.5,)  # a single width below 1 degC is valid
    assert grid["lags"] == _transition.DEFAULT_SEARCH["lags"]
    assert grid["centres"] == (1.0, 4.0)
    assert all(type(value) is float for value in grid["centres"] + grid["widths"])
    assert _transition.check_search({})["shapes"] == _transition.TRANSITION_SHAPES


def test_check_search_names_only_the_bad_shapes():
    with pytest.raises(ValueError, match=r"unknown shape\(s\) \['bogus'\]; expected"):
        _transition.check_search({"shapes": ("logistic", "bogus")})
    with pytest.raises(ValueError, match=r"unknown shape\(s\) \(\); expected"):
        _transition.check_search({"shapes": ()})


@pytest.mark.parametrize("runs", [None, np.array([2, 0, 2, 1, 0, 2, 0, 1, 2, 2, 0, 1, 0])])
def test_search_rows_take_every_kth_row_of_each_run(monkeypatch, runs):
    monkeypatch.setattr(_transition, "MAX_SEARCH_ROWS", 5)
    n_samples = 13
    stride = 3  # ceil(13 / 5)
    labels = np.zeros(n_samples, dtype=int) if runs is None else runs
    expected = sorted(
        row for label in np.unique(labels) for row in np.flatnonzero(labels == label)[::stride]
    )
    assert _transition.search_rows(runs, n_samples).tolist() == expected
    monkeypatch.setattr(_transition, "MAX_SEARCH_ROWS", 13)
    assert _transition.search_rows(runs, n_samples).tolist() == list(range(n_samples))


def test_standardise():
    columns = np.column_stack([np.arange(5.0) + 100.0, np.full(5, 7.0), [1.0, 3.0, 2.0, 8.0, 0.0]])
    out = _transition._standardise(columns)
    np.testing.assert_allclose(out[:, [0, 2]].mean(axis=0), 0.0, atol=1e-14)
    np.testing.assert_allclose(out[:, [0, 2]].std(axis=0), 1.0)
    np.testing.assert_array_equal(out[:, 1], 0.0)  # a constant column carries nothing


def test_smooth_coefficients_are_hats_times_each_multiplier():
    temperature = np.linspace(-3.0, 30.0, 67)
    rate = np.cos(temperature)
    base = np.column_stack([temperature, temperature**2])
    out = _transition._smooth_coefficients(base, temperature, [None, rate])
    knots = np.arange(-3.0, 30.0 + 8.0, 8.0)  # from the coldest row, every KNOT_SPACING
    assert out.shape == (67, 2 + 2 * knots.size)
    hats = out[:, 2 : 2 + knots.size]
    np.testing.assert_allclose(hats.sum(axis=1), 1.0)  # a partition of unity over T
    assert hats.min() == 0.0
    np.testing.assert_allclose(hats[:, 0], np.maximum(0.0, 1.0 - np.abs(temperature + 3.0) / 8.0))
    np.testing.assert_allclose(out[:, 2 + knots.size :], hats * rate[:, None])


def test_fold_solver_predicts_each_fold_from_the_others():
    rng = np.random.default_rng(0)
    n_samples = 120
    base = rng.normal(size=(n_samples, 3)) * [1.0, 10.0, 0.1] + [5.0, 0.0, 1.0]
    extra = rng.normal(size=(n_samples, 1))
    Y = np.column_stack([base @ [1.0, 0.2, 3.0], extra[:, 0] * 2.0]) + rng.normal(
        size=(n_samples, 2)
    )
    folds = np.repeat([2, 0, 1], 40)
    solver = _transition._FoldSolver(base, Y, folds)
    for design, losses in (
        (base, solver.losses()),
        (np.hstack([base, extra]), solver.losses(extra)),
    ):
        expected = np.empty(n_samples)
        for fold in (0, 1, 2):
            held = folds == fold
            model = LinearRegression().fit(design[~held], Y[~held])
            expected[held] = np.sum((Y[held] - model.predict(design[held])) ** 2, axis=1)
        # to the search's ridge (1e-8 of the mean diagonal), far below the losses
        np.testing.assert_allclose(losses, expected[solver.order], rtol=1e-5, atol=1e-6)


def _glass_case(centre, seed=0, n_runs=4):
    """Runs ramping through ``centre``, a drift whose gain on the 3600-s lag excess steps
    there (a logistic of the 900-s lag, 0.75 degC wide), little noise."""
    rng = np.random.default_rng(seed)
    period = 60.0
    temperature, time, run = [], [], []
    for k in range(n_runs):
        low, high = centre - 14.0 - 2.0 * k, centre + 12.0 + 2.0 * k
        path = np.concatenate(
            [
                np.full(60, low),
                np.linspace(low, high, 240 + 20 * k),
                np.full(60, high),
                np.linspace(high, low, 200 + 20 * k),
            ]
        )
        temperature.append(path + 0.01 * rng.normal(size=path.size))
        time.append(np.arange(path.size) * period)
        run.append(np.full(path.size, k))
    T, t, runs = map(np.concatenate, (temperature, time, run))
    probe = compute_thermal_features(
        T,
        time=t,
        run=runs,
        terms=("T", "dT", *(f"T_lag{lag:g}s" for lag in LAGS)),
        smoothing=120.0,
    )
    deficit = dict(zip(LAGS, probe[:, 2:].T, strict=True))
    gain = _transition.step("logistic", T - deficit[900.0], centre, 0.75)
    y = 0.01 * T + 0.5 * deficit[3600.0] * (1.0 + 2.0 * gain) + 0.002 * rng.normal(size=T.size)
    base = compute_thermal_features(
        T, time=t, run=runs, terms=DEFAULT_STATE_TERMS, smoothing=120.0
    )
    return base, y, T, probe[:, 1], deficit, runs


def _search(case, **grid):
    base, y, T, rate, deficit, runs = case
    params = {"shapes": ("logistic",), "widths": (0.75,), "lags": (900.0,), **grid}
    return _transition.search_transition(
        base, y, T, rate, deficit.__getitem__, runs, base_lags=(900.0, 3600.0), **params
    )


def test_search_finds_a_half_degree_centre_and_reports_its_own_gain():
    case = _glass_case(20.5)
    found = _search(case)
    assert found.centre == 20.5  # the fine grid's half degrees, not rounded to whole ones
    assert found.terms == tuple(
        "logistic20.5C_w0.75C_lag900s" + suffix
        for suffix in ("", "_dT", "_T_lag900s", "_T_lag3600s")
    )
    # The gain and its standard error, recomputed from the found candidate's columns.
    base, y, T, rate, deficit, runs = case
    multipliers = [None, rate, deficit[900.0], deficit[3600.0]]
    Y = ((y - y.mean()) / y.std())[:, None]
    solver = _transition._FoldSolver(
        _transition._smooth_coefficients(base, T, multipliers), Y, runs
    )
    values = _transition.step("logistic", T - deficit[900.0], 20.5, 0.75)
    extra = np.column_stack([values if m is None else values * m for m in multipliers])
    without, with_step = solver.losses(), solver.losses(extra)
    assert found.held_out_gain == pytest.approx(1.0 - with_step.mean() / without.mean(), rel=1e-9)
    chunks = np.array_split(without - with_step, 20)  # 20 consecutive chunks of the rows
    assert without.size % 20 == 0
    error = np.std([chunk.mean() for chunk in chunks], ddof=1) / np.sqrt(20) / without.mean()
    assert found.standard_error == pytest.approx(error, rel=1e-9)


def test_search_reads_every_output_on_its_own_scale():
    case = _glass_case(20.5)
    base, y, T, rate, deficit, runs = case
    one = _search(case)
    assert type(one.n_candidates) is int
    assert one.n_candidates >= 13  # coarse and fine
    # A second output of pure noise on a far larger scale: each output counts once.
    noise = 1e3 * np.random.default_rng(5).normal(size=y.size) + 7.0
    Y = np.column_stack([y, noise])
    two = _transition.search_transition(
        base, Y, T, rate, deficit.__getitem__, runs,
        base_lags=(900.0, 3600.0), shapes=("logistic",), widths=(0.75,), lags=(900.0,),
    )  # fmt: skip
    multipliers = [None, rate, deficit[900.0], deficit[3600.0]]
    Z = (Y - Y.mean(axis=0)) / Y.std(axis=0)
    solver = _transition._FoldSolver(
        _transition._smooth_coefficients(base, T, multipliers), Z, runs
    )
    values = _transition.step("logistic", T - deficit[900.0], two.centre, 0.75)
    extra = np.column_stack([values if m is None else values * m for m in multipliers])
    gain = 1.0 - solver.losses(extra).mean() / solver.losses().mean()
    assert two.held_out_gain == pytest.approx(gain, rel=1e-9)
    # the noise output's held-out loss, in the denominator, dilutes the gain
    assert 0.0 < two.held_out_gain < one.held_out_gain


def test_search_without_a_rate_has_no_rate_terms():
    base, y, T, _, deficit, runs = _glass_case(20.5)
    found = _transition.search_transition(
        base, y, T, None, deficit.__getitem__, runs, base_lags=(3600.0,),
        shapes=("logistic",), widths=(0.75,), lags=(900.0,),
    )  # fmt: skip
    assert found.terms == (
        "logistic20.5C_w0.75C_lag900s",
        "logistic20.5C_w0.75C_lag900s_T_lag3600s",
    )


def test_search_stays_inside_the_given_centre_range():
    case = _glass_case(20.5)
    # The range's edge is the true centre: the grid holds it, and the fine grid around it
    # does not reach past the range.
    found = _search(case, centres=(17.0, 20.5))
    assert found.centre == 20.5
    found = _search(case, centres=(21.5, 30.0))
    assert 21.5 <= found.centre <= 30.0
    assert _search(case, centres=(20.2, 20.8)) is None  # no whole degree inside
