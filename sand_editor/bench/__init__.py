"""Benchmarks: our generator against a faithful port of the reference's algorithm."""
