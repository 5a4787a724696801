"""A mission: the robot notices its damage while it swims, rebuilds its self-model from where
it stands, and swims on (``aquafish mission``; docs/main_job.md, "Missions").

Before the mission (:func:`prepare_prior`, reused from ``--self-model DIR``): the healthy
robot's self-model (its design by default; or, with ``prior_source="eea"``, the case study's
self-model EEA, :func:`aquafish.case_study.model_fields`, at the preset's budget on damage
``none``), its NEAT gait evolved on the self-model robot
(the run directory keeps its final population as data, ``final_population.json``) and the damage
monitor's calibration of that gait on the self-model (:mod:`aquafish.monitor`, saved beside
the self-model as ``monitor_calibration.json``). That is all the robot knows: the only prior.

The mission (:func:`run_mission`) is one AquaFish-v0 episode that is never reset, with the
damage at ``damage_onset_s``. The gait swims and the monitor watches its forward speed. On
the alarm the robot:

1. stops: zero commands (pectorals 0 rev/s, caudal 0 Hz) until it is near rest
   (:data:`REST_SPEED`, :data:`REST_TURN`) or :attr:`MissionPreset.stop_max_s` has passed;
2. runs the EEA's target experiments where it is (:class:`MissionTarget`): each action is
   commanded on the robot of the mission's world for the experiment's duration from its
   current pose and flipper angles (not reset, not moved back to a start); its IMU log
   (yaw taken relative to the heading it started from, as a model starts at yaw 0) is the
   experiment's; the initial flipper angles are whatever the stop left, unknown to the EEA
   (the true ones are recorded for the report only); it stops again after every experiment;
3. rebuilds its self-model with the EEA warm-started at the self-model from before the
   damage (:func:`eea.search.lineages.warm_start`: every lineage's CMA-ES starts at that
   model, which its first estimation generation holds), for the preset's rounds;
4. evolves two kinds of gait on the new self-model, each starting from the old gait's final
   NEAT population (:func:`gait.neat_evolution.evolve_from_population`; the preset's
   generations each): *heading-holding*, its episodes started turned away from the mission's
   heading by :attr:`MissionPreset.new_gait_start_yaws_deg` and scored along it, so the gait is
   selected to turn to the mission's heading and hold it (its observation holds its yaw); and
   *straight*, the case study's episodes (every start heading along the mission's heading,
   20 s at ``quick``), as the oracle's gait is evolved;
5. rehearses: the fittest genomes of every generation of both evolutions swim on the new
   self-model from rest at the robot's own yaw (its IMU's; the flipper angles, which it does
   not know, drawn :attr:`MissionPreset.rehearsal_draws` times, the same draws for every
   candidate) for :attr:`MissionPreset.rehearsal_s`, and the one that goes furthest along the
   mission's heading swims on (:func:`gait.rehearsal.rehearse`). Neither kind is better
   everywhere: from the same state, with the truth as the self-model, the straight kind's
   rehearsal winner swam 0.57 units/s where the heading-holding one swam 0.32 on one mission,
   and the reverse on others (docs/main_job.md, "Two kinds of new gait").

One alarm, one recovery: the monitor is not re-armed afterwards. (Re-arming it with the new
gait's range on the new self-model was tried and removed: the range is the model's, and a
robot swimming at 95 % of the oracle's speed fell outside it; docs/main_job.md.)

Simulated time passes in the stops and experiments (they are in the timeline); the world is
paused while the robot computes (the EEA's estimation and exploration, the gait's evolution),
whose wall time is ``compute_seconds``.

Heading: the mission's heading is the robot's initial forward direction (world +y,
:data:`aquafish_gym.env.INITIAL_HEADING`); every speed is the displacement along it per second
(units/s, 1 unit = 8 cm) over a span of the mission (:func:`span_speed`).

The yardsticks (not the robot's: they know the damage; their compute is not the mission's) never
hold the mission's own procedure. The oracle gait is independent (:mod:`aquafish.oracle`: the
best of three runs evolved on the true damaged robot with three times the gait budget and seeds
the mission never uses); ``oracle_speed`` is its speed 20 s from rest along the heading, and
``oracle_in_window`` its speed from the very state the new gait took over from, over the span of
``speed_after``. From the bit-identical state at the onset, the mission also runs two
counterfactuals to its end (``counterfactuals``): ``keep_old`` (no alarm: the old gait carries
on) and ``oracle_at_alarm`` (the damage known at the alarm: the oracle gait from the alarm's
state, no stop, no experiment). Each, and the mission, records ``net_displacement`` (units along
the heading from the onset to the end: every stop is charged) and ``final_speed`` (units/s over
the last :data:`FINAL_SPAN_S`, or the last third if shorter). A mission is ``recovered`` when its
net displacement beats ``keep_old``'s and its final speed is at least
:data:`RECOVERED_FINAL_SHARE` of ``oracle_at_alarm``'s (:func:`judge_recovery`).
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import json
import logging
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path

import gymnasium as gym
import numpy as np

import aquafish_gym  # registers AquaFish-v0  # noqa: F401
import eea
import gait
from aquafish.case_study import (DEFAULT_METHOD, DEFAULT_MODEL_SPACE, HYPOTHESES_SELF_MODEL_FIELDS, PRESETS,
                                 model_fields, model_robot, own_self_model_fields)
from aquafish.mission_video import ANGLE_COLUMNS, write_mission_video
from aquafish.oracle import check_procedure_seed, evolve_oracle
from aquafish.monitor import CALIBRATION_FILE, DamageMonitor, MonitorCalibration, calibrate
from aquafish_gym import ServoFaults, get_damage
from aquafish_gym.checks import check_int, short_json
from aquafish_gym.env import FRAME_SKIP, INITIAL_HEADING, check_onset
from aquafish_gym.files import atomic_write
from aquafish_gym.params import DT_S
from aquafish_gym.rundir import FileError, check_fingerprint, check_output_dir, make_subdir, read_json, run_lock
from aquafish_gym.simulator import AT_REST, WorldState
from eea import EEAConfig
from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.experiment import quantise_angles
from eea.fault_check import check_final_model, search_screen
from eea.record import save_experiments
from eea.round import RoundParts, run_round
from eea.search.lineages import make_estimation, warm_start
from gait.controller import NEAT_CONTROLLER_FILE
from gait.neat_evolution import GaitResult, evolve_from_population, write_population_file
from gait.population_file import POPULATION_FILE
from gait.rehearsal import Rehearsal, rehearse
from gait.robots import Robot
from gait.shared_pool import SharedPool

__all__ = ["EXPERIMENTS_FILE", "MISSION_FILE", "MISSION_PRESETS", "NEW_GAIT_KINDS",
           "FINAL_SPAN_S", "MISSION_STEP_BYTES", "ORACLE_DIR", "RECOVERED_FINAL_SHARE", "PRIORS", "RECOVERED_DIR",
           "RECOVERY_FIELDS", "SETTINGS_FILE", "check_mission_size", "mission_settings", "MissionPreset", "MissionTarget", "Prior", "load_prior",
           "make_prior", "mission_oracle_speed", "mission_preset", "new_gait_kinds", "plot_timeline", "prepare_prior",
           "final_span_s", "final_speed", "judge_recovery", "net_displacement", "run_mission", "span_speed",
           "stop_robot"]

log = logging.getLogger(__name__)

MISSION_FILE, TRAJECTORY_FILE, TIMELINE_FILE = "mission.json", "trajectory.csv", "timeline.png"
#: Where a mission with a recovery writes the robot's new self-model (``self_model.json``: the
#: genome and the robot, as a prior's), gait (``best_controller.json``, for ``aquafish transfer``)
#: and the target experiments it made (:data:`EXPERIMENTS_FILE`).
RECOVERED_DIR = "recovered"
#: The recovery's target experiments, actions and IMU logs (:func:`eea.record.save_experiments`;
#: :func:`eea.record.load_experiments` reads them back, to score models on them offline).
EXPERIMENTS_FILE = "experiments.npz"
#: Control period of the mission (s): AquaFish-v0's.
CONTROL_S = FRAME_SKIP * DT_S
#: Env action that stops the robot: pectorals 0 rev/s, caudal 0 Hz (its fin held where it is).
STOP_ACTION = np.array([0.0, 0.0, -1.0])
#: "Near rest": speed (units/s) and turn rate (rad/s) under which a stop ends.
REST_SPEED, REST_TURN = 0.02, 0.05
#: The phases of the timeline (``trajectory.csv``'s ``phase``).
PHASES = ("gait", "stop", "experiment", "new_gait")


@dataclasses.dataclass(frozen=True)
class MissionPreset:
    """A mission's budgets.

    Attributes:
        case_preset: the case-study preset (:data:`aquafish.case_study.PRESETS`) giving the EEA
            budget and the NEAT population, generations and starts per genome.
        gait_episode_s: simulated seconds of every gait-evolution episode and oracle score.
        calibration_seeds: healthy episodes of the monitor's calibration.
        calibration_episode_s: their simulated seconds.
        window_s, warmup_s: the monitor's window and warm-up (:class:`MonitorCalibration`).
        stop_max_s: the longest stop (s) before an experiment is run anyway.
        speed_span_s: seconds before the onset over which ``speed_before`` is measured.
        new_gait_start_yaws_deg: the heading-holding new gait's fitness episodes, one per
            entry: each starts turned by it (degrees counter-clockwise from the mission's
            heading) and is scored by its distance along the mission's heading (the straight
            kind's are the case preset's, :func:`_new_gait`).
        rehearsal_top: the fittest genomes of each generation of each new gait's evolution
            that are rehearsed (:func:`gait.rehearsal.rehearse`).
        rehearsal_s: seconds of each rehearsal swim (78 s: the span of a 300 s mission's
            ``speed_after``, the new gait taking over near 222 s).
        rehearsal_draws: rehearsal swims per candidate, each from other flipper angles.
        recovery_fields: the recovery's self-model EEA settings over the case study's method
            and budget (flat :class:`~eea.config.EEAConfig` names, as ``aquafish case-study
            --self-model-fields``), in place of the case preset's own (empty: the case preset's);
            a mission's own ``self_model_fields`` go over these.
    """

    case_preset: str
    gait_episode_s: float
    calibration_seeds: int
    calibration_episode_s: float
    window_s: float = 6.0
    warmup_s: float = 6.0
    stop_max_s: float = 20.0
    speed_span_s: float = 20.0
    new_gait_start_yaws_deg: tuple[float, ...] = (-135.0, -45.0, 45.0, 135.0)
    rehearsal_top: int = 3
    rehearsal_s: float = 78.0
    rehearsal_draws: int = 4
    recovery_fields: Mapping = dataclasses.field(default_factory=dict)


#: The recovery's self-model search at ``quick`` and ``medium`` since 2026-12-03: the ranked
#: fault hypotheses (:data:`aquafish.case_study.HYPOTHESES_SELF_MODEL_FIELDS`, the ``quick``
#: case study's), which recovered 19 of 20 development and held-out missions at about half the
#: simulations of the lean search (:data:`aquafish.case_study.LEAN_SELF_MODEL_FIELDS`, 18 of 20,
#: the missions' search until then; docs/main_job.md, "The ranked hypotheses in the missions'
#: recovery").
RECOVERY_FIELDS = HYPOTHESES_SELF_MODEL_FIELDS

MISSION_PRESETS: dict[str, MissionPreset] = {
    # seconds: the test's end-to-end check (tiny EEA and NEAT budgets, short episodes)
    "smoke": MissionPreset("smoke", gait_episode_s=4.0, calibration_seeds=2, calibration_episode_s=10.0,
                           window_s=2.0, warmup_s=2.0, stop_max_s=2.0, speed_span_s=5.0,
                           new_gait_start_yaws_deg=(-90.0, 90.0), rehearsal_top=2, rehearsal_s=4.0,
                           rehearsal_draws=2),
    # the case study's quick budgets, 20 s gait episodes. The calibration's episodes (initial flipper
    # angles) matter more than their length: 6 x 60 s gave 3 false alarms in 4 h of healthy swimming
    # and alarmed before the onset in 16 of 24 missions, 24 x 60 s none and none (docs/main_job.md).
    # Stops of up to 20 s, not 5 s: the robot drifts at up to 0.27 units/s after 5 s, and the
    # experiments that start from it identify worse (docs/main_job.md, "Missions")
    "quick": MissionPreset("quick", gait_episode_s=20.0, calibration_seeds=24, calibration_episode_s=60.0,
                           recovery_fields=RECOVERY_FIELDS),
    "medium": MissionPreset("medium", gait_episode_s=20.0, calibration_seeds=24, calibration_episode_s=120.0,
                            recovery_fields=RECOVERY_FIELDS),
}


def recovery_self_model_fields(settings: MissionPreset, fields: Mapping | None) -> dict:
    """The recovery's self-model EEA settings of its own: the mission preset's
    ``recovery_fields`` (or, for a preset without them, the case preset's
    :attr:`aquafish.case_study.CaseStudyPreset.self_model_fields`; a mission's recovery does not
    inherit the case study's self-model settings field by field, so a change of the case study's
    leaves the missions as they were measured) and ``fields`` over them, merged and checked by
    :func:`aquafish.case_study.own_self_model_fields`, the one path the case study and the
    recovery benchmark take too.

    Raises:
        ValueError: as :func:`aquafish.case_study.check_self_model_fields`, for ``fields``
            alone or merged with the presets'.
    """
    case = PRESETS[settings.case_preset]
    merged = dataclasses.replace(case, self_model_fields=dict(settings.recovery_fields or case.self_model_fields))
    return own_self_model_fields(merged, fields)


def mission_preset(name: str) -> MissionPreset:
    """The preset ``name``. Raises ValueError naming the valid ones."""
    if name not in MISSION_PRESETS:
        raise ValueError(f"unknown mission preset {name!r}; valid: {sorted(MISSION_PRESETS)}")
    return MISSION_PRESETS[name]


def _eea_config(preset: MissionPreset, damage: str, seed: int, workers: int | None,
                own: dict | None = None) -> EEAConfig:
    """The case study's self-model EEA settings at the preset's budget, with ``own`` (checked
    :func:`aquafish.case_study.check_self_model_fields`) over them."""
    return EEAConfig.from_method(DEFAULT_METHOD, PRESETS[preset.case_preset].budget, damage=damage, seed=seed,
                                 **model_fields(own=own), **({"workers": workers} if workers else {}))


def _gait_kwargs(preset: MissionPreset, seed: int, workers: int | None, progress: bool) -> dict:
    case = PRESETS[preset.case_preset]
    return dict(generations=case.gait_generations, population_size=case.gait_population, seed=seed,
                workers=workers, episodes_per_genome=case.gait_episodes, episode_duration_s=preset.gait_episode_s,
                progress=progress)


# -- the prior: self-model, gait, calibration ---------------------------------------------------------------


@dataclasses.dataclass
class Prior:
    """What the robot knows before the damage (:func:`prepare_prior`).

    Attributes:
        directory: the self-model directory (``eea/``, ``gait/``, ``monitor_calibration.json``).
        genome: ``(57,)`` the self-model's genome (``morphology+servos``).
        robot: the self-model as a robot (:func:`aquafish.case_study.model_robot`).
        controller: the gait evolved on it.
        calibration: the monitor's calibration of the gait on the self-model.
    """

    directory: Path
    genome: np.ndarray
    robot: Robot
    controller: object
    calibration: MonitorCalibration

    @property
    def gait_dir(self) -> Path:
        """The gait's NEAT run directory (its ``final_population.json`` holds the final population)."""
        return self.directory / "gait"


#: Where the self-model before the damage comes from (:func:`prepare_prior`).
PRIORS: tuple[str, ...] = ("design", "eea")


def prepare_prior(directory, preset: str = "quick", seed: int = 0, *, prior: str = "design",
                  workers: int | None = None, progress: bool = True) -> Prior:
    """Make (or reuse, when finished) the healthy robot's self-model, gait and calibration in ``directory``.

    The self-model before the damage is the robot's design (``prior="design"``, default: the
    healthy morphology and servo gains 1, what the robot was built to; a robot is deployed
    knowing its design, and the damage after deployment is what it must find), or one the EEA
    builds from scratch on the healthy robot (``"eea"``: ``eea/``, the case study's self-model
    EEA on damage ``none`` at the preset's budget; at ``quick`` it can land on a wrong servo
    sign, and the gait evolved on it then swims worse than its calibration expects: a false
    alarm). Then ``gait/``: NEAT on the self-model robot, its starts at spread headings
    (:func:`gait.evolve_gait`'s ``spread_headings``); ``monitor_calibration.json``: the
    monitor's calibration of the gait on the self-model from ``calibration_seeds`` random
    starts. Each step is skipped when done.

    Raises:
        ValueError: an unknown ``prior`` (the valid names listed), preset or bad seed, or a
            directory that cannot be written.
    """
    if prior not in PRIORS:
        raise ValueError(f"unknown prior {prior!r}; valid: {', '.join(PRIORS)}")
    settings = mission_preset(preset)
    check_int("seed", seed, 0)
    out = check_output_dir(directory, "--self-model")
    if prior == "design":
        space = get_model_space(DEFAULT_MODEL_SPACE)
        return make_prior(out, space.encode(space.truth("none")[None])[0], gait.as_robot("none"), preset, seed,
                          workers=workers, progress=progress)
    config = _eea_config(settings, "none", seed, workers)
    eea.run(config, out / "eea", progress=progress)
    result = eea.load_result(out / "eea")
    genome = get_model_space(result.config.model_space).encode(np.asarray(result.self_model)[None])[0]
    return make_prior(out, genome, model_robot(result, "self-model (healthy)"), preset, seed, workers=workers,
                      progress=progress)


def make_prior(directory, genome, robot: Robot, preset: str = "quick", seed: int = 0, *, workers: int | None = None,
               calibration_seeds: int | None = None, progress: bool = True) -> Prior:
    """The gait and monitor calibration of a given self-model (``genome``, ``robot``) in
    ``directory`` (``gait/``, ``monitor_calibration.json``; each reused when there): the part of
    :func:`prepare_prior` after the EEA. ``calibration_seeds`` overrides the preset's."""
    settings = mission_preset(preset)
    out = check_output_dir(directory, "--self-model")
    # the prior's gait starts its fitness episodes at spread headings, each scored along its own:
    # a gait that swims alike whichever way it points keeps the monitor's speed range over hours
    # (docs/main_job.md, "Gaits from spread headings"); the oracle and the recovered gait are scored
    # as the case study's
    gait.evolve_or_load_gait(robot, out / "gait", **_gait_kwargs(settings, seed, workers, progress),
                             spread_headings=True)
    # the final population as data (a run made before the file existed: from its checkpoint, in the
    # directory this command made): a mission's new gaits start from it, never from a pickle
    write_population_file(out / "gait")
    n = calibration_seeds or settings.calibration_seeds
    wanted = (n, settings.calibration_episode_s, settings.window_s, settings.warmup_s)
    saved = MonitorCalibration.load(out / CALIBRATION_FILE) if (out / CALIBRATION_FILE).is_file() else None
    if saved is None or (saved.episodes, saved.episode_duration_s, saved.window_s, saved.warmup_s) != wanted:
        # made anew when missing or made with other settings (an older preset's): it is cheap and deterministic
        controller = gait.load_controller(out / "gait" / "best_controller.json")
        _calibrate(controller, robot, settings, n).save(out / CALIBRATION_FILE)
    genome = np.asarray(genome, dtype=np.uint8)
    _write_self_model(out, genome, robot)
    return Prior(out, genome, robot, gait.load_controller(out / "gait" / "best_controller.json"),
                 MonitorCalibration.load(out))


def load_prior(directory) -> Prior:
    """The :class:`Prior` :func:`prepare_prior` left in ``directory``.

    ``directory`` is an input (``--self-model DIR``, possibly received from someone else): only
    its data files are read (``self_model.json``, the gait's ``best_controller.json`` and
    ``final_population.json``, ``monitor_calibration.json``); nothing in it is unpickled, and
    its NEAT checkpoints are never read.

    Raises:
        ValueError: a missing or unfinished part (named).
    """
    d = Path(directory)
    for part in ("self_model.json", "gait/best_controller.json", "gait/run.json", f"gait/{POPULATION_FILE}",
                 CALIBRATION_FILE):
        if not (d / part).is_file():
            raise ValueError(f"--self-model {d} holds no finished self-model: {part} is missing (make one with "
                             "aquafish mission without --self-model, whose OUT/self_model it writes)")
    genome, robot = _read_self_model(d / "self_model.json")
    return Prior(d, genome, robot, gait.load_controller(d / "gait" / "best_controller.json"), MonitorCalibration.load(d))


# -- target experiments in the mission's world ----------------------------------------------------------------


class _Mission:
    """The mission's world and its record: the env (never reset after the start, never
    rendered), the clock and the trajectory (every control step: what the video is drawn from)."""

    def __init__(self, damage: str, onset_s: float, duration_s: float, seed: int):
        self.env = gym.make("AquaFish-v0", damage=damage, damage_onset_s=onset_s,
                            episode_duration_s=10 * duration_s + 1000.0).unwrapped
        self.obs, info = self.env.reset(seed=seed)
        self.time_s = 0.0
        self.damaged = bool(info["damaged"])
        self.rows: list[dict] = []
        self._record("gait")

    @property
    def world(self):
        return self.env.world

    def position(self) -> np.ndarray:
        return (self.world.position[0, 0] - self.world.home[0]).copy()

    def yaw_deg(self) -> float:
        return float(self.world.imu_rpy_deg()[0, 2])

    def _record(self, phase: str) -> None:
        x, y, z = (float(v) for v in self.position())
        v = self.world.linear_velocity[0, 0]
        row = {"time_s": round(self.time_s, 6), "x": x, "y": y, "z": z, "yaw_deg": self.yaw_deg(),
               "speed_along_heading": float(v @ INITIAL_HEADING), "phase": phase, "damaged": int(self.damaged)}
        row.update(zip(ANGLE_COLUMNS, (float(a) for a in self.world.joint_angles()[0])))
        self.rows.append(row)

    def step(self, action, phase: str):
        """One control step of the env (0.1 s) with ``action`` in [-1, 1]^3."""
        self.obs, _, _, _, info = self.env.step(np.asarray(action, dtype=np.float64))
        self.time_s += CONTROL_S
        self.damaged = bool(info["damaged"])
        self.onset_due()
        self._record(phase)
        return self.obs

    def onset_due(self) -> None:
        """Bring the damage in force once the mission's clock reaches the onset.

        The env counts its onset in its own control steps, which the experiments (run on the
        world directly) do not advance; so the mission applies it by its own clock, at the first
        0.1 s boundary at or after ``damage_onset_s`` (:meth:`AquaFishEnv.apply_damage_onset`)."""
        env = self.env
        if env.damage_pending and self.time_s >= env.onset_step * CONTROL_S - 1e-9:
            self.damaged = env.apply_damage_onset()

    def at_rest(self) -> bool:
        w = self.world
        return bool(np.linalg.norm(w.linear_velocity[0, 0]) < REST_SPEED
                    and np.linalg.norm(w.angular_velocity[0, 0]) < REST_TURN)

    def snapshot(self) -> "_Snapshot":
        """The mission's state now (the world's, the env's episode, the clock), to swim other
        gaits from later (:meth:`swim_from`). The mission itself goes on from the restored
        state, as every later swim does (:meth:`aquafish_gym.BatchWorld.restore_state`: a run
        from a restored state repeats to the bit, the saved world's own continuation does not)."""
        snap = _Snapshot(self.world.save_state(), copy.deepcopy(self.env._episodes), self.time_s, self.obs.copy(),
                         self.damaged, len(self.rows))
        self._restore(snap)
        return snap

    def _restore(self, snap: "_Snapshot") -> None:
        self.world.restore_state(snap.world)
        self.env._episodes = copy.deepcopy(snap.episodes)
        self.time_s, self.obs, self.damaged = snap.time_s, snap.obs.copy(), snap.damaged

    def swim_from(self, snap: "_Snapshot", controller, end_s: float, phase: str,
                  clock_origin_s: float | None = None) -> list[dict]:
        """Swim ``controller`` from ``snap`` until ``end_s`` (s); its timeline rows, the
        snapshot's row first. The mission's own rows are left as they were.

        Args:
            clock_origin_s: None: the controller starts afresh (reset, its clock 0 at the
                snapshot), as a new gait does. A time (s): the controller goes on as it stood
                (not reset: pass a copy made at the snapshot) with its clock counted from
                there, as the gait that was swimming at the snapshot would."""
        rows, self.rows = self.rows, [dict(self.rows[snap.rows - 1])]
        try:
            self._restore(snap)
            if clock_origin_s is None:
                controller.reset()
            origin = snap.time_s if clock_origin_s is None else clock_origin_s
            while self.time_s < end_s - 1e-9:
                self.step(controller.act(self.obs, self.time_s - origin), phase)
            return self.rows
        finally:
            self.rows = rows


@dataclasses.dataclass(frozen=True)
class _Snapshot:
    """A moment of a mission (:meth:`_Mission.snapshot`)."""

    world: WorldState
    episodes: object
    time_s: float
    obs: np.ndarray
    damaged: bool
    rows: int


def stop_robot(mission: _Mission, max_s: float) -> float:
    """Zero commands until the robot is near rest or ``max_s`` has passed; the seconds it took."""
    start = mission.time_s
    while not mission.at_rest() and mission.time_s - start < max_s - 1e-9:
        mission.step(STOP_ACTION, "stop")
    return mission.time_s - start


class MissionTarget:
    """The EEA's target (:class:`eea.target.Target`'s interface) as the robot of the mission's world.

    :meth:`perform` commands the action on the robot where it is, in the state it is in (no
    reset, no return to a start), for ``steps`` physics steps of 0.01 s, logging its IMU
    (:meth:`aquafish_gym.BatchWorld.run`, the same code that simulates the EEA's models), then
    stops it (:func:`stop_robot`) for the next experiment. The log's yaw is taken relative to
    the robot's yaw at the experiment's start (a model starts at yaw 0). The stop leaves the
    robot rolling and turning (after 20 s up to about 17 deg/s): :attr:`start_motion` is what
    its IMU measures at the start (roll, pitch, angular velocity, the yaw taken out), and every
    model's simulation of the experiment starts from it (:attr:`eea.experiment.Experiment.start_motion`;
    from rest, the true damaged robot explained a lost flipper's experiments worse than a
    weakly pushing flipper did, docs/main_job.md). The caudal controller starts its sweep at the
    fin's current angle, as a model's does. The initial flipper angles are whatever the robot
    has: the EEA does not see them; they are returned (snapped to the models' grid) for the
    report's angle errors, as :class:`eea.target.Target` returns the ones it drew.

    Attributes:
        morphology, faults: the true damaged robot's (the EEA's OBJ_FIT reports use them only).
        starts: per experiment, the robot's position ``(3,)`` at its start (units, world frame).
        true_angles: per experiment, the flipper angles it started from (rad).
        start_motion: ``(7,)`` the last experiment's start motion
            (:meth:`aquafish_gym.BatchWorld.start_motion`; :data:`~aquafish_gym.simulator.AT_REST`
            before the first).
    """

    def __init__(self, mission: _Mission, damage: str, steps: int, stop_max_s: float, params=None):
        preset = get_damage(damage)
        self.mission, self.damage, self.steps, self.stop_max_s = mission, damage, int(steps), float(stop_max_s)
        self.morphology, self.faults = preset.apply(), preset.faults
        self.params = params
        self.starts: list[np.ndarray] = []
        self.true_angles: list[np.ndarray] = []
        self.start_motion = np.array(AT_REST)

    def perform(self, action) -> tuple[np.ndarray, np.ndarray]:
        """Run the servo command ``action`` ``(3,)`` (rev/s, rev/s, Hz) in the mission's world now.

        Returns:
            ``(imu_log (steps, 3) deg, true_angles (3,) rad)``.
        """
        act = np.asarray(action, dtype=np.float64)
        if act.shape != (3,):
            raise ValueError(f"action must have shape (3,) (left rev/s, right rev/s, caudal Hz), got {act.shape}")
        m, w = self.mission, self.mission.world
        angles = w.joint_angles()[0]
        amp = w.params.caudal_amplitude_rad
        angles[2] = float(np.clip(angles[2], -amp, amp))
        true = quantise_angles(angles[None])[1][0]
        self.starts.append(m.position())
        self.true_angles.append(true)
        self.start_motion = w.start_motion()[0]  # what the IMU measures: the models start from it
        yaw0 = m.yaw_deg()
        w.sync_caudal_phase(0)  # the sweep starts where the fin is
        w.set_actions(act[None])
        logs, done = [], 0
        while done < self.steps:  # in control-period chunks, so the trajectory is recorded every 0.1 s
            chunk = min(FRAME_SKIP, self.steps - done)
            logs.append(w.run(chunk)[0])
            done += chunk
            m.time_s += chunk * DT_S
            m.onset_due()
            m._record("experiment")
        imu = np.concatenate(logs)
        imu[:, 2] = np.degrees(np.unwrap(np.radians(imu[:, 2] - yaw0)))
        w.set_actions(np.zeros((1, 3)))
        stop_robot(m, self.stop_max_s)
        return imu, true


# -- speeds, timeline ---------------------------------------------------------------------------------------------


def span_speed(rows: list[dict], start_s: float, end_s: float | None = None) -> float | None:
    """Displacement along the mission's heading (+y, the robot's initial forward direction) per
    second between the trajectory samples nearest ``start_s`` and ``end_s`` (default: the last);
    None for a span shorter than one control period."""
    t = np.array([r["time_s"] for r in rows])
    end_s = t[-1] if end_s is None else end_s
    i, j = int(np.argmin(np.abs(t - start_s))), int(np.argmin(np.abs(t - end_s)))
    if t[j] - t[i] < CONTROL_S - 1e-9:
        return None
    return _along_heading(rows[i], rows[j]) / float(t[j] - t[i])


def _along_heading(start: dict, end: dict) -> float:
    """Units along the mission's heading from the trajectory row ``start`` to ``end``."""
    a, b = (np.array([r["x"], r["y"], r["z"]]) for r in (start, end))
    return float((b - a) @ INITIAL_HEADING)


def plot_timeline(rows: list[dict], report: dict, path) -> Path:
    """Speed along the heading (1 s moving mean) and yaw over time, onset, alarm and new gait marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([r["time_s"] for r in rows])
    speed = np.array([r["speed_along_heading"] for r in rows])
    smooth = np.convolve(speed, np.ones(10) / 10, mode="same") if len(speed) >= 10 else speed
    yaw = np.degrees(np.unwrap(np.radians([r["yaw_deg"] for r in rows])))
    fig, (a, b) = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    a.plot(t, smooth, lw=1, color="tab:blue")
    a.set_ylabel("speed along heading\n(units/s, 1 s mean)")
    b.plot(t, yaw, lw=1, color="tab:gray")
    b.set_ylabel("yaw (deg)")
    b.set_xlabel("mission time (s)")
    for ax in (a, b):
        for key, colour, label in (("onset_s", "tab:red", "damage"), ("alarm_s", "tab:orange", "alarm"),
                                   ("recovered_s", "tab:green", "new gait")):
            if report.get(key) is not None:
                ax.axvline(report[key], color=colour, ls="--", lw=1, label=label if ax is a else None)
        exp = t[[r["phase"] in ("experiment", "stop") for r in rows]]
        if exp.size:
            ax.axvspan(exp.min(), exp.max(), color="tab:orange", alpha=0.08)
    a.legend(fontsize=8, loc="upper right")
    a.set_title(f"mission: {report['damage']} at {report['onset_s']:g} s ({report['preset']} preset, seed {report['seed']})",
                fontsize=9)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _write_trajectory(rows: list[dict], path: Path) -> None:
    cols = list(rows[0])
    lines = [",".join(cols)] + [",".join(repr(r[c]) if isinstance(r[c], float) else str(r[c]) for c in cols)
                                for r in rows]
    atomic_write(path, ("\n".join(lines) + "\n").encode())


# -- the mission -----------------------------------------------------------------------------------------------------


def run_mission(damage: str, out_dir, *, onset_s: float = 30.0, duration_s: float = 300.0, preset: str = "quick",
                seed: int = 0, self_model=None, prior_source: str = "design", workers: int | None = None,
                warm_start: bool = True, self_model_fields: Mapping | None = None,
                video: bool = True, oracle: bool = True, oracle_dir=None,
                progress: bool = True) -> dict:
    """Run a mission and write ``mission.json``, ``timeline.png``, ``trajectory.csv`` and a video in ``out_dir``.

    Args:
        damage: the damage that comes in force at ``onset_s`` (a preset, a JSON fault or
            ``sampled:SEED``; :func:`aquafish_gym.get_damage`).
        out_dir: the mission directory (``self_model/`` is made in it unless ``self_model``).
        onset_s: simulated seconds before the damage (>= 0, < ``duration_s``).
        duration_s: simulated seconds of the mission (the recovery's stops and experiments
            included; it runs to its end even past them).
        preset: :data:`MISSION_PRESETS`.
        seed: seeds the start's flipper angles, the EEA runs and the gaits.
        self_model: a directory :func:`prepare_prior` made, reused as the prior.
        prior_source: without ``self_model``, where the self-model before the damage comes from:
            ``"design"`` (default) or ``"eea"`` (:func:`prepare_prior`'s ``prior``).
        workers: evaluation processes (default 1).
        warm_start: start the recovery's EEA at the current self-model (default); False starts
            it from a random population, as the case study does (the comparison's baseline).
        self_model_fields: :class:`~eea.config.EEAConfig` settings of the recovery's self-model
            EEA over the preset's ``recovery_fields`` (which are over the case study's; flat
            names, e.g. ``{"lineages": 1}``; None: none), as
            ``aquafish.case_study.run_case_study``'s; the two merged are recorded in
            ``mission.json``. The prior (``prior_source="eea"``) is built with the case study's
            own settings.
        video: write ``mission.mp4`` (or ``.gif``), drawn from the trajectory after the mission
            (:func:`aquafish.mission_video.write_mission_video`).
        oracle: evolve the oracle gaits on the true damaged robot for ``oracle_speed`` and
            ``oracle_in_window`` and the ``counterfactuals`` (:func:`mission_oracle_speed`,
            :func:`judge_recovery`).
        oracle_dir: where the oracle's runs are evolved, or loaded when finished (default
            ``out_dir/oracle``); it depends on no mission seed, so the missions of one damage
            and preset can share it.
        progress: progress bars.

    Returns:
        The report written as ``mission.json``.

    ``out_dir/mission_settings.json`` (:data:`SETTINGS_FILE`, :func:`mission_settings`) records
    the settings before any work: a rerun with the same settings runs the mission again (its
    prior reused), one with other settings is refused.

    Raises:
        ValueError: a bad setting (named), a mission whose memory cannot fit
            (:func:`check_mission_size`), an unusable directory, or a ``self_model`` that holds
            no finished self-model, all before anything is written.
        aquafish_gym.rundir.MismatchError: ``out_dir`` holds a mission of other settings (the
            fields named), or another command's output.
    """
    damage = get_damage(damage).name
    settings = mission_preset(preset)
    check_procedure_seed(seed)
    onset_s = check_onset(onset_s)
    if isinstance(duration_s, bool) or not isinstance(duration_s, (int, float)) or not math.isfinite(duration_s) \
            or duration_s <= 0:
        raise ValueError(f"--duration-s must be a positive number of simulated seconds, got {duration_s!r}")
    if onset_s >= duration_s:
        raise ValueError(f"--onset-s ({onset_s:g}) must come before the end of the mission (--duration-s {duration_s:g})")
    if workers is not None:
        check_int("workers", workers, 1)
    if prior_source not in PRIORS:
        raise ValueError(f"unknown prior {prior_source!r}; valid: {', '.join(PRIORS)}")
    own = recovery_self_model_fields(settings, self_model_fields)
    check_mission_size(settings, damage, seed, float(duration_s), workers, own,
                       prior_source if self_model is None else None)
    out = check_output_dir(out_dir)
    oracle_base = out / ORACLE_DIR if oracle_dir is None else check_output_dir(oracle_dir, "oracle_dir")
    wanted = mission_settings(damage, seed, preset, onset_s, float(duration_s), bool(warm_start), own, bool(oracle),
                              prior_source, self_model)
    with run_lock(out, command="mission"):
        _check_settings(out, wanted)
        atomic_write(out / SETTINGS_FILE, (json.dumps(wanted, indent=2) + "\n").encode())
        prior = load_prior(self_model) if self_model is not None else \
            prepare_prior(out / "self_model", preset, seed, prior=prior_source, workers=workers, progress=progress)
        return _run(prior, damage, onset_s, float(duration_s), settings, preset, seed, out, workers or 1, video,
                    oracle, progress, bool(warm_start), own, oracle_base)


#: A mission directory's manifest: the settings that define its results (:func:`mission_settings`).
SETTINGS_FILE = "mission_settings.json"
#: Memory a mission keeps per control step (0.1 s) of its ``duration_s``: the trajectory's rows
#: (about 700 bytes each) of the mission and of the swims that judge it (``keep_old``,
#: ``oracle_at_alarm``, the oracle in the window), its CSV and the timeline's arrays.
MISSION_STEP_BYTES = 5_000


def check_mission_size(settings: MissionPreset, damage: str, seed: int, duration_s: float, workers: int | None,
                       own: dict, prior_source: str | None = None) -> None:
    """Refuse, before anything is written, a mission whose memory cannot fit: its ``duration_s``
    (:data:`MISSION_STEP_BYTES` per control step) and its EEA runs, the recovery's with the
    mission's own self-model settings ``own`` and, with ``prior_source="eea"``, the prior's
    (:func:`eea.run.check_run_memory`, as ``aquafish eea`` refuses them).

    Raises:
        ValueError: the estimate exceeds the available memory (the setting named).
    """
    from aquafish_gym.rundir import check_memory
    from eea.run import check_run_memory

    check_memory(f"--duration-s {duration_s:g}", duration_s / CONTROL_S * MISSION_STEP_BYTES,
                 "give a shorter --duration-s")
    try:
        check_run_memory(_eea_config(settings, damage, seed, workers, own))
    except ValueError as err:
        raise ValueError(f"--self-model-fields: the recovery's self-model search with {err}") from None
    if prior_source == "eea":
        check_run_memory(_eea_config(settings, "none", seed, workers))


def mission_settings(damage: str, seed: int, preset: str, onset_s: float, duration_s: float, warm_start: bool,
                     own: Mapping, oracle: bool, prior_source: str, self_model=None) -> dict:
    """The manifest of a mission directory (:data:`SETTINGS_FILE`): the settings that define its
    results. The prior is ``prior_source`` (``design``, ``eea``) or, with ``self_model``, that
    directory (its real path); workers, video and progress change no result and are not in it."""
    return {"damage": damage, "seed": int(seed), "preset": preset, "onset_s": float(onset_s),
            "duration_s": float(duration_s), "warm_start": bool(warm_start), "self_model_fields": dict(own),
            "oracle": bool(oracle), "prior_source": None if self_model is not None else prior_source,
            "self_model": None if self_model is None else os.path.realpath(self_model)}


def _check_settings(out: Path, wanted: dict) -> None:
    """Refuse a mission directory that holds a mission of other settings: its manifest's, or for a
    mission written before the manifest, its ``mission.json``'s (the fields it records).

    Raises:
        MismatchError: the fields that differ named.
        FileError: the manifest or report is not a JSON object.
    """
    if (out / SETTINGS_FILE).is_file():
        recorded = read_json(out / SETTINGS_FILE)
    elif (out / MISSION_FILE).is_file():
        report = read_json(out / MISSION_FILE)
        recorded = {k: report[k] for k in ("damage", "seed", "preset", "onset_s", "duration_s", "warm_start",
                                           "self_model_fields") if k in report}
    else:
        return

    def flat(values: dict) -> dict:
        return {k: json.dumps(v, sort_keys=True) if k == "self_model_fields" else v for k, v in values.items()}

    check_fingerprint(out, flat(recorded), flat(wanted),
                      "use another --out, or the settings it was run with (the same settings run the mission again)")


def _run(prior: Prior, damage: str, onset_s: float, duration_s: float, settings: MissionPreset, preset: str, seed: int,
         out: Path, workers: int, video: bool, oracle: bool, progress: bool, warm: bool,
         own: dict | None, oracle_dir: Path) -> dict:
    mission = _Mission(damage, onset_s, duration_s, seed)
    monitor = DamageMonitor(prior.calibration)
    monitor.update(mission.obs, {"time_s": 0.0})
    controller, gait_start = prior.controller, 0.0
    controller.reset()
    recovery: dict = {}  # the recovery after the alarm: when, what it cost, the model it found
    snapshot, window, oracle_speed, takeover_yaw = None, None, None, 0.0
    # the counterfactuals' starts: the first moment the damage is in force (with the old gait as it
    # stood), and the alarm's moment (a false alarm's is no start: the damage is still to come)
    onset_snap, old_gait, alarm_snap, counterfactuals, independent = None, None, None, None, None
    try:
        while mission.time_s < duration_s - 1e-9:
            phase = "gait" if not recovery else "new_gait"
            obs = mission.step(controller.act(mission.obs, mission.time_s - gait_start), phase)
            if mission.damaged and onset_snap is None:
                onset_snap, old_gait = mission.snapshot(), copy.deepcopy(controller)
                obs = mission.obs
            if recovery or not monitor.update(obs, {"time_s": mission.time_s}):
                continue
            # the alarm: stop, experiment where the robot is, rebuild the self-model, evolve a gait
            alarm_s = mission.time_s
            log.info("mission: alarm at %.1f s", alarm_s)
            if mission.damaged:
                alarm_snap = mission.snapshot()
            stop_robot(mission, settings.stop_max_s)
            config = _eea_config(settings, damage, seed, workers, own)
            records, target, new_model, check, eea_s = _recover_model(
                mission, prior.genome if warm else None, config, settings, progress)
            t0 = time.perf_counter()
            takeover_yaw = mission.yaw_deg()  # what the robot's IMU says
            controller, rehearsal = _new_gait(new_model, prior, settings, seed, workers, progress, takeover_yaw)
            gait_s = time.perf_counter() - t0
            gait_start = mission.time_s
            controller.reset()
            if mission.damaged:  # the oracles swim from here too (not after a false alarm: the onset is still to come)
                snapshot = mission.snapshot()
            new_genome = get_model_space(config.model_space).encode(check.model[None])[0]
            recovery = {"alarm_s": alarm_s, "recovered_s": mission.time_s, "target_experiments": len(records),
                        "compute_seconds": eea_s + gait_s, "compute_seconds_eea": eea_s,
                        "compute_seconds_gait": gait_s, "self_model": _model_dict(new_genome),
                        "simulations": _simulations(records, check),
                        "robot_yaw_at_new_gait_deg": round(takeover_yaw, 3), "rehearsal": rehearsal,
                        "fault_check": {"replaced": check.index != 0, "polished": check.polished,
                                        "simulations": check.simulations, "procedure": check.procedure,
                                        "final_model": _model_dict(records[-1].best_genome)},
                        "experiment_s": target.steps * DT_S, "experiments": _experiments(records, target)}
            experiments = records[-1].experiments  # the robot's own data, kept to be scored again offline
        rows = mission.rows
        sizes = (mission.env.base_morphology.to_array(), mission.env.morphology.to_array())  # before, after the onset
        recovered_s = recovery.get("recovered_s")
        after_start = None if recovered_s is None else recovered_s + settings.warmup_s  # speed_after's span
        if after_start is not None and after_start >= rows[-1]["time_s"]:
            after_start = None  # the mission ended before it
        if oracle:
            independent, oracle_speed = _straight_oracle(damage, settings, seed, oracle_dir, workers, progress)
            if snapshot is not None and after_start is not None:
                window = _oracle_in_window(mission, snapshot, after_start, independent.controller, duration_s)
            if onset_snap is not None:
                counterfactuals = _counterfactuals(mission, onset_snap, old_gait, alarm_snap, independent.controller,
                                                   duration_s)
    finally:
        mission.env.close()

    alarm_s = recovery.get("alarm_s")
    healthy_end = onset_s if alarm_s is None else min(onset_s, alarm_s)  # the old gait swimming, undamaged
    speed_before = span_speed(rows, max(settings.warmup_s, healthy_end - settings.speed_span_s), healthy_end)
    speed_damaged = span_speed(rows, onset_s, alarm_s)
    speed_after = None if after_start is None else span_speed(rows, after_start)
    displacement = None if onset_snap is None else net_displacement(rows, onset_snap.time_s)
    ending = final_speed(rows, duration_s)
    space = get_model_space("morphology+servos")
    report = {
        "damage": damage, "seed": seed, "preset": preset, "duration_s": duration_s,
        "heading": "world +y: the robot's initial forward direction; speeds are displacement along it per second "
                   "(units/s, 1 unit = 8 cm)",
        "warm_start": warm,
        "self_model_fields": dict(own or {}),
        "new_gait_start_yaws_deg": list(settings.new_gait_start_yaws_deg),
        "robot_yaw_at_new_gait_deg": recovery.get("robot_yaw_at_new_gait_deg"),
        "rehearsal": recovery.get("rehearsal"),
        "onset_s": onset_s,
        "damage_in_force_s": next((r["time_s"] for r in rows if r["damaged"]), None),
        "alarm_s": alarm_s, "recovered_s": recovered_s,
        "false_alarm": alarm_s is not None and alarm_s < onset_s,
        "target_experiments": recovery.get("target_experiments", 0),
        "experiment_s": recovery.get("experiment_s"),
        "compute_seconds": recovery.get("compute_seconds", 0.0),
        "compute_seconds_eea": recovery.get("compute_seconds_eea", 0.0),
        "compute_seconds_gait": recovery.get("compute_seconds_gait", 0.0),
        "simulations": recovery.get("simulations"),
        "speed_before": speed_before, "speed_damaged": speed_damaged, "speed_after": speed_after,
        "oracle_speed": oracle_speed,
        "oracle_in_window": window,
        "oracle": None if independent is None else independent.record(),
        "net_displacement": displacement, "final_speed": ending,
        "counterfactuals": counterfactuals,
        "recovered": None if counterfactuals is None else judge_recovery(displacement, ending, counterfactuals),
        "monitor": {"lower": prior.calibration.lower, "upper": prior.calibration.upper,
                    "window_s": prior.calibration.window_s},
        "self_model_before": _model_dict(prior.genome),
        "self_model_after": recovery.get("self_model"),
        "fault_check": recovery.get("fault_check"),
        "true_model": dict(zip(space.fields, np.round(space.truth(damage), 4).tolist())),
        "experiments": recovery.get("experiments", []),
        "self_model_dir": str(prior.directory),
        "files": {"timeline": TIMELINE_FILE, "trajectory": TRAJECTORY_FILE},
    }
    if recovery:  # what the robot knows after the recovery: its new self-model and gait
        recovered = make_subdir(out, RECOVERED_DIR)  # never through a link planted in the mission directory
        _write_self_model(recovered, new_genome, new_model)
        controller.save(recovered / NEAT_CONTROLLER_FILE)
        save_experiments(recovered / EXPERIMENTS_FILE, experiments)
        report["files"]["recovered"] = RECOVERED_DIR
        report["files"]["experiments"] = f"{RECOVERED_DIR}/{EXPERIMENTS_FILE}"
    _write_trajectory(rows, out / TRAJECTORY_FILE)
    plot_timeline(rows, report, out / TIMELINE_FILE)
    report["files"]["video"] = write_mission_video(rows, report, out / "mission", *sizes).name if video else None
    atomic_write(out / MISSION_FILE, (json.dumps(report, indent=2) + "\n").encode())
    return report


def _read_self_model(path: Path) -> tuple[np.ndarray, Robot]:
    """The genome and robot of a ``self_model.json`` (:func:`_write_self_model`), checked field by
    field: the file may come from anyone (``--self-model DIR``).

    Raises:
        FileError: (a ``ValueError``) not a JSON object, or ``genome`` that is not the
            ``morphology+servos`` genome's bits (0 or 1), or ``robot`` that is not a robot (the
            file and the field named).
    """
    fix = "make one with aquafish mission without --self-model, whose OUT/self_model it writes"
    data = read_json(path)
    bits = get_model_space("morphology+servos").n_bits
    genome = data.get("genome")
    if not (isinstance(genome, list) and len(genome) == bits
            and all(type(b) is int and b in (0, 1) for b in genome)):  # noqa: E721 (no bools, no floats)
        raise FileError(path, f"field 'genome' must be the {bits} bits (0 or 1) of a morphology+servos model genome, "
                              f"got {short_json(genome, 40)}", fix)
    try:
        if not isinstance(data.get("robot"), dict):
            raise TypeError(f"a JSON object, got {type(data.get('robot')).__name__}")
        robot = Robot.from_dict(data["robot"])
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        problem = f"no field {err.args[0]!r}" if isinstance(err, KeyError) else str(err).splitlines()[0][:200]
        raise FileError(path, f"field 'robot' is not a robot ({problem})", fix) from None
    return np.asarray(genome, dtype=np.uint8), robot


def _write_self_model(directory: Path, genome: np.ndarray, robot: Robot) -> None:
    """``directory/self_model.json``: a ``morphology+servos`` genome and its robot, as a prior holds
    them (:func:`load_prior` reads it)."""
    atomic_write(directory / "self_model.json",
                 (json.dumps({"genome": np.asarray(genome).tolist(), "robot": robot.to_dict()}) + "\n").encode())


def _simulations(records, check) -> dict[str, int]:
    """The recovery's model simulations (1.28 s each at ``quick``), a count that does not depend on
    the machine's load as ``compute_seconds`` does: the EEA rounds' exploration and estimation
    (cache hits excluded) and the fault check's."""
    exploration = sum(int(r.exploration_simulations) for r in records)
    return {"exploration": exploration, "estimation": int(records[-1].simulations) - exploration,
            "fault_check": int(check.simulations)}


def _experiments(records, target: MissionTarget) -> list[dict]:
    """A recovery's target experiments for the report: round, action, where and from which
    flipper angles the robot started it, the round's MOD_FIT."""
    return [{"round": r.number, "action": r.action.round(4).tolist(), "start_position": s.round(4).tolist(),
             "true_initial_angles_rad": a.round(4).tolist(), "model_fitness": r.model_fitness}
            for r, s, a in zip(records, target.starts, target.true_angles)]


def _model_dict(genome: np.ndarray) -> dict[str, float]:
    """A ``morphology+servos`` model genome as ``{field: value}`` (simulator units, gains)."""
    space = get_model_space("morphology+servos")
    return dict(zip(space.fields, np.round(space.decode(np.asarray(genome)[None])[0], 4).tolist()))


def _calibrate(controller, robot: Robot, settings: MissionPreset, seeds: int | None = None) -> MonitorCalibration:
    """The monitor's healthy range of ``controller`` on the self-model ``robot``: ``seeds`` (default
    the preset's) healthy episodes from seeds 1000, 1001, ..."""
    n = seeds or settings.calibration_seeds
    return calibrate(controller, robot, seeds=range(1000, 1000 + n), window_s=settings.window_s,
                     warmup_s=settings.warmup_s, episode_duration_s=settings.calibration_episode_s)


def _recover_model(mission: _Mission, genome: np.ndarray | None, config: EEAConfig, settings: MissionPreset,
                   progress: bool):
    """The EEA's rounds with the mission's robot as the target, warm-started at the current
    self-model ``genome`` (None: from a random population), then the final model's check against
    fault hypotheses (:mod:`eea.fault_check`): ``(round records, the MissionTarget, the
    new self-model robot, the check, wall seconds of compute)``.
    The target's simulated seconds are not compute: they are the mission's."""
    rng = np.random.default_rng(config.seed)
    t0, sim_wall = time.perf_counter(), 0.0
    with Evaluator.for_config(config) as evaluator:
        estimation = make_estimation(config.estimation, config.ga, config.model_space, rng)
        if genome is not None:
            warm_start(estimation, genome)
        parts = RoundParts.from_config(config, rng, evaluator, estimation)
        target = MissionTarget(mission, config.damage, config.steps, settings.stop_max_s, config.sim_params)
        parts = dataclasses.replace(parts, target=target)
        records, experiments = [], ()
        for number in range(1, config.rounds + 1):
            record = run_round(number, experiments, parts, rng)
            experiments = record.experiments
            records.append(record)
            sim_wall += record.target_s
            if progress:
                print(f"mission: round {number}/{config.rounds} model fitness {record.model_fitness:.3f}", flush=True)
        final = get_model_space(config.model_space).decode(records[-1].best_genome[None])[0]
        check = check_final_model(final, experiments, evaluator, config.rounds,
                                  screen_angles=search_screen(config, parts.strategy, final, len(experiments)))
    values = check.model
    robot = Robot(aquafish_gym.Morphology.from_array(values[:9]), "none", "self-model (after the damage)",
                  ServoFaults(speed_scale=tuple(float(g) for g in values[9:])))
    return records, target, robot, check, time.perf_counter() - t0 - sim_wall


def mission_oracle_speed(damage: str, settings: MissionPreset, seed: int, oracle_dir: Path, workers: int = 1,
                         progress: bool = False) -> float:
    """The oracle's speed (units/s): the independent oracle gait (:mod:`aquafish.oracle`: the best
    of three runs evolved on the true damaged robot ``damage`` with three times the preset's NEAT
    generations and seeds the mission never uses; kept in ``oracle_dir``, reused when finished),
    its mean speed along the heading on the damaged robot (distance / episode seconds, 20 s from
    rest at ``quick``, over the case preset's transfer starts from ``seed``). ``mission.json``'s
    ``oracle_speed``.

    Raises:
        ValueError: an unknown damage, or an oracle run made with other settings.
    """
    return _straight_oracle(damage, settings, seed, Path(oracle_dir), workers, progress)[1]


#: Where a mission keeps its independent oracle's runs (:mod:`aquafish.oracle`).
ORACLE_DIR = "oracle"


def _straight_oracle(damage: str, settings: MissionPreset, seed: int, oracle_dir: Path, workers: int, progress: bool):
    """:func:`mission_oracle_speed`'s :class:`~aquafish.oracle.OracleGait` and speed."""
    robot = gait.as_robot(damage)
    case = PRESETS[settings.case_preset]
    independent = evolve_oracle(robot, oracle_dir, generations=case.gait_generations,
                                population_size=case.gait_population, episodes_per_genome=case.gait_episodes,
                                episode_duration_s=settings.gait_episode_s, workers=workers, progress=progress)
    t = gait.score_transfer(independent.controller, robot, robot, seed=seed, episodes=case.transfer_episodes,
                            episode_duration_s=settings.gait_episode_s)
    return independent, float(t.target_distance / settings.gait_episode_s)


# -- judging a mission against what else the robot could have done ------------------------------------------------

#: The final speed is measured over the mission's last this many seconds, or its last third if
#: that is shorter (:func:`final_speed`).
FINAL_SPAN_S = 120.0
#: A recovered mission's final speed is at least this share of ``oracle_at_alarm``'s.
RECOVERED_FINAL_SHARE = 0.8


def final_span_s(duration_s: float) -> float:
    """Seconds at the mission's end that :func:`final_speed` spans: :data:`FINAL_SPAN_S`, or a
    third of ``duration_s`` if that is shorter."""
    return min(FINAL_SPAN_S, duration_s / 3.0)


def net_displacement(rows: list[dict], onset_s: float) -> float:
    """Units along the mission's heading from the trajectory sample nearest ``onset_s`` to the
    last: what the robot made of the mission after the damage, every stop charged."""
    t = np.array([r["time_s"] for r in rows])
    return _along_heading(rows[int(np.argmin(np.abs(t - onset_s)))], rows[-1])


def final_speed(rows: list[dict], duration_s: float) -> float | None:
    """Units/s along the mission's heading over its last :func:`final_span_s` (:func:`span_speed`)."""
    return span_speed(rows, duration_s - final_span_s(duration_s), duration_s)


def judge_recovery(displacement: float, speed: float | None, counterfactuals: dict) -> bool | None:
    """Whether a mission recovered: its net displacement beats ``keep_old``'s (carrying on with the
    old gait) and its final speed is at least :data:`RECOVERED_FINAL_SHARE` of ``oracle_at_alarm``'s
    (the damage known at the alarm, the independent oracle gait swum from there, no stop).

    Args:
        displacement: the mission's net displacement (units, :func:`net_displacement`).
        speed: the mission's final speed (units/s, :func:`final_speed`).
        counterfactuals: ``mission.json``'s ``counterfactuals``.

    Returns:
        None when there is no ``oracle_at_alarm`` (no alarm after the onset) or its final speed is
        not forward (nothing to recover to), else the verdict.
    """
    oracle = counterfactuals.get("oracle_at_alarm")
    if oracle is None or oracle["final_speed"] is None or not oracle["final_speed"] > 0:
        return None
    keep = counterfactuals["keep_old"]["net_displacement"]
    return bool(displacement > keep and speed is not None and speed >= RECOVERED_FINAL_SHARE * oracle["final_speed"])


def _counterfactuals(mission: _Mission, onset: _Snapshot, old_gait, alarm: _Snapshot | None, oracle_controller,
                     duration_s: float) -> dict:
    """``mission.json``'s ``counterfactuals``, over the mission's own span from the onset's
    bit-identical state: ``keep_old`` (no alarm: the old gait, as it stood at the onset, swims on
    to the end) and ``oracle_at_alarm`` (the damage known at the alarm: the independent oracle gait
    from the alarm's state to the end, no stop, no experiment; None without an alarm after the
    onset). Each: ``net_displacement`` (units from the onset's position to the end, along the
    heading), ``final_speed`` (units/s, :func:`final_speed`) and ``start_s``."""
    onset_s = onset.time_s
    keep = mission.swim_from(onset, old_gait, duration_s, "keep_old", clock_origin_s=0.0)
    result = {"keep_old": {"start_s": onset_s, "net_displacement": net_displacement(keep, onset_s),
                           "final_speed": final_speed(keep, duration_s)}, "oracle_at_alarm": None}
    if alarm is not None:
        swum = mission.swim_from(alarm, oracle_controller, duration_s, "oracle_at_alarm")
        result["oracle_at_alarm"] = {"start_s": alarm.time_s,  # from the onset's row, keep_old's first
                                     "net_displacement": _along_heading(keep[0], swum[-1]),
                                     "final_speed": final_speed(swum, duration_s)}
    return result


#: The kinds of new gait a recovery evolves and rehearses (:func:`_new_gait`), in the order a tie
#: in the rehearsal goes by.
NEW_GAIT_KINDS: tuple[str, ...] = ("heading_holding", "straight")


def new_gait_kinds(robot: Robot, prior: Prior, settings: MissionPreset, seed: int, workers: int, progress: bool,
                   yaw_deg: float) -> dict[str, tuple[GaitResult, Rehearsal]]:
    """Every kind of :data:`NEW_GAIT_KINDS` evolved on ``robot`` and rehearsed from ``yaw_deg``:
    ``{kind: (evolution, rehearsal)}``, in that order.

    Each kind runs the preset's generations from the prior gait's final population
    (:func:`gait.neat_evolution.evolve_from_population`, keeping the preset's ``rehearsal_top``
    fittest genomes of every generation as candidates): ``heading_holding``, episodes started
    turned by the preset's ``new_gait_start_yaws_deg`` and scored along the mission's heading;
    ``straight``, the case preset's episodes, every one heading along it. Then its candidates swim
    on ``robot`` from rest at ``yaw_deg`` (the robot's yaw, degrees from the mission's heading,
    clipped to [-180, 180]) with the same flipper-angle draws for every candidate
    (:func:`gait.rehearsal.rehearse`). Not in the paper (docs/main_job.md, "Two kinds of new gait").
    With ``workers`` > 1 the two kinds run at once on one :class:`~gait.shared_pool.SharedPool`
    (a straight generation is one world, which alone keeps one core busy), with the results
    they give one after the other.

    Args:
        robot: the robot the gaits are evolved and rehearsed on (the new self-model, or the
            true damaged robot for the window's oracle).
        prior: the mission's prior; its gait's final population seeds both evolutions.
        settings: the mission preset (generations through its case preset, episodes, rehearsal).
        seed: seeds both evolutions and the rehearsal's flipper-angle draws.
        workers: evaluation processes.
        progress: show NEAT's progress.
        yaw_deg: the robot's yaw at the takeover, degrees from the mission's heading.

    Raises:
        ValueError: as :func:`gait.neat_evolution.evolve_from_population` and
            :func:`gait.rehearsal.rehearse` raise (e.g. no population file in the prior's gait).
    """
    case = PRESETS[settings.case_preset]
    yaws = settings.new_gait_start_yaws_deg
    episodes = {"heading_holding": {"episodes_per_genome": len(yaws), "start_yaws_deg": yaws},
                "straight": {"episodes_per_genome": case.gait_episodes, "start_yaws_deg": None}}
    start_yaw = float(np.clip(yaw_deg, -180.0, 180.0))

    def one_kind(kind: str, shared: SharedPool | None) -> tuple[GaitResult, Rehearsal]:
        result = evolve_from_population(robot, prior.gait_dir, case.gait_generations, seed=seed,
                                        episode_duration_s=settings.gait_episode_s, workers=workers,
                                        progress=progress, keep_top=settings.rehearsal_top, shared=shared,
                                        **episodes[kind])
        return result, rehearse(result.candidates, robot, start_yaw_deg=start_yaw, duration_s=settings.rehearsal_s,
                                seed=seed, draws=settings.rehearsal_draws, workers=workers, shared=shared)

    if workers == 1:
        return {kind: one_kind(kind, None) for kind in NEW_GAIT_KINDS}
    with SharedPool(workers) as shared:   # both kinds at once: one kind's generation is one world
        return dict(zip(NEW_GAIT_KINDS, shared.run_each([functools.partial(one_kind, kind, shared)
                                                         for kind in NEW_GAIT_KINDS])))


def _new_gait(robot: Robot, prior: Prior, settings: MissionPreset, seed: int, workers: int, progress: bool,
              yaw_deg: float):
    """The recovery's gait on ``robot`` and its rehearsal's record: of :func:`new_gait_kinds`'
    rehearsed winners, the one that went furthest (a tie: the first kind). The record: the
    chosen ``kind`` and, per kind, its candidates, the one its rehearsal chose, their distances
    (units) and the generation each was first kept in (0: the prior's population, evaluated on
    ``robot``)."""
    kinds, record = new_gait_kinds(robot, prior, settings, seed, workers, progress, yaw_deg), {}
    for kind, (result, chosen) in kinds.items():
        best = next((k for k, c in enumerate(result.candidates)
                     if c.genome.key == result.best_controller.genome.key), None)
        record[kind] = {"candidates": len(result.candidates), "chosen": chosen.index, "evolution_best": best,
                        "distances_units": np.round(chosen.scores, 4).tolist(),
                        "generations": result.candidate_generations}
    kind = max(NEW_GAIT_KINDS, key=lambda k: kinds[k][1].scores[kinds[k][1].index])  # a tie: the first kind
    return kinds[kind][1].controller, {"kind": kind, "start_yaw_deg": round(float(yaw_deg), 3),
                                       "seconds": settings.rehearsal_s, "draws": settings.rehearsal_draws,
                                       "kinds": record}


def _oracle_in_window(mission: _Mission, snapshot: _Snapshot, after_s: float, controller, duration_s: float) -> dict:
    """``mission.json``'s ``oracle_in_window``: the independent oracle gait swum on the damaged
    robot from where and how it stood when the new gait took over (the same state, to the bit,
    that the new gait swam on from), over the span ``speed_after`` is measured on. The
    mission's own new-gait procedure is no part of it (a yardstick never holds what it judges).
    ``straight`` and ``best``: its speed (units/s); ``after_s`` the span's start (s), as given."""
    speed = span_speed(mission.swim_from(snapshot, controller, duration_s, "oracle"), after_s)
    return {"after_s": after_s, "straight": speed, "best": speed}
