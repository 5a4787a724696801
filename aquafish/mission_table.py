"""The mission table: many missions' ``mission.json`` in one table, judged against the mission's goals.

A mission (:mod:`aquafish.mission`) answers for one damage and one seed. ``aquafish mission-table
DIR ...`` reads finished missions (each ``DIR/mission.json``) and writes what a reader needs to
judge the whole: one row per mission (damage, seed, search start, alarm delay, target
experiments, compute, the speeds, the net displacement and final speed beside the two
counterfactuals', the gains found beside the truth) and the totals the goals are stated in:

* an alarm within :data:`ALARM_WITHIN_S` of the damage (and none before it) on at least 95 %
  of missions;
* **recovered** (``mission.json``'s ``recovered``, :func:`aquafish.mission.judge_recovery`): the
  mission's net displacement from the onset beats ``keep_old``'s (the old gait carrying on)
  and its final speed is at least 80 % of ``oracle_at_alarm``'s (the independent oracle gait
  from the alarm's state); no yardstick holds the mission's own procedure;
* beside it, the older measures: the speed after recovery against the oracle swum in the same
  window from the same state (``recovered_in_window``) and against the oracle's 20 s speed from
  rest (``recovered_20s``), each at :data:`RECOVERED_SHARE`;
* from alarm to new gait, at most :data:`COMPUTE_BUDGET_S` seconds of compute.

Speeds are displacement along the mission's heading per second (units/s, 1 unit = 8 cm), as
``mission.json`` records them.
"""

from __future__ import annotations

import json
import math
import os
import statistics
from pathlib import Path
from typing import Sequence

from aquafish.mission import RECOVERED_FINAL_SHARE
from aquafish.recovery import signs_right
from aquafish_gym.checks import short_json
from aquafish_gym.files import InputFileError, parse_json, read_input

__all__ = ["ALARM_WITHIN_S", "COMPUTE_BUDGET_S", "RECOVERED_SHARE", "WINDOW_ORACLE_MIN_SHARE", "check_report",
           "format_table",
           "mission_row", "read_missions", "summarise_missions"]

#: The alarm must come within this many seconds of the damage coming in force.
ALARM_WITHIN_S = 10.0
#: The older measures: the speed after recovery is at least this share of the oracle gait's.
RECOVERED_SHARE = 0.8
#: The oracle in the window judges a mission only where it swims at least this share of the
#: 20 s oracle's speed; else (no gait known turns the robot back within the window: the
#: yardstick is near 0 and any crawl would pass) the 20 s oracle judges, the harder test.
WINDOW_ORACLE_MIN_SHARE = 0.25
#: Compute from alarm to new gait allowed (seconds, the 2-core machine).
COMPUTE_BUDGET_S = 300.0

_GAINS = ("left_pectoral_gain", "right_pectoral_gain", "caudal_gain")
_MORPHOLOGY_KEYS = ("left_pectoral_x", "left_pectoral_y", "right_pectoral_x", "right_pectoral_y")


def read_missions(directories: Sequence[str | os.PathLike]) -> list[dict]:
    """The ``mission.json`` report of every directory, in the order given. An entry that is a file
    is read as a mission report itself (``docs/results`` keeps reports as ``<name>.json``).

    Raises:
        ValueError: no directory given, a directory given twice, or one without a readable
            ``mission.json`` (the message names it: a mission still running has none yet), or
            whose ``mission.json`` is no mission report (:func:`check_report`: the file and the
            field named).
    """
    if not directories:
        raise ValueError("give at least one mission directory (an aquafish mission --out)")
    seen: set[Path] = set()
    reports = []
    for d in directories:
        path = Path(d) if Path(d).is_file() else Path(d) / "mission.json"
        key = path.resolve()
        if key in seen:
            raise ValueError(f"{d}: given twice")
        seen.add(key)
        try:
            report = parse_json(read_input(path), source=path)  # a regular file, bounded, not nested too deep
        except InputFileError as err:
            raise ValueError(f"{err}; give a mission directory") from None
        except FileNotFoundError:
            raise ValueError(f"{d}: no mission.json (not a mission directory, or the mission has not finished)") from None
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as err:
            raise ValueError(f"{path}: cannot be read as a mission report ({err})") from None
        try:
            check_report(report)
        except ValueError as err:
            raise ValueError(f"{path}: {err}") from None
        reports.append(report)
    return reports


def _shown(value) -> str:
    """A report's value in a message (:func:`aquafish_gym.checks.short_json`)."""
    return short_json(value, 40)


def _number(value) -> bool:
    """A finite real number (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_numbers(record: dict, keys, where: str = "", required: bool = False) -> None:
    for key in keys:
        if key not in record:
            if required:
                raise ValueError(f"not a mission report: no {where}{key!r} field")
            continue
        value = record[key]
        if value is not None and not _number(value):
            raise ValueError(f"not a mission report: field {where}{key!r} must be a finite number or null, got "
                             f"{_shown(value)}")


def _check_mapping(record: dict, key: str, where: str = "") -> dict:
    value = record.get(key)
    if value is not None and not isinstance(value, dict):
        raise ValueError(f"not a mission report: field {where}{key!r} must be a JSON object or null, got "
                         f"{_shown(value)}")
    return value or {}


def check_report(report) -> None:
    """Check that ``report`` has the shape of a ``mission.json``: the fields :func:`mission_row`
    reads, each of its type; every distance, speed and time a finite number or null (NaN is
    refused, not counted).

    Raises:
        ValueError: one line naming the first field that is missing or of the wrong shape.
    """
    if not isinstance(report, dict):
        raise ValueError(f"not a mission report: holds a JSON {type(report).__name__}, not an object")
    for key in ("damage", "seed", "warm_start", "false_alarm", "target_experiments", "compute_seconds", "onset_s",
                "alarm_s", "speed_before", "speed_damaged", "speed_after", "oracle_speed", "true_model"):
        if key not in report:
            raise ValueError(f"not a mission report: no {key!r} field")
    kinds = {"damage": (str, "a string"), "warm_start": (bool, "true or false"), "false_alarm": (bool, "true or false")}
    for key, (kind, text) in kinds.items():
        if not isinstance(report[key], kind):
            raise ValueError(f"not a mission report: field {key!r} must be {text}, got {_shown(report[key])}")
    for key in ("seed", "target_experiments"):
        value = report[key]
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise ValueError(f"not a mission report: field {key!r} must be an int >= 0, got {_shown(value)}")
    if report.get("recovered") is not None and not isinstance(report["recovered"], bool):
        raise ValueError(f"not a mission report: field 'recovered' must be true, false or null, got "
                         f"{_shown(report['recovered'])}")
    if "new_gait_start" in report and report["new_gait_start"] not in ("mission_heading", "robot_heading"):
        raise ValueError(f"not a mission report: field 'new_gait_start' must be \"mission_heading\" or "
                         f"\"robot_heading\", got {_shown(report['new_gait_start'])}")
    _check_numbers(report, ("onset_s", "damage_in_force_s", "alarm_s", "compute_seconds", "speed_before",
                            "speed_damaged", "speed_after", "oracle_speed", "net_displacement", "final_speed"))
    _check_numbers(_check_mapping(report, "oracle_in_window"), ("best",), "oracle_in_window.")
    _check_mapping(report, "self_model_fields")
    truth = _check_mapping(report, "true_model")
    if not truth:
        raise ValueError(f"not a mission report: field 'true_model' must be a JSON object of the true gains, got "
                         f"{_shown(report['true_model'])}")
    _check_numbers(truth, _GAINS, "true_model.", required=True)
    _check_numbers(truth, _MORPHOLOGY_KEYS, "true_model.")
    if _check_mapping(report, "self_model_after"):
        _check_numbers(report["self_model_after"], _GAINS, "self_model_after.", required=True)
    counterfactuals = _check_mapping(report, "counterfactuals")
    for name in ("keep_old", "oracle_at_alarm"):
        _check_numbers(_check_mapping(counterfactuals, name, "counterfactuals."), ("net_displacement", "final_speed"),
                       f"counterfactuals.{name}.")


def _share(after, oracle) -> float | None:
    if after is None or oracle is None or not oracle > 0:
        return None
    return after / oracle


def _new_gait(report: dict) -> str:
    if "new_gait_start_yaws_deg" in report:
        return "spread"
    return report.get("new_gait_start", "mission_heading")


def mission_row(report: dict) -> dict:
    """One mission's row of the table, from its ``mission.json`` report.

    Returns:
        A dict: ``damage``, ``seed``, ``warm_start``, ``false_alarm``, ``alarm_delay_s`` (alarm
        minus the damage coming in force; None without an alarm or for a false alarm),
        ``target_experiments``, ``compute_s``, ``speed_before``, ``speed_damaged``,
        ``speed_after``, ``oracle_speed`` (units/s), ``self_model_fields`` (the recovery's own
        EEA settings; ``{}`` for none or a report made before they were recorded),
        ``new_gait`` (how the new gait's episodes started: ``"spread"``, turned by
        ``new_gait_start_yaws_deg`` and scored along the mission's heading, as today's missions;
        ``"mission_heading"`` or ``"robot_heading"`` for a report of an earlier version, whose
        episodes all started one way),
        ``after_share`` (``speed_after`` over ``oracle_speed``; None without an oracle that
        swims forward), ``oracle_in_window`` (the best oracle's speed in ``speed_after``'s
        window, units/s; None in a report without it) and ``window_share`` (``speed_after`` over
        it), ``gains`` (found) and
        ``true_gains`` (three each: left, right pectoral, caudal), ``signs_right`` (as
        :func:`aquafish.recovery.signs_right`; None without a recovery); the counterfactuals'
        measures: ``net_displacement`` and ``final_speed`` (the mission's), ``keep_old_net``,
        ``keep_old_final``, ``oracle_at_alarm_net``, ``oracle_at_alarm_final`` (units, units/s;
        None in a report made before them), ``beats_keep_old``, ``final_share`` (final speed over
        ``oracle_at_alarm``'s) and ``recovered`` (``mission.json``'s; None without it); and the
        verdicts ``alarm_in_time``, ``recovered_in_window`` (the older measure: by
        ``window_share`` where ``window_judges``: there is an oracle in the window and it swims
        at least :data:`WINDOW_ORACLE_MIN_SHARE` of the 20 s oracle's speed; else by
        ``after_share``), ``recovered_20s`` (by ``after_share`` alone) and ``compute_in_budget``.

    Raises:
        ValueError: a report without the fields a mission writes or with one of the wrong shape
            (:func:`check_report`; the message names the first).
    """
    check_report(report)
    try:
        onset = report.get("damage_in_force_s", report["onset_s"])
        alarm, false_alarm = report["alarm_s"], bool(report["false_alarm"])
        after, oracle = report["speed_after"], report["oracle_speed"]
        truth, found = report["true_model"], report.get("self_model_after")
        row = {"damage": report["damage"], "seed": report["seed"], "warm_start": report["warm_start"],
               "false_alarm": false_alarm, "target_experiments": report["target_experiments"],
               "compute_s": report["compute_seconds"], "speed_before": report["speed_before"],
               "speed_damaged": report["speed_damaged"], "speed_after": after, "oracle_speed": oracle,
               "self_model_fields": dict(report.get("self_model_fields") or {}),
               "new_gait": _new_gait(report),
               "oracle_in_window": (report.get("oracle_in_window") or {}).get("best")}
    except KeyError as err:
        raise ValueError(f"not a mission report: no {err.args[0]!r} field") from None
    delay = None if alarm is None or false_alarm or onset is None else alarm - onset
    share = _share(after, oracle)
    row["alarm_delay_s"] = delay
    row["after_share"] = share
    row["window_share"] = _share(after, row["oracle_in_window"])
    window = row["oracle_in_window"]
    row["window_judges"] = (window is not None and share is not None
                            and window >= WINDOW_ORACLE_MIN_SHARE * oracle)
    judged = row["window_share"] if row["window_judges"] else share
    row["true_gains"] = [truth[k] for k in _GAINS]
    row["gains"] = [found[k] for k in _GAINS] if found else None
    morphology = {k: truth[k] for k in _MORPHOLOGY_KEYS if k in truth}
    row["signs_right"] = (signs_right({"self_model": found, "target": truth}, morphology) if found else None)
    row["alarm_in_time"] = delay is not None and delay <= ALARM_WITHIN_S
    row["recovered_in_window"] = judged is not None and judged >= RECOVERED_SHARE
    counterfactuals = report.get("counterfactuals") or {}
    keep, at_alarm = counterfactuals.get("keep_old") or {}, counterfactuals.get("oracle_at_alarm") or {}
    row["net_displacement"], row["final_speed"] = report.get("net_displacement"), report.get("final_speed")
    row["keep_old_net"], row["keep_old_final"] = keep.get("net_displacement"), keep.get("final_speed")
    row["oracle_at_alarm_net"] = at_alarm.get("net_displacement")
    row["oracle_at_alarm_final"] = at_alarm.get("final_speed")
    row["beats_keep_old"] = (None if row["net_displacement"] is None or row["keep_old_net"] is None
                             else row["net_displacement"] > row["keep_old_net"])
    row["final_share"] = _share(row["final_speed"], row["oracle_at_alarm_final"])
    row["recovered"] = report.get("recovered")
    row["recovered_20s"] = share is not None and share >= RECOVERED_SHARE
    row["compute_in_budget"] = row["compute_s"] is not None and row["compute_s"] <= COMPUTE_BUDGET_S
    return row


def summarise_missions(reports: Sequence[dict]) -> dict:
    """The table's rows and totals.

    Returns:
        ``{"rows": [mission_row, ...], "totals": {...}}``: ``missions``, ``false_alarms``,
        ``alarm_in_time`` (missions with an alarm within :data:`ALARM_WITHIN_S` of the damage),
        ``recovered`` (against the counterfactuals, among the missions judged so: ``judged``),
        ``beats_keep_old`` and ``final_80`` (its two parts, among the missions with the
        counterfactuals: ``with_counterfactuals``), ``recovered_in_window`` (the older
        measure, at least :data:`RECOVERED_SHARE` of the oracle after recovery, as
        :func:`mission_row` judges it; among missions with an oracle speed: ``with_oracle``),
        ``recovered_20s`` (against the 20 s oracle alone), ``with_window`` (missions judged by
        the oracle in the window, ``window_judges``), ``signs_right`` (among missions whose
        verdict is not None: ``signs_judged``), ``compute_in_budget``, and the median compute
        seconds and alarm delay.
    """
    rows = [mission_row(r) for r in reports]
    delays = [r["alarm_delay_s"] for r in rows if r["alarm_delay_s"] is not None]
    compute = [r["compute_s"] for r in rows if r["compute_s"] is not None]
    judged = [r["signs_right"] for r in rows if r["signs_right"] is not None]
    totals = {
        "missions": len(rows),
        "false_alarms": sum(r["false_alarm"] for r in rows),
        "alarm_in_time": sum(r["alarm_in_time"] for r in rows),
        "judged": sum(r["recovered"] is not None for r in rows),
        "recovered": sum(bool(r["recovered"]) for r in rows),
        "with_counterfactuals": sum(r["beats_keep_old"] is not None for r in rows),
        "beats_keep_old": sum(bool(r["beats_keep_old"]) for r in rows),
        "final_80": sum(r["final_share"] is not None and r["final_share"] >= RECOVERED_FINAL_SHARE for r in rows),
        "with_oracle": sum(r["after_share"] is not None for r in rows),
        "recovered_in_window": sum(r["recovered_in_window"] for r in rows),
        "recovered_20s": sum(r["recovered_20s"] for r in rows),
        "with_window": sum(r["window_judges"] for r in rows),
        "signs_judged": len(judged),
        "signs_right": sum(judged),
        "compute_in_budget": sum(r["compute_in_budget"] for r in rows),
        "median_compute_s": _median(compute),
        "median_alarm_delay_s": _median(delays),
    }
    return {"rows": rows, "totals": totals}


def _median(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def _num(x, digits: int = 3) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _percent(share, tick: bool) -> str:
    return "-" if share is None else f"{100 * share:.0f} %" + (" ✓" if tick else "")


def _gains(g) -> str:
    return "-" if g is None else ", ".join(f"{x:+g}" for x in g)


def format_table(summary: dict) -> str:
    """``summary`` (:func:`summarise_missions`) as a Markdown table and a line of totals."""
    from aquafish.case_study import format_self_model_fields

    head = ("| damage | seed | EEA start | alarm after the damage (s) | experiments | compute (s) | "
            "net from the onset: mission | keep old | oracle at alarm | final speed: mission | keep old | "
            "oracle at alarm | final / oracle at alarm | recovered | speed before | "
            "damaged | after | oracle (20 s) | after / oracle | oracle in window | after / oracle in window | "
            "gains found (L, R, C) | true | signs |")
    lines = [head, "|" + "---|" * head.count(" | ") + "---|"]
    settings: list[str] = []  # the distinct own EEA settings, marked ‡1, ‡2, ... in the rows
    for r in summary["rows"]:
        start = "warm" if r["warm_start"] else "cold"
        if r.get("self_model_fields"):
            text = format_self_model_fields(r["self_model_fields"])
            if text not in settings:
                settings.append(text)
            start += f" ‡{settings.index(text) + 1}"
        if r.get("new_gait", "spread") != "spread":
            start += {"mission_heading": ", gait from +y only", "robot_heading": ", gait from the robot's heading"}[
                r["new_gait"]]
        alarm = "false alarm" if r["false_alarm"] else _num(r["alarm_delay_s"], 1)
        windowed = r["window_judges"]
        dagger = "" if windowed or r["oracle_in_window"] is None else " †"  # the window's oracle does not judge
        share = _percent(r["after_share"], r["recovered_in_window"] and not windowed)
        window_share = _percent(r["window_share"], r["recovered_in_window"] and windowed)
        recovered = {True: "**yes**", False: "no", None: "-"}[r["recovered"]]
        signs = {True: "✓", False: "✗", None: "-"}[r["signs_right"]]
        lines.append(f"| `{r['damage']}` | {r['seed']} | {start} | {alarm} | "
                     f"{r['target_experiments']} | {_num(r['compute_s'], 0)} | {_num(r['net_displacement'], 1)} | "
                     f"{_num(r['keep_old_net'], 1)} | {_num(r['oracle_at_alarm_net'], 1)} | {_num(r['final_speed'])} | "
                     f"{_num(r['keep_old_final'])} | {_num(r['oracle_at_alarm_final'])} | "
                     f"{_percent(r['final_share'], False)} | {recovered} | {_num(r['speed_before'])} | "
                     f"{_num(r['speed_damaged'])} | {_num(r['speed_after'])} | {_num(r['oracle_speed'])} | {share} | "
                     f"{_num(r['oracle_in_window'])}{dagger} | {window_share} | {_gains(r['gains'])} | "
                     f"{_gains(r['true_gains'])} | {signs} |")
    t = summary["totals"]
    lines.append("")
    lines.extend(f"‡{i}: the recovery's self-model EEA with {text} (the rest as the case study's)." for i, text
                 in enumerate(settings, 1))
    if settings:
        lines.append("")
    if any(r["oracle_in_window"] is not None and not r["window_judges"] for r in summary["rows"]):
        lines.extend([f"†: the oracle in the window swims less than {100 * WINDOW_ORACLE_MIN_SHARE:.0f} % of the 20 s "
                      "oracle's speed (no gait known turns the robot back within the window); the 20 s oracle "
                      "judges the mission.", ""])
    lines.append(f"{t['missions']} missions: alarm within {ALARM_WITHIN_S:g} s of the damage on {t['alarm_in_time']}, "
                 f"{t['false_alarms']} false alarms; recovered (net displacement beyond keeping the old gait and a "
                 f"final speed at least 80 % of the oracle's from the alarm) on {t['recovered']} of {t['judged']} "
                 f"judged (beyond keeping the old gait on {t['beats_keep_old']}, 80 % of the oracle's final speed on "
                 f"{t['final_80']}); the older measures: after recovery {100 * RECOVERED_SHARE:.0f} % of the oracle on "
                 f"{t['recovered_in_window']} of {t['with_oracle']} with an oracle (in the window where measured, on "
                 f"{t['with_window']}; against the 20 s oracle alone on {t['recovered_20s']}); pectoral signs right on {t['signs_right']} of "
                 f"{t['signs_judged']}; compute within {COMPUTE_BUDGET_S:g} s on {t['compute_in_budget']} (median "
                 f"{_num(t['median_compute_s'], 0)} s); median alarm delay {_num(t['median_alarm_delay_s'], 1)} s.")
    return "\n".join(lines) + "\n"
