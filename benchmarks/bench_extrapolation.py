"""Outside the calibration: whether the default compensation is ever worse than none there.

Run (about 5 min on two cores)::

    python benchmarks/bench_extrapolation.py --n-jobs 2

``--quick`` (CI): one tuning seed (0), one preset (layered_glass), 240 s samples, the real
recording's warm->cold split (axes x and z), the peer ratios and flag rates as ``INFO``;
``--tune``: the sweeps on the tuning seeds. Writes
``benchmarks/results/extrapolation[_quick|_tune].md`` and ``.json`` (``--out DIR``
elsewhere). The cases are built in ``_cases.py`` (its ``bench_extrapolation`` section).

A gyro is calibrated in a chamber and then used in conditions the chamber did not show. This
benchmark calibrates as the reference paper does (heating only) or on part of a recording,
compensates conditions outside that calibration, and compares, on the rows outside the
calibrated temperatures, the rows inside them at rates never calibrated, and the rows inside
the calibration domain:

- ``uncompensated``: the calibration's mean drift removed (bias calibration only, no
  thermal model; with the simulator's per-run turn-on biases this is stricter than the raw
  output);
- ``line in T``: ``LinearRegression`` on the temperature;
- ``held line in T``: the same line evaluated at the temperature clamped to the calibrated
  [TMIN, TMAX], the firmware practice (PX4, ArduPilot);
- ``poly3 in T`` and ``held poly3 in T``: a cubic in the temperature, free and held;
- ``linear (features)``: ``LinearRegression`` on the default features, with the default
  uncalibrated policy (the linear model on the same features);
- ``default``: ``make_compensation_pipeline(RBFNetRegressor(random_state=0))`` (policy
  ``uncalibrated="blend"``), and the same network with ``uncalibrated="none"`` (the behaviour
  before the calibration domain) and ``"clip"``, and with ``tail_alpha="auto"``.

Cases:

1. **simulator, heating-only calibration**: per physics preset (lumped, layered,
   layered_glass) and seed, one gyro calibrated on ``profile="paper"`` runs (soak, ramp
   *up*, soak) between 10 and 40 degC at two azimuths, then compensated on runs of the same
   unit (same seed) that cycle down to -10 degC (``profile="cycle"``) and that only cool
   (``profile="cooling"``). Row groups: *outside T* (colder or warmer than every calibrated
   temperature), *new rates* (inside the calibrated temperatures, with a rate dT outside
   the calibrated rates), *inside* (inside the domain).
2. **simulator, shared profiles**: the same presets and seeds, a ``make_thermal_campaign``
   of one unit, four azimuths, ``profile="paper"`` at one ramp rate, split leave one
   azimuth out: the share of flagged rows (and, reported, among the held-out runs that
   never leave the calibrated temperatures).
3. **real recording** (``load_psim_tvc``, averaged to one row per second, one run, a time
   column, so the default features with their lags): calibrate on the 12 warmer bursts and
   compensate the 13 colder ones, the reverse, and alternate bursts; axes x, y and z.

Targets (exit 1 when one fails):

- outside T (case 1): the default's MSD <= 1.5 x the best of uncompensated, the line in T
  and the held line on every case, and the median of that ratio over the cases <= 1;
  <= uncompensated wherever the line is;
- new rates (case 1): the default's MSD <= 1.2 x the line in T;
- flags: >= 95 % of the outside-T rows flagged (case 1); in case 2, <= 2 % of the rows
  inside the calibrated temperatures flagged;
- what the policy costs where calibration and use share profiles (case 2, on the campaign of
  ``bench_thermal_state.py``): the default's pooled MSD <= 1.02 x ``uncalibrated="none"``'s, and
  the share of those held-out rows flagged <= 2 % on average over the campaigns, <= 5 % on
  each;
- the first rule, on every group of case 1 outside the calibration (outside T, new rates):
  the default's MSD <= 1.05 x uncompensated;
- real recording: warm->cold and cold->warm, >= 95 % of the rows flagged; on x and y the
  default <= uncompensated and <= 1.5 x the line in T; on z (no thermal drift to speak of)
  <= uncompensated; alternate bursts (even->odd, odd->even) on x and y the default <= 1 x
  the line and the network alone (``uncalibrated="none"``) <= 2 x the line, on z the default
  <= uncompensated.

Tuning and judging are kept apart: the blend width
(``sklearn_ifog.policy.BlendWithFallback().width``, 1) and the margin (1.5) were chosen on
seeds 0-7 (``--tune`` prints the blend width and margin sweeps on them; the margin is the
smallest of the sweep that leaves at most 2 % of the shared-profile rows inside the
calibrated temperatures flagged there); the verdicts are scored on the register's judged
seeds (``_cases.SEEDS``; 8-12 until issue 42 retired them), which played no part in the
choice.
The width was first chosen as 10 on seeds 0-2, where it met the new-rates target on every
case; seed 3 then showed it keeping a network 11-18 x worse than the line (``--tune``) (a glass
transition seen heating only), so safety decided for the narrowest width of the sweep.
The fallback's plane in T and dT (``sklearn_ifog._tuning.REPEATED_RATIO``, 0.75) was chosen
the same way: on seeds 0-7, from the ``repeated_ratio`` sweep of ``--tune``, as the ratio
with the fewest first-rule failures, then the fewest outside-T failures; and then the held-out
scale at which a plane with a ratio between it and 1 is trusted too
(``sklearn_ifog._tuning.CARRIED_SCALE``, 0.9), from the ``carried_scale`` sweep by the same
order, a tie going to the value that trusts the plane less. The weight of a rate's excess in
the domain's distance (``sklearn_ifog._tuning.RATE_WEIGHT``, 2) came last, from the
``rate weight`` sweep of ``--tune`` (0, no rate term, to 4): the largest weight that keeps
the shared-profile rows inside the calibrated temperatures flagged at most 2 % on every
tuning seed (3 and 4 do not).

Also printed (not a target): the fallback's evidence, per case, against what the line in T
and the default do outside the calibrated temperatures, and how the plane's
``repeated_ratio`` would fare at other values (:func:`evidence_markdown`): whether the
calibration can tell when a slope extrapolates.
And an alternative policy measured beside the blend (not a target, not the default): the
network's deviation from the fallback clamped to ``c`` times the half-range it spans on the
calibration rows (:func:`deviation_clamp`, ``c`` in ``CLAMP_FACTORS``), with each target's
failures counted for it and for the blend (:func:`clamp_markdown`).
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog._tuning import CARRIED_SCALE, RATE_WEIGHT, REPEATED_RATIO
from sklearn_ifog.datasets import noise_floor
from sklearn_ifog.domain import box_distance
from sklearn_ifog.fallback import (
    extremes_held_out,
    fit_fallback,
    held_out_runs,
)
from sklearn_ifog.policy import fallback_weight

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _cases import (
    EXTRAPOLATION_PROFILES,
    EXTRAPOLATION_QUICK_PHYSICS,
    EXTRAPOLATION_REAL_AXES,
    EXTRAPOLATION_REAL_SPLITS,
    PHYSICS,
    SEEDS,
    extrapolation_calibration,
    extrapolation_mixed_profiles,
    extrapolation_operation,
    extrapolation_shared_profiles,
    extrapolation_sizes,
    real_per_second,
)
from _results import add_out_argument, command_line, write_results
from _verdict import exit_code, verdict_line

JUDGED_SEEDS = SEEDS["bench_extrapolation"]["judged"]
TUNING_SEEDS = SEEDS["bench_extrapolation"]["tuning"]
SWEEP_WIDTHS = (1.0, 3.0, 10.0, 30.0)
SWEEP_MARGINS = (0.1, 0.5, 1.0, 1.5, 2.0)
# An alternative policy measured beside the blend (not the default): the network's
# deviation from the fallback clipped to c times the half-range it spans on the calibration
# rows (about their centre), on every row.
CLAMP_FACTORS = (1.0, 1.5, 2.0, 3.0)
# Held-out-run ratios at which ``fit_fallback`` would trust the plane in T and dT
# (``repeated_ratio``; the default, ``sklearn_ifog._tuning.REPEATED_RATIO``, was chosen on the
# tuning seeds from this sweep).
REPEATED_RATIOS = (0.5, 0.6, 0.75, 0.9, 1.0)
# Held-out scales at which ``fit_fallback`` would also trust a plane whose ratio lies between
# REPEATED_RATIO and 1 (``carried_scale``; the default, ``sklearn_ifog._tuning.CARRIED_SCALE``,
# was chosen on the tuning seeds from this sweep; inf: never, the rule before it).
CARRIED_SCALES = (0.8, 0.85, 0.9, 0.95, np.inf)
# Weights of a rate's excess beyond its calibrated range in the domain's distance (the
# default, ``sklearn_ifog._tuning.RATE_WEIGHT``, was chosen on the tuning seeds from this
# sweep; 0: no rate term, the domain before it).
RATE_WEIGHTS = (0.0, 1.0, 2.0, 3.0, 4.0)

OUTSIDE_RATIO = 1.5  # outside T: <= 1.5 x the better of uncompensated and the line
RATE_RATIO = 1.2  # new rates: <= 1.2 x the line
FLAGGED_OUTSIDE = 0.95
FLAGGED_SHARED = 0.02
# Held-out runs of calibrated profiles (the 'mix' campaigns, leave one azimuth out): the
# share of their rows flagged, on average over the campaigns and at most on any one.
FLAGGED_HELD_OUT = 0.02
FLAGGED_HELD_OUT_MAX = 0.05
OUTSIDE_MEDIAN = 1.0  # outside T, over the cases: median <= 1 x the best of the peers
INTERLEAVED_RATIO = 1.0  # the recording's interleaved bursts: default <= 1 x the line
NETWORK_ALONE_RATIO = 2.0  # ... and the network alone <= 2 x the line
NEVER_WORSE = 1.05  # the first rule, within the noise of a held-out MSD
UNCHANGED_RATIO = 1.02  # what the policy may cost where calibration and use share profiles


def _network(**params):
    return RBFNetRegressor(random_state=0, **params)


def deviation_clamp(model, X_cal, X_op):
    """The alternative policy's predictions of ``X_op``, one per ``CLAMP_FACTORS`` entry.

    The fitted ``model``'s network (``uncalibrated="none"``) minus its fallback, clipped on every
    row to ``c`` times the half-range that difference spans on the calibration rows (about
    its centre), plus the fallback: where the calibration saw the network stay near the
    fallback, it may not leave it far anywhere else. A firmware-friendly clamp on the
    output, where the ``"clip"`` policy clamps the inputs.
    """
    features_cal = model.steps[0][1].transform(X_cal)
    features_op = model.steps[0][1].transform(X_op)
    policy = model.uncalibrated
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.set_params(uncalibrated="none")
        network_cal, network_op = model.predict(X_cal), model.predict(X_op)
        model.set_params(uncalibrated=policy)
    base_cal = model.fallback_.predict(features_cal)[:, 0]
    base_op = model.fallback_.predict(features_op)[:, 0]
    deviation = network_cal - base_cal
    centre = (deviation.max() + deviation.min()) / 2
    half = (deviation.max() - deviation.min()) / 2
    return {
        f"clamp {c:g}": base_op
        + np.clip(network_op - base_op, centre - c * half, centre + c * half)
        for c in CLAMP_FACTORS
    }


def fallback_evidence(X_cal, y_cal):
    """What the calibration says of the fallback's candidates (``fit_fallback``'s evidence).

    ``line``: a line in T's squared error over the constant's at the worse of the two
    calibrated extremes, each held out in turn; ``runs``: the plane in T and dT's over the
    constant's on each run held out (``held_out_runs``); ``plane ends``: the plane's over
    the constant's at the cold and the warm extreme.
    """
    features = make_compensation_pipeline(LinearRegression()).steps[0][1].fit(X_cal)
    raw = np.asarray(features.transform(X_cal))
    names = list(features.get_feature_names_out())
    temperature, rate = raw[:, names.index("T")], raw[:, names.index("dT")]
    line = extremes_held_out(temperature, y_cal[:, None])
    plane = extremes_held_out(temperature, y_cal[:, None], rate)
    runs, scale = held_out_runs(
        temperature, rate, y_cal[:, None], X_cal["run"].to_numpy(), return_scale=True
    )
    return {
        "line": max(float(end[1].mean() / end[0].mean()) for end in line),
        "runs": float(runs[0]),
        "scale": float(scale[0]),
        "plane ends": [float(end[1].mean() / end[0].mean()) for end in plane],
    }


def fallback_kind(fallback):
    """``"constant"``, ``"line"`` or ``"plane"``, with the side(s) held flat."""
    if fallback.rate_slope is not None and fallback.rate_slope[0] != 0:
        held = [
            side
            for side, hold in (("below", fallback.hold_below), ("above", fallback.hold_above))
            if hold[0]
        ]
        return "plane" + (f", flat {' and '.join(held)}" if held else "")
    return "line" if fallback.slope[0] != 0 else "constant"


def rate_weighted_distance(model, features, rate_weight):
    """The domain's distance of feature rows with the rate term at ``rate_weight`` (0: none).

    ``model.domain_``'s box with its rate scale rescaled from ``RATE_WEIGHT`` to
    ``rate_weight``: the distance ``predict`` would use had the domain been fitted with it.
    """
    box = model.domain_.box_
    if rate_weight == 0 or not box.rate_columns:
        box = box._replace(rate_columns=())
    else:
        box = box._replace(rate_scale=box.rate_scale * RATE_WEIGHT / rate_weight)
    return box_distance(box, features)


def rate_weight_sweep(model, features, network):
    """The blend at each ``RATE_WEIGHTS`` entry: the same network and fallback as the
    default's predict, only the rate term of the distance changes."""
    fallback = model.fallback_.predict(features)[:, 0]
    out = {}
    for rate_weight in RATE_WEIGHTS:
        distance = rate_weighted_distance(model, features, rate_weight)
        weight = fallback_weight(distance, model.domain_.threshold_)
        out[f"rate weight {rate_weight:g}"] = (1.0 - weight) * network + weight * fallback
    return out


def repeated_sweep(model, X_cal, y_cal, features_op, network_op):
    """The blend with the fallback ``fit_fallback`` gives at each ``REPEATED_RATIOS`` entry
    (``carried_scale`` at its default) and at each ``CARRIED_SCALES`` entry
    (``repeated_ratio`` at its default).

    The same network (``uncalibrated="none"``) and blend weights as the default's predict, only
    the fallback's rule changes.
    """
    transformer = model.steps[0][1]
    raw = np.asarray(transformer.transform(X_cal))
    column, rate_column = model.fallback_.column, list(model.feature_names_out_).index("dT")
    weight = fallback_weight(
        box_distance(model.domain_.box_, features_op), model.domain_.threshold_
    )
    out = {}
    rules = [(f"repeated {ratio:g}", ratio, CARRIED_SCALE) for ratio in REPEATED_RATIOS]
    rules += [(f"scale {scale:g}", REPEATED_RATIO, scale) for scale in CARRIED_SCALES]
    for key, ratio, scale in rules:
        fallback = fit_fallback(
            raw[:, column],
            y_cal[:, None],
            column,
            rate=raw[:, rate_column],
            rate_column=rate_column,
            runs=X_cal["run"].to_numpy(),
            repeated_ratio=ratio,
            carried_scale=scale,
        )
        blended = fallback.predict(features_op)[:, 0]
        out[key] = (1.0 - weight) * network_op + weight * blended
    return out


def peers(X_cal, y_cal, X_op):
    """Predictions of every model on ``X_op`` after calibrating on ``(X_cal, y_cal)``."""
    temperature_cal, temperature_op = X_cal[["temperature"]], X_op[["temperature"]]
    predictions = {"uncompensated": np.full(len(X_op), float(np.mean(y_cal)))}
    predictions["line in T"] = (
        LinearRegression().fit(temperature_cal, y_cal).predict(temperature_op)
    )
    poly3 = make_pipeline(PolynomialFeatures(3), LinearRegression())
    predictions["poly3 in T"] = poly3.fit(temperature_cal, y_cal).predict(temperature_op)
    # The firmware practice (PX4, ArduPilot): the calibrated polynomial evaluated at the
    # temperature clamped to the calibrated [TMIN, TMAX].
    held = temperature_op.clip(
        float(temperature_cal.min().iloc[0]), float(temperature_cal.max().iloc[0])
    )
    line = LinearRegression().fit(temperature_cal, y_cal)
    predictions["held line in T"] = line.predict(held)
    predictions["held poly3 in T"] = poly3.predict(held)
    predictions["linear (features)"] = (
        make_compensation_pipeline(LinearRegression()).fit(X_cal, y_cal).predict(X_op)
    )
    default = make_compensation_pipeline(_network()).fit(X_cal, y_cal)
    predictions["default"] = default.predict(X_op)
    for policy in ("none", "clip"):
        default.set_params(uncalibrated=policy)
        predictions[f"default, uncalibrated={policy!r}"] = default.predict(X_op)
    default.set_params(uncalibrated="blend")
    tail = make_compensation_pipeline(_network(tail_alpha="auto")).fit(X_cal, y_cal)
    predictions["default, tail_alpha='auto'"] = tail.predict(X_op)
    handover = make_compensation_pipeline(_network(), handover=True).fit(X_cal, y_cal)
    predictions["default, handover"] = handover.predict(X_op)
    features = default.steps[0][1].transform(X_op)
    distance = default.calibration_distance(X_op)
    # The blend at other widths, from the same network and fallback (the formula of predict).
    fallback = default.fallback_.predict(features)[:, 0]
    none = predictions["default, uncalibrated='none'"]
    sweep = {}
    for width in SWEEP_WIDTHS:
        weight = fallback_weight(distance, default.domain_.threshold_, width)
        sweep[f"blend width {width:g}"] = (1.0 - weight) * none + weight * fallback
    sweep.update(deviation_clamp(default, X_cal, X_op))
    sweep.update(rate_weight_sweep(default, features, none))
    return predictions, sweep, default, features


def beyond_calibrated_temperatures(temperature, calibrated):
    """Whether each of ``temperature`` lies outside the range of the ``calibrated`` ones."""
    return (temperature < calibrated.min()) | (temperature > calibrated.max())


def _msd(y, prediction, mask):
    return float(np.mean(np.square(y[mask] - prediction[mask]))) if mask.any() else None


def _score(y, predictions, groups):
    return {
        group: {
            "rows": int(mask.sum()),
            **{name: _msd(y, p, mask) for name, p in predictions.items()},
        }
        for group, mask in groups.items()
    }


def simulator_case(physics, seed, sampling_period, n_runs):
    """Case 1: heating-only calibration, cycling and cooling operation; scores per group."""
    calibration = extrapolation_calibration(physics, seed, sampling_period, n_runs)
    X_cal, y_cal = calibration.data, calibration.target.to_numpy()
    evidence = fallback_evidence(X_cal, y_cal)
    record = {}
    for profile in EXTRAPOLATION_PROFILES:
        operation = extrapolation_operation(profile, physics, seed, sampling_period, n_runs)
        X_op, y_op = operation.data, operation.target.to_numpy()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            predictions, sweep, model, features = peers(X_cal, y_cal, X_op)
            sweep.update(
                repeated_sweep(
                    model, X_cal, y_cal, features, predictions["default, uncalibrated='none'"]
                )
            )
        outside_t = beyond_calibrated_temperatures(
            X_op["temperature"].to_numpy(), X_cal["temperature"].to_numpy()
        )
        rate_column = list(model.feature_names_out_).index("dT")
        rate = features[:, rate_column]
        rate_low = model.domain_.data_min_[rate_column]
        rate_high = model.domain_.data_max_[rate_column]
        new_rates = ~outside_t & ((rate < rate_low) | (rate > rate_high))
        flagged = model.outside_calibration(X_op)
        groups = {"outside T": outside_t, "new rates": new_rates, "inside domain": ~flagged}
        record[profile] = {
            "scores": _score(y_op, predictions, groups),
            "sweep": _score(y_op, sweep, groups),
            "flagged outside T": float(flagged[outside_t].mean()) if outside_t.any() else None,
            "fallback": fallback_kind(model.fallback_),
            "evidence": evidence,
        }
    return record


def shared_profile_case(physics, seed, sampling_period, n_runs):
    """Case 2: leave one azimuth out; flagged rows, and what the policy costs there.

    The runs share their profile (``"paper"``, one ramp rate) for the flags; their levels
    are still drawn per run, so a held-out run can reach a temperature no calibration run
    reached: those rows are outside by definition (and flagged), so the share that the
    target bounds is that of the rows inside the calibrated temperatures; the total is
    reported too, and (not a target) the share among the rows of the held-out runs that
    stay inside the calibrated temperatures from start to end: a run that later rises
    above them is still ramping at temperatures where every calibration run soaked, a
    thermal state the calibration did not show, even on its rows inside them. The cost:
    the default network with its policy against the same network with ``uncalibrated="none"``,
    pooled MSD over the noise floor, leave one azimuth out on the campaign of
    ``bench_thermal_state.py`` (``profile="mix"``, drawn ramp rates), and the part of it
    that arises on the rows outside the calibrated temperatures and on the flagged rows
    inside them.
    """
    X, y = extrapolation_shared_profiles(physics, seed, sampling_period, n_runs)
    flagged, flagged_inside_t, rows, rows_inside_t = 0, 0, 0, 0
    contained_rows, contained_flagged = 0, 0
    by_margin, by_rate = {}, {}
    temperature = X["temperature"].to_numpy()
    for azimuth in np.unique(X["azimuth"]):
        held = (X["azimuth"] == azimuth).to_numpy()
        model = make_compensation_pipeline(LinearRegression()).fit(X[~held], y[~held])
        outside = model.outside_calibration(X[held])
        inside_t = ~beyond_calibrated_temperatures(temperature[held], temperature[~held])
        flagged += int(outside.sum())
        flagged_inside_t += int(outside[inside_t].sum())
        # Runs that never leave the calibrated temperatures: the strict reading of "shared
        # profiles" (a run that later rises above them ramps where the calibration soaked).
        runs = X["run"].to_numpy()[held]
        escaped = np.unique(runs[~inside_t])
        contained = ~np.isin(runs, escaped)
        contained_rows += int(contained.sum())
        contained_flagged += int(outside[contained].sum())
        # The margin sweep (the temperature rule flags nothing inside the calibrated T).
        distance = model.calibration_distance(X[held])[inside_t]
        for margin in SWEEP_MARGINS:
            by_margin[margin] = by_margin.get(margin, 0) + int((distance > margin).sum())
        rows_held = model.steps[0][1].transform(X[held])[inside_t]
        for rate_weight in RATE_WEIGHTS:
            weighted = rate_weighted_distance(model, rows_held, rate_weight)
            by_rate[rate_weight] = by_rate.get(rate_weight, 0) + int(
                (weighted > model.domain_.threshold_).sum()
            )
        rows += int(held.sum())
        rows_inside_t += int(inside_t.sum())
    mixed = extrapolation_mixed_profiles(physics, seed, sampling_period, n_runs)
    X, y = mixed.data, mixed.target.to_numpy()
    squared = {"default": 0.0, "default, uncalibrated='none'": 0.0}
    floor, outside_rows = 0.0, 0
    # Where the policy's cost arises: the default's squared error beyond uncalibrated='none''s,
    # summed over the rows outside the calibrated temperatures and over the flagged rows
    # inside them.
    excess = {"outside T": 0.0, "flagged inside T": 0.0}
    by_kind, handover_rows = {}, 0
    fit_seconds = {"default": 0.0, "handover": 0.0}
    temperature = X["temperature"].to_numpy()
    for azimuth in np.unique(X["azimuth"]):
        held = (X["azimuth"] == azimuth).to_numpy()
        started = time.perf_counter()
        model = make_compensation_pipeline(_network()).fit(X[~held], y[~held])
        fit_seconds["default"] += time.perf_counter() - started
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            policy = model.predict(X[held])
            squared["default"] += float(np.sum((y[held] - policy) ** 2))
            for name, clamped in deviation_clamp(model, X[~held], X[held]).items():
                squared[name] = squared.get(name, 0.0) + float(np.sum((y[held] - clamped) ** 2))
            model.set_params(uncalibrated="none")
            free = model.predict(X[held])
        features_held = model.steps[0][1].transform(X[held])
        for name, blended in rate_weight_sweep(model, features_held, free).items():
            squared[name] = squared.get(name, 0.0) + float(np.sum((y[held] - blended) ** 2))
        squared["default, uncalibrated='none'"] += float(np.sum((y[held] - free) ** 2))
        # The same network with the held-out handover per kind of novelty (opt-in).
        started = time.perf_counter()
        handover = make_compensation_pipeline(_network(), handover=True).fit(X[~held], y[~held])
        fit_seconds["handover"] += time.perf_counter() - started
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            handed = handover.predict(X[held])
        squared["default, handover"] = squared.get("default, handover", 0.0) + float(
            np.sum((y[held] - handed) ** 2)
        )
        handover_rows += int(handover.outside_calibration(X[held]).sum())
        floor += noise_floor(mixed.frame, np.flatnonzero(held)) * held.sum()
        outside = model.outside_calibration(X[held])
        outside_rows += int(outside.sum())
        outside_t = beyond_calibrated_temperatures(temperature[held], temperature[~held])
        gain = np.square(y[held] - policy) - np.square(y[held] - free)
        excess["outside T"] += float(gain[outside_t].sum())
        excess["flagged inside T"] += float(gain[outside & ~outside_t].sum())
        # Which kind of novelty each flagged row shows, and how the network alone and the
        # fallback do on it (the evidence a handover per kind would need).
        fallback = model.fallback_.predict(features_held)[:, 0]
        for kind, mask in flagged_kinds(model, features_held, outside, outside_t).items():
            cell = by_kind.setdefault(kind, {"rows": 0, "network": 0.0, "fallback": 0.0})
            cell["rows"] += int(mask.sum())
            cell["network"] += float(np.sum((y[held] - free)[mask] ** 2))
            cell["fallback"] += float(np.sum((y[held] - fallback)[mask] ** 2))
    return {
        "flagged": flagged / rows,
        "flagged inside T": flagged_inside_t / rows_inside_t,
        "rows": rows,
        "rows inside T": rows_inside_t,
        "rows of contained runs": contained_rows,
        "flagged in contained runs": (
            contained_flagged / contained_rows if contained_rows else None
        ),
        "flagged inside T by margin": {m: n / rows_inside_t for m, n in by_margin.items()},
        "flagged inside T by rate weight": {k: n / rows_inside_t for k, n in by_rate.items()},
        "msd/floor": {name: value / floor for name, value in squared.items()},
        "mixed rows outside": outside_rows / X.shape[0],
        "mixed rows outside, handover": handover_rows / X.shape[0],
        "fit time, handover / default": fit_seconds["handover"] / fit_seconds["default"],
        "mixed flagged by kind": {
            kind: {
                "share": cell["rows"] / X.shape[0],
                "network / fallback": cell["network"] / cell["fallback"]
                if cell["fallback"] > 0
                else None,
            }
            for kind, cell in by_kind.items()
        },
        "mixed cost by group": {
            group: value / squared["default, uncalibrated='none'"]
            for group, value in excess.items()
        },
    }


def flagged_kinds(model, features, outside, outside_t):
    """The flagged rows by the kind of novelty they show: beyond the calibrated
    temperatures; within them but beyond the calibrated rates; within both (a thermal state,
    a combination the calibration did not show)."""
    domain = model.domain_
    rates = features[:, domain.rate_columns_]
    low, high = domain.data_min_[domain.rate_columns_], domain.data_max_[domain.rate_columns_]
    beyond_rates = np.any((rates < low) | (rates > high), axis=1)
    return {
        "outside T": outside & outside_t,
        "new rates": outside & ~outside_t & beyond_rates,
        "thermal state": outside & ~outside_t & ~beyond_rates,
    }


def real_case(split, axis):
    """Case 3: calibrate on the ``split``'s bursts of the recording, compensate the others."""
    table = real_per_second(EXTRAPOLATION_REAL_AXES)
    calibrate = EXTRAPOLATION_REAL_SPLITS[split](table["burst"].to_numpy())
    X = table[["run", "time", "temperature"]]
    y = table[axis].to_numpy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        predictions, sweep, model, _ = peers(X[calibrate], y[calibrate], X[~calibrate])
        flags = model.outside_calibration(X[~calibrate])
    predictions.update({name: p for name, p in sweep.items() if name.startswith("clamp")})
    held = y[~calibrate]
    everything = np.ones(held.shape[0], dtype=bool)
    return {
        "scores": _score(held, predictions, {"all": everything})["all"],
        "flagged": float(np.mean(flags)),
        "threshold": float(model.domain_.threshold_),
    }


def _best_outside(scores):
    """The best of the peers a user has without a model: uncompensated, the line in T and
    the line held at the calibrated temperatures (the firmware practice)."""
    return min(scores["uncompensated"], scores["line in T"], scores["held line in T"])


def checks(simulated, shared, real, quick=False):
    """The targets' lines and verdicts. With ``quick`` (one seed, 2 runs of 240-s samples)
    the ratios to the peers and the flag rates print as INFO (not judged at that size); the
    promises a broken default would break stay judged: never worse than uncompensated, the
    rows outside the calibration flagged, and the real recording's split."""
    lines, passed = [], []

    def add(ok, text, judged=True):
        if judged:
            passed.append(bool(ok))
        lines.append(verdict_line(ok, text, judged))

    outside_ratios = []
    for (physics, seed), record in simulated.items():
        for profile, cell in record.items():
            name = f"{physics} seed {seed}, {profile}"
            outside = cell["scores"]["outside T"]
            if outside["rows"]:
                ratio = outside["default"] / _best_outside(outside)
                outside_ratios.append(ratio)
                add(
                    ratio <= OUTSIDE_RATIO,
                    f"{name}, outside T: default <= {OUTSIDE_RATIO:g} x min(uncompensated, "
                    f"line, held line) ({ratio:.3f})",
                    not quick,
                )
                if outside["line in T"] <= outside["uncompensated"]:
                    ratio = outside["default"] / outside["uncompensated"]
                    add(
                        ratio <= 1.0,
                        f"{name}, outside T (line beats uncompensated): default "
                        f"<= uncompensated ({ratio:.3f})",
                    )
                flagged = cell["flagged outside T"]
                add(
                    flagged >= FLAGGED_OUTSIDE,
                    f"{name}: outside-T rows flagged >= {FLAGGED_OUTSIDE:.0%} ({flagged:.3f})",
                )
            for group in ("outside T", "new rates"):
                scores = cell["scores"][group]
                if scores["rows"]:
                    ratio = scores["default"] / scores["uncompensated"]
                    add(
                        ratio <= NEVER_WORSE,
                        f"{name}, {group}: never worse than uncompensated, default <= "
                        f"{NEVER_WORSE:g} x uncompensated ({ratio:.3f})",
                    )
            rates = cell["scores"]["new rates"]
            if rates["rows"]:
                ratio = rates["default"] / rates["line in T"]
                add(
                    ratio <= RATE_RATIO,
                    f"{name}, new rates: default <= {RATE_RATIO:g} x line ({ratio:.3f})",
                    not quick,
                )
    if outside_ratios:
        median = float(np.median(outside_ratios))
        add(
            median <= OUTSIDE_MEDIAN,
            f"outside T, over the {len(outside_ratios)} cases: median of default / "
            f"min(uncompensated, line, held line) <= {OUTSIDE_MEDIAN:g} ({median:.3f})",
            not quick,
        )
    for (physics, seed), cell in shared.items():
        share = cell["flagged inside T"]
        add(
            share <= FLAGGED_SHARED,
            f"{physics} seed {seed}, leave one azimuth out: rows inside the calibrated "
            f"temperatures flagged <= {FLAGGED_SHARED:.0%} ({share:.4f})",
            not quick,
        )
        share = cell["mixed rows outside"]
        add(
            share <= FLAGGED_HELD_OUT_MAX,
            f"{physics} seed {seed}, leave one azimuth out (profile 'mix'): held-out rows "
            f"flagged <= {FLAGGED_HELD_OUT_MAX:.0%} ({share:.4f})",
            not quick,
        )
        costs = cell["msd/floor"]
        ratio = costs["default"] / costs["default, uncalibrated='none'"]
        add(
            ratio <= UNCHANGED_RATIO,
            f"{physics} seed {seed}, leave one azimuth out (profile 'mix'): default MSD <= "
            f"{UNCHANGED_RATIO:g} x uncalibrated='none' ({ratio:.3f})",
            not quick,
        )
    if shared:
        mean = float(np.mean([cell["mixed rows outside"] for cell in shared.values()]))
        add(
            mean <= FLAGGED_HELD_OUT,
            f"leave one azimuth out (profile 'mix'), over the {len(shared)} campaigns: mean "
            f"share of held-out rows flagged <= {FLAGGED_HELD_OUT:.0%} ({mean:.4f})",
            not quick,
        )
    for (split, axis), cell in real.items():
        scores = cell["scores"]
        name = f"real {split}, {axis}"
        if split.endswith("bursts"):
            if axis == "gyro_z":
                ratio = scores["default"] / scores["uncompensated"]
                add(ratio <= 1.0, f"{name}: default <= uncompensated ({ratio:.3f})")
                continue
            ratio = scores["default"] / scores["line in T"]
            add(
                ratio <= INTERLEAVED_RATIO,
                f"{name}: default <= {INTERLEAVED_RATIO:g} x line in T ({ratio:.3f})",
            )
            ratio = scores["default, uncalibrated='none'"] / scores["line in T"]
            add(
                ratio <= NETWORK_ALONE_RATIO,
                f"{name}: the network alone (uncalibrated='none') <= {NETWORK_ALONE_RATIO:g} x "
                f"line in T ({ratio:.3f})",
            )
            continue
        add(
            cell["flagged"] >= FLAGGED_OUTSIDE,
            f"{name}: rows flagged >= {FLAGGED_OUTSIDE:.0%} ({cell['flagged']:.3f})",
        )
        ratio = scores["default"] / scores["uncompensated"]
        add(ratio <= 1.0, f"{name}: default <= uncompensated ({ratio:.3f})")
        if axis != "gyro_z":
            ratio = scores["default"] / scores["line in T"]
            add(
                ratio <= OUTSIDE_RATIO,
                f"{name}: default <= {OUTSIDE_RATIO:g} x line in T ({ratio:.3f})",
            )
    return lines, passed


MODEL_ORDER = (
    "uncompensated",
    "line in T",
    "held line in T",
    "poly3 in T",
    "held poly3 in T",
    "linear (features)",
    "default",
    "default, uncalibrated='none'",
    "default, uncalibrated='clip'",
    "default, tail_alpha='auto'",
    "default, handover",
)


def _share(value):
    return "-" if value is None else f"{value:.4f}"


def _cell(value):
    return "-" if value is None else f"{value:.4g}"


def markdown(simulated, shared, real, sweep_only, lines, command, seconds):
    out = [
        "# Outside the calibration",
        "",
        f"Command: `{command}` ({seconds:.0f} s). MSD in (deg/h)^2; see the script's "
        "docstring for the cases, models and targets.",
        "",
    ]
    if not sweep_only:
        out += [
            "## Simulator: heating-only calibration, cycling / cooling operation",
            "",
            "| case | rows | " + " | ".join(MODEL_ORDER) + " | flagged |",
            "|---|---|" + "---|" * len(MODEL_ORDER) + "---|",
        ]
        for (physics, seed), record in simulated.items():
            for profile, cell in record.items():
                for group, scores in cell["scores"].items():
                    flagged = cell["flagged outside T"] if group == "outside T" else None
                    out.append(
                        f"| {physics} s{seed} {profile}, {group} | {scores['rows']} | "
                        + " | ".join(_cell(scores[name]) for name in MODEL_ORDER)
                        + f" | {_cell(flagged)} |"
                    )
        out += [
            "",
            "## Simulator: leave one azimuth out (shared profiles)",
            "",
            "The last two columns: the default's squared error beyond uncalibrated='none''s on "
            "the 'mix' campaign, summed over its rows outside the calibrated temperatures and "
            "over its flagged rows inside them, over uncalibrated='none''s total (their sum is "
            "the cost, default over uncalibrated='none', minus 1).",
            "",
        ]
        out += [
            "| case | rows | flagged | rows inside the calibrated T | flagged among them | "
            "rows of runs inside the calibrated T | flagged among them | "
            "'mix' rows outside | default MSD/floor | uncalibrated='none' MSD/floor | "
            "cost from rows outside T | cost from flagged rows inside T |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for (physics, seed), cell in shared.items():
            costs = cell["msd/floor"]
            free = costs["default, uncalibrated='none'"]
            by_group = cell["mixed cost by group"]
            out.append(
                f"| {physics} s{seed} | {cell['rows']} | {cell['flagged']:.4f} | "
                f"{cell['rows inside T']} | {cell['flagged inside T']:.4f} | "
                f"{cell['rows of contained runs']} | "
                f"{_share(cell['flagged in contained runs'])} | "
                f"{cell['mixed rows outside']:.3f} | {costs['default']:.4f} | "
                f"{free:.4f} | {by_group['outside T']:+.4f} | "
                f"{by_group['flagged inside T']:+.4f} |"
            )
        out += ["", "## Real recording (load_psim_tvc, 1 row per second)", ""]
        out += [
            "| split, axis | rows | " + " | ".join(MODEL_ORDER) + " | flagged | threshold |",
            "|---|---|" + "---|" * len(MODEL_ORDER) + "---|---|",
        ]
        for (split, axis), cell in real.items():
            scores = cell["scores"]
            out.append(
                f"| {split}, {axis} | {scores['rows']} | "
                + " | ".join(_cell(scores[name]) for name in MODEL_ORDER)
                + f" | {cell['flagged']:.3f} | {cell['threshold']:.3f} |"
            )
    out += [
        "",
        "## Blend width sweep (ratio to the better of uncompensated and the line in T; "
        "new rates: ratio to the line)",
        "",
        "| case | group | " + " | ".join(f"width {w:g}" for w in SWEEP_WIDTHS) + " |",
        "|---|---|" + "---|" * len(SWEEP_WIDTHS),
    ]
    for (physics, seed), record in simulated.items():
        for profile, cell in record.items():
            for group in ("outside T", "new rates"):
                scores = cell["scores"][group]
                if not scores["rows"]:
                    continue
                best = scores["line in T"]
                if group == "outside T":
                    best = min(best, scores["uncompensated"])
                ratios = [cell["sweep"][group][f"blend width {w:g}"] / best for w in SWEEP_WIDTHS]
                out.append(
                    f"| {physics} s{seed} {profile} | {group} | "
                    + " | ".join(f"{r:.3f}" for r in ratios)
                    + " |"
                )
    if shared:
        out += [
            "",
            "## Margin sweep (leave one azimuth out: share of the rows inside the calibrated "
            "temperatures flagged)",
            "",
            "| case | " + " | ".join(f"margin {m:g}" for m in SWEEP_MARGINS) + " |",
            "|---|" + "---|" * len(SWEEP_MARGINS),
        ]
        for (physics, seed), cell in shared.items():
            shares = cell["flagged inside T by margin"]
            out.append(
                f"| {physics} s{seed} | "
                + " | ".join(f"{shares[m]:.4f}" for m in SWEEP_MARGINS)
                + " |"
            )
    out += kinds_markdown(shared)
    out += rate_weight_markdown(simulated, shared)
    out += evidence_markdown(simulated)
    out += clamp_markdown(simulated, shared, real)
    out += ["", "## Verdict", "", *lines, ""]
    return "\n".join(out)


def clamp_markdown(simulated, shared, real):
    """The targets' failures of the default blend beside the deviation clamp's.

    Counted on this run's cases with the targets' own thresholds (see :func:`checks`); the
    clamp's predictions are :func:`deviation_clamp`'s. Not a verdict: the clamp is an
    alternative measured for the record of the issue "Safe outside the calibration".
    """
    policies = {"blend (default)": None, **{f"clamp {c:g}": f"clamp {c:g}" for c in CLAMP_FACTORS}}
    header = [
        "",
        "## An alternative policy: the network's deviation from the fallback clamped",
        "",
        "Failures of each target on this run's cases (the blend's are the verdict's; "
        "'clamp c': the network's deviation from the fallback clipped to c times its "
        "calibrated half-range).",
        "",
        "| policy | outside T (<= 1.5 x min(uncompensated, line)) | outside T (<= uncompensated "
        "where the line is) | first rule (<= 1.05 x uncompensated) | new rates (<= 1.2 x "
        "line) | shared profiles (<= 1.02 x uncalibrated='none') | real recording |",
        "|---|---|---|---|---|---|---|",
    ]
    rows = []
    for policy, key in policies.items():
        counts = {name: [0, 0] for name in ("outside", "line", "first", "rates", "shared", "real")}

        def count(name, failed, counts=counts):
            counts[name][0] += bool(failed)
            counts[name][1] += 1

        for record in simulated.values():
            for cell in record.values():
                groups = {
                    group: (cell["scores"][group], cell["sweep"][group])
                    for group in ("outside T", "new rates")
                }
                for group, (scores, sweep) in groups.items():
                    if not scores["rows"]:
                        continue
                    ours = scores["default"] if key is None else sweep[key]
                    count("first", ours > NEVER_WORSE * scores["uncompensated"])
                    if group == "outside T":
                        best = min(scores["uncompensated"], scores["line in T"])
                        count("outside", ours > OUTSIDE_RATIO * best)
                        if scores["line in T"] <= scores["uncompensated"]:
                            count("line", ours > scores["uncompensated"])
                    else:
                        count("rates", ours > RATE_RATIO * scores["line in T"])
        for cell in shared.values():
            costs = cell["msd/floor"]
            ours = costs["default"] if key is None else costs[key]
            count("shared", ours > UNCHANGED_RATIO * costs["default, uncalibrated='none'"])
        for (split, axis), cell in real.items():
            scores = cell["scores"]
            ours = scores["default"] if key is None else scores[key]
            if split.endswith("bursts"):
                if axis == "gyro_z":
                    count("real", ours > scores["uncompensated"])
                else:
                    count("real", ours > INTERLEAVED_RATIO * scores["line in T"])
                continue
            count("real", ours > scores["uncompensated"])
            if axis != "gyro_z":
                count("real", ours > OUTSIDE_RATIO * scores["line in T"])
        cells = [f"{failed} of {total}" if total else "-" for failed, total in counts.values()]
        rows.append(f"| {policy} | " + " | ".join(cells) + " |")
    return header + rows


def kinds_markdown(shared):
    """Where the 'mix' campaigns' flags arise, by kind of novelty (:func:`flagged_kinds`):
    the share of the held-out rows of each kind, and the network alone's squared error
    there over the fallback's (below 1: the network was the better of the two)."""
    kinds = ("outside T", "new rates", "thermal state")
    out = [
        "",
        "## The 'mix' campaigns' flags by kind of novelty (leave one azimuth out)",
        "",
        "Share of the held-out rows flagged, by kind; in brackets the network alone's MSD "
        "over the fallback's on them (below 1: the network was better there).",
        "",
        "| case | " + " | ".join(kinds) + " |",
        "|---|" + "---|" * len(kinds),
    ]
    for (physics, seed), cell in shared.items():
        cells = []
        for kind in kinds:
            entry = cell["mixed flagged by kind"].get(kind)
            if entry is None:
                cells.append("-")
                continue
            ratio = entry["network / fallback"]
            cells.append(f"{entry['share']:.4f} ({_cell(ratio)})")
        out.append(f"| {physics} s{seed} | " + " | ".join(cells) + " |")
    out += [
        "",
        "With `handover=True` (opt-in: the domain widens per kind where held-out runs show the "
        "model beating its fallback): the held-out rows flagged and the pooled MSD over "
        "`uncalibrated='none'`'s, beside the default's.",
        "",
        "| case | flagged, default | flagged, handover | MSD / none, default | MSD / none, "
        "handover | fit time, handover / default |",
        "|---|---|---|---|---|---|",
    ]
    for (physics, seed), cell in shared.items():
        costs = cell["msd/floor"]
        none = costs["default, uncalibrated='none'"]
        out.append(
            f"| {physics} s{seed} | {cell['mixed rows outside']:.4f} | "
            f"{cell['mixed rows outside, handover']:.4f} | {costs['default'] / none:.3f} | "
            f"{costs['default, handover'] / none:.3f} | "
            f"{cell['fit time, handover / default']:.2f} |"
        )
    return out


def sweep_failures(simulated, key):
    """The failures of the sweep's predictions ``key`` on the simulator cases:
    ``(outside T, cases outside T, first rule, new rates)``, by the targets' thresholds."""
    outside = first = rates = total = 0
    for record in simulated.values():
        for cell in record.values():
            for group in ("outside T", "new rates"):
                scores, sweep = cell["scores"][group], cell["sweep"][group]
                if not scores["rows"]:
                    continue
                ours = sweep[key]
                first += ours > NEVER_WORSE * scores["uncompensated"]
                if group == "outside T":
                    total += 1
                    best = min(scores["uncompensated"], scores["line in T"])
                    outside += ours > OUTSIDE_RATIO * best
                else:
                    rates += ours > RATE_RATIO * scores["line in T"]
    return outside, total, first, rates


def rate_weight_markdown(simulated, shared):
    """Each target's failures at each weight of the rate term (``RATE_WEIGHTS``).

    The same network and fallback as the default's (:func:`rate_weight_sweep`); the flags
    and the cost where calibration and use share profiles from the shared-profile case.
    """
    out = [
        "",
        f"## Rate weight sweep (the rate's excess in the distance; the default "
        f"{RATE_WEIGHT:g}, 0: no rate term)",
        "",
        f"| rate weight | outside T (<= {OUTSIDE_RATIO:g} x min(uncompensated, line)) | first "
        f"rule (<= {NEVER_WORSE:g} x uncompensated) | new rates (<= {RATE_RATIO:g} x line) | "
        f"shared profiles: flagged inside T > {FLAGGED_SHARED:g} | largest share flagged "
        f"inside T | shared profiles: cost > {UNCHANGED_RATIO:g} x uncalibrated='none' |",
        "|---|---|---|---|---|---|---|",
    ]
    for rate_weight in RATE_WEIGHTS:
        key = f"rate weight {rate_weight:g}"
        outside, total, first, rates = sweep_failures(simulated, key)
        shares = [cell["flagged inside T by rate weight"][rate_weight] for cell in shared.values()]
        costs = [
            cell["msd/floor"][key]
            > UNCHANGED_RATIO * cell["msd/floor"]["default, uncalibrated='none'"]
            for cell in shared.values()
        ]
        out.append(
            f"| {rate_weight:g} | {outside} of {total} | {first} | {rates} | "
            f"{sum(share > FLAGGED_SHARED for share in shares)} of {len(shares)} | "
            f"{max(shares, default=0.0):.4f} | {sum(costs)} of {len(costs)} |"
        )
    return out


def evidence_markdown(simulated):
    """Can the calibration tell when a line extrapolates? Its evidence against the use.

    Per case: the fallback's evidence (:func:`fallback_evidence`: the line in T's at the
    worse calibrated extreme, the plane in T and dT's on held-out runs and at each extreme),
    the fallback ``fit_fallback`` chose, and what the line in T and the default then do
    outside the calibrated temperatures (MSD over uncompensated's). Then the sweep of the
    plane's ``repeated_ratio`` (:func:`repeated_sweep`, the same network and blend): each
    target's failures at each ratio.
    """
    out = [
        "",
        "## The fallback's evidence against what it does outside T",
        "",
        "Evidence: squared error over the constant's, for the line in T at the worse "
        "calibrated extreme, for the plane in T and dT on each calibration run held out and "
        "at the cold / warm extreme; the held-out runs' scale (how far they bear out the "
        "plane's predictions, 1 in full). Outside T: MSD over uncompensated's.",
        "",
        "| case | line, extremes | plane, held-out runs | held-out scale | plane, cold / warm "
        "extreme | fallback | line outside T | default outside T |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for (physics, seed), record in simulated.items():
        for profile, cell in record.items():
            scores = cell["scores"]["outside T"]
            if not scores["rows"]:
                continue
            evidence, uncompensated = cell["evidence"], scores["uncompensated"]
            cold, warm = evidence["plane ends"]
            out.append(
                f"| {physics} s{seed} {profile} | {evidence['line']:.3f} | "
                f"{evidence['runs']:.3f} | {evidence['scale']:.3f} | {cold:.3f} / {warm:.3f} | "
                f"{cell['fallback']} | "
                f"{scores['line in T'] / uncompensated:.3f} | "
                f"{scores['default'] / uncompensated:.3f} |"
            )
    out += [
        "",
        f"Trust the plane when its held-out-run ratio is at most ... (the default "
        f"{REPEATED_RATIO:g}), or below 1 with a held-out scale of at least ... (the default "
        f"{CARRIED_SCALE:g}; inf: never); failures of each target:",
        "",
        f"| rule | outside T (<= {OUTSIDE_RATIO:g} x min(uncompensated, line)) | first rule "
        f"(<= {NEVER_WORSE:g} x uncompensated, outside T and new rates) | new rates "
        f"(<= {RATE_RATIO:g} x line) |",
        "|---|---|---|---|",
    ]
    keys = [f"repeated {ratio:g}" for ratio in REPEATED_RATIOS]
    keys += [f"scale {scale:g}" for scale in CARRIED_SCALES]
    for key in keys:
        outside, total, first, rates = sweep_failures(simulated, key)
        label = key.replace("repeated", "ratio <=").replace("scale", "scale >=")
        out.append(f"| {label} | {outside} of {total} | {first} | {rates} |")
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI mode: small and fast")
    parser.add_argument(
        "--seeds", type=int, nargs="+", help="seeds (default: the judged seeds; --quick: 0)"
    )
    parser.add_argument("--physics", nargs="+", choices=PHYSICS, help="presets (default all)")
    parser.add_argument(
        "--tune",
        action="store_true",
        help="the simulator cases and the sweeps only, on the tuning seeds (default 0 to 7)",
    )
    parser.add_argument("--n-jobs", type=int, default=1)
    add_out_argument(parser)
    args = parser.parse_args(argv)
    quick = args.quick
    seeds = args.seeds or (
        list(TUNING_SEEDS[:1]) if quick else list(TUNING_SEEDS if args.tune else JUDGED_SEEDS)
    )
    physics_list = args.physics or list(EXTRAPOLATION_QUICK_PHYSICS if quick else PHYSICS)
    period, n_runs = extrapolation_sizes(quick)
    command = command_line(__file__, argv)
    started = time.perf_counter()
    cases = [(physics, seed) for physics in physics_list for seed in seeds]
    parallel = Parallel(n_jobs=args.n_jobs)
    simulated = dict(
        zip(
            cases,
            parallel(delayed(simulator_case)(p, s, period, n_runs) for p, s in cases),
            strict=True,
        )
    )
    shared = dict(
        zip(
            cases,
            parallel(delayed(shared_profile_case)(p, s, period, n_runs) for p, s in cases),
            strict=True,
        )
    )
    real = {}
    if not args.tune:
        splits = ["warm->cold"] if quick else list(EXTRAPOLATION_REAL_SPLITS)
        axes = ["gyro_x", "gyro_z"] if quick else list(EXTRAPOLATION_REAL_AXES)
        real_cases = [(split, axis) for split in splits for axis in axes]
        real = dict(
            zip(
                real_cases,
                parallel(delayed(real_case)(split, axis) for split, axis in real_cases),
                strict=True,
            )
        )
    lines, passed = checks(simulated, shared, real, quick)
    seconds = time.perf_counter() - started
    text = markdown(simulated, shared, real, args.tune, lines, command, seconds)
    print(text)
    name = "extrapolation" + ("_quick" if quick else "") + ("_tune" if args.tune else "")
    results = {
        "simulated": {f"{p}|{s}": v for (p, s), v in simulated.items()},
        "shared": {
            f"{p}|{s}": {
                **v,
                "flagged inside T by margin": {
                    str(m): share for m, share in v["flagged inside T by margin"].items()
                },
                "flagged inside T by rate weight": {
                    str(k): share for k, share in v["flagged inside T by rate weight"].items()
                },
            }
            for (p, s), v in shared.items()
        },
        "real": {f"{split}|{axis}": v for (split, axis), v in real.items()},
    }
    write_results(
        args.out,
        name,
        text,
        results,
        script=__file__,
        command=command,
        seconds=seconds,
        verdicts=lines,
    )
    return 0 if args.tune else exit_code(passed)


if __name__ == "__main__":
    sys.exit(main())
