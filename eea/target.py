"""The target system of the EEA: the simulated damaged robot (paper sections 3.2, 4 and 5).

The target is the healthy robot with a named damage (:func:`aquafish_gym.get_damage`):
a damaged morphology plus its servo faults. As in the paper, "the orientation of the
target robot was randomized between every action": each :meth:`Target.perform` draws new
true initial flipper angles from the run's generator (pectorals uniform in [0, 2 pi),
caudal uniform in [-30 deg, 30 deg], snapped to the 1e-6 rad grid models are simulated on,
:func:`eea.experiment.quantise_angles`) and returns them beside the IMU log; who may see them
is the inference strategy's business.
"""

from __future__ import annotations

import numpy as np

from aquafish_gym import Morphology, SimParams, get_damage, simulate_batch
from aquafish_gym.checks import check_int
from aquafish_gym.simulator import AT_REST
from eea.experiment import check_params, quantise_angles, random_angles

__all__ = ["Target"]


class Target:
    """The simulated damaged robot on which actions are performed.

    Args:
        damage: name of the damage preset (``aquafish_gym.DAMAGES``), e.g.
            ``"left_pectoral_half"`` (the paper's case study).
        steps: simulation steps (0.01 s each) of every experiment, >= 1.
        rng: draws the true initial angles of every experiment (the run's generator).
        params: simulator parameters (default: the defaults); the caudal sweep must be
            the default one (:func:`eea.experiment.check_params`).

    Attributes:
        morphology: the damaged :class:`~aquafish_gym.Morphology` (the oracle for OBJ_FIT).
        faults: the damaged robot's :class:`~aquafish_gym.ServoFaults`.
        start_motion: ``(7,)`` what the target's IMU measured at the start of its last
            experiment, which the models' simulations of it start from
            (:attr:`eea.experiment.Experiment.start_motion`): always
            :data:`~aquafish_gym.simulator.AT_REST` here, every experiment starting level and still.

    Raises:
        ValueError: on an unknown damage name (the message lists the valid names),
            ``steps < 1`` or ``params`` with another caudal sweep.
    """

    def __init__(self, damage: str, steps: int, rng: np.random.Generator, params: SimParams | None = None) -> None:
        preset = get_damage(damage)
        check_int("steps", steps, 1)
        self.damage = damage
        self.morphology: Morphology = preset.apply()
        self.faults = preset.faults
        self.steps = int(steps)
        self.params = check_params(params)
        self.start_motion = np.array(AT_REST)
        self._rng = rng

    def perform(self, action) -> tuple[np.ndarray, np.ndarray]:
        """Run one action on the target from fresh random initial angles.

        Args:
            action: ``(3,)`` servo command: left and right pectoral speed (rev/s, in
                [-0.5, 0.5]) and caudal frequency (Hz, in [0, 1]).

        Returns:
            ``(imu_log, true_angles)``: ``(steps, 3)`` roll, pitch, yaw in degrees (yaw
            unwrapped) and the ``(3,)`` true initial angles in radians.

        Raises:
            ValueError: if the action has the wrong shape or is out of range.
        """
        act = np.asarray(action, dtype=np.float64)
        if act.shape != (3,):
            raise ValueError(f"action must have shape (3,) (left rev/s, right rev/s, caudal Hz), got {act.shape}")
        true_angles = quantise_angles(random_angles(self._rng, 1))[1][0]  # on the models' grid
        log = simulate_batch(self.morphology.to_array()[None], act[None], true_angles[None], self.steps,
                             faults=self.faults, params=self.params)
        return log[0], true_angles
