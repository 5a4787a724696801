"""One flag set: ``--out``, ``--workers``, ``--processes``, ``--seed``/``--seeds``, ``--budget``,
``--episode-duration-s`` and ``--no-progress`` mean the same on every ``aquafish`` command and
``aquafish bench`` benchmark.

Every sub-command's parser (:func:`aquafish.cli.build_parser`) and every benchmark's (its
``main`` with a parser class that stops at ``parse_args``) is read: a shared flag has one
attribute, one type and the shared help; an old spelling is only an alias of the canonical flag
(hidden from ``--help``, same attribute) and parses to the same value. A new command that spells
``--output`` or ``--preset`` alone fails here.
"""

import argparse
import importlib
import pkgutil

import pytest

import aquafish.benchmarks
from aquafish.cli import build_parser
from aquafish_gym.argtypes import EPISODE_DURATION_HELP, PROCESSES_HELP, WORKERS_HELP

#: Canonical flag -> (attribute, name of its type (None: store_true), how its help begins (None:
#: the command's own words)).
CANONICAL = {
    "--out": ("out", "path", None),
    "--workers": ("workers", "int >= 1", WORKERS_HELP),
    "--processes": ("processes", "int >= 1", PROCESSES_HELP),
    "--seed": ("seed", "seed", None),  # aquafish_gym.argtypes.seed_below: below 2**32, or a procedure's limit
    "--seeds": ("seeds", "comma-separated seed list", None),
    "--budget": ("budget", None, None),  # a name among choices (test_budget_names_...)
    "--episode-duration-s": ("episode_duration_s", "positive_float", EPISODE_DURATION_HELP),
    "--no-progress": ("no_progress", None, "no progress (default: a bar on a terminal, one line per "),
}
#: Old or other spellings -> the canonical flags one of which must hold the same attribute.
OLD = {
    "--output": ("--out",), "--output-dir": ("--out",), "--out-dir": ("--out",), "--outdir": ("--out",),
    "--preset": ("--budget",),
    "--episode-duration": ("--episode-duration-s",),
    "--duration": ("--episode-duration-s", "--duration-s"),  # swim's episode; eea's experiment length
    "--quiet": ("--no-progress",),
    "--jobs": ("--workers",), "--n-jobs": ("--workers",), "--num-workers": ("--workers",),
}
#: Benchmarks whose flag of a shared name is a sweep (a comma-separated list of counts).
SWEEPS = {("bench eea_round", "--workers"), ("bench neat_generation", "--workers")}
#: Commands that run long enough to show progress: each has ``--no-progress``.
LONG_RUNNING = {"eea", "gait", "rl", "case-study", "study", "damages", "baselines", "recovery", "mission"}
#: Commands without ``--no-progress``, and why: they display no progress to turn off.
NO_PROGRESS_DISPLAY = {
    "swim": "a few seconds, prints one line per robot",
    "envs": "lists the tasks", "doctor": "prints the simulator path", "bench": "its benchmarks print their own tables",
    "transfer": "a few episodes, prints one line per controller",
    "diagnose": "prints one table line per run as it is diagnosed",
    "plot": "draws a figure", "compare": "prints a table", "mission-table": "prints a table",
    "tables": "prints tables or checks a page against them",
    "heldout": "chooses an action: its run action has --no-progress (tests/aquafish/test_heldout.py)",
}
#: Arguments a command needs to parse at all.
REQUIRED = {"eea": ["--out", "r"], "study": ["--out", "s"], "transfer": ["--controller", "c", "--target", "healthy"],
            "plot": ["d"], "compare": ["a=d"], "diagnose": ["d"], "baselines": ["--out", "b"],
            "recovery": ["--out", "r"], "mission": ["--damage", "none", "--out", "m"], "bench": ["sim"],
            "mission-table": ["m"]}


class _Built(Exception):
    pass


def _benchmark_parser(name: str) -> argparse.ArgumentParser:
    """The parser ``aquafish.benchmarks.NAME.main`` builds, caught at ``parse_args`` (nothing runs)."""
    built = []

    class Catch(argparse.ArgumentParser):
        def parse_args(self, args=None, namespace=None):
            if self in built:  # the test's own parsing
                return super().parse_args(args, namespace)
            built.append(self)
            raise _Built

    with pytest.raises(_Built):
        importlib.import_module(f"aquafish.benchmarks.{name}").main([], prog=f"aquafish bench {name}",
                                                                     parser_class=Catch)
    return built[0]


def _parsers() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    parsers = dict(sub.choices)
    for module in pkgutil.iter_modules(aquafish.benchmarks.__path__):
        parsers[f"bench {module.name}"] = _benchmark_parser(module.name)
    return parsers


PARSERS = _parsers()


def _type_name(action: argparse.Action):
    return None if action.type is None else getattr(action.type, "__name__", repr(action.type))


@pytest.mark.parametrize("command", list(PARSERS))
def test_shared_flags_have_one_attribute_type_and_help(command):
    flags = PARSERS[command]._option_string_actions
    for flag, (dest, type_name, help_start) in CANONICAL.items():
        if flag not in flags or (command, flag) in SWEEPS:
            continue
        action = flags[flag]
        assert action.dest == dest, f"{command} {flag}: stored as {action.dest}, not {dest}"
        if type_name is not None:
            assert _type_name(action) == type_name, f"{command} {flag}: type {_type_name(action)}, not {type_name}"
        if flag == "--no-progress":
            assert isinstance(action, argparse._StoreTrueAction)
        if flag == "--budget":
            from eea.methods import BUDGETS

            assert action.choices and set(action.choices) <= set(BUDGETS), f"{command} --budget: {action.choices}"
        if help_start is not None:
            assert action.help.startswith(help_start), f"{command} {flag}: help {action.help!r}"


@pytest.mark.parametrize("command", list(PARSERS))
def test_no_command_spells_an_old_form_without_the_canonical_one(command):
    flags = PARSERS[command]._option_string_actions
    for old, canonicals in OLD.items():
        if old not in flags:
            continue
        present = [c for c in canonicals if c in flags and flags[c].dest == flags[old].dest]
        assert present, f"{command} has {old} but not {' or '.join(canonicals)} storing the same attribute"
        canonical = flags[present[0]]
        if flags[old] is not canonical:  # a separate alias: hidden, named in the canonical flag's help
            assert flags[old].help == argparse.SUPPRESS and old in canonical.help, f"{command} {old}"
            assert (_type_name(flags[old]), flags[old].choices) == (_type_name(canonical), canonical.choices)


def _aliases():
    for command, parser in PARSERS.items():
        flags = parser._option_string_actions
        for old, canonicals in OLD.items():
            canonical = next((c for c in canonicals if c in flags), None)
            if old in flags and canonical:  # an old spelling alone fails the test above
                yield pytest.param(command, old, canonical, id=f"{command} {old}")


def _value(action: argparse.Action) -> list[str]:
    if isinstance(action, argparse._StoreTrueAction):
        return []
    if action.choices:
        return [next(c for c in action.choices if c != action.default)]
    return {"path": ["x.png"], "positive_float": ["2.5"]}.get(_type_name(action), ["7"])


@pytest.mark.parametrize("command, old, canonical", list(_aliases()))
def test_an_old_spelling_parses_to_the_canonical_flags_value(command, old, canonical):
    parser = PARSERS[command]
    value = _value(parser._option_string_actions[canonical])
    base = REQUIRED.get(command, [])
    by_old, by_canonical = (vars(parser.parse_args([*base, flag, *value])) for flag in (old, canonical))
    assert by_old == by_canonical
    assert by_old != vars(parser.parse_args(base))  # the value given, not the default


def test_every_long_running_command_has_no_progress():
    commands = {c for c in PARSERS if not c.startswith("bench ")}
    assert LONG_RUNNING | set(NO_PROGRESS_DISPLAY) == commands, "classify a new command: LONG_RUNNING or not"
    assert {c for c in commands if "--no-progress" in PARSERS[c]._option_string_actions} == LONG_RUNNING


def test_workers_and_processes_are_two_counts():
    """``--workers``: processes inside one run; ``--processes``: runs at once (study, recovery)."""
    assert {c for c in PARSERS if "--processes" in PARSERS[c]._option_string_actions} == {"study", "recovery"}
    assert WORKERS_HELP == "evaluation processes inside one run" and PROCESSES_HELP == "runs at once"


def test_budget_names_mean_the_same_level_everywhere():
    """A budget name is one level: ``case-study --budget quick`` runs its EEA at ``eea --budget
    quick``; ``mission --budget quick`` runs the case study's quick budget."""
    from aquafish.case_study import PRESETS
    from aquafish.mission import MISSION_PRESETS
    from eea.methods import BUDGETS

    choices = {c: tuple(p._option_string_actions["--budget"].choices or ()) for c, p in PARSERS.items()
               if "--budget" in p._option_string_actions}
    assert set(choices) == {"eea", "study", "case-study", "recovery", "mission", "bench case_study_stages",
                            "bench neat_generation", "bench gaits_at_once"}
    assert choices["eea"] == choices["study"] == tuple(BUDGETS)
    for command in ("case-study", "recovery", "bench case_study_stages", "bench neat_generation",
                    "bench gaits_at_once"):
        assert sorted(choices[command]) == sorted(PRESETS)
    assert all(PRESETS[name].budget == name and name in BUDGETS for name in PRESETS)
    assert sorted(choices["mission"]) == sorted(MISSION_PRESETS)
    assert all(MISSION_PRESETS[name].case_preset == name for name in MISSION_PRESETS)
    assert PARSERS["case-study"].get_default("budget") == PARSERS["recovery"].get_default("budget") == "quick"


def test_episode_length_and_mission_length_are_told_apart():
    """``--episode-duration-s``: a gait's episodes; ``mission --duration-s``: the whole mission."""
    have = {c for c, p in PARSERS.items() if "--episode-duration-s" in p._option_string_actions}
    assert have == {"swim", "gait", "rl", "case-study", "recovery"}
    assert "whole mission" in PARSERS["mission"]._option_string_actions["--duration-s"].help


def test_json_object_reads_inline_json_or_a_file_and_refuses_anything_else(tmp_path):
    from aquafish_gym.argtypes import json_object

    assert json_object('{"lineages": 1, "duration_s": 2.56}') == {"lineages": 1, "duration_s": 2.56}
    (tmp_path / "lean.json").write_text('{"profile_refine": 0}')
    assert json_object(str(tmp_path / "lean.json")) == {"profile_refine": 0}
    for text, message in (('[1, 2]', "must be a JSON object"), ('{"a": 1, "a": 2}', "key 'a' given twice"),
                          ('{lineages: 1}', "is not valid JSON"), (str(tmp_path / "none.json"), "cannot read")):
        with pytest.raises(argparse.ArgumentTypeError, match=message):
            json_object(text)
