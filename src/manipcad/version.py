"""The package version (also in pyproject.toml); written into every saved file."""

__version__ = "0.1.0"
