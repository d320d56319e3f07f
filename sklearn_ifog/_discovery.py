"""Find the package's estimators, the way ``sklearn.utils.all_estimators`` does for sklearn."""

import importlib
import inspect
import pkgutil
from pathlib import Path

from sklearn.base import BaseEstimator

# The package's folder: the walk below imports every module (the package root first), so
# this module itself needs none of them.
_PACKAGE_PATH = [str(Path(__file__).resolve().parent)]


def all_estimators():
    """Every public estimator class defined in ``sklearn_ifog``, sorted by name.

    Returns
    -------
    estimators : list of (str, type)
        ``(name, class)`` pairs.

    Examples
    --------
    >>> from sklearn_ifog._discovery import all_estimators
    >>> "ThermalFeatures" in dict(all_estimators())
    True
    """
    found = {}
    for module_info in pkgutil.walk_packages(_PACKAGE_PATH, prefix="sklearn_ifog."):
        if module_info.name.endswith(("__main__", ".cli")):
            continue
        module = importlib.import_module(module_info.name)
        for name, obj in inspect.getmembers(module, inspect.isclass):
            if (
                issubclass(obj, BaseEstimator)
                and obj.__module__.startswith("sklearn_ifog.")
                and not name.startswith("_")
                and not inspect.isabstract(obj)
            ):
                found[name] = obj
    return sorted(found.items())
