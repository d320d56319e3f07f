"""A fitted Pipeline's steps after ThermalFeatures, compiled to plain numpy arithmetic.

:func:`compile_steps` reads the fitted parameters once (the export schema of
:func:`sklearn_ifog._description.describe_pipeline`: scalers, PolynomialFeatures; the final
regressor's :class:`~sklearn_ifog._output_layer.OutputLayer`, a linear regressor or
:class:`~sklearn_ifog.RBFNetRegressor`) and returns a :class:`CompiledSteps` that
evaluates them without scikit-learn's per-call validation: on a block of rows with the same
operations as the estimators (so a whole run gives ``pipeline.predict`` bit for bit), and on
one row with the fewest numpy calls. It also gives the final regressor's *output-layer
design* (the columns its prediction is linear in: the Gaussian activations, the tail and 1
of the RBF network; the inputs and 1 of a linear model) and its weights, for online
recalibration. A Pipeline with a step this module does not know is not compiled
(:func:`compile_steps` returns None) and the caller keeps scikit-learn's path.

:func:`compile_domain` does the same for the calibration domain of a
:class:`~sklearn_ifog.pipeline.CompensationPipeline`: a :class:`CompiledDomain` holds its
box, margin, policy (an :class:`~sklearn_ifog.policy.UncalibratedPolicy`) and fallback, and
applies the policy as ``predict`` does (a block of rows, with the plain functions of
:mod:`sklearn_ifog.domain`), and
tests one row with a single small matrix-vector product.
"""

import math

import numpy as np

from sklearn_ifog._description import describe_pipeline
from sklearn_ifog._output_layer import layer_kind, read_layer
from sklearn_ifog._tuning import NOVELTY_RAMP, RATE_WEIGHT
from sklearn_ifog.domain import locate, require_box
from sklearn_ifog.policy import policy_for
from sklearn_ifog.rbf._basis import predict_network, tail_features

__all__ = ["CompiledDomain", "CompiledSteps", "FastRow", "compile_domain", "compile_steps"]


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

    def __init__(self, layer):
        # The regressor's own shapes (a 1-D coef_ and a scalar intercept_ for one output):
        # the same matrix-vector product as its predict.
        self.coef = layer.coef[0] if layer.single_output else layer.coef
        self.intercept = layer.intercept[0] if layer.single_output else layer.intercept
        self.n_outputs = layer.n_outputs
        # Output layer: the inputs, then 1.
        self.weights = layer.weights
        self.bias_index = self.weights.shape[0] - 1

    def predict(self, X):
        Y = X @ self.coef.T + self.intercept
        return Y.reshape(X.shape[0], -1)

    def design(self, X):
        return np.hstack([X, np.ones((X.shape[0], 1))])


class _Network:
    """An RBFNetRegressor's network, its output layer ``[phi(z), t(z), 1]``."""

    kind = "rbf_network"

    def __init__(self, layer):
        network = layer.network
        self.network = network
        self.x_mean = np.asarray(layer.x_mean, dtype=np.float64)
        self.x_scale = np.asarray(layer.x_scale, dtype=np.float64)
        self.centers = network.centers
        self.gain = -0.5 / np.square(network.widths)
        # The stored tail (a network fitted without one carries a zero linear tail, which
        # the recalibration may move).
        self.degree = layer.tail_degree
        self.n_outputs = layer.n_outputs
        self.weights = layer.weights
        self.bias_index = self.weights.shape[0] - 1
        n_inputs = self.centers.shape[1]
        self.first, self.second = np.triu_indices(n_inputs)

    def standardise(self, X):
        return (X - self.x_mean) / self.x_scale

    def predict(self, X):
        # As RBFNetRegressor.predict: the same function on the same standardised inputs.
        network = self.network
        return predict_network(
            self.standardise(X),
            centers=network.centers,
            widths=network.widths,
            coef=network.coef,
            tail_coef=network.tail_coef,
            intercept=network.intercept,
        )

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


_FINALS = {"linear": _Linear, "rbf_network": _Network}


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

    def __init__(self, transforms, final, single_output, specs=()):
        self.transforms = transforms
        self.specs = list(specs)
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
    try:
        spec = describe_pipeline(pipeline)
    except (TypeError, ValueError):
        return None
    transforms = [_TRANSFORMS[step["op"]](step) for step in spec["steps"][:-1]]
    regressor = [s for s in pipeline.steps if s[1] not in (None, "passthrough")][-1][1]
    evaluator = _FINALS.get(layer_kind(regressor))
    if evaluator is None:  # pragma: no cover - describe_pipeline refuses these
        return None
    final = evaluator(read_layer(regressor))
    return CompiledSteps(transforms, final, spec["single_output"], spec["steps"][:-1])


class FastRow:
    """One row, one output, in Python floats and three numpy calls (the step's hot path).

    For a Pipeline of affine scalers (StandardScaler, RobustScaler, MaxAbsScaler,
    MinMaxScaler) then an RBF network or a linear model, with one output. The scalers and the
    network's standardisation run on Python floats with the estimators' own operations (so
    the standardised row is the batch one bit for bit); the network is the batch
    formula of :func:`sklearn_ifog.rbf._basis.gaussian_design` with its polynomial tail and
    intercept folded into the same product: ``r = M @ [z, ||z||², 1]``, then
    ``drift = coef @ exp(r[:K]) + [z, ||z||², 1] @ r[K:]``.

    Parameters
    ----------
    compiled : CompiledSteps
        The compiled steps.
    weights : ndarray of shape (n_weights, 1), default=None
        Output-layer weights to use instead of the fitted ones (online recalibration).
    """

    def __init__(self, compiled, weights=None):
        self.stages = []
        for spec in compiled.specs:
            if spec["op"] == "center_scale":
                self.stages.append(("cs", list(zip(spec["center"], spec["scale"], strict=True))))
            else:
                clip = spec["clip"]
                self.stages.append(
                    ("ma", list(zip(spec["multiply"], spec["add"], strict=True)), clip)
                )
        final = compiled.final
        self.kind = final.kind
        weights = final.weights if weights is None else weights
        self.set_weights(final, np.asarray(weights, dtype=np.float64)[:, 0])

    @staticmethod
    def supports(compiled):
        """Whether ``compiled`` has the form this fast path evaluates."""
        return (
            compiled is not None
            and compiled.final.n_outputs == 1
            and all(spec["op"] != "polynomial" for spec in compiled.specs)
        )

    def set_weights(self, final, weights):
        """Use the output-layer ``weights`` (1-D, the design's order)."""
        if final.kind == "linear":
            self.linear = (weights[:-1].tolist(), float(weights[-1]))
            return
        self.network = [
            (float(m), float(s)) for m, s in zip(final.x_mean, final.x_scale, strict=True)
        ]
        centers = final.centers
        n_centers, n_inputs = centers.shape
        inv_var = -2.0 * final.gain  # 1 / widths**2
        M = np.zeros((n_centers + n_inputs + 2, n_inputs + 2))
        # As gaussian_design: [z, ||z||², 1] @ [c/σ²; -1/(2σ²); -||c||²/(2σ²)].
        M[:n_centers, :n_inputs] = centers * inv_var[:, None]
        M[:n_centers, n_inputs] = -0.5 * inv_var
        M[:n_centers, n_inputs + 1] = -0.5 * inv_var * np.square(centers).sum(axis=1)
        tail = weights[n_centers:-1]
        Q = M[n_centers:]
        if final.degree >= 1:
            Q[:n_inputs, n_inputs + 1] = tail[:n_inputs]
        if final.degree == 2:
            Q[final.first, final.second] = tail[n_inputs:]
        Q[n_inputs + 1, n_inputs + 1] = weights[-1]
        self.M = M
        self.n_centers = n_centers
        self.coef = np.ascontiguousarray(weights[:n_centers])

    def __call__(self, row):
        """Drift (a float) of one feature row (a sequence of floats)."""
        for stage in self.stages:
            if stage[0] == "cs":
                row = [(x - c) / s for x, (c, s) in zip(row, stage[1])]  # noqa: B905
            else:
                row = [x * m + a for x, (m, a) in zip(row, stage[1])]  # noqa: B905
                if stage[2] is not None:
                    low, high = stage[2]
                    row = [low if x < low else high if x > high else x for x in row]
        if self.kind == "linear":
            coef, intercept = self.linear
            total = 0.0
            for x, w in zip(row, coef):  # noqa: B905
                total += w * x
            return total + intercept
        z = [(x - m) / s for x, (m, s) in zip(row, self.network)]  # noqa: B905
        norm2 = 0.0
        for value in z:
            norm2 += value * value
        z.append(norm2)
        z.append(1.0)
        augmented = np.array(z)
        r = self.M @ augmented
        K = self.n_centers
        phi = r[:K]
        np.exp(phi, out=phi)
        return float(self.coef @ phi + augmented @ r[K:])


class CompiledDomain:
    """A CompensationPipeline's calibration domain and policy, for streaming.

    Built by :func:`compile_domain` from the fitted pipeline's ``domain_`` (a
    :class:`~sklearn_ifog.domain.CalibrationDomain`), ``uncalibrated`` and ``fallback_``, read
    once (a later ``set_params`` of the pipeline does not reach it). A block of feature rows
    goes through the operations of
    :meth:`~sklearn_ifog.pipeline.CompensationPipeline.predict`:
    :func:`~sklearn_ifog.domain.locate` says which rows are outside, and the policy
    object applies itself (:meth:`~sklearn_ifog.policy.UncalibratedPolicy.apply`).
    :meth:`row_where` is the same test for one row without any validation: one small
    matrix-vector product and a comparison per temperature (the online step's hot path).

    Parameters
    ----------
    domain : CalibrationDomain
        Fitted; its calibrated ``threshold_`` is the distance that still counts as inside
        (``margin``).
    policy : UncalibratedPolicy
        The policy for the rows outside (:func:`~sklearn_ifog.policy.policy_for` of the
        pipeline's ``uncalibrated``).
    fallback : Fallback
        The conservative model (of a policy that uses one, ``"blend"``).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog.domain import CalibrationDomain
    >>> from sklearn_ifog.fallback import Fallback
    >>> from sklearn_ifog._compiled import CompiledDomain
    >>> from sklearn_ifog.policy import BlendWithFallback
    >>> t = np.linspace(10.0, 40.0, 31)
    >>> fitted = CalibrationDomain(margin=1.0, temperature=0).fit(np.column_stack([t, t**2]))
    >>> fallback = Fallback(np.array([1.0]), np.array([0.0]), 0)
    >>> domain = CompiledDomain(fitted, BlendWithFallback(), fallback)
    >>> features = np.array([[25.0, 625.0], [9.0, 81.0], [-60.0, 3600.0]])
    >>> distance, outside = domain.where(features)
    >>> outside.tolist()  # 9 degC is below the calibrated 10 degC: outside at any distance
    [False, True, True]
    >>> row_distance, row_outside = domain.row_where([9.0, 81.0])
    >>> bool(np.isclose(row_distance, distance[1], rtol=1e-12, atol=1e-12)), row_outside
    (True, True)
    >>> prediction = np.full((3, 1), 7.0)
    >>> domain.apply(features, prediction, distance, outside).round(6).tolist()  # far: 1
    [[7.0], [7.0], [1.0]]
    """

    def __init__(self, domain, policy, fallback):
        self.domain = domain
        self.box = domain.box_
        self.margin = float(domain.threshold_)
        self.policy = policy
        self.fallback = fallback
        self.temperature_columns = list(domain.temperature_columns_)
        self.data_min, self.data_max = domain.data_min_, domain.data_max_
        box = self.box
        # One row's scaled excesses as one product with [x, 1]: the standardisation, the
        # rotation and the division by the axis scale folded into one matrix, stacked with
        # its negative, the bounds (and the centre) in the last column, give
        # (p - upper) / s above (lower - p) / s; the positive entries are the excesses.
        along = box.axes / box.axis_scale[:, None]
        stacked = np.vstack([along, -along])
        bounds = np.concatenate([box.upper / box.axis_scale, -box.lower / box.axis_scale])
        offset = bounds + stacked @ (box.center / box.scale)
        self._excess_matrix = np.hstack([stacked / box.scale, -offset[:, None]])
        self._temperature_bounds = [
            (column, float(self.data_min[column]), float(self.data_max[column]))
            for column in self.temperature_columns
        ]
        # The rate term of box_distance: (column, low, high, scale) per rate feature.
        self._rate_bounds = [
            (int(column), float(low), float(high), float(scale))
            for column, low, high, scale in zip(
                box.rate_columns, box.rate_low, box.rate_high, box.rate_scale, strict=True
            )
        ]
        self._boost = float(box.boost)
        self._feature_scale = box.scale.tolist()
        self._boost_bounds = [
            (int(column), float(low), float(high))
            for column, low, high in zip(
                box.temperature_columns, box.temperature_low, box.temperature_high, strict=True
            )
        ]
        self._rate_ramp = RATE_WEIGHT * NOVELTY_RAMP

    def where(self, features):
        """Distance of every feature row outside the box, and whether it is outside.

        Parameters
        ----------
        features : ndarray of shape (n_samples, n_features)

        Returns
        -------
        distance : ndarray of shape (n_samples,)
            In decorrelated standard deviations (0 inside the box).
        outside : ndarray of shape (n_samples,), dtype=bool
            Farther than ``margin``, or a temperature beyond its calibrated range.
        """
        where = locate(self.domain, features)
        return where.distance, where.outside

    def row_where(self, row):
        """:meth:`where` of one row (a sequence of floats): ``(distance, outside)``.

        Python float and bool. The distance's terms are grouped differently from
        :func:`~sklearn_ifog.domain.box_distance` (equal to 1e-12 relative, with an absolute
        floor of rounding at the box's scale); the temperature test is exact.
        """
        # Python floats after the one product: cheaper than numpy calls on 2 n_features
        # values.
        squares = 0.0
        for excess in (self._excess_matrix @ np.array([*row, 1.0])).tolist():
            if excess > 0.0:
                squares += excess * excess
        rate_squares = 0.0
        for column, low, high, scale in self._rate_bounds:
            value = row[column]
            if value < low:
                rate_squares += ((low - value) / scale) ** 2
            elif value > high:
                rate_squares += ((value - high) / scale) ** 2
        distance = math.sqrt(squares + rate_squares)
        if self._boost:
            novelty = rate_squares / self._rate_ramp**2
            for column, low, high in self._boost_bounds:
                value = row[column]
                ramp = self._feature_scale[column] * NOVELTY_RAMP
                if value < low:
                    novelty += ((low - value) / ramp) ** 2
                elif value > high:
                    novelty += ((value - high) / ramp) ** 2
            if novelty > 0.0:
                distance += self._boost * min(math.sqrt(novelty), 1.0)
        # outside_domain: beyond the margin, or any temperature beyond its range.
        outside = distance > self.margin
        for column, low, high in self._temperature_bounds:
            value = row[column]
            outside = outside or value < low or value > high
        return distance, bool(outside)

    def apply(self, features, prediction, distance, outside, evaluate=None):
        """The prediction of every row under the policy (rows inside unchanged).

        Parameters
        ----------
        features : ndarray of shape (n_samples, n_features)
            The thermal feature rows.
        prediction : ndarray of shape (n_samples, n_outputs)
            The model's prediction of those rows (not modified).
        distance, outside : ndarray of shape (n_samples,)
            Their :meth:`where`.
        evaluate : callable, default=None
            ``evaluate(rows) -> (n_rows, n_outputs)``: the model's prediction of feature
            rows, for a policy that moves rows (``"clip"``; unused by the others).

        Returns
        -------
        prediction : ndarray of shape (n_samples, n_outputs)
            A new array when a row is outside and the policy changes it, else
            ``prediction`` itself.
        """
        return self.policy.apply(
            prediction,
            features,
            distance,
            outside,
            domain=self.domain,
            fallback=self.fallback,
            evaluate=evaluate,
        )

    def project(self, features):
        """Feature rows moved onto the domain (the ``"clip"`` policy's inputs).

        The domain's own :meth:`~sklearn_ifog.domain.CalibrationDomain.project`, as the
        batch ``predict`` calls it.
        """
        return self.domain.project(features)


def compile_domain(pipeline):
    """The calibration domain of a fitted CompensationPipeline, or None for another model.

    Parameters
    ----------
    pipeline : estimator
        A fitted :class:`~sklearn_ifog.pipeline.CompensationPipeline` (anything else, e.g. a
        plain scikit-learn Pipeline, has no calibration domain).

    Returns
    -------
    domain : CompiledDomain or None

    Examples
    --------
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn_ifog import make_compensation_pipeline
    >>> from sklearn_ifog._compiled import compile_domain
    >>> from sklearn_ifog.datasets import make_thermal_campaign
    >>> X, y = make_thermal_campaign(
    ...     n_units=1, n_runs=1, sampling_period=300.0, random_state=0, return_X_y=True
    ... )
    >>> model = make_compensation_pipeline(LinearRegression()).fit(X, y)
    >>> domain = compile_domain(model)
    >>> domain.policy, domain.margin == model.domain_.threshold_, domain.temperature_columns
    (BlendWithFallback(width=1.0), True, [0])
    >>> compile_domain(model[:]) is None  # a plain Pipeline of the same steps
    True
    """
    if not hasattr(pipeline, "fit_domain"):  # a model that learns its own domain
        return None
    domain = pipeline.domain_
    require_box(domain, "Streaming compensation and the C and JSON exports")
    return CompiledDomain(domain, policy_for(pipeline.uncalibrated), pipeline.fallback_)
