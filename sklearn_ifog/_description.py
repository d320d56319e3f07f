"""The description of a fitted compensation Pipeline as plain parameters (the export schema).

:func:`describe_pipeline` turns ``ThermalFeatures → [row-wise transformers] → regressor`` into
a JSON-able dict, whose schema this docstring specifies (the one specification of the JSON
export and of what the C export renders). A private module that serves several: both exports
(``to_json`` writes the dict, ``to_c`` renders it) and the compiled fast path of streaming
(:mod:`sklearn_ifog._compiled` reads the steps from it), so all three carry exactly the same
numbers and the online path needs nothing from :mod:`sklearn_ifog.export`. The output layer
of the final regressor is read by :mod:`sklearn_ifog._output_layer`.
Every float goes through ``float(...)`` of a float64, so ``json`` (which writes ``repr``)
and the C generator (``repr`` / ``%.9g``) keep round-trip precision.

Schema (version 9; version 8 had no ``"term_parameters"``, and so no transition term a
reader could compute without parsing its name; version 7 had no ``"scale_factor"``, which
version 8 writes only for a pipeline fitted with ``input_rate``, so a version-7 document
means what it meant: the drift is the prediction; version 6 named the policy's key
``"outside"``, now ``"uncalibrated"`` as the pipeline's parameter; version 5 ended "clip" on
the temperature clamp, where the row could stay outside the widened box; version 4 had the
margin where version 5 has the calibrated threshold, and no boost; version 3 no rate term in
the domain (``"rate_columns"``...), version 2 no ``"domain"``, version 1 an EMA
``smoothing`` in samples and its ``alpha``)::

    {
      "schema": "sklearn-ifog-pipeline",
      "schema_version": 9,
      "generator": "sklearn-ifog <version>",
      "features": {
        "op": "thermal_features",
        "temperature": [<column name or position>, ...],   # one per sensor, in order
        "time": <column> | null,
        "run": <column> | null,
        "terms": [...],              # among "T", "dT", "TdT", "T2", "gradient", "T_lag<tau>s",
                                     # "TT_lag<tau>s", transition terms (below)
        "term_time_constants": [...],  # per term: its lag's time constant, s, or null (a
                                     # transition term: its step's lag)
        "term_parameters": [...],    # per term: null, or a transition term's parameters
        "smoothing": float,          # time constant of dT's smoothing, s (0: none)
        "time_constants": [...],     # s: the lags carried per sensor (lag terms, smoothing)
        "seconds_per_unit": float | null,   # null when time is null (per-sample difference)
        "feature_names": [...]       # output columns: for each sensor, for each term
      },
      "steps": [ <step>, ... ],      # after the features, applied in order, row by row
      "n_features": int,             # features entering the first step
      "n_outputs": int,
      "single_output": bool,         # the Pipeline predicts a 1-D array
      "domain": <domain> | null,     # a CompensationPipeline's calibration domain and
                                     # uncalibrated policy; null for a plain Pipeline
      "scale_factor": <scale_factor> # only for a pipeline fitted with input_rate (absent
                                     # otherwise: the prediction is the drift)
    }

Each step is ``{"name", "class", "op", "n_inputs", "n_outputs", ...}`` with ``op``:

- ``"center_scale"``: ``y = (x - center) / scale`` (StandardScaler, RobustScaler,
  MaxAbsScaler); ``center``, ``scale``: lists of length ``n_inputs``.
- ``"multiply_add"``: ``y = x * multiply + add``, then clipped to ``clip`` (``[low, high]``)
  when ``clip`` is not null (MinMaxScaler).
- ``"polynomial"``: ``y[k] = prod_j x[j] ** powers[k][j]`` (PolynomialFeatures).
- ``"linear"`` (last step): ``y = coef @ x + intercept``; ``coef``: ``n_outputs`` lists of
  ``n_inputs``.
- ``"rbf_network"`` (last step): ``z = (x - x_mean) / x_scale``;
  ``phi[k] = exp(-||z - centers[k]||^2 / (2 widths[k]^2))``;
  ``y = coef @ phi + tail_coef @ t(z) + intercept``; ``centers``: K lists of ``n_inputs``,
  ``coef``: ``n_outputs`` lists of K, ``tail_coef``: ``n_outputs`` lists of ``n_tail``.
  The polynomial tail ``t(z)`` has degree ``tail_degree``: 1, ``t(z) = z``
  (``n_tail = n_inputs``; a model without tail has an all-zero one); 2, ``z`` followed by
  the monomials ``z[i] * z[j]`` for ``i <= j``, row-major (``z0², z0 z1, ..., z1², ...``,
  the order of scikit-learn's ``PolynomialFeatures(degree=2, include_bias=False)``;
  ``n_tail = n_inputs + n_inputs (n_inputs + 1) / 2``).

The domain (:mod:`sklearn_ifog.domain`; arrays of ``n_features`` entries, the features as
ThermalFeatures outputs them, before any later step)::

    {
      "center": [...], "scale": [...],       # standardisation of the features
      "axes": [[...], ...],                  # principal axes, one per row (row-major)
      "axis_scale": [...],                   # the calibration's standard deviation per axis
      "lower": [...], "upper": [...],        # the calibration's range along each axis
      "margin": <float>,                     # the calibrated threshold (domain_.threshold_):
                                             # the distance that still counts as inside
      "blend_width": <float>,                # width of the "blend" policy's smoothstep
      "temperature_columns": [<int>, ...],   # features holding a temperature (T of each
                                             # sensor): their range admits no margin
      "temperature_low": [...], "temperature_high": [...],   # their calibrated ranges
      "rate_columns": [<int>, ...],          # features holding a rate (dT of each sensor):
                                             # their excess adds to the distance ([]: none)
      "rate_low": [...], "rate_high": [...], # their calibrated ranges
      "rate_scale": [...],                   # their standard deviation over RATE_WEIGHT
      "boost": <float>,                      # threshold - margin: beyond the calibrated
                                             # rates or temperatures, held to the margin
      "boost_temperature_low": [...], "boost_temperature_high": [...],   # where the
                                             # temperature novelty starts
      "boost_rate_ramp": <float>,            # the novelty's scales (rho_r, rho_t): the
      "boost_temperature_ramp": <float>,     # boost in full at a novelty of 1
      "projection_rounds": <int>,            # rounds of "clip" with temperature columns
      "uncalibrated": "blend" | "clip" | "none",  # the policy outside the domain
      "fallback": {"intercept": [...], "slope": [...],   # n_outputs each
                   "column": <int> | null,   # the feature holding T; null: a constant
                   "low": <float> | null, "high": <float> | null,   # calibrated T range
                   "hold_below": [<bool>, ...], "hold_above": [<bool>, ...],   # per output
                   "rate_column": <int> | null,   # the feature holding dT; null: none
                   "rate_slope": [...], "rate_bound": <float>}
    }

A row ``x`` of features has the coordinates ``p = axes @ ((x - center) / scale)``; along
axis ``k`` its excess ``e_k`` is ``lower_k - p_k`` below the range, ``p_k - upper_k``
above it, 0 inside; its box distance is ``b = sqrt(sum_k (e_k / axis_scale_k)^2)``. Along
rate column ``r`` (``x[rate_columns[r]]``) its excess ``g_r`` is ``rate_low_r - x[...]``
below the range, ``x[...] - rate_high_r`` above it, 0 inside; its distance is
``d = sqrt(b^2 + G^2) + boost * min(N, 1)`` with ``G^2 = sum_r (g_r / rate_scale_r)^2``
and the novelty ``N^2 = (G / rho_r)^2 + sum_t (h_t / (rho_t scale[c_t]))^2``
(``rho_r = boost_rate_ramp``, ``rho_t = boost_temperature_ramp``), ``h_t`` the excess of
temperature column ``c_t`` beyond ``[boost_temperature_low_t,
boost_temperature_high_t]`` (``d = b``
without rate columns or with every rate and temperature in its range: a rate
the calibration never showed, such as a cooling row of a heating-only calibration, is
outside even where the axes spread it within the margin). It is outside when
``d > margin`` or when a temperature column ``x[c]`` lies outside
``[temperature_low, temperature_high]`` (by any amount). Rows inside get the steps'
prediction ``y``; rows outside follow ``uncalibrated``:

- ``"blend"``: ``(1 - w) y + w f`` with ``s = clip((d - margin) / blend_width, 0, 1)``,
  ``w = s^2 (3 - 2 s)`` (0 for a row outside by a temperature alone) and the fallback
  ``f = intercept + t * slope - slope * hold_below * min(t - low, 0) - slope * hold_above
  * max(t - high, 0) + rate_slope * clip(x[rate_column], -rate_bound, rate_bound)`` with
  ``t = x[column]``, per output, each term evaluated in that order; a hold term is absent
  when no output holds on that side, the rate term when ``rate_column`` is null
  (``f = intercept`` when ``column`` is null).
- ``"clip"``: the steps' prediction at the row projected onto the domain. One projection
  ``P(x)``, by the box distance ``b`` alone (the rates are not moved: a row outside by its
  rates only is evaluated as it is): a row with ``b <= margin`` is unchanged; else, with
  ``c`` its coordinates clamped to ``[lower, upper]`` and ``q = c + (p - c) * (margin /
  b)``, it becomes
  ``(axes^T @ q) * scale + center``. Without temperature columns the projected row is
  ``P(x)``; with them, ``projection_rounds`` times: ``x = P(x)``, then every temperature
  column clamped to its range; then ``x = P(x)`` once more and, when a temperature column
  ``c`` lies beyond its range, ``x = center + s (x - center)`` with ``s`` the smallest
  ``(bound_c - center_c) / (x_c - center_c)`` over those columns (``bound_c`` the end of the
  range it crossed), then every temperature column clamped to its range (a rounding
  error's change). The result lies within ``margin`` of the box (the segment to ``center``
  stays in the widened box) and in every temperature range.
- ``"none"``: ``y``.

With a scale factor (:mod:`sklearn_ifog.scale_factor`, a
:class:`~sklearn_ifog.pipeline.CompensationPipeline` fitted with ``input_rate``), the two
outputs (``n_outputs`` 2, and the fallback's) are the bias ``b`` (deg/h) and the
scale-factor error ``s`` (dimensionless), the policy applied to the pair as to any two
outputs::

    {
      "input_rate": <column name or position>,   # the input rate's column of the fit, deg/h
      "input_rate_unit": "deg/h",
      "outputs": ["bias", "scale_factor"],        # the meaning of the two outputs
      "input_rate_range": [<low>, <high>],        # the calibrated input rates, deg/h
      "slack": <float>,                           # share of max(|low|, |high|)
      "asymmetry": <float>                        # a: positive minus negative inputs / 2
    }

A gyro output ``rate`` stands for the input rate ``(rate - b) / (1 + s + a sign(rate -
b))``; the drift at a known input rate ``w`` is ``b + w * s + a |w|``. An input rate (the
output standing in for it when it is not known) is beyond the calibrated ones, and the row
outside the calibration (the flag only: the policy reads the domain's distance alone), when
it is below ``low - d`` or above ``high + d``, ``d = slack * max(|low|, |high|)``.

The feature rules are those of :class:`sklearn_ifog.ThermalFeatures`. Per sensor and per
time constant ``tau`` of ``time_constants``, a deficit ``e`` (the temperature minus its
first-order lag) is carried: ``e = 0`` at a run's first row, then at each sample, with
``u`` the raw temperature::

    x = (t - t_prev) / tau;  a = exp(-x);  g = (x > 0) ? -expm1(-x) / x : 1;
    e = a * e + g * (u - u_prev)

The first row of a run has ``dT = 0``; later rows ``dT = e_smoothing / smoothing *
seconds_per_unit`` when ``smoothing > 0`` (``e_smoothing``: the deficit at
``tau = smoothing``), else ``dT = (u - u_prev) / (t - t_prev) * seconds_per_unit``, or
``u - u_prev`` without time. Terms: ``"T"`` the raw temperature, ``"dT"``, ``"TdT"`` =
``T * dT``, ``"T2"`` = ``T * T``, ``"gradient"`` = ``T - T_first_sensor`` (no column for the
first sensor), ``"T_lag<tau>s"`` = the deficit at its ``term_time_constants`` entry,
``"TT_lag<tau>s"`` = ``T *`` that deficit. Columns:
sensor by sensor, term by term within a sensor.

A transition term (``<shape><c>C_w<w>C_lag<tau>s[_dT|_T_lag<tau2>s]``, see
:mod:`sklearn_ifog._transition`) has its ``term_parameters`` entry::

    {
      "shape": "logistic" | "erf" | "hinge",
      "centre": <float>,            # c, degC
      "width": <float>,             # w, degC, > 0
      "lag": <float>,               # s: the inner temperature's lag (in time_constants)
      "multiplier": null | "dT" | "T_lag",
      "multiplier_lag": <float> | null   # s: the lag excess multiplied ("T_lag"; in
                                         # time_constants), null otherwise
    }

With ``z = ((T - deficit[lag]) - c) / w`` (``T`` the raw temperature, ``deficit[lag]`` the
sensor's deficit at that time constant, so ``T - deficit[lag]`` is its lag), the step is:

- ``"logistic"``: ``s = 0.5 + 0.5 * tanh(0.5 * z)``;
- ``"erf"``: ``s = 0.5 + 0.5 * erf(sqrt(0.5) * z)``;
- ``"hinge"``: ``s = w * (max(z, 0) + log1p(exp(-|z|)))`` (degC).

The term is ``s`` (multiplier null), ``s * dT`` (``"dT"``) or ``s * deficit[multiplier_lag]``
(``"T_lag"``).
"""

import numbers

import numpy as np
from sklearn import preprocessing
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted

from sklearn_ifog import _tuning, _version
from sklearn_ifog import domain as _domain
from sklearn_ifog._contract import (
    get_term,
    resolved_settings,
    seconds_per_unit,
    sensor_keys,
    state_time_constants,
    valid_terms_text,
)
from sklearn_ifog._output_layer import layer_kind, read_layer, supported_names
from sklearn_ifog.features import ThermalFeatures
from sklearn_ifog.policy import BlendWithFallback, policy_for
from sklearn_ifog.scale_factor import INPUT_RATE_UNIT

SCHEMA_NAME = "sklearn-ifog-pipeline"
SCHEMA_VERSION = 9


def _floats(values):
    """Nested lists of Python floats from an array (exact float64 values)."""
    return np.asarray(values, dtype=np.float64).tolist()


def _class_path(step):
    cls = type(step)
    return f"{cls.__module__}.{cls.__qualname__}"


def _step_label(name, step):
    return f"step {name!r} ({_class_path(step)})"


def _known_names():
    transformers = ", ".join(cls.__name__ for cls in TRANSFORMER_CONVERTERS)
    return f"transformers: {transformers}; final regressors: {supported_names()}"


def _column(value):
    """A column reference as JSON can hold it (name or position)."""
    if value is None:
        return None
    if isinstance(value, numbers.Integral):
        return int(value)
    return str(value)


def _term_parameters(term):
    """A term's ``"term_parameters"`` entry: a copy of its parameters (floats), or None."""
    if term.parameters is None:
        return None
    return {
        key: float(value) if isinstance(value, numbers.Real) else value
        for key, value in term.parameters.items()
    }


def describe_features(step, name="thermalfeatures"):
    """The ThermalFeatures part of the schema (see the module docstring)."""
    check_is_fitted(step)
    sensors = sensor_keys(step.temperature)
    resolved_terms, smoothing = resolved_settings(step)
    terms = [str(term) for term in resolved_terms]
    definitions = {}
    for term in terms:
        try:
            definitions[term] = get_term(term)
        except ValueError:
            raise ValueError(
                f"Cannot export {_step_label(name, step)}: unknown feature term {term!r}; "
                f"the exporters compute {valid_terms_text()}."
            ) from None
    return {
        "op": "thermal_features",
        "temperature": [_column(sensor) for sensor in sensors],
        "time": _column(step.time),
        "run": _column(step.run),
        "terms": terms,
        "term_time_constants": [definitions[term].time_constant for term in terms],
        "term_parameters": [_term_parameters(definitions[term]) for term in terms],
        "smoothing": smoothing,
        "time_constants": list(state_time_constants(terms, smoothing)),
        "seconds_per_unit": None if step.time is None else seconds_per_unit(step.rate_unit),
        "feature_names": [str(name) for name in step.get_feature_names_out()],
    }


def _standard_scaler(step, n_inputs):
    center = step.mean_ if step.with_mean else np.zeros(n_inputs)
    scale = step.scale_ if step.with_std else np.ones(n_inputs)
    return {"op": "center_scale", "center": _floats(center), "scale": _floats(scale)}


def _robust_scaler(step, n_inputs):
    center = step.center_ if step.with_centering else np.zeros(n_inputs)
    scale = step.scale_ if step.with_scaling else np.ones(n_inputs)
    return {"op": "center_scale", "center": _floats(center), "scale": _floats(scale)}


def _max_abs_scaler(step, n_inputs):
    return {
        "op": "center_scale",
        "center": _floats(np.zeros(n_inputs)),
        "scale": _floats(step.scale_),
    }


def _min_max_scaler(step, n_inputs):
    clip = _floats(step.feature_range) if step.clip else None
    return {
        "op": "multiply_add",
        "multiply": _floats(step.scale_),
        "add": _floats(step.min_),
        "clip": clip,
    }


def _polynomial(step, n_inputs):
    return {"op": "polynomial", "powers": np.asarray(step.powers_, dtype=int).tolist()}


TRANSFORMER_CONVERTERS = {
    preprocessing.StandardScaler: _standard_scaler,
    preprocessing.RobustScaler: _robust_scaler,
    preprocessing.MaxAbsScaler: _max_abs_scaler,
    preprocessing.MinMaxScaler: _min_max_scaler,
    preprocessing.PolynomialFeatures: _polynomial,
}


def _linear(layer):
    """The ``"linear"`` step of a linear model's output layer (an ``OutputLayer``)."""
    return {"op": "linear", "coef": _floats(layer.coef), "intercept": _floats(layer.intercept)}


def _rbf_network(layer):
    """The ``"rbf_network"`` step of a network's output layer (an ``OutputLayer``)."""
    network = layer.network
    tail, tail_degree = layer.tail_coef, layer.tail_degree
    if tail_degree == 0 or not np.any(tail):
        # No tail, or an all-zero one: written as a zero linear tail (one schema shape).
        tail_degree, tail = 1, np.zeros((layer.n_outputs, network.centers.shape[1]))
    return {
        "op": "rbf_network",
        "x_mean": _floats(layer.x_mean),
        "x_scale": _floats(layer.x_scale),
        "centers": _floats(network.centers),
        "widths": _floats(network.widths),
        "coef": _floats(layer.coef),
        "tail_degree": tail_degree,
        "tail_coef": _floats(tail),
        "intercept": _floats(layer.intercept),
    }


_LAYER_STEPS = {"linear": _linear, "rbf_network": _rbf_network}


def _check_finite(spec, label):
    for key, value in spec.items():
        if key in {"name", "class", "op", "n_inputs", "n_outputs", "clip", "tail_degree"} or (
            value is None
        ):
            continue
        array = np.asarray(value, dtype=np.float64)
        if not np.all(np.isfinite(array)):
            raise ValueError(f"Cannot export {label}: parameter {key!r} holds NaN or inf.")


def _describe_fallback(fallback, n_outputs):
    """The schema's ``"fallback"`` entry: a line in T, held flat beyond a calibrated extreme
    where ``hold_below`` / ``hold_above``, plus a rate term clipped to ``rate_bound``
    (:class:`~sklearn_ifog.fallback.Fallback`; zeros, no bounds, for a line or a constant)."""
    has_rate = fallback.rate_column is not None and fallback.rate_slope is not None

    def holds(hold):
        return [False] * n_outputs if hold is None else [bool(value) for value in hold]

    def bound(value):
        return float(value) if np.isfinite(value) else None

    return {
        "intercept": _floats(fallback.intercept),
        "slope": _floats(fallback.slope),
        "column": None if fallback.column is None else int(fallback.column),
        "low": bound(fallback.low),
        "high": bound(fallback.high),
        "hold_below": holds(fallback.hold_below),
        "hold_above": holds(fallback.hold_above),
        "rate_column": int(fallback.rate_column) if has_rate else None,
        "rate_slope": _floats(fallback.rate_slope) if has_rate else [0.0] * n_outputs,
        "rate_bound": float(fallback.rate_bound) if has_rate else 0.0,
    }


def describe_pipeline(pipeline):
    """Describe a fitted compensation Pipeline as the export schema's dict.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline
        Fitted; its first step is a :class:`~sklearn_ifog.ThermalFeatures`, its last a known
        regressor, with known row-wise transformers (or ``"passthrough"``) in between.

    Returns
    -------
    spec : dict
        JSON-able description (see the module docstring for the schema); its ``"domain"``
        holds a :class:`~sklearn_ifog.pipeline.CompensationPipeline`'s calibration domain,
        fallback and ``uncalibrated`` policy, None for a plain Pipeline.

    Raises
    ------
    TypeError
        If ``pipeline`` is not a Pipeline, or a step is of a type the exporters do not know
        (the message names the step and its class).
    ValueError
        If the first step is not a ThermalFeatures, a parameter is not finite, or the steps'
        widths do not chain.
    """
    if not isinstance(pipeline, Pipeline):
        raise TypeError(
            "Expected a fitted sklearn.pipeline.Pipeline (ThermalFeatures → ... → regressor), "
            f"got {_class_path(pipeline)}."
        )
    check_is_fitted(pipeline)
    steps = [(name, step) for name, step in pipeline.steps if step not in (None, "passthrough")]
    if len(steps) < 2:
        raise ValueError("Cannot export: the Pipeline needs ThermalFeatures and a regressor.")
    first_name, first = steps[0]
    if type(first) is not ThermalFeatures:
        raise ValueError(
            f"Cannot export: the first step must be a sklearn_ifog.ThermalFeatures, got "
            f"{_step_label(first_name, first)}."
        )
    features = describe_features(first, first_name)
    n_features = len(features["feature_names"])
    width = n_features
    described = []
    for name, step in steps[1:-1]:
        converter = TRANSFORMER_CONVERTERS.get(type(step))
        if converter is None:
            raise TypeError(
                f"Cannot export {_step_label(name, step)}: the exporters do not know this "
                f"estimator ({_known_names()})."
            )
        spec = {"name": name, "class": _class_path(step), **converter(step, width)}
        n_out = len(spec["powers"]) if spec["op"] == "polynomial" else width
        _check_chain(name, step, width)
        spec["n_inputs"], spec["n_outputs"] = width, n_out
        _check_finite(spec, _step_label(name, step))
        described.append(spec)
        width = n_out
    name, regressor = steps[-1]
    kind = layer_kind(regressor)
    if kind is not None:
        layer = read_layer(regressor)
        spec, single_output = _LAYER_STEPS[kind](layer), layer.single_output
    else:
        raise TypeError(
            f"Cannot export {_step_label(name, regressor)}: the exporters do not know this "
            f"estimator ({_known_names()})."
        )
    _check_chain(name, regressor, width)
    n_outputs = len(spec["intercept"])
    spec = {
        "name": name,
        "class": _class_path(regressor),
        **spec,
        "n_inputs": width,
        "n_outputs": n_outputs,
    }
    _check_finite(spec, _step_label(name, regressor))
    described.append(spec)
    spec = {
        "schema": SCHEMA_NAME,
        "schema_version": SCHEMA_VERSION,
        "generator": f"sklearn-ifog {_version.__version__}",
        "features": features,
        "steps": described,
        "n_features": n_features,
        "n_outputs": n_outputs,
        "single_output": single_output,
        "domain": describe_domain(pipeline, n_features, n_outputs),
    }
    scale = describe_scale_factor(pipeline, n_outputs)
    if scale is not None:  # absent for the bias alone: a version-7 document's meaning
        spec["scale_factor"] = scale
    return spec


def _check_chain(name, step, width):
    expected = getattr(step, "n_features_in_", width)
    if expected != width:
        raise ValueError(
            f"Cannot export {_step_label(name, step)}: it was fitted on {expected} features "
            f"but the previous step gives {width}."
        )


def describe_domain(pipeline, n_features, n_outputs):
    """The ``"domain"`` entry of the schema: None unless ``pipeline`` has a domain.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline
        Fitted; a :class:`~sklearn_ifog.pipeline.CompensationPipeline` carries a domain.
    n_features, n_outputs : int
        Widths of the features and of the prediction, to check the domain against.

    Returns
    -------
    domain : dict or None
        See the module docstring.

    Raises
    ------
    ValueError
        If the pipeline's ``uncalibrated`` or its domain's ``threshold_`` is not one it could
        predict with, or the domain's shapes do not match the features (both name the
        parameter).

    Examples
    --------
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import make_compensation_pipeline
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> X, y = make_thermal_campaign(
    ...     n_units=1, n_runs=1, sampling_period=120.0, random_state=0, return_X_y=True
    ... )
    >>> model = make_compensation_pipeline(
    ...     LinearRegression(), terms=("T", "dT"), uncalibrated="clip", margin=0.5
    ... ).fit(X, y)
    >>> domain = describe_domain(model, n_features=2, n_outputs=1)
    >>> (
    ...     domain["uncalibrated"],
    ...     domain["margin"],
    ...     len(domain["axes"]),
    ...     domain["temperature_columns"],
    ... )
    ('clip', 0.5, 2, [0])
    >>> domain["rate_columns"], len(domain["rate_low"]), len(domain["rate_scale"])
    ([1], 1, 1)
    """
    if not hasattr(pipeline, "fit_domain"):  # a model that learns its own domain
        return None
    check_is_fitted(pipeline, "domain_")
    _domain.require_box(pipeline.domain_, "Streaming compensation and the C and JSON exports")
    margin = pipeline.domain_.threshold_
    try:
        policy = policy_for(pipeline.uncalibrated)
    except (TypeError, ValueError) as error:
        raise ValueError(f"Cannot export the calibration domain: {error}") from None
    if (
        isinstance(margin, bool)
        or not isinstance(margin, numbers.Real)
        or not np.isfinite(margin)
        or margin < 0
    ):
        raise ValueError(
            f"Cannot export the calibration domain: its threshold (domain_.threshold_, the "
            f"exported margin) must be a finite number >= 0, "
            f"got {margin!r}."
        )
    box, fallback = pipeline.domain_.box_, pipeline.fallback_
    columns = [int(column) for column in pipeline.domain_.temperature_columns_]
    if box.center.shape != (n_features,) or fallback.intercept.shape != (n_outputs,):
        raise ValueError(
            f"Cannot export the calibration domain: it was fitted on {box.center.shape[0]} "
            f"features and {fallback.intercept.shape[0]} output(s), but the pipeline gives "
            f"{n_features} features and predicts {n_outputs} output(s); refit it."
        )
    spec = {
        "center": _floats(box.center),
        "scale": _floats(box.scale),
        "axes": _floats(box.axes),
        "axis_scale": _floats(box.axis_scale),
        "lower": _floats(box.lower),
        "upper": _floats(box.upper),
        "margin": float(margin),
        # The blend's width even under another policy: the C header defines it always.
        "blend_width": float(BlendWithFallback().width),
        "temperature_columns": columns,
        "temperature_low": _floats(pipeline.domain_.data_min_[columns]),
        "temperature_high": _floats(pipeline.domain_.data_max_[columns]),
        # One more term of the distance per rate feature (dT of each sensor): the excess
        # beyond its calibrated range over its scale (empty for a domain without them).
        "rate_columns": [int(column) for column in box.rate_columns],
        "rate_low": _floats(box.rate_low),
        "rate_high": _floats(box.rate_high),
        "rate_scale": _floats(box.rate_scale),
        "boost": float(box.boost),
        # Where the boost's temperature novelty starts (the calibrated temperatures, widened
        # where held-out runs showed the model extrapolating well).
        "boost_temperature_low": _floats(box.temperature_low),
        "boost_temperature_high": _floats(box.temperature_high),
        # Standard deviations (over RATE_WEIGHT, as rate_scale is) of a rate, and of a
        # temperature, beyond its range at which the boost is added in full.
        "boost_rate_ramp": float(_tuning.RATE_WEIGHT * _tuning.NOVELTY_RAMP),
        "boost_temperature_ramp": float(_tuning.NOVELTY_RAMP),
        "projection_rounds": int(_tuning.PROJECTION_ROUNDS),
        "uncalibrated": policy.name,
        "fallback": _describe_fallback(fallback, n_outputs),
    }
    numbers_only = {
        key: value for key, value in spec.items() if key not in ("uncalibrated", "fallback")
    }
    _check_finite(numbers_only, "the calibration domain")
    _check_finite({**spec["fallback"], "column": None}, "the calibration domain's fallback")
    return spec


def describe_scale_factor(pipeline, n_outputs):
    """The ``"scale_factor"`` entry of the schema: None unless fitted with ``input_rate``.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline
        Fitted; a :class:`~sklearn_ifog.pipeline.CompensationPipeline` with ``input_rate``
        predicts the bias and the scale-factor error (:mod:`sklearn_ifog.scale_factor`).
    n_outputs : int
        The outputs of its final step (2 with a scale factor).

    Returns
    -------
    scale_factor : dict or None
        See the module docstring.

    Raises
    ------
    ValueError
        If the pipeline was fitted with ``input_rate`` but does not predict two outputs or
        has no calibrated input-rate range (``input_rate_range_``).

    Examples
    --------
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import make_compensation_pipeline
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> X, y = make_thermal_campaign(
    ...     n_units=1, n_runs=1, sampling_period=120.0, random_state=0, return_X_y=True
    ... )
    >>> omega = 3600.0 * (X.index.to_numpy() % 3 - 1) * 100.0  # -100, 0, 100 deg/s
    >>> X = X.assign(reference=omega)
    >>> model = make_compensation_pipeline(LinearRegression(), input_rate="reference")
    >>> model = model.fit(X, y + 1e-4 * omega)
    >>> entry = describe_scale_factor(model, n_outputs=2)
    >>> entry["input_rate"], entry["outputs"], entry["input_rate_range"], entry["slack"]
    ('reference', ['bias', 'scale_factor'], [-360000.0, 360000.0], 0.05)
    >>> describe_scale_factor(model[:], n_outputs=2) is None  # a plain Pipeline
    True
    """
    column = getattr(pipeline, "input_rate", None)
    if column is None:
        return None
    check_is_fitted(pipeline, "input_rate_range_")
    bounds = pipeline.input_rate_range_
    if n_outputs != 2 or bounds is None or not np.all(np.isfinite(bounds)):
        raise ValueError(
            f"Cannot export the scale factor: a pipeline fitted with input_rate={column!r} "
            f"predicts 2 outputs (bias, scale factor) within a finite input_rate_range_, got "
            f"{n_outputs} output(s) and input_rate_range_={bounds!r}; refit it."
        )
    return {
        "input_rate": _column(column),
        "input_rate_unit": INPUT_RATE_UNIT,
        "outputs": ["bias", "scale_factor"],
        "input_rate_range": _floats(bounds),
        "slack": float(_tuning.INPUT_RATE_SLACK),
        "asymmetry": float(pipeline.asymmetry_),
    }
