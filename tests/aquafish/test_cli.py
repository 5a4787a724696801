"""The ``aquafish`` parser: every sub-command registered, no optional dependency imported."""

import subprocess
import sys

from aquafish.cli import build_parser, main

COMMANDS = ["swim", "bench", "eea", "gait", "transfer", "rl", "case-study", "study", "plot", "diagnose", "damages"]


def test_every_command_is_registered_in_help_order():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert list(sub.choices) == COMMANDS


def test_building_the_parser_imports_no_optional_dependency():
    code = ("import sys; from aquafish.cli import build_parser; build_parser(); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'stable_baselines3', 'torch', 'ray', 'pandas'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_bench_passes_the_rest_to_the_benchmark(capsys):
    args = build_parser().parse_args(["bench", "sim", "--steps", "2", "--sizes", "1"])
    assert (args.what, args.rest) == ("sim", ["--steps", "2", "--sizes", "1"])
    assert main(["bench", "sim", "--steps", "2", "--repeats", "1", "--sizes", "1"]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[1].split()[:2] == ["robots", "steps"] and table[2].split()[:2] == ["1", "2"]
