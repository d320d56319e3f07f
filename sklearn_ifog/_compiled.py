"""A fitted Pipeline's steps after ThermalFeatures, compiled to plain numpy arithmetic.

:func:`compile_steps` reads the fitted parameters once (the export schema of
:func:`sklearn_ifog.export._spec.describe_pipeline`: scalers, PolynomialFeatures, a linear
regressor or :class:`~sklearn_ifog.RBFNetRegressor`) and returns a :class:`CompiledSteps` that
evaluates them without scikit-learn's per-call validation: on a block of rows with the same
operations as the estimators (so a whole run gives ``pipeline.predict`` bit for bit), and on
one row with the fewest numpy calls. It also gives the final regressor's *output-layer
design* (the columns its prediction is linear in: the Gaussian activations, the tail and 1
of the RBF network; the inputs and 1 of a linear model) and its weights, for online
recalibration. A Pipeline with a step this module does not know is not compiled
(:func:`compile_steps` returns None) and the caller keeps scikit-learn's path.
"""

import numpy as np

from sklearn_ifog.rbf._basis import predict_network, tail_features

__all__ = ["CompiledSteps", "compile_steps"]


def _center_scale(spec):
    center = np.asarray(spec["center"], dtype=np.float64)
    scale = np.asarray(spec["scale"], dtype=np.float64)

    def apply(X):
        X = X - center
        X /= scale
        return X

    return apply


def _multiply_add(spec):
    multiply = np.asarray(spec["multiply"], dtype=np.float64)
    add = np.asarray(spec["add"], dtype=np.float64)
    clip = spec["clip"]

    def apply(X):
        X = X * multiply
        X += add
        if clip is not None:
            np.clip(X, clip[0], clip[1], out=X)
        return X

    return apply


def _polynomial(spec):
    powers = np.asarray(spec["powers"], dtype=int)
    # Each output column as the product of its factors, left to right: one multiplication
    # for every degree-2 monomial, as scikit-learn's PolynomialFeatures computes it.
    factors = [np.repeat(np.arange(powers.shape[1]), row) for row in powers]

    def apply(X):
        out = np.empty((X.shape[0], len(factors)))
        for column, columns in enumerate(factors):
            if columns.size == 0:
                out[:, column] = 1.0
            elif columns.size == 1:
                out[:, column] = X[:, columns[0]]
            else:
                product = X[:, columns[0]] * X[:, columns[1]]
                for extra in columns[2:]:
                    product = product * X[:, extra]
                out[:, column] = product
        return out

    return apply


_TRANSFORMS = {
    "center_scale": _center_scale,
    "multiply_add": _multiply_add,
    "polynomial": _polynomial,
}


class _Linear:
    """``y = X @ coef.T + intercept`` as scikit-learn's linear models compute it."""

    kind = "linear"

    def __init__(self, regressor):
        self.coef = np.asarray(regressor.coef_, dtype=np.float64)
        self.intercept = np.asarray(regressor.intercept_, dtype=np.float64)
        coef2 = np.atleast_2d(self.coef)
        self.n_outputs = coef2.shape[0]
        # Output layer: the inputs, then 1.
        self.weights = np.vstack([coef2.T, np.broadcast_to(self.intercept, (self.n_outputs,))])
        self.bias_index = self.weights.shape[0] - 1

    def predict(self, X):
        Y = X @ self.coef.T + self.intercept
        return Y.reshape(X.shape[0], -1)

    def design(self, X):
        return np.hstack([X, np.ones((X.shape[0], 1))])


class _Network:
    """An RBFNetRegressor's network, its output layer ``[phi(z), t(z), 1]``."""

    kind = "rbf_network"

    def __init__(self, regressor):
        network = regressor._network()
        self.network = network
        self.x_mean = np.asarray(regressor.x_mean_, dtype=np.float64)
        self.x_scale = np.asarray(regressor.x_scale_, dtype=np.float64)
        self.centers = network.centers
        self.gain = -0.5 / np.square(network.widths)
        self.degree = network.tail_degree
        self.n_outputs = network.coef.shape[0]
        self.weights = np.vstack([network.coef.T, network.tail_coef.T, network.intercept[None]])
        self.bias_index = self.weights.shape[0] - 1
        n_inputs = self.centers.shape[1]
        self.first, self.second = np.triu_indices(n_inputs)

    def standardise(self, X):
        return (X - self.x_mean) / self.x_scale

    def predict(self, X):
        # As RBFNetRegressor.predict: the same function on the same standardised inputs.
        return predict_network(self.standardise(X), *self.network)

    def design(self, X):
        Z = self.standardise(X)
        diff = Z[:, None, :] - self.centers
        diff *= diff
        phi = diff.sum(axis=2)
        phi *= self.gain
        np.exp(phi, out=phi)
        return np.hstack([phi, tail_features(Z, self.degree), np.ones((Z.shape[0], 1))])

    def predict_row(self, x):
        """One row (1-D ``x``): the small-batch formula of the network, fewest calls."""
        z = (x - self.x_mean) / self.x_scale
        diff = z - self.centers
        diff *= diff
        phi = diff.sum(axis=1)
        phi *= self.gain
        np.exp(phi, out=phi)
        network = self.network
        out = network.coef @ phi
        if self.degree:
            n_inputs = z.shape[0]
            out += network.tail_coef[:, :n_inputs] @ z
            if self.degree == 2:
                out += network.tail_coef[:, n_inputs:] @ (z[self.first] * z[self.second])
        out += network.intercept
        return out


class CompiledSteps:
    """The steps after ThermalFeatures as plain functions (see the module docstring).

    Attributes
    ----------
    final : object
        The final regressor's evaluator (``predict``, ``design``, ``weights``,
        ``bias_index``, ``n_outputs``).
    single_output : bool
        The Pipeline predicts a 1-D array.
    """

    def __init__(self, transforms, final, single_output):
        self.transforms = transforms
        self.final = final
        self.single_output = single_output

    def transform(self, X):
        """Rows through the transformers (before the final regressor)."""
        for apply in self.transforms:
            X = apply(X)
        return X

    def predict(self, features):
        """Drift of feature rows, shape ``(n_samples, n_outputs)``."""
        return self.final.predict(self.transform(features))

    def design(self, features):
        """Output-layer design rows of the final regressor, ``(n_samples, n_weights)``."""
        return self.final.design(self.transform(features))

    def predict_row(self, feature_row):
        """Drift of one feature row (1-D), shape ``(n_outputs,)``."""
        x = feature_row
        for apply in self.transforms:
            x = apply(x[None])[0]
        if self.final.kind == "rbf_network":
            return self.final.predict_row(x)
        return self.final.predict(x[None])[0]


def compile_steps(pipeline):
    """Compile a fitted compensation Pipeline's steps after ThermalFeatures.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline
        Fitted: ThermalFeatures, then steps the exporters know.

    Returns
    -------
    compiled : CompiledSteps or None
        None when a step is of a kind the exporters do not know (the caller then evaluates
        the Pipeline with scikit-learn).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn.preprocessing import StandardScaler
    >>> from sklearn_ifog import ThermalFeatures
    >>> from sklearn_ifog._compiled import compile_steps
    >>> X = np.column_stack([np.arange(6.0), 20 + np.arange(6.0) ** 2 / 10])
    >>> model = make_pipeline(
    ...     ThermalFeatures(temperature=1, time=0), StandardScaler(), LinearRegression()
    ... ).fit(X, X[:, 1])
    >>> compiled = compile_steps(model)
    >>> bool(np.allclose(compiled.predict(model[0].transform(X))[:, 0], model.predict(X)))
    True
    """
    from sklearn_ifog.export._spec import LINEAR_REGRESSORS, describe_pipeline
    from sklearn_ifog.rbf import RBFNetRegressor

    try:
        spec = describe_pipeline(pipeline)
    except (TypeError, ValueError):
        return None
    transforms = [_TRANSFORMS[step["op"]](step) for step in spec["steps"][:-1]]
    regressor = [s for s in pipeline.steps if s[1] not in (None, "passthrough")][-1][1]
    if type(regressor) is RBFNetRegressor:
        final = _Network(regressor)
    elif type(regressor) in LINEAR_REGRESSORS:
        final = _Linear(regressor)
    else:  # pragma: no cover - describe_pipeline refuses these
        return None
    return CompiledSteps(transforms, final, spec["single_output"])
