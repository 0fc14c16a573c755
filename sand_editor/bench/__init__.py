"""Benchmarks: our generator against a faithful port of the reference's algorithm."""

from sand_editor.bench._optional import MissingPackage

__all__ = ["MissingPackage"]
