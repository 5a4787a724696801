"""Damage presets: a transformation of a morphology plus servo faults (docs/simulator.md).

Damage is not a different robot class: :class:`Damage` maps a healthy :class:`Morphology`
to a damaged one and carries :class:`ServoFaults` that the simulator applies to the motors.
Add a preset with :func:`register_damage`.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from aquafish_gym.morphology import Morphology

SERVO_NAMES = ("left_pectoral", "right_pectoral", "caudal")


@dataclasses.dataclass(frozen=True)
class ServoFaults:
    """Faults of the three servos (left pectoral, right pectoral, caudal).

    Attributes:
        seized: per servo, True if the motor has failed and holds the flipper at its
            initial angle (``seized_left_pectoral``).
        speed_scale: per servo, a gain on the commanded speed (pectorals, in [-1, 1]) or
            frequency (caudal, in [0, 1]); 1.0 is a healthy servo, a fraction a weak one, 0 a
            dead one, and a negative pectoral gain a servo that turns the wrong way
            (remounted or miswired: ``reversed_left_pectoral``).

    Raises:
        ValueError: wrong lengths, a pectoral gain outside [-1, 1] or a caudal one outside [0, 1].
    """

    seized: tuple[bool, bool, bool] = (False, False, False)
    speed_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        if len(self.seized) != 3 or len(self.speed_scale) != 3:
            raise ValueError(f"ServoFaults fields need one entry per servo {SERVO_NAMES}, got seized={self.seized}, speed_scale={self.speed_scale}")
        object.__setattr__(self, "seized", tuple(bool(s) for s in self.seized))
        scales = tuple(float(s) for s in self.speed_scale)
        if not (all(-1.0 <= s <= 1.0 for s in scales[:2]) and 0.0 <= scales[2] <= 1.0):
            raise ValueError(f"ServoFaults.speed_scale: the pectoral gains must be in [-1, 1] (negative: turning the "
                             f"wrong way) and the caudal one in [0, 1], got {scales}")
        object.__setattr__(self, "speed_scale", scales)

    @property
    def healthy(self) -> bool:
        """True when no servo is seized or slowed."""
        return not any(self.seized) and all(s == 1.0 for s in self.speed_scale)


NO_FAULTS = ServoFaults()


@dataclasses.dataclass(frozen=True)
class Damage:
    """A named damage: a morphology transformation and servo faults.

    Attributes:
        name: registry key, e.g. ``"left_pectoral_half"``.
        description: one sentence for documentation and reports.
        transform: maps a morphology to the damaged morphology.
        faults: servo faults the damaged robot has.
    """

    name: str
    description: str
    transform: Callable[[Morphology], Morphology]
    faults: ServoFaults = NO_FAULTS

    def apply(self, morphology: Morphology | None = None) -> Morphology:
        """Return the damaged version of ``morphology`` (default: the healthy robot)."""
        return self.transform(morphology if morphology is not None else Morphology.healthy())


def _scale(**factors: float) -> Callable[[Morphology], Morphology]:
    def transform(m: Morphology) -> Morphology:
        return m.replace(**{k: getattr(m, k) * f for k, f in factors.items()})

    return transform


def _identity(m: Morphology) -> Morphology:
    return m


DAMAGES: dict[str, Damage] = {}


def register_damage(damage: Damage) -> Damage:
    """Add a damage preset to :data:`DAMAGES` (raises ``ValueError`` if the name is taken)."""
    if damage.name in DAMAGES:
        raise ValueError(f"damage {damage.name!r} is already registered")
    DAMAGES[damage.name] = damage
    return damage


for _d in (
    Damage("none", "No damage: the healthy robot.", _identity),
    Damage("left_pectoral_half", "Left pectoral flipper length halved (the paper's case study, section 5).", _scale(left_pectoral_y=0.5)),
    Damage("right_pectoral_half", "Right pectoral flipper length halved.", _scale(right_pectoral_y=0.5)),
    Damage("left_pectoral_missing", "Left pectoral flipper lost entirely (all three dimensions 0).", _scale(left_pectoral_x=0.0, left_pectoral_y=0.0, left_pectoral_z=0.0)),
    Damage("caudal_half", "Caudal fin length halved.", _scale(caudal_y=0.5)),
    Damage("caudal_missing", "Caudal fin lost entirely (all three dimensions 0): the tail gives no thrust.", _scale(caudal_x=0.0, caudal_y=0.0, caudal_z=0.0)),
    Damage("seized_left_pectoral", "Left pectoral servo seized: the flipper stays at its initial angle.", _identity, ServoFaults(seized=(True, False, False))),
    Damage("weak_right_pectoral", "Right pectoral servo turns at half the commanded speed.", _identity, ServoFaults(speed_scale=(1.0, 0.5, 1.0))),
    Damage("reversed_left_pectoral", "Left pectoral servo turns the wrong way (remounted or miswired): gain -1.", _identity, ServoFaults(speed_scale=(-1.0, 1.0, 1.0))),
):
    register_damage(_d)


def get_damage(name: str) -> Damage:
    """Look up a damage preset by name.

    Raises:
        ValueError: unknown name; the message lists the valid names.
    """
    try:
        return DAMAGES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown damage {name!r}; valid names: {', '.join(sorted(DAMAGES))}") from None


def faults_array(faults, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Broadcast servo faults to a batch.

    Args:
        faults: ``None``, one :class:`ServoFaults` for all robots, or a sequence of ``n``.
        n: batch size.

    Returns:
        ``(seized (n, 3) bool, speed_scale (n, 3) float64)``.

    Raises:
        ValueError: a sequence of the wrong length or of the wrong type.
    """
    if faults is None:
        faults = NO_FAULTS
    if isinstance(faults, ServoFaults):
        faults = [faults] * n
    faults = list(faults)
    if len(faults) != n or not all(isinstance(f, ServoFaults) for f in faults):
        raise ValueError(f"faults must be None, a ServoFaults, or a sequence of {n} ServoFaults; got {len(faults)} items")
    return (np.array([f.seized for f in faults], dtype=bool), np.array([f.speed_scale for f in faults], dtype=np.float64))
