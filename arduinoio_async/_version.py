"""The package version: the only place it is written (pyproject.toml reads it from here;
the package's ``__init__`` and the benchmark report import it, so no layer has to import
the package facade for it)."""

__version__ = "0.1.0"
