"""Does the truth explain a mission's experiments best once the models start from the robot's motion?

A mission's target experiments start after a stop that leaves the robot drifting (up to about
0.1 units/s and 17 deg/s after 20 s). Missions recorded before experiments kept their start
motion (``Experiment.start_motion``) simulated every model from rest, level. This probe replays
such a mission to each experiment's start (the healthy gait to the recorded alarm, the stop,
then the recorded actions in order; it checks that the replayed IMU logs are the recorded
ones), keeps the robot's state at each start (roll, pitch, height, linear and angular velocity,
turned into the model's frame, yaw 0), and fits the kept self-model and the truth equally hard
(as ``lost_flipper_fit.py``: the fault check's refit settings, two seeds): with the models
starting at rest, and from the robot's motion at each experiment's start (``--parts``: ``all``
of it, or ``imu``, what an IMU measures: roll, pitch and angular velocity, which is what the
library's models start from now). It prints the MOD_FITs (eq. 3) each way, and the truth's
mean similarity at the true initial angles.

    python docs/studies/probes/start_motion_fit.py runs/missions/rehearsal_sampled_1017_s5001 \\
        runs/missions/prior_s5001/self_model
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pybullet as p

import eea
import eea.evaluation
from aquafish.mission import MISSION_PRESETS, _eea_config, load_prior
from aquafish_gym import simulator
from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.inference.selection import select_model
from mission_replay import replay_to_takeover


def _yaw(q) -> float:
    x, y, z, w = q
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def replay_starts(report: dict, prior_dir: Path, experiments) -> list[dict]:
    """Replay the mission to each experiment's start; the robot's state there in the model's
    frame (the robot's yaw taken out): ``{"orientation", "dz", "linear", "angular"}``."""
    starts = []

    def record_start(mission) -> None:
        w = mission.world
        body, c = w.bodies[0], w.client
        pos, q = p.getBasePositionAndOrientation(body, physicsClientId=c)
        lin, ang = p.getBaseVelocity(body, physicsClientId=c)
        unturn = p.getQuaternionFromEuler((0.0, 0.0, -_yaw(q)))
        rot = np.array(p.getMatrixFromQuaternion(unturn)).reshape(3, 3)
        _, q_model = p.multiplyTransforms((0, 0, 0), unturn, (0, 0, 0), q)
        starts.append({"orientation": q_model, "dz": pos[2] - w.home[0, 2],
                       "linear": rot @ np.array(lin), "angular": rot @ np.array(ang)})

    replay_to_takeover(report, load_prior(prior_dir), experiments, record_start).env.close()
    return starts


#: what of the robot's state at an experiment's start the models take: "all", or "imu" (what an IMU
#: measures: roll, pitch and the angular rates; the models keep the home height and no linear velocity)
PARTS = ("all", "imu")


def patch_starts(experiments, starts, parts: str = "all") -> None:
    """Make every model simulation of an experiment's action start from that experiment's state."""
    if parts == "imu":
        starts = [dict(s, dz=0.0, linear=np.zeros(3)) for s in starts]
    by_action = {np.asarray(x.action, dtype=np.float64).tobytes(): s for x, s in zip(experiments, starts)}
    if len(by_action) != len(experiments):
        raise SystemExit("two experiments share an action: the probe cannot tell their starts apart")

    def simulate_batch(morphologies, actions, initial_angles, steps, *, faults=None, params=None, rng=None,
                       native=None, start_motion=None):  # the replayed experiments' own start_motion: at rest
        prm = params if params is not None else simulator.SimParams()
        morph = simulator.validate_morphologies(morphologies)
        acts = simulator.validate_actions(actions, len(morph))
        world = simulator.BatchWorld(morph, prm, faults, client=simulator._shared_client(), native=native)
        world.reset(initial_angles, acts)
        for i, (body, home) in enumerate(zip(world.bodies, world.home)):
            s = by_action[acts[i].tobytes()]
            p.resetBasePositionAndOrientation(body, (home[0], home[1], home[2] + s["dz"]), s["orientation"],
                                              physicsClientId=world.client)
            p.resetBaseVelocity(body, s["linear"].tolist(), s["angular"].tolist(), physicsClientId=world.client)
        world._read_state()
        return world.run(int(steps), rng)

    eea.evaluation.simulate_batch = simulate_batch


def fit(kept, truth, experiments, config, seeds=(0, 1)) -> list[list[float]]:
    out = []
    with Evaluator.for_config(config, workers=1) as evaluator:
        for seed in seeds:
            s = select_model(np.stack([kept, truth]), experiments, evaluator, np.random.default_rng(seed),
                             generations=10, scan_cycles=2, model_space="morphology+servos")
            out.append(np.round(s.model_fitness, 5).tolist())
    return out


def truth_at_true_angles(truth, experiments, config) -> float:
    with Evaluator.for_config(config, workers=1) as evaluator:
        space = get_model_space("morphology+servos")
        genome = space.encode(truth[None])
        angles = np.stack([x.true_angles for x in experiments])[None]
        return float(evaluator.similarities(genome, experiments, angles).mean())


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mission")
    parser.add_argument("prior", help="the mission's prior self-model (runs/missions/prior_sS/self_model)")
    parser.add_argument("--parts", default="all,imu", help=f"comma-separated, of {PARTS}")
    args = parser.parse_args(argv)
    directory = Path(args.mission)
    report = json.loads((directory / "mission.json").read_text())
    experiments = eea.load_experiments(directory / "recovered" / "experiments.npz")
    space = get_model_space("morphology+servos")
    kept = np.array([report["self_model_after"][f] for f in space.fields])
    truth = np.array([report["true_model"][f] for f in space.fields])
    config = _eea_config(MISSION_PRESETS[report["preset"]], report["damage"], report["seed"], 1,
                         report.get("self_model_fields") or {})
    starts = replay_starts(report, Path(args.prior), experiments)
    rest = {"fit": fit(kept, truth, experiments, config), "truth_true_angles": truth_at_true_angles(truth, experiments,
                                                                                                    config)}
    moving = {}
    original = eea.evaluation.simulate_batch
    for parts in args.parts.split(","):
        patch_starts(experiments, starts, parts)
        moving[parts] = {"fit": fit(kept, truth, experiments, config),
                         "truth_true_angles": truth_at_true_angles(truth, experiments, config)}
        eea.evaluation.simulate_batch = original
    print(json.dumps({"mission": directory.name, "kept_gains": kept[9:].tolist(), "true_gains": truth[9:].tolist(),
                      "start_speeds": [round(float(np.linalg.norm(s["linear"])), 4) for s in starts],
                      "start_turn_deg_s": [round(float(np.degrees(np.linalg.norm(s["angular"]))), 3) for s in starts],
                      "from_rest": rest, "from_robot_motion": moving}), flush=True)


if __name__ == "__main__":
    main()
