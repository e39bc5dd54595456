"""The package version (a leaf module: importing it loads nothing else from exactgrasp)."""

__version__ = "0.1.0"
