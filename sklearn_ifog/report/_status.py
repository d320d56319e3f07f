"""Where the rows of a compensation lay with respect to the model's calibration domain.

:func:`calibration_status` measures every row with the model that predicts it (a
:class:`~sklearn_ifog.CompensationPipeline`, or a meta-estimator around them);
:func:`per_run_calibration` sums it up run by run. Read by the report's "Calibration domain"
section and by the command line (``sklearn-ifog compensate`` and ``report``).
"""

import numpy as np
from sklearn.exceptions import NotFittedError

from sklearn_ifog import _table
from sklearn_ifog._per_run import ALL_RUNS
from sklearn_ifog.domain import has_box, locate
from sklearn_ifog.policy import policy_for

__all__ = ["calibration_status", "per_run_calibration"]


def _domain_pipelines(model, X):
    """(pipeline, X of its rows, positions of those rows) for every model behind ``model``.

    The calibration protocol's ``calibrated_parts``: a CompensationPipeline is itself with
    every row, a UnitwiseRegressor gives each unit's model its rows, a ConformalRegressor
    its model fitted on every row. None for a model without it (another estimator, or a
    model saved before the domain existed).
    """
    parts_of = getattr(model, "calibrated_parts", None)
    if parts_of is None:
        return None
    try:
        return parts_of(X)
    except NotFittedError:  # no calibration domain (e.g. saved before it existed)
        return None


def calibration_status(model, X):
    """Where every row of ``X`` lies with respect to the calibration domain of ``model``.

    For a :class:`~sklearn_ifog.CompensationPipeline`, or a
    :class:`~sklearn_ifog.UnitwiseRegressor` or :class:`~sklearn_ifog.ConformalRegressor`
    around them (each row is then measured by the model that predicts it): the flag and
    the distance of :meth:`~sklearn_ifog.CompensationPipeline.outside_calibration` and
    :meth:`~sklearn_ifog.CompensationPipeline.calibration_distance`, how far the
    temperature lies beyond the calibrated range (:meth:`~sklearn_ifog.CalibrationDomain.
    excess` of the T feature, ``fallback_.column``), and whether the model's policy
    (``uncalibrated``) changed the row's prediction.

    Parameters
    ----------
    model : estimator
        A fitted drift model.
    X : array-like or DataFrame of shape (n_samples, n_columns)
        The rows the model predicts, in the layout of its ``fit``.

    Returns
    -------
    status : sklearn.utils.Bunch or None
        None when the model has no calibration domain (another estimator, or a model
        saved before the domain existed); else, one value per row:

        - ``outside``: bool, :meth:`~sklearn_ifog.CompensationPipeline.outside_calibration`;
        - ``distance``: float, :meth:`~sklearn_ifog.CompensationPipeline.calibration_distance`
          (decorrelated standard deviations, 0 inside the box);
        - ``temperature_excess``: float, degrees C below the coldest (negative) or above
          the warmest (positive) calibrated temperature, 0 inside that range; NaN for a
          model without a T feature, or whose domain is another novelty detector (it knows
          no calibrated ranges; so too the ranges and the rate's excess below);
        - ``temperature_min``, ``temperature_max``: float, the calibrated temperature
          range of the row's model (NaN without a T feature);
        - ``rate_excess``: float, how far the first sensor's rate dT lies below the slowest
          (negative) or above the fastest (positive) calibrated rate, in dT's unit (degC per
          minute by default), 0 inside that range; NaN for a model without a dT feature in
          its domain;
        - ``rate_min``, ``rate_max``: float, the calibrated rates of the row's model (NaN
          without a dT feature);
        - ``policy``: str, the ``uncalibrated`` policy of the row's model;
        - ``fallback``: str, ``"plane"`` (a line in T and the rate dT), ``"line"`` (a line
          in T) or ``"constant"`` (the calibration's mean drift), what ``"blend"`` falls
          back towards (:func:`~sklearn_ifog.fallback.fallback_name`);
        - ``adjusted``: bool, whether the policy changed the row's prediction from the
          regressor's own (:meth:`~sklearn_ifog.policy.UncalibratedPolicy.changed_rows`).

    Raises
    ------
    ValueError
        If X is not what the model reads (as its ``predict`` raises), or holds a unit a
        UnitwiseRegressor was not fitted on.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import make_compensation_pipeline
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> from sklearn_ifog.report import calibration_status
    >>> X, y = make_thermal_campaign(
    ...     n_units=1,
    ...     n_runs=2,
    ...     azimuths=[0.0],
    ...     sampling_period=120.0,
    ...     temperature_range=(10.0, 40.0),
    ...     random_state=0,
    ...     return_X_y=True,
    ... )
    >>> model = make_compensation_pipeline(LinearRegression()).fit(X, y)
    >>> cold = X.assign(temperature=X["temperature"] - 30.0)
    >>> status = calibration_status(model, cold)
    >>> bool(np.array_equal(status.outside, model.outside_calibration(cold)))
    True
    >>> coldest = X["temperature"].min()
    >>> bool(np.isclose(status.temperature_excess.min(), cold["temperature"].min() - coldest))
    True
    >>> calibration_status(LinearRegression().fit([[0.0], [1.0]], [0.0, 1.0]), [[2.0]]) is None
    True
    """
    from sklearn.utils import Bunch

    from sklearn_ifog.fallback import fallback_name

    X = _table.as_table(X)
    n_samples = X.shape[0]
    parts = _domain_pipelines(model, X)
    if parts is None:
        return None
    status = Bunch(
        outside=np.empty(n_samples, dtype=bool),
        distance=np.empty(n_samples),
        temperature_excess=np.full(n_samples, np.nan),
        temperature_min=np.full(n_samples, np.nan),
        temperature_max=np.full(n_samples, np.nan),
        rate_excess=np.full(n_samples, np.nan),
        rate_min=np.full(n_samples, np.nan),
        rate_max=np.full(n_samples, np.nan),
        policy=np.empty(n_samples, dtype=object),
        fallback=np.empty(n_samples, dtype=object),
        adjusted=np.empty(n_samples, dtype=bool),
    )
    for pipeline, X_part, rows in parts:
        # One pass through the feature step: the flag and the distance of
        # outside_calibration and calibration_distance, and the rows the policy changed
        # (asked of the policy object, without predicting again).
        domain = pipeline.domain_
        features = _table.as_float_rows(pipeline.steps[0][1].transform(X_part))
        where = locate(domain, features)
        status.outside[rows] = where.outside
        status.distance[rows] = where.distance
        status.policy[rows] = pipeline.uncalibrated
        policy = policy_for(pipeline.uncalibrated)
        status.adjusted[rows] = policy.changed_rows(features, where, domain)
        fallback = pipeline.fallback_
        status.fallback[rows] = fallback_name(fallback)
        column = fallback.column
        rates = list(getattr(domain, "rate_columns_", []))
        if (column is None and not rates) or not has_box(domain):
            continue  # another detector knows no calibrated ranges: NaN, as without T
        excess = domain.excess(features)
        if column is not None:
            status.temperature_excess[rows] = excess[:, column]
            status.temperature_min[rows] = domain.data_min_[column]
            status.temperature_max[rows] = domain.data_max_[column]
        if rates:
            status.rate_excess[rows] = excess[:, rates[0]]
            status.rate_min[rows] = domain.data_min_[rates[0]]
            status.rate_max[rows] = domain.data_max_[rates[0]]
    return status


def per_run_calibration(status, run=None):
    """Rows outside the calibration domain, run by run.

    Parameters
    ----------
    status : sklearn.utils.Bunch
        The per-row result of :func:`calibration_status`.
    run : array-like of shape (n_samples,), default=None
        Run label of every row; None means one run.

    Returns
    -------
    table : pandas.DataFrame
        Indexed by ``run`` (in order of first appearance; with ``run``, a last row
        ``"(all runs)"``; without, that row only), with columns ``samples``,
        ``rows_outside``, ``outside_share`` (their fraction), ``max_distance`` (the
        largest distance, decorrelated standard deviations), ``degC_below`` and
        ``degC_above`` (how far the temperature went below the coldest and above the
        warmest calibrated temperature, 0 if it never did; NaN for a model without a T
        feature), ``rate_below`` and ``rate_above`` (alike for the rate dT, in its unit,
        from the status's ``rate_excess``; NaN without it).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.utils import Bunch
    >>> from sklearn_ifog.report import per_run_calibration
    >>> status = Bunch(
    ...     distance=np.array([0.0, 0.5, 2.0, 0.0]),
    ...     outside=np.array([False, True, True, False]),
    ...     temperature_excess=np.array([0.0, -1.5, -4.0, 2.0]),
    ... )
    >>> table = per_run_calibration(status, run=["a", "a", "a", "b"])
    >>> table[["rows_outside", "outside_share", "max_distance", "degC_below", "degC_above"]]
                rows_outside  outside_share  max_distance  degC_below  degC_above
    run
    a                      2       0.666667           2.0         4.0         0.0
    b                      0       0.000000           0.0         0.0         2.0
    (all runs)             2       0.500000           2.0         4.0         2.0
    """
    import pandas as pd

    distance = np.asarray(status.distance, dtype=np.float64)
    outside = np.asarray(status.outside, dtype=bool)
    excess = np.asarray(status.temperature_excess, dtype=np.float64)
    n_samples = distance.shape[0]
    rate_excess = np.asarray(status.get("rate_excess", np.full(n_samples, np.nan)), dtype=float)
    if run is not None and len(run) != n_samples:
        raise ValueError(f"run has {len(run)} labels; the status has {n_samples} rows.")

    def measures(rows):
        return {
            "samples": int(rows.size),
            "rows_outside": int(outside[rows].sum()),
            "outside_share": float(outside[rows].mean()),
            "max_distance": float(distance[rows].max()),
            # NaN (no T feature) stays NaN: max of NaN is NaN
            "degC_below": float(np.maximum(-excess[rows], 0.0).max()),
            "degC_above": float(np.maximum(excess[rows], 0.0).max()),
            "rate_below": float(np.maximum(-rate_excess[rows], 0.0).max()),
            "rate_above": float(np.maximum(rate_excess[rows], 0.0).max()),
        }

    segments = _table.run_segments(run, n_samples)
    table = pd.DataFrame(
        [
            {"run": ALL_RUNS if label is None else label, **measures(rows)}
            for label, rows in segments
        ]
    ).set_index("run")
    if run is not None:
        table.loc[ALL_RUNS] = measures(np.arange(n_samples))
    return table.astype({"samples": int, "rows_outside": int})
