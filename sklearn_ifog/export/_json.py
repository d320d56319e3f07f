"""Export of a fitted compensation Pipeline to JSON, for firmware in other languages."""

import json
from pathlib import Path

from sklearn_ifog._description import describe_pipeline
from sklearn_ifog._io import write_text_files


def to_json(pipeline, path):
    """Write the parameters of a fitted compensation Pipeline to a JSON file.

    The file holds exactly what :func:`to_c` compiles in, for implementations in other
    languages: the ThermalFeatures rules (sensor columns, time column, terms, the smoothing
    and the lags' time constants in seconds, time unit), then every step in order with its
    operation and parameters, under a ``"schema"`` name and a ``"schema_version"``
    (currently 8), and for a :class:`~sklearn_ifog.pipeline.CompensationPipeline` its
    calibration domain and ``uncalibrated`` policy (``"domain"``; null for a plain Pipeline).
    Per sensor and per time constant ``tau`` of ``time_constants``, the
    deficit ``e`` of the temperature ``u`` behind its first-order lag is 0 at a run's first
    row, then ``x = (t - t_prev) / tau``, ``a = exp(-x)``, ``g = -expm1(-x) / x`` (1 when
    ``x == 0``), ``e = a * e + g * (u - u_prev)``; a ``"T_lag<tau>s"`` term is that ``e``,
    a ``"TT_lag<tau>s"`` term ``u * e``, and, with ``smoothing > 0``,
    ``dT = e / smoothing * seconds_per_unit`` at ``tau = smoothing``. Floats are written with
    round-trip precision (Python's ``repr``). The schema is documented in
    ``sklearn_ifog/_description.py``; in short, per step ``op``:

    - ``"center_scale"``: ``y = (x - center) / scale``;
    - ``"multiply_add"``: ``y = x * multiply + add``, clipped to ``clip`` when given;
    - ``"polynomial"``: ``y[k] = prod_j x[j] ** powers[k][j]``;
    - ``"linear"``: ``y = coef @ x + intercept``;
    - ``"rbf_network"``: ``z = (x - x_mean) / x_scale``,
      ``y = coef @ exp(-||z - centers||^2 / (2 widths^2)) + tail_coef @ t(z) + intercept``,
      with ``t(z)`` the polynomial tail of degree ``tail_degree`` (``z``, then for degree 2
      the monomials ``z[i] * z[j]``, ``i <= j``, in ``PolynomialFeatures`` order).

    The ``"domain"`` entry holds the box in decorrelated coordinates (``center``, ``scale``,
    ``axes`` one per row, ``axis_scale``, ``lower``, ``upper``), ``margin``, ``blend_width``,
    the temperature columns and their calibrated ranges (``temperature_columns``,
    ``temperature_low``, ``temperature_high``), the rate columns with their calibrated ranges
    and scales (``rate_columns``, ``rate_low``, ``rate_high``, ``rate_scale``; empty lists
    for a model without them), ``projection_rounds``, the policy ``uncalibrated`` and the
    ``fallback`` (``intercept``, ``slope``, ``column``, the calibrated ``low`` and ``high``
    with ``hold_below`` / ``hold_above``, ``rate_column``, ``rate_slope``, ``rate_bound``):
    a row's distance is ``sqrt(sum_k (e_k / axis_scale_k)^2 + sum_r (g_r /
    rate_scale_r)^2)`` with ``e_k`` the excess of its coordinate
    ``(axes @ ((x - center) / scale))_k`` beyond ``[lower_k, upper_k]`` and ``g_r`` the
    excess of its rate ``x[rate_columns[r]]`` beyond ``[rate_low_r, rate_high_r]`` (0
    inside); it is outside above ``margin`` or with a temperature beyond its range; the
    policies are those of :meth:`~sklearn_ifog.pipeline.CompensationPipeline.predict`,
    written out in ``sklearn_ifog/_description.py`` (``"blend"`` weighs by this distance,
    ``"clip"`` projects by the box's term alone).

    A pipeline fitted with ``input_rate`` (a scale factor, issue 44) predicts two outputs, the
    bias ``b`` (deg/h) and the scale-factor error ``s`` (dimensionless), the policy and its
    fallback acting on that pair; its document adds ``"scale_factor"``: the ``input_rate``
    column, ``input_rate_unit`` (``"deg/h"``), ``outputs`` (``["bias",
    "scale_factor"]``), the calibrated ``input_rate_range`` (deg/h), the ``slack`` (a share
    of its larger magnitude) and the ``asymmetry`` ``a``. A gyro output ``rate`` stands for
    the input rate ``(rate - b) / (1 + s + a sign(rate - b))``; the drift at a known input
    rate ``w`` is ``b + w * s + a |w|``; an input rate (the
    output standing in for it) below ``low - d`` or above ``high + d``, ``d = slack *
    max(|low|, |high|)``, is outside the calibration too. A document without the entry (every
    bias-only model, and every document of schema version 7) predicts the drift.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline or UnitwiseRegressor
        Fitted; the same pipelines as :func:`to_c` accepts. A
        :class:`~sklearn_ifog.UnitwiseRegressor` is written as ``{"schema":
        "sklearn-ifog-units", "schema_version": 1, "unit_column": ..., "pooling": ...,
        "units": [{"unit": label, "model": <the pipeline's document>}, ...]}``.
    path : str or path-like
        The file to write (atomically: a temporary file, then a rename).

    Returns
    -------
    path : pathlib.Path
        The path written.

    Raises
    ------
    TypeError
        If a step is of a type the exporter does not know (the message names the step).
    ValueError
        If the first step is not ThermalFeatures or a parameter is not finite.

    Examples
    --------
    >>> import json, tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn_ifog import ThermalFeatures
    >>> from sklearn_ifog.export import to_json
    >>> X = np.column_stack([np.arange(6.0), 20 + np.arange(6.0) ** 2 / 10])
    >>> model = make_pipeline(ThermalFeatures(temperature=1, time=0), LinearRegression())
    >>> model = model.fit(X, X[:, 1] / 100)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     spec = json.loads(to_json(model, Path(directory) / "model.json").read_text())
    >>> spec["schema_version"], [step["op"] for step in spec["steps"]], spec["domain"]
    (9, ['linear'], None)

    A CompensationPipeline also writes where it was calibrated:

    >>> from sklearn_ifog import make_compensation_pipeline
    >>> model = make_compensation_pipeline(
    ...     LinearRegression(), temperature=1, time=0, run=None, terms=("T", "dT"), margin=0.5
    ... ).fit(X, X[:, 1] / 100)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     spec = json.loads(to_json(model, Path(directory) / "model.json").read_text())
    >>> domain = spec["domain"]
    >>> (
    ...     domain["uncalibrated"],
    ...     domain["margin"],
    ...     domain["temperature_high"],
    ...     domain["fallback"]["column"],
    ... )
    ('blend', 0.5, [22.5], 0)
    """
    if hasattr(pipeline, "unit_models"):  # a model per unit
        spec = _unitwise_spec(pipeline)
    else:
        spec = describe_pipeline(pipeline)
    path = Path(path)
    text = json.dumps(spec, indent=2, allow_nan=False) + "\n"
    write_text_files({path: text})
    return path


def _unitwise_spec(model):
    """The JSON document of a fitted UnitwiseRegressor: every unit's pipeline document."""
    from sklearn.utils.validation import check_is_fitted

    check_is_fitted(model)
    units = []
    for unit, estimator in model.estimators_.items():
        try:
            units.append({"unit": unit, "model": describe_pipeline(estimator)})
        except (TypeError, ValueError) as error:
            raise type(error)(f"unit {unit!r}: {error}") from error
    return {
        "schema": "sklearn-ifog-units",
        "schema_version": 1,
        "unit_column": model.unit,
        "pooling": model.pooling,
        "units": units,
    }
