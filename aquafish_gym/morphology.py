"""Robot morphology: the nine flipper dimensions the self-modeling algorithm estimates.

Source: paper section 3.1; docs/simulator.md. Units are simulator units: the body
diameter is 1.0 and stands for 8 cm of the physical robot.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import numpy as np

#: Names of the nine dimensions, in the order of :meth:`Morphology.to_array`.
MORPHOLOGY_FIELDS: tuple[str, ...] = (
    "left_pectoral_x",
    "left_pectoral_y",
    "left_pectoral_z",
    "right_pectoral_x",
    "right_pectoral_y",
    "right_pectoral_z",
    "caudal_x",
    "caudal_y",
    "caudal_z",
)

#: ``(9, 2)`` array of ``[min, max]`` per dimension (simulator units), paper section 3.1.
#: Pectoral (span out from the body, length, thickness) in [0, 1] x [0, 2] x [0, 0.5];
#: caudal (thickness, length, height) in [0, 0.5] x [0, 2] x [0, 1].
MORPHOLOGY_BOUNDS: np.ndarray = np.array(
    [
        [0.0, 1.0], [0.0, 2.0], [0.0, 0.5],
        [0.0, 1.0], [0.0, 2.0], [0.0, 0.5],
        [0.0, 0.5], [0.0, 2.0], [0.0, 1.0],
    ]
)
MORPHOLOGY_BOUNDS.setflags(write=False)

_HEALTHY = (0.25, 1.0, 0.0625, 0.25, 1.0, 0.0625, 0.25, 0.875, 0.375)


@dataclasses.dataclass(frozen=True)
class Morphology:
    """The nine flipper dimensions of the robot (simulator units, 1 unit = 8 cm).

    Pectoral flippers are boxes (x = span out from the body, y = length, z = thickness)
    hinged on the body's side on a lateral axis; the caudal fin is a box (x = thickness,
    y = length, z = height) hinged at the tail on a vertical axis. A dimension of 0 is legal
    and means a missing flipper (no drag, no mass, no collision shape).

    Raises:
        ValueError: if a field is NaN, infinite or outside :data:`MORPHOLOGY_BOUNDS`;
            the message names the field and its allowed range.
    """

    left_pectoral_x: float
    left_pectoral_y: float
    left_pectoral_z: float
    right_pectoral_x: float
    right_pectoral_y: float
    right_pectoral_z: float
    caudal_x: float
    caudal_y: float
    caudal_z: float

    FIELDS: ClassVar[tuple[str, ...]] = MORPHOLOGY_FIELDS

    def __post_init__(self) -> None:
        for name, (lo, hi) in zip(MORPHOLOGY_FIELDS, MORPHOLOGY_BOUNDS):
            value = getattr(self, name)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ValueError(f"Morphology.{name} must be a number in [{lo}, {hi}], got {value!r}") from None
            if not math.isfinite(value) or value < lo or value > hi:
                raise ValueError(f"Morphology.{name} must be in [{lo}, {hi}] (simulator units), got {value!r}")
            object.__setattr__(self, name, value)

    @classmethod
    def healthy(cls) -> "Morphology":
        """The undamaged robot: pectorals (0.25, 1.0, 0.0625), caudal (0.25, 0.875, 0.375).

        These are the physical robot's 8 x 2 cm flippers and 7 x 3 x 2 cm fin (paper Fig. 1).
        """
        return cls(*_HEALTHY)

    def to_array(self) -> np.ndarray:
        """Return the dimensions as a float64 array of shape ``(9,)`` in :data:`MORPHOLOGY_FIELDS` order."""
        return np.array([getattr(self, n) for n in MORPHOLOGY_FIELDS], dtype=np.float64)

    @classmethod
    def from_array(cls, values) -> "Morphology":
        """Build a morphology from a sequence of shape ``(9,)`` (:data:`MORPHOLOGY_FIELDS` order).

        Raises:
            ValueError: wrong shape, NaN, or a value out of range (the field is named).
        """
        arr = np.asarray(values, dtype=np.float64)
        if arr.shape != (9,):
            raise ValueError(f"a morphology array must have shape (9,) ({', '.join(MORPHOLOGY_FIELDS)}), got shape {arr.shape}")
        return cls(*arr.tolist())

    def replace(self, **changes: float) -> "Morphology":
        """Return a copy with some dimensions changed (validated like the constructor)."""
        return dataclasses.replace(self, **changes)


def validate_morphologies(morphologies) -> np.ndarray:
    """Check and return a batch of morphologies as a float64 ``(N, 9)`` array.

    Accepts an ``(N, 9)`` array-like, a single ``(9,)`` array, or a sequence of
    :class:`Morphology`.

    Raises:
        ValueError: wrong shape, NaN/inf, or a value outside :data:`MORPHOLOGY_BOUNDS`
            (the message names robot index, field and range).
    """
    if isinstance(morphologies, Morphology):
        morphologies = [morphologies]
    if isinstance(morphologies, (list, tuple)) and morphologies and isinstance(morphologies[0], Morphology):
        arr = np.stack([m.to_array() for m in morphologies])
    else:
        arr = np.asarray(morphologies, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 9 or arr.shape[0] == 0:
        raise ValueError(f"morphologies must have shape (N, 9) with N >= 1, got {np.shape(morphologies)}")
    bad = ~np.isfinite(arr) | (arr < MORPHOLOGY_BOUNDS[:, 0]) | (arr > MORPHOLOGY_BOUNDS[:, 1])
    if bad.any():
        i, j = np.argwhere(bad)[0]
        lo, hi = MORPHOLOGY_BOUNDS[j]
        raise ValueError(f"morphologies[{i}].{MORPHOLOGY_FIELDS[j]} must be in [{lo}, {hi}], got {arr[i, j]!r}")
    return arr
