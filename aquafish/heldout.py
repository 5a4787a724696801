"""Sealed held-out sets (``aquafish heldout``): one registry of every held-out set, and the one
way a sealed set is spent.

The registry is a TOML file, committed with the code (``benchmarks/heldout.toml``; not
installed with the package). One table per set, ``[sets.NAME]`` (NAME: letters, digits, ``_``
and ``-``), with these keys:

* ``kind``: ``"recovery"`` (cells of the recovery benchmark, :func:`aquafish.recovery.run_recovery`)
  or ``"missions"`` (missions, :func:`aquafish.mission.run_mission`);
* ``description``: what the set is, in words;
* ``damages``: preset names (not ``none``) or ``sampled:SEED``, each once;
* ``seeds``: ints >= 0, each once;
* ``missions`` (``missions`` sets only): ``[[damage, seed], ...]``, each pair once, each damage
  one of ``damages`` and each seed one of ``seeds``, every one of them used. Without it, the
  missions are every damage at every seed (the cross product), as a recovery set's cells are;
* ``settings``: a table. A recovery set's ``preset`` (a case-study budget) and
  ``episode_duration_s`` (simulated seconds > 0); a missions set's ``preset`` (a mission budget),
  ``onset_s`` (simulated seconds >= 0) and ``duration_s`` (simulated seconds > ``onset_s``);
* ``reality_gap``: ``"none"`` (the sets run in the simulator they were developed in);
* ``status``, one of :data:`STATUSES`:

  * ``"sealed"``: never run, never looked at. No ``commit``, ``out``, ``records`` or ``result``.
  * ``"spent"``: run once by :func:`spend` on a method frozen at ``commit`` (the 40 hex digits of
    the checkout's ``HEAD``), into ``out``; ``result`` is the one-line summary of its published
    number, and ``records`` the path of its committed records. While it runs, ``result`` is
    :data:`RUNNING` and ``records`` is absent: such a set is resumed only at the same commit
    into the same ``out``.
  * ``"validation"``: looked at while developing; never again called held out. ``note`` says
    where it was used (it may keep the ``commit``, ``out``, ``records`` and ``result`` of a
    run).

  ``note`` is allowed with every status and required with ``"validation"``.

A path in ``out`` and ``records`` is relative to the checkout's root when it lies inside it
(``docs/results/heldout/benchmark_20s``), else absolute.

The registry is read with :mod:`tomllib` and written with ``tomli-w`` (atomically,
:func:`aquafish_gym.files.atomic_write`), the sets' keys in :data:`KEY_ORDER`. ``tomli-w``
writes no comments, so the file's leading comment block (its first lines that are comments or
blank), which states the rules, is kept as it is and written again above the tables
(:data:`HEADER` for a file without one); a comment anywhere else is dropped by a rewrite.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import subprocess
import tomllib
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

#: The registry's path in the repository, and the command's default (relative to the current directory).
REGISTRY_PATH = Path("benchmarks/heldout.toml")
#: The kinds of sets: the recovery benchmark's cells, or missions.
KINDS = ("recovery", "missions")
#: The statuses of a set (the module's docstring says what each means).
STATUSES = ("sealed", "spent", "validation")
#: ``result`` of a spent set whose run has not finished.
RUNNING = "running"
#: The allowed ``reality_gap`` values.
REALITY_GAPS = ("none",)
#: The packages of the method: a set is spent only when none has uncommitted changes.
METHOD_DIRS = ("aquafish", "aquafish_gym", "eea", "gait")
#: The keys of a set, in the order they are written; the first seven are required.
KEY_ORDER = ("kind", "description", "status", "reality_gap", "damages", "seeds", "settings",
             "commit", "out", "records", "result", "note", "missions")
REQUIRED_KEYS = KEY_ORDER[:7]
#: The keys of ``settings`` for each kind, in the order they are written.
SETTINGS_KEYS = {"recovery": ("preset", "episode_duration_s"), "missions": ("preset", "onset_s", "duration_s")}
#: The leading comment block written above the tables of a registry that has none.
HEADER = """\
# The held-out sets: every set that has been, is or will be called held out (aquafish.heldout,
# docs/heldout.md). Rules:
#
# * A sealed set is run once, by `aquafish heldout run NAME --out DIR`, on a method frozen at a
#   commit (no uncommitted change to aquafish/, aquafish_gym/, eea/, gait/). The command marks it
#   spent at that commit before it runs anything, so a set that was looked at never goes back to
#   sealed; a spent set is never run again (an interrupted run resumes at the same commit into
#   the same directory).
# * Its result is published whatever it is: the set's `result` and its committed `records`.
# * A set looked at while developing is validation, and is never again called held out.
#
# This block is kept when the command rewrites the file; comments below it are not.
"""

_NAME = re.compile(r"[A-Za-z0-9_-]+")
_SAMPLED = re.compile(r"sampled:(0|[1-9][0-9]*)")
_COMMIT = re.compile(r"[0-9a-f]{40}")


def load_registry(path: str | os.PathLike = REGISTRY_PATH) -> dict[str, dict]:
    """Read and check the registry.

    Args:
        path: the registry's TOML file.

    Returns:
        Set name -> its table (as in the file, the numbers of ``settings`` as floats), in the
        file's order.

    Raises:
        ValueError: the file is missing, is not TOML, or a set is malformed (:func:`check_set`;
            the message names the file, the set and the field).
    """
    return _parse(_read(Path(path)), Path(path))


def check_set(name: str, entry: Mapping) -> dict:
    """Check one set's table and return it with its keys in :data:`KEY_ORDER`.

    Args:
        name: the set's name.
        entry: its table (the module's docstring lists the keys).

    Returns:
        The table, checked (``settings``' numbers as floats).

    Raises:
        ValueError: naming the set and the field: an unknown key, a missing required key, a
            kind, status or ``reality_gap`` not allowed, a bad damage, seed, mission or setting,
            or a key that the status does not allow or needs.
    """
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise ValueError(f"set {name!r}: a set's name is letters, digits, '_' and '-'")
    if not isinstance(entry, Mapping):
        raise ValueError(f"set {name!r}: is not a table ([sets.{name}])")

    def bad(field: str, what: str) -> ValueError:
        return ValueError(f"set {name!r}, field {field!r}: {what}")

    unknown = sorted(set(entry) - set(KEY_ORDER))
    if unknown:
        raise bad(unknown[0], f"unknown key; allowed: {', '.join(KEY_ORDER)}")
    for key in REQUIRED_KEYS:
        if key not in entry:
            raise bad(key, "missing (every set has kind, description, status, reality_gap, damages, seeds, settings)")
    kind, status = entry["kind"], entry["status"]
    if kind not in KINDS:
        raise bad("kind", f"{kind!r} is not a kind; allowed: {', '.join(KINDS)}")
    if status not in STATUSES:
        raise bad("status", f"{status!r} is not a status; allowed: {', '.join(STATUSES)}")
    if entry["reality_gap"] not in REALITY_GAPS:
        raise bad("reality_gap", f"{entry['reality_gap']!r} is not allowed; allowed: {', '.join(REALITY_GAPS)}")
    for key in ("description", "commit", "out", "records", "result", "note"):
        if key in entry and (not isinstance(entry[key], str) or not entry[key].strip()):
            raise bad(key, "must be a non-empty string")
    checked = dict(entry)
    checked["damages"] = _check_damages(entry["damages"], bad)
    checked["seeds"] = _check_seeds(entry["seeds"], bad)
    checked["settings"] = _check_settings(kind, entry["settings"], bad)
    if "missions" in entry:
        if kind != "missions":
            raise bad("missions", f"only a missions set lists its missions; this set's kind is {kind!r}")
        checked["missions"] = _check_missions(entry["missions"], checked["damages"], checked["seeds"], bad)
    run_keys = [k for k in ("commit", "out", "records", "result") if k in entry]
    if status == "sealed" and run_keys:
        raise bad(run_keys[0], "a sealed set was never run: it has no commit, out, records or result")
    if status == "spent":
        for key in ("commit", "out", "result"):
            if key not in entry:
                raise bad(key, "missing: a spent set names the commit it ran at, its out and its result")
        if entry["result"] != RUNNING and "records" not in entry:
            raise bad("records", "missing: a spent set with a result names its committed records")
    if status == "validation" and "note" not in entry:
        raise bad("note", "missing: a validation set's note says where it was looked at")
    if "commit" in entry and not _COMMIT.fullmatch(entry["commit"]):
        raise bad("commit", f"{entry['commit']!r} is not a commit: 40 lowercase hex digits (git rev-parse HEAD)")
    return {key: checked[key] for key in KEY_ORDER if key in checked}


def missions_of(entry: Mapping) -> list[tuple[str, int]]:
    """A set's missions, or a recovery set's cells: ``(damage, seed)`` pairs, the explicit
    ``missions`` if the set lists them, else every damage at every seed (damage-major)."""
    if "missions" in entry:
        return [(d, s) for d, s in entry["missions"]]
    return [(d, s) for d in entry["damages"] for s in entry["seeds"]]


def list_sets(path: str | os.PathLike = REGISTRY_PATH) -> list[dict]:
    """One row per set of the registry: ``name``, ``kind``, ``status``, ``count`` (cells or
    missions) and ``commit`` (None unless it ran).

    Raises:
        ValueError: as :func:`load_registry`.
    """
    return [{"name": name, "kind": e["kind"], "status": e["status"], "count": len(missions_of(e)),
             "commit": e.get("commit")} for name, e in load_registry(path).items()]


def format_sets(rows: list[dict]) -> str:
    """:func:`list_sets`' rows as a plain-text table (the commit shortened to 12 digits)."""
    table = [("name", "kind", "status", "cells", "commit")]
    table += [(r["name"], r["kind"], r["status"], str(r["count"]), (r["commit"] or "-")[:12]) for r in rows]
    widths = [max(len(row[i]) for row in table) for i in range(len(table[0]))]
    return "".join("  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() + "\n" for row in table)


def format_set(name: str, entry: Mapping) -> str:
    """One set as its TOML table, with a line saying how many cells or missions it has."""
    import tomli_w

    noun = "cells (damage x seed)" if entry["kind"] == "recovery" else "missions"
    return tomli_w.dumps({"sets": {name: dict(entry)}}) + f"\n# {len(missions_of(entry))} {noun}\n"


def write_registry(path: str | os.PathLike, sets: Mapping[str, Mapping]) -> None:
    """Write ``sets`` to the registry ``path`` atomically, keeping the file's leading comment
    block (:data:`HEADER` when it has none or does not exist).

    Raises:
        ValueError: a set is malformed (:func:`check_set`); nothing is written.
        OSError: the file cannot be written.
    """
    import tomli_w

    from aquafish_gym.files import atomic_write

    path = Path(path)
    checked = {name: check_set(name, entry) for name, entry in sets.items()}
    header = _header(path.read_text()) if path.exists() else ""
    text = (header or HEADER).rstrip("\n") + "\n\n" + tomli_w.dumps({"sets": checked})
    atomic_write(path, text.encode())


def method_checkout() -> Path:
    """The root of the git checkout the imported ``aquafish`` package is in: the method that runs.

    Raises:
        ValueError: the package is not in a git checkout (an installed wheel), or git is missing.
    """
    import aquafish

    return _git_root(Path(aquafish.__file__).resolve().parent)


def method_commit(checkout: str | os.PathLike) -> str:
    """``HEAD`` of ``checkout``, checked to be the method that runs.

    Args:
        checkout: the root of a git checkout.

    Returns:
        The commit, 40 hex digits.

    Raises:
        ValueError: ``checkout`` is not a git checkout, git is missing, or a tracked file under
            :data:`METHOD_DIRS` has uncommitted changes (staged or not; untracked files are not
            the method and do not count); the message lists the first of them.
    """
    checkout = Path(checkout)
    head = _git(checkout, "rev-parse", "--verify", "HEAD").strip()
    changed = _git(checkout, "status", "--porcelain", "--untracked-files=no", "--", *METHOD_DIRS).splitlines()
    if changed:
        files = ", ".join(line[3:] for line in changed[:5])
        files += f" and {len(changed) - 5} more" if len(changed) > 5 else ""
        raise ValueError(f"the method is not frozen at a commit: {checkout} has uncommitted changes under "
                         f"{', '.join(d + '/' for d in METHOD_DIRS)} ({files}); commit them (or run from a clean "
                         "checkout) before spending a held-out set")
    return head


def check_runnable(entry: Mapping, processes: int = 1, workers: int | None = None) -> None:
    """Check that the set's settings are ones its runner accepts, without running anything
    (as the runner checks them: :func:`aquafish.recovery.check_spec`; a mission's preset,
    damages, onset and duration).

    Raises:
        ValueError: a setting the runner refuses, ``processes`` or ``workers`` not an int >= 1,
            or ``processes`` > 1 for a missions set (its missions run one at a time).
    """
    from aquafish_gym.checks import check_int

    check_int("processes", processes, 1)
    if workers is not None:
        check_int("workers", workers, 1)
    s = entry["settings"]
    if entry["kind"] == "recovery":
        from aquafish.recovery import check_spec

        check_spec(s["preset"], entry["damages"], entry["seeds"], s["episode_duration_s"])
        return
    from aquafish.mission import mission_preset
    from aquafish_gym import get_damage
    from aquafish_gym.env import check_onset

    if processes != 1:
        raise ValueError(f"--processes must be 1 for a missions set (its missions run one at a time), got {processes}")
    mission_preset(s["preset"])
    for damage in entry["damages"]:
        get_damage(damage)
    check_onset(s["onset_s"])


def run_recovery_set(entry: Mapping, out: Path, *, processes: int = 1, workers: int | None = None,
                     progress: bool = True) -> str:
    """Run a recovery set's cells into ``out`` (:func:`aquafish.recovery.run_recovery`; finished
    cells are reused) and return the one-line result: how many cells break the healthy gait,
    and in how many of those each row recovers (and the self-model's signs, where judged).

    Raises:
        ValueError: as :func:`aquafish.recovery.run_recovery`.
    """
    from aquafish.recovery import run_recovery

    s = entry["settings"]
    summary = run_recovery(out, preset=s["preset"], damages=entry["damages"], seeds=entry["seeds"],
                           episode_duration_s=s["episode_duration_s"], processes=processes, workers=workers,
                           progress=progress)
    return recovery_result(summary["totals"])


def recovery_result(totals: Mapping) -> str:
    """The one-line result of a recovery set from its summary's ``totals``
    (:func:`aquafish.recovery.summarize`): the breaking cells, each row's recoveries among them,
    and the self-model's signs where they are judged."""
    rows = totals.get("rows") or {}
    text = (f"{totals['breaking']} of {totals['cells']} cells break the healthy gait; recovers in them: "
            + (", ".join(f"{key} {r['recovers']}/{r['of']}" for key, r in rows.items()) or "no rows"))
    identified = totals.get("identified") or {}
    if identified.get("of"):
        text += f"; the self-model's signs right in {identified['right']}/{identified['of']}"
    return text


def mission_dir_name(damage: str, seed: int) -> str:
    """A mission's directory in the set's ``out``: ``<damage, ':' as '_'>_s<seed>`` (``sampled_3100_s7200``)."""
    return f"{damage.replace(':', '_')}_s{seed}"


def run_missions_set(entry: Mapping, out: Path, *, processes: int = 1, workers: int | None = None,
                     progress: bool = True) -> str:
    """Run a missions set's missions one at a time into ``out/<mission_dir_name>``
    (:func:`aquafish.mission.run_mission`, no video), skipping those whose ``mission.json``
    exists, with one prior per seed (``out/priors/seed<S>``, :func:`aquafish.mission.prepare_prior`:
    the robot's design) and one oracle per damage (``out/oracles/<damage>``; it depends on no
    seed); write ``out/summary.md`` and ``out/summary.json``
    (:func:`aquafish.mission_table.summarise_missions`) and return the one-line result: the
    missions run, the alarms in time, the false alarms and the recoveries.

    Raises:
        ValueError: as :func:`aquafish.mission.run_mission`; ``processes`` other than 1.
    """
    import json

    from aquafish.mission import MISSION_FILE, prepare_prior, run_mission
    from aquafish.mission_table import format_table, read_missions, summarise_missions
    from aquafish_gym.files import atomic_write

    if processes != 1:
        raise ValueError(f"--processes must be 1 for a missions set (its missions run one at a time), got {processes}")
    s = entry["settings"]
    dirs = []
    for damage, seed in missions_of(entry):
        mission_dir = out / mission_dir_name(damage, seed)
        if not (mission_dir / MISSION_FILE).is_file():
            prior = out / "priors" / f"seed{seed}"
            prepare_prior(prior, s["preset"], seed, workers=workers, progress=progress)
            run_mission(damage, mission_dir, onset_s=s["onset_s"], duration_s=s["duration_s"], preset=s["preset"],
                        seed=seed, self_model=prior, workers=workers, video=False, progress=progress,
                        oracle_dir=out / "oracles" / damage.replace(":", "_"))
        dirs.append(mission_dir)
    summary = summarise_missions(read_missions(dirs))
    atomic_write(out / "summary.json", (json.dumps(summary, indent=1) + "\n").encode())
    atomic_write(out / "summary.md", format_table(summary).encode())
    t = summary["totals"]
    return (f"{t['missions']} missions run: alarm in time in {t['alarm_in_time']}, {t['false_alarms']} false "
            f"alarms, recovered in {t['recovered']} of the {t['judged']} judged (beyond keep_old in "
            f"{t['beats_keep_old']}, 80 % of oracle_at_alarm's final speed in {t['final_80']})")


def spend(name: str, out_dir: str | os.PathLike, registry_path: str | os.PathLike = REGISTRY_PATH, *,
          checkout: str | os.PathLike | None = None, processes: int = 1, workers: int | None = None,
          progress: bool = True) -> dict:
    """Spend the sealed set ``name``: run it once, on the method frozen at the checkout's
    ``HEAD``, into ``out_dir``, and record its result in the registry.

    In order: the set must be sealed (or spent and still :data:`RUNNING` at the same commit
    into the same ``out``: a resume), its settings runnable (:func:`check_runnable`), ``out_dir``
    writable, and the method frozen (:func:`method_commit`). Then the registry is rewritten
    with the set ``"spent"``, its ``commit``, ``out`` and ``result = "running"`` *before*
    anything runs, so a set that was looked at never silently goes back to sealed. The set runs
    (:func:`run_recovery_set` or :func:`run_missions_set`, looked up when called), and the
    registry is rewritten with its ``result`` and ``records = out``. A run that fails leaves the
    set spent and running: run the same command at the same commit to resume it. The registry
    is locked while it is read and rewritten, so two commands cannot both spend one set.

    Args:
        name: the set.
        out_dir: the set's run directory (for the records, inside the checkout: e.g.
            ``docs/results/heldout/NAME``).
        registry_path: the registry.
        checkout: the git checkout whose ``HEAD`` is the method (default: the one the
            imported ``aquafish`` is in, :func:`method_checkout`).
        processes: cells at once (recovery sets; a missions set needs 1).
        workers: evaluation processes (a cell's or a mission's; default: the runner's).
        progress: show progress.

    Returns:
        The set's table as recorded at the end (status ``"spent"``, ``commit``, ``out``,
        ``records``, ``result``).

    Raises:
        ValueError: an unknown set (naming the sets), a validation set (it is not held out), a
            spent set (naming its commit, out and records: a spent set is never run again), a
            setting the runner refuses, an ``out_dir`` that cannot be written, a method that is
            not frozen at a commit or not in a git checkout, a malformed registry, or the
            runner's own error (the set stays spent and running).
        OSError: the registry cannot be written.
    """
    from aquafish_gym.rundir import check_output_dir

    registry_path = Path(registry_path)
    out = check_output_dir(out_dir)
    root = Path(checkout) if checkout is not None else method_checkout()
    recorded_out = _record_path(out, root)
    with _registry_lock(registry_path):
        sets = load_registry(registry_path)
        entry = _find(sets, name, registry_path)
        commit = None
        if entry["status"] == "spent" and entry["result"] == RUNNING:
            commit = method_commit(root)
            if entry["commit"] != commit or entry["out"] != recorded_out:
                raise ValueError(_spent_message(name, entry) + f"; only the same commit into the same --out resumes "
                                 f"it (this is {commit[:12]} into {recorded_out})")
        elif entry["status"] != "sealed":
            raise ValueError(_refusal(name, entry))
        check_runnable(entry, processes, workers)
        if commit is None:
            commit = method_commit(root)
            entry = check_set(name, {**entry, "status": "spent", "commit": commit, "out": recorded_out,
                                     "result": RUNNING})
            sets[name] = entry
            write_registry(registry_path, sets)
    run: Callable[..., str] = run_recovery_set if entry["kind"] == "recovery" else run_missions_set
    result = run(entry, out, processes=processes, workers=workers, progress=progress)
    with _registry_lock(registry_path):
        sets = load_registry(registry_path)
        now = _find(sets, name, registry_path)
        if now.get("status") != "spent" or now.get("commit") != commit or now.get("result") != RUNNING:
            raise ValueError(f"set {name!r} changed in {registry_path} while it ran (status {now['status']!r}, "
                             f"commit {now.get('commit')}); its result was not recorded: {result}")
        sets[name] = check_set(name, {**now, "result": result, "records": recorded_out})
        write_registry(registry_path, sets)
    return sets[name]


def _refusal(name: str, entry: Mapping) -> str:
    if entry["status"] == "validation":
        return (f"set {name!r} is a validation set, not held out: it was looked at while developing "
                f"({entry['note']}); a validation set is never run as held out")
    return _spent_message(name, entry) + "; a spent set is never run again"


def _spent_message(name: str, entry: Mapping) -> str:
    result = entry["result"]
    state = "is still running (result pending)" if result == RUNNING else f"has its result: {result}"
    return (f"set {name!r} was spent at commit {entry['commit']} into {entry['out']}"
            + (f" (records {entry['records']})" if "records" in entry else "") + f" and {state}")


def _find(sets: Mapping[str, dict], name: str, path: Path) -> dict:
    if name not in sets:
        raise ValueError(f"no set {name!r} in {path}; its sets: {', '.join(sets) or 'none'}")
    return dict(sets[name])


def _record_path(out: Path, root: Path) -> str:
    """``out`` relative to the checkout's root if it lies in it (POSIX form), else absolute."""
    absolute = Path(out).resolve()
    try:
        return absolute.relative_to(root.resolve()).as_posix()
    except ValueError:
        return absolute.as_posix()


def _read(path: Path) -> dict:
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise ValueError(f"no registry of held-out sets at {path}; run from the repository's root or give "
                         f"--registry PATH (the repository's is {REGISTRY_PATH})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path} is not valid TOML: {err}") from None


def _parse(data: Mapping, path: Path) -> dict[str, dict]:
    extra = sorted(set(data) - {"sets"})
    if extra:
        raise ValueError(f"{path}: unknown top-level key {extra[0]!r}; the registry holds only [sets.NAME] tables")
    sets = data.get("sets", {})
    if not isinstance(sets, Mapping):
        raise ValueError(f"{path}: 'sets' must be tables [sets.NAME]")
    try:
        return {name: check_set(name, entry) for name, entry in sets.items()}
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from None


def _header(text: str) -> str:
    """The leading comment block of a TOML text: its first lines that are comments or blank."""
    lines = []
    for line in text.splitlines(keepends=True):
        if line.strip() and not line.lstrip().startswith("#"):
            break
        lines.append(line)
    return "".join(lines).strip("\n") + "\n" if any(line.strip() for line in lines) else ""


def _check_damages(damages, bad) -> list[str]:
    from aquafish_gym.damage import DAMAGES

    presets = sorted(d for d in DAMAGES if d != "none")
    if not isinstance(damages, list) or not damages:
        raise bad("damages", "must be a non-empty list of damages")
    for damage in damages:
        if not isinstance(damage, str) or not (damage in presets or _SAMPLED.fullmatch(damage)):
            raise bad("damages", f"{damage!r} is not a damage; allowed: a preset ({', '.join(presets)}) or "
                                 "sampled:SEED (SEED an int >= 0, no leading zeros)")
    _check_unique(damages, "damages", bad)
    return list(damages)


def _check_seeds(seeds, bad) -> list[int]:
    if not isinstance(seeds, list) or not seeds:
        raise bad("seeds", "must be a non-empty list of ints >= 0")
    for seed in seeds:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise bad("seeds", f"{seed!r} is not a seed; allowed: an int >= 0")
    _check_unique(seeds, "seeds", bad)
    return list(seeds)


def _check_unique(values: list, field: str, bad) -> None:
    seen = set()
    for value in values:
        if value in seen:
            raise bad(field, f"{value!r} is listed twice")
        seen.add(value)


def _check_settings(kind: str, settings, bad) -> dict:
    import math

    keys = SETTINGS_KEYS[kind]
    if not isinstance(settings, Mapping):
        raise bad("settings", f"must be a table with {', '.join(keys)}")
    for key in settings:
        if key not in keys:
            raise bad(f"settings.{key}", f"unknown for a {kind} set; allowed: {', '.join(keys)}")
    checked = {}
    for key in keys:
        if key not in settings:
            raise bad(f"settings.{key}", f"missing (a {kind} set's settings are {', '.join(keys)})")
        value = settings[key]
        if key == "preset":
            if not isinstance(value, str) or not value:
                raise bad("settings.preset", f"{value!r} is not a preset name")
            checked[key] = value
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0 \
                or (value == 0 and key != "onset_s"):
            raise bad(f"settings.{key}", f"{value!r} is not allowed; allowed: simulated seconds, a finite number "
                                         + (">= 0" if key == "onset_s" else "> 0"))
        checked[key] = float(value)
    if kind == "missions" and checked["onset_s"] >= checked["duration_s"]:
        raise bad("settings.onset_s", f"{checked['onset_s']:g} must come before the end of the mission "
                                      f"(duration_s {checked['duration_s']:g})")
    return checked


def _check_missions(missions, damages: list[str], seeds: list[int], bad) -> list[list]:
    if not isinstance(missions, list) or not missions:
        raise bad("missions", "must be a non-empty list of [damage, seed] pairs")
    pairs = []
    for pair in missions:
        if not (isinstance(pair, list) and len(pair) == 2 and pair[0] in damages and not isinstance(pair[1], bool)
                and isinstance(pair[1], int) and pair[1] in seeds):
            raise bad("missions", f"{pair!r} is not a mission; allowed: [damage, seed], the damage one of the set's "
                                  "damages and the seed one of its seeds")
        pairs.append([pair[0], pair[1]])
    _check_unique([tuple(p) for p in pairs], "missions", bad)
    used_damages, used_seeds = {p[0] for p in pairs}, {p[1] for p in pairs}
    unused = [d for d in damages if d not in used_damages] + [s for s in seeds if s not in used_seeds]
    if unused:
        raise bad("missions", f"{unused[0]!r} is in the set's damages or seeds but in none of its missions")
    return pairs


def _git_root(path: Path) -> Path:
    return Path(_git(path, "rev-parse", "--show-toplevel").strip())


def _git(cwd: Path, *args: str) -> str:
    try:
        done = subprocess.run(["git", "-C", str(cwd), *args], capture_output=True, text=True, check=False)
    except FileNotFoundError:
        raise ValueError("git is not installed: spending a held-out set records the commit of the method") from None
    if done.returncode != 0:
        reason = " ".join(done.stderr.split()) or f"git {args[0]} failed"
        raise ValueError(f"{cwd} is not a usable git checkout ({reason}): a held-out set is spent on a method "
                         "frozen at a commit, run from a git checkout (pip install -e)")
    return done.stdout


@contextlib.contextmanager
def _registry_lock(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on the registry file while it is read and rewritten.

    The rewrite replaces the file (a new inode), so a lock taken on the file that was just
    replaced is let go and taken again on the new one.

    Raises:
        ValueError: the registry does not exist.
    """
    while True:
        try:
            fd = os.open(path, os.O_RDONLY)
        except FileNotFoundError:
            _read(path)  # raises the message naming the registry
            raise
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            if os.fstat(fd).st_ino == os.stat(path).st_ino:
                break
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)
    try:
        yield
    finally:
        os.close(fd)
