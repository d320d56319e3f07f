"""Compensation reports in Markdown and HTML.

:class:`Report` collects headings, paragraphs, tables and figures and renders them as
Markdown (figures linked, for a repository or a wiki) and as one self-contained HTML file
(figures embedded, to hand on). :func:`compensation_report` builds the report a gyro engineer
hands on after a thermal test from the run's columns (a :class:`RunColumns`): MSD and bias
stability before and after compensation per run, the raw and compensated rate with the
temperature, the Allan deviation before and after, and, for a model that knows its
calibration domain, which rows lay outside it and what the model did there
(:func:`calibration_status`, :func:`per_run_calibration`).

Its modules: ``_document`` (the :class:`Report`), ``_columns`` (the :class:`RunColumns`),
``_compensation`` (:func:`compensation_report`, :func:`per_unit_table`) and its sections
(``_sections``), ``_status`` (where the rows lay with respect to the calibration domain) and
``_words`` (the report's text: how the report and the command line say, in words, what a
model did outside its calibration).
"""

from sklearn_ifog.report._columns import RunColumns
from sklearn_ifog.report._compensation import compensation_report, per_unit_table
from sklearn_ifog.report._document import Report
from sklearn_ifog.report._status import calibration_status, per_run_calibration

__all__ = [
    "Report",
    "RunColumns",
    "calibration_status",
    "compensation_report",
    "per_run_calibration",
    "per_unit_table",
]
