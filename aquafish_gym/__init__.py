"""aquafish_gym: the simulated aquatic robot of Rose et al. (ERLARS 2013), section 3.1.

A capsule body with two continuous-rotation pectoral flippers and an oscillating caudal fin
on PyBullet with a vectorised fluid-drag model; morphology and damage are parameters. It is
both the *target* (the damaged robot) and the *candidate model* of the self-modeling
algorithm, and the Gymnasium env ``AquaFish-v0`` (registered on import).
"""

from aquafish_gym.damage import DAMAGES, Damage, ServoFaults, get_damage, register_damage
from aquafish_gym.morphology import MORPHOLOGY_BOUNDS, MORPHOLOGY_FIELDS, Morphology
from aquafish_gym.params import DT_S, SimParams
from aquafish_gym.simulator import ACTION_BOUNDS, ACTION_FIELDS, BatchWorld, simulate_batch

import gymnasium as _gym

if "AquaFish-v0" not in _gym.registry:
    _gym.register(id="AquaFish-v0", entry_point="aquafish_gym.env:AquaFishEnv", kwargs={})

__all__ = [
    "ACTION_BOUNDS", "ACTION_FIELDS", "DAMAGES", "DT_S", "MORPHOLOGY_BOUNDS", "MORPHOLOGY_FIELDS",
    "BatchWorld", "Damage", "Morphology", "ServoFaults", "SimParams",
    "get_damage", "register_damage", "simulate_batch",
]
