"""The conformal band of a streamed ConformalRegressor: its fold models, evaluated online."""

import numpy as np

from sklearn_ifog._compiled import compile_domain, compile_steps
from sklearn_ifog.domain import temperature_excess
from sklearn_ifog.policy import fallback_weight


def as_frame(features, names):
    """Feature rows as the later steps were fitted on them (a DataFrame with ``names``)."""
    if names is None:
        return features
    import pandas as pd

    return pd.DataFrame(features, columns=names)


def sklearn_evaluator(steps, names):
    """``evaluate(features) -> (n, n_outputs)`` of the fitted ``steps`` by scikit-learn."""

    def evaluate(features):
        prediction = np.asarray(steps.predict(as_frame(features, names)), dtype=np.float64)
        return prediction.reshape(features.shape[0], -1)

    return evaluate


class ConformalBand:
    """The drift bounds of feature rows, as ``ConformalRegressor.predict_interval`` gives them.

    Parameters
    ----------
    conformal : ConformalRegressor
        Fitted, around a Pipeline whose first step is ThermalFeatures.
    compiled : CompiledSteps or None
        The full model's compiled steps after ThermalFeatures (None: not compiled); the
        fold models are compiled too when it is and every one of them compiles.
    names : sequence of str or None
        The feature names the later steps were fitted on (None: an array).

    Attributes
    ----------
    fold_compiled : list of CompiledSteps or None
        The fold models' compiled steps (None: scikit-learn evaluates them).
    fold_domains : list of CompiledDomain or None
        Each fold model's calibration domain (None for a fold without one).
    """

    def __init__(self, conformal, compiled, names):
        self.conformal = conformal
        self.compiled = compiled
        self.names = names
        self.fold_domains = [compile_domain(model) for model in conformal.estimators_]
        self.fold_compiled = None
        if compiled is not None:
            folds = [compile_steps(model) for model in conformal.estimators_]
            if all(fold is not None for fold in folds):
                self.fold_compiled = folds

    def interval(self, features, drift, distance=None, margin=None):
        """The band of the rows with thermal ``features``, as predict_interval gives it.

        The fold models and the difficulty model's inputs (the features through the steps
        before the regressor) are evaluated compiled when every fold model compiles, else by
        scikit-learn. ``distance``: the rows' distance outside the full model's domain (None
        without one), for the band's share of the fallback where the model blends to it;
        ``margin``: that domain's.
        """
        conformal = self.conformal
        n_samples = features.shape[0]
        if self.fold_compiled is not None:
            evaluators = [compiled.predict for compiled in self.fold_compiled]
        else:
            evaluators = [
                sklearn_evaluator(model[1:], self.names) for model in conformal.estimators_
            ]
        predictions = []
        for evaluate, fold_domain in zip(evaluators, self.fold_domains, strict=True):
            prediction = evaluate(features).reshape(n_samples, -1)
            if fold_domain is not None:
                fold_where = fold_domain.where(features)
                prediction = fold_domain.apply(features, prediction, *fold_where, evaluate)
            predictions.append(prediction[:, 0])
        predictions = np.stack(predictions)
        raw = None
        if conformal.adaptive:
            rest = conformal.estimator_[1:]
            if len(rest.steps) == 1:
                raw = features
            elif self.fold_compiled is not None:
                raw = self.compiled.transform(features)
            else:
                raw = rest[:-1].transform(as_frame(features, self.names))
            raw = np.asarray(raw, dtype=float)
        centre = np.asarray(drift, dtype=float).reshape(n_samples)
        if distance is not None and getattr(conformal, "fallback_scores_", None) is not None:
            # As ConformalRegressor._outside_terms: the full model's fallback weight.
            share = fallback_weight(distance, margin)
            domain = conformal.estimator_.domain_
            # The distance is at hand: only the degrees beyond the calibrated temperatures.
            beyond = temperature_excess(
                features, domain.temperature_columns_, domain.data_min_, domain.data_max_
            )
            return conformal.bounds_from_predictions(
                centre, predictions, raw, fallback_share=share, temperature_beyond=beyond
            )
        return conformal.bounds_from_predictions(centre, predictions, raw)
