"""Saving and loading models: joblib and skops round trips, trust, versions, atomicity."""

import pickle
import warnings
import zipfile

import joblib
import numpy as np
import pytest
import sklearn
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import StandardScaler

import sklearn_ifog
from sklearn_ifog import RBFNetRegressor, ThermalFeatures, _version
from sklearn_ifog._discovery import all_estimators
from sklearn_ifog.comparison import SubsampledRegressor
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.persistence import TRUSTED_TYPES, ModelVersionWarning, load_model, save_model

skops_io = pytest.importorskip("skops.io", reason="skops is an optional extra")
from skops.io.exceptions import UntrustedTypesFoundException  # noqa: E402

FEATURE_COLUMNS = ["temperature", "time", "run"]


@pytest.fixture(scope="module")
def campaign_frame():
    campaign = make_thermal_campaign(
        n_units=1, n_runs=2, azimuths=(0.0,), sampling_period=60.0, random_state=0
    )
    return campaign.frame


@pytest.fixture(scope="module")
def fitted_pipeline(campaign_frame):
    pipeline = make_pipeline(
        ThermalFeatures(temperature="temperature", time="time", run="run"),
        StandardScaler(),
        RBFNetRegressor(random_state=0),
    )
    drift = campaign_frame["rate"] - campaign_frame["reference"]
    return pipeline.fit(campaign_frame[FEATURE_COLUMNS], drift)


class _CustomScaler(TransformerMixin, BaseEstimator):
    """A type skops has never heard of: files holding it must be refused."""

    def fit(self, X, y=None):
        self.factor_ = 2.0
        return self

    def transform(self, X):
        return np.asarray(X, dtype=float) * self.factor_


@pytest.mark.parametrize("file_format", ["joblib", "skops"])
def test_round_trip_gives_identical_predictions(
    tmp_path, campaign_frame, fitted_pipeline, file_format
):
    path = tmp_path / f"model.{file_format}"
    save_model(fitted_pipeline, path, metadata={"site": "lab 3", "runs": [0, 1]})
    loaded, metadata = load_model(path, return_metadata=True)

    X = campaign_frame[FEATURE_COLUMNS]
    expected = fitted_pipeline.predict(X)
    np.testing.assert_array_equal(loaded.predict(X), expected)
    assert np.ptp(expected) > 0  # a real model, not a constant
    assert zipfile.is_zipfile(path) == (file_format == "skops")
    assert metadata["sklearn_ifog_version"] == sklearn_ifog.__version__
    assert metadata["sklearn_version"] == sklearn.__version__
    assert metadata["numpy_version"] == np.__version__
    assert metadata["model_class"] == "sklearn.pipeline.Pipeline"
    assert metadata["feature_columns"] == FEATURE_COLUMNS
    assert metadata["extra"] == {"site": "lab 3", "runs": [0, 1]}
    assert metadata["created"].endswith("+00:00")


def test_skops_file_loads_with_trusted_types_in_plain_skops(tmp_path, fitted_pipeline):
    path = tmp_path / "model.skops"
    save_model(fitted_pipeline, path)
    untrusted = skops_io.get_untrusted_types(file=path)
    assert set(untrusted) <= set(TRUSTED_TYPES)
    assert "sklearn_ifog.rbf._network.RBFNetRegressor" in untrusted
    payload = skops_io.load(path, trusted=TRUSTED_TYPES)
    assert isinstance(payload["model"], Pipeline)
    with pytest.raises(UntrustedTypesFoundException, match="RBFNetRegressor"):
        skops_io.load(path, trusted=[])


def test_trusted_types_cover_every_estimator_of_the_package():
    defined = {f"{cls.__module__}.{cls.__qualname__}" for _, cls in all_estimators()}
    missing = defined - set(TRUSTED_TYPES)
    assert not missing, f"add to TRUSTED_TYPES: {sorted(missing)}"


def test_untrusted_type_is_refused(tmp_path):
    X = np.array([[0.0], [1.0], [2.0]])
    model = make_pipeline(_CustomScaler(), LinearRegression()).fit(X, [1.0, 3.0, 5.0])
    path = tmp_path / "custom.skops"
    save_model(model, path)
    custom_type = f"{_CustomScaler.__module__}._CustomScaler"

    with pytest.raises(UntrustedTypesFoundException, match="_CustomScaler"):
        load_model(path)
    with pytest.raises(UntrustedTypesFoundException, match="_CustomScaler"):
        load_model(path, trusted=TRUSTED_TYPES)
    # the refusal is about trust only: trusting the type explicitly loads it
    loaded = load_model(path, trusted=[*TRUSTED_TYPES, custom_type])
    np.testing.assert_allclose(loaded.predict([[3.0]]), [7.0])


SUBSAMPLED = "sklearn_ifog.comparison.SubsampledRegressor"


def test_files_name_the_subsampled_path(tmp_path):
    model = SubsampledRegressor(LinearRegression(), max_samples=3, random_state=0)
    model.fit([[0.0], [1.0], [2.0], [3.0]], [0.0, 2.0, 4.0, 6.0])
    path = tmp_path / "now.skops"
    save_model(model, path)
    assert skops_io.get_untrusted_types(file=path) == [SUBSAMPLED]
    assert SUBSAMPLED in TRUSTED_TYPES
    np.testing.assert_allclose(load_model(path).predict([[4.0]]), [8.0])


@pytest.mark.parametrize("file_format", ["joblib", "skops"])
def test_other_package_version_warns_naming_both(tmp_path, monkeypatch, file_format):
    model = LinearRegression().fit([[0.0], [1.0]], [0.0, 2.0])
    path = tmp_path / f"old.{file_format}"
    current = sklearn_ifog.__version__
    monkeypatch.setattr(_version, "__version__", "0.0.1")
    save_model(model, path)
    monkeypatch.setattr(_version, "__version__", current)

    with pytest.warns(ModelVersionWarning, match=r"sklearn-ifog 0\.0\.1") as record:
        loaded = load_model(path)
    message = str(record[0].message)
    assert f"this is sklearn-ifog {current}" in message
    assert record[0].message.mismatches == {"sklearn-ifog": ("0.0.1", current)}
    np.testing.assert_allclose(loaded.predict([[2.0]]), [4.0])


def test_same_versions_do_not_warn(tmp_path):
    model = LinearRegression().fit([[0.0], [1.0]], [0.0, 2.0])
    path = tmp_path / "model.joblib"
    save_model(model, path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_model(path)


def test_failed_save_leaves_no_file_and_keeps_the_old_one(tmp_path):
    path = tmp_path / "model.joblib"
    good = LinearRegression().fit([[0.0], [1.0]], [0.0, 2.0])
    save_model(good, path)
    before = path.read_bytes()

    unpicklable = LinearRegression().fit([[0.0], [1.0]], [0.0, 2.0])
    unpicklable.note_ = lambda: None  # lambdas cannot be pickled
    with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
        save_model(unpicklable, path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.joblib"]

    with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
        save_model(unpicklable, tmp_path / "new.joblib")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.joblib"]


def test_format_follows_suffix_unless_given(tmp_path):
    model = LinearRegression().fit([[0.0], [1.0]], [0.0, 2.0])
    save_model(model, tmp_path / "a.skops")
    save_model(model, tmp_path / "b.bin", format="skops")
    save_model(model, tmp_path / "c.bin")
    assert zipfile.is_zipfile(tmp_path / "a.skops")
    assert zipfile.is_zipfile(tmp_path / "b.bin")
    assert not zipfile.is_zipfile(tmp_path / "c.bin")
    with pytest.raises(ValueError, match="format must be one of"):
        save_model(model, tmp_path / "d.bin", format="pickle")


def test_bad_metadata_and_foreign_files_are_rejected(tmp_path):
    model = LinearRegression().fit([[0.0], [1.0]], [0.0, 2.0])
    with pytest.raises(TypeError, match="metadata must be plain data"):
        save_model(model, tmp_path / "m.joblib", metadata={"when": object()})
    assert not (tmp_path / "m.joblib").exists()

    joblib.dump(model, tmp_path / "bare.joblib")
    with pytest.raises(ValueError, match="not a model file written by"):
        load_model(tmp_path / "bare.joblib")
    with pytest.raises(FileNotFoundError, match="No model file"):
        load_model(tmp_path / "missing.joblib")


@pytest.mark.parametrize("extension", ["joblib", "skops"])
def test_a_model_with_a_searched_transition_saves_and_loads(tmp_path, extension):
    # ThermalFeatures(transition=...) holds a Transition (a named tuple of the package):
    # skops must trust it, and both formats must give it back with the same predictions.
    from _campaigns import small_glass_campaign

    from sklearn_ifog import make_compensation_pipeline

    campaign = small_glass_campaign()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = make_compensation_pipeline(transition="auto").fit(
            campaign.data, np.asarray(campaign.target)
        )
    assert model.steps[0][1].transition_ is not None
    path = tmp_path / f"model.{extension}"
    save_model(model, path)
    loaded = load_model(path)
    assert loaded.steps[0][1].transition_ == model.steps[0][1].transition_
    np.testing.assert_array_equal(loaded.predict(campaign.data), model.predict(campaign.data))
