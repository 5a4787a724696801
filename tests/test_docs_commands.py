"""Every ``aquafish`` command shown in the README and docs parses with today's command line.

A command in a fenced ``bash`` block (continuation lines joined) is parsed by
:func:`aquafish.cli.build_parser`, not run: a renamed or retired flag fails here. A config file
it names (``--config examples/...toml``, from the repository's root) is applied as ``aquafish``
applies it, so its keys and values are checked too.
"""

import re
import shlex
from pathlib import Path

import pytest

from aquafish.cli import build_parser
from aquafish.config_file import parse_command_line
from eea.compat import RETIRED_FIELDS

ROOT = Path(__file__).parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
#: Records of retired variants name commands that ran at an older commit (they say which).
HISTORICAL = {ROOT / "docs/studies/retired_variants.md"}
#: Commits at which retired fields last ran, where not the retirement's 82b7524: a page that shows
#: such a field's flag must name its commit.
RETIRED_FIELD_COMMITS = {"cma_global_flip": "eac968c", "new_gait_start": "0661181", "oob_draw": "e5577a9"}
#: Retired values of flags that stay, and the commit they last ran at.
RETIRED_FLAG_VALUES = {"--model-space morphology_nonzero": "e5577a9"}
#: Retired flags of commands other than ``eea`` (their last commit is in RETIRED_FIELD_COMMITS).
RETIRED_FLAGS = ("new_gait_start",)
#: Retired sub-commands, by the commit they last ran at: a page that shows one must name it.
RETIRED_COMMANDS = {"select": "aa88ba2"}


def _commands():
    for path in DOCS:
        if path in HISTORICAL or "results" in path.relative_to(ROOT).parts:
            continue
        for block in re.findall(r"```(?:bash|sh|console)\n(.*?)```", path.read_text(), flags=re.S):
            for line in block.replace("\\\n", " ").splitlines():
                line = line.split("#", 1)[0].strip()
                retired = [f for f in (*RETIRED_FIELDS, *RETIRED_FLAGS) if f"--{f.replace('_', '-')} " in line + " "]
                values = [v for v in RETIRED_FLAG_VALUES if f"{v} " in line + " "]
                if values:  # a retired value's command: the page must name the commit it last ran at
                    for value in values:
                        assert RETIRED_FLAG_VALUES[value] in path.read_text(), f"{path}: {line} uses {value}"
                elif retired:  # a retired variant's command: the page must name the commit it last ran at
                    for field in retired:
                        commit = RETIRED_FIELD_COMMITS.get(field, "82b7524")
                        assert commit in path.read_text(), f"{path}: {line} uses retired {field}; name {commit}"
                elif line.split()[1:2] and line.split()[1] in RETIRED_COMMANDS and line.startswith("aquafish "):
                    commit = RETIRED_COMMANDS[line.split()[1]]
                    assert commit in path.read_text(), f"{path}: {line} is retired; name commit {commit}"
                elif line.startswith("aquafish ") and "..." not in line:  # "..." abbreviates a command above
                    yield pytest.param(line, id=f"{path.relative_to(ROOT)}: {line[:60]}")


@pytest.mark.parametrize("command", list(_commands()))
def test_documented_command_parses(command, monkeypatch):
    argv = shlex.split(command)[1:]
    argv = ["1" if re.fullmatch(r"[A-Z]", a) else a for a in argv if a not in ("&", "&&")]  # placeholders: S, N
    if argv[0] == "study" and "--out" not in argv and "--config" not in argv:
        argv += ["--out", "x"]
    monkeypatch.chdir(ROOT)  # a config file's path is relative to the repository's root
    args, _ = parse_command_line(build_parser(), argv)
    if argv[0] in ("eea", "study"):  # no flag of a strategy or search its runs do not use (eea.config.FLAT_FIELDS)
        _check_flags_are_used(args)


def _check_flags_are_used(args) -> None:
    """Build the command's config (``eea``) or study (``study``): a flag of a strategy or search
    that no run uses raises; another error (a placeholder such as ``--damage D``) is not this test's."""
    from aquafish.studies_cli import STUDY_EXCLUDED
    from aquafish.study import StudySpec
    from eea.cli import config_fields, config_flag_names, config_from_args, given_flags

    try:
        if args.command == "eea":
            config_from_args(args, config_flag_names())
        else:
            names = config_flag_names(STUDY_EXCLUDED)
            StudySpec(args.conditions, args.durations, args.replicates, {"workers": 1, **config_fields(args, names)},
                      first_seed=args.first_seed, fixed=list(given_flags(args, names)))
    except ValueError as err:
        assert " needs " not in str(err) and "no run of the study uses" not in str(err), str(err)
