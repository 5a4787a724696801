"""Benchmark scripts (run as ``python -m aquafish.benchmarks.<name>``); not part of the test suite."""

from __future__ import annotations

import argparse


def add_budget(parser: argparse.ArgumentParser, what: str) -> None:
    """The ``--budget`` flag of a benchmark that runs a case-study budget (old spelling
    ``--preset``): one of :data:`aquafish.case_study.PRESETS`, default ``quick``; ``what`` says
    what the benchmark takes from it, in its help."""
    from aquafish.case_study import PRESETS
    from aquafish_gym.argtypes import add_alias

    add_alias(parser, parser.add_argument("--budget", choices=sorted(PRESETS), default="quick",
                                          help=f"{what} (default: quick)"), "--preset")
