"""Replay a finished mission to its new gait's takeover, checked against its record (a helper of the probes).

The mission is rerun from its record (``mission.json``) and the prior it started from: the
healthy gait swims to the alarm, the robot stops, and the recovered experiments' actions are
performed where the robot stands (``MissionTarget``); every IMU log must match the recorded
one (to 1e-6 deg), and the takeover's time and yaw the record's. The probes that ask what
another choice at the takeover would have given (``new_gait_kinds.py``,
``new_gait_generations.py``; they write their JSON lines with :func:`emit_line`) or what the
robot's motion at each experiment's start was (``start_motion_fit.py``) start from here. Run
the probes as scripts from any directory (Python puts this folder on their path).
"""
from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from aquafish.mission import MISSION_PRESETS, MissionTarget, _eea_config, _Mission, stop_robot
from eea.encoding import get_model_space
from eea.record import load_experiments


def replay_to_takeover(report: dict, prior, experiments: Sequence,
                       before_each: Callable[[_Mission], None] | None = None) -> _Mission:
    """The mission of ``report`` replayed to its takeover; the caller closes ``mission.env``.

    ``prior`` is the mission's prior (:func:`aquafish.mission.load_prior`), ``experiments`` the
    recovered experiments (:func:`eea.record.load_experiments`), in order. ``before_each(mission)``
    is called before each experiment is performed. Raises ``SystemExit`` naming the first
    experiment whose IMU log differs from the record, or the takeover's time and yaw if they do.
    """
    settings = MISSION_PRESETS[report["preset"]]
    config = _eea_config(settings, report["damage"], report["seed"], 1, report.get("self_model_fields") or {})
    mission = _Mission(report["damage"], report["onset_s"], report["duration_s"], report["seed"])
    try:
        controller = prior.controller
        controller.reset()
        while mission.time_s < report["alarm_s"] - 1e-9:
            mission.step(controller.act(mission.obs, mission.time_s), "gait")
        stop_robot(mission, settings.stop_max_s)
        target = MissionTarget(mission, report["damage"], config.steps, settings.stop_max_s, config.sim_params)
        for x in experiments:
            if before_each is not None:
                before_each(mission)
            imu, _ = target.perform(x.action)
            if not np.allclose(imu, x.imu_log, atol=1e-6):
                raise SystemExit(f"replay differs from the recorded experiment {x.index}: "
                                 f"max |d| {np.max(np.abs(imu - x.imu_log)):.3g} deg")
        if abs(mission.time_s - report["recovered_s"]) > 1e-6 or \
                abs(mission.yaw_deg() - report["robot_yaw_at_new_gait_deg"]) > 1e-3:
            raise SystemExit(f"replay reaches {mission.time_s:.2f} s at {mission.yaw_deg():.3f} deg, the record "
                             f"{report['recovered_s']} s at {report['robot_yaw_at_new_gait_deg']} deg")
    except BaseException:
        mission.env.close()
        raise
    return mission


def load_checked_mission(directory, workers: int):
    """A finished mission's fault check inputs, for the probes that make the check again
    (``check_screen_scan.py``, ``check_screen_polish.py``, ``check_fewer_experiments.py``):
    None if ``directory`` has no ``mission.json`` or its mission made no check; else ``(report, experiments, final_model,
    kept, config)``: the record, the recovered experiments, the search's final model and the
    kept self-model (``(12,)`` ``morphology+servos`` values each) and the recovery's
    ``EEAConfig`` with ``workers``."""
    report_path = Path(directory) / "mission.json"
    if not report_path.is_file():
        return None
    report = json.loads(report_path.read_text())
    if not report.get("fault_check"):
        return None
    fields = get_model_space("morphology+servos").fields
    experiments = load_experiments(Path(directory) / "recovered" / "experiments.npz")
    model = np.array([report["fault_check"]["final_model"][f] for f in fields])
    kept = np.array([report["self_model_after"][f] for f in fields])
    config = _eea_config(MISSION_PRESETS[report["preset"]], report["damage"], report["seed"], workers,
                         report.get("self_model_fields") or {})
    return report, experiments, model, kept, config


def emit_line(line: dict, out: Path | None) -> None:
    """Print ``line`` as one JSON line, and append it to ``out`` (created with its folders) if given."""
    print(json.dumps(line), flush=True)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        with open(out, "a") as f:
            f.write(json.dumps(line) + "\n")
