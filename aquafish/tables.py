"""The README's result tables, rendered from the run records they report (``aquafish tables``).

A results table of a Markdown page stands between two marker lines::

    <!-- table: recovery -->

    | gait of | ... |
    |---|---|
    | **the self-model** | ... |

    <!-- /table -->

``recovery`` names a :class:`TableSpec` of :data:`TABLES`: the records the table is made of
(paths relative to the repository's root: a recovery benchmark's ``summary.json``, missions'
``mission.json`` reports, the run directories of EEA studies) and the function that renders it
from them. :func:`render_page` replaces the body of every marked table of a page by its
rendering (``aquafish tables --write README.md``); :func:`check_page` lists every cell where the
page and the records disagree (``aquafish tables --check README.md``, which the tests run on the
repository's README). No result is typed here: each number comes from a record, or from a
definition the records are judged by (the thresholds :data:`aquafish.mission_table.ALARM_WITHIN_S`,
:data:`~aquafish.mission_table.RECOVERED_SHARE` and :data:`NEAR_TRUTH`, the goals :data:`ALARM_GOAL`
and :data:`~aquafish.mission_table.COMPUTE_BUDGET_S`). A number no record gives (the paper's own
values, which no run of this repository measured) is left out of the table, not typed in.

Three renderers cover the README's tables, each driven by its records, so that a table over
other records (a new benchmark directory, another set of missions) is a new :class:`TableSpec`
line, not new code:

* :func:`recovery_table`: one column per :class:`RecoveryColumn` (a benchmark's
  ``summary.json``, :func:`aquafish.recovery.summarize`), one row per row key of the summary's
  totals: in how many of the cells that break the healthy gait the row recovers;
* :func:`mission_table`: one column per :class:`MissionColumn` (missions' reports, judged by
  :func:`aquafish.mission_table.summarise_missions`), the goals beside them;
* :func:`study_table`: one column per :class:`StudyColumn` (a damage: its variants' EEA runs,
  summarised by :func:`eea.analysis.compare.compare_variants` as ``aquafish compare`` does), one
  row per :class:`StudyRow`: the final OBJ_FIT's mean ± std, Welch's p against the column's
  baseline on the seeds both ran, and how many runs end at :data:`NEAR_TRUTH` or above.
"""

from __future__ import annotations

import dataclasses
import glob
import re
import statistics
from functools import partial
from pathlib import Path
from typing import Callable, Mapping, NamedTuple, Sequence

from aquafish.mission import RECOVERED_FINAL_SHARE
from aquafish.mission_table import ALARM_WITHIN_S, COMPUTE_BUDGET_S, RECOVERED_SHARE, mission_row, read_missions, \
    summarise_missions
from aquafish.recovery import ROWS
from aquafish_gym.rundir import read_json

__all__ = ["ALARM_GOAL", "MISSION_FIELDS", "MISSION_ROWS", "NEAR_TRUTH", "RECOVERY_ROWS", "TABLES", "MissionColumn",
           "MissionRow", "RecoveryColumn", "StudyColumn", "StudyRow", "TableSpec", "check_page", "find_tables",
           "mission_table", "recovery_table", "render_page", "study_table"]

#: The missions' goal for alarms: an alarm within :data:`aquafish.mission_table.ALARM_WITHIN_S`
#: of the damage on at least this share of the missions (the goal :mod:`aquafish.mission_table`
#: states; a definition, like the other goals, not a result).
ALARM_GOAL = 0.95
#: The OBJ_FIT at or above which a run counts as near the truth, as ``aquafish compare``'s
#: ``>= 0.95`` column counts runs (a definition, not a result).
NEAR_TRUTH = 0.95

_OPEN = re.compile(r"<!--\s*table:\s*(\S+)\s*-->")
_CLOSE = re.compile(r"<!--\s*/table\s*-->")
_MARKER = re.compile(r"<!--\s*/?\s*table\b")


@dataclasses.dataclass(frozen=True)
class TableSpec:
    """One table of :data:`TABLES`: the records it is made of and how it is rendered.

    Attributes:
        records: the table's columns, each naming its records by paths relative to the root
            (:class:`RecoveryColumn`, :class:`MissionColumn` or :class:`StudyColumn`, as
            ``render`` takes them).
        render: ``render(records, root)``: the Markdown table (header, separator and rows, one
            line each, no trailing newline) from the records under the directory ``root``.
    """

    records: tuple
    render: Callable[[Sequence, Path], str]

    def table(self, root: str | Path = ".") -> str:
        """The table rendered from the records under ``root``.

        Raises:
            ValueError: a record is missing or unreadable, or does not hold what the table needs
                (the message names it).
        """
        return self.render(self.records, Path(root))


# ---------------------------------------------------------------------------------- common


def _read_json(root: Path, relative: str) -> dict:
    """The JSON object of the record ``root/relative`` (:func:`aquafish_gym.rundir.read_json`: a regular
    file, bounded; a :class:`~aquafish_gym.rundir.FileError`, a ``ValueError``, names a bad one)."""
    try:
        return read_json(root / relative)
    except FileNotFoundError:
        raise ValueError(f"{relative}: no such record under {root}") from None
    except OSError as err:
        raise ValueError(f"{relative}: cannot be read ({err})") from None


def _fill(template: str, **fields) -> str:
    """``template`` formatted with ``fields``; a field it names that is not among them is an error."""
    try:
        return template.format(**fields)
    except (KeyError, IndexError) as err:
        raise ValueError(f"{template!r} names {err.args[0]!r}; it may name {', '.join(fields)}") from None


def _row(cells: Sequence[str]) -> str:
    return "|" + "".join(f" {c} |" if c else " |" for c in cells)


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = [_row(header), "|" + "---|" * len(header)]
    lines += [_row(r) for r in rows]
    return "\n".join(lines)


def _bold(text: str) -> str:
    return f"**{text}**" if text else text


def _range(values: Sequence[int]) -> str:
    """``0-4`` for consecutive integers, else ``0,2,5``."""
    values = sorted(int(v) for v in values)
    if len(values) > 1 and values == list(range(values[0], values[-1] + 1)):
        return f"{values[0]}-{values[-1]}"
    return ",".join(map(str, values))


# ---------------------------------------------------------------------------------- recovery


class RecoveryColumn(NamedTuple):
    """A column of :func:`recovery_table`: one recovery benchmark.

    Attributes:
        title: the column's header, a template filled with ``duration`` (the episodes'
            seconds), ``preset``, ``breaking`` and ``cells`` (how many cells break the healthy
            gait, of how many) and ``damages`` (the benchmark's damages, consecutive sampled
            faults as a range: ```sampled:1000`-`1019```).
        summary: the benchmark's ``summary.json`` (``aquafish recovery``), relative to the root.
        cells: the ``summary.json`` of a run of every damage whose breaking cells ``summary``
            ran again (a benchmark re-run on its breaking cells only): it counts the cells and
            the damages, and its breaking cells must be ``summary``'s. None: ``summary`` counts
            them.
    """

    title: str
    summary: str
    cells: str | None = None


#: The recovery table's rows: (title, key). A key is a row of :data:`aquafish.recovery.ROWS`
#: (how many breaking cells it recovers in), ``identified`` (cells whose self-model has both
#: pectoral signs right), ``faults_named`` or ``strict_identification``. A bold title makes the
#: row's numbers bold.
RECOVERY_ROWS: tuple[tuple[str, str], ...] = (
    ("**the self-model**", "self_model"),
    ("PPO on the self-model", "ppo"),
    ("plain EEA (`none`, the paper's morphology)", "plain_eea"),
    ("the paper's out-of-band model", "out_of_band"),
    ("damage-robust NEAT (evolved on random damage presets)", "robust"),
    ("damage-robust PPO", "robust_ppo"),
    ("self-model with both pectoral signs right", "identified"),
)

#: Totals of a summary that are not rows: key -> the field of its count (beside ``of``).
_COUNTED = {"identified": "right", "faults_named": "named", "strict_identification": "strict"}


def _finished_summary(root: Path, relative: str) -> dict:
    summary = _read_json(root, relative)
    try:
        missing, totals, settings = summary.get("missing") or [], summary["totals"], summary["settings"]
        totals["cells"], totals["breaking"], totals["rows"], settings["episode_duration_s"]
    except (KeyError, TypeError) as err:
        raise ValueError(f"{relative}: not a recovery summary (aquafish recovery's summary.json): no {err}") from None
    if missing:
        raise ValueError(f"{relative}: {len(missing)} cells not finished; finish the benchmark (aquafish recovery "
                         "with its --out) before its table")
    return summary


def _damages_text(damages: Sequence[str]) -> str:
    """The damages, in order, runs of consecutive sampled faults as ```sampled:A`-`B```."""
    parts: list[str] = []
    run: list[int] = []

    def flush():
        if run:
            parts.append(f"`sampled:{run[0]}`" + (f"-`{run[-1]}`" if len(run) > 1 else ""))
            run.clear()

    for damage in damages:
        seed = damage.partition("sampled:")[2]
        if damage.startswith("sampled:") and seed.isdigit():
            if run and int(seed) != run[-1] + 1:
                flush()
            run.append(int(seed))
        else:
            flush()
            parts.append(f"`{damage}`")
    flush()
    return ", ".join(parts)


def _recovery_column(column: RecoveryColumn, root: Path) -> tuple[str, dict]:
    """The column's header and its totals."""
    summary = _finished_summary(root, column.summary)
    counted = summary if column.cells is None else _finished_summary(root, column.cells)
    if column.cells is not None:
        breaking = {(c["damage"], c["seed"]) for c in summary["cells"] if c["breaks"]}
        triaged = {(c["damage"], c["seed"]) for c in counted["cells"] if c["breaks"]}
        if breaking != triaged:
            raise ValueError(f"{column.summary}: its breaking cells are not those of {column.cells} "
                             f"({len(breaking)} against {len(triaged)})")
        for key in ("preset", "episode_duration_s"):
            if summary["settings"].get(key) != counted["settings"].get(key):
                raise ValueError(f"{column.summary} and {column.cells} differ in {key}")
    settings, totals = summary["settings"], summary["totals"]
    title = _fill(column.title, duration=f"{settings['episode_duration_s']:g}", preset=settings.get("preset"),
                  breaking=totals["breaking"], cells=counted["totals"]["cells"],
                  damages=_damages_text(counted["settings"].get("damages", ())))
    return title, totals


def _recovery_cell(totals: dict, key: str) -> str:
    """How many breaking cells the row counts: ``n``, or ``n of m`` when only ``m`` of them have it."""
    if key in _COUNTED:
        counts = totals.get(key)
        if not counts or not counts.get("of"):
            return ""
        n, of = counts[_COUNTED[key]], counts["of"]
    else:
        if key not in totals["rows"]:
            return ""
        n, of = totals["rows"][key]["recovers"], totals["rows"][key]["of"]
    return f"{n}" if of == totals["breaking"] else f"{n} of {of}"


def recovery_table(columns: Sequence[RecoveryColumn], root: Path, rows: Sequence[tuple[str, str]] = RECOVERY_ROWS,
                   first: str = "gait of") -> str:
    """The recovery benchmark's table: per row, in how many of the cells that break the healthy gait it recovers.

    Args:
        columns: one benchmark each.
        root: the directory the records' paths are relative to.
        rows: (title, key) per row (:data:`RECOVERY_ROWS`); a cell is empty where the benchmark
            has no such row (a row it did not run), and says ``n of m`` where only ``m`` of the
            breaking cells have the row.
        first: the header of the row titles' column.

    Raises:
        ValueError: no column or row, an unknown row key, a record missing, unreadable, not a
            recovery summary or not finished, a title naming an unknown field, or a ``cells``
            record whose breaking cells are not the summary's.
    """
    if not columns or not rows:
        raise ValueError("a recovery table needs at least one column and one row")
    unknown = [key for _, key in rows if key not in ROWS[1:] and key not in _COUNTED]
    if unknown:
        raise ValueError(f"unknown recovery rows {unknown}; valid: {', '.join((*ROWS[1:], *_COUNTED))}")
    read = [_recovery_column(c, root) for c in columns]
    body = []
    for title, key in rows:
        bold = title.startswith("**") and title.endswith("**")
        cells = [_recovery_cell(totals, key) for _, totals in read]
        body.append([title, *(_bold(c) if bold else c for c in cells)])
    return _table([first, *(title for title, _ in read)], body)


# ---------------------------------------------------------------------------------- missions


class MissionColumn(NamedTuple):
    """A column of :func:`mission_table`: a set of missions.

    Attributes:
        title: the column's header, a template filled with ``missions`` (how many).
        missions: the missions' reports, relative to the root: ``mission.json`` files (under any
            name: ``docs/results`` keeps them as ``<name>.json``), mission directories (an
            ``aquafish mission --out``), directories of mission directories, or glob patterns of
            any of these (each must match).
        idle: notes for the ``compute`` row from runs on an idle machine: (template, reports)
            pairs; the template is formatted with the reports' rows
            (:func:`aquafish.mission_table.mission_row`) as positional arguments
            (``{0[compute_s]:.1f} s idle``). The notes come before the range of the column's own
            compute seconds.
    """

    title: str
    missions: tuple[str, ...]
    idle: tuple[tuple[str, tuple[str, ...]], ...] = ()


class MissionRow(NamedTuple):
    """A row of :func:`mission_table`.

    Attributes:
        title: the row's title, a template filled with :data:`MISSION_FIELDS`.
        key: what its cells count: ``alarm`` (alarms within
            :data:`~aquafish.mission_table.ALARM_WITHIN_S` of the damage, and the range of the
            alarms' delays), ``simulations`` (the mean robot simulations from alarm to new gait,
            to the hundred; the first column says "a mission"), ``compute`` (the compute seconds
            from alarm to new gait: the column's idle notes, then the range of its missions'),
            or a count of :func:`aquafish.mission_table.summarise_missions`'s totals
            (``recovered_in_window``, ``recovered_20s``, ``recovered``, ``signs_right``, ...;
            ``n of m`` where fewer than all missions are judged).
        goal: the goal's cell, a template filled with :data:`MISSION_FIELDS`.
        bold: the row's numbers in bold.
    """

    title: str
    key: str
    goal: str = ""
    bold: bool = False


#: The fields the titles and goals of :class:`MissionRow` may name: the definitions the missions
#: are judged by, in the units a reader reads them in (seconds, percent).
MISSION_FIELDS = {"alarm_within_s": f"{ALARM_WITHIN_S:g}", "alarm_goal": f"{100 * ALARM_GOAL:.0f}",
                  "recovered_share": f"{100 * RECOVERED_SHARE:.0f}", "compute_budget_s": f"{COMPUTE_BUDGET_S:g}",
                  "final_share": f"{100 * RECOVERED_FINAL_SHARE:.0f}"}

#: The README's mission rows.
MISSION_ROWS: tuple[MissionRow, ...] = (
    MissionRow("alarm within {alarm_within_s} s of the damage", "alarm", "{alarm_goal} %"),
    MissionRow("**recovered**: further than carrying on with the old gait, and a final speed at least "
               "{final_share} % of the oracle's from the alarm", "recovered", "all", bold=True),
    MissionRow("further than carrying on with the old gait (net displacement from the onset)", "beats_keep_old"),
    MissionRow("final speed at least {final_share} % of the oracle's swum from the alarm", "final_80"),
    MissionRow("the older measure: after recovery {recovered_share} % of the oracle swum from the takeover state",
               "recovered_in_window"),
    MissionRow("simulations from alarm to new gait", "simulations"),
    MissionRow("compute from alarm to new gait, 2 cores", "compute", "{compute_budget_s} s"),
)

#: Counts of the totals judged among fewer than all missions: count -> how many were judged.
_JUDGED_AMONG = {"recovered": "judged", "recovered_in_window": "with_oracle", "recovered_20s": "with_oracle",
                 "signs_right": "signs_judged", "beats_keep_old": "with_counterfactuals",
                 "final_80": "with_counterfactuals"}


def _mission_paths(root: Path, entries: Sequence[str]) -> list[Path]:
    """Every report an entry of :attr:`MissionColumn.missions` names, in the order given."""
    found: list[Path] = []
    for entry in entries:
        matches = sorted(glob.glob(str(root / entry))) if glob.has_magic(entry) else [str(root / entry)]
        if not matches:
            raise ValueError(f"{entry}: matches no mission report under {root}")
        for match in map(Path, matches):
            if match.is_dir() and not (match / "mission.json").exists():
                inner = sorted(p.parent for p in match.glob("*/mission.json"))
                if not inner:
                    raise ValueError(f"{entry}: no mission.json in {match} or its subdirectories")
                found += inner
            elif not match.exists():
                raise ValueError(f"{entry}: no such mission report under {root}")
            else:
                found.append(match)
    return found


def _read_reports(root: Path, entries: Sequence[str]) -> list[dict]:
    """The reports of :func:`_mission_paths`, read and checked by :func:`aquafish.mission_table.read_missions`
    (a mission named twice refused)."""
    return read_missions(_mission_paths(root, entries))


def _simulations(report: dict) -> int | None:
    """The robot simulations a mission ran from alarm to new gait (every stage's; None if unrecorded)."""
    sims = report.get("simulations")
    return sum(sims.values()) if isinstance(sims, dict) and sims else None


def _span(values: Sequence[float], digits: int) -> str:
    """``lo-hi`` at ``digits`` decimals (one number when they print alike)."""
    lo, hi = f"{min(values):.{digits}f}", f"{max(values):.{digits}f}"
    return lo if lo == hi else f"{lo}-{hi}"


def _mission_cell(key: str, column: MissionColumn, root: Path, reports: list[dict], summary: dict,
                  first: bool) -> str:
    t, rows = summary["totals"], summary["rows"]
    if key == "alarm":
        delays = [r["alarm_delay_s"] for r in rows if r["alarm_delay_s"] is not None]
        return f"{t['alarm_in_time']}" + (f" ({_span(delays, 1)} s)" if delays else "")
    if key == "simulations":
        sims = [s for s in map(_simulations, reports) if s is not None]
        return "" if not sims else f"{round(statistics.mean(sims), -2):,.0f}" + (" a mission" if first else "")
    if key == "compute":
        notes = []
        for template, paths in column.idle:
            idle_rows = [mission_row(r) for r in _read_reports(root, paths)]
            try:
                notes.append(template.format(*idle_rows))
            except (KeyError, IndexError) as err:
                raise ValueError(f"idle note {template!r}: its reports have no {err.args[0]!r}") from None
        compute = [r["compute_s"] for r in rows if r["compute_s"] is not None]
        return "; ".join([*notes, *([f"{_span(compute, 0)} s loaded"] if compute else [])])
    if key not in t or key in ("missions", "median_compute_s", "median_alarm_delay_s"):
        raise ValueError(f"unknown mission row {key!r}; valid: alarm, simulations, compute, "
                         + ", ".join(k for k in t if k != "missions" and not k.startswith("median")))
    among = t.get(_JUDGED_AMONG.get(key, "missions"), t["missions"])
    if key in _JUDGED_AMONG and not among:
        return ""
    return f"{t[key]}" + ("" if among == t["missions"] else f" of {among}")


def mission_table(columns: Sequence[MissionColumn], root: Path, rows: Sequence[MissionRow] = MISSION_ROWS,
                  first: str = "", goal: str = "goal") -> str:
    """The missions' table: per set of missions, how many met each goal, and at what cost.

    Each column's missions are judged by :func:`aquafish.mission_table.summarise_missions`; a
    row (:class:`MissionRow`) counts one of its totals or gives the alarms' delays, the
    simulations or the compute from alarm to new gait. The last column holds the goals.

    Args:
        columns: one set of missions each.
        root: the directory the records' paths are relative to.
        rows: the rows (:data:`MISSION_ROWS`).
        first: the header of the row titles' column.
        goal: the header of the goals' column.

    Raises:
        ValueError: no column or row, an unknown row key, a report missing, unreadable or
            without a mission's fields, a pattern that matches nothing, a mission named twice,
            or a title, goal or note naming an unknown field.
    """
    if not columns or not rows:
        raise ValueError("a mission table needs at least one column and one row")
    titles, cells = [], []
    for i, column in enumerate(columns):
        reports = _read_reports(root, column.missions)
        summary = summarise_missions(reports)
        titles.append(_fill(column.title, missions=summary["totals"]["missions"]))
        cells.append([_mission_cell(row.key, column, root, reports, summary, i == 0) for row in rows])
    body = []
    for j, row in enumerate(rows):
        values = [c[j] for c in cells]
        body.append([_fill(row.title, **MISSION_FIELDS), *(_bold(v) if row.bold else v for v in values),
                     _fill(row.goal, **MISSION_FIELDS)])
    return _table([first, *titles, goal], body)


# ---------------------------------------------------------------------------------- studies


class StudyColumn(NamedTuple):
    """A column of :func:`study_table`: one damage's EEA runs, by variant.

    Attributes:
        title: the column's header.
        variants: variant name -> the directories of its runs, relative to the root (as
            ``aquafish compare LABEL=DIR``: searched recursively, one run per seed; several
            directories join their seeds).
        baseline: the variant Welch's p is computed against (on the seeds both ran).
    """

    title: str
    variants: Mapping[str, tuple[str, ...]]
    baseline: str


class StudyRow(NamedTuple):
    """A row of :func:`study_table`: one variant across the columns.

    Attributes:
        title: the row's title, a template filled with ``seeds`` (``0-4``; the same in every column).
        variant: the variant's name in every column's :attr:`StudyColumn.variants`.
        p: give Welch's p against the column's baseline.
        count: give how many runs end at :data:`NEAR_TRUTH` or above (``9/10``; the first column
            says ``>= 0.95``).
        bold: a mean at :data:`NEAR_TRUTH` or above in bold.
    """

    title: str
    variant: str
    p: bool = False
    count: bool = False
    bold: bool = False


def _p_text(p: float) -> str:
    """Three decimals, or two significant digits where three decimals would show 0 (``0.068``, ``1.7e-05``)."""
    return f"{p:.3f}" if round(p, 3) > 0 else f"{p:.2g}"


def _study_cell(summary, base, row: StudyRow, first: bool) -> str:
    from eea.analysis.plot import welch_p_value

    text = f"{summary.mean:.3f} ± {summary.std:.3f}"
    if row.bold and summary.mean >= NEAR_TRUTH:
        text = _bold(text)
    extras = []
    if row.count:
        near = int((summary.final >= NEAR_TRUTH).sum())
        extras.append(f"{near}/{len(summary.seeds)}" + (f" >= {NEAR_TRUTH:g}" if first else ""))
    if row.p and summary is not base:
        common = sorted(set(summary.seeds.tolist()) & set(base.seeds.tolist()))
        p = welch_p_value(summary.final_on(common), base.final_on(common))
        if p == p:  # NaN: the test is undefined on these seeds
            extras.append(f"p {_p_text(p)}")
    return text + (f" ({', '.join(extras)})" if extras else "")


def study_table(columns: Sequence[StudyColumn], root: Path, rows: Sequence[StudyRow] = (), first: str = "method",
                rounds: int | None = None, reference: tuple[str, str] | None = None) -> str:
    """The final OBJ_FIT of EEA variants: a row per variant, a column per damage.

    Each column's variants are summarised at one round by
    :func:`eea.analysis.compare.compare_variants` (the ``aquafish compare`` table's numbers): a
    cell is the final OBJ_FIT's mean ± std (ddof 0), then, as the row asks, how many runs end at
    :data:`NEAR_TRUTH` or above and Welch's p (:func:`eea.analysis.plot.welch_p_value`) against
    the column's baseline on the seeds both ran.

    Args:
        columns: one damage each.
        root: the directory the records' paths are relative to.
        rows: one variant each.
        first: the header of the row titles' column.
        rounds: the round compared; None: the shortest planned run of each column's variants.
        reference: a last column of published values: its title and a JSON record (relative to
            ``root``) whose ``objective_fitness`` maps a variant to its text (a row whose variant
            it lacks is left empty), e.g. the paper's values read off its figures.

    Raises:
        ValueError: no column or row, a variant or baseline a column lacks, run directories
            missing or without finished runs, a row whose seeds differ between columns, a
            reference record that cannot be read.
    """
    from eea.analysis.compare import compare_variants
    from eea.analysis.plot import find_runs

    if not columns or not rows:
        raise ValueError("a study table needs at least one column and one row")
    summaries = []
    for column in columns:
        missing = sorted({r.variant for r in rows} - set(column.variants)) + (
            [column.baseline] if column.baseline not in column.variants else [])
        if missing:
            raise ValueError(f"column {column.title!r} has no variant {', '.join(map(repr, missing))}")
        names = list(dict.fromkeys([*(r.variant for r in rows), column.baseline]))
        runs = {name: find_runs([root / d for d in column.variants[name]]) for name in names}
        summaries.append(compare_variants(runs, rounds=rounds))
    body = []
    for row in rows:
        seeds = {_range(s[row.variant].seeds) for s in summaries}
        if len(seeds) > 1:
            raise ValueError(f"row {row.title!r}: its seeds differ between the columns ({', '.join(sorted(seeds))})")
        cells = [_study_cell(s[row.variant], s[c.baseline], row, i == 0)
                 for i, (s, c) in enumerate(zip(summaries, columns))]
        body.append([_fill(row.title, seeds=seeds.pop()), *cells])
    if reference is None:
        return _table([first, *(c.title for c in columns)], body)
    title, path = reference
    published = _read_json(root, path).get("objective_fitness")
    if not isinstance(published, dict):
        raise ValueError(f"{path}: not a reference record: no objective_fitness object")
    for line, row in zip(body, rows):
        line.append(str(published.get(row.variant, "")))
    return _table([first, *(c.title for c in columns), title], body)


#: The surface swimmer's self-modeling runs (``reduced`` budget): variant -> run directories,
#: ``{key}`` the damage's short name.
_SURFACE_RUNS = {
    "known": ("docs/results/surface_paper4_{key}/known",),
    "none": ("docs/results/surface_paper4_{key}/none",),
    "in_band": ("docs/results/surface_paper4_{key}/in_band",),
    "out_of_band": ("docs/results/surface_paper4_{key}/out_of_band",),
    "out_of_band, every seed": ("docs/results/surface_paper4_{key}/out_of_band",
                                "docs/results/surface_oob_{key}_5_9/out_of_band"),
    "profile_lineages": ("docs/results/surface_lin2_{key}/profile_lineages",),
}


def _surface_column(title: str, key: str) -> StudyColumn:
    return StudyColumn(title, {name: tuple(d.format(key=key) for d in dirs) for name, dirs in _SURFACE_RUNS.items()},
                       baseline="out_of_band, every seed")


# ---------------------------------------------------------------------------------- the tables

#: The README's tables by name (the name of their markers).
TABLES: dict[str, TableSpec] = {
    "recovery": TableSpec(records=(
        RecoveryColumn("{duration} s, sealed set `benchmark_20s`: {breaking} of {cells} cells break",
                       "docs/results/heldout/benchmark_20s/summary.json"),
    ), render=partial(recovery_table, rows=(*RECOVERY_ROWS, (
        "self-model identified strictly (every part's fault kind right, no healthy part held faulty)",
        "strict_identification")))),
    "mission": TableSpec(records=(
        MissionColumn("sealed set `missions_development_damages` ({missions} missions)",
                      ("docs/results/heldout/missions_development_damages/*.json",)),
        MissionColumn("sealed set `missions_fresh_faults` ({missions})",
                      ("docs/results/heldout/missions_fresh_faults/*.json",)),
        MissionColumn("validation, before the counterfactuals ({missions})",
                      ("docs/results/missions_hyp/warm_*_s[0-2].json", "docs/results/missions_hyp/warm_sampled10*_s500*.json")),
    ), render=partial(mission_table, rows=MISSION_ROWS)),
    "obj_fit": TableSpec(records=(
        _surface_column("`left_pectoral_half`", "lph"),
        _surface_column("`right_pectoral_half`", "rph"),
        _surface_column("`caudal_half`", "ch"),
    ), render=partial(study_table, rows=(
        StudyRow("`known`, seeds {seeds}", "known", p=True),
        StudyRow("`none`, seeds {seeds}", "none"),
        StudyRow("`in_band`, seeds {seeds}", "in_band"),
        StudyRow("`out_of_band`, seeds {seeds}", "out_of_band"),
        StudyRow("**best method** (`profile_lineages`), seeds {seeds}", "profile_lineages", p=True, count=True,
                 bold=True),
    ), reference=("paper", "docs/results/paper_reference.json"))),
}


# ---------------------------------------------------------------------------------- pages


@dataclasses.dataclass(frozen=True)
class _Block:
    """A marked table of a page: its name and the 0-based indices of its two marker lines."""

    name: str
    open: int
    close: int


def find_tables(text: str, source: str = "the page", tables: Mapping[str, TableSpec] | None = None) -> list[_Block]:
    """The marked tables of a page, in order.

    Args:
        text: the page.
        source: the page's name in messages.
        tables: the known tables (default :data:`TABLES`).

    Raises:
        ValueError: a marker naming an unknown table, an opening marker not closed before the
            next one or the end of the page, a closing marker without an opening one, or a
            malformed marker (the message names the line).
    """
    tables = TABLES if tables is None else tables
    blocks, opened = [], None
    for i, line in enumerate(text.splitlines()):
        stripped = line.strip()
        opening, closing = _OPEN.fullmatch(stripped), _CLOSE.fullmatch(stripped)
        if opening:
            name = opening.group(1)
            if opened is not None:
                raise ValueError(f"{source} line {opened[1] + 1}: table {opened[0]!r} is not closed "
                                 f"(line {i + 1} opens another before <!-- /table -->)")
            if name not in tables:
                raise ValueError(f"{source} line {i + 1}: unknown table {name!r}; known: {', '.join(tables)}")
            opened = (name, i)
        elif closing:
            if opened is None:
                raise ValueError(f"{source} line {i + 1}: <!-- /table --> closes no table")
            blocks.append(_Block(opened[0], opened[1], i))
            opened = None
        elif _MARKER.match(stripped):
            raise ValueError(f"{source} line {i + 1}: malformed table marker {stripped!r}; write "
                             "<!-- table: NAME --> or <!-- /table -->")
    if opened is not None:
        raise ValueError(f"{source} line {opened[1] + 1}: table {opened[0]!r} is not closed (no <!-- /table --> "
                         "after it)")
    return blocks


def _rendered(blocks: Sequence[_Block], root: Path, tables: Mapping[str, TableSpec]) -> dict[str, str]:
    return {name: tables[name].table(root) for name in dict.fromkeys(b.name for b in blocks)}


def render_page(text: str, root: str | Path = ".", source: str = "the page",
                tables: Mapping[str, TableSpec] | None = None) -> str:
    """``text`` with the body of every marked table replaced by its rendering (a blank line, the
    table, a blank line); the rest of the page as it was.

    Args:
        text: the page.
        root: the directory the records' paths are relative to.
        source: the page's name in messages.
        tables: the known tables (default :data:`TABLES`).

    Raises:
        ValueError: as :func:`find_tables`, or a table that cannot be rendered from its records.
    """
    tables = TABLES if tables is None else tables
    lines = text.splitlines(keepends=True)
    blocks = find_tables(text, source, tables)
    rendered = _rendered(blocks, Path(root), tables)
    newline = "\r\n" if lines and lines[0].endswith("\r\n") else "\n"
    for block in reversed(blocks):
        body = [newline, *(line + newline for line in rendered[block.name].splitlines()), newline]
        lines[block.open + 1:block.close] = body
    return "".join(lines)


def _cells(line: str) -> list[str]:
    """A Markdown table row's cells (an escaped ``\\|`` stays in its cell)."""
    line = line.strip()
    if line.startswith("|"):
        line = line[1:]
    if line.endswith("|") and not line.endswith("\\|"):
        line = line[:-1]
    return [c.strip() for c in re.split(r"(?<!\\)\|", line)]


def _differences(name: str, page: list[str], records: list[str]) -> list[str]:
    """Each cell where the page's table differs from the records': table, row, column, both texts."""
    page_rows, record_rows = [_cells(x) for x in page], [_cells(x) for x in records]
    out = []

    def compare(row_name: str, ours: list[str], theirs: list[str], header: list[str]) -> None:
        for i in range(max(len(ours), len(theirs))):
            a = ours[i] if i < len(ours) else "(no cell)"
            b = theirs[i] if i < len(theirs) else "(no cell)"
            if a != b:
                column = header[i] if i < len(header) and header[i] else f"column {i + 1}"
                out.append(f"table {name!r}, row {row_name!r}, column {column!r}: the page has {a!r}, "
                           f"the records give {b!r}")

    if not page_rows:
        return [f"table {name!r}: the page has no table between its markers"]
    header = page_rows[0]
    compare("(header)", page_rows[0], record_rows[0], header)
    page_body, record_body = page_rows[2:], record_rows[2:]
    if len(page_body) == len(record_body):
        for ours, theirs in zip(page_body, record_body):
            compare(ours[0], ours, theirs, header)
    else:
        theirs_by_title = {r[0]: r for r in record_body}
        ours_titles = {r[0] for r in page_body}
        for ours in page_body:
            if ours[0] in theirs_by_title:
                compare(ours[0], ours, theirs_by_title[ours[0]], header)
            else:
                out.append(f"table {name!r}, row {ours[0]!r}: on the page, not in the records' table")
        out += [f"table {name!r}, row {r[0]!r}: in the records' table, not on the page"
                for r in record_body if r[0] not in ours_titles]
    if not out and page != records:  # the separator, or spacing the cells do not show
        out.append(f"table {name!r}: the lines differ in layout (separator or spacing)")
    return out


def check_page(text: str, root: str | Path = ".", source: str = "the page",
               tables: Mapping[str, TableSpec] | None = None) -> tuple[int, list[str]]:
    """Compare every marked table of a page with its rendering from the records.

    Args:
        text: the page.
        root: the directory the records' paths are relative to.
        source: the page's name in messages.
        tables: the known tables (default :data:`TABLES`).

    Returns:
        ``(tables, differences)``: how many marked tables the page has, and one line per cell
        that differs (the table's name, the row by its first cell, the column by its header, the
        page's text and the records'); no lines when all agree.

    Raises:
        ValueError: as :func:`find_tables`, or a table that cannot be rendered from its records.
    """
    tables = TABLES if tables is None else tables
    lines = text.splitlines()
    blocks = find_tables(text, source, tables)
    rendered = _rendered(blocks, Path(root), tables)
    differences = []
    for block in blocks:
        page = [line.rstrip() for line in lines[block.open + 1:block.close] if line.strip()]
        differences += _differences(block.name, page, rendered[block.name].splitlines())
    return len(blocks), differences
