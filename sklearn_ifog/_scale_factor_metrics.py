"""Scale-factor metrics of rate-table data: ppm per temperature bin, linearity, asymmetry.

On a rate table the gyro's error (output minus input rate, deg/h) is ``b + Ω s``: a bias
``b`` and the scale-factor error ``s`` (dimensionless, reported in ppm, ``1e6 s``) times the
input rate ``Ω`` (deg/h). Every metric here reads ``s`` as the least-squares slope of the
error on the input rate, with an intercept (the bias), so rows at zero input rate carry no
scale factor of their own: they only pin the bias. Where no slope can be read (every input
rate the same, or all zero) the metric is NaN, never a silent 0.

Served by :mod:`sklearn_ifog.metrics` (which re-exports the public names), the report
(:mod:`sklearn_ifog.report`) and :func:`sklearn_ifog.plotting.plot_scale_factor`. Applied to
the raw error ``rate - Ω`` they measure the gyro; to the residual ``rate - Ω - drift`` of a
scale-factor model (:class:`~sklearn_ifog.CompensationPipeline` with ``input_rate``) they
measure what the compensation leaves.
"""

import numbers

import numpy as np
from sklearn.utils import check_array

from sklearn_ifog import _table
from sklearn_ifog._per_run import ALL_RUNS

__all__ = [
    "residual_by_input_rate",
    "scale_factor_asymmetry",
    "scale_factor_error",
    "scale_factor_linearity",
    "scale_factor_peak_to_peak",
]

PPM = 1e6
# A slope needs input rates that differ: a spread of the input rates (their sum of squares
# about the mean) below this share of their sum of squares is round-off of equal rates.
_SPREAD_ROUNDOFF = 1e-12


def _columns(**named):
    """The named arrays as finite 1-D float64 of one length; ValueError naming a bad one."""
    checked, length, first = {}, None, None
    for name, values in named.items():
        array = check_array(
            values, ensure_2d=False, dtype=np.float64, input_name=name, ensure_min_samples=1
        )
        if array.ndim != 1:
            raise ValueError(f"{name} must be one-dimensional, got shape {array.shape}.")
        if length is None:
            length, first = array.shape[0], name
        elif array.shape[0] != length:
            raise ValueError(
                f"{name} has {array.shape[0]} values, {first} has {length}; give one per row."
            )
        checked[name] = array
    return checked.values()


def _run_labels(run, n_samples):
    """The run labels as a 1-D array of one per row (None stays None)."""
    if run is None:
        return None
    labels = np.asarray(run)
    if labels.ndim != 1 or labels.shape[0] != n_samples:
        raise ValueError(
            f"run has shape {labels.shape}, input_rate has ({n_samples},); give one run label "
            "per row."
        )
    return labels


def _bin_edges(bins, temperature):
    """The temperature bins' edges: ``bins`` equal bins over the range, or the given edges."""
    if isinstance(bins, numbers.Integral) and not isinstance(bins, bool):
        if bins < 1:
            raise ValueError(f"bins must be a positive number of bins, got {bins}.")
        return np.histogram_bin_edges(temperature, bins=int(bins))
    if isinstance(bins, (str, bool, numbers.Number)):
        raise TypeError(
            f"bins must be a number of bins (int) or the bins' edges (array-like, deg C), "
            f"got {bins!r}."
        )
    edges = np.asarray(bins, dtype=np.float64)
    if edges.ndim != 1 or edges.size < 2 or not np.isfinite(edges).all():
        raise ValueError(
            f"bins as edges must be at least two finite temperatures, deg C; got {bins!r}."
        )
    if np.any(np.diff(edges) <= 0):
        raise ValueError(f"bins as edges must increase strictly, got {edges.tolist()}.")
    return edges


def _bin_of(temperature, edges):
    """The bin of every row (-1 outside the edges); the last bin holds its upper edge."""
    index = np.searchsorted(edges, temperature, side="right") - 1
    index[temperature == edges[-1]] = edges.size - 2
    index[(temperature < edges[0]) | (temperature > edges[-1])] = -1
    return index


def _slope_sums(omega, error, group, n_groups):
    """Per group: rows, and the centred sums ``Σ(Ω-Ω̄)²``, ``Σ(Ω-Ω̄)(e-ē)``, ``ΣΩ²``."""
    count = np.bincount(group, minlength=n_groups).astype(np.float64)
    safe = np.maximum(count, 1.0)
    omega_mean = np.bincount(group, omega, n_groups) / safe
    error_mean = np.bincount(group, error, n_groups) / safe
    d_omega = omega - omega_mean[group]
    sxx = np.bincount(group, d_omega * d_omega, n_groups)
    sxy = np.bincount(group, d_omega * (error - error_mean[group]), n_groups)
    return count, sxx, sxy, np.bincount(group, omega * omega, n_groups)


def _slope(sxx, sxy, total):
    """``sxy / sxx`` where the input rates spread (NaN where they do not)."""
    sxx, sxy, total = np.broadcast_arrays(*map(np.atleast_1d, (sxx, sxy, total)))
    valid = sxx > _SPREAD_ROUNDOFF * total
    return np.divide(sxy, sxx, out=np.full(sxx.shape, np.nan), where=valid)


def _binned(input_rate, error, temperature, run, bins):
    """(edges, labels, per-(run, bin) sums, pooled per-bin sums) of the scale-factor table."""
    omega, error, temperature = _columns(
        input_rate=input_rate, error=error, temperature=temperature
    )
    n_samples = omega.shape[0]
    run = _run_labels(run, n_samples)
    edges = _bin_edges(bins, temperature)
    n_bins = edges.size - 1
    in_bin = _bin_of(temperature, edges)
    segments = _table.run_segments(run, n_samples)
    run_index = np.empty(n_samples, dtype=np.intp)
    for position, (_, rows) in enumerate(segments):
        run_index[rows] = position
    kept = in_bin >= 0
    group = run_index[kept] * n_bins + in_bin[kept]
    n_groups = len(segments) * n_bins
    sums = _slope_sums(omega[kept], error[kept], group, n_groups)
    per_run = [values.reshape(len(segments), n_bins) for values in sums]
    labels = [ALL_RUNS if label is None else label for label, _ in segments]
    return edges, labels, per_run, run is not None


def scale_factor_error(input_rate, error, temperature, *, run=None, bins=10):
    """The scale-factor error in ppm per temperature bin and run.

    In every temperature bin (and run), the least-squares slope of the ``error`` on the
    ``input_rate``, with an intercept (the bias, whatever it is there), times ``1e6``: the
    error a gyro multiplies, in ppm of the input rate. Rows at zero input rate pin the
    intercept and carry no scale factor of their own: a bin whose rows all have one input
    rate (e.g. all zero) has a NaN scale factor, never a silent 0. With ``run``, the
    ``"(all runs)"`` rows pool the runs' rows of a bin, each run with its own intercept (a
    bias that moves from run to run does not bend the slope).

    Parameters
    ----------
    input_rate : array-like of shape (n_samples,)
        True input rate, deg/h (the rate table's, ``reference``).
    error : array-like of shape (n_samples,)
        The output's error, deg/h: ``rate - input_rate`` before compensation (the drift
        target ``y``), ``rate - input_rate - drift`` after.
    temperature : array-like of shape (n_samples,)
        Coil temperature, deg C.
    run : array-like of shape (n_samples,), default=None
        Run label of each row; None: one run.
    bins : int or array-like of float, default=10
        Number of equal temperature bins over the rows' range, or the bins' edges (deg C,
        increasing; the last bin holds its upper edge, rows outside the edges are in no
        bin).

    Returns
    -------
    table : pandas.DataFrame
        One row per run (in order of first appearance) and bin, then with ``run`` one per
        bin for ``"(all runs)"`` (without ``run``, those rows only), with columns ``run``,
        ``temperature`` (the bin's centre, deg C), ``T_low``, ``T_high``, ``ppm`` (NaN
        where the bin's input rates do not differ) and ``samples`` (rows in the bin).

    Raises
    ------
    ValueError
        If an array is not one finite number per row (naming it), ``run`` is not one
        label per row, or ``bins`` is not a positive count or increasing edges.
    TypeError
        If ``bins`` is neither an int nor an array of edges.

    See Also
    --------
    scale_factor_peak_to_peak : Its range over temperature.
    sklearn_ifog.plotting.plot_scale_factor : It against temperature, before and after.

    Examples
    --------
    A scale-factor error of 100 ppm below 20 °C and 300 ppm above, on a bias of 0.5 deg/h;
    the third bin holds zero input rate only:

    >>> import numpy as np
    >>> from sklearn_ifog.metrics import scale_factor_error
    >>> omega = np.tile([0.0, 3600.0, -3600.0, 36000.0], 3)
    >>> temperature = np.repeat([10.0, 30.0, 50.0], 4)
    >>> ppm = np.where(temperature < 20.0, 100.0, 300.0)
    >>> error = 0.5 + omega * ppm * 1e-6
    >>> omega[8:] = 0.0
    >>> table = scale_factor_error(omega, error, temperature, bins=[0.0, 20.0, 40.0, 60.0])
    >>> table[["temperature", "ppm", "samples"]]
       temperature    ppm  samples
    0         10.0  100.0        4
    1         30.0  300.0        4
    2         50.0    NaN        4
    """
    import pandas as pd

    edges, labels, (count, sxx, sxy, total), has_runs = _binned(
        input_rate, error, temperature, run, bins
    )
    frames = []
    rows = [(label, count[i], sxx[i], sxy[i], total[i]) for i, label in enumerate(labels)]
    if has_runs:
        rows.append((ALL_RUNS, *(values.sum(axis=0) for values in (count, sxx, sxy, total))))
    for label, n_rows, spread, cross, squares in rows:
        frames.append(
            pd.DataFrame(
                {
                    "run": [label] * n_rows.size,
                    "temperature": (edges[:-1] + edges[1:]) / 2.0,
                    "T_low": edges[:-1],
                    "T_high": edges[1:],
                    "ppm": PPM * _slope(spread, cross, squares),
                    "samples": n_rows.astype(int),
                }
            )
        )
    return pd.concat(frames, ignore_index=True)


def scale_factor_peak_to_peak(input_rate, error, temperature, *, run=None, bins=10):
    """The scale-factor error's peak-to-peak over temperature, ppm.

    The range (largest minus smallest) of the per-bin scale-factor errors of all runs
    pooled (the ``"(all runs)"`` rows of :func:`scale_factor_error`), over the bins where
    one can be read: the published figure of a gyro's scale-factor thermal sensitivity.

    Parameters
    ----------
    input_rate, error, temperature, run, bins
        As for :func:`scale_factor_error`.

    Returns
    -------
    peak_to_peak : float
        ppm; NaN when fewer than two bins have a scale factor.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.metrics import scale_factor_peak_to_peak
    >>> temperature = np.linspace(-40.0, 70.0, 1100)
    >>> omega = np.tile([0.0, 3.6e5, -3.6e5, 1.08e6], 275)
    >>> error = 0.2 + omega * 1e-6 * (200.0 + 4.0 * temperature)  # 4 ppm/degC
    >>> round(scale_factor_peak_to_peak(omega, error, temperature, bins=11))
    400
    """
    table = scale_factor_error(input_rate, error, temperature, run=run, bins=bins)
    ppm = table.loc[table["run"] == ALL_RUNS, "ppm"].to_numpy()
    ppm = ppm[np.isfinite(ppm)]
    return float(np.ptp(ppm)) if ppm.size >= 2 else float("nan")


def _rate_levels(input_rate, resolution):
    """Every row's input rate rounded to ``resolution`` (None: as given), checked."""
    if resolution is None:
        return input_rate
    if (
        isinstance(resolution, bool)
        or not isinstance(resolution, numbers.Real)
        or not np.isfinite(resolution)
        or resolution <= 0
    ):
        raise ValueError(
            f"resolution must be a positive step of input rate, deg/h, or None; got "
            f"{resolution!r}."
        )
    return np.round(input_rate / resolution) * resolution


def residual_by_input_rate(input_rate, residual, *, resolution=None):
    """The residual's root mean square at each input rate, deg/h.

    What a compensation leaves at each set point of the rate table (or, applied to
    ``rate - input_rate``, the raw error there): a scale-factor error shows as a residual
    growing with the input rate.

    Parameters
    ----------
    input_rate : array-like of shape (n_samples,)
        True input rate, deg/h.
    residual : array-like of shape (n_samples,)
        Error of every row, deg/h (``rate - input_rate - drift`` after compensation).
    resolution : float, default=None
        Rows whose input rates round to the same multiple of ``resolution`` (deg/h) are one
        input rate (for a measured, noisy reference); None: rows are grouped by their exact
        input rate (a rate table's set points).

    Returns
    -------
    table : pandas.DataFrame
        Indexed by ``input_rate`` (deg/h, increasing), with columns ``rms`` and ``mean``
        (deg/h) and ``samples``.

    Raises
    ------
    ValueError
        If an array is not one finite number per row (naming it), or ``resolution`` is not
        a positive number.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.metrics import residual_by_input_rate
    >>> omega = np.array([0.0, 0.0, 3600.0, 3600.0, -3600.0, -3600.0])
    >>> residual = np.array([0.1, -0.1, 0.3, 0.5, -0.4, -0.4])
    >>> residual_by_input_rate(omega, residual)
                rms  mean  samples
    input_rate
    -3600.0     0.4  -0.4        2
     0.0        0.1   0.0        2
     3600.0     0.4   0.4        2
    """
    import pandas as pd

    omega, residual = _columns(input_rate=input_rate, residual=residual)
    levels, group = np.unique(_rate_levels(omega, resolution), return_inverse=True)
    count = np.bincount(group, minlength=levels.size).astype(np.float64)
    table = pd.DataFrame(
        {
            "rms": np.sqrt(np.bincount(group, residual * residual, levels.size) / count),
            "mean": np.bincount(group, residual, levels.size) / count,
            "samples": count.astype(int),
        },
        index=pd.Index(levels, name="input_rate"),
    )
    return table


def scale_factor_linearity(input_rate, error, *, resolution=None):
    """The scale factor's nonlinearity, ppm of full scale.

    The mean error at every input rate, fitted by a line in the input rate (least squares,
    one point per input rate): the largest deviation of a mean from the line, divided by
    the largest input rate in magnitude (the full scale), times ``1e6``. A gyro whose error
    is ``b + Ω s`` at every input rate has a linearity of 0.

    Parameters
    ----------
    input_rate : array-like of shape (n_samples,)
        True input rate, deg/h.
    error : array-like of shape (n_samples,)
        The output's error, deg/h (``rate - input_rate``, or a compensation's residual).
    resolution : float, default=None
        As for :func:`residual_by_input_rate`.

    Returns
    -------
    linearity : float
        ppm of full scale; NaN with fewer than two input rates or none but zero.

    Examples
    --------
    The error at 360000 deg/h (100 deg/s) lies 3.6 deg/h above the line through the
    others; the best line through all five misses the means by at most 1.1 deg/h, about
    3 ppm of the full scale:

    >>> import numpy as np
    >>> from sklearn_ifog.metrics import scale_factor_linearity
    >>> omega = np.array([-3.6e5, -3.6e4, 0.0, 3.6e4, 3.6e5])
    >>> error = 1e-4 * omega + np.array([0.0, 0.0, 0.0, 0.0, 3.6])
    >>> round(scale_factor_linearity(omega, error), 2)
    3.05
    """
    omega, error = _columns(input_rate=input_rate, error=error)
    means = residual_by_input_rate(omega, error, resolution=resolution)
    levels, mean = means.index.to_numpy(dtype=np.float64), means["mean"].to_numpy()
    full_scale = float(np.max(np.abs(levels)))
    if levels.size < 2 or full_scale == 0.0:
        return float("nan")
    design = np.column_stack([np.ones_like(levels), levels / full_scale])
    coef = np.linalg.lstsq(design, mean, rcond=None)[0]
    return float(PPM * np.max(np.abs(mean - design @ coef)) / full_scale)


def _side_slope(omega, error):
    """The least-squares slope of ``error`` on ``omega`` (NaN where ``omega`` is constant)."""
    if omega.size == 0:
        return float("nan")
    d_omega = omega - omega.mean()
    sxx = float(d_omega @ d_omega)
    return float(_slope(sxx, float(d_omega @ (error - error.mean())), float(omega @ omega))[0])


def scale_factor_asymmetry(input_rate, error):
    """The scale factor's asymmetry: positive inputs' scale-factor error minus negative's, ppm.

    The least-squares slope of the error on the input rate (with an intercept) over the
    rows of non-negative input rate, minus the same over the rows of non-positive input
    rate, times ``1e6``; rows at zero input rate pin both sides' intercept.

    Parameters
    ----------
    input_rate : array-like of shape (n_samples,)
        True input rate, deg/h.
    error : array-like of shape (n_samples,)
        The output's error, deg/h.

    Returns
    -------
    asymmetry : float
        ppm; NaN when either side has a single input rate (e.g. only positive inputs).

    Examples
    --------
    120 ppm for positive inputs, 100 ppm for negative ones:

    >>> import numpy as np
    >>> from sklearn_ifog.metrics import scale_factor_asymmetry
    >>> omega = np.array([-3.6e5, -3.6e4, 0.0, 3.6e4, 3.6e5])
    >>> error = 0.3 + omega * np.where(omega > 0, 120e-6, 100e-6)
    >>> round(scale_factor_asymmetry(omega, error), 6)
    20.0
    """
    omega, error = _columns(input_rate=input_rate, error=error)
    positive, negative = omega >= 0, omega <= 0
    return PPM * (
        _side_slope(omega[positive], error[positive])
        - _side_slope(omega[negative], error[negative])
    )
