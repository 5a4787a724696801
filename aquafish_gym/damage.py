"""Damages: a transformation of a morphology plus servo faults (docs/simulator.md).

Damage is not a different robot class: :class:`Damage` maps a healthy :class:`Morphology`
to a damaged one and carries :class:`ServoFaults` that the simulator applies to the motors.
:func:`get_damage` resolves a damage's text: a preset name (:data:`DAMAGES`), a fault written
out as JSON (inline or a ``.json`` file) or ``sampled:SEED`` (:mod:`aquafish_gym.faults`).
A preset added with :func:`register_damage` exists only in the process that registered it;
a fault given as text is rebuilt from its text in every worker process.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Callable

import numpy as np

from aquafish_gym.faults import SAMPLED_PREFIX, Fault, fault_from_file, parse_sampled_seed, sampled_fault
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
        name: the damage's text, which :func:`get_damage` resolves back to it: a preset name
            (``"left_pectoral_half"``), a fault's canonical JSON (``'{"gains":[1.0,-0.5,1.0]}'``)
            or ``"sampled:7"``.
        description: one sentence for documentation and reports.
        transform: maps a morphology to the damaged morphology (picklable for the built-in
            damages: a :class:`ScaleTransform` or a module-level function).
        faults: servo faults the damaged robot has.
    """

    name: str
    description: str
    transform: Callable[[Morphology], Morphology]
    faults: ServoFaults = NO_FAULTS

    def apply(self, morphology: Morphology | None = None) -> Morphology:
        """Return the damaged version of ``morphology`` (default: the healthy robot)."""
        return self.transform(morphology if morphology is not None else Morphology.healthy())


@dataclasses.dataclass(frozen=True)
class ScaleTransform:
    """A morphology transformation that multiplies some dimensions by factors (picklable).

    Attributes:
        factors: ``((field, factor), ...)``, field names from ``MORPHOLOGY_FIELDS``.
    """

    factors: tuple[tuple[str, float], ...] = ()

    def __call__(self, m: Morphology) -> Morphology:
        """``m`` with each named dimension times its factor (ValueError out of bounds)."""
        return m.replace(**{k: getattr(m, k) * f for k, f in self.factors})


def _scale(**factors: float) -> ScaleTransform:
    return ScaleTransform(tuple(factors.items()))


def _identity(m: Morphology) -> Morphology:
    return m


DAMAGES: dict[str, Damage] = {}


def register_damage(damage: Damage) -> Damage:
    """Add a damage preset to :data:`DAMAGES` (raises ``ValueError`` if the name is taken).

    The preset exists only in this process: a worker process (a spawned pool re-imports the
    main module) does not have it. To hand a damage to workers, give it as a JSON fault
    (:func:`get_damage`), which every process rebuilds from its text.
    """
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


def fault_damage(fault: Fault, name: str | None = None) -> Damage:
    """The :class:`Damage` of a :class:`~aquafish_gym.faults.Fault`, named ``name`` (default: its
    canonical JSON); its transform is a picklable :class:`ScaleTransform`."""
    return Damage(name if name is not None else fault.to_json(), fault.describe(), ScaleTransform(fault.scale),
                  ServoFaults(seized=fault.seized, speed_scale=fault.gains))


def get_damage(name: str) -> Damage:
    """Resolve a damage's text to a :class:`Damage`.

    Args:
        name: one of

            * a preset name in :data:`DAMAGES` (``"left_pectoral_half"``): that preset;
            * a fault written out as JSON (:class:`~aquafish_gym.faults.Fault`), inline
              (``'{"gains": [1, -0.5, 1]}'``) or in a file (a path ending in ``.json``, read
              now): a damage named by the fault's canonical JSON (so a file's damage no
              longer depends on the file);
            * ``"sampled:SEED"`` (SEED an int >= 0): the fault
              :func:`~aquafish_gym.faults.sampled_fault` draws, named ``"sampled:SEED"``
              (leading zeros dropped).

    Returns:
        The damage; its ``name`` is the canonical text, which resolves to an equal damage.

    Raises:
        ValueError: one line: an unknown name (listing the presets and the other forms), or
            an invalid fault (``damage fault: ...``, naming the key and its allowed range).
    """
    if not isinstance(name, str):
        raise ValueError(f"a damage is a preset name, a JSON fault or sampled:SEED (text), got {type(name).__name__}")
    if name in DAMAGES:
        return DAMAGES[name]
    text = name.strip()
    if text.startswith(SAMPLED_PREFIX):
        seed = parse_sampled_seed(text)
        return fault_damage(sampled_fault(seed), f"{SAMPLED_PREFIX}{seed}")
    if text.startswith(("{", "[")):
        return fault_damage(Fault.from_json(text))
    if text.lower().endswith(".json"):
        return fault_damage(fault_from_file(Path(text)))
    raise ValueError(f"unknown damage {name!r}; valid names: {', '.join(sorted(DAMAGES))}; or a JSON fault "
                     f"(inline '{{\"gains\": [1, -0.5, 1]}}' or a FILE.json with the keys scale, seized, gains) "
                     f"or sampled:SEED")


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
