"""A fitted compensation Pipeline described as plain parameters (the export schema).

``describe_pipeline`` turns ``ThermalFeatures → [row-wise transformers] → regressor`` into a
JSON-able dict; the C generator renders that dict and ``to_json`` writes it, so both exports
carry exactly the same numbers. The functions live in :mod:`sklearn_ifog._description`
(beside the output layer, :mod:`sklearn_ifog._output_layer`, below ``export``: the compiled
streaming path reads the same description) and are re-exported here with the schema.
Every float goes through ``float(...)`` of a float64, so ``json`` (which writes ``repr``)
and the C generator (``repr`` / ``%.9g``) keep round-trip precision.

Schema (version 6; version 5 ended "clip" on the temperature clamp, where the row could
stay outside the widened box; version 4 had the margin where version 5 has the calibrated
threshold, and no boost; version 3 no rate term in the domain (``"rate_columns"``...),
version 2 no ``"domain"``, version 1 an EMA ``smoothing`` in samples and its ``alpha``)::

    {
      "schema": "sklearn-ifog-pipeline",
      "schema_version": 6,
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
      "outside": "blend" | "clip" | "none",  # the policy outside the domain
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
prediction ``y``; rows outside follow ``outside``:

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

from sklearn_ifog._description import (
    SCHEMA_NAME,
    SCHEMA_VERSION,
    TRANSFORMER_CONVERTERS,
    describe_domain,
    describe_features,
    describe_pipeline,
)
from sklearn_ifog._output_layer import LINEAR_REGRESSORS

__all__ = [
    "LINEAR_REGRESSORS",
    "SCHEMA_NAME",
    "SCHEMA_VERSION",
    "TRANSFORMER_CONVERTERS",
    "describe_domain",
    "describe_features",
    "describe_pipeline",
]
