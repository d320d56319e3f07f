"""numpydoc validation of every public object of the package.

Every public class and function: a docstring with a summary, every parameter documented in
signature order, a Returns section for functions, and an Examples section (which pytest runs
as a doctest). Public methods of the classes: summary, parameters and returns.
"""

import importlib
import inspect
import pkgutil

import pytest
from numpydoc.validate import validate

import sklearn_ifog

OBJECT_CHECKS = {"GL08", "SS01", "PR01", "PR02", "PR03", "PR07", "RT01", "EX01"}
METHOD_CHECKS = {"GL08", "SS01", "PR01", "PR02", "PR03", "PR07", "RT01"}
# Methods whose docstrings scikit-learn's mixins provide, or that only exist to be found by
# scikit-learn's machinery.
SKIPPED_METHODS = {"set_params", "get_params", "get_metadata_routing", "set_output"}


def _public_modules():
    yield sklearn_ifog
    for info in pkgutil.walk_packages(sklearn_ifog.__path__, prefix="sklearn_ifog."):
        if any(part.startswith("_") for part in info.name.split(".")[1:]):
            continue
        yield importlib.import_module(info.name)


def _public_objects():
    seen = set()
    for module in _public_modules():
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name)
            if not (inspect.isclass(obj) or inspect.isfunction(obj)):
                continue
            path = f"{obj.__module__}.{obj.__qualname__}"
            if path in seen:
                continue
            seen.add(path)
            yield f"{module.__name__}.{name}", obj


def _public_methods():
    for path, obj in _public_objects():
        if not inspect.isclass(obj):
            continue
        for name, member in inspect.getmembers(obj):
            if name.startswith("_") or name in SKIPPED_METHODS:
                continue
            if not (inspect.isfunction(member) or isinstance(member, property)):
                continue
            if isinstance(member, property):
                continue
            owner = next((klass for klass in obj.__mro__ if name in vars(klass)), None)
            if owner is None or not owner.__module__.startswith("sklearn_ifog"):
                continue
            yield f"{path}.{name}"


OBJECTS = sorted(dict(_public_objects()))
METHODS = sorted(set(_public_methods()))


def _errors(import_path, checks):
    result = validate(import_path)
    return [f"{code}: {message}" for code, message in result["errors"] if code in checks]


def test_public_api_is_documented():
    assert "sklearn_ifog.ThermalFeatures" in OBJECTS
    assert "sklearn_ifog.RBFNetRegressor" in OBJECTS


@pytest.mark.parametrize("import_path", OBJECTS)
def test_object_docstring(import_path):
    errors = _errors(import_path, OBJECT_CHECKS)
    assert not errors, f"{import_path}:\n" + "\n".join(errors)


@pytest.mark.parametrize("import_path", METHODS)
def test_method_docstring(import_path):
    errors = _errors(import_path, METHOD_CHECKS)
    assert not errors, f"{import_path}:\n" + "\n".join(errors)
