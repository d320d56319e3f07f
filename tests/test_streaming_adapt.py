"""Online recalibration of StreamingCompensator (recursive least squares) and its fast path.

Equalities are "to 1e-12 relative", with an absolute floor of 1e-12 times the largest value
(as in test_streaming.py). Recovery tests use noise-free data whose ageing the output layer
can represent exactly, so they assert the recursion's algebra, not a statistic.
"""

import json

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.neighbors import KNeighborsRegressor
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import FunctionTransformer, StandardScaler

from sklearn_ifog import RBFNetRegressor, ThermalFeatures
from sklearn_ifog._rls import initial_covariance, rls_sequence
from sklearn_ifog.datasets import age_campaign, make_thermal_campaign, noise_floor
from sklearn_ifog.streaming import StreamingCompensator

RTOL = 1e-12
MODES = [None, "bias", "output"]


@pytest.fixture(scope="module")
def campaign():
    bunch = make_thermal_campaign(n_units=1, n_runs=2, sampling_period=30.0, random_state=0)
    frame = bunch.frame.groupby("run", sort=False).head(400).reset_index(drop=True)
    return frame


def _features(**params):
    return ThermalFeatures(temperature="temperature", time="time", run="run", **params)


@pytest.fixture(scope="module")
def models(campaign):
    y = campaign["rate"] - campaign["reference"]
    rbf = RBFNetRegressor(n_centers=8, criterion=None, max_candidates=60, random_state=0)
    return {
        "rbf": make_pipeline(_features(), StandardScaler(), rbf).fit(campaign, y),
        "linear": make_pipeline(_features(), StandardScaler(), LinearRegression()).fit(
            campaign, y
        ),
        # Not compiled: scikit-learn evaluates it (adapt="bias" only).
        "knn": make_pipeline(_features(), StandardScaler(), KNeighborsRegressor(3)).fit(
            campaign, y
        ),
    }


def _close(actual, expected):
    expected = np.asarray(expected, dtype=np.float64)
    floor = RTOL * np.max(np.abs(expected))
    np.testing.assert_allclose(np.asarray(actual, dtype=np.float64), expected, RTOL, floor)


def _references(campaign, fraction=0.4, shift=0.05, seed=1):
    """References on a random part of the samples (None elsewhere), true rate + shift."""
    has = np.random.default_rng(seed).random(len(campaign)) < fraction
    return np.where(has, campaign["reference"].to_numpy() + shift, None), has


def _chunks(compensator, frame, rate, reference, size):
    drift = []
    for start in range(0, len(frame), size):
        stop = start + size
        drift.append(
            compensator.update(frame.iloc[start:stop], rate[start:stop], reference[start:stop])[1]
        )
    return np.concatenate(drift)


@pytest.mark.parametrize("mode", ["bias", "output"])
@pytest.mark.parametrize("name", ["rbf", "linear"])
def test_recalibration_is_the_same_whatever_the_chunking(models, campaign, mode, name):
    model = models[name]
    rate = campaign["rate"].to_numpy()
    reference, _ = _references(campaign)
    whole = StreamingCompensator(model, adapt=mode).update(campaign, rate, reference)[1]
    chunked = _chunks(StreamingCompensator(model, adapt=mode), campaign, rate, reference, 7)
    stepper = StreamingCompensator(model, adapt=mode)
    stepped = [
        stepper.step(t, temperature, r, run=run, reference=ref)[1]
        for t, temperature, r, run, ref in zip(
            campaign["time"],
            campaign["temperature"],
            rate,
            campaign["run"],
            reference,
            strict=True,
        )
    ]
    _close(chunked, whole)
    _close(stepped, whole)
    assert isinstance(stepped[0], float)
    # The recalibration moved the prediction (the references are 0.05 deg/h off the model).
    assert np.max(np.abs(whole - model.predict(campaign))) > 0.01
    final = StreamingCompensator(model, adapt=mode).update(campaign, rate, reference)
    assert final is not None
    states = [c.get_state()["rls"] for c in (stepper,)]
    assert states[0]["n_updates"] == int(np.sum(reference != None))  # noqa: E711


@pytest.mark.parametrize("mode", ["bias", "output"])
def test_recalibration_survives_save_and_restore(models, campaign, mode):
    model = models["rbf"]
    rate = campaign["rate"].to_numpy()
    reference, _ = _references(campaign)
    expected = StreamingCompensator(model, adapt=mode).update(campaign, rate, reference)[1]
    cut = 333
    first = StreamingCompensator(model, adapt=mode)
    head = first.update(campaign.iloc[:cut], rate[:cut], reference[:cut])[1]
    saved = json.loads(json.dumps(first.get_state()))
    second = StreamingCompensator(model, adapt=mode).set_state(saved)
    tail = _chunks(second, campaign.iloc[cut:], rate[cut:], reference[cut:], 11)
    _close(np.concatenate([head, tail]), expected)
    assert saved["adapt"] == mode
    n_weights = np.shape(saved["rls"]["weights"])[0]
    assert np.shape(saved["rls"]["covariance"]) == (n_weights, n_weights)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", ["rbf", "linear"])
def test_without_references_adaptation_changes_nothing(models, campaign, mode, name):
    model = models[name]
    compensator = StreamingCompensator(model, adapt=mode)
    assert compensator.compiled
    compensated, drift = compensator.update(campaign, campaign["rate"])
    _close(drift, model.predict(campaign))
    _close(compensated, campaign["rate"] - model.predict(campaign))
    if mode is not None:
        assert compensator.get_state()["rls"]["n_updates"] == 0


def test_bias_recalibration_of_a_model_that_is_not_compiled(models, campaign):
    model = models["knn"]
    with pytest.raises(ValueError, match=r"adapt='output' needs .*KNeighborsRegressor"):
        StreamingCompensator(model, adapt="output")
    compensator = StreamingCompensator(model, adapt="bias", forgetting=1.0)
    assert not compensator.compiled
    rate = campaign["rate"].to_numpy()
    # A shift of 0.1 deg/h, known on every sample of the first run: with no forgetting and
    # the diffuse prior the bias is the running mean of the residuals.
    first = campaign["run"] == campaign["run"].iloc[0]
    reference = campaign["reference"].to_numpy() - 0.1
    base = model.predict(campaign)
    drift = compensator.update(campaign[first], rate[first], reference[first])[1]
    residual = (rate - reference - base)[first.to_numpy()]
    bias = compensator.get_state()["rls"]["weights"][0][0]
    prior = 1.0 / initial_covariance(np.zeros((1, 1)), bias_index=0)[0, 0]
    np.testing.assert_allclose(bias, residual.sum() / (len(residual) + prior), rtol=1e-9)
    # Each sample is compensated before its own update.
    np.testing.assert_allclose(drift[0], base[0], rtol=1e-12)
    stepped = compensator.step(
        campaign["time"].iloc[-1] + 30.0, 20.0, 1.0, run=campaign["run"].iloc[-1]
    )
    assert isinstance(stepped[0], float)


def test_output_recalibration_recovers_an_aged_linear_model(campaign):
    # Noise-free: the model is exact, then the unit ages (x1.2 and +0.1 deg/h); both are
    # output-layer directions, so the diffuse prior learns them from one run.
    features = _features(terms=("T", "dT", "TdT"))
    X = campaign
    truth = 0.01 * X["temperature"] + 0.002 * X["temperature"] ** 2 / 10
    model = make_pipeline(features, StandardScaler(), Ridge(alpha=1e-12)).fit(X, truth)
    aged = 1.2 * model.predict(X) + 0.1
    first = (X["run"] == X["run"].iloc[0]).to_numpy()
    compensator = StreamingCompensator(model, adapt="output", forgetting=1.0)
    compensator.update(X[first], aged[first], np.zeros(first.sum()))
    compensated, _ = compensator.update(X[~first], aged[~first])
    before = aged[~first] - model.predict(X[~first])
    assert np.max(np.abs(compensated)) < 1e-3 * np.max(np.abs(before))


def test_forgetting_weighs_recent_references(models, campaign):
    # With forgetting, a bias that changes is tracked; without, it is averaged.
    model = models["linear"]
    n = 400
    rows = campaign.iloc[:n]
    rate = rows["rate"].to_numpy()
    reference = rows["reference"].to_numpy() - np.r_[np.zeros(n // 2), np.full(n - n // 2, 0.2)]
    base = model.predict(rows)
    learnt = {}
    for forgetting in (1.0, 0.95):
        compensator = StreamingCompensator(model, adapt="bias", forgetting=forgetting)
        compensator.update(rows, rate, reference)
        learnt[forgetting] = compensator.get_state()["rls"]["weights"][0][0]
    tail_residual = np.mean((rate - reference - base)[-50:])
    assert abs(learnt[0.95] - tail_residual) < abs(learnt[1.0] - tail_residual)
    assert abs(learnt[1.0] - np.mean(rate - reference - base)) < 1e-3


def test_rls_is_weighted_least_squares():
    # The recursion equals the closed form: argmin sum lam^(n-i) e_i^2 + lam^n (w - w0)' P0^-1
    # (w - w0) (with lam = 1 the covariance only shrinks: the trace bound never acts).
    rng = np.random.default_rng(0)
    design = np.column_stack([rng.normal(size=(60, 3)), np.ones(60)])
    target = design @ np.array([[0.5], [-1.0], [2.0], [0.3]]) + rng.normal(0, 0.1, (60, 1))
    w0 = np.array([[0.4], [-0.8], [1.5], [0.0]])
    P0 = initial_covariance(w0, bias_index=3)
    has = rng.random(60) < 0.7
    for lam in (1.0, 0.97):
        _, W, P, resets = rls_sequence(w0, P0, design, target, has, lam, P0)
        k = np.flatnonzero(has)
        weights = lam ** (len(k) - 1 - np.arange(len(k)))
        A = design[k]
        lhs = A.T @ (weights[:, None] * A) + lam ** len(k) * np.linalg.inv(P0)
        rhs = A.T @ (weights[:, None] * (target[k] - A @ w0))
        expected = w0 + np.linalg.solve(lhs, rhs)
        if lam == 1.0:
            np.testing.assert_allclose(W, expected, rtol=1e-8)
            np.testing.assert_allclose(P, np.linalg.inv(lhs), rtol=1e-6, atol=1e-12)
        assert resets == 0
        np.testing.assert_array_equal(P, P.T)
        assert np.all(np.linalg.eigvalsh(P) > 0)
        assert np.trace(P) <= np.trace(P0) * (1 + 1e-12)


def test_covariance_stays_bounded_and_is_reset_when_not_positive_definite(models, campaign):
    model = models["rbf"]
    rate = campaign["rate"].to_numpy()
    reference = campaign["reference"].to_numpy()
    compensator = StreamingCompensator(model, adapt="output", forgetting=0.9)
    compensator.update(campaign, rate, reference)
    state = compensator.get_state()
    P = np.array(state["rls"]["covariance"])
    P0 = compensator._prior["covariance"]
    np.testing.assert_array_equal(P, P.T)
    assert np.all(np.linalg.eigvalsh(P) > -1e-9 * np.trace(P0))
    assert np.trace(P) <= np.trace(P0) * (1 + 1e-12)  # wind-up bounded by the start
    # A negative definite covariance (symmetric, so accepted) is reset at the next update.
    broken = json.loads(json.dumps(state))
    broken["rls"]["covariance"] = (-np.eye(P.shape[0])).tolist()
    compensator.set_state(broken)
    compensator.update(
        campaign.iloc[-1:].assign(time=campaign["time"].iloc[-1] + 30), rate[:1], reference[:1]
    )
    after = compensator.get_state()["rls"]
    assert after["n_resets"] == state["rls"]["n_resets"] + 1
    assert np.all(np.isfinite(after["weights"]))
    assert np.all(np.linalg.eigvalsh(np.array(after["covariance"])) > 0)


def test_reset_keeps_the_recalibration_unless_asked(models, campaign):
    model = models["linear"]
    rows = campaign.iloc[:50]
    compensator = StreamingCompensator(model, adapt="bias")
    compensator.update(rows, rows["rate"], rows["reference"] - 0.1)
    learnt = compensator.get_state()["rls"]
    assert learnt["n_updates"] == 50
    assert compensator.reset().get_state()["rls"] == learnt
    assert compensator.reset(adaptation=True).get_state()["rls"]["n_updates"] == 0
    assert compensator.get_state()["rls"]["weights"] == [[0.0]]


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"adapt": "gain"}, r"adapt must be None, 'bias' or 'output', got 'gain'"),
        ({"forgetting": 0.0}, r"forgetting must be a number in \(0, 1\], got 0\.0"),
        ({"forgetting": 1.5}, r"forgetting must be a number in \(0, 1\], got 1\.5"),
        ({"forgetting": float("nan")}, r"forgetting must be a number in \(0, 1\], got nan"),
        ({"forgetting": "0.9"}, r"forgetting must be a number in \(0, 1\], got '0\.9'"),
    ],
)
def test_bad_parameters_are_named(models, params, message):
    with pytest.raises(ValueError, match=message):
        StreamingCompensator(models["rbf"], **params)


@pytest.mark.parametrize("mode", MODES)
def test_bad_input_leaves_the_state_exactly_as_it_was(models, campaign, mode):
    compensator = StreamingCompensator(models["rbf"], adapt=mode)
    rows = campaign.iloc[:20]
    compensator.update(rows, rows["rate"], rows["reference"] if mode else None)
    before = compensator.get_state()
    more = campaign.iloc[20:25]
    rate = more["rate"].to_numpy()
    t, temperature = more["time"].iloc[0], more["temperature"].iloc[0]
    bad_calls = [
        (r"rate contains NaN or inf", lambda: compensator.step(t, temperature, np.nan)),
        (
            r"reference contains NaN or inf",
            lambda: compensator.step(t, temperature, 1.0, reference=np.inf),
        ),
        (r"reference needs the rate", lambda: compensator.step(t, temperature, reference=1.0)),
        (
            r"rate contains NaN or inf \(1 value\(s\); first at row 2",
            lambda: compensator.update(more, np.where(np.arange(5) == 2, np.nan, rate)),
        ),
        (
            r"reference contains NaN or inf \(1 value\(s\); first at row 3",
            lambda: compensator.update(more, rate, [0.0, None, 1.0, np.nan, 0.0]),
        ),
        (r"reference needs the rate", lambda: compensator.update(more, None, np.zeros(5))),
        (r"reference has shape \(4,\)", lambda: compensator.update(more, rate, np.zeros(4))),
        (r"temperature contains NaN", lambda: compensator.step(t, np.nan, 1.0, reference=0.0)),
    ]
    for message, call in bad_calls:
        with pytest.raises(ValueError, match=message):
            call()
        assert compensator.get_state() == before, message


def test_set_state_checks_the_recalibration(models, campaign):
    compensator = StreamingCompensator(models["rbf"], adapt="output")
    state = compensator.get_state()
    plain = StreamingCompensator(models["rbf"])
    with pytest.raises(ValueError, match=r"adapt='output'; this one has adapt=None"):
        plain.set_state(state)
    bad = json.loads(json.dumps(state))
    bad["rls"]["weights"] = bad["rls"]["weights"][:-1]
    with pytest.raises(ValueError, match=r"weights of shape \(\d+, 1\)"):
        compensator.set_state(bad)
    bad = json.loads(json.dumps(state))
    bad["rls"]["covariance"][0][1] += 1.0
    with pytest.raises(ValueError, match="covariance'\\] must be symmetric"):
        compensator.set_state(bad)
    assert compensator.get_state() == state


def test_fallback_path_for_unknown_steps_equals_batch(campaign):
    model = make_pipeline(
        _features(), FunctionTransformer(np.tanh), StandardScaler(), Ridge(alpha=1e-3)
    ).fit(campaign, campaign["drift"])
    compensator = StreamingCompensator(model)
    assert not compensator.compiled
    stepped = [
        compensator.step(t, temperature, run=run)[1]
        for t, temperature, run in zip(
            campaign["time"][:50], campaign["temperature"][:50], campaign["run"][:50], strict=True
        )
    ]
    _close(stepped, model.predict(campaign.iloc[:50]))


def test_age_campaign(campaign):
    bunch = make_thermal_campaign(n_units=1, n_runs=3, sampling_period=60.0, random_state=3)
    runs = bunch.frame["run"].unique()
    aged = age_campaign(bunch, bias_shift=0.05, sensitivity_change=0.2, runs=runs[1:])
    later = bunch.frame["run"].isin(runs[1:]).to_numpy()
    old, new = bunch.frame, aged.frame
    np.testing.assert_array_equal(new["drift"][~later], old["drift"][~later])
    np.testing.assert_allclose(new["drift"][later], 1.2 * old["drift"][later] + 0.05, atol=1e-15)
    np.testing.assert_allclose(noise_floor(new), noise_floor(old), rtol=1e-9)
    np.testing.assert_allclose(aged.target, new["rate"] - new["reference"])
    assert aged.ageing == {"bias_shift": 0.05, "sensitivity_change": 0.2, "runs": list(runs[1:])}
    assert old is bunch.frame
    assert not np.shares_memory(old["rate"], new["rate"])
    with pytest.raises(ValueError, match=r"runs \[99\] are not in the campaign"):
        age_campaign(bunch, runs=[99])
    arrays = make_thermal_campaign(n_units=1, n_runs=1, random_state=0, as_frame=False)
    with pytest.raises(ValueError, match="as_frame=True"):
        age_campaign(arrays)


@pytest.mark.parametrize("mode", ["bias", "output"])
def test_steps_and_chunks_mixed_share_one_recalibration(models, campaign, mode):
    # Chunks with references, then single steps, then a restored copy: one recursion.
    model = models["rbf"]
    rate = campaign["rate"].to_numpy()
    reference, _ = _references(campaign)
    expected = StreamingCompensator(model, adapt=mode).update(campaign, rate, reference)[1]
    compensator = StreamingCompensator(model, adapt=mode)
    drift = list(compensator.update(campaign.iloc[:300], rate[:300], reference[:300])[1])
    for i in range(300, 340):
        row = campaign.iloc[i]
        drift.append(
            compensator.step(row["time"], row["temperature"], rate[i], reference=reference[i])[1]
        )
    copy = StreamingCompensator(model, adapt=mode).set_state(compensator.get_state())
    for i in range(340, 380):
        row = campaign.iloc[i]
        drift.append(
            copy.step(row["time"], row["temperature"], rate[i], reference=reference[i])[1]
        )
    _close(drift, expected[:380])
    # Back to the fitted model: the plain compensator's drift again.
    copy.reset(adaptation=True)
    plain = StreamingCompensator(model)
    row = campaign.iloc[0]
    assert copy.step(row["time"], row["temperature"], run=row["run"])[1] == pytest.approx(
        plain.step(row["time"], row["temperature"], run=row["run"])[1], rel=1e-12
    )
