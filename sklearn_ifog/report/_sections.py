"""The sections of :func:`~sklearn_ifog.report.compensation_report`, each added to its
:class:`~sklearn_ifog.report.Report`: the summary, the calibration domain (in words), the
figures and the model.
"""

import datetime
from pathlib import Path

import numpy as np

from sklearn_ifog._per_run import ALL_RUNS, sample_period
from sklearn_ifog.report._words import number_text, policy_actions, rate_beyond_text

__all__ = []


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
    # rate-table data: the input rates dwarf the drift, so draw the output's error instead
    errors = data.get("errors", False)
    offset = data.reference if errors else np.zeros_like(data.reference)
    if errors:
        report.add_paragraph(
            "The input rates (the reference) dwarf the drift: the figures draw the error, "
            "output minus input rate, before and after compensation."
        )
    for index, label in enumerate(shown):
        rows_of_run = data.segments[label]
        outside = None if data.outside is None else data.outside[rows_of_run]
        ax, _ = plot_compensation(
            data.time[rows_of_run] - data.time[rows_of_run][0],
            data.rate[rows_of_run] - offset[rows_of_run],
            data.compensated[rows_of_run] - offset[rows_of_run],
            data.temperature[rows_of_run],
            reference=(data.reference - offset)[rows_of_run],
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
        what = "error (output minus input rate)" if errors else "output"
        report.add_figure(
            path,
            f"Run {label}: raw (grey) and compensated {what}{band}, "
            f"{'zero' if errors else 'reference'} (dashed) and temperature (red, right "
            f"axis){shaded}.",
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


def transitions_of(model):
    """``[(label, Transition)]``: every searched transition of a model's feature steps.

    A pipeline's first step, a meta-estimator's fitted ``estimator_`` or
    ``lot_estimator_``, and a lot's per-unit ``estimators_`` (labelled by unit); only
    ThermalFeatures fitted with ``transition`` (a ``transition_`` that is not None).
    """
    found = []

    def walk(estimator, label):
        if estimator is None:
            return
        steps = getattr(estimator, "steps", None)
        if steps:
            transition = getattr(steps[0][1], "transition_", None)
            if transition is not None:
                found.append((label, transition))
            return
        units = getattr(estimator, "estimators_", None)
        if isinstance(units, dict):
            for unit, member in units.items():
                walk(member, f"unit {unit}")
            return
        walk(getattr(estimator, "estimator_", None), label)

    walk(model, None)
    return found


def _add_transition(report, model):
    """What the feature step's transition search found (only when it ran)."""
    found = transitions_of(model)
    if not found:
        return
    report.add_heading("Transition search", level=3)
    report.add_paragraph(
        "The feature step searched the calibration for a coating's transition (experimental, "
        "ThermalFeatures(transition=...)): a smooth step of the lagged sensor temperature, "
        "kept only when, chosen on half of the calibration's held-out runs, it beat the "
        "features without it on the other half by more than one standard error, both ways "
        "round. The held-out gain is the search's own least-squares model's."
    )
    report.add_table(
        {
            "model": ["the model" if label is None else label for label, _ in found],
            "shape": [t.shape for _, t in found],
            "centre, °C": [t.centre for _, t in found],
            "width, °C": [t.width for _, t in found],
            "lag, s": [t.lag for _, t in found],
            "held-out gain": [t.held_out_gain for _, t in found],
            "standard error": [t.standard_error for _, t in found],
            "kept": ["yes" if t.terms else "no" for _, t in found],
        },
        index=False,
        caption="The best transition of each search and whether its terms were kept.",
    )
