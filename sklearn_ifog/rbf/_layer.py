"""What the rest of the package reads of a fitted RBF network, below the estimator.

:class:`~sklearn_ifog.RBFNetRegressor` derives from :class:`GaussianNetworkLayer`, so the
modules that read a fitted network's output layer (partial pooling, the compiled online
path, the exports) recognise it and read it with :func:`network_of` without standing on the
estimator and its whole fitting machinery (issue 43, point 8: the house's floors).
"""

import numpy as np
from sklearn.utils.validation import check_is_fitted

from sklearn_ifog.rbf._basis import Network

__all__ = ["GaussianNetworkLayer", "is_network_layer", "network_of"]


class GaussianNetworkLayer:
    """Mixin of an estimator whose fitted output layer is one Gaussian RBF network.

    Its fitted attributes are ``centers_``, ``widths_``, ``coef_``, ``tail_coef_``,
    ``intercept_``, ``x_mean_``, ``x_scale_`` and ``n_features_in_``, and ``predict``
    evaluates :func:`network_of` on ``(X - x_mean_) / x_scale_``.
    """


def is_network_layer(regressor, *, exact):
    """Whether ``regressor`` is a network layer estimator (:class:`GaussianNetworkLayer`).

    Parameters
    ----------
    regressor : object
        Any object.
    exact : bool
        True: only a class that derives from the mixin directly (RBFNetRegressor itself,
        not a subclass of it, which may change ``predict``), as the exports and the
        compiled path require; False: subclasses too (partial pooling).

    Returns
    -------
    is_layer : bool

    Examples
    --------
    >>> from sklearn_ifog import RBFNetRegressor
    >>> class Tuned(RBFNetRegressor):
    ...     pass
    >>> is_network_layer(RBFNetRegressor(), exact=True), is_network_layer(Tuned(), exact=True)
    (True, False)
    >>> is_network_layer(Tuned(), exact=False), is_network_layer(object(), exact=False)
    (True, False)
    """
    if exact:
        return GaussianNetworkLayer in type(regressor).__bases__
    return isinstance(regressor, GaussianNetworkLayer)


def network_of(regressor):
    """The fitted network of an ``RBFNetRegressor``, as one ``Network`` record.

    The network (a :class:`~sklearn_ifog.rbf._basis.Network`) on the standardised inputs
    ``(X - x_mean_) / x_scale_``, with 2-D weights (one row per output, even when ``y`` was
    1-D) and a zero linear tail when the fitted one has none. It is what ``predict``
    evaluates, and it serves several modules that read a fitted network: partial pooling
    (``unitwise``), the compiled online path (``_compiled``) and the exports (``export``).
    A private module's function rather than a public method, because ``Network`` is an
    internal record of the package, not part of its public API.

    Parameters
    ----------
    regressor : RBFNetRegressor
        A fitted network regressor.

    Returns
    -------
    network : Network
        Its ``centers``, ``widths``, ``coef`` (n_outputs, n_centers), ``tail_coef``
        (n_outputs, n_tail) and ``intercept`` (n_outputs,).

    Raises
    ------
    sklearn.exceptions.NotFittedError
        When ``regressor`` is not fitted.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog import RBFNetRegressor
    >>> X = np.linspace(-1, 1, 200)[:, None]
    >>> model = RBFNetRegressor(refine=None, random_state=0).fit(X, np.sin(3 * X[:, 0]))
    >>> network = network_of(model)
    >>> network.coef.shape == (1, model.centers_.shape[0])
    True
    >>> Z = (X - model.x_mean_) / model.x_scale_
    >>> bool(np.array_equal(network.predict(Z)[:, 0], model.predict(X)))
    True
    """
    check_is_fitted(regressor)
    return _as_network(regressor)


def _as_network(regressor):
    """:func:`network_of` without the fitted check (the caller has made it)."""
    coef = np.atleast_2d(np.asarray(regressor.coef_, dtype=np.float64))
    n_outputs = coef.shape[0]
    return Network(
        centers=np.asarray(regressor.centers_, dtype=np.float64).reshape(
            -1, regressor.n_features_in_
        ),
        widths=np.broadcast_to(np.asarray(regressor.widths_, dtype=np.float64), coef.shape[1:]),
        coef=coef,
        tail_coef=np.asarray(regressor.tail_coef_, dtype=np.float64).reshape(n_outputs, -1),
        intercept=np.broadcast_to(
            np.asarray(regressor.intercept_, dtype=np.float64), (n_outputs,)
        ),
    )
