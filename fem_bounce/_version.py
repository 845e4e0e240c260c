"""The package's version (pyproject.toml's), for fem_bounce.__version__ and each run's summary.json: a module
of its own so that output.py reads it without importing the package's API (fem_bounce/__init__.py)."""
__version__ = "0.1.0"
