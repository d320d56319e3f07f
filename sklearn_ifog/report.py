"""Compensation reports in Markdown and HTML.

:class:`Report` collects headings, paragraphs, tables and figures and renders them as
Markdown (figures linked, for a repository or a wiki) and as one self-contained HTML file
(figures embedded, to hand on). :func:`compensation_report` builds the report a gyro engineer
hands on after a thermal test: MSD and bias stability before and after compensation per run,
the raw and compensated rate with the temperature, and the Allan deviation before and after.
"""

import base64
import datetime
import html
import mimetypes
import numbers
import os
from pathlib import Path

import numpy as np

from sklearn_ifog import _table
from sklearn_ifog._io import atomic_path
from sklearn_ifog.metrics import _ALL_RUNS

__all__ = ["Report", "compensation_report"]


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
):
    """Measure a compensation and write its report (Markdown and HTML) with figures.

    For every run, the table of :func:`~sklearn_ifog.metrics.per_run_metrics`: the MSD of
    the raw and of the compensated rate from the reference (the reference paper's Eq. 24),
    their ratio and the bias stability before and after (``bias_window``-second averages,
    IEEE Std 952 practice; n/a where the run is too short or not uniformly sampled); the raw
    and compensated rate with the temperature for the first ``max_runs`` runs; and the Allan
    deviation of the error (output minus reference) before and after compensation, for the
    longest run.

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

    Returns
    -------
    result : sklearn.utils.Bunch
        ``report`` (the :class:`Report`), ``table`` (DataFrame indexed by run, with a last
        row ``"(all runs)"`` for all rows together; without ``run``, that row only),
        ``unit_table`` (DataFrame indexed by unit, or None without ``unit``), ``figures``
        (list of Path) and ``paths`` (``{"markdown": Path, "html": Path}``).

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
    """
    from sklearn.utils import Bunch

    from sklearn_ifog.metrics import _compensation_arrays, per_run_metrics

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
    rate, drift, reference, temperature, time_values = _compensation_arrays(
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
            _ALL_RUNS if label is None else label: rows
            for label, rows in _table.run_segments(run, rate.shape[0])
        },
        has_runs=run is not None,
        interval=None,
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
            coverage[_ALL_RUNS] = interval_coverage(measured, interval)
            width[_ALL_RUNS] = mean_interval_width(interval)
        table["coverage"] = table.index.map(coverage)
        table["width"] = table.index.map(width)
    unit_table = None if unit is None else per_unit_table(rate, drift, reference, unit, run)
    if report is None:
        report = Report(title)
    _add_summary(report, heading, data, table, data_name, bias_window, time is None, unit_table)
    figures = _add_compensation_figures(report, directory, data, max_runs)
    figures += _add_allan_deviation(report, directory, data)
    if model_metadata:
        _add_model(report, model_metadata)
    paths = report.write(directory)
    return Bunch(report=report, table=table, unit_table=unit_table, figures=figures, paths=paths)


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
        f"(reduction {table.loc[_ALL_RUNS, 'reduction']:.3g}x)."
    )
    if unit_table is not None:
        report.add_table(
            unit_table, caption="Per-unit MSD before and after compensation, (deg/h)^2."
        )
    report.add_table(table, caption="Per-run MSD and bias stability, before and after.")


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
        ax, _ = plot_compensation(
            data.time[rows_of_run] - data.time[rows_of_run][0],
            data.rate[rows_of_run],
            data.compensated[rows_of_run],
            data.temperature[rows_of_run],
            reference=data.reference[rows_of_run],
            interval=None if data.interval is None else data.interval[rows_of_run],
            title=f"run {label}" if data.has_runs else None,
        )
        path = save_figure(ax, Path(directory) / f"compensation_{index + 1}.png")
        figures.append(path)
        band = "" if data.interval is None else ", the band where the true rate should lie"
        report.add_figure(
            path,
            f"Run {label}: raw (grey) and compensated output{band}, reference (dashed) and "
            "temperature (red, right axis).",
        )
    return figures


def _add_allan_deviation(report, directory, data):
    """Allan deviation of the error of the longest run, before and after; [path] or []."""
    from sklearn_ifog.metrics import _sample_period, allan_deviation
    from sklearn_ifog.plotting import plot_allan_deviation, save_figure

    longest = max(data.segments, key=lambda label: data.segments[label].size)
    rows_of_run = data.segments[longest]
    period, uniform = _sample_period(data.time[rows_of_run])
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
