"""What partial pooling asks of the lot and of a unit's own model, besides the shrinkage.

Plain functions over fitted models and numpy arrays, for
:class:`~sklearn_ifog.unitwise.UnitwiseRegressor` (which holds the scikit-learn surface; the
numerics of the shrunk output layer live in :mod:`sklearn_ifog._shrinkage`): the check that
the final regressor has an output layer to shrink (:func:`check_partial`), the check that
every unit's calibrated temperature changes (:func:`check_units_change_temperature`), what a
fitted model's output layer sees (:func:`layer_inputs`), how many rows a unit's own model
needs (:func:`rows_needed`, at least ``MIN_UNIT_ROWS``), and that own model's held-out error
on its own basis (:func:`own_score`), against which the shrunk layers are compared.
"""

import numpy as np
from sklearn.pipeline import Pipeline

from sklearn_ifog._output_layer import (
    final_step,
    has_output_layer,
    layer_design,
    layer_weights,
    supported_names,
)
from sklearn_ifog._shrinkage import solve_shrunk
from sklearn_ifog.rbf._layer import is_network_layer

__all__ = [
    "MIN_UNIT_ROWS",
    "check_partial",
    "check_units_change_temperature",
    "layer_inputs",
    "own_score",
    "rows_needed",
]

# A unit whose model is fitted on its rows alone (pooling="none", or a unit that keeps its
# own model) needs at least this many rows, whatever the model: a single row holds no
# temperature change (its dT and lags follow the first-row rule), so a model fitted on it
# learns a constant. A final regressor with a linear output layer needs, besides, at least
# one row per output-layer weight, or its weights are not determined by the unit's rows.
MIN_UNIT_ROWS = 2


def check_partial(estimator):
    """A ValueError unless the final regressor of ``estimator`` has a linear output layer
    fitted to the drift (not a scale-factor pipeline's product layer)."""
    final = final_step(estimator)
    if not has_output_layer(final):
        raise ValueError(
            f"pooling='partial' shrinks a linear output layer towards the lot's; the final "
            f"regressor {type(final).__name__} has none. Use pooling='none' or 'full', or a "
            f"final regressor among: {supported_names()} (alone or as the last step of a "
            "Pipeline)."
        )
    if getattr(estimator, "input_rate", None) is not None:
        raise ValueError(
            "pooling='partial' shrinks an output layer fitted to the drift; a scale-factor "
            f"model (input_rate={estimator.input_rate!r}) solves its layer on the product of "
            "the thermal basis and the input rate. Use pooling='none' (each unit its own "
            "bias and scale factor) or 'full'."
        )


def check_units_change_temperature(lot, X_inner, rows, unit_column):
    """A ValueError naming the first unit whose calibrated temperature never changes.

    Only for a lot model that knows its temperature columns (a fitted
    :class:`~sklearn_ifog.pipeline.CompensationPipeline`); ``rows``: unit -> row indices.
    A single row is a spot calibration that ``"partial"`` shrinks to the lot (see
    ``UnitwiseRegressor._enough_rows``); many rows at one exact temperature are a stuck or
    misassigned sensor.
    """
    domain = getattr(lot, "domain_", None)
    columns = getattr(domain, "temperature_columns_", None)
    if not columns or not isinstance(lot, Pipeline):
        return
    # the rows as the domain reads them: the output of the pipeline's feature step
    raw = np.asarray(lot.steps[0][1].transform(X_inner), dtype=np.float64)[:, columns]
    names = getattr(lot, "feature_names_out_", None)
    for unit, index in rows.items():
        constant = np.flatnonzero(np.ptp(raw[index], axis=0) == 0)
        if index.size > 1 and constant.size:
            column = int(constant[0])
            name = repr(str(names[columns[column]])) if names is not None else column
            raise ValueError(
                f"unit {unit!r} (column {unit_column!r} of X): its temperature (feature "
                f"{name}) is constant ({float(raw[index[0], column])!r}) over its "
                f"{index.size} calibration rows. A unit calibrated at one temperature says "
                "nothing of its thermal drift (a stuck or misassigned sensor?); calibrate it "
                "on runs that change temperature, or leave it out of the lot."
            )


def layer_inputs(model, X):
    """What the final regressor of the fitted ``model`` sees for ``X``, as a float array."""
    if isinstance(model, Pipeline):
        X = model[:-1].transform(X)
    return np.asarray(X, dtype=np.float64)


def rows_needed(model):
    """(rows a unit needs for the fitted ``model`` to be determined by them, why)."""
    final = final_step(model)
    if has_output_layer(final):
        n_weights = layer_weights(final).shape[0]
        if not is_network_layer(final, exact=False) and not getattr(final, "fit_intercept", True):
            n_weights -= 1  # layer_weights carries an intercept row of zeros
        why = (
            f"{type(final).__name__} with {n_weights} output-layer weights: one row per "
            "weight determines them"
        )
        return max(MIN_UNIT_ROWS, n_weights), why
    return MIN_UNIT_ROWS, "one row holds no temperature change"


def own_score(model, X, Y, folds):
    """Held-out mean squared error of a unit's own model, one run out at a time.

    The model is fitted once on all of the unit's rows; each fold re-solves its output layer
    without the held-out rows, as the network solves it (its ridge ``alpha`` per row on the
    Gaussian weights, its tail penalty on the tail, the intercept free; plain least squares
    for a linear model) and predicts them, without the ``uncalibrated`` policy. The basis
    (centres and widths) is the one learnt from all the rows, as the lot's is for the shrunk
    layer: both candidates keep their basis and are compared on their output layers.
    ``inf`` when the model is None or a fold leaves fewer rows than output weights.
    """
    if model is None:
        return np.inf
    final = final_step(model)
    Phi = layer_design(final, layer_inputs(model, X))
    penalty = np.zeros(Phi.shape[1])
    if is_network_layer(final, exact=False):
        n_centers = np.shape(final.centers_)[0]
        penalty[:n_centers] = final.alpha
        penalty[n_centers:-1] = final.selection_path_.get("tail_alpha", 0.0)
        # The tail penalty's shape: a ridge on the reparametrised tail, as the network's.
        basis = final.selection_path_.get("tail_transform")
        if basis is not None and Phi.shape[1] > n_centers + 1:
            Phi[:, n_centers:-1] = Phi[:, n_centers:-1] @ basis
    zero = np.zeros((Phi.shape[1], Y.shape[1]))
    sse = 0.0
    for test in folds:
        if np.count_nonzero(~test) < Phi.shape[1]:
            return np.inf
        (weights,) = solve_shrunk(Phi[~test], Y[~test], zero, np.sqrt(penalty), [1.0])
        sse += float(np.square(Y[test] - Phi[test] @ weights).sum())
    return sse / Y.size
