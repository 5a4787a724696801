"""Faults as data: a damage written out as JSON, or drawn from a seed (docs/simulator.md).

A :class:`Fault` is what a damage does to the robot, in three optional parts:

* ``scale``: morphology field name (:data:`~aquafish_gym.MORPHOLOGY_FIELDS`) -> factor >= 0
  multiplying that dimension (0: the part is gone);
* ``seized``: three booleans (left pectoral, right pectoral, caudal), True for a servo that
  holds its flipper at its initial angle;
* ``gains``: three servo gains on the command, the pectorals' in [-1, 1] (negative: turning
  the wrong way), the caudal's in [0, 1] (1: healthy, a fraction: weak, 0: dead).

It is written as JSON (``{"gains": [1, -0.5, 1]}``) inline or in a ``.json`` file, and its
canonical text (:meth:`Fault.to_json`: compact, keys sorted, parts at their default left
out) is what a run records, so a worker process rebuilds the fault from text alone.
``sampled:SEED`` names a fault drawn by :func:`sampled_fault`. :func:`aquafish_gym.get_damage`
resolves every form to a :class:`~aquafish_gym.Damage`; this module has no dependency on it.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from aquafish_gym.checks import DuplicateKeyError, json_loads_unique_keys, short_repr
from aquafish_gym.files import InputFileError, read_input
from aquafish_gym.morphology import MORPHOLOGY_BOUNDS, MORPHOLOGY_FIELDS, Morphology

__all__ = ["FAULT_KEYS", "SAMPLED_KINDS", "SAMPLED_PREFIX", "Fault", "FaultDraw", "draw_faults", "fault_from_file",
           "parse_sampled_seed", "sampled_fault"]

#: The keys of a JSON fault, each optional.
FAULT_KEYS: tuple[str, ...] = ("scale", "seized", "gains")
#: The prefix of a sampled fault's text, ``sampled:SEED``.
SAMPLED_PREFIX = "sampled:"
_SERVOS = ("left pectoral", "right pectoral", "caudal")
_HEALTHY = dict(zip(MORPHOLOGY_FIELDS, Morphology.healthy().to_array().tolist()))
_PREFIX = "damage fault: "
#: The most digits of a ``sampled:SEED``'s SEED (Python converts no longer integer text).
MAX_SAMPLED_SEED_DIGITS = 4300


def _error(message: str) -> ValueError:
    return ValueError(_PREFIX + message)


def _number(value, where: str, allowed: str) -> float:
    """A finite JSON number (not a bool), as a float; -0.0 becomes 0.0."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        got = _json_short(value) if _jsonable(value) else short_repr(value)
        raise _error(f"{where} must be a number in {allowed}, got {got}")
    return float(value) + 0.0


def _json_short(value, limit: int = 80) -> str:
    """``value`` as JSON for a message, at most about ``limit`` characters."""
    text = json.dumps(value)
    return text if len(text) <= limit else text[:limit] + f"... ({len(text)} characters)"


def _jsonable(value) -> bool:
    try:
        json.dumps(value, allow_nan=False)
    except (TypeError, ValueError):
        return False
    return True


def _fmt(x: float) -> str:
    """A number as a person writes it: ``-2``, ``0.5``."""
    return f"{x:g}" if isinstance(x, (int, float)) and not isinstance(x, bool) else repr(x)


def _scale_range(field: str) -> tuple[float, float]:
    """The factors of ``field`` that keep the healthy robot inside :data:`MORPHOLOGY_BOUNDS`."""
    lo, hi = MORPHOLOGY_BOUNDS[MORPHOLOGY_FIELDS.index(field)]
    return 0.0, float(hi) / _HEALTHY[field]


@dataclasses.dataclass(frozen=True)
class Fault:
    """One fault of the robot: morphology factors, seized servos and servo gains.

    Attributes:
        scale: ``((field, factor), ...)`` in :data:`MORPHOLOGY_FIELDS` order, each factor
            >= 0 and small enough that the healthy robot stays in :data:`MORPHOLOGY_BOUNDS`
            (e.g. ``left_pectoral_y`` in [0, 2]); a factor of 1 is dropped.
        seized: ``(3,)`` per servo (left pectoral, right pectoral, caudal), True: seized.
        gains: ``(3,)`` servo gains, pectorals in [-1, 1], caudal in [0, 1].

    Raises:
        ValueError: one line, ``damage fault: ...``, naming the key and its allowed range.
    """

    scale: tuple[tuple[str, float], ...] = ()
    seized: tuple[bool, bool, bool] = (False, False, False)
    gains: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        scale = dict(self.scale) if not isinstance(self.scale, dict) else self.scale
        if not isinstance(self.scale, dict) and len(scale) != len(self.scale):
            raise _error(f"scale names a field twice: {short_repr(self.scale)}")
        for field in scale:
            if field not in MORPHOLOGY_FIELDS:
                raise _error(f"scale: unknown morphology field {short_repr(field)}; "
                             f"fields: {', '.join(MORPHOLOGY_FIELDS)}")
        factors = {}
        for field in MORPHOLOGY_FIELDS:
            if field in scale:
                lo, hi = _scale_range(field)
                allowed = f"[0, {_fmt(round(hi, 4))}]"
                factor = _number(scale[field], f"scale.{field}", allowed)
                if not lo <= factor <= hi:
                    raise _error(f"scale.{field} must be in {allowed} (the healthy {_fmt(_HEALTHY[field])} times it "
                                 f"must stay within [{_fmt(lo)}, {_fmt(hi * _HEALTHY[field])}] units), got {_fmt(factor)}")
                if factor != 1.0:
                    factors[field] = factor
        object.__setattr__(self, "scale", tuple(factors.items()))
        seized = self.seized
        if not isinstance(seized, (list, tuple)) or len(seized) != 3:
            raise _error(f"seized must be 3 booleans (left pectoral, right pectoral, caudal), got {short_repr(seized)}")
        for i, s in enumerate(seized):
            if not isinstance(s, (bool, np.bool_)):
                raise _error(f"seized[{i}] must be true or false, got {short_repr(s)}")
        object.__setattr__(self, "seized", tuple(bool(s) for s in seized))
        gains = self.gains
        if not isinstance(gains, (list, tuple)) or len(gains) != 3:
            raise _error(f"gains must be 3 numbers (left pectoral, right pectoral in [-1, 1]; caudal in [0, 1]), "
                         f"got {short_repr(gains)}")
        values = []
        for i, g in enumerate(gains):
            lo = -1.0 if i < 2 else 0.0
            allowed = f"[{_fmt(lo)}, 1]"
            value = _number(g, f"gains[{i}]", allowed)
            if not lo <= value <= 1.0:
                raise _error(f"gains[{i}] must be in {allowed}, got {_fmt(value)}")
            values.append(value)
        object.__setattr__(self, "gains", tuple(values))

    @classmethod
    def from_dict(cls, data) -> "Fault":
        """A fault from a JSON object's content (``{"scale": {...}, "seized": [...], "gains": [...]}``).

        Raises:
            ValueError: not a mapping, an unknown key, or an invalid value (one line).
        """
        if not isinstance(data, dict):
            raise _error(f"a fault is a JSON object with the keys {', '.join(FAULT_KEYS)} (each optional), "
                         f"got {type(data).__name__}")
        for key in data:
            if key not in FAULT_KEYS:
                raise _error(f"unknown key {short_repr(key)}; allowed: {', '.join(FAULT_KEYS)}")
        scale = data.get("scale", {})
        if not isinstance(scale, dict):
            raise _error(f"scale must be an object of morphology field -> factor >= 0, got {short_repr(scale)}")
        return cls(scale=tuple(scale.items()), seized=data.get("seized", (False, False, False)),
                   gains=data.get("gains", (1.0, 1.0, 1.0)))

    @classmethod
    def from_json(cls, text: str, source: str = "") -> "Fault":
        """A fault from JSON text (``source``, e.g. a file name, prefixes a syntax error).

        Raises:
            ValueError: invalid JSON, a key given twice, or as :meth:`from_dict`.
        """

        try:
            data = json_loads_unique_keys(text)
        except DuplicateKeyError as err:
            raise _error(str(err)) from None
        except InputFileError as err:  # nested too deeply, an integer too long
            raise _error(f"{source + ': ' if source else ''}the JSON {err.problem}") from None
        except json.JSONDecodeError as err:
            raise _error(f"{source + ': ' if source else ''}not valid JSON ({err})") from None
        return cls.from_dict(data)

    def to_dict(self) -> dict:
        """The canonical JSON content: only the keys not at their default (``{}``: no fault)."""
        d: dict = {}
        if self.scale:
            d["scale"] = dict(self.scale)
        if any(self.seized):
            d["seized"] = list(self.seized)
        if self.gains != (1.0, 1.0, 1.0):
            d["gains"] = list(self.gains)
        return d

    def to_json(self) -> str:
        """The canonical text: compact JSON with sorted keys (``{"gains":[1.0,-0.5,1.0]}``); equal
        faults give equal text, and :meth:`from_json` reads it back to an equal fault."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    def describe(self) -> str:
        """One sentence: what the fault does, part by part."""
        parts = []
        scale = dict(self.scale)
        for flipper, name in (("left_pectoral", "left pectoral flipper"), ("right_pectoral", "right pectoral flipper"),
                              ("caudal", "caudal fin")):
            fields = [f"{flipper}_{axis}" for axis in "xyz"]
            given = {f: scale[f] for f in fields if f in scale}
            if len(given) == 3 and all(v == 0.0 for v in given.values()):
                parts.append(f"{name} lost")
            elif list(given) == [f"{flipper}_y"] and given[f"{flipper}_y"] < 1.0:
                parts.append(f"{name} shortened to {_fmt(given[f'{flipper}_y'])} of its length")
            else:
                parts += [f"{field} scaled by {_fmt(v)}" for field, v in given.items()]
        for servo, seized, gain in zip(_SERVOS, self.seized, self.gains):
            if seized:
                parts.append(f"{servo} servo seized")
            if gain == 0.0:
                parts.append(f"{servo} servo dead (gain 0)")
            elif gain < 0.0:
                parts.append(f"{servo} servo reversed (gain {_fmt(gain)})")
            elif gain < 1.0:
                parts.append(f"{servo} servo weak (gain {_fmt(gain)})")
        if not parts:
            return "No fault: the healthy robot."
        text = ", ".join(parts[:-1]) + " and " + parts[-1] if len(parts) > 1 else parts[0]
        return text[0].upper() + text[1:] + "."


def fault_from_file(path) -> Fault:
    """Read a JSON fault from ``path`` (a file name ending in ``.json``): a regular file of at most
    :data:`~aquafish_gym.files.MAX_INPUT_BYTES` (:func:`aquafish_gym.files.read_input`; a FIFO
    or a device is refused unread).

    Raises:
        ValueError: the file cannot be read, is no regular file or too large, or its content as
            :meth:`Fault.from_json`.
    """
    try:
        text = read_input(path).decode("utf-8")
    except InputFileError as err:
        raise _error(f"cannot read {err}") from None
    except UnicodeDecodeError:
        raise _error(f"cannot read {path}: it is not UTF-8 text; a fault is JSON") from None
    except OSError as err:
        raise _error(f"cannot read {path}: {err.strerror or err}") from None
    return Fault.from_json(text, str(path))


def parse_sampled_seed(text: str) -> int:
    """The SEED of ``sampled:SEED`` (an int >= 0).

    Raises:
        ValueError: SEED is not an int >= 0.
    """
    seed = (text[len(SAMPLED_PREFIX):] if text.startswith(SAMPLED_PREFIX) else text).strip()
    if not (seed.isascii() and seed.isdigit()):  # "²".isdigit() is True, and int() refuses it
        raise _error(f"sampled:SEED needs an int SEED >= 0, got {short_repr(text)} (SEED in the digits 0-9)")
    if len(seed.lstrip("0")) > MAX_SAMPLED_SEED_DIGITS:
        raise _error(f"sampled:SEED needs an int SEED >= 0 of at most {MAX_SAMPLED_SEED_DIGITS} digits, got one of "
                     f"{len(seed.lstrip('0'))} digits")
    return int(seed)


@dataclasses.dataclass(frozen=True)
class FaultDraw:
    """One fault of a sampled fault.

    Attributes:
        kind: ``reversed``, ``weak``, ``dead``, ``seized``, ``shortened`` or ``lost``.
        part: ``left_pectoral``, ``right_pectoral`` or ``caudal``.
        value: the weak servo's gain or the shortened flipper's length factor; None otherwise.
    """

    kind: str
    part: str
    value: float | None = None


#: The kinds of a sampled fault: ``(kind, part, weight in percent)``; a ``pectoral`` kind
#: goes on the left or the right pectoral with probability 1/2 each.
SAMPLED_KINDS: tuple[tuple[str, str, int], ...] = (
    ("reversed", "pectoral", 15),   # gain -1
    ("weak", "pectoral", 15),       # gain uniform in [0.2, 0.8], rounded to 0.01
    ("dead", "pectoral", 10),       # gain 0
    ("seized", "pectoral", 10),     # the flipper held at its initial angle
    ("shortened", "pectoral", 20),  # length (y) x uniform in [0.25, 0.75], rounded to 0.01
    ("lost", "pectoral", 15),       # x, y and z x 0
    ("weak", "caudal", 10),         # gain uniform in [0.2, 0.8], rounded to 0.01
    ("dead", "caudal", 5),          # gain 0
)
_SIDES = ("left_pectoral", "right_pectoral")


def _pick(u: float, kinds) -> tuple[str, str]:
    total = sum(w for _, _, w in kinds)
    edge = 0
    for kind, part, weight in kinds:
        edge += weight
        if u * total < edge:
            return kind, part
    return kinds[-1][:2]  # u * total rounds up to total: the last kind


def draw_faults(seed: int) -> tuple[FaultDraw, ...]:
    """The faults of ``sampled:SEED``, one or two, on different parts.

    The distribution (docs/simulator.md, "Damage"): ``u = numpy.random.default_rng(seed).random(7)``
    (PCG64: the same numbers on every machine), read in this order:

    * ``u[0] < 0.5``: one fault, else two (probability 1/2 each);
    * fault ``i`` (0, 1) reads ``u[1 + 3i]`` (kind), ``u[2 + 3i]`` (side), ``u[3 + 3i]``
      (magnitude). Its kind, with probability (percent): pectoral servo reversed (gain -1) 15,
      weak (gain uniform in [0.2, 0.8]) 15, dead (gain 0) 10, seized 10; pectoral flipper
      shortened (length x uniform in [0.25, 0.75]) 20 or lost (x, y, z x 0) 15; caudal servo
      weak (gain uniform in [0.2, 0.8]) 10 or dead (gain 0) 5 (:data:`SAMPLED_KINDS`).
      Actuator faults 65 %, morphological 35 %. A pectoral fault is on the left when the side
      number is < 0.5, else on the right; magnitudes are rounded to 0.01.
    * The second fault is on another part: after a pectoral fault, a pectoral kind goes on
      the other side (its side number is not used); after a caudal fault, the kind is drawn
      among the pectoral kinds (weights renormalised over their 85 %).

    Args:
        seed: an int >= 0.

    Returns:
        One or two :class:`FaultDraw`, in draw order.

    Raises:
        ValueError: ``seed`` is not an int >= 0.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise _error(f"sampled:SEED needs an int SEED >= 0, got {seed!r}")
    u = np.random.default_rng(int(seed)).random(7).tolist()
    draws: list[FaultDraw] = []
    for i in range(1 if u[0] < 0.5 else 2):
        u_kind, u_side, u_value = u[1 + 3 * i: 4 + 3 * i]
        kinds = SAMPLED_KINDS
        if draws and draws[0].part == "caudal":
            kinds = tuple(k for k in SAMPLED_KINDS if k[1] == "pectoral")
        kind, part = _pick(u_kind, kinds)
        if part == "pectoral":
            if draws:  # the first fault's side is taken
                part = _SIDES[1 - _SIDES.index(draws[0].part)] if draws[0].part in _SIDES else _SIDES[u_side >= 0.5]
            else:
                part = _SIDES[u_side >= 0.5]
        value = None
        if kind == "weak":
            value = round(0.2 + 0.6 * u_value, 2)
        elif kind == "shortened":
            value = round(0.25 + 0.5 * u_value, 2)
        draws.append(FaultDraw(kind, part, value))
    return tuple(draws)


def sampled_fault(seed: int) -> Fault:
    """The fault ``sampled:SEED`` names: :func:`draw_faults` (which documents the distribution)
    written as a :class:`Fault`.

    Raises:
        ValueError: ``seed`` is not an int >= 0.
    """
    scale: dict[str, float] = {}
    seized = [False, False, False]
    gains = [1.0, 1.0, 1.0]
    for d in draw_faults(seed):
        servo = ("left_pectoral", "right_pectoral", "caudal").index(d.part)
        if d.kind == "reversed":
            gains[servo] = -1.0
        elif d.kind in ("weak", "dead"):
            gains[servo] = d.value if d.kind == "weak" else 0.0
        elif d.kind == "seized":
            seized[servo] = True
        elif d.kind == "shortened":
            scale[f"{d.part}_y"] = d.value
        else:  # lost
            scale.update({f"{d.part}_{axis}": 0.0 for axis in "xyz"})
    return Fault(scale=tuple(scale.items()), seized=tuple(seized), gains=tuple(gains))
