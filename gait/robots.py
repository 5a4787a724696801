"""Which robot a controller swims in: a morphology plus a damage preset, and servo faults.

A :class:`Robot` is everything AquaFish-v0 needs to build the body: the nine flipper
dimensions and the name of a damage (which may also carry servo faults, e.g. a seized
servo), or ``"random"`` (a damage preset drawn per episode: damage randomisation), and
optionally explicit :class:`~aquafish_gym.ServoFaults` (e.g. the servo gains of a
``morphology+servos`` self-model) that override the damage's. The transfer protocol runs one controller on two robots: its *native* one (the
morphology it was evolved for) and a *target* (e.g. the damaged robot).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

from aquafish_gym import DAMAGES, MORPHOLOGY_FIELDS, Morphology, ServoFaults, get_damage
from aquafish_gym.faults import SAMPLED_PREFIX
from aquafish_gym.files import parse_json, read_input

#: The ``damage`` of a :class:`Robot` that draws a damage preset per episode (AquaFish-v0's
#: damage randomisation): a robot trained on it is the damage-robust policy's.
RANDOM_DAMAGE = "random"


@dataclasses.dataclass(frozen=True)
class Robot:
    """A morphology, a damage preset and servo faults, as passed to ``gym.make("AquaFish-v0", ...)``.

    Attributes:
        morphology: the nine flipper dimensions before the damage (simulator units).
        damage: a damage :func:`aquafish_gym.get_damage` resolves (a preset name, a JSON fault
            inline or as a ``.json`` file, ``sampled:SEED``), kept as its canonical text (a file
            is read once) and applied to ``morphology`` by the env, or
            :data:`RANDOM_DAMAGE` (``"random"``): every episode draws a preset from its
            ``reset(seed=...)`` generator, so one seed always draws the same damage.
        label: a short name for legends and reports.
        faults: servo faults overriding the damage's (AquaFish-v0's ``faults``), e.g.
            ``ServoFaults(speed_scale=gains)`` for a self-model's servo gains; None: the
            damage's own faults.

    Raises:
        ValueError: an unknown damage name, a morphology that is not a ``Morphology``, or
            faults that are not ``ServoFaults``.
    """

    morphology: Morphology
    damage: str = "none"
    label: str = ""
    faults: ServoFaults | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.morphology, Morphology):
            raise ValueError(f"Robot.morphology must be a Morphology, got {type(self.morphology).__name__}")
        if self.damage != RANDOM_DAMAGE:
            object.__setattr__(self, "damage", get_damage(self.damage).name)
        if self.faults is not None and not isinstance(self.faults, ServoFaults):
            raise ValueError(f"Robot.faults must be a ServoFaults or None, got {type(self.faults).__name__}")
        if not self.label:
            base = "healthy" if self.morphology == Morphology.healthy() else "custom"
            label = base if self.damage == "none" else f"{base} + {self.damage}"
            if self.faults is not None and not self.faults.healthy:
                label += " (servo gains " + ", ".join(f"{g:g}" for g in self.faults.speed_scale) + ")"
            object.__setattr__(self, "label", label)

    def env_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for ``gym.make("AquaFish-v0", ...)``."""
        kwargs: dict[str, Any] = {"morphology": self.morphology, "damage": self.damage}
        if self.faults is not None:
            kwargs["faults"] = self.faults
        return kwargs

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description: label, damage, the morphology by field name, and the faults
        (``seized``, ``speed_scale``) when given (absent otherwise, so the fingerprints of
        runs on robots without them are unchanged)."""
        d = {"label": self.label, "damage": self.damage,
             "morphology": dict(zip(MORPHOLOGY_FIELDS, self.morphology.to_array().tolist()))}
        if self.faults is not None:
            d["faults"] = {"seized": list(self.faults.seized), "speed_scale": list(self.faults.speed_scale)}
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Robot":
        """The robot :meth:`to_dict` described (its inverse).

        Raises:
            KeyError: ``morphology`` or a morphology field is missing.
            ValueError: an invalid morphology, damage or faults (as the constructor).
        """
        faults = d.get("faults")
        return cls(Morphology.from_array([d["morphology"][f] for f in MORPHOLOGY_FIELDS]), d.get("damage", "none"),
                   d.get("label", ""), None if faults is None else ServoFaults(seized=tuple(faults["seized"]),
                                                                               speed_scale=tuple(faults["speed_scale"])))


def as_robot(value, *, damage: str = "none") -> Robot:
    """Interpret a robot given in any of the accepted forms.

    Args:
        value: a :class:`Robot`; a :class:`Morphology` or 9 numbers (with ``damage``);
            or a string for :func:`parse_robot` (``"healthy"``, a damage name, a file,
            or 9 comma-separated numbers).
        damage: damage applied to a morphology given as ``Morphology`` or numbers.

    Raises:
        ValueError: anything else, or an invalid morphology or damage.
    """
    if isinstance(value, Robot):
        return value
    if isinstance(value, Morphology):
        return Robot(value, damage)
    if isinstance(value, (str, Path)):
        robot = parse_robot(str(value))
        if damage != "none":
            if robot.damage != "none":
                raise ValueError(f"robot {value!r} already has damage {robot.damage!r}; cannot add damage {damage!r}")
            robot = Robot(robot.morphology, damage)
        return robot
    if isinstance(value, (list, tuple, np.ndarray)):
        return Robot(Morphology.from_array(value), damage)
    raise ValueError(f"a robot must be a Robot, Morphology, 9 numbers or a string spec, got {type(value).__name__}")


def parse_robot(spec: str) -> Robot:
    """Parse a command-line robot description.

    Accepted forms:
        * ``healthy``: the undamaged robot.
        * a damage name (``left_pectoral_half``, ...), an inline JSON fault
          (``{"gains": [1, -0.5, 1]}``) or ``sampled:SEED``: the healthy robot with that damage,
          including its servo faults; this is the paper's damaged *target*. (A ``.json`` file
          is a robot, below; pass a fault file as a ``damage``.)
        * 9 comma-separated numbers: a morphology (``MORPHOLOGY_FIELDS`` order, units).
        * a file: JSON (a list of 9 numbers, a mapping of the nine field names, or a mapping
          with a ``"morphology"`` entry of either form, an optional ``"damage"`` and optional
          ``"faults"``, ``{"seized": [...], "speed_scale": [...]}``), or a text file of 9 numbers separated by commas or whitespace.

    Raises:
        ValueError: none of the forms, naming what is allowed.
    """
    spec = spec.strip()
    if spec == "healthy":
        return Robot(Morphology.healthy(), "none", "healthy")
    if spec in DAMAGES or spec.startswith((SAMPLED_PREFIX, "{")):
        damage = get_damage(spec).name
        return Robot(Morphology.healthy(), damage, damage)
    path = Path(spec)
    if path.is_file():
        return _robot_from_file(path)
    if "," in spec:
        try:
            numbers = [float(s) for s in spec.split(",")]
        except ValueError:
            raise ValueError(f"morphology {spec!r}: expected 9 comma-separated numbers") from None
        return Robot(Morphology.from_array(numbers), "none", "custom")
    raise ValueError(f"unknown robot {spec!r}; use 'healthy', a damage name ({', '.join(sorted(DAMAGES))}), "
                     f"a JSON fault or sampled:SEED, "
                     f"9 comma-separated numbers ({', '.join(MORPHOLOGY_FIELDS)}) or a JSON/text file")


def _morphology_from(value, source: str) -> Morphology:
    if isinstance(value, dict):
        missing = set(MORPHOLOGY_FIELDS) - set(value)
        if missing:
            raise ValueError(f"{source}: morphology mapping lacks {sorted(missing)}")
        return Morphology(**{k: value[k] for k in MORPHOLOGY_FIELDS})
    return Morphology.from_array(value)


def _robot_from_file(path: Path) -> Robot:
    try:
        text = read_input(path).decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not UTF-8 text") from None
    if path.suffix.lower() == ".json":
        try:
            data = parse_json(text, source=path)
        except json.JSONDecodeError as err:
            raise ValueError(f"{path}: not valid JSON ({err})") from None
        if isinstance(data, dict) and "morphology" in data:
            faults = data.get("faults")
            if faults is not None:
                try:
                    faults = ServoFaults(**faults)
                except TypeError as err:
                    raise ValueError(f"{path}: faults must map 'seized' and/or 'speed_scale' ({err})") from None
            return Robot(_morphology_from(data["morphology"], str(path)), data.get("damage", "none"), path.stem,
                         faults)
        return Robot(_morphology_from(data, str(path)), "none", path.stem)
    try:
        numbers = [float(s) for s in text.replace(",", " ").split()]
    except ValueError:
        raise ValueError(f"{path}: expected 9 numbers separated by commas or whitespace") from None
    return Robot(Morphology.from_array(numbers), "none", path.stem)
