"""Drift targets and compensated rates.

A thermal test gives, per sample, the gyro output ``rate`` and the true input ``reference``
(Earth-rate component or turntable rate). Two training targets are in use:

- ``kind="reference"``: the measured drift ``rate - reference`` (needs the reference);
- ``kind="error_set"``: the reference paper's *error set* Q, the training output minus its own
  mean, per run. It needs no knowledge of the input rate (a constant per run cancels), at the
  price of leaving each run's mean bias to a separate calibration.

After fitting a drift model, the compensated rate is ``rate - model.predict(X)``
(:func:`compensate`).
"""

import numbers

import numpy as np
from sklearn.utils.validation import check_is_fitted

from sklearn_ifog import _table

__all__ = ["compensate", "drift_target"]

_TARGET_KINDS = ("reference", "error_set")


def drift_target(frame, *, rate="rate", reference="reference", kind="reference", run="run"):
    """Build the drift target of a thermal-test table.

    Parameters
    ----------
    frame : pandas.DataFrame or polars.DataFrame
        One row per sample, with the gyro output, the reference rate (for
        ``kind="reference"``) and the run id (for ``kind="error_set"``).
    rate : str, default="rate"
        Column of the gyro output (deg/h).
    reference : str or None, default="reference"
        Column of the true input rate (deg/h). Required for ``kind="reference"``. For
        ``kind="error_set"`` it is subtracted first when given, which only matters where the
        reference varies within a run (turntable steps); None uses the raw output.
    kind : {"reference", "error_set"}, default="reference"
        ``"reference"``: ``rate - reference``. ``"error_set"``: the reference paper's error
        set Q, the output (minus reference, if given) minus its mean over the run.
    run : str or None, default="run"
        Column of the run id, used by ``kind="error_set"``; None treats the whole frame as
        one run. Ignored by ``kind="reference"``.

    Returns
    -------
    target : pandas.Series or ndarray of shape (n_samples,)
        A Series on the frame's index (named ``"drift_measured"`` or ``"error_set"``) when
        ``frame`` is a pandas DataFrame, a float array otherwise. Rows keep their order.

    Raises
    ------
    ValueError
        If ``kind`` is unknown, a column is missing or holds missing values.
    TypeError
        If a column is not numeric.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn_ifog.compensation import drift_target
    >>> frame = pd.DataFrame(
    ...     {"run": [0, 0, 1, 1], "rate": [10.0, 12.0, 5.0, 9.0], "reference": 10.0}
    ... )
    >>> drift_target(frame).tolist()
    [0.0, 2.0, -5.0, -1.0]
    >>> drift_target(frame, kind="error_set").tolist()
    [-1.0, 1.0, -2.0, 2.0]
    """
    if kind not in _TARGET_KINDS:
        raise ValueError(f"kind must be one of {_TARGET_KINDS}, got {kind!r}.")
    if not hasattr(frame, "columns"):
        raise TypeError(f"frame must be a pandas or polars DataFrame, got {type(frame).__name__}.")
    if kind == "reference" and reference is None:
        raise ValueError(
            'kind="reference" needs the reference column; pass reference="<column>" or use '
            'kind="error_set".'
        )
    values = _table.numeric_column(frame, rate, param="rate", source="frame")
    if reference is not None:
        values = values - _table.numeric_column(
            frame, reference, param="reference", source="frame"
        )
    name = "drift_measured"
    if kind == "error_set":
        name = "error_set"
        if run is None:
            values = values - values.mean()
        else:
            labels = _table.label_column(
                frame,
                run,
                param="run",
                source="frame",
                hint="Pass run=None to treat the frame as one run.",
            )
            values = values - _table.per_run_mean(values, labels)
    index = getattr(frame, "index", None)
    if index is not None and type(frame).__module__.startswith("pandas"):
        import pandas as pd

        return pd.Series(values, index=index, name=name)
    return values


def compensate(model, X, rate):
    """Compensated rate: the gyro output minus the drift a fitted model predicts.

    Parameters
    ----------
    model : fitted regressor
        Usually a fitted :class:`~sklearn.pipeline.Pipeline` (ThermalFeatures →
        StandardScaler → regressor) trained on a drift target. It must predict one output.
    X : array-like or DataFrame of shape (n_samples, n_columns)
        The model's input, in the layout it was fitted on.
    rate : str, int or array-like of shape (n_samples,)
        The gyro output (deg/h), or the name (or integer position) of its column in ``X``.

    Returns
    -------
    compensated : pandas.Series or ndarray of shape (n_samples,)
        ``rate - model.predict(X)``; for a pipeline fitted with ``input_rate`` (a scale
        factor), the input rate of its ``compensate``. A Series named
        ``"rate_compensated"`` (on ``rate``'s index) when ``rate`` is a pandas Series or a
        column of a pandas DataFrame, a float array otherwise.

    Raises
    ------
    sklearn.exceptions.NotFittedError
        If ``model`` is not fitted.
    ValueError
        If ``rate`` does not name a column of ``X``, its length differs from ``X``'s, or the
        model predicts several outputs.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog.compensation import compensate
    >>> temperature = np.array([[0.0], [10.0], [20.0]])
    >>> drift = np.array([0.0, 1.0, 2.0])
    >>> model = LinearRegression().fit(temperature, drift)
    >>> compensate(model, temperature, rate=[15.0, 16.0, 17.0]).round(6).tolist()
    [15.0, 15.0, 15.0]
    """
    check_is_fitted(model)
    index = None
    if isinstance(rate, str | numbers.Integral):
        table = _table.as_table(X)
        index = X.index if _table.frame_kind(table) == "pandas" else None
        rate = _table.numeric_column(table, rate, param="rate", finite=False)
    n_samples = X.shape[0] if hasattr(X, "shape") else len(X)
    if len(rate) != n_samples:
        raise ValueError(f"rate has {len(rate)} values but X has {n_samples} rows.")
    if getattr(model, "input_rate", None) is not None and hasattr(model, "compensate"):
        # A scale-factor model: the input rate (rate - b) / (1 + s ± a), not rate - drift.
        compensated = model.compensate(X, np.asarray(rate, dtype=np.float64))
        return _named_like(rate, compensated, index)
    prediction = np.asarray(model.predict(X), dtype=np.float64)
    if prediction.ndim == 2 and prediction.shape[1] == 1:
        prediction = prediction[:, 0]
    if prediction.ndim != 1:
        raise ValueError(
            f"The model predicts {prediction.shape[1]} outputs; compensate needs a "
            "single-output drift model."
        )
    values = np.asarray(rate, dtype=np.float64)
    if values.ndim != 1:
        raise ValueError(f"rate must be 1-D, got shape {values.shape}.")
    return _named_like(rate, values - prediction, index)


def _named_like(rate, compensated, index):
    """``compensated`` as a Series named "rate_compensated" on ``rate``'s (or ``index``)
    pandas index, a float array otherwise."""
    if type(rate).__module__.startswith("pandas"):
        index = rate.index
    if index is not None:
        import pandas as pd

        return pd.Series(compensated, index=index, name="rate_compensated")
    return compensated
