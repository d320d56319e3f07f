"""The description of a fitted compensation Pipeline as plain parameters (the export schema).

:func:`describe_pipeline` turns ``ThermalFeatures → [row-wise transformers] → regressor`` into
a JSON-able dict, documented in :mod:`sklearn_ifog.export._spec` (which re-exports these
names). A private module that serves several: both exports (``to_json`` writes the dict,
``to_c`` renders it) and the compiled fast path of streaming (:mod:`sklearn_ifog._compiled`
reads the steps from it), so all three carry exactly the same numbers and the online path
needs nothing from :mod:`sklearn_ifog.export`. The output layer of the final regressor is
read by :mod:`sklearn_ifog._output_layer`.
"""

import numbers

import numpy as np
from sklearn import preprocessing
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted

from sklearn_ifog import _version
from sklearn_ifog import domain as _domain
from sklearn_ifog import policy as _policy
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

SCHEMA_NAME = "sklearn-ifog-pipeline"
SCHEMA_VERSION = 6


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
        fallback and ``outside`` policy, None for a plain Pipeline.

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
    return {
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
        If the pipeline's ``outside`` or its domain's ``threshold_`` is not one it could
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
    ...     LinearRegression(), terms=("T", "dT"), outside="clip", margin=0.5
    ... ).fit(X, y)
    >>> domain = describe_domain(model, n_features=2, n_outputs=1)
    >>> domain["outside"], domain["margin"], len(domain["axes"]), domain["temperature_columns"]
    ('clip', 0.5, 2, [0])
    >>> domain["rate_columns"], len(domain["rate_low"]), len(domain["rate_scale"])
    ([1], 1, 1)
    """
    from sklearn_ifog.pipeline import OUTSIDE_POLICIES, CompensationPipeline

    if not isinstance(pipeline, CompensationPipeline):
        return None
    check_is_fitted(pipeline, "domain_")
    outside, margin = pipeline.outside, pipeline.domain_.threshold_
    if outside not in OUTSIDE_POLICIES:
        raise ValueError(
            f"Cannot export the calibration domain: outside must be one of "
            f"{list(OUTSIDE_POLICIES)}, got {outside!r}."
        )
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
        "blend_width": float(_policy.BLEND_WIDTH),
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
        "boost_rate_ramp": float(_domain.RATE_WEIGHT * _domain.NOVELTY_RAMP),
        "boost_temperature_ramp": float(_domain.NOVELTY_RAMP),
        "projection_rounds": int(_domain.PROJECTION_ROUNDS),
        "outside": outside,
        "fallback": _describe_fallback(fallback, n_outputs),
    }
    numbers_only = {
        key: value for key, value in spec.items() if key not in ("outside", "fallback")
    }
    _check_finite(numbers_only, "the calibration domain")
    _check_finite({**spec["fallback"], "column": None}, "the calibration domain's fallback")
    return spec
