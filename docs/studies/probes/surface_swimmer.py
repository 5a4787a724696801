"""How the surface swimmer swims, and which damages break an open-loop gait (docs/physics.md tables).

Prints Markdown: (1) speeds in body lengths per second with the tail only, the pectorals
only and both, and the turning rate under differential paddling; (2) the open-loop damage
table: for every damage preset, the best constant command (a grid over the servo ranges)
for the healthy robot and for the damaged one, and what the healthy command keeps of the
damaged body's own best on the damaged robot, over 20 s and 60 s. Distances are along the
initial heading (+y), means over ``--starts`` random initial flipper angles (seeds 0, 1, ...).
All robots of a table run in one batched world.

    python docs/studies/probes/surface_swimmer.py [--starts 10] [--waterline 0.3 | deep] [--draft-sweep | --feedback]
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

from aquafish_gym import DAMAGES, BatchWorld, Morphology, SimParams, argtypes, get_damage
from aquafish_gym.robot import BODY_LENGTH

GRID_PECTORAL = (-0.5, -0.25, 0.0, 0.25, 0.5)   # rev/s
GRID_CAUDAL = (0.0, 1.0)                         # Hz
CHECKPOINTS_S = (20.0, 60.0)


def starts(n: int) -> np.ndarray:
    """``(n, 3)`` initial angles: pectorals uniform on [0, 2 pi), caudal on +-30 deg, from seeds 0..n-1."""
    out = []
    for seed in range(n):
        rng = np.random.default_rng(seed)
        out.append([*rng.uniform(0, 2 * np.pi, 2), rng.uniform(-np.radians(30), np.radians(30))])
    return np.array(out)


def swim(morphs, faults, actions, angles, params, seconds) -> tuple[np.ndarray, np.ndarray]:
    """Forward distance ``(N, len(seconds))`` (units, along +y) and final yaw ``(N,)`` (deg, unwrapped)."""
    out = np.empty((len(morphs), len(seconds)))
    yaw = np.zeros(len(morphs))
    with BatchWorld(morphs, params, faults) as world:
        world.reset(angles, actions)
        y0 = world.position[:, 0, 1].copy()
        done, last = 0, world.imu_rpy_deg()[:, 2]
        for k, t in enumerate(seconds):
            steps = int(round(t / 0.01)) - done
            for _ in range(steps // 10):   # yaw unwrapped from samples 0.1 s apart
                world.advance(10)
                now = world.imu_rpy_deg()[:, 2]
                yaw += (now - last + 180.0) % 360.0 - 180.0
                last = now
            done += steps
            out[:, k] = world.position[:, 0, 1] - y0
    return out, yaw


def speeds(params, angles) -> None:
    commands = {"tail only (0, 0, 1 Hz)": (0.0, 0.0, 1.0), "pectorals only (-0.5, -0.5, 0)": (-0.5, -0.5, 0.0),
                "both (-0.5, -0.5, 1 Hz)": (-0.5, -0.5, 1.0), "one pectoral (-0.5, 0, 0)": (-0.5, 0.0, 0.0),
                "pectorals opposed (-0.5, 0.5, 0)": (-0.5, 0.5, 0.0)}
    n = len(angles)
    healthy = np.tile(Morphology.healthy().to_array(), (n * len(commands), 1))
    actions = np.repeat(np.array(list(commands.values())), n, axis=0)
    dist, yaw = swim(healthy, None, actions, np.tile(angles, (len(commands), 1)), params, (20.0,))
    print("| command (rev/s, rev/s, Hz) | speed (BL/s) mean [min, max] | yaw rate (deg/s) mean [min, max] |")
    print("|---|---|---|")
    for i, name in enumerate(commands):
        bl = dist[i * n:(i + 1) * n, 0] / 20.0 / BODY_LENGTH
        rate = yaw[i * n:(i + 1) * n] / 20.0
        print(f"| {name} | {bl.mean():.3f} [{bl.min():.3f}, {bl.max():.3f}] | "
              f"{rate.mean():+.1f} [{rate.min():+.1f}, {rate.max():+.1f}] |")


def draft_sweep(angles, waterlines=(0.0, 0.15, 0.3, 0.4, 0.5)) -> None:
    """Speed (BL/s, 20 s) of pectorals only and tail only, and the yaw (deg) of ``left_pectoral_half``
    under the healthy both-flipper command, at several drafts: the evidence for the default."""
    commands = np.array([(-0.5, -0.5, 0.0), (0.0, 0.0, 1.0), (-0.5, -0.5, 1.0)])
    n = len(angles)
    print("| waterline (units above the centre) | freeboard (cm) | pectorals only (BL/s) | tail only (BL/s) | "
          "both (BL/s) | `left_pectoral_half` under both: yaw after 20 s (deg) |")
    print("|---|---|---|---|---|---|")
    for h in waterlines:
        params = SimParams(waterline=h)
        healthy = np.tile(Morphology.healthy().to_array(), (3 * n, 1))
        dist, _ = swim(healthy, None, np.repeat(commands, n, axis=0), np.tile(angles, (3, 1)), params, (20.0,))
        bl = dist[:, 0].reshape(3, n).mean(axis=1) / 20.0 / BODY_LENGTH
        damaged = np.tile(get_damage("left_pectoral_half").apply().to_array(), (n, 1))
        _, yaw = swim(damaged, None, np.tile(commands[2], (n, 1)), angles, params, (20.0,))
        print(f"| {h} | {(0.5 - h) * 8:.1f} | {bl[0]:.3f} | {bl[1]:.3f} | {bl[2]:.3f} | {yaw.mean():+.0f} |")


def damage_table(params, angles) -> None:
    grid = np.array(list(itertools.product(GRID_PECTORAL, GRID_PECTORAL, GRID_CAUDAL)))
    names = sorted(DAMAGES)
    n, g = len(angles), len(grid)
    mean = np.empty((len(names), g, len(CHECKPOINTS_S)))   # (damage, command, horizon)
    for i, name in enumerate(names):   # one world per damage: g * n robots
        d = get_damage(name)
        morphs = np.tile(d.apply().to_array(), (g * n, 1))
        dist, _ = swim(morphs, d.faults, np.repeat(grid, n, axis=0), np.tile(angles, (g, 1)), params, CHECKPOINTS_S)
        mean[i] = dist.reshape(g, n, len(CHECKPOINTS_S)).mean(axis=1)
    healthy = names.index("none")
    print("| damage | horizon | healthy command | its distance on the damaged robot | best command for the damaged body "
          "| its distance | kept |")
    print("|---|---|---|---|---|---|---|")
    for h, t in enumerate(CHECKPOINTS_S):
        best_healthy = int(np.argmax(mean[healthy, :, h]))
        for i, name in enumerate(names):
            best = int(np.argmax(mean[i, :, h]))
            kept = mean[i, best_healthy, h] / mean[i, best, h] if mean[i, best, h] > 0 else float("nan")
            print(f"| `{name}` | {t:.0f} s | {tuple(grid[best_healthy].tolist())} | {mean[i, best_healthy, h]:.1f} | "
                  f"{tuple(grid[best].tolist())} | {mean[i, best, h]:.1f} | {100 * kept:.0f} % |")


def feedback_table(angles) -> None:
    """:class:`gait.HeadingHoldController` (differential paddling on the yaw error, gain 2 per rad,
    base (-1, -1, 1)) on every damage preset, 20 s and 60 s, from the same starts."""
    from gait import HeadingHoldController
    from gait.rollout import rollout

    controller = HeadingHoldController()
    print("| damage | heading hold, 20 s | heading hold, 60 s |")
    print("|---|---|---|")
    for name in sorted(DAMAGES):
        cells = []
        for t in CHECKPOINTS_S:
            d = np.array([rollout(controller, name, initial_angles=a, episode_duration_s=t).distance for a in angles])
            cells.append(f"{d.mean():.1f} [{d.min():.1f}, {d.max():.1f}]")
        print(f"| `{name}` | {cells[0]} | {cells[1]} |")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=10, help="random initial flipper angles per command (>= 1)")
    parser.add_argument("--waterline", type=argtypes.waterline, default=0.3,
                        help="free surface above the body's centre (units), or 'deep'")
    parser.add_argument("--draft-sweep", action="store_true", help="only the table of speeds against the draft")
    parser.add_argument("--feedback", action="store_true", help="only the heading-hold controller's table")
    args = parser.parse_args(argv)
    if args.starts < 1:
        parser.error(f"--starts must be >= 1, got {args.starts}")
    waterline = args.waterline
    params = SimParams(waterline=waterline)
    angles = starts(args.starts)
    if args.draft_sweep:
        draft_sweep(angles)
        return
    if args.feedback:
        feedback_table(angles)
        return
    print(f"physics: {'deep water' if waterline is None else f'surface, waterline {waterline}'}; "
          f"{args.starts} starts\n")
    speeds(params, angles)
    print()
    damage_table(params, angles)


if __name__ == "__main__":
    main()
