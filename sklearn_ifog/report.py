"""Compensation reports in Markdown and HTML.

:class:`Report` collects headings, paragraphs, tables and figures and renders them as
Markdown (figures linked, for a repository or a wiki) and as one self-contained HTML file
(figures embedded, to hand on). :func:`compensation_report` builds the report a gyro engineer
hands on after a thermal test: MSD and bias stability before and after compensation per run,
the raw and compensated rate with the temperature, the Allan deviation before and after, and,
for a model that knows its calibration domain, which rows lay outside it and what the model
did there (:func:`calibration_status`, :func:`per_run_calibration`).
"""

import base64
import copy
import datetime
import html
import mimetypes
import numbers
import os
import warnings
from pathlib import Path

import numpy as np

from sklearn_ifog import _table
from sklearn_ifog._domain_words import number_text, policy_actions, rate_beyond_text
from sklearn_ifog._io import atomic_path
from sklearn_ifog._per_run import ALL_RUNS, compensation_arrays, sample_period

__all__ = [
    "Report",
    "calibration_status",
    "compensation_report",
    "per_run_calibration",
]


def _format_cell(value, float_format):
    if value is None:
        return ""
    if isinstance(value, bool | np.bool_):
        return str(bool(value))
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        value = float(value)
        if np.isnan(value):
            return "n/a"
        return float_format.format(value)
    return str(value)


def _table_rows(table, index):
    """(header, rows) of a DataFrame, a dict of columns or a list of row dicts."""
    if hasattr(table, "columns") and hasattr(table, "itertuples"):
        if index:
            names = [name for name in table.index.names if name is not None]
            table = table.reset_index() if names else table
        header = [str(column) for column in table.columns]
        rows = [list(row) for row in table.itertuples(index=False, name=None)]
        return header, rows
    if isinstance(table, dict):
        header = [str(column) for column in table]
        columns = [list(values) for values in table.values()]
        lengths = {len(values) for values in columns}
        if len(lengths) > 1:
            raise ValueError(f"Table columns differ in length: {sorted(lengths)}.")
        return header, [list(row) for row in zip(*columns, strict=True)]
    rows = list(table)
    header = []
    for row in rows:
        header.extend(key for key in row if key not in header)
    return [str(key) for key in header], [[row.get(key) for key in header] for row in rows]


class Report:
    """A document of headings, paragraphs, tables and figures, written as Markdown and HTML.

    Parameters
    ----------
    title : str
        The document's title.

    Examples
    --------
    >>> from sklearn_ifog.report import Report
    >>> report = Report("Thermal test")
    >>> report.add_paragraph("Two runs.")
    >>> report.add_table({"run": [0, 1], "msd": [1.234e-4, 5e-5]})
    >>> print(report.to_markdown())
    # Thermal test
    <BLANKLINE>
    Two runs.
    <BLANKLINE>
    | run | msd |
    | --- | --- |
    | 0 | 0.0001234 |
    | 1 | 5e-05 |
    <BLANKLINE>
    """

    def __init__(self, title):
        self.title = title
        self.blocks = []

    def add_heading(self, text, level=2):
        """Add a section heading.

        Parameters
        ----------
        text : str
            The heading.
        level : {2, 3, 4}, default=2
            Its level (the title is level 1).
        """
        if level not in (2, 3, 4):
            raise ValueError(f"level must be 2, 3 or 4, got {level!r}.")
        self.blocks.append(("heading", (str(text), level)))

    def add_paragraph(self, text):
        """Add a paragraph of plain text.

        Parameters
        ----------
        text : str
            The paragraph; HTML special characters are escaped in the HTML output.
        """
        self.blocks.append(("paragraph", str(text)))

    def add_table(self, table, *, caption=None, index=True, float_format="{:.4g}"):
        """Add a table.

        Parameters
        ----------
        table : pandas.DataFrame, dict of str to list, or list of dict
            The rows. A DataFrame's named index becomes its first column(s) when ``index``.
        caption : str, default=None
            Text under the table.
        index : bool, default=True
            Whether to show a DataFrame's named index.
        float_format : str, default="{:.4g}"
            Format of real numbers.
        """
        header, rows = _table_rows(table, index)
        cells = [[_format_cell(value, float_format) for value in row] for row in rows]
        self.blocks.append(("table", (header, cells, caption)))

    def add_figure(self, path, caption):
        """Add a figure already saved as a file.

        Parameters
        ----------
        path : str or path-like
            The image (PNG or SVG), usually in the directory the report is written to.
        caption : str
            Text under the figure (and its alternative text).
        """
        self.blocks.append(("figure", (Path(path), str(caption))))

    def to_markdown(self, directory=None):
        """Render the report as Markdown.

        Parameters
        ----------
        directory : str or path-like, default=None
            Directory the Markdown file will be in: figure links are made relative to it.
            None links the figures by the paths they were added with.

        Returns
        -------
        text : str
            The Markdown document.
        """
        lines = [f"# {self.title}", ""]
        for kind, content in self.blocks:
            if kind == "heading":
                text, level = content
                lines += ["#" * level + " " + text, ""]
            elif kind == "paragraph":
                lines += [content, ""]
            elif kind == "table":
                header, cells, caption = content

                def escape(cell):
                    return cell.replace("|", "\\|")

                lines.append("| " + " | ".join(map(escape, header)) + " |")
                lines.append("|" + "|".join(" --- " for _ in header) + "|")
                lines += ["| " + " | ".join(map(escape, row)) + " |" for row in cells]
                lines.append("")
                if caption:
                    lines += [f"*{caption}*", ""]
            else:
                path, caption = content
                link = _relative(path, directory)
                lines += [f"![{caption}]({link})", "", f"*{caption}*", ""]
        return "\n".join(lines)

    def to_html(self, directory=None, *, embed_figures=True):
        """Render the report as one HTML page.

        Parameters
        ----------
        directory : str or path-like, default=None
            Directory the HTML file will be in, for figure links (``embed_figures=False``).
        embed_figures : bool, default=True
            Embed the figures as base64 data URIs, so the page is one self-contained file;
            False links them instead.

        Returns
        -------
        text : str
            The HTML document.
        """
        parts = [
            "<!DOCTYPE html>",
            '<html lang="en"><head><meta charset="utf-8">',
            f"<title>{html.escape(self.title)}</title>",
            "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;padding:0 1em}"
            "table{border-collapse:collapse;margin:1em 0}"
            "td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}"
            "th{background:#eee}figure{margin:1.5em 0}img{max-width:100%}"
            "figcaption,.caption{color:#555;font-style:italic}</style>",
            "</head><body>",
            f"<h1>{html.escape(self.title)}</h1>",
        ]
        for kind, content in self.blocks:
            if kind == "heading":
                text, level = content
                parts.append(f"<h{level}>{html.escape(text)}</h{level}>")
            elif kind == "paragraph":
                parts.append(f"<p>{html.escape(content)}</p>")
            elif kind == "table":
                header, cells, caption = content
                parts.append("<table><thead><tr>")
                parts += [f"<th>{html.escape(cell)}</th>" for cell in header]
                parts.append("</tr></thead><tbody>")
                for row in cells:
                    parts.append(
                        "<tr>" + "".join(f"<td>{html.escape(cell)}</td>" for cell in row) + "</tr>"
                    )
                parts.append("</tbody></table>")
                if caption:
                    parts.append(f'<p class="caption">{html.escape(caption)}</p>')
            else:
                path, caption = content
                if embed_figures:
                    mime = mimetypes.guess_type(path.name)[0] or "image/png"
                    data = base64.b64encode(path.read_bytes()).decode("ascii")
                    source = f"data:{mime};base64,{data}"
                else:
                    source = html.escape(_relative(path, directory))
                parts.append(
                    f'<figure><img src="{source}" alt="{html.escape(caption)}">'
                    f"<figcaption>{html.escape(caption)}</figcaption></figure>"
                )
        parts.append("</body></html>")
        return "\n".join(parts) + "\n"

    def write(self, directory, name="report"):
        """Write ``name.md`` (figures linked) and ``name.html`` (figures embedded), atomically.

        Parameters
        ----------
        directory : str or path-like
            An existing directory (the figures are usually saved there too).
        name : str, default="report"
            File name stem.

        Returns
        -------
        paths : dict
            ``{"markdown": Path, "html": Path}``.
        """
        directory = Path(directory)
        paths = {"markdown": directory / f"{name}.md", "html": directory / f"{name}.html"}
        texts = {
            "markdown": self.to_markdown(directory),
            "html": self.to_html(directory, embed_figures=True),
        }
        for kind, path in paths.items():
            with atomic_path(path) as temporary:
                temporary.write_text(texts[kind], encoding="utf-8")
        return paths


def _relative(path, directory):
    if directory is None:
        return Path(path).as_posix()
    return Path(os.path.relpath(Path(path), Path(directory))).as_posix()


def compensation_report(
    directory,
    *,
    rate,
    drift,
    reference,
    temperature,
    time=None,
    run=None,
    unit=None,
    title="Thermal compensation report",
    model_metadata=None,
    data_name=None,
    max_runs=4,
    bias_window=100.0,
    report=None,
    heading="Compensation",
    interval=None,
    model=None,
    X=None,
):
    """Measure a compensation and write its report (Markdown and HTML) with figures.

    For every run, the table of :func:`~sklearn_ifog.metrics.per_run_metrics`: the MSD of
    the raw and of the compensated rate from the reference (the reference paper's Eq. 24),
    their ratio and the bias stability before and after (``bias_window``-second averages,
    IEEE Std 952 practice; n/a where the run is too short or not uniformly sampled); the raw
    and compensated rate with the temperature for the first ``max_runs`` runs; and the Allan
    deviation of the error (output minus reference) before and after compensation, for the
    longest run. Given the ``model`` and the rows ``X`` it predicted ``drift`` from, and
    when that model knows its calibration domain (a
    :class:`~sklearn_ifog.CompensationPipeline`, or a meta-estimator around them), a
    "Calibration domain" section says whether rows lay outside it and what the model's
    ``outside`` policy did there, with a table per run (:func:`per_run_calibration`), and
    the figures shade the stretches outside.

    Parameters
    ----------
    directory : str or path-like
        Existing directory for the report and its PNG figures.
    rate, drift, reference, temperature : array-like of shape (n_samples,)
        Gyro output (deg/h), predicted drift (deg/h), true input rate (deg/h), coil
        temperature (deg C).
    time : array-like of shape (n_samples,), default=None
        Time, seconds (None: the sample index, at an assumed 1 s period).
    run : array-like of shape (n_samples,), default=None
        Run label of each row; None means one run. Rows of a run are in time order.
    unit : array-like of shape (n_samples,), default=None
        Unit (gyro) label of each row, e.g. for a :class:`~sklearn_ifog.UnitwiseRegressor`:
        a per-unit table (MSD before and after, their ratio, runs and samples) is added
        before the per-run one.
    title : str, default="Thermal compensation report"
        Report title (ignored when ``report`` is given).
    model_metadata : dict, default=None
        Metadata of the model (from :func:`~sklearn_ifog.persistence.load_model`), shown
        in a "Model" section.
    data_name : str, default=None
        Name of the data set, shown in the summary.
    max_runs : int, default=4
        Number of runs drawn (the first ones, in order of appearance).
    bias_window : float, default=100.0
        Averaging window of the bias stability, seconds.
    report : Report, default=None
        A report to append the sections to (e.g. with sections of your own before); None
        starts a new one.
    heading : str, default="Compensation"
        Heading of the section this function adds.
    interval : array-like of shape (n_samples, 2), default=None
        Lower and upper bound of the drift (deg/h), e.g. from
        :meth:`~sklearn_ifog.ConformalRegressor.predict_interval`. The table then gains the
        columns ``coverage`` (fraction of the run's samples whose measured drift,
        ``rate - reference``, lies inside) and ``width`` (mean width, deg/h), and the
        figures shade the band.
    model : estimator, default=None
        The fitted drift model that predicted ``drift`` (with ``X``): its calibration
        domain is read by :func:`calibration_status`. A model without one gets a line
        saying so.
    X : array-like or DataFrame of shape (n_samples, n_columns), default=None
        The rows ``model`` predicted ``drift`` from, in the order of ``rate``.

    Returns
    -------
    result : sklearn.utils.Bunch
        ``report`` (the :class:`Report`), ``table`` (DataFrame indexed by run, with a last
        row ``"(all runs)"`` for all rows together; without ``run``, that row only),
        ``unit_table`` (DataFrame indexed by unit, or None without ``unit``), ``figures``
        (list of Path), ``paths`` (``{"markdown": Path, "html": Path}``), and with a
        model that has a calibration domain ``calibration`` (the per-row
        :func:`calibration_status`) and ``calibration_table``
        (:func:`per_run_calibration`, indexed like ``table``); both None otherwise.

    Raises
    ------
    ValueError
        If the arrays differ in length, ``model`` is given without ``X`` (or the
        reverse), or ``X`` does not have one row per sample.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from sklearn_ifog.report import compensation_report
    >>> time = np.arange(0.0, 3600.0, 1.0)
    >>> temperature = 20.0 + 10.0 * np.sin(time / 600.0)
    >>> drift = 0.02 * (temperature - 20.0)
    >>> noise = np.random.default_rng(0).normal(0.0, 0.001, time.size)
    >>> rate = 7.5 + drift + noise
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     result = compensation_report(
    ...         directory,
    ...         rate=rate,
    ...         drift=drift,
    ...         reference=7.5,
    ...         temperature=temperature,
    ...         time=time,
    ...     )
    ...     sorted(path.name for path in result.paths.values())
    ['report.html', 'report.md']
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
    ...     result = compensation_report(
    ...         directory,
    ...         rate=frame["rate"],
    ...         drift=model.predict(cold.data),
    ...         reference=frame["reference"],
    ...         temperature=frame["temperature"],
    ...         time=frame["time"],
    ...         run=frame["run"],
    ...         model=model,
    ...         X=cold.data,
    ...     )
    >>> result.calibration_table["outside_share"].tolist()
    [1.0, 1.0, 1.0]
    """
    from sklearn.utils import Bunch

    from sklearn_ifog.metrics import per_run_metrics

    directory = Path(directory)
    table = per_run_metrics(
        rate=rate,
        drift=drift,
        reference=reference,
        temperature=temperature,
        time=time,
        run=run,
        bias_window=bias_window,
    )
    rate, drift, reference, temperature, time_values = compensation_arrays(
        rate, drift, reference, temperature, time
    )
    data = Bunch(
        rate=rate,
        compensated=rate - drift,
        reference=reference,
        temperature=temperature,
        time=time_values,
        # {run label: row positions in time order}, in order of first appearance.
        segments={
            ALL_RUNS if label is None else label: rows
            for label, rows in _table.run_segments(run, rate.shape[0])
        },
        has_runs=run is not None,
        interval=None,
        outside=None,
    )
    if interval is not None:
        from sklearn_ifog.metrics import interval_coverage, mean_interval_width

        interval = np.asarray(interval, dtype=float)
        if interval.shape != (rate.shape[0], 2):
            raise ValueError(
                f"interval has shape {interval.shape}; expected ({rate.shape[0]}, 2), the "
                "lower and upper drift bound of every sample."
            )
        data.interval = interval
        measured = rate - reference
        coverage, width = {}, {}
        for label, rows in data.segments.items():
            coverage[label] = interval_coverage(measured[rows], interval[rows])
            width[label] = mean_interval_width(interval[rows])
        if run is not None:
            coverage[ALL_RUNS] = interval_coverage(measured, interval)
            width[ALL_RUNS] = mean_interval_width(interval)
        table["coverage"] = table.index.map(coverage)
        table["width"] = table.index.map(width)
    status = calibration_table = None
    if (model is None) != (X is None):
        given, missing = ("model", "X") if X is None else ("X", "model")
        raise ValueError(
            f"{given} was given without {missing}: the calibration domain needs both, the "
            "model and the rows X it predicted drift from (or neither)."
        )
    if model is not None:
        status = calibration_status(model, X)
        if status is not None:
            if status.distance.shape[0] != rate.shape[0]:
                raise ValueError(
                    f"X has {status.distance.shape[0]} rows, rate has {rate.shape[0]}; give "
                    "the rows the model predicted drift from, one per sample."
                )
            calibration_table = per_run_calibration(status, run)
    data.outside = None if status is None else status.outside
    unit_table = None if unit is None else per_unit_table(rate, drift, reference, unit, run)
    if report is None:
        report = Report(title)
    _add_summary(report, heading, data, table, data_name, bias_window, time is None, unit_table)
    if model is not None:
        _add_calibration(report, data, status, calibration_table)
    figures = _add_compensation_figures(report, directory, data, max_runs)
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
    )


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


# -- the calibration domain --------------------------------------------------------------------


def _domain_pipelines(model, X, rows):
    """(pipeline, X of its rows, positions of those rows) for every model behind ``model``.

    None when one of them has no calibration domain. Follows how each meta-estimator
    predicts: a ConformalRegressor with its estimator fitted on all rows; a
    UnitwiseRegressor with each unit's model on the unit's rows (without the unit column),
    or its lot model on all rows when every unit present uses it (``pooling="full"``).
    """
    from sklearn_ifog.conformal import ConformalRegressor
    from sklearn_ifog.pipeline import CompensationPipeline
    from sklearn_ifog.unitwise import UnitwiseRegressor

    if isinstance(model, CompensationPipeline):
        return [(model, X, rows)] if hasattr(model, "domain_") else None
    if isinstance(model, ConformalRegressor) and hasattr(model, "estimator_"):
        return _domain_pipelines(model.estimator_, X, rows)
    if not (isinstance(model, UnitwiseRegressor) and hasattr(model, "estimators_")):
        return None
    parts = []
    for unit_model, X_part, index in model.unit_models(X):
        found = _domain_pipelines(unit_model, X_part, rows[index])
        if found is None:
            return None
        parts += found
    return parts


def _adjusted_rows(pipeline, X):
    """Rows whose prediction the ``outside`` policy changed from the regressor's own."""
    if pipeline.outside == "none":
        return np.zeros(_table.as_table(X).shape[0], dtype=bool)
    free = copy.copy(pipeline).set_params(outside="none")  # the fitted steps are shared
    with_policy = np.asarray(pipeline.predict(X), dtype=np.float64)
    without = np.asarray(free.predict(X), dtype=np.float64)
    changed = with_policy != without
    return changed.reshape(changed.shape[0], -1).any(axis=1)


def calibration_status(model, X):
    """Where every row of ``X`` lies with respect to the calibration domain of ``model``.

    For a :class:`~sklearn_ifog.CompensationPipeline`, or a
    :class:`~sklearn_ifog.UnitwiseRegressor` or :class:`~sklearn_ifog.ConformalRegressor`
    around them (each row is then measured by the model that predicts it): the flag and
    the distance of :meth:`~sklearn_ifog.CompensationPipeline.outside_calibration` and
    :meth:`~sklearn_ifog.CompensationPipeline.calibration_distance`, how far the
    temperature lies beyond the calibrated range (:meth:`~sklearn_ifog.CalibrationDomain.
    excess` of the T feature, ``fallback_.column``), and whether the model's ``outside``
    policy changed the row's prediction.

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
          model without a T feature;
        - ``temperature_min``, ``temperature_max``: float, the calibrated temperature
          range of the row's model (NaN without a T feature);
        - ``rate_excess``: float, how far the first sensor's rate dT lies below the slowest
          (negative) or above the fastest (positive) calibrated rate, in dT's unit (degC per
          minute by default), 0 inside that range; NaN for a model without a dT feature in
          its domain;
        - ``rate_min``, ``rate_max``: float, the calibrated rates of the row's model (NaN
          without a dT feature);
        - ``policy``: str, the ``outside`` policy of the row's model;
        - ``fallback``: str, ``"plane"`` (a line in T and the rate dT), ``"line"`` (a line
          in T) or ``"constant"`` (the calibration's mean drift), what ``"blend"`` falls
          back towards (:func:`~sklearn_ifog.fallback.fallback_name`);
        - ``adjusted``: bool, whether the policy changed the row's prediction from the
          regressor's own (the model predicted again with ``outside="none"``).

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

    from sklearn_ifog.domain import OutsideCalibrationWarning
    from sklearn_ifog.fallback import fallback_name

    X = _table.as_table(X)
    n_samples = X.shape[0]
    parts = _domain_pipelines(model, X, np.arange(n_samples))
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
        status.outside[rows] = pipeline.outside_calibration(X_part)
        status.distance[rows] = pipeline.calibration_distance(X_part)
        status.policy[rows] = pipeline.outside
        fallback = pipeline.fallback_
        status.fallback[rows] = fallback_name(fallback)
        with warnings.catch_warnings():
            # the caller was warned when it predicted; this only measures what changed
            warnings.simplefilter("ignore", OutsideCalibrationWarning)
            status.adjusted[rows] = _adjusted_rows(pipeline, X_part)
        column = fallback.column
        rates = list(getattr(pipeline.domain_, "rate_columns_", []))
        if column is None and not rates:
            continue
        domain = pipeline.domain_
        features = _table.as_float_rows(pipeline.steps[0][1].transform(X_part))
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


# -- the sections of compensation_report -----------------------------------------------------


def _add_summary(report, heading, data, table, data_name, bias_window, no_time, unit_table=None):
    """The heading, what was measured, the overall MSD and the per-run table."""
    from sklearn_ifog.metrics import mean_squared_deviation

    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    report.add_heading(heading)
    source = f" of {data_name}" if data_name else ""
    report.add_paragraph(
        f"{data.rate.shape[0]} samples{source} in {len(data.segments)} run(s), compensated "
        f"with the model below (report made {stamp}). MSD is the mean squared deviation of "
        "the output from the reference rate, (deg/h)^2 (the reference paper's Eq. 24); the "
        f"bias stability is the standard deviation of {bias_window:g} s averages of the "
        "error, deg/h."
    )
    if no_time:
        report.add_paragraph(
            "No time was given: samples are numbered, and durations, bias stability and the "
            "Allan deviation assume 1 s between samples."
        )
    overall_before = float(mean_squared_deviation(data.reference, data.rate))
    overall_after = float(mean_squared_deviation(data.reference, data.compensated))
    report.add_paragraph(
        f"Overall MSD: {overall_before:.3g} before, {overall_after:.3g} after compensation "
        f"(reduction {table.loc[ALL_RUNS, 'reduction']:.3g}x)."
    )
    if unit_table is not None:
        report.add_table(
            unit_table, caption="Per-unit MSD before and after compensation, (deg/h)^2."
        )
    report.add_table(table, caption="Per-run MSD and bias stability, before and after.")


def _temperature_clause(table, status):
    """How far the temperature (and its rate) went beyond the calibrated ranges (all runs),
    as a clause."""
    below, above = table.loc[ALL_RUNS, ["degC_below", "degC_above"]]
    if np.isnan(below):  # a model without a temperature feature
        return ""
    rates = _rate_clause(table, status)
    beyond = []
    if below > 0:
        beyond.append(f"down to {below:.3g} °C below the coldest")
    if above > 0:
        beyond.append(f"up to {above:.3g} °C above the warmest")
    if not beyond:
        if rates:
            return " The temperature itself stayed within the calibrated range." + rates
        return (
            " The temperature itself stayed within the calibrated range: the rates or the "
            "thermal states (lags), or their combination with the temperature, are what the "
            "calibration never saw."
        )
    return f" The coil temperature went {' and '.join(beyond)} calibrated temperature." + rates


def _rate_clause(table, status):
    """How far the rate dT went beyond the calibrated rates (all runs), as a clause ("" when
    it never did beyond round-off, or without a rate)."""
    below, above = table.loc[ALL_RUNS, ["rate_below", "rate_above"]]
    low, high = status.get("rate_min"), status.get("rate_max")
    if low is None or np.isnan(low).all():  # a model without a rate dT
        return ""
    beyond = rate_beyond_text(below, above, np.nanmin(low), np.nanmax(high))
    if not beyond:
        return ""
    return (
        f" Its rate dT went {beyond} calibrated rate (in dT's unit; a heating-only "
        "calibration used while cooling lies here)."
    )


def _add_calibration(report, data, status, table):
    """Whether rows lay outside the model's calibration domain, and what the model did."""
    report.add_heading("Calibration domain", level=3)
    if status is None:
        report.add_paragraph(
            "The model carries no calibration domain (it is not a compensation pipeline, or "
            "was saved before the domain existed): rows outside its calibration cannot be "
            "flagged."
        )
        return
    ranges = np.unique(np.column_stack([status.temperature_min, status.temperature_max]), axis=0)
    # one model's (or every unit's same) calibrated temperatures, said in the text
    calibrated = inside_range = ""
    if ranges.shape[0] == 1 and not np.isnan(ranges[0, 0]):
        calibrated = f"; its temperatures from {ranges[0, 0]:.4g} to {ranges[0, 1]:.4g} °C"
        inside_range = f" (calibrated from {ranges[0, 0]:.4g} to {ranges[0, 1]:.4g} °C)"
    n_samples, n_outside = status.outside.size, int(status.outside.sum())
    if n_outside == 0:
        report.add_paragraph(
            f"All {n_samples} rows lie inside the model's calibration domain{inside_range}: "
            "every prediction is the model's own."
        )
        return
    runs_outside = sum(bool(status.outside[rows].any()) for rows in data.segments.values())
    report.add_paragraph(
        f"{n_outside} of {n_samples} rows ({n_outside / n_samples:.1%}), in "
        f"{runs_outside} of {len(data.segments)} run(s), lie outside the model's calibration "
        f"domain (the temperatures, rates and thermal states it was calibrated on"
        f"{calibrated}), up to {number_text(table.loc[ALL_RUNS, 'max_distance'])} decorrelated "
        f"standard deviations out.{_temperature_clause(table, status)} There, "
        f"{'; '.join(policy_actions(status))}. The figures shade these stretches: their "
        "compensation is an extrapolation, not a calibrated one; calibrate over the "
        "conditions these runs reach to trust it."
    )
    report.add_table(
        table,
        caption="Rows outside the calibration domain per run: their share, the largest "
        "distance from the calibrated box (decorrelated standard deviations; a row is "
        "outside beyond the model's margin, or with its temperature beyond the calibrated "
        "range) and how far the temperature went below the coldest and above the warmest "
        "calibrated temperature, °C.",
    )


def _add_compensation_figures(report, directory, data, max_runs):
    """Raw and compensated output of the first ``max_runs`` runs; the figures' paths."""
    from sklearn_ifog.plotting import plot_compensation, save_figure

    figures = []
    labels = list(data.segments)
    shown = labels[:max_runs]
    report.add_heading("Raw and compensated output", level=3)
    if len(shown) < len(labels):
        report.add_paragraph(f"The first {len(shown)} of {len(labels)} runs are drawn.")
    for index, label in enumerate(shown):
        rows_of_run = data.segments[label]
        outside = None if data.outside is None else data.outside[rows_of_run]
        ax, _ = plot_compensation(
            data.time[rows_of_run] - data.time[rows_of_run][0],
            data.rate[rows_of_run],
            data.compensated[rows_of_run],
            data.temperature[rows_of_run],
            reference=data.reference[rows_of_run],
            interval=None if data.interval is None else data.interval[rows_of_run],
            outside=outside,
            title=f"run {label}" if data.has_runs else None,
        )
        path = save_figure(ax, Path(directory) / f"compensation_{index + 1}.png")
        figures.append(path)
        band = "" if data.interval is None else ", the band where the true rate should lie"
        shaded = ""
        if outside is not None and outside.any():
            shaded = "; shaded where the rows lie outside the calibration domain"
        report.add_figure(
            path,
            f"Run {label}: raw (grey) and compensated output{band}, reference (dashed) and "
            f"temperature (red, right axis){shaded}.",
        )
    return figures


def _add_allan_deviation(report, directory, data):
    """Allan deviation of the error of the longest run, before and after; [path] or []."""
    from sklearn_ifog.metrics import allan_deviation
    from sklearn_ifog.plotting import plot_allan_deviation, save_figure

    longest = max(data.segments, key=lambda label: data.segments[label].size)
    rows_of_run = data.segments[longest]
    period, uniform = sample_period(data.time[rows_of_run])
    report.add_heading("Allan deviation", level=3)
    if not (uniform and rows_of_run.size >= 16):
        report.add_paragraph(f"Not computed: run {longest} is not uniformly sampled or too short.")
        return []
    curves = {}
    for name, values in (("raw", data.rate), ("compensated", data.compensated)):
        error = values[rows_of_run] - data.reference[rows_of_run]
        curves[name] = allan_deviation(error, sample_period=period)
    ax = plot_allan_deviation(curves, title=f"run {longest}" if data.has_runs else None)
    path = save_figure(ax, Path(directory) / "allan_deviation.png")
    report.add_figure(
        path,
        f"Overlapping Allan deviation of the error before and after compensation "
        f"(run {longest}, the longest; sample period {period:g} s).",
    )
    return [path]


def _add_model(report, model_metadata):
    """The model's class, versions, input columns and training MSDs."""
    report.add_heading("Model")
    extra = model_metadata.get("extra") or {}
    details = {
        "model class": model_metadata.get("model_class"),
        "saved": model_metadata.get("created"),
        "sklearn-ifog version": model_metadata.get("sklearn_ifog_version"),
        "scikit-learn version": model_metadata.get("sklearn_version"),
        "input columns": ", ".join(model_metadata.get("feature_columns") or []) or None,
    }
    training = extra.get("training") or {}
    if training:
        details["trained on"] = (
            f"{training.get('file')} ({training.get('n_samples')} samples; training MSD "
            f"{training.get('msd_before', np.nan):.3g} -> "
            f"{training.get('msd_after', np.nan):.3g})"
        )
    report.add_table(
        {
            "property": list(details),
            "value": ["n/a" if value is None else str(value) for value in details.values()],
        },
        index=False,
    )
