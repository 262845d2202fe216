"""walkmon's version, written once: pyproject.toml reads it (``[tool.setuptools.dynamic]``), ``walkmon.__version__``
and ``walkmon --version`` show it."""

__version__ = "0.1.0"
