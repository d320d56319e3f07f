"""The report document: headings, paragraphs, tables and figures, as Markdown and HTML.

:class:`Report` renders as Markdown (figures linked, for a repository or a wiki) and as one
self-contained HTML file (figures embedded, to hand on); :func:`compensation_report
<sklearn_ifog.report.compensation_report>` fills one.
"""

import base64
import html
import mimetypes
import numbers
import os
from pathlib import Path

import numpy as np

from sklearn_ifog._io import atomic_path

__all__ = ["Report"]


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
