"""A meta-estimator that fits a regressor on a random subsample of the rows.

:class:`SubsampledRegressor` makes the exact kernel methods (Gaussian processes, kernel ridge,
SVR), whose cost grows with the square or the cube of the number of rows, usable as baselines
on thermal tests of tens of thousands of samples;
:func:`~sklearn_ifog.comparison.default_regressors` wraps its kernel baselines in it. It wraps
any regressor and is not a cross-validation tool, hence a module of its own.
"""

import numbers
from typing import ClassVar

import numpy as np
from sklearn.base import BaseEstimator, MetaEstimatorMixin, RegressorMixin, clone
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.utils import check_random_state, get_tags
from sklearn.utils.validation import check_is_fitted, validate_data

from sklearn_ifog._compat import HasMethods, Interval, _fit_context

__all__ = ["SubsampledRegressor"]


class SubsampledRegressor(MetaEstimatorMixin, RegressorMixin, BaseEstimator):
    """Fit a regressor on a random subsample of at most ``max_samples`` rows.

    Exact kernel methods (Gaussian processes, kernel ridge, SVR) cost O(n²) memory and up to
    O(n³) time; a thermal test logs tens of thousands of samples. This wrapper fits a clone
    of ``estimator`` on a uniform random subsample without replacement (rows kept in their
    original order) and predicts with it. Put it *after* the feature step of a pipeline:
    ΔT needs consecutive rows.

    Parameters
    ----------
    estimator : estimator object, default=None
        The regressor to fit. None means
        :class:`~sklearn.gaussian_process.GaussianProcessRegressor`.
    max_samples : int, default=1000
        Largest number of rows the estimator is fitted on; all rows when there are fewer.
    random_state : int, RandomState instance or None, default=None
        Draws the subsample. Pass an int for reproducible results.

    Attributes
    ----------
    estimator_ : estimator
        The fitted clone of ``estimator``.
    sample_indices_ : ndarray of shape (n_fitted,)
        Rows of the training data the estimator was fitted on, increasing.
    n_features_in_ : int
        Number of features seen during fit.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of features seen during fit, when X has string column names.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog.subsampled import SubsampledRegressor
    >>> X = np.arange(100.0).reshape(-1, 1)
    >>> model = SubsampledRegressor(LinearRegression(), max_samples=10, random_state=0)
    >>> model.fit(X, 2 * X[:, 0]).sample_indices_.shape
    (10,)
    >>> model.predict([[200.0]]).round(6)
    array([400.])
    """

    _parameter_constraints: ClassVar[dict] = {
        "estimator": [HasMethods(["fit", "predict"]), None],
        "max_samples": [Interval(numbers.Integral, 1, None, closed="left")],
        "random_state": ["random_state"],
    }

    def __init__(self, estimator=None, *, max_samples=1000, random_state=None):
        self.estimator = estimator
        self.max_samples = max_samples
        self.random_state = random_state

    def _base_estimator(self):
        return GaussianProcessRegressor() if self.estimator is None else self.estimator

    @_fit_context(
        # The wrapped estimator validates its own parameters.
        prefer_skip_nested_validation=False
    )
    def fit(self, X, y):
        """Fit the estimator on a random subsample of the rows.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Training data.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Target values.

        Returns
        -------
        self : object
            Fitted estimator.
        """
        X, y = validate_data(self, X, y, y_numeric=True, multi_output=True)
        n_samples = X.shape[0]
        if n_samples > self.max_samples:
            rng = check_random_state(self.random_state)
            indices = np.sort(rng.choice(n_samples, size=self.max_samples, replace=False))
        else:
            indices = np.arange(n_samples)
        self.sample_indices_ = indices
        self.estimator_ = clone(self._base_estimator()).fit(X[indices], y[indices])
        return self

    def predict(self, X):
        """Predict with the estimator fitted on the subsample.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Samples.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Predicted values.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        return self.estimator_.predict(X)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        inner = get_tags(self._base_estimator())
        tags.target_tags.multi_output = inner.target_tags.multi_output
        tags.non_deterministic = inner.non_deterministic
        return tags
