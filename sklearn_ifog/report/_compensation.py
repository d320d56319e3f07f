"""The compensation report a gyro engineer hands on after a thermal test.

:func:`compensation_report` measures a compensation run by run and writes its report with
figures; :func:`per_unit_table` is its per-unit table for a production lot.
"""

from pathlib import Path

import numpy as np

from sklearn_ifog import _table
from sklearn_ifog._per_run import ALL_RUNS, compensation_arrays
from sklearn_ifog.report._columns import RunColumns
from sklearn_ifog.report._document import Report
from sklearn_ifog.report._scale_factor import add_scale_factor, wants_scale_factor
from sklearn_ifog.report._sections import (
    _add_allan_deviation,
    _add_calibration,
    _add_compensation_figures,
    _add_model,
    _add_summary,
    _add_transition,
)
from sklearn_ifog.report._status import calibration_status, per_run_calibration

__all__ = ["compensation_report", "per_unit_table"]

DEFAULT_TITLE = "Thermal compensation report"


def compensation_report(
    directory,
    columns,
    *,
    title=None,
    report=None,
    heading="Compensation",
    data_name=None,
    model_metadata=None,
    max_runs=4,
    bias_window=100.0,
    interval=None,
    model=None,
    X=None,
    scale_factor=None,
    temperature_bins=10,
):
    """Measure a compensation and write its report (Markdown and HTML) with figures.

    For every run, the table of :func:`~sklearn_ifog.metrics.per_run_metrics`: the MSD of
    the raw and of the compensated rate from the reference (the reference paper's Eq. 24),
    their ratio and the bias stability before and after (``bias_window``-second averages,
    IEEE Std 952 practice; n/a where the run is too short or not uniformly sampled); the raw
    and compensated rate with the temperature for the first ``max_runs`` runs; and the Allan
    deviation of the error (output minus reference) before and after compensation, for the
    longest run. Given the ``model`` and the rows ``X`` it predicted the drift from, and
    when that model knows its calibration domain (a
    :class:`~sklearn_ifog.CompensationPipeline`, or a meta-estimator around them), a
    "Calibration domain" section says whether rows lay outside it and what the model's
    ``uncalibrated`` policy did there, with a table per run (:func:`per_run_calibration`), and
    the figures shade the stretches outside; a model whose feature step searched for a
    coating's transition (``ThermalFeatures(transition=...)``) gets a "Transition search"
    table of what it found and whether it was kept. For rate-table data (a model fitted with
    ``input_rate``, or ``scale_factor=True``), a "Scale factor" section: the scale-factor
    error in ppm per temperature bin before and after compensation, its peak-to-peak over
    temperature, the linearity and asymmetry, the residual at each input rate and a figure
    of the ppm against temperature; the figures of the output then draw its error (output
    minus input rate), since the input rates dwarf it.

    Parameters
    ----------
    directory : str or path-like
        Existing directory for the report and its PNG figures.
    columns : RunColumns
        The run's columns: gyro output, predicted drift, reference and coil temperature of
        every sample, and optionally its time, run and unit (with ``unit``, a per-unit
        table, MSD before and after, their ratio, runs and samples, is added before the
        per-run one).
    title : str, default=None
        Title of the new report; None: ``"Thermal compensation report"``. Only for a new
        report: with ``report`` given, that report keeps its own title and giving ``title``
        too is an error.
    report : Report, default=None
        A report to append the sections to (e.g. with sections of your own before); None
        starts a new one, titled ``title``.
    heading : str, default="Compensation"
        Heading of the section this function adds.
    data_name : str, default=None
        Name of the data set, shown in the summary.
    model_metadata : dict, default=None
        Metadata of the model (from :func:`~sklearn_ifog.persistence.load_model`), shown
        in a "Model" section.
    max_runs : int, default=4
        Number of runs drawn (the first ones, in order of appearance).
    bias_window : float, default=100.0
        Averaging window of the bias stability, seconds.
    interval : array-like of shape (n_samples, 2), default=None
        Lower and upper bound of the drift (deg/h), e.g. from
        :meth:`~sklearn_ifog.ConformalRegressor.predict_interval`. The table then gains the
        columns ``coverage`` (fraction of the run's samples whose measured drift,
        ``rate - reference``, lies inside) and ``width`` (mean width, deg/h), and the
        figures shade the band.
    model : estimator, default=None
        The fitted drift model that predicted ``columns.drift`` (with ``X``): its
        calibration domain is read by :func:`calibration_status`. A model without one gets
        a line saying so.
    X : array-like or DataFrame of shape (n_samples, n_columns), default=None
        The rows ``model`` predicted the drift from, in the order of ``columns``.
    scale_factor : bool, default=None
        Whether to add the "Scale factor" section, with ``columns.reference`` as the input
        rate (deg/h) of every row; None: when ``model`` (or the model it wraps) was fitted
        with ``input_rate``.
    temperature_bins : int or array-like of float, default=10
        The scale-factor section's temperature bins: a number of equal bins over the rows'
        range, or their edges, deg C (:func:`~sklearn_ifog.metrics.scale_factor_error`).

    Returns
    -------
    result : sklearn.utils.Bunch
        ``report`` (the :class:`Report`), ``table`` (DataFrame indexed by run, with a last
        row ``"(all runs)"`` for all rows together; without ``run``, that row only),
        ``unit_table`` (DataFrame indexed by unit, or None without ``unit``), ``figures``
        (list of Path), ``paths`` (``{"markdown": Path, "html": Path}``), and with a
        model that has a calibration domain ``calibration`` (the per-row
        :func:`calibration_status`) and ``calibration_table``
        (:func:`per_run_calibration`, indexed like ``table``); both None otherwise; and
        ``scale_factor``: with the scale-factor section, a Bunch of its ``table`` (ppm per
        run and temperature bin, ``ppm_before`` and ``ppm_after``; the ``"(all runs)"`` rows
        pool the runs), ``summary`` (peak-to-peak, linearity and asymmetry in ppm, before
        and after) and ``by_input_rate`` (the error's root mean square at each input rate,
        deg/h, before and after), None without.

    Raises
    ------
    TypeError
        If ``columns`` is not a :class:`RunColumns`.
    ValueError
        If ``title`` and ``report`` are both given, ``interval`` does not have one
        (lower, upper) pair per sample, ``model`` is given without ``X`` (or the
        reverse), ``X`` does not have one row per sample, ``scale_factor`` is not None, True
        or False, or ``temperature_bins`` is bad. Nothing is written then.

    See Also
    --------
    RunColumns : The record of the run's columns, checked when it is made.
    sklearn_ifog.metrics.per_run_metrics : The per-run table alone.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from sklearn_ifog.report import RunColumns, compensation_report
    >>> time = np.arange(0.0, 3600.0, 1.0)
    >>> temperature = 20.0 + 10.0 * np.sin(time / 600.0)
    >>> drift = 0.02 * (temperature - 20.0)
    >>> noise = np.random.default_rng(0).normal(0.0, 0.001, time.size)
    >>> rate = 7.5 + drift + noise
    >>> columns = RunColumns(
    ...     rate=rate, drift=drift, reference=7.5, temperature=temperature, time=time
    ... )
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     result = compensation_report(directory, columns, title="Gyro 7, one run")
    ...     sorted(path.name for path in result.paths.values())
    ['report.html', 'report.md']
    >>> result.report.title
    'Gyro 7, one run'
    >>> bool(result.table.loc["(all runs)", "reduction"] > 100)
    True

    With the model and the rows it predicted from, the report says where the model was
    outside its calibration (here a cold test, the model calibrated between 10 and 40 °C):

    >>> import warnings
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import OutsideCalibrationWarning, make_compensation_pipeline
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> def campaign(temperature_range, seed):
    ...     return make_thermal_campaign(
    ...         n_units=1,
    ...         n_runs=2,
    ...         azimuths=[0.0],
    ...         sampling_period=120.0,
    ...         temperature_range=temperature_range,
    ...         random_state=seed,
    ...     )
    >>> warm, cold = campaign((10.0, 40.0), 0), campaign((-20.0, 5.0), 1)
    >>> model = make_compensation_pipeline(LinearRegression()).fit(warm.data, warm.target)
    >>> frame = cold.frame
    >>> with warnings.catch_warnings(), tempfile.TemporaryDirectory() as directory:
    ...     warnings.simplefilter("ignore", OutsideCalibrationWarning)  # the report says it
    ...     columns = RunColumns(
    ...         rate=frame["rate"],
    ...         drift=model.predict(cold.data),
    ...         reference=frame["reference"],
    ...         temperature=frame["temperature"],
    ...         time=frame["time"],
    ...         run=frame["run"],
    ...     )
    ...     result = compensation_report(directory, columns, model=model, X=cold.data)
    >>> result.calibration_table["outside_share"].tolist()
    [1.0, 1.0, 1.0]

    Rate-table data: the reference steps through input rates and the gyro's scale-factor
    error moves 2 ppm/°C; a model fitted with ``input_rate`` gets the "Scale factor" section
    by itself, here it is asked for (``drift`` the true one, so the noise is left after):

    >>> omega = np.tile([0.0, 3.6e5, -3.6e5, 1.08e6], time.size // 4)
    >>> drift = 0.3 + omega * 2e-6 * (temperature - 20.0)
    >>> table_columns = RunColumns(
    ...     rate=omega + drift + noise,
    ...     drift=drift,
    ...     reference=omega,
    ...     temperature=temperature,
    ...     time=time,
    ... )
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     result = compensation_report(directory, table_columns, scale_factor=True)
    >>> peak_to_peak = result.scale_factor.summary.loc["peak_to_peak_ppm"]
    >>> round(peak_to_peak["before"]), bool(peak_to_peak["after"] < 0.01)
    (37, True)

    A report of your own keeps its title; ``title`` is for a new one only:

    >>> with tempfile.TemporaryDirectory() as directory:
    ...     compensation_report(directory, columns, title="Lot 3", report=Report("Lot 3"))
    Traceback (most recent call last):
    ...
    ValueError: title and report were both given: report keeps its own title ('Lot 3'); ...
    """
    from sklearn.utils import Bunch

    from sklearn_ifog.metrics import per_run_metrics

    if not isinstance(columns, RunColumns):
        raise TypeError(
            "columns must be a RunColumns (rate, drift, reference, temperature and optionally "
            f"time, run, unit), got {type(columns).__name__}."
        )
    if title is not None and report is not None:
        raise ValueError(
            f"title and report were both given: report keeps its own title ({report.title!r}); "
            "give title only to start a new report, or make the report with Report(title)."
        )
    directory = Path(directory)
    with_scale_factor = wants_scale_factor(scale_factor, model)
    run = columns.run
    table = per_run_metrics(
        rate=columns.rate,
        drift=columns.drift,
        reference=columns.reference,
        temperature=columns.temperature,
        time=columns.time,
        run=run,
        bias_window=bias_window,
    )
    rate, drift, reference, temperature, time_values = compensation_arrays(
        columns.rate, columns.drift, columns.reference, columns.temperature, columns.time
    )
    n_samples = rate.shape[0]
    data = Bunch(
        rate=rate,
        compensated=rate - drift,
        reference=reference,
        temperature=temperature,
        time=time_values,
        # {run label: row positions in time order}, in order of first appearance.
        segments={
            ALL_RUNS if label is None else label: rows
            for label, rows in _table.run_segments(run, n_samples)
        },
        has_runs=run is not None,
        interval=None,
        outside=None,
        errors=with_scale_factor,  # the figures draw output minus input rate
    )
    if interval is not None:
        _add_interval(table, data, interval, run)
    status, calibration_table = _calibration(model, X, n_samples, run)
    data.outside = None if status is None else status.outside
    unit_table = (
        None
        if columns.unit is None
        else per_unit_table(rate, drift, columns.reference, columns.unit, run)
    )
    if report is None:
        report = Report(DEFAULT_TITLE if title is None else title)
    no_time = columns.time is None
    _add_summary(report, heading, data, table, data_name, bias_window, no_time, unit_table)
    if model is not None:
        _add_calibration(report, data, status, calibration_table)
        _add_transition(report, model)
    scale = None
    if with_scale_factor:
        scale = add_scale_factor(report, directory, data, run, temperature_bins)
    figures = [] if scale is None else scale.pop("figures")
    figures += _add_compensation_figures(report, directory, data, max_runs)
    figures += _add_allan_deviation(report, directory, data)
    if model_metadata:
        _add_model(report, model_metadata)
    paths = report.write(directory)
    return Bunch(
        report=report,
        table=table,
        unit_table=unit_table,
        figures=figures,
        paths=paths,
        calibration=status,
        calibration_table=calibration_table,
        scale_factor=scale,
    )


def _add_interval(table, data, interval, run):
    """The drift interval of every row into ``data``, and its coverage and mean width per run
    (and over all runs, with ``run``) as the columns ``coverage`` and ``width`` of
    ``table``."""
    from sklearn_ifog.metrics import interval_coverage, mean_interval_width

    n_samples = data.rate.shape[0]
    interval = np.asarray(interval, dtype=float)
    if interval.shape != (n_samples, 2):
        raise ValueError(
            f"interval has shape {interval.shape}; expected ({n_samples}, 2), the "
            "lower and upper drift bound of every sample."
        )
    data.interval = interval
    measured = data.rate - data.reference
    coverage, width = {}, {}
    for label, rows in data.segments.items():
        coverage[label] = interval_coverage(measured[rows], interval[rows])
        width[label] = mean_interval_width(interval[rows])
    if run is not None:
        coverage[ALL_RUNS] = interval_coverage(measured, interval)
        width[ALL_RUNS] = mean_interval_width(interval)
    table["coverage"] = table.index.map(coverage)
    table["width"] = table.index.map(width)


def _calibration(model, X, n_samples, run):
    """``(calibration_status(model, X), per_run_calibration(...))``, both None without a
    model or for a model without a calibration domain; checks that model and X come
    together and that X has ``n_samples`` rows."""
    if (model is None) != (X is None):
        given, missing = ("model", "X") if X is None else ("X", "model")
        raise ValueError(
            f"{given} was given without {missing}: the calibration domain needs both, the "
            "model and the rows X it predicted drift from (or neither)."
        )
    if model is None:
        return None, None
    status = calibration_status(model, X)
    if status is None:
        return None, None
    if status.distance.shape[0] != n_samples:
        raise ValueError(
            f"X has {status.distance.shape[0]} rows, rate has {n_samples}; give "
            "the rows the model predicted drift from, one per sample."
        )
    return status, per_run_calibration(status, run)


def per_unit_table(rate, drift, reference, unit, run=None):
    """MSD before and after compensation for every unit of a lot.

    Parameters
    ----------
    rate, drift, reference : array-like of shape (n_samples,)
        Gyro output, predicted drift and true input rate, deg/h (``reference`` may be a
        scalar).
    unit : array-like of shape (n_samples,)
        Unit label of every row.
    run : array-like of shape (n_samples,), default=None
        Run label of every row, to count each unit's runs (None: one per unit).

    Returns
    -------
    table : pandas.DataFrame
        Indexed by unit (sorted): ``msd_before``, ``msd_after``, ``reduction``, ``n_runs``,
        ``n_samples``.

    Examples
    --------
    >>> from sklearn_ifog.report import per_unit_table
    >>> table = per_unit_table([1.0, 1.2, 2.0], [0.0, 0.2, 1.0], 1.0, ["a", "a", "b"])
    >>> table[["msd_before", "msd_after", "n_samples"]].round(3)
          msd_before  msd_after  n_samples
    unit
    a           0.02        0.0          2
    b           1.00        0.0          1
    """
    import pandas as pd

    rate = np.asarray(rate, dtype=np.float64)
    error = rate - np.broadcast_to(np.asarray(reference, dtype=np.float64), rate.shape)
    compensated = error - np.asarray(drift, dtype=np.float64)
    unit = np.asarray(unit)
    frame = pd.DataFrame(
        {
            "unit": unit,
            "before": error**2,
            "after": compensated**2,
            "run": np.zeros(unit.shape[0]) if run is None else np.asarray(run),
        }
    )
    grouped = frame.groupby("unit", sort=True)
    table = pd.DataFrame(
        {
            "msd_before": grouped["before"].mean(),
            "msd_after": grouped["after"].mean(),
        }
    )
    table["reduction"] = table["msd_before"] / table["msd_after"]
    table["n_runs"] = grouped["run"].nunique()
    table["n_samples"] = grouped.size()
    return table
