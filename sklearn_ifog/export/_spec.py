"""A fitted compensation Pipeline described as plain parameters (the export schema).

``describe_pipeline`` turns ``ThermalFeatures → [row-wise transformers] → regressor`` into a
JSON-able dict; the C generator renders that dict and ``to_json`` writes it, so both exports
carry exactly the same numbers. Every float goes through ``float(...)`` of a float64, so
``json`` (which writes ``repr``) and the C generator (``repr`` / ``%.9g``) keep round-trip
precision.

Schema (version 3; version 2 had no ``"domain"``, version 1 an EMA ``smoothing`` in samples
and its ``alpha``)::

    {
      "schema": "sklearn-ifog-pipeline",
      "schema_version": 3,
      "generator": "sklearn-ifog <version>",
      "features": {
        "op": "thermal_features",
        "temperature": [<column name or position>, ...],   # one per sensor, in order
        "time": <column> | null,
        "run": <column> | null,
        "terms": [...],              # among "T", "dT", "TdT", "T2", "gradient", "T_lag<tau>s",
                                     # "TT_lag<tau>s"
        "term_time_constants": [...],  # per term: its lag's time constant, s, or null
        "smoothing": float,          # time constant of dT's smoothing, s (0: none)
        "time_constants": [...],     # s: the lags carried per sensor (lag terms, smoothing)
        "seconds_per_unit": float | null,   # null when time is null (per-sample difference)
        "feature_names": [...]       # output columns: for each sensor, for each term
      },
      "steps": [ <step>, ... ],      # after the features, applied in order, row by row
      "n_features": int,             # features entering the first step
      "n_outputs": int,
      "single_output": bool,         # the Pipeline predicts a 1-D array
      "domain": <domain> | null      # a CompensationPipeline's calibration domain and
                                     # outside policy; null for a plain Pipeline
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
      "margin": <float>,                     # distance that still counts as inside
      "blend_width": <float>,                # width of the "blend" policy's smoothstep
      "temperature_columns": [<int>, ...],   # features holding a temperature (T of each
                                             # sensor): their range admits no margin
      "temperature_low": [...], "temperature_high": [...],   # their calibrated ranges
      "projection_rounds": <int>,            # rounds of "clip" with temperature columns
      "outside": "blend" | "clip" | "none",  # the policy outside the domain
      "fallback": {"intercept": [...], "slope": [...],   # n_outputs each
                   "column": <int> | null}   # the feature holding T; null: a constant
    }

A row ``x`` of features has the coordinates ``p = axes @ ((x - center) / scale)``; along
axis ``k`` its excess ``e_k`` is ``lower_k - p_k`` below the range, ``p_k - upper_k``
above it, 0 inside; its distance is ``d = sqrt(sum_k (e_k / axis_scale_k)^2)``. It is
outside when ``d > margin`` or when a temperature column ``x[c]`` lies outside
``[temperature_low, temperature_high]`` (by any amount). Rows inside get the steps'
prediction ``y``; rows outside follow ``outside``:

- ``"blend"``: ``(1 - w) y + w f`` with ``s = clip((d - margin) / blend_width, 0, 1)``,
  ``w = s^2 (3 - 2 s)`` (0 for a row outside by a temperature alone) and the fallback
  ``f = intercept + x[column] * slope`` (``f = intercept`` when ``column`` is null).
- ``"clip"``: the steps' prediction at the row projected onto the domain. One projection
  ``P(x)``: a row with ``d <= margin`` is unchanged; else, with ``c`` its coordinates
  clamped to ``[lower, upper]`` and ``q = c + (p - c) * (margin / d)``, it becomes
  ``(axes^T @ q) * scale + center``. Without temperature columns the projected row is
  ``P(x)``; with them, ``projection_rounds`` times: ``x = P(x)``, then every temperature
  column clamped to its range.
- ``"none"``: ``y``.

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
"""

import numbers

import numpy as np
from sklearn import linear_model, preprocessing
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted

import sklearn_ifog
from sklearn_ifog import domain as _domain
from sklearn_ifog._contract import (
    get_term,
    seconds_per_unit,
    sensor_keys,
    state_time_constants,
    valid_terms_text,
)
from sklearn_ifog.features import ThermalFeatures
from sklearn_ifog.rbf import RBFNetRegressor

SCHEMA_NAME = "sklearn-ifog-pipeline"
SCHEMA_VERSION = 3

# Regressors whose predict is exactly ``X @ coef_.T + intercept_``.
LINEAR_REGRESSORS = (
    linear_model.LinearRegression,
    linear_model.Ridge,
    linear_model.RidgeCV,
    linear_model.Lasso,
    linear_model.LassoCV,
    linear_model.ElasticNet,
    linear_model.ElasticNetCV,
    linear_model.Lars,
    linear_model.LassoLars,
    linear_model.BayesianRidge,
    linear_model.ARDRegression,
    linear_model.HuberRegressor,
    linear_model.SGDRegressor,
    linear_model.QuantileRegressor,
    linear_model.TheilSenRegressor,
)


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
    regressors = ", ".join(cls.__name__ for cls in (RBFNetRegressor, *LINEAR_REGRESSORS))
    return f"transformers: {transformers}; final regressors: {regressors}"


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
    resolved_terms, smoothing = step._resolved()
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


def _linear(step):
    coef = np.asarray(step.coef_, dtype=np.float64)
    single_output = coef.ndim == 1
    coef = np.atleast_2d(coef)
    intercept = np.broadcast_to(np.asarray(step.intercept_, dtype=np.float64), coef.shape[:1])
    return {"op": "linear", "coef": _floats(coef), "intercept": _floats(intercept)}, single_output


def _rbf_network(step):
    single_output = np.ndim(step.coef_) == 1
    network = step._network()  # the fitted network as one value, 2-D weights
    n_outputs, n_inputs = network.coef.shape[0], network.centers.shape[1]
    tail = network.tail_coef
    tail_degree = network.tail_degree
    if tail_degree == 0 or not np.any(tail):
        # No tail, or an all-zero one: written as a zero linear tail (one schema shape).
        tail_degree, tail = 1, np.zeros((n_outputs, n_inputs))
    spec = {
        "op": "rbf_network",
        "x_mean": _floats(step.x_mean_),
        "x_scale": _floats(step.x_scale_),
        "centers": _floats(network.centers),
        "widths": _floats(network.widths),
        "coef": _floats(network.coef),
        "tail_degree": tail_degree,
        "tail_coef": _floats(tail),
        "intercept": _floats(network.intercept),
    }
    return spec, single_output


def _check_finite(spec, label):
    for key, value in spec.items():
        if key in {"name", "class", "op", "n_inputs", "n_outputs", "clip", "tail_degree"} or (
            value is None
        ):
            continue
        array = np.asarray(value, dtype=np.float64)
        if not np.all(np.isfinite(array)):
            raise ValueError(f"Cannot export {label}: parameter {key!r} holds NaN or inf.")


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
    if type(regressor) is RBFNetRegressor:
        spec, single_output = _rbf_network(regressor)
    elif type(regressor) in LINEAR_REGRESSORS:
        spec, single_output = _linear(regressor)
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
        "generator": f"sklearn-ifog {sklearn_ifog.__version__}",
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
        If the pipeline's ``outside`` or ``margin`` is not one it could predict with, or the
        domain's shapes do not match the features (both name the parameter).

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
    """
    from sklearn_ifog.pipeline import OUTSIDE_POLICIES, CompensationPipeline

    if not isinstance(pipeline, CompensationPipeline):
        return None
    check_is_fitted(pipeline, "domain_")
    outside, margin = pipeline.outside, pipeline.domain_.margin
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
            f"Cannot export the calibration domain: margin must be a finite number >= 0, "
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
        "blend_width": float(_domain.BLEND_WIDTH),
        "temperature_columns": columns,
        "temperature_low": _floats(pipeline.domain_.data_min_[columns]),
        "temperature_high": _floats(pipeline.domain_.data_max_[columns]),
        "projection_rounds": int(_domain.PROJECTION_ROUNDS),
        "outside": outside,
        "fallback": {
            "intercept": _floats(fallback.intercept),
            "slope": _floats(fallback.slope),
            "column": None if fallback.column is None else int(fallback.column),
        },
    }
    numbers_only = {
        key: value for key, value in spec.items() if key not in ("outside", "fallback")
    }
    _check_finite(numbers_only, "the calibration domain")
    _check_finite({**spec["fallback"], "column": None}, "the calibration domain's fallback")
    return spec
