"""The package's version: its one definition.

``pyproject.toml`` reads it from here (``[tool.setuptools.dynamic]``), the package root
re-exports it as ``sklearn_ifog.__version__``, and the modules that record it (model files,
the export schema, the command line's ``--version``) import this module rather than the
package root.
"""

__version__ = "0.1.0.dev0"
