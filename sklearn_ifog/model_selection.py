"""Cross-validation across units, azimuths and runs.

A thermal-test campaign nests runs inside (unit, azimuth) pairs, so the honest questions are
"does a model trained on these runs compensate a run it has not seen?" (leave-one-run-out),
"... the same gyro at another heading?" (leave-one-azimuth-out, within a unit) and "... another
gyro?" (leave-one-unit-out). The splitters here answer them. They are ordinary scikit-learn
cross-validators: they take the labels from the columns of ``X`` when ``X`` is a DataFrame
(the run id travels inside X as a column), or from ``groups``, and work anywhere a
``cv=`` is accepted (:class:`~sklearn.model_selection.GridSearchCV`,
:func:`~sklearn.model_selection.cross_validate`,
:func:`~sklearn_ifog.comparison.compare_regressors`). A run never straddles two folds: the
unit and azimuth splitters check that every run of ``X`` has one unit and one azimuth.

Running on a Dask cluster
-------------------------
Every fit of a search goes through joblib, so a Dask cluster takes the work without code
changes: connect a :class:`distributed.Client` and wrap the call in joblib's ``"dask"``
backend::

    import joblib
    from distributed import Client
    from sklearn.model_selection import GridSearchCV

    client = Client("tcp://scheduler:8786")  # or Client(LocalCluster()) on one machine
    with joblib.parallel_backend("dask"):
        search = GridSearchCV(pipe, grid, cv=LeaveOneRunOut(), n_jobs=-1).fit(X, y)

The workers need ``sklearn-ifog`` installed (same version as the client). The results are
the same as with the default backend: each fit is seeded by ``random_state``, not by where it
runs. For large campaigns, ship the data to the workers once rather than with every task:
``joblib.parallel_backend("dask", scatter=[X, y])``.
"""

import numpy as np
from sklearn.model_selection import BaseCrossValidator

from sklearn_ifog import _table
from sklearn_ifog._compat import GroupsConsumerMixin

__all__ = ["LeaveOneAzimuthOut", "LeaveOneRunOut", "LeaveOneUnitOut"]


def _column_values(X, key):
    """Values of column ``key`` (name or position) of ``X``, or None if X has no such column."""
    position = _table.find_column(X, key)
    return None if position is None else np.asarray(_table.column_at(X, position))


def _labels_1d(values, *, name):
    values = np.asarray(values)
    if values.ndim != 1:
        raise ValueError(f"{name} labels must be 1-D, got shape {values.shape}.")
    if values.dtype.kind == "f" and np.isnan(values).any():
        raise ValueError(f"{name} labels contain NaN; every row needs a {name}.")
    return values


class _LeaveOneLabelOut(GroupsConsumerMixin, BaseCrossValidator):
    """Leave out one label at a time, optionally within each unit (shared machinery).

    Subclasses set ``_label_name`` (the attribute holding the label column) and
    ``_within_unit`` (whether folds stay inside one unit).
    """

    _label_name = ""

    def _within(self):
        return False

    def _labels(self, X, groups):
        """(labels, units or None) of every row, validated."""
        n_samples = None if X is None else (X.shape[0] if hasattr(X, "shape") else len(X))
        label_column = getattr(self, self._label_name)
        what = self._label_name
        if groups is not None:
            labels = _labels_1d(groups, name=what)
        else:
            labels = _column_values(X, label_column)
            if labels is None:
                columns = list(getattr(X, "columns", []))
                raise ValueError(
                    f"{type(self).__name__} needs the {what} of every row: X has no column "
                    f"{label_column!r} (columns: {columns}) and groups is None. Pass a "
                    f"DataFrame with that column, set {what}= to its name or position, or "
                    "pass groups=."
                )
            labels = _labels_1d(labels, name=what)
        if n_samples is not None and labels.shape[0] != n_samples:
            raise ValueError(
                f"{what} labels have {labels.shape[0]} values but X has {n_samples} rows."
            )
        units = None
        if self._within():
            units = _column_values(X, self.unit)
            if units is None:
                raise ValueError(
                    f"{type(self).__name__}(within_unit=True) needs the unit of every row: X "
                    f"has no column {self.unit!r}. For data from one unit, pass "
                    "within_unit=False (the folds are the same)."
                )
            units = _labels_1d(units, name="unit")
        self._check_runs_nested(X, labels, units)
        return labels, units

    def _check_runs_nested(self, X, labels, units):
        """Raise if a run of X spans several labels (or units): it would straddle folds."""
        run_column = getattr(self, "run", None)
        runs = _column_values(X, run_column)
        if runs is None:
            return
        runs = _labels_1d(runs, name="run")
        checks = [(units, "unit")]
        if self._label_name != "run":
            checks.insert(0, (labels, self._label_name))
        run_ids, run_codes = np.unique(runs, return_inverse=True)
        for values, what in checks:
            if values is None:
                continue
            names, codes = np.unique(values, return_inverse=True)
            pairs = np.unique(run_codes.ravel() * names.size + codes.ravel())
            per_run = np.bincount(pairs // names.size, minlength=run_ids.size)
            if (per_run > 1).any():
                bad = int(np.flatnonzero(per_run > 1)[0])
                seen = names[pairs[pairs // names.size == bad] % names.size]
                raise ValueError(
                    f"Run {run_ids[bad]} spans several {what}s "
                    f"({', '.join(str(value) for value in seen.tolist())}): a run must belong "
                    f"to one {what}, or it would straddle two folds. Check the {run_column!r} "
                    f"and {what} columns."
                )

    def _folds(self, labels, units):
        """Boolean (train, test) masks, fold by fold."""
        if units is None:
            blocks = [np.ones(labels.shape[0], dtype=bool)]
        else:
            blocks = [units == unit for unit in np.unique(units)]
        folds = []
        for block in blocks:
            block_labels = np.unique(labels[block])
            if block_labels.size < 2:
                continue
            for label in block_labels:
                test = block & (labels == label)
                folds.append((block & ~test, test))
        if not folds:
            where = " within any unit" if units is not None else ""
            raise ValueError(
                f"{type(self).__name__} needs at least 2 distinct {self._label_name}s"
                f"{where}; got {np.unique(labels).tolist()}."
            )
        return folds

    def split(self, X, y=None, groups=None):
        """Generate indices to split data into training and test set.

        Parameters
        ----------
        X : DataFrame or array-like of shape (n_samples, n_columns)
            Training data; the label columns are read from it when ``groups`` is None.
        y : array-like of shape (n_samples,), default=None
            Ignored, for API compatibility.
        groups : array-like of shape (n_samples,), default=None
            Labels of the left-out quantity; overrides the column of ``X``.

        Yields
        ------
        train : ndarray
            The training set indices for that split.
        test : ndarray
            The testing set indices for that split.
        """
        labels, units = self._labels(X, groups)
        for train, test in self._folds(labels, units):
            yield np.flatnonzero(train), np.flatnonzero(test)

    def get_n_splits(self, X=None, y=None, groups=None):
        """Number of splitting iterations.

        Parameters
        ----------
        X : DataFrame or array-like of shape (n_samples, n_columns), default=None
            Data to read the label columns from when ``groups`` is None.
        y : array-like of shape (n_samples,), default=None
            Ignored, for API compatibility.
        groups : array-like of shape (n_samples,), default=None
            Labels of the left-out quantity; overrides the column of ``X``.

        Returns
        -------
        n_splits : int
            Number of folds.
        """
        labels, units = self._labels(X, groups)
        return len(self._folds(labels, units))


class LeaveOneUnitOut(_LeaveOneLabelOut):
    """Leave-one-unit-out cross-validator: train on the other gyros, test on one.

    Each fold tests on every row of one unit and trains on all the others. Labels come from
    the ``unit`` column of ``X`` (a DataFrame, or an array with ``unit`` an integer
    position) or from ``groups``. When ``X`` has the ``run`` column, every run must belong to
    one unit (else a ValueError), so no run straddles two folds.

    Parameters
    ----------
    unit : str or int, default="unit"
        Column of ``X`` holding the unit id.
    run : str, int or None, default="run"
        Column of ``X`` holding the run id, for the nesting check; None skips the check.

    See Also
    --------
    LeaveOneAzimuthOut : Leave one azimuth out, within each unit.
    LeaveOneRunOut : Leave one run out.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn_ifog.model_selection import LeaveOneUnitOut
    >>> X = pd.DataFrame({"unit": [1, 1, 2, 2], "run": [0, 1, 2, 3], "temperature": 20.0})
    >>> cv = LeaveOneUnitOut()
    >>> cv.get_n_splits(X)
    2
    >>> [test.tolist() for _, test in cv.split(X)]
    [[0, 1], [2, 3]]
    """

    _label_name = "unit"

    def __init__(self, *, unit="unit", run="run"):
        self.unit = unit
        self.run = run


class LeaveOneAzimuthOut(_LeaveOneLabelOut):
    """Leave-one-azimuth-out cross-validator, within each unit by default.

    With ``within_unit=True`` each fold tests on the rows of one (unit, azimuth) pair and
    trains on the same unit's other azimuths: a gyro's compensation is calibrated at some
    headings and checked at another, as in the reference paper's Table 2 (train at 0°, test
    at 90°). Units with a single azimuth give no fold. With ``within_unit=False`` the folds
    pool all units: test on one azimuth, train on every other azimuth of every unit.

    Labels come from the ``azimuth`` (and ``unit``) columns of ``X``, or the azimuths from
    ``groups``. When ``X`` has the ``run`` column, every run must have one azimuth and one
    unit (else a ValueError), so no run straddles two folds.

    Parameters
    ----------
    unit : str or int, default="unit"
        Column of ``X`` holding the unit id (used when ``within_unit=True``).
    azimuth : str or int, default="azimuth"
        Column of ``X`` holding the azimuth (deg).
    run : str, int or None, default="run"
        Column of ``X`` holding the run id, for the nesting check; None skips the check.
    within_unit : bool, default=True
        Whether a fold trains only on the test unit's other azimuths.

    See Also
    --------
    LeaveOneUnitOut : Leave one unit out.
    LeaveOneRunOut : Leave one run out.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn_ifog.model_selection import LeaveOneAzimuthOut
    >>> X = pd.DataFrame(
    ...     {
    ...         "unit": [1, 1, 1, 2, 2],
    ...         "azimuth": [0.0, 0.0, 90.0, 0.0, 45.0],
    ...         "run": [0, 1, 2, 3, 4],
    ...     }
    ... )
    >>> for train, test in LeaveOneAzimuthOut().split(X):
    ...     print(train.tolist(), test.tolist())
    [2] [0, 1]
    [0, 1] [2]
    [4] [3]
    [3] [4]
    """

    _label_name = "azimuth"

    def __init__(self, *, unit="unit", azimuth="azimuth", run="run", within_unit=True):
        self.unit = unit
        self.azimuth = azimuth
        self.run = run
        self.within_unit = within_unit

    def _within(self):
        return bool(self.within_unit)


class LeaveOneRunOut(_LeaveOneLabelOut):
    """Leave-one-run-out cross-validator: test on one whole run, train on the others.

    Rows of one run always land in the same fold. With ``within_unit=True`` a fold trains
    only on the other runs of the test run's unit (a per-gyro calibration); by default it
    trains on every other run.

    Parameters
    ----------
    run : str or int, default="run"
        Column of ``X`` holding the run id.
    unit : str or int, default="unit"
        Column of ``X`` holding the unit id (used when ``within_unit=True``).
    within_unit : bool, default=False
        Whether a fold trains only on runs of the test run's unit.

    See Also
    --------
    LeaveOneUnitOut : Leave one unit out.
    LeaveOneAzimuthOut : Leave one azimuth out, within each unit.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.model_selection import LeaveOneRunOut
    >>> X = np.array([[0, 21.0], [0, 21.5], [1, 22.0], [2, 22.5]])
    >>> [test.tolist() for _, test in LeaveOneRunOut(run=0).split(X)]
    [[0, 1], [2], [3]]
    """

    _label_name = "run"

    def __init__(self, *, run="run", unit="unit", within_unit=False):
        self.run = run
        self.unit = unit
        self.within_unit = within_unit

    def _within(self):
        return bool(self.within_unit)
