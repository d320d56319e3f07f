"""Plots a gyro engineer reads after a thermal test.

- :func:`plot_compensation`: the raw and compensated rate against time, with the coil
  temperature on a second axis (the reference paper's Figs. 10 and 12), the stretches outside
  the model's calibration domain shaded;
- :func:`plot_allan_deviation`: Allan deviation curves, e.g. before and after compensation;
- :func:`plot_msd_by_model`: mean squared deviation per model on a log scale;
- :func:`plot_scale_factor`: the scale-factor error (ppm) of rate-table data against
  temperature, before and after compensation.

matplotlib is optional (``pip install 'sklearn-ifog[plot]'``) and only imported when a
function here is called. With ``ax=None`` the functions build a
:class:`matplotlib.figure.Figure` directly, without pyplot, so they never open a window or
touch the global backend: the figure renders with Agg when saved (:func:`save_figure`) and
displays inline in a notebook. Pass ``ax=`` to draw into your own figure.
"""

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from sklearn_ifog._contract import SECONDS_PER_UNIT
from sklearn_ifog._io import atomic_path

__all__ = [
    "new_figure",
    "outside_stretches",
    "plot_allan_deviation",
    "plot_compensation",
    "plot_msd_by_model",
    "plot_scale_factor",
    "save_figure",
]

_RAW_COLOR = "0.55"
_TEMPERATURE_COLOR = "tab:red"
_SERIES_COLORS = ("tab:blue", "tab:green", "tab:purple", "tab:orange", "tab:brown")
# Stretches outside the calibration domain: a light amber behind the curves, a colour none
# of the curves use.
_OUTSIDE_COLOR = "#f0a830"
_OUTSIDE_ALPHA = 0.22
_OUTSIDE_LABEL = "outside calibration"


def _matplotlib():
    try:
        import matplotlib
    except ImportError as error:
        raise ImportError(
            "Plotting needs matplotlib; install it with: pip install 'sklearn-ifog[plot]'"
        ) from error
    return matplotlib


def new_figure(nrows=1, ncols=1, *, figsize=None):
    """A new figure and its axes, made without pyplot (no window, no global state).

    Parameters
    ----------
    nrows, ncols : int, default=1
        Grid of axes.
    figsize : (float, float), default=None
        Size in inches; None scales (8, 4) by the grid.

    Returns
    -------
    figure : matplotlib.figure.Figure
    axes : matplotlib.axes.Axes or ndarray of them
        One Axes for a 1x1 grid, else an array as from :meth:`Figure.subplots`.

    Examples
    --------
    >>> from sklearn_ifog.plotting import new_figure
    >>> figure, axes = new_figure(2, 1)
    >>> axes.shape
    (2,)
    """
    _matplotlib()
    from matplotlib.figure import Figure

    if figsize is None:
        figsize = (8.0 * ncols, 4.0 * nrows)
    figure = Figure(figsize=figsize, layout="constrained")
    return figure, figure.subplots(nrows, ncols, squeeze=True)


def _new_axes(figsize):
    return new_figure(figsize=figsize)[1]


def _as_series_mapping(values, default_label):
    if isinstance(values, Mapping):
        return {str(label): np.asarray(series, dtype=float) for label, series in values.items()}
    return {default_label: np.asarray(values, dtype=float)}


def outside_stretches(outside):
    """First and last row of every stretch of consecutive True values of a mask.

    Parameters
    ----------
    outside : array-like of bool, shape (n_samples,)
        E.g. :meth:`~sklearn_ifog.CompensationPipeline.outside_calibration` of a run.

    Returns
    -------
    first, last : ndarray of int
        Row of the first and of the last True value of every stretch, in order.

    Examples
    --------
    >>> from sklearn_ifog.plotting import outside_stretches
    >>> first, last = outside_stretches([True, False, False, True, True, False, True])
    >>> first.tolist(), last.tolist()
    ([0, 3, 6], [0, 4, 6])
    """
    edges = np.diff(np.concatenate([[0], np.asarray(outside, dtype=np.int8), [0]]))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1


def _stretch_extents(x, first, last):
    """(start, end) on the axis ``x`` of the stretches: half-way to the neighbouring samples.

    Each sample owns the interval half-way to its neighbours (the first and last sample end
    at their own time), so a single sample outside still shows and the shaded stretches
    and the unshaded ones tile the time axis.
    """
    middle = (x[1:] + x[:-1]) / 2.0
    return np.concatenate([x[:1], middle])[first], np.concatenate([middle, x[-1:]])[last]


def _check_outside(outside, series, shape):
    """{series label or None: boolean mask}; a TypeError/ValueError naming what is wrong."""
    masks = outside if isinstance(outside, Mapping) else {None: outside}
    unknown = [label for label in masks if label is not None and str(label) not in series]
    if unknown:
        raise ValueError(
            f"outside names series {unknown} that compensated does not have; its series are "
            f"{list(series)}."
        )
    checked = {}
    for label, mask in masks.items():
        name = "outside" if label is None else f"outside[{str(label)!r}]"
        mask = np.asarray(mask)
        if mask.dtype != bool:
            raise TypeError(
                f"{name} must be a boolean mask (True where a row lies outside the "
                f"calibration domain), got dtype {mask.dtype}."
            )
        if mask.shape != shape:
            raise ValueError(
                f"{name} has shape {mask.shape} but time has shape {shape}; give one flag "
                "per sample."
            )
        checked[None if label is None else str(label)] = mask
    return checked


def _shade_outside(ax, x, masks, series_colors):
    """axvspan over every stretch of every mask; one legend entry per mask."""
    for label, mask in masks.items():
        first, last = outside_stretches(mask)
        color = _OUTSIDE_COLOR if label is None else series_colors[label]
        legend = _OUTSIDE_LABEL if label is None else f"{_OUTSIDE_LABEL} ({label})"
        for number, (start, end) in enumerate(zip(*_stretch_extents(x, first, last), strict=True)):
            ax.axvspan(
                start,
                end,
                facecolor=color,
                alpha=_OUTSIDE_ALPHA,
                linewidth=0,
                zorder=0,
                # one legend entry per mask; every span findable by its gid
                label=legend if number == 0 else "_nolegend_",
                gid=legend,
            )


def plot_compensation(
    time,
    rate,
    compensated,
    temperature=None,
    *,
    reference=None,
    interval=None,
    outside=None,
    time_unit="h",
    ax=None,
    title=None,
):
    """Plot the raw and compensated gyro rate over time, with the temperature.

    The raw output in grey, each compensated output in colour, the true input rate as a
    dashed line and the coil temperature (red) on a twin axis on the right, as in the
    reference paper's Figs. 10 and 12.

    Parameters
    ----------
    time : array-like of shape (n_samples,)
        Time in seconds.
    rate : array-like of shape (n_samples,)
        Raw gyro output (deg/h).
    compensated : array-like of shape (n_samples,) or dict of str to array-like
        Compensated output (deg/h), or several (e.g. ``{"traditional": ..., "modified":
        ...}``), each drawn with its label.
    temperature : array-like of shape (n_samples,), default=None
        Coil temperature (deg C), drawn on the right axis; None draws none.
    reference : float or array-like of shape (n_samples,), default=None
        True input rate (deg/h), drawn dashed.
    interval : array-like of shape (n_samples, 2), default=None
        Lower and upper bound of the *drift* (deg/h), e.g.
        :meth:`~sklearn_ifog.ConformalRegressor.predict_interval`; the band where the true
        input rate should lie, ``[rate - upper, rate - lower]``, is shaded around the
        compensated output (label ``"band"``).
    outside : array-like of bool of shape (n_samples,) or dict of str to it, default=None
        True where a row lies outside the model's calibration domain, e.g.
        :meth:`~sklearn_ifog.CompensationPipeline.outside_calibration`; every stretch of
        consecutive such rows is shaded over the full height (:meth:`~matplotlib.axes.Axes.
        axvspan`, from half-way to the previous sample to half-way to the next; legend
        ``"outside calibration"``). A dict gives one mask per compensated series (its keys
        among ``compensated``'s), shaded in that series' colour.
    time_unit : {"s", "min", "h"}, default="h"
        Unit of the time axis.
    ax : matplotlib.axes.Axes, default=None
        Axes to draw into; None makes a new figure.
    title : str, default=None
        Axes title.

    Returns
    -------
    ax : matplotlib.axes.Axes
        The rate axes.
    temperature_ax : matplotlib.axes.Axes or None
        The twin temperature axes (None if no temperature was given).

    Raises
    ------
    ValueError
        If the arrays differ in length, ``time_unit`` is unknown or ``outside`` names a
        series ``compensated`` does not have.
    TypeError
        If ``outside`` is not boolean.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.plotting import plot_compensation
    >>> time = np.arange(0.0, 7200.0, 10.0)
    >>> temperature = 10.0 + 30.0 * time / time[-1]
    >>> rate = 10.0 + 0.01 * temperature
    >>> ax, temperature_ax = plot_compensation(time, rate, rate - 0.01 * temperature, temperature)
    >>> [line.get_label() for line in ax.get_lines()]
    ['raw', 'compensated']
    >>> temperature_ax.get_ylabel()
    'temperature (°C)'
    >>> drift = 0.01 * temperature
    >>> band = np.column_stack([drift - 0.05, drift + 0.05])
    >>> ax, _ = plot_compensation(time, rate, rate - drift, interval=band)
    >>> [patch.get_label() for patch in ax.collections]
    ['band']
    >>> outside = temperature < 12.0  # the first stretch, colder than the calibration
    >>> ax, _ = plot_compensation(time, rate, rate - drift, temperature, outside=outside)
    >>> [text.get_text() for text in ax.get_legend().get_texts()]
    ['raw', 'compensated', 'outside calibration', 'temperature']
    """
    if time_unit not in SECONDS_PER_UNIT:
        raise ValueError(
            f"time_unit must be one of {sorted(SECONDS_PER_UNIT)}, got {time_unit!r}."
        )
    time = np.asarray(time, dtype=float)
    rate = np.asarray(rate, dtype=float)
    series = _as_series_mapping(compensated, "compensated")
    named = {"rate": rate, **{f"compensated[{label!r}]": s for label, s in series.items()}}
    if temperature is not None:
        temperature = np.asarray(temperature, dtype=float)
        named["temperature"] = temperature
    if interval is not None:
        interval = np.asarray(interval, dtype=float)
        if interval.shape != (*time.shape, 2):
            raise ValueError(
                f"interval has shape {interval.shape} but time has shape {time.shape}; give "
                "(lower, upper) per sample, shape (n_samples, 2)."
            )
    for name, values in named.items():
        if values.shape != time.shape:
            raise ValueError(
                f"{name} has shape {values.shape} but time has shape {time.shape}; "
                "give one value per sample."
            )
    if outside is not None:
        outside = _check_outside(outside, series, time.shape)
    if ax is None:
        ax = _new_axes((8.0, 4.0))
    hours = time / SECONDS_PER_UNIT[time_unit]
    ax.plot(hours, rate, color=_RAW_COLOR, linewidth=0.8, label="raw")
    if interval is not None:
        ax.fill_between(
            hours,
            rate - interval[:, 1],
            rate - interval[:, 0],
            color=_SERIES_COLORS[0],
            alpha=0.25,
            linewidth=0,
            label="band",
        )
    series_colors = dict(zip(series, _SERIES_COLORS * 4, strict=False))
    for label, values in series.items():
        ax.plot(hours, values, color=series_colors[label], linewidth=0.8, label=label)
    if outside is not None and time.size:
        _shade_outside(ax, hours, outside, series_colors)
    if reference is not None:
        ax.plot(
            hours,
            np.broadcast_to(np.asarray(reference, dtype=float), time.shape),
            color="black",
            linestyle="--",
            linewidth=0.8,
            label="_reference",
        )
    ax.set_xlabel(f"time ({time_unit})")
    ax.set_ylabel("rate (°/h)")
    ax.grid(True, alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    temperature_ax = None
    if temperature is not None:
        twin = ax.twinx()
        (line,) = twin.plot(
            hours, temperature, color=_TEMPERATURE_COLOR, linewidth=1.0, label="temperature"
        )
        twin.set_ylabel("temperature (°C)", color=_TEMPERATURE_COLOR)
        twin.tick_params(axis="y", colors=_TEMPERATURE_COLOR)
        handles.append(line)
        labels.append("temperature")
        temperature_ax = twin
    ax.legend(handles, labels, loc="best", fontsize="small")
    if title is not None:
        ax.set_title(title)
    return ax, temperature_ax


def plot_allan_deviation(curves, *, ax=None, title=None):
    """Plot Allan deviation curves on log-log axes.

    Parameters
    ----------
    curves : dict of str to (taus, adev)
        For each label (e.g. ``"raw"``, ``"compensated"``), the averaging times (s) and the
        Allan deviations (deg/h), as computed by :func:`sklearn_ifog.metrics.allan_deviation`.
    ax : matplotlib.axes.Axes, default=None
        Axes to draw into; None makes a new figure.
    title : str, default=None
        Axes title.

    Returns
    -------
    ax : matplotlib.axes.Axes

    Raises
    ------
    ValueError
        If a curve's arrays differ in length, or hold no positive value to draw.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.plotting import plot_allan_deviation
    >>> taus = np.array([1.0, 10.0, 100.0])
    >>> ax = plot_allan_deviation({"raw": (taus, 0.1 / np.sqrt(taus))})
    >>> ax.get_xscale(), ax.get_yscale()
    ('log', 'log')
    """
    if ax is None:
        ax = _new_axes((6.0, 4.5))
    colors = (_RAW_COLOR, *_SERIES_COLORS)
    for (label, (taus, adev)), color in zip(curves.items(), colors * 4, strict=False):
        taus = np.asarray(taus, dtype=float)
        adev = np.asarray(adev, dtype=float)
        if taus.shape != adev.shape:
            raise ValueError(
                f"curve {label!r}: taus has shape {taus.shape} but adev has {adev.shape}."
            )
        keep = (taus > 0) & (adev > 0) & np.isfinite(adev)
        if not keep.any():
            raise ValueError(f"curve {label!r} has no positive Allan deviation to draw.")
        ax.loglog(taus[keep], adev[keep], marker=".", color=color, label=str(label))
    ax.set_xlabel("averaging time τ (s)")
    ax.set_ylabel("Allan deviation (°/h)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    if title is not None:
        ax.set_title(title)
    return ax


def plot_msd_by_model(msd, *, before=None, floor=None, ax=None, title=None):
    """Bar chart of the mean squared deviation per model, log scale.

    Parameters
    ----------
    msd : dict of str to float or array-like, or pandas.Series
        Model name to its MSD after compensation (deg²/h²), or to one MSD per fold or
        experiment: the bar is the mean, the dots the individual values.
    before : float or array-like, default=None
        MSD of the raw output, drawn as a grey bar labelled "raw" (left-most) unless
        ``msd`` already has a ``"raw"`` entry.
    floor : float, default=None
        The lowest MSD a perfect drift model could reach (the gyro's noise, e.g. known in a
        simulation), drawn as a dashed horizontal line labelled "noise floor".
    ax : matplotlib.axes.Axes, default=None
        Axes to draw into; None makes a new figure.
    title : str, default=None
        Axes title.

    Returns
    -------
    ax : matplotlib.axes.Axes

    Raises
    ------
    ValueError
        If ``msd`` is empty or holds a non-positive or non-finite value (log scale).

    Examples
    --------
    >>> from sklearn_ifog.plotting import plot_msd_by_model
    >>> ax = plot_msd_by_model({"linear": [1e-3, 2e-3], "rbf": 1e-4}, before=0.1)
    >>> [label.get_text() for label in ax.get_xticklabels()]
    ['raw', 'linear', 'rbf']
    >>> ax.get_yscale()
    'log'
    """
    entries = {str(name): np.atleast_1d(np.asarray(v, dtype=float)) for name, v in msd.items()}
    if before is not None and "raw" not in entries:
        entries = {"raw": np.atleast_1d(np.asarray(before, dtype=float)), **entries}
    if not entries:
        raise ValueError("msd is empty: give at least one model's MSD.")
    for name, values in entries.items():
        if values.size == 0 or not np.all(np.isfinite(values) & (values > 0)):
            raise ValueError(
                f"MSD of {name!r} must be positive and finite to draw on a log scale, "
                f"got {values.tolist()}."
            )
    if ax is None:
        ax = _new_axes((max(5.0, 0.75 * len(entries) + 2.0), 4.5))
    positions = np.arange(len(entries))
    means = [values.mean() for values in entries.values()]
    colors = [_RAW_COLOR if name == "raw" else "tab:blue" for name in entries]
    ax.bar(positions, means, color=colors, alpha=0.8)
    for position, values in zip(positions, entries.values(), strict=True):
        if values.size > 1:
            ax.plot(np.full(values.size, position), values, "k.", markersize=4)
    if floor is not None:
        if not (np.isfinite(floor) and floor > 0):
            raise ValueError(f"floor must be positive and finite, got {floor!r}.")
        ax.axhline(floor, color="black", linestyle="--", linewidth=0.8, label="noise floor")
        ax.legend(fontsize="small")
    ax.set_yscale("log")
    ax.set_xticks(positions, list(entries), rotation=30, ha="right")
    ax.set_ylabel("MSD ((°/h)²)")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    if title is not None:
        ax.set_title(title)
    return ax


def plot_scale_factor(
    input_rate, temperature, before, after=None, *, run=None, bins=10, ax=None, title=None
):
    """Plot the scale-factor error (ppm) against temperature, before and after compensation.

    For each error, the scale-factor error of every temperature bin
    (:func:`sklearn_ifog.metrics.scale_factor_error`): all runs pooled as a line, and with
    several runs each run's as dots of the same colour. Bins without a scale factor (one
    input rate only, e.g. zero) are gaps.

    Parameters
    ----------
    input_rate : array-like of shape (n_samples,)
        True input rate, deg/h.
    temperature : array-like of shape (n_samples,)
        Coil temperature, deg C.
    before : array-like of shape (n_samples,)
        Error before compensation, deg/h: ``rate - input_rate`` (the drift target ``y``).
    after : array-like of shape (n_samples,), default=None
        Error after compensation, deg/h: ``y - model.predict(X)``; None draws ``before``
        only.
    run : array-like of shape (n_samples,), default=None
        Run label of each row; None: one run.
    bins : int or array-like of float, default=10
        Temperature bins, as for :func:`~sklearn_ifog.metrics.scale_factor_error`.
    ax : matplotlib.axes.Axes, default=None
        Axes to draw into; None makes a new figure.
    title : str, default=None
        Axes title.

    Returns
    -------
    ax : matplotlib.axes.Axes

    Raises
    ------
    ValueError
        If no temperature bin has a scale factor to draw (its input rates all equal), or
        an input is bad (as for :func:`~sklearn_ifog.metrics.scale_factor_error`).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.plotting import plot_scale_factor
    >>> temperature = np.linspace(-40.0, 70.0, 400)
    >>> omega = np.tile([0.0, 3.6e5, -3.6e5, 1.08e6], 100)
    >>> before = omega * 1e-6 * (4.0 * temperature)  # 4 ppm/degC
    >>> after = before - omega * 1e-6 * (3.9 * temperature)
    >>> ax = plot_scale_factor(omega, temperature, before, after, bins=4)
    >>> ax.get_legend_handles_labels()[1]
    ['before', 'after']
    >>> ax.get_lines()[1].get_ydata().round(1).tolist()
    [-2.6, 0.2, 2.9, 5.7]
    """
    from sklearn_ifog._per_run import ALL_RUNS
    from sklearn_ifog.metrics import scale_factor_error

    errors = {"before": before} if after is None else {"before": before, "after": after}
    tables = {
        label: scale_factor_error(input_rate, error, temperature, run=run, bins=bins)
        for label, error in errors.items()
    }
    if not any(np.isfinite(table["ppm"]).any() for table in tables.values()):
        raise ValueError(
            "No temperature bin has a scale factor to draw: its rows' input_rate must take at "
            "least two values (a scale factor is the slope of the error on the input rate)."
        )
    if ax is None:
        ax = _new_axes((7.0, 4.5))
    for (label, table), color in zip(tables.items(), (_RAW_COLOR, "tab:blue"), strict=False):
        pooled = table[table["run"] == ALL_RUNS]
        ax.plot(pooled["temperature"], pooled["ppm"], marker="o", color=color, label=label)
        runs = table[table["run"] != ALL_RUNS]
        if run is not None and runs["run"].nunique() > 1:
            ax.plot(runs["temperature"], runs["ppm"], ".", color=color, alpha=0.5)
    ax.axhline(0.0, color="black", linewidth=0.6)
    ax.set_xlabel("temperature (°C)")
    ax.set_ylabel("scale-factor error (ppm)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    if title is not None:
        ax.set_title(title)
    return ax


def save_figure(figure, path, *, dpi=120):
    """Save a figure atomically (temporary file, then rename); the format follows the suffix.

    Parameters
    ----------
    figure : matplotlib.figure.Figure or matplotlib.axes.Axes
        The figure, or an axes of it.
    path : str or path-like
        Output file, e.g. ``"compensation.png"``; its directory must exist.
    dpi : float, default=120
        Resolution of raster formats.

    Returns
    -------
    path : pathlib.Path

    Raises
    ------
    ValueError
        If ``path`` has no suffix to tell the format.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from sklearn_ifog.plotting import plot_msd_by_model, save_figure
    >>> ax = plot_msd_by_model({"rbf": 1e-4}, before=1e-2)
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     path = save_figure(ax, pathlib.Path(directory) / "msd.png")
    ...     path.read_bytes()[:4] == b"\\x89PNG"
    True
    """
    path = Path(path)
    file_format = path.suffix.lstrip(".").lower()
    if not file_format:
        raise ValueError(f"Cannot tell the figure format of {os.fspath(path)!r}: no suffix.")
    figure = getattr(figure, "figure", figure)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format=file_format, dpi=dpi)
    return path
