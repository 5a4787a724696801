"""Benchmark scripts (run as ``python -m aquafish.benchmarks.<name>``); not part of the test suite."""
