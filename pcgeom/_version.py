"""The package version, in one place (read by ``pcgeom --version`` and written to results)."""

__version__ = "0.1.0"
