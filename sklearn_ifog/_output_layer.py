"""The linear output layer of a fitted final regressor: which regressors have one, its
weights, its design, and a copy of a model with new weights.

A final regressor whose prediction is linear in known columns of its input has an *output
layer*: ``prediction = design(X) @ weights``, the intercept's column (ones) last. Two kinds
are known: a linear model of :data:`LINEAR_REGRESSORS` (the design: its inputs, then 1) and
:class:`~sklearn_ifog.RBFNetRegressor` (the Gaussian activations of the standardised
inputs, the polynomial tail, then 1). :func:`read_layer` reads one as an
:class:`OutputLayer` record.

A private module that serves several: partial pooling (:mod:`sklearn_ifog.unitwise` and
:mod:`sklearn_ifog._pooling`: the layer's design and weights, :func:`layer_design` /
:func:`layer_weights`, and :func:`with_weights` to write the shrunk weights back), the
compiled fast path (:mod:`sklearn_ifog._compiled`, which evaluates the layer and gives its
design to the online recalibration of :mod:`sklearn_ifog.streaming`), and the pipeline's
description (:mod:`sklearn_ifog._description`) that both exports write.

Two views of an RBF network's tail, kept apart on purpose: the network stores a tail of
zeros (width ``n_features``, degree 1) when it was fitted without one. The layer as stored
(:attr:`OutputLayer.weights`, what the compiled path, the recalibration and the exports
use) carries those zero columns, so ``adapt="output"`` may move them; partial pooling
shrinks only what the network fitted (:func:`layer_weights`: no tail columns then).
"""

import copy
from typing import NamedTuple

import numpy as np
from sklearn import linear_model
from sklearn.pipeline import Pipeline

from sklearn_ifog.rbf._basis import Network, gaussian_design, tail_features
from sklearn_ifog.rbf._layer import is_network_layer, network_of

__all__ = [
    "LINEAR_REGRESSORS",
    "OutputLayer",
    "final_step",
    "has_output_layer",
    "layer_design",
    "layer_kind",
    "layer_weights",
    "read_layer",
    "with_weights",
    "write_weights",
]

#: Linear regressors whose ``predict`` is exactly ``X @ coef_.T + intercept_``: the ones the
#: exports write, the compiled path evaluates, the recalibration adapts and partial pooling
#: shrinks (with :class:`~sklearn_ifog.RBFNetRegressor`).
LINEAR_REGRESSORS = (
    linear_model.LinearRegression,
    linear_model.Ridge,
    linear_model.RidgeCV,
    linear_model.Lasso,
    linear_model.LassoCV,
    linear_model.ElasticNet,
    linear_model.ElasticNetCV,
    linear_model.Lars,
    linear_model.LassoLars,
    linear_model.BayesianRidge,
    linear_model.ARDRegression,
    linear_model.HuberRegressor,
    linear_model.SGDRegressor,
    linear_model.QuantileRegressor,
    linear_model.TheilSenRegressor,
)


class OutputLayer(NamedTuple):
    """The output layer of a fitted final regressor (see the module docstring).

    Attributes
    ----------
    kind : {"linear", "rbf_network"}
        A linear model, or an RBF network.
    coef : ndarray of shape (n_outputs, n_basis)
        A linear model's input weights; the network's Gaussian weights.
    tail_coef : ndarray of shape (n_outputs, n_tail)
        The network's tail weights as stored (a network fitted without a tail stores zeros
        of width ``n_features``); width 0 for a linear model.
    intercept : ndarray of shape (n_outputs,)
        The intercepts.
    single_output : bool
        Whether the regressor's ``coef_`` is 1-D (its ``predict`` gives a 1-D array).
    tail_degree : int, default=0
        Degree of the stored tail (``tail_coef``'s columns: 1 for a network fitted without
        a tail); 0 for a linear model.
    fitted_tail_degree : int, default=0
        The network's fitted ``tail_degree_`` (0: fitted without a tail); 0 for a linear
        model.
    network : Network or None, default=None
        The network on standardised inputs (None for a linear model).
    x_mean, x_scale : ndarray of shape (n_features,) or None, default=None
        The network's input standardisation, ``z = (x - x_mean) / x_scale``, as fitted.
    """

    kind: str
    coef: np.ndarray
    tail_coef: np.ndarray
    intercept: np.ndarray
    single_output: bool
    tail_degree: int = 0
    fitted_tail_degree: int = 0
    network: Network | None = None
    x_mean: np.ndarray | None = None
    x_scale: np.ndarray | None = None

    @property
    def n_outputs(self):
        """Outputs of the regressor."""
        return self.coef.shape[0]

    @property
    def weights(self):
        """The stored layer's weights, ``(n_basis + n_tail + 1, n_outputs)``, intercept last.

        The rows of the design ``[basis, tail as stored, 1]`` (a new array).
        """
        return np.vstack([self.coef.T, self.tail_coef.T, self.intercept[None]])


def final_step(estimator):
    """The last estimator of a Pipeline (the estimator itself otherwise)."""
    return estimator.steps[-1][1] if isinstance(estimator, Pipeline) else estimator


def layer_kind(regressor):
    """``"rbf_network"``, ``"linear"`` or None: the kind of ``regressor``'s output layer.

    By exact type, as the exports and the compiled path require (a subclass may change
    ``predict``): :class:`~sklearn_ifog.RBFNetRegressor`, one of :data:`LINEAR_REGRESSORS`.
    """
    if is_network_layer(regressor, exact=True):
        return "rbf_network"
    if type(regressor) in LINEAR_REGRESSORS:
        return "linear"
    return None


def has_output_layer(regressor):
    """Whether partial pooling can shrink ``regressor``'s output layer (subclasses too)."""
    return is_network_layer(regressor, exact=False) or isinstance(regressor, LINEAR_REGRESSORS)


def supported_names():
    """The classes with an output layer, by name, for error messages."""
    return ", ".join(["RBFNetRegressor", *(cls.__name__ for cls in LINEAR_REGRESSORS)])


def read_layer(final):
    """The output layer of a fitted final regressor.

    Parameters
    ----------
    final : RBFNetRegressor or linear regressor
        Fitted (a linear regressor: any with ``coef_`` and ``intercept_``).

    Returns
    -------
    layer : OutputLayer

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog._output_layer import read_layer
    >>> X = np.arange(4.0).reshape(-1, 1)
    >>> layer = read_layer(LinearRegression().fit(X, 2 * X[:, 0] + 1))
    >>> layer.kind, layer.single_output, layer.weights.round(6).ravel().tolist()
    ('linear', True, [2.0, 1.0])
    """
    single_output = np.ndim(final.coef_) == 1
    if is_network_layer(final, exact=False):
        network = network_of(final)  # the fitted network as one value, 2-D weights
        return OutputLayer(
            kind="rbf_network",
            coef=network.coef,
            tail_coef=network.tail_coef,
            intercept=network.intercept,
            single_output=single_output,
            tail_degree=network.tail_degree,
            fitted_tail_degree=final.tail_degree_,
            network=network,
            x_mean=final.x_mean_,
            x_scale=final.x_scale_,
        )
    coef = np.atleast_2d(np.asarray(final.coef_, dtype=np.float64))
    intercept = np.broadcast_to(np.asarray(final.intercept_, dtype=np.float64), coef.shape[:1])
    return OutputLayer(
        kind="linear",
        coef=coef,
        tail_coef=np.zeros((coef.shape[0], 0)),
        intercept=intercept,
        single_output=single_output,
    )


def layer_design(final, X):
    """The output-layer design of a fitted final regressor, as partial pooling solves it.

    Parameters
    ----------
    final : RBFNetRegressor or linear regressor
        Fitted.
    X : ndarray of shape (n_samples, n_features)
        Its inputs.

    Returns
    -------
    Phi : ndarray of shape (n_samples, n_columns)
        RBF network: the Gaussian activations, the tail regressors (only with a fitted
        tail), then ones; linear model: the inputs, then ones.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog._output_layer import layer_design
    >>> X = np.arange(6.0).reshape(3, 2)
    >>> layer_design(LinearRegression().fit(X, X[:, 0]), X)[:, -1]
    array([1., 1., 1.])
    """
    ones = np.ones((X.shape[0], 1))
    if is_network_layer(final, exact=False):
        layer = read_layer(final)
        Z = (X - layer.x_mean) / layer.x_scale
        parts = [gaussian_design(Z, layer.network.centers, layer.network.widths)]
        if layer.fitted_tail_degree > 0:
            parts.append(tail_features(Z, layer.fitted_tail_degree))
        return np.hstack([*parts, ones])
    return np.hstack([X, ones])


def layer_weights(final):
    """The weights of the output layer, shape (n_columns, n_outputs), as :func:`layer_design`.

    Parameters
    ----------
    final : RBFNetRegressor or linear regressor
        Fitted.

    Returns
    -------
    W : ndarray of shape (n_columns, n_outputs)
        The Gaussian weights, the tail's (only with a fitted tail), then the intercept; a
        linear model's coefficients, then its intercept.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog._output_layer import layer_weights
    >>> X = np.arange(6.0).reshape(3, 2)
    >>> layer_weights(LinearRegression().fit(X, X[:, 0] + 1)).shape
    (3, 1)
    """
    layer = read_layer(final)
    blocks = [layer.coef]
    if layer.fitted_tail_degree > 0:
        blocks.append(layer.tail_coef)
    blocks.append(layer.intercept[:, None])
    return np.hstack(blocks).T


def with_weights(model, W):
    """A deep copy of the fitted ``model`` whose output layer has the weights ``W``.

    Parameters
    ----------
    model : estimator
        Fitted: a final regressor with an output layer, alone or last in a Pipeline.
    W : ndarray of shape (n_columns, n_outputs)
        The new weights, in the order of :func:`layer_weights` (an RBF network fitted
        without a tail gets a zero tail back).

    Returns
    -------
    model : estimator
        The copy; ``model`` itself is not changed.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog._output_layer import with_weights
    >>> X = np.arange(6.0).reshape(3, 2)
    >>> model = LinearRegression().fit(X, X[:, 0])
    >>> with_weights(model, np.array([[1.0], [2.0], [3.0]])).predict([[1.0, 1.0]])
    array([6.])
    """
    model = copy.deepcopy(model)
    write_weights(final_step(model), W)
    return model


def write_weights(final, W):
    """Write the output-layer weights ``W`` into the fitted final regressor, in place.

    As :func:`with_weights`, on ``final`` itself (the product-basis fit of
    :mod:`sklearn_ifog.scale_factor` writes its solved layer into the pipeline's step).

    Parameters
    ----------
    final : RBFNetRegressor or linear regressor
        Fitted, with as many outputs as ``W`` has columns.
    W : ndarray of shape (n_columns, n_outputs)
        In the order of :func:`layer_weights`.
    """
    one_d = np.ndim(final.coef_) == 1
    W = W.T  # (n_outputs, n_columns)
    intercept = W[:, -1]
    if is_network_layer(final, exact=False):
        n_centers = np.atleast_2d(final.coef_).shape[1]
        coef = W[:, :n_centers]
        tail = np.zeros_like(np.atleast_2d(final.tail_coef_))
        if final.tail_degree_ > 0:
            tail = W[:, n_centers:-1]
        final.coef_ = coef[0].copy() if one_d else coef.copy()
        final.tail_coef_ = tail[0].copy() if one_d else tail.copy()
    else:
        coef = W[:, :-1]
        final.coef_ = coef[0].copy() if one_d else coef.copy()
    final.intercept_ = float(intercept[0]) if np.ndim(final.intercept_) == 0 else intercept.copy()
