"""aquafish_gym: the simulated aquatic robot of Rose et al. (ERLARS 2013), section 3.1.

A capsule body with two continuous-rotation pectoral flippers and an oscillating caudal fin
on PyBullet with a vectorised fluid-drag model; morphology and damage are parameters. It is
both the *target* (the damaged robot) and the *candidate model* of the self-modeling
algorithm, and a Gymnasium env family registered on import (``aquafish envs`` lists it):

* ``AquaFish-v0``: swim forward (the paper's task; :mod:`aquafish_gym.env`);
* ``AquaFishStationKeeping-v0``: hold position and heading in a water current
  (:mod:`aquafish_gym.station_keeping`);
* ``AquaFishHeading-v0``: turn to and hold a target heading (:mod:`aquafish_gym.heading`).

Each registers a ``vector_entry_point`` (:mod:`aquafish_gym.vector_env`): ``gym.make_vec(id,
num_envs=N)`` steps N robots in one PyBullet world.
"""

from importlib.metadata import PackageNotFoundError as _PackageNotFoundError
from importlib.metadata import version as _version

try:  # the installed distribution's version (pyproject.toml); the same in the four packages
    __version__: str = _version("aquafish")
except _PackageNotFoundError:  # run from a source tree that is not installed
    __version__ = "0+unknown"

from aquafish_gym.damage import DAMAGES, Damage, ServoFaults, get_damage, register_damage
from aquafish_gym.faults import Fault, sampled_fault
from aquafish_gym.morphology import MORPHOLOGY_BOUNDS, MORPHOLOGY_FIELDS, Morphology
from aquafish_gym.params import DT_S, SimParams
from aquafish_gym.simulator import ACTION_BOUNDS, ACTION_FIELDS, BatchWorld, simulate_batch

import gymnasium as _gym

#: The registered tasks: env id -> entry point.
ENV_IDS: dict[str, str] = {
    "AquaFish-v0": "aquafish_gym.env:AquaFishEnv",
    "AquaFishStationKeeping-v0": "aquafish_gym.station_keeping:StationKeepingEnv",
    "AquaFishHeading-v0": "aquafish_gym.heading:HeadingEnv",
}
#: Their batched vector envs (``gym.make_vec(id, num_envs=N)``: N robots in one world):
#: env id -> vector entry point (:mod:`aquafish_gym.vector_env`).
VECTOR_ENTRY_POINTS: dict[str, str] = {
    "AquaFish-v0": "aquafish_gym.vector_env:AquaFishVectorEnv",
    "AquaFishStationKeeping-v0": "aquafish_gym.vector_env:StationKeepingVectorEnv",
    "AquaFishHeading-v0": "aquafish_gym.vector_env:HeadingVectorEnv",
}
for _id, _entry_point in ENV_IDS.items():
    if _id not in _gym.registry:
        _gym.register(id=_id, entry_point=_entry_point, vector_entry_point=VECTOR_ENTRY_POINTS[_id], kwargs={})

__all__ = [
    "ACTION_BOUNDS", "ACTION_FIELDS", "DAMAGES", "DT_S", "ENV_IDS", "VECTOR_ENTRY_POINTS", "MORPHOLOGY_BOUNDS",
    "MORPHOLOGY_FIELDS", "BatchWorld", "Damage", "Fault", "Morphology", "ServoFaults", "SimParams",
    "get_damage", "register_damage", "sampled_fault", "simulate_batch",
]
