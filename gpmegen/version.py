"""The package version (read by the generator, which records it in every generated folder)."""

__version__ = "0.1.0"
