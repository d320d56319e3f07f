"""The scale factor in streaming: the input rate a gyro output stands for, sample by sample.

A :class:`~sklearn_ifog.pipeline.CompensationPipeline` fitted with ``input_rate`` predicts two
outputs, the bias ``b`` and the scale-factor error ``s`` (:mod:`sklearn_ifog.scale_factor`);
the compensator applies the calibration domain's policy to that pair exactly as the batch
path does, then :class:`InputRates` turns it into what the pipeline's ``compensate`` and
``predict`` return (the input rate ``(rate - b) / (1 + s ± a)``, or the drift
``b + Ω s + a |Ω|`` at a known input rate ``Ω``) and flags the input rates beyond the
calibrated ones, as ``outside_calibration`` does.
"""

from sklearn_ifog import _table, scale_factor
from sklearn_ifog.scale_factor import beyond_input_rates
from sklearn_ifog.streaming._inputs import number_array

__all__ = ["InputRates", "input_rates_of"]


class InputRates:
    """The scale factor's last step: ``[b, s]`` (policed) to the compensator's outputs.

    Parameters
    ----------
    column : str or int
        The pipeline's ``input_rate`` column.
    low, high : float
        The calibrated input rates, deg/h (``input_rate_range_``).
    asymmetry : float, default=0.0
        The pipeline's ``asymmetry_``: the drift is ``b + Ω s + a |Ω|``.
    """

    def __init__(self, column, low, high, asymmetry=0.0):
        self.column = column
        self.low = float(low)
        self.high = float(high)
        self.asymmetry = float(asymmetry)

    def beyond(self, omega):
        """:func:`beyond_input_rates` with the calibrated range."""
        return beyond_input_rates(omega, self.low, self.high)

    def row(self, pair, rate):
        """``(input rate, drift, beyond)`` of one sample from its ``[b, s]`` and output.

        The arithmetic of :func:`~sklearn_ifog.scale_factor.input_rate_estimate` on Python
        floats; the drift is ``rate - input rate`` (``b + s * input rate``).
        """
        if rate is None:
            raise self._needs_rate("step")
        excess = rate - float(pair[0])
        sign = (excess > 0) - (excess < 0)
        estimate = excess / (1.0 + float(pair[1]) + self.asymmetry * sign)
        return estimate, rate - estimate, bool(self.beyond(rate))

    def rows(self, pairs, rate, omega):
        """``(input rate or None, drift, beyond)`` of a chunk's rows.

        With ``rate`` (the gyro output, shape ``(n_samples,)``): the input rate it stands
        for, ``pipeline.compensate``'s, the drift ``rate - input rate``, and the output
        standing in for the input rate in the calibration check. Without it: the drift
        ``b + Ω s + a |Ω|`` at the rows' input rate ``omega`` (``pipeline.predict``'s), no
        input rate.
        """
        if rate is not None:
            estimate = scale_factor.input_rate_estimate(pairs, rate, self.asymmetry)
            return estimate, rate - estimate, self.beyond(rate)
        return None, scale_factor.drift_of(pairs, omega, self.asymmetry), self.beyond(omega)

    def table(self, X, rate, first_step):
        """``(X, rate, omega)`` of a chunk: ``X`` with the input-rate column (the output
        standing in where it is missing, as ``compensate`` does), ``rate`` as a float array
        of shape ``(n_samples,)`` (or None) and, without ``rate``, the column's input rates.

        Raises
        ------
        ValueError
            If ``rate`` is not one number per row, or without ``rate`` ``X`` has no
            input-rate column (naming it).
        """
        n_rows = _table.as_table(X).shape[0]
        if rate is None:
            try:
                return X, None, scale_factor.input_rate_of(X, self.column)
            except ValueError as error:
                raise ValueError(
                    f"update without rate gives the drift at the rows' input rate: {error} "
                    "Pass rate, the gyro output, to compensate it into the input rate."
                ) from None
        values = number_array(rate, "rate", "deg/h")
        if values.size != n_rows or values.ndim > 2 or values.shape[0] != n_rows:
            raise ValueError(
                f"rate must hold one gyro output per row of X ({n_rows}) for a scale-factor "
                f"model (input_rate={self.column!r}), got shape {values.shape}."
            )
        values = values.reshape(n_rows)
        names = getattr(first_step, "feature_names_in_", None)
        X = scale_factor.with_input_rate(X, self.column, values, names, first_step.n_features_in_)
        return X, values, None

    def _needs_rate(self, method):
        return ValueError(
            f"{method} needs rate, the gyro output: a model fitted with input_rate="
            f"{self.column!r} compensates an output into its input rate, and its drift "
            "b + input_rate * s depends on the input rate (update(X) takes rows holding the "
            "input-rate column to give the drift at it)."
        )


def input_rates_of(pipeline, adapt):
    """The :class:`InputRates` of a pipeline fitted with ``input_rate`` (None without one).

    Raises
    ------
    ValueError
        With ``adapt`` (the recalibration learns ``rate - reference`` as the drift, which
        with a scale factor is ``b + Ω s + a |Ω|``: not supported). A ConformalRegressor
        never holds a scale-factor model (its ``fit`` refuses one).
    """
    column = getattr(pipeline, "input_rate", None)
    if column is None:
        return None
    if adapt is not None:
        raise ValueError(
            f"adapt={adapt!r} is not available for a pipeline fitted with input_rate="
            f"{column!r}: the online recalibration learns rate - reference as a bias-only "
            "drift, where a scale-factor model's is b + input_rate * s. Use adapt=None (refit "
            "on new rate-table data to recalibrate)."
        )
    low, high = pipeline.input_rate_range_
    return InputRates(column, low, high, pipeline.asymmetry_)
