"""Simulated IMU: the robot's own roll, pitch and yaw (docs/simulator.md).

The robot's axes are x lateral, y forward, z up, so (unlike PyBullet's
``getEulerFromQuaternion``, whose "roll" is about world x) we define, with the
body-to-world rotation R = Rz(yaw) @ Rx(pitch) @ Ry(roll):

* pitch: about the lateral x axis, positive nose up: ``asin(R[2, 1])``;
* roll: about the longitudinal y axis, positive right side down: ``atan2(-R[2, 0], R[2, 2])``;
* yaw: about z, positive turning left (counter-clockwise seen from above):
  ``atan2(-R[0, 1], R[1, 1])``.
"""

from __future__ import annotations

import numpy as np


def roll_pitch_yaw_deg(rotation: np.ndarray) -> np.ndarray:
    """Robot roll, pitch, yaw in degrees from body-to-world rotations.

    Args:
        rotation: ``(..., 3, 3)`` body-to-world rotation matrices.

    Returns:
        ``(..., 3)`` [roll, pitch, yaw] in degrees, each in (-180, 180] (pitch in [-90, 90]).
    """
    r = rotation
    roll = np.arctan2(-r[..., 2, 0], r[..., 2, 2])
    pitch = np.arcsin(np.clip(r[..., 2, 1], -1.0, 1.0))
    yaw = np.arctan2(-r[..., 0, 1], r[..., 1, 1])
    return np.degrees(np.stack([roll, pitch, yaw], axis=-1))


def unwrap_yaw_deg(log: np.ndarray) -> np.ndarray:
    """Unwrap the yaw channel (index 2) of an ``(N, steps, 3)`` IMU log along time (in place copy)."""
    out = np.array(log, dtype=np.float64, copy=True)
    out[..., 2] = np.degrees(np.unwrap(np.radians(out[..., 2]), axis=-1))
    return out
