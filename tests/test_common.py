"""scikit-learn's estimator checks on every estimator of the package.

Modelled on imbalanced-learn's ``imblearn/tests/test_common.py``: one
``parametrize_with_checks`` over all estimators, an ``expected_failed_checks`` callable that
gives the reason for each expected failure, and the explicit checks scikit-learn's own suite
adds on top.
"""

import pytest
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import (
    check_dataframe_column_names_consistency,
    check_param_validation,
    check_set_output_transform,
    check_set_output_transform_pandas,
    check_set_output_transform_polars,
    check_transformer_get_feature_names_out,
    check_transformer_get_feature_names_out_pandas,
    parametrize_with_checks,
)

from sklearn_ifog import RBFNetRegressor, ThermalFeatures
from sklearn_ifog._discovery import all_estimators

# Parameters under which an estimator can take the generic arrays the checks feed it.
CHECK_PARAMS = {
    # The checks pass unnamed arrays: name the temperature column by position.
    "ThermalFeatures": {"temperature": 0},
    # A meta-estimator needs an estimator; the checks' arrays have no run column, so the
    # calibration folds are given as an int (KFold over rows, each row its own group).
    "ConformalRegressor": {"estimator": Ridge(), "cv": 3},
    # The recommended pipeline's steps, on the checks' unnamed arrays (temperature: column 0).
    "CompensationPipeline": {
        "steps": [
            ("features", ThermalFeatures(temperature=0)),
            ("scale", StandardScaler()),
            ("regressor", LinearRegression()),
        ]
    },
    # The unit is a column of X: the first one of the checks' arrays. With pooling="full"
    # every unit is predicted by the lot's model, and a unit must have been seen in fit.
    "UnitwiseRegressor": {
        "estimator": LinearRegression(),
        "unit": 0,
        "pooling": "full",
        "run": None,
    },
}

_ORDER_DEPENDENT = {
    "check_methods_subset_invariance": (
        "dT of a row is the difference from the previous row of its run: a row transformed "
        "in a smaller batch loses its predecessor (first-row rule, dT = 0)."
    ),
    "check_methods_sample_order_invariance": (
        "Row order is the time order within a run: shuffling the rows changes every dT."
    ),
}

# Checks that fail by design, with the reason (imbalanced-learn's convention).
EXPECTED_FAILED_CHECKS = {
    "ThermalFeatures": _ORDER_DEPENDENT,
    "CalibrationDomain": {
        "check_outliers_fit_predict": (
            "A novelty detector without contamination: the calibration rows define the "
            "domain, so every one of them is inside and fit_predict never gives -1."
        ),
        "check_outliers_train": (
            "A novelty detector without contamination: every training row is inside by "
            "construction, so the check's expected -1 on training outliers never comes."
        ),
    },
    "CompensationPipeline": {
        **_ORDER_DEPENDENT,
        "check_estimators_overwrite_params": (
            "A Pipeline fits its steps in place, as scikit-learn's own Pipeline does (which "
            "scikit-learn does not run through these checks)."
        ),
        "check_dont_overwrite_parameters": (
            "A Pipeline fits its steps in place, as scikit-learn's own Pipeline does."
        ),
        "check_regressors_train": (
            "The thermal features read only the temperature column (column 0) of the check's "
            "arrays, whose target depends on every column, so the training score stays low."
        ),
    },
    "UnitwiseRegressor": {
        "check_fit_idempotent": (
            "It predicts new rows of the units seen in fit; the check's new rows have new "
            "values in the unit column (unseen units), which is an error naming the unit."
        ),
        "check_estimators_nan_inf": (
            "A NaN in the unit column is a missing unit id: a ValueError saying so, not the "
            "check's wording."
        ),
        "check_fit2d_1feature": (
            "A single column is the unit column and leaves the model no input: a ValueError "
            "saying so, not the check's wording."
        ),
        "check_dtype_object": (
            "Unit ids of mixed types (the check's dict among numbers) are a TypeError "
            "naming the unit column and the types found, not the check's wording."
        ),
    },
}

# The network without refinement (an extra instance below; the default refines).
UNREFINED_NETWORK_FAILED_CHECKS = {
    "check_non_transformer_estimators_n_iter": (
        "n_iter_ counts refinement iterations (max_iter bounds the refinement); "
        "refine=None refines nothing, so n_iter_ is 0 by design."
    ),
}


def _instances():
    instances = [cls(**CHECK_PARAMS.get(name, {})) for name, cls in all_estimators()]
    # The checks also run on the network without refinement (refine=None).
    return [*instances, RBFNetRegressor(refine=None)]


def expected_failed_checks(estimator):
    if isinstance(estimator, RBFNetRegressor) and estimator.refine is None:
        return UNREFINED_NETWORK_FAILED_CHECKS
    return EXPECTED_FAILED_CHECKS.get(type(estimator).__name__, {})


def _ids(estimator):
    return type(estimator).__name__


def test_every_estimator_is_checked():
    names = {name for name, _ in all_estimators()}
    assert {
        "CalibrationDomain",
        "CompensationPipeline",
        "ThermalFeatures",
        "RBFNetRegressor",
        "UnitwiseRegressor",
    } <= names


@parametrize_with_checks(_instances(), expected_failed_checks=expected_failed_checks)
def test_sklearn_compatible_estimator(estimator, check):
    check(estimator)


@pytest.mark.parametrize("estimator", _instances(), ids=_ids)
def test_param_validation(estimator):
    check_param_validation(type(estimator).__name__, estimator)


@pytest.mark.parametrize("estimator", _instances(), ids=_ids)
def test_dataframe_column_names_consistency(estimator):
    check_dataframe_column_names_consistency(type(estimator).__name__, estimator)


TRANSFORMERS = [est for est in _instances() if hasattr(est, "transform")]


@pytest.mark.parametrize("estimator", TRANSFORMERS, ids=_ids)
@pytest.mark.parametrize(
    "check",
    [
        check_set_output_transform,
        check_set_output_transform_pandas,
        check_set_output_transform_polars,
        check_transformer_get_feature_names_out,
        check_transformer_get_feature_names_out_pandas,
    ],
    ids=lambda check: check.__name__,
)
def test_transformer_output_checks(estimator, check):
    check(type(estimator).__name__, estimator)
