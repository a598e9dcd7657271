"""The version of freefloat, in one place: ``pyproject.toml`` reads it (hatch), ``freefloat --version`` prints it."""

__version__ = "0.2.0"
