"""Export of a fitted compensation Pipeline to self-contained C99 (header + source).

:func:`render_c` fills the templates of :mod:`sklearn_ifog.export._templates` with the
description of :func:`sklearn_ifog._description.describe_pipeline`: the steps' C
(:mod:`sklearn_ifog.export._c_steps`), the front end, domain and recalibration parts
(:mod:`sklearn_ifog.export._c_parts`), written with :mod:`sklearn_ifog.export._c_writer`.
"""

import re
from pathlib import Path

from sklearn_ifog._compiled import compile_steps
from sklearn_ifog._description import describe_pipeline
from sklearn_ifog._io import write_text_files
from sklearn_ifog.export._c_parts import (
    adaptation_parts,
    domain_parts,
    features_body,
    scale_parts,
    state_parts,
)
from sklearn_ifog.export._c_steps import RENDERERS
from sklearn_ifog.export._c_writer import Writer, c_comment, format_c_literal
from sklearn_ifog.export._templates._source import HEADER, SOURCE
from sklearn_ifog.streaming._recalibration import check_adaptation, recalibration_prior

__all__ = ["format_c_literal", "render_c", "to_c", "to_c_units"]

_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def render_c(
    spec,
    prefix="ifog",
    precision="double",
    *,
    adapt=None,
    forgetting=0.999,
    prior=None,
    degree=None,
):
    """Render the export schema's dict as C99 header and source text.

    Parameters
    ----------
    spec : dict
        The output of :func:`sklearn_ifog._description.describe_pipeline`.
    prefix : str, default="ifog"
        Prefix of every public C name and of the file names.
    precision : {"double", "float"}, default="double"
        Type of the parameters and of the network arithmetic.
    adapt : {None, "bias", "output"}, default=None
        The online recalibration to write (see :func:`to_c`).
    forgetting : float, default=0.999
        Its forgetting factor.
    prior : RecalibrationPrior, default=None
        Its start (:func:`sklearn_ifog.streaming._recalibration.recalibration_prior`, the
        Python compensator's); needed with ``adapt``.
    degree : int, default=None
        The degree of the network's stored tail (the output-layer design of
        ``adapt="output"``).

    Returns
    -------
    header, source : str
        The contents of ``{prefix}.h`` and ``{prefix}.c``.
    """
    _check_scale_factor(spec, adapt)
    writer = Writer(prefix, precision)
    steps = spec["steps"]
    buffers = ["features"] + [f"x{k}" for k in range(1, len(steps))] + ["drift"]
    for k, step in enumerate(steps[:-1], start=1):
        writer.emit(f"    {writer.real} x{k}[{step['n_outputs']}];")
    for k, step in enumerate(steps):
        writer.emit(f"    /* {c_comment(step['name'])}: {step['class']} */")
        RENDERERS[step["op"]](writer, f"step{k}", step, buffers[k], buffers[k + 1])
    # The last step (linear or RBF network) always loops over both indices.
    predict_lines = ["    int i;", "    int j;", *writer.lines]
    features = spec["features"]
    pipeline_lines = [" *   ThermalFeatures"] + [
        f" *   -> {c_comment(step['name'])} ({step['class']})" for step in steps
    ]
    time_column = features["time"]
    lag_define, lag_field, lag_reset, lag_table = state_parts(features, prefix)
    domain = domain_parts(writer, spec, prefix, adapt)
    adaptation = adaptation_parts(writer, spec, prefix, adapt, forgetting, prior, degree)
    fields = {
        "prefix": prefix,
        "PREFIX": prefix.upper(),
        "guard": f"{prefix.upper()}_H",
        "generator": spec["generator"],
        "pipeline_lines": "\n".join(pipeline_lines),
        "real": precision,
        "n_sensors": len(features["temperature"]),
        "n_features": spec["n_features"],
        "n_outputs": spec["n_outputs"],
        "sensor_list": c_comment(", ".join(str(column) for column in features["temperature"])),
        "feature_list": c_comment(", ".join(features["feature_names"])),
        "time_note": (
            " (ignored: the model differences per sample)"
            if time_column is None
            else f" (column {c_comment(str(time_column))})"
        ),
        "time_null": " (may be NULL)" if time_column is None else "",
        "parameters": "\n".join(
            [lag_table, *writer.parameters] if lag_table else writer.parameters
        ),
        "lag_define": lag_define,
        "lag_field": lag_field,
        "lag_reset": lag_reset,
        "features_body": features_body(features, prefix),
        "predict_body": "\n".join(predict_lines),
        "batch_time": "0.0" if time_column is None else "time[sample]",
        "batch_prelude": "    (void)time; /* the model differences per sample */\n"
        if time_column is None
        else "",
        **domain,
        **adaptation,
        **scale_parts(spec, prefix),
    }
    return HEADER.substitute(fields), SOURCE.substitute(fields)


def _check_scale_factor(spec, adapt):
    """Refuse ``adapt`` for a model with a scale factor (the recalibration learns a drift)."""
    scale = spec.get("scale_factor")
    if scale is not None and adapt is not None:
        raise ValueError(
            f"adapt={adapt!r} is not available for a pipeline fitted with input_rate="
            f"{scale['input_rate']!r}: the online recalibration learns rate - reference as a "
            "bias-only drift, where a scale-factor model's is b + input_rate * s. Use "
            "adapt=None (refit on new rate-table data to recalibrate)."
        )


def to_c(pipeline, directory, precision="double", prefix="ifog", *, adapt=None, forgetting=0.999):
    """Write a fitted compensation Pipeline as a self-contained C99 header and source.

    The generated ``{prefix}.h`` / ``{prefix}.c`` need nothing beyond ``<math.h>`` and
    allocate no memory. They provide a state struct ``{prefix}_state`` with
    ``{prefix}_init`` / ``{prefix}_reset`` (at the start of every run), the streaming
    ``{prefix}_step`` (one sample in, the drift out) and ``{prefix}_compensate``, the batch
    ``{prefix}_batch`` (one whole run, with the fitted model), and
    ``{prefix}_predict_features`` (the stateless part after ThermalFeatures, fitted model).

    With ``adapt``, the state also carries the online recalibration of
    :class:`~sklearn_ifog.streaming.StreamingCompensator` (same ``adapt`` and
    ``forgetting``, same initial weights and covariance factor, same square-root RLS and
    guards, in fixed-size double arrays): ``{prefix}_adapt(&state, time, temperature, rate,
    reference, drift)`` compensates a sample whose true rate is known and then learns from
    it, ``{prefix}_step`` uses the recalibrated weights, ``{prefix}_reset`` (a new run)
    keeps them and ``{prefix}_reset_adaptation`` (called by ``{prefix}_init``) returns to
    the fitted model. Parameters are written with round-trip precision. The causal front
    end (differences of time and temperature, the exact first-order lags of the lag terms and
    of the smoothing, with fixed-size state arrays) is computed in double even for
    ``precision="float"``: differencing 0.01 °C steps of a 30 °C reading in single precision
    would alone cost about 1e-4 relative.

    A :class:`~sklearn_ifog.pipeline.CompensationPipeline` also brings its calibration domain
    and ``uncalibrated`` policy (``{PREFIX}_HAS_DOMAIN`` is 1; 0 for a plain Pipeline): every
    sample's distance outside the domain and its flag, as ``calibration_distance`` and
    ``outside_calibration`` give them, and its drift under the same policy as ``predict``
    (``"blend"``, ``"clip"`` or ``"none"``, with the pipeline's ``margin`` and the blend's
    ``width``, :class:`~sklearn_ifog.policy.BlendWithFallback`; each policy object hands the
    writer its C, :meth:`~sklearn_ifog.policy.UncalibratedPolicy.c_fragment`). After
    ``{prefix}_step``, ``{prefix}_compensate`` or ``{prefix}_adapt``, ``state.last_distance``
    and ``state.last_outside`` hold the sample's distance and flag;
    ``{prefix}_calibration_distance(features)`` is the stateless distance and
    ``{prefix}_predict_features`` applies the policy. The distance carries the domain's rate
    term (:func:`~sklearn_ifog.domain.box_distance`: a rate beyond its calibrated range adds
    to it), which the flag and ``"blend"`` read; ``"clip"`` projects by the box alone, as
    :func:`~sklearn_ifog.domain.project_to_box` does. The domain is computed in double
    whatever the precision. With ``adapt``, a sample outside the domain is compensated by
    the policy and does not update the recalibration, and the ``"bias"`` offset is added
    after the policy (the rule of :class:`~sklearn_ifog.streaming.StreamingCompensator`).

    A pipeline fitted with ``input_rate`` (a scale factor, issue 44) predicts the pair of the
    bias ``b`` (deg/h) and the scale-factor error ``s``: ``{prefix}_step``, ``{prefix}_batch``
    and ``{prefix}_predict_features`` give that pair (``{PREFIX}_N_OUTPUTS`` is 2), the
    domain's policy applied to it as ``predict`` does (``"blend"`` with the two-output
    fallback, ``"clip"`` at the projected row); ``{PREFIX}_HAS_SCALE_FACTOR`` is 1 and
    ``{PREFIX}_INPUT_RATE_LOW`` / ``_HIGH`` / ``_SLACK`` hold the calibrated input rates.
    ``{prefix}_compensate(&state, time, temperature, rate, compensated)`` takes one gyro
    output and gives the input rate it stands for, ``(rate - b) / (1 + s + a sign(rate -
    b))`` (``pipeline.compensate``; ``a`` is ``{PREFIX}_ASYMMETRY``, the pipeline's
    ``asymmetry_``); ``{prefix}_drift_at(&state, time, temperature, input_rate, drift)`` the
    drift ``b + s * input_rate + a * |input_rate|`` at a known input rate
    (``pipeline.predict``);
    after either, ``state.last_outside`` is also 1 when the output (or the known input
    rate) lies beyond the calibrated input rates (``outside_calibration``; the policy reads
    the domain alone), and ``{prefix}_beyond_input_rates`` makes that test alone. Without
    ``input_rate`` nothing of this is written.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline or CompensationPipeline
        Fitted: :class:`~sklearn_ifog.ThermalFeatures`, then any of StandardScaler,
        RobustScaler, MaxAbsScaler, MinMaxScaler, PolynomialFeatures (or "passthrough"), then
        a :class:`~sklearn_ifog.RBFNetRegressor` or a linear regressor (LinearRegression,
        Ridge, Lasso, ElasticNet, BayesianRidge, HuberRegressor, ... and their CV forms).
    directory : str or path-like
        Where to write the two files (created if missing).
    precision : {"double", "float"}, default="double"
        C type of the parameters and of the network arithmetic.
    prefix : str, default="ifog"
        A C identifier: prefix of every generated name and the files' base name.
    adapt : {None, "bias", "output"}, default=None
        Online recalibration (see :class:`~sklearn_ifog.streaming.StreamingCompensator`);
        not with a pipeline fitted with ``input_rate`` (a ``ValueError``); needs
        ``precision="double"`` (the initial covariance spans eight orders of
        magnitude: single precision cannot carry it).
    forgetting : float, default=0.999
        Forgetting factor of the recalibration, in (0, 1].

    Returns
    -------
    header, source : pathlib.Path
        The paths written.

    Raises
    ------
    TypeError
        If a step is of a type the exporter does not know (the message names the step).
    ValueError
        On a bad ``precision`` or ``prefix``, a first step that is not ThermalFeatures, a
        parameter that is not finite, a CompensationPipeline whose ``uncalibrated`` or
        ``margin`` is not one it could predict with, or ``adapt`` with a pipeline fitted
        with ``input_rate``.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn_ifog import ThermalFeatures
    >>> from sklearn_ifog.export import to_c
    >>> X = np.column_stack([np.arange(6.0), 20 + np.arange(6.0) ** 2 / 10])
    >>> model = make_pipeline(ThermalFeatures(temperature=1, time=0), LinearRegression())
    >>> model = model.fit(X, X[:, 1] / 100)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     header, source = to_c(model, directory)
    ...     print(header.name, source.name, "ifog_step" in source.read_text())
    ifog.h ifog.c True

    A CompensationPipeline brings its calibration domain, its flag and its policy:

    >>> from sklearn_ifog import make_compensation_pipeline
    >>> model = make_compensation_pipeline(
    ...     LinearRegression(),
    ...     temperature=1,
    ...     time=0,
    ...     run=None,
    ...     terms=("T", "dT"),
    ...     uncalibrated="clip",
    ... ).fit(X, X[:, 1] / 100)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     text = to_c(model, directory)[0].read_text()
    >>> "#define IFOG_HAS_DOMAIN 1" in text, "int last_outside;" in text
    (True, True)
    """
    if precision not in ("double", "float"):
        raise ValueError(f"precision must be 'double' or 'float', got {precision!r}.")
    if not isinstance(prefix, str) or not _IDENTIFIER.match(prefix):
        raise ValueError(
            f"prefix must be a C identifier (a letter, then letters, digits or '_'), "
            f"got {prefix!r}."
        )
    if adapt is not None and precision != "double":
        raise ValueError(
            f"adapt={adapt!r} needs precision='double', got {precision!r}: the recalibration's "
            "covariance factor is updated in double."
        )
    spec = describe_pipeline(pipeline)
    _check_scale_factor(spec, adapt)
    prior, degree = None, None
    if adapt is not None or forgetting != 0.999:
        # The compensator's checks of adapt and forgetting, and its initial weights and
        # factor: one recalibration, in Python and in C. The pipeline compiles, since it
        # could be described.
        check_adaptation(adapt, forgetting)
        compiled = compile_steps(pipeline)
        prior = recalibration_prior(adapt, compiled, compiled.final.n_outputs)
        degree = getattr(compiled.final, "degree", None)
    header_text, source_text = render_c(
        spec,
        prefix=prefix,
        precision=precision,
        adapt=adapt,
        forgetting=float(forgetting),
        prior=prior,
        degree=degree,
    )
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    header = directory / f"{prefix}.h"
    source = directory / f"{prefix}.c"
    write_text_files({header: header_text, source: source_text})
    return header, source


def _unit_identifier(unit):
    """A unit label as the tail of a C identifier: letters, digits and '_' only."""
    text = re.sub(r"[^A-Za-z0-9_]", "_", str(unit))
    return text or "_"


def to_c_units(model, directory, precision="double", prefix="ifog"):
    """Write every unit of a fitted :class:`~sklearn_ifog.UnitwiseRegressor` as C99.

    One header and one source per unit, each exactly what :func:`to_c` writes for that
    unit's model, with the prefix ``{prefix}_unit_{unit}`` (characters of the unit label
    that cannot be in a C identifier become ``_``). Firmware flashes one gyro's pair; every
    unit keeps its own state and functions, so several can be linked together. A unit whose
    model is a :class:`~sklearn_ifog.pipeline.CompensationPipeline` carries that model's
    own calibration domain, fallback and ``uncalibrated`` policy, the ones its ``predict`` uses
    (:class:`~sklearn_ifog.UnitwiseRegressor` says which rows each unit's domain is fitted
    on).

    Parameters
    ----------
    model : UnitwiseRegressor
        Fitted; every unit's model must be a Pipeline :func:`to_c` accepts.
    directory : str or path-like
        Where to write the files (created if missing).
    precision : {"double", "float"}, default="double"
        As for :func:`to_c`.
    prefix : str, default="ifog"
        A C identifier: the start of every unit's prefix.

    Returns
    -------
    written : dict
        Unit -> ``(header, source)`` paths, in the order of ``model.units_``.

    Raises
    ------
    TypeError
        If ``model`` is not a fitted UnitwiseRegressor, or a unit's model is not exportable.
    ValueError
        As for :func:`to_c`, or when two unit labels give the same identifier.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> import pandas as pd
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn_ifog import ThermalFeatures, UnitwiseRegressor
    >>> from sklearn_ifog.export import to_c_units
    >>> time = np.tile(np.arange(30.0), 2)
    >>> X = pd.DataFrame({"unit": ["A-1"] * 30 + ["B-2"] * 30, "time": time})
    >>> X["temperature"] = 20 + X["time"] ** 2 / 100
    >>> pipe = make_pipeline(ThermalFeatures(time="time"), LinearRegression())
    >>> model = UnitwiseRegressor(pipe, pooling="none").fit(X, X["temperature"] / 100)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     written = to_c_units(model, directory)
    ...     print({unit: header.name for unit, (header, _) in written.items()})
    {'A-1': 'ifog_unit_A_1.h', 'B-2': 'ifog_unit_B_2.h'}
    """
    from sklearn.utils.validation import check_is_fitted

    if not hasattr(model, "unit_models"):  # a model per unit
        raise TypeError(
            f"to_c_units exports a UnitwiseRegressor, got {type(model).__name__}; use to_c."
        )
    check_is_fitted(model)
    if not isinstance(prefix, str) or not _IDENTIFIER.match(prefix):
        raise ValueError(
            f"prefix must be a C identifier (a letter, then letters, digits or '_'), "
            f"got {prefix!r}."
        )
    prefixes = {}
    for unit in model.estimators_:
        name = f"{prefix}_unit_{_unit_identifier(unit)}"
        if name in prefixes.values():
            other = next(key for key, value in prefixes.items() if value == name)
            raise ValueError(
                f"units {other!r} and {unit!r} give the same C identifier {name!r}; rename one."
            )
        prefixes[unit] = name
    if precision not in ("double", "float"):
        raise ValueError(f"precision must be 'double' or 'float', got {precision!r}.")
    rendered = {}
    for unit, name in prefixes.items():
        try:
            spec = describe_pipeline(model.estimators_[unit])
        except (TypeError, ValueError) as error:
            raise type(error)(f"unit {unit!r}: {error}") from error
        rendered[unit] = (name, *render_c(spec, prefix=name, precision=precision))
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    files, written = {}, {}
    for unit, (name, header_text, source_text) in rendered.items():
        header, source = directory / f"{name}.h", directory / f"{name}.c"
        files[header], files[source] = header_text, source_text
        written[unit] = (header, source)
    write_text_files(files)
    return written
