"""Can the pectoral flippers alone propel the robot? Constant-speed paddling on a tailless robot.

A flipper on a continuous-rotation servo at constant speed is a fully submerged paddle wheel:
its power and recovery strokes mirror each other, so its mean thrust is zero by symmetry
(docs/physics.md, "Pectoral flippers in deep water"). This script measures it: every pair of constant pectoral
speeds on a 5 x 5 grid in [-0.5, 0.5] rev/s, 10 random starts each, 20 s, all 250 robots
in one batch (about a minute on one core). In deep water (``SimParams(waterline=None)``), the
physics the page's numbers were measured in; the surface swimmer's paddles do push (docs/physics.md).

    python docs/studies/probes/pectoral_paddling.py
"""

import numpy as np

from aquafish_gym import BatchWorld, SimParams, get_damage

tailless = get_damage("caudal_missing").apply().to_array()
speeds = np.linspace(-0.5, 0.5, 5)  # rev/s
commands = np.array([(left, right, 0.0) for left in speeds for right in speeds])
rng = np.random.default_rng(0)
starts = np.column_stack([rng.uniform(0, 2 * np.pi, 10), rng.uniform(0, 2 * np.pi, 10), np.zeros(10)])
n = len(commands) * len(starts)

with BatchWorld(np.tile(tailless, (n, 1)), SimParams(waterline=None)) as world:
    world.reset(np.tile(starts, (len(commands), 1)), np.repeat(commands, len(starts), axis=0))
    for _ in range(2000):  # 20 s
        world.step()
    forward = (world.position[:, 0, 1] - world.home[:, 1]).reshape(len(commands), len(starts))

print("left rev/s  right rev/s  forward distance in 20 s (units): mean +- std over 10 starts")
for (left, right, _), row in zip(commands, forward):
    print(f"{left:+10.2f} {right:+12.2f}  {row.mean():+.3f} +- {row.std():.3f}")
print(f"best mean {forward.mean(axis=1).max():+.3f} units; the caudal fin alone at 1 Hz swims about 8")
