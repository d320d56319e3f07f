"""The files the commands read and write: the saved model, the output paths.

:func:`load_model` reads a model saved by ``fit`` (a file this package cannot read is the
user's :class:`~sklearn_ifog.cli._common.InputError`, not an internal error);
:func:`check_output_parent` and :func:`check_output_directory` refuse, before any work, an
output that could not be written.
"""

import pickle
import sys
import warnings
import zipfile
from pathlib import Path

from sklearn_ifog.cli._common import PROGRAM, InputError, one_line

# What loading a model raises when the file is not a model this package can read: a
# missing or unreadable file, not a pickle or zip, truncated, refused by skops (untrusted
# types: a TypeError), written by something else (a ValueError), or naming classes this
# installation does not have. Anything else is a bug, reported as an internal error.
_NOT_A_MODEL = (
    OSError,
    EOFError,
    ValueError,
    TypeError,
    KeyError,
    ImportError,
    AttributeError,
    pickle.UnpicklingError,
    zipfile.BadZipFile,
)


def check_output_parent(path):
    """An InputError unless the directory ``path`` would be written in exists."""
    parent = Path(path).parent
    if not parent.is_dir():
        raise InputError(f"{path}: the directory {parent} does not exist")


def check_output_directory(out):
    """An InputError unless ``out`` can be made (or replaced) as an output directory."""
    out = Path(out)
    check_output_parent(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out} exists and is not a directory")


def load_model(path):
    """(model, metadata) from ``path``; version warnings become one stderr line each."""
    from sklearn_ifog import persistence

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such model file")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            model, metadata = persistence.load_model(path, return_metadata=True)
        except _NOT_A_MODEL as error:
            raise InputError(f"{path}: cannot load the model: {one_line(error)}") from None
    for warning in caught:
        print(f"{PROGRAM}: warning: {one_line(warning.message)}", file=sys.stderr)
    return model, metadata
