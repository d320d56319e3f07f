"""The policy objects (issue 43, point 2): what a compensation model predicts where it was
not calibrated, each policy one object of ``sklearn_ifog.policy``.

Every value below is computed by hand on a domain of one feature, a temperature calibrated
from 10 to 40 degC (31 rows, standard deviation ``SD``, threshold 1 at this size), so a row
``40 + k SD`` degC lies at distance ``k``.
"""

import numpy as np
import pytest

from sklearn_ifog.domain import CalibrationDomain, locate
from sklearn_ifog.fallback import Fallback
from sklearn_ifog.policy import (
    POLICY_NAMES,
    BlendWithFallback,
    CFragment,
    ClipToDomain,
    KeepModel,
    UncalibratedPolicy,
    policy_for,
)

T = np.linspace(10.0, 40.0, 31)
SD = T.std()


@pytest.fixture(scope="module")
def domain():
    fitted = CalibrationDomain(margin=1.0, temperature=0).fit(T[:, None])
    assert fitted.threshold_ == 1.0  # too few rows to calibrate it: the margin
    return fitted


def _rows(domain, *temperatures):
    rows = np.array(temperatures, dtype=np.float64)[:, None]
    return rows, locate(domain, rows)


# --- policy_for -----------------------------------------------------------------------------


def test_policy_for_resolves_every_name_to_a_fresh_object():
    assert POLICY_NAMES == ("blend", "clip", "none")
    for name, kind in zip(POLICY_NAMES, (BlendWithFallback, ClipToDomain, KeepModel), strict=True):
        policy = policy_for(name)
        assert type(policy) is kind
        assert isinstance(policy, UncalibratedPolicy)
        assert policy.name == name
        assert policy.parameter_text == f"uncalibrated={name!r}"
        assert policy_for(name) is not policy
    assert repr(policy_for("blend")) == "BlendWithFallback(width=1.0)"
    assert repr(policy_for("clip")) == "ClipToDomain()"


def test_policy_for_names_the_parameter():
    with pytest.raises(ValueError, match=r"^uncalibrated must be one of \['blend', 'clip', "):
        policy_for("hold")
    with pytest.raises(ValueError, match="got 'Blend'"):
        policy_for("Blend")  # names are exact
    with pytest.raises(TypeError, match=r"uncalibrated must be a str .* got NoneType None"):
        policy_for(None)
    with pytest.raises(TypeError, match="got list"):
        policy_for(["blend"])


def test_the_flags_say_what_each_policy_needs():
    flags = {
        name: (policy.uses_fallback, policy.moves_rows, policy.keeps_model)
        for name, policy in ((name, policy_for(name)) for name in POLICY_NAMES)
    }
    assert flags == {
        "blend": (True, False, False),
        "clip": (False, True, False),
        "none": (False, False, True),
    }


def test_the_blend_width_is_checked():
    assert BlendWithFallback().width == 1.0
    assert BlendWithFallback(width=2).width == 2.0
    assert BlendWithFallback(width=np.float32(0.5)).width == 0.5
    for bad in (0.0, -1.0, float("nan"), float("inf"), True, "1"):
        with pytest.raises(ValueError, match="width must be a finite number > 0"):
            BlendWithFallback(width=bad)


# --- apply: the arithmetic, by hand -----------------------------------------------------------


def test_blend_moves_to_the_fallback_by_a_smoothstep_of_the_distance(domain):
    # 0.25, 0.5 and 0.75 beyond the threshold (1): weights s^2 (3 - 2 s) = 0.15625, 0.5,
    # 0.84375; 2 beyond: the fallback alone; 41 degC lies within the threshold (distance
    # 1 / SD < 1) but beyond the calibrated 40 degC: outside, with weight 0.
    beyond = np.array([0.25, 0.5, 0.75, 2.0])
    rows, where = _rows(domain, 25.0, 41.0, *(40.0 + (1.0 + beyond) * SD))
    assert where.outside.tolist() == [False, True, True, True, True, True]
    prediction = np.full((6, 1), 7.0)
    fallback = Fallback(np.array([1.0]), np.array([0.0]), 0)  # a constant 1
    blended = BlendWithFallback().apply(
        prediction, rows, where.distance, where.outside, domain=domain, fallback=fallback
    )
    expected = [7.0, 7.0, 7.0 - 6.0 * 0.15625, 4.0, 7.0 - 6.0 * 0.84375, 1.0]
    np.testing.assert_allclose(blended[:, 0], expected, rtol=1e-12)
    assert blended[0, 0] == blended[1, 0] == 7.0  # exactly the model's
    np.testing.assert_array_equal(prediction, 7.0)  # not modified
    # A wider blend: 0.5 beyond a width of 2 is s = 0.25.
    wide = BlendWithFallback(width=2.0).apply(
        prediction, rows, where.distance, where.outside, domain=domain, fallback=fallback
    )
    np.testing.assert_allclose(wide[3, 0], 7.0 - 6.0 * 0.15625, rtol=1e-12)


def test_blend_weighs_a_line_fallback_per_row(domain):
    # The fallback a line in T, 0.1 per degree: at 40 + 3 SD degC it takes the row whole.
    rows, where = _rows(domain, 40.0 + 3.0 * SD)
    fallback = Fallback(np.array([-2.0]), np.array([0.1]), 0)
    blended = BlendWithFallback().apply(
        np.array([[7.0]]), rows, where.distance, where.outside, domain=domain, fallback=fallback
    )
    np.testing.assert_allclose(blended, [[-2.0 + 0.1 * (40.0 + 3.0 * SD)]], rtol=1e-12)


def test_clip_evaluates_the_model_at_the_nearest_calibrated_point(domain):
    # One temperature feature: its range admits no margin, so the nearest point of the
    # domain to 45 degC is 40 degC and to 5 degC is 10 degC.
    rows, where = _rows(domain, 25.0, 45.0, 5.0)
    evaluated = []

    def evaluate(moved):
        evaluated.append(moved.copy())
        return 2.0 * moved

    clipped = ClipToDomain().apply(
        2.0 * rows, rows, where.distance, where.outside, domain=domain, evaluate=evaluate
    )
    np.testing.assert_allclose(clipped[:, 0], [50.0, 80.0, 20.0], rtol=1e-12)
    np.testing.assert_allclose(evaluated[0][:, 0], [40.0, 10.0], rtol=1e-12)  # outside only


def test_no_policy_changes_a_block_without_rows_outside(domain):
    rows, where = _rows(domain, 15.0, 25.0)
    prediction = np.array([[1.0], [2.0]])
    for name in POLICY_NAMES:
        same = policy_for(name).apply(
            prediction,
            rows,
            where.distance,
            where.outside,
            domain=domain,
            fallback=None,
            evaluate=None,
        )
        assert same is prediction, name


def test_keep_model_returns_the_prediction_itself(domain):
    rows, where = _rows(domain, 25.0, 300.0)
    prediction = np.array([[1.0], [2.0]])
    kept = KeepModel().apply(prediction, rows, where.distance, where.outside, domain=domain)
    assert kept is prediction


# --- fallback_share and changed_rows ---------------------------------------------------------


def test_fallback_share_is_the_blend_weight_and_zero_for_the_others():
    distance = 1.0 + np.array([0.0, 0.25, 0.5, 0.75, 1.0, 5.0])
    np.testing.assert_allclose(
        BlendWithFallback().fallback_share(distance, 1.0),
        [0.0, 0.15625, 0.5, 0.84375, 1.0, 1.0],
        atol=1e-15,
    )
    for name in ("clip", "none"):
        share = policy_for(name).fallback_share(distance, 1.0)
        assert share.dtype == np.float64
        np.testing.assert_array_equal(share, 0.0)


def test_changed_rows_without_predicting(domain):
    # inside; beyond T within the threshold; far
    rows, where = _rows(domain, 25.0, 41.0, 300.0)
    assert BlendWithFallback().changed_rows(rows, where, domain).tolist() == [False, False, True]
    assert ClipToDomain().changed_rows(rows, where, domain).tolist() == [False, True, True]
    assert KeepModel().changed_rows(rows, where, domain).tolist() == [False, False, False]


def test_clip_leaves_a_row_outside_by_its_rate_alone_unchanged():
    # A heating-only calibration: a slow cooling row at a calibrated temperature is outside
    # by its rate, which the projection does not move (sklearn_ifog.domain.project_to_box).
    t = np.linspace(0.0, 1.0, 400)
    temperature = 10.0 + 30.0 * np.clip((t - 0.2) / 0.6, 0.0, 1.0)
    rate = np.gradient(temperature)
    X = np.column_stack([temperature, rate, temperature * rate])
    domain = CalibrationDomain(margin=1.5, temperature=0, rate=1).fit(X)
    sd = X[:, 1].std()
    rows = np.array([[25.0, -sd, -25.0 * sd], [25.0, 0.0, 0.0], [55.0, 0.0, 0.0]])
    where = locate(domain, rows)
    assert where.outside.tolist() == [True, False, True]
    assert ClipToDomain().changed_rows(rows, where, domain).tolist() == [False, False, True]
    # ... while the blend hands it to the fallback (its distance is beyond the threshold);
    # the last row, outside by its temperature alone within the threshold, it leaves alone.
    share = BlendWithFallback().fallback_share(where.distance, domain.threshold_)
    assert share[0] > 0.0 == share[2]
    assert BlendWithFallback().changed_rows(rows, where, domain).tolist() == [True, False, False]


# --- describe ---------------------------------------------------------------------------------


def test_each_policy_describes_itself():
    assert KeepModel().describe(5, 5, "line") == (
        "the model extrapolated freely, nothing bounding its error (uncalibrated='none')"
    )
    held = (
        "the model was held at the domain's edge, its prediction at the nearest calibrated "
        "point (uncalibrated='clip')"
    )
    assert ClipToDomain().describe(5, 0, "line") == held
    assert ClipToDomain().describe(5, 2, "line") == (
        held + ", for 3 of these 5 rows; the other 2 kept the model's own prediction"
    )
    blend = BlendWithFallback()
    assert blend.describe(4, 0, "constant") == (
        "the model fell back towards the calibration's mean drift (a constant: no slope in T "
        "extrapolated better), the farther out the more (uncalibrated='blend')"
    )
    assert blend.describe(4, 1, "plane").endswith(
        "(uncalibrated='blend'), for 3 of these 4 rows; the other 1 kept the model's own "
        "prediction"
    )
    assert blend.describe(4, 4, "line") == (
        "each of these 4 rows kept the model's own prediction: uncalibrated='blend' gives way "
        "to its fallback, a line in T fitted on the calibration, only farther from the "
        "calibrated combinations than these rows lie"
    )


# --- the C fragment -------------------------------------------------------------------------


def _fragment(name, temperatures=True):
    calls = []

    def fallback():
        calls.append(1)
        return "ifog_fallback_intercept[k]", False

    fragment = policy_for(name).c_fragment(
        "ifog", temperatures=temperatures, fallback=fallback, fallback_words="a constant"
    )
    assert isinstance(fragment, CFragment)
    return fragment, len(calls)


def test_each_policy_hands_the_c_writer_its_fragment():
    blend, calls = _fragment("blend")
    assert calls == 1
    assert "static void ifog_blend(" in blend.after_flag
    assert "const double fallback = ifog_fallback_intercept[k];" in blend.after_flag
    assert "    (void)features;\n" in blend.after_flag  # the constant reads no feature
    assert "ifog_blend(features, *distance, drift);" in blend.guarded_call
    assert "ifog_blend(features, *distance, drift);" in blend.recalibrated_call
    assert (blend.functions, blend.flag_block) == ("", "")
    assert "IFOG_MARGIN + IFOG_BLEND_WIDTH" in blend.description
    assert blend.description.endswith("the fallback is a constant")

    clip, calls = _fragment("clip")
    assert calls == 0  # no fallback code for a policy without one
    assert "static void ifog_project(" in clip.functions
    assert "static void ifog_pull_back(" in clip.functions
    assert "IFOG_PROJECTION_ROUNDS" in clip.flag_block
    assert (clip.after_flag, clip.guarded_call, clip.recalibrated_call) == ("", "", "")
    once, _ = _fragment("clip", temperatures=False)
    assert "ifog_pull_back" not in once.functions
    assert "ifog_project(coordinates, inside, box, evaluated);" in once.flag_block

    none, calls = _fragment("none")
    assert calls == 0
    assert none[:5] == ("", "", "", "", "")
    assert none.description == "the model's own\n * extrapolation (the sample is only flagged)"


# --- what the mutation run of policy.py found untested ---------------------------------------


def test_clip_refuses_a_detector_without_a_box_by_the_policys_name():
    from sklearn.covariance import EllipticEnvelope

    rows = np.random.default_rng(0).normal(size=(60, 2))
    detector = EllipticEnvelope(random_state=0).fit(rows)
    where = locate(detector, rows)
    message = r"^uncalibrated='clip' needs the pipeline's domain to be a CalibrationDomain"
    with pytest.raises(ValueError, match=message):
        ClipToDomain().changed_rows(rows, where, detector)
    with pytest.raises(ValueError, match=message):
        ClipToDomain().apply(
            np.zeros((60, 1)), rows, where.distance, where.outside, domain=detector
        )


def test_the_share_follows_the_blends_own_width():
    distance = np.array([1.0, 2.0, 3.0])
    np.testing.assert_allclose(
        BlendWithFallback(width=2.0).fallback_share(distance, 1.0), [0.0, 0.5, 1.0]
    )


def test_shares_and_changed_rows_have_one_value_per_row(domain):
    rows, where = _rows(domain, 25.0, 41.0, 300.0)
    for policy in (KeepModel(), ClipToDomain(), BlendWithFallback()):
        share = policy.fallback_share(where.distance, 1.0)
        assert share.shape == (3,)
        assert share.dtype == np.float64
        changed = policy.changed_rows(rows, where, domain)
        assert changed.shape == (3,)
        assert changed.dtype == bool


def test_clip_counts_a_single_row_that_kept_the_models_prediction():
    assert (
        ClipToDomain()
        .describe(5, 1, "line")
        .endswith(", for 4 of these 5 rows; the other 1 kept the model's own prediction")
    )
