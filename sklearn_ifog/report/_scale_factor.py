"""The report's "Scale factor" section, for rate-table data (issue 44, point 3).

For a model that learns the scale factor (a :class:`~sklearn_ifog.CompensationPipeline`
with ``input_rate``), or when asked, :func:`~sklearn_ifog.report.compensation_report` adds
the scale-factor error in ppm per temperature bin before and after compensation, its
peak-to-peak over temperature, the linearity and asymmetry, the residual at each input rate
and their figure, all from :mod:`sklearn_ifog.metrics`. The input rate is the report's
reference: on a rate table the drift target is ``rate - reference``.
"""

from pathlib import Path

import numpy as np

from sklearn_ifog._per_run import ALL_RUNS

__all__ = []

DEG_H_PER_DEG_S = 3600.0


def input_rate_column(model):
    """The input-rate column of a scale-factor model (or of the model it wraps), else None."""
    for part in (model, getattr(model, "estimator", None), getattr(model, "estimator_", None)):
        column = getattr(part, "input_rate", None) if part is not None else None
        if column is not None and not callable(column):
            return column
    return None


def wants_scale_factor(scale_factor, model):
    """Whether the report gets the section: ``scale_factor``, or None: a scale-factor model."""
    if scale_factor is None:
        return input_rate_column(model) is not None
    if not isinstance(scale_factor, bool | np.bool_):
        raise ValueError(
            "scale_factor must be None (a section for a model fitted with input_rate), True "
            f"or False; got {scale_factor!r}."
        )
    return bool(scale_factor)


def scale_factor_tables(data, run, bins):
    """The section's numbers: per-bin ppm, the summary and the residual per input rate.

    Returns
    -------
    tables : sklearn.utils.Bunch
        ``table`` (:func:`~sklearn_ifog.metrics.scale_factor_error` before and after:
        ``run``, ``temperature``, ``T_low``, ``T_high``, ``ppm_before``, ``ppm_after``,
        ``samples``), ``summary`` (DataFrame indexed by ``peak_to_peak_ppm``,
        ``linearity_ppm``, ``asymmetry_ppm``, columns ``before`` and ``after``) and
        ``by_input_rate`` (indexed by ``input_rate``, deg/h: ``deg_s``, ``rms_before``,
        ``rms_after`` in deg/h, ``samples``).
    """
    import pandas as pd
    from sklearn.utils import Bunch

    from sklearn_ifog import metrics

    omega, temperature = data.reference, data.temperature
    errors = {"before": data.rate - omega, "after": data.compensated - omega}
    tables = {
        name: metrics.scale_factor_error(omega, error, temperature, run=run, bins=bins)
        for name, error in errors.items()
    }
    table = tables["before"].rename(columns={"ppm": "ppm_before"})
    table.insert(table.columns.get_loc("ppm_before") + 1, "ppm_after", tables["after"]["ppm"])
    summary = pd.DataFrame(
        {
            name: [
                metrics.scale_factor_peak_to_peak(omega, error, temperature, run=run, bins=bins),
                metrics.scale_factor_linearity(omega, error),
                metrics.scale_factor_asymmetry(omega, error),
            ]
            for name, error in errors.items()
        },
        index=pd.Index(["peak_to_peak_ppm", "linearity_ppm", "asymmetry_ppm"], name="metric"),
    )
    residuals = {name: metrics.residual_by_input_rate(omega, e) for name, e in errors.items()}
    by_input_rate = pd.DataFrame(
        {
            "deg_s": residuals["before"].index.to_numpy() / DEG_H_PER_DEG_S,
            "rms_before": residuals["before"]["rms"],
            "rms_after": residuals["after"]["rms"],
            "samples": residuals["before"]["samples"],
        }
    )
    return Bunch(table=table, summary=summary, by_input_rate=by_input_rate, errors=errors)


def _ratio_text(before, after):
    if not (np.isfinite(before) and np.isfinite(after)) or after <= 0:
        return ""
    return f" ({before / after:.3g}x smaller)"


def add_scale_factor(report, directory, data, run, bins):
    """The "Scale factor" section; its tables (a Bunch, see :func:`scale_factor_tables`,
    with ``figures``: the figure's path in a list, empty when there is none to draw)."""
    from sklearn_ifog.plotting import plot_scale_factor, save_figure

    tables = scale_factor_tables(data, run, bins)
    errors = tables.pop("errors")
    summary = tables.summary
    report.add_heading("Scale factor", level=3)
    pooled = tables.table[tables.table["run"] == ALL_RUNS]
    tables.figures = []
    if not np.isfinite(pooled[["ppm_before", "ppm_after"]].to_numpy()).any():
        report.add_paragraph(
            "No scale factor can be read: in no temperature bin do the input rates (the "
            "reference) take two values; a scale factor is the slope of the error on the "
            "input rate."
        )
        return tables
    before, after = summary.loc["peak_to_peak_ppm", ["before", "after"]]
    report.add_paragraph(
        "The scale-factor error is the least-squares slope of the error (output minus input "
        "rate, deg/h) on the input rate, with an intercept, in ppm of the input rate, per "
        "temperature bin (all runs pooled, each with its own bias; n/a where the bin's input "
        "rates do not differ, e.g. all zero). Its peak-to-peak over temperature: "
        f"{before:.3g} ppm before, {after:.3g} ppm after compensation"
        f"{_ratio_text(before, after)}. The linearity is the largest deviation of the "
        "per-rate mean errors from their best line, in ppm of the full scale; the asymmetry "
        "the scale-factor error of positive inputs minus that of negative ones, ppm."
    )
    report.add_table(summary, caption="Scale factor before and after compensation, ppm.")
    report.add_table(
        pooled.drop(columns="run").set_index("temperature"),
        caption="Scale-factor error per temperature bin (centre, edges, deg C), all runs "
        "pooled, ppm.",
    )
    report.add_table(
        tables.by_input_rate,
        caption="Root mean square of the error at each input rate (deg/h; the rate also "
        "in deg/s), before and after compensation.",
    )
    ax = plot_scale_factor(
        data.reference,
        data.temperature,
        errors["before"],
        errors["after"],
        run=run,
        bins=bins,
        title="scale-factor error",
    )
    path = save_figure(ax, Path(directory) / "scale_factor.png")
    report.add_figure(
        path,
        "Scale-factor error against temperature, before (grey) and after (blue) "
        "compensation: all runs pooled (line) and each run (dots).",
    )
    tables.figures = [path]
    return tables
