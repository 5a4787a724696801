"""Binary genomes of the EEA: model (morphology) and action encodings (paper section 3.2).

Both genomes are bit strings made of consecutive unsigned-integer *fields*, each stored
most-significant bit first and decoded linearly onto its range, in one of two ways:

* closed: ``value = lo + (hi - lo) * int(bits) / (2**nbits - 1)``; all-zeros decodes to
  ``lo`` and all-ones to ``hi``.
* half-open: ``value = lo + (hi - lo) * int(bits) / 2**nbits``; all-zeros decodes to
  ``lo`` and all-ones to one step below ``hi``. The levels are the dyadic fractions of the
  range (0.25, 0.375, 0.875, ... of it).

The two genomes use them as follows:

* Model genome, 45 bits, half-open: 15 per flipper in the order left pectoral, right
  pectoral, caudal; per flipper x (5 bits), y (6 bits), z (4 bits). Pectoral ranges x in
  [0, 1), y in [0, 2), z in [0, 0.5); caudal x in [0, 0.5), y in [0, 2), z in [0, 1)
  (section 3.1, Figure 4). The decoded order and ranges are the simulator's own,
  ``aquafish_gym.MORPHOLOGY_FIELDS`` and ``MORPHOLOGY_BOUNDS``. Half-open because the robot's own dimensions are
  dyadic fractions of these ranges: the healthy robot and every damage preset are exact
  model genomes (OBJ_FIT = 1 reachable; docs/self_modeling.md, "Model grid").
* Action genome, 18 bits, closed: 6 per servo; left pectoral speed in [-0.5, 0.5] rev/s,
  right pectoral speed in [-0.5, 0.5] rev/s, caudal frequency in [0, 1] Hz (section 3.2;
  the ranges are ``aquafish_gym.ACTION_BOUNDS``), so full speed either way and 1 Hz are
  commands.

Model spaces (``EEAConfig.model_space``, :data:`MODEL_SPACES`): what a model genome holds.

* ``morphology`` (the paper's, the default): the 45-bit genome above, 9 flipper dimensions.
* ``morphology+servos`` (not the paper's): the same 45 bits followed by 12 bits of servo
  gains, 4 per servo in the order left pectoral, right pectoral, caudal
  (:data:`SERVO_GAIN_FIELDS`), 57 bits, 12 values. A gain multiplies the commanded speed
  (pectorals, in [-1, 1]: negative = turning the wrong way, 0 = seized or dead, a fraction =
  weak) or the commanded frequency (caudal, in [0, 1]); the model is simulated with
  ``ServoFaults(speed_scale=gains)``, so these are what the target's
  :class:`~aquafish_gym.ServoFaults` are modelled by (a seized servo is gain 0: it
  simulates bit for bit like ``seized``, see :func:`servo_gains`).

  Gain levels: the uniform grid of 1/16 of the gain's range, ``lo + (hi - lo) k / 16`` for
  k in {0, 2, 3, ..., 16}, the 16 values of a 4-bit field (code c is k = c for c = 0 and
  k = c + 1 otherwise). Pectorals: -1, -0.75, -0.625, ..., -0.125, 0, 0.125, ..., 0.875,
  1 (steps of 0.125; -0.875 left out); caudal: 0, 0.125, 0.1875, ..., 0.9375, 1 (steps of
  0.0625; 0.0625 left out), so every damage preset's gains (1, 0.5, 0, -1) and both ends of
  each range are exact levels (why this grid: docs/self_modeling.md, "Model space").
  Resolution: 1/16 of each range, twice that between the two lowest levels. Encoding a value
  rounds it to the nearest level (half-way between the two lowest: to the upper one).

Genomes may be given as bool, integer or float arrays whose entries are exactly 0 or 1;
encoders return ``uint8``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquafish_gym import ACTION_BOUNDS, MORPHOLOGY_BOUNDS, MORPHOLOGY_FIELDS, ServoFaults, get_damage

__all__ = [
    "ACTION_BITS",
    "ACTION_FIELD_BITS",
    "MODEL_BITS",
    "MODEL_FIELD_BITS",
    "MODEL_SPACES",
    "ModelSpace",
    "SERVO_GAIN_BITS",
    "SERVO_GAIN_BOUNDS",
    "SERVO_GAIN_FIELDS",
    "decode_actions",
    "decode_fields",
    "decode_gains",
    "decode_models",
    "encode_actions",
    "encode_fields",
    "encode_gains",
    "encode_models",
    "genome_keys",
    "genomes_from_keys",
    "get_model_space",
    "model_space_of",
    "servo_gains",
]

MODEL_FIELD_BITS: tuple[int, ...] = (5, 6, 4) * 3
MODEL_BITS: int = sum(MODEL_FIELD_BITS)  # 45

ACTION_FIELD_BITS: tuple[int, ...] = (6, 6, 6)
ACTION_BITS: int = sum(ACTION_FIELD_BITS)  # 18

# Values may lie outside [lo, hi] by this fraction of the range (floating-point round-off)
# and still be encoded onto the nearest end; anything further out raises.
_RANGE_TOLERANCE = 1e-9


def _check_layout(field_bits, bounds) -> tuple[np.ndarray, np.ndarray]:
    """Validate a field layout; return field widths (n_fields,) and bounds (n_fields, 2)."""
    widths = np.asarray(field_bits)
    if widths.ndim != 1 or widths.size == 0 or not np.issubdtype(widths.dtype, np.integer):
        raise ValueError(f"field_bits must be a non-empty sequence of ints, got {field_bits!r}")
    if np.any(widths < 1) or np.any(widths > 62):
        raise ValueError(f"field_bits entries must be in [1, 62], got {field_bits!r}")
    bounds = np.asarray(bounds, dtype=np.float64)
    if bounds.shape != (widths.size, 2):
        raise ValueError(
            f"bounds must have shape ({widths.size}, 2) to match field_bits, got {bounds.shape}"
        )
    if not np.all(np.isfinite(bounds)) or np.any(bounds[:, 1] <= bounds[:, 0]):
        raise ValueError("bounds rows must be finite [low, high] with low < high")
    return widths.astype(np.int64), bounds


def _as_2d(x: np.ndarray, width: int, name: str, what: str) -> tuple[np.ndarray, bool]:
    """Return x as (P, width) and whether the input was a single 1-D row."""
    if x.ndim not in (1, 2) or x.shape[-1] != width:
        raise ValueError(
            f"{name} must have shape ({width},) or (P, {width}) ({what}), got {x.shape}"
        )
    return x.reshape(-1, width), x.ndim == 1


def decode_fields(genomes, field_bits, bounds, *, half_open: bool = False) -> np.ndarray:
    """Decode bit-string genomes into real values field by field.

    Args:
        genomes: ``(P, n_bits)`` or ``(n_bits,)`` array of 0/1 (bool, int or float),
            ``n_bits = sum(field_bits)``; each field most-significant bit first.
        field_bits: ``(n_fields,)`` number of bits of each field, in genome order.
        bounds: ``(n_fields, 2)`` [low, high] of each field's decoded value.
        half_open: decode onto ``2**nbits`` levels of [low, high) instead of the closed
            [low, high] (see the module docstring).

    Returns:
        ``(P, n_fields)`` (or ``(n_fields,)`` for a 1-D genome) float64 values,
        ``low + (high - low) * int / (2**nbits - 1)``, or ``/ 2**nbits`` if ``half_open``.

    Raises:
        ValueError: if the layout is invalid, the genome width is not ``sum(field_bits)``,
            or an entry is not exactly 0 or 1 (NaN included).
    """
    widths, bounds = _check_layout(field_bits, bounds)
    n_bits = int(widths.sum())
    g = np.asarray(genomes)
    if not (np.issubdtype(g.dtype, np.number) or g.dtype == np.bool_):
        raise ValueError(f"genomes must be a numeric or bool array, got dtype {g.dtype}")
    g2, single = _as_2d(g, n_bits, "genomes", f"{len(widths)} fields of {widths.tolist()} bits")
    if g2.dtype != np.bool_ and not np.all((g2 == 0) | (g2 == 1)):
        bad = g2[~((g2 == 0) | (g2 == 1))].flat[0]
        raise ValueError(f"genomes must contain only 0 and 1, found {bad!r}")
    # Weight matrix (n_bits, n_fields): 2**k for bit k (from the right) of its own field.
    field_of_bit = np.repeat(np.arange(widths.size), widths)
    ends = np.cumsum(widths)
    shift_of_bit = ends[field_of_bit] - 1 - np.arange(n_bits)
    weights = np.zeros((n_bits, widths.size), dtype=np.int64)
    weights[np.arange(n_bits), field_of_bit] = np.left_shift(1, shift_of_bit)
    ints = g2.astype(np.int64) @ weights
    divisor = np.left_shift(1, widths) - (0 if half_open else 1)
    frac = ints / divisor.astype(np.float64)
    values = bounds[:, 0] + (bounds[:, 1] - bounds[:, 0]) * frac
    return values[0] if single else values


def _fractions(values, bounds: np.ndarray, name: str, what: str) -> tuple[np.ndarray, bool]:
    """``(P, n)`` the finite ``values``' fractions of their ``(n, 2)`` ranges, and whether one row
    was given; raises ValueError (naming ``name``) for a wrong width, NaN, infinity or a value
    outside its range by more than ``_RANGE_TOLERANCE`` of it."""
    v2, single = _as_2d(np.asarray(values, dtype=np.float64), len(bounds), name, what)
    if not np.all(np.isfinite(v2)):
        raise ValueError(f"{name} must be finite (found NaN or infinity)")
    lo, hi = bounds[:, 0], bounds[:, 1]
    frac = (v2 - lo) / (hi - lo)
    outside = (frac < -_RANGE_TOLERANCE) | (frac > 1 + _RANGE_TOLERANCE)
    if np.any(outside):
        row, col = np.argwhere(outside)[0]
        raise ValueError(f"{name}[{row}, {col}] = {v2[row, col]!r} is outside its range [{lo[col]}, {hi[col]}]")
    return frac, single


def encode_fields(values, field_bits, bounds, *, half_open: bool = False) -> np.ndarray:
    """Encode real values onto the nearest grid point of each field (inverse of decode).

    Args:
        values: ``(P, n_fields)`` or ``(n_fields,)`` values inside ``bounds``.
        field_bits: ``(n_fields,)`` number of bits of each field, in genome order.
        bounds: ``(n_fields, 2)`` [low, high] of each field.
        half_open: the grid of ``decode_fields(..., half_open=True)``; values nearer
            ``high`` than the top level encode onto the top level.

    Returns:
        ``(P, n_bits)`` (or ``(n_bits,)``) uint8 genomes, most-significant bit first.
        Exact halfway values round to the even integer (``numpy.rint``).

    Raises:
        ValueError: if the layout is invalid, the width is not ``n_fields``, a value is
            NaN or infinite, or a value lies outside [low, high] (by more than 1e-9 of the
            range, which absorbs floating-point round-off).
    """
    widths, bounds = _check_layout(field_bits, bounds)
    frac, single = _fractions(values, bounds, "values", "one value per field")
    levels = np.left_shift(1, widths) - 1
    divisor = levels + 1 if half_open else levels
    ints = np.clip(np.rint(frac * divisor), 0, levels).astype(np.int64)
    field_of_bit = np.repeat(np.arange(widths.size), widths)
    shift_of_bit = np.cumsum(widths)[field_of_bit] - 1 - np.arange(field_of_bit.size)
    bits = (np.right_shift(ints[:, field_of_bit], shift_of_bit) & 1).astype(np.uint8)
    return bits[0] if single else bits


def decode_models(genomes) -> np.ndarray:
    """Decode model genomes (paper section 3.2, Figure 4) into flipper dimensions.

    Args:
        genomes: ``(P, 45)`` or ``(45,)`` array of 0/1 (uint8, bool, ...).

    Returns:
        ``(P, 9)`` or ``(9,)`` float64 dimensions in simulator units, order
        ``aquafish_gym.MORPHOLOGY_FIELDS``, on the
        half-open grid ``lo + (hi - lo) * k / 2**nbits``.

    Raises:
        ValueError: if the width is not 45 or an entry is not 0 or 1.
    """
    return decode_fields(genomes, MODEL_FIELD_BITS, MORPHOLOGY_BOUNDS, half_open=True)


def encode_models(dims) -> np.ndarray:
    """Encode flipper dimensions onto the nearest model genome (inverse of ``decode_models``).

    Args:
        dims: ``(P, 9)`` or ``(9,)`` dimensions in simulator units, order
            ``aquafish_gym.MORPHOLOGY_FIELDS``, each inside its ``MORPHOLOGY_BOUNDS`` row.

    Returns:
        ``(P, 45)`` or ``(45,)`` uint8 genomes.

    Raises:
        ValueError: if the width is not 9, a value is NaN or outside its range.
    """
    return encode_fields(dims, MODEL_FIELD_BITS, MORPHOLOGY_BOUNDS, half_open=True)


def decode_actions(genomes) -> np.ndarray:
    """Decode action genomes (paper section 3.2) into servo commands.

    Args:
        genomes: ``(P, 18)`` or ``(18,)`` array of 0/1.

    Returns:
        ``(P, 3)`` or ``(3,)`` float64 commands: left and right pectoral speed (rev/s, in
        [-0.5, 0.5]) and caudal frequency (Hz, in [0, 1]).

    Raises:
        ValueError: if the width is not 18 or an entry is not 0 or 1.
    """
    return decode_fields(genomes, ACTION_FIELD_BITS, ACTION_BOUNDS)


def encode_actions(actions) -> np.ndarray:
    """Encode servo commands onto the nearest action genome (inverse of ``decode_actions``).

    Args:
        actions: ``(P, 3)`` or ``(3,)`` commands (rev/s, rev/s, Hz) inside ``ACTION_BOUNDS``.

    Returns:
        ``(P, 18)`` or ``(18,)`` uint8 genomes.

    Raises:
        ValueError: if the width is not 3, a value is NaN or outside its range.
    """
    return encode_fields(actions, ACTION_FIELD_BITS, ACTION_BOUNDS)


def genome_keys(genomes) -> list[bytes]:
    """One hashable key per genome row (its bytes), for caches and memories keyed by model.

    Args:
        genomes: ``(P, n_bits)`` genomes of 0/1 values.

    Returns:
        P ``bytes`` objects of ``n_bits`` bytes each; :func:`genomes_from_keys` inverts it.
    """
    return [row.tobytes() for row in np.asarray(genomes, dtype=np.uint8)]


def genomes_from_keys(keys, n_bits: int) -> np.ndarray:
    """The ``(N, n_bits)`` uint8 genomes of :func:`genome_keys` keys (read-only view).

    Raises:
        ValueError: if a key is not ``n_bits`` bytes long.
    """
    keys = list(keys)
    if any(len(k) != n_bits for k in keys):
        raise ValueError(f"every genome key must be {n_bits} bytes long")
    return np.frombuffer(b"".join(keys), dtype=np.uint8).reshape(len(keys), n_bits)


# -- servo gains and model spaces -------------------------------------------------------------

#: The servo gains of the ``morphology+servos`` model space, in genome order.
SERVO_GAIN_FIELDS: tuple[str, ...] = ("left_pectoral_gain", "right_pectoral_gain", "caudal_gain")
#: Their ranges: ``ServoFaults.speed_scale``'s (pectorals [-1, 1], caudal [0, 1]).
SERVO_GAIN_BOUNDS: np.ndarray = np.array([[-1.0, 1.0], [-1.0, 1.0], [0.0, 1.0]])
SERVO_GAIN_BOUNDS.setflags(write=False)
#: Bits per gain: 16 levels each (the module docstring).
SERVO_GAIN_BITS: tuple[int, ...] = (4, 4, 4)
_GAIN_STEPS = 16  # the grid lo + (hi - lo) k / 16, k in {0, 2, 3, ..., 16}


def _bits_to_ints(genomes, widths) -> tuple[np.ndarray, bool]:
    """``(P, n_fields)`` int64 field values of 0/1 genomes (most-significant bit first)."""
    widths = np.asarray(widths, dtype=np.int64)
    g = np.asarray(genomes)
    if not (np.issubdtype(g.dtype, np.number) or g.dtype == np.bool_):
        raise ValueError(f"genomes must be a numeric or bool array, got dtype {g.dtype}")
    g2, single = _as_2d(g, int(widths.sum()), "genomes", f"{len(widths)} fields of {widths.tolist()} bits")
    if g2.dtype != np.bool_ and not np.all((g2 == 0) | (g2 == 1)):
        bad = g2[~((g2 == 0) | (g2 == 1))].flat[0]
        raise ValueError(f"genomes must contain only 0 and 1, found {bad!r}")
    field_of_bit = np.repeat(np.arange(widths.size), widths)
    shift_of_bit = np.cumsum(widths)[field_of_bit] - 1 - np.arange(field_of_bit.size)
    weights = np.zeros((field_of_bit.size, widths.size), dtype=np.int64)
    weights[np.arange(field_of_bit.size), field_of_bit] = np.left_shift(1, shift_of_bit)
    return g2.astype(np.int64) @ weights, single


def _ints_to_bits(ints: np.ndarray, widths) -> np.ndarray:
    """``(P, sum(widths))`` uint8 genomes of ``(P, n_fields)`` field values."""
    widths = np.asarray(widths, dtype=np.int64)
    field_of_bit = np.repeat(np.arange(widths.size), widths)
    shift_of_bit = np.cumsum(widths)[field_of_bit] - 1 - np.arange(field_of_bit.size)
    return (np.right_shift(np.asarray(ints, dtype=np.int64)[:, field_of_bit], shift_of_bit) & 1).astype(np.uint8)


def decode_gains(genomes) -> np.ndarray:
    """Decode servo-gain genomes (the 12 bits a ``morphology+servos`` model genome appends).

    Args:
        genomes: ``(P, 12)`` or ``(12,)`` array of 0/1.

    Returns:
        ``(P, 3)`` or ``(3,)`` float64 gains (left pectoral, right pectoral in [-1, 1];
        caudal in [0, 1]) on the grid of the module docstring: field value c is level
        ``lo + (hi - lo) * k / 16`` with ``k = c + (c > 0)``.

    Raises:
        ValueError: if the width is not 12 or an entry is not 0 or 1.
    """
    codes, single = _bits_to_ints(genomes, SERVO_GAIN_BITS)
    k = codes + (codes > 0)
    lo, hi = SERVO_GAIN_BOUNDS[:, 0], SERVO_GAIN_BOUNDS[:, 1]
    gains = lo + (hi - lo) * (k / _GAIN_STEPS)
    return gains[0] if single else gains


def encode_gains(gains) -> np.ndarray:
    """Encode servo gains onto the nearest gain genome (inverse of :func:`decode_gains`).

    Args:
        gains: ``(P, 3)`` or ``(3,)`` gains inside :data:`SERVO_GAIN_BOUNDS` (by 1e-9 of the
            range at most).

    Returns:
        ``(P, 12)`` or ``(12,)`` uint8 genomes; a value between the two lowest levels goes to
        the nearer one (half-way: the upper one).

    Raises:
        ValueError: if the width is not 3, or a value is NaN, infinite or outside its range.
    """
    frac, single = _fractions(gains, SERVO_GAIN_BOUNDS, "gains", "left pectoral, right pectoral, caudal")
    scaled = frac * _GAIN_STEPS
    k = np.clip(np.rint(scaled), 0, _GAIN_STEPS).astype(np.int64)
    k = np.where(k == 1, np.where(scaled < 1.0, 0, 2), k)  # level 1 is left out: the nearer of 0 and 2
    bits = _ints_to_bits(k - (k > 0), SERVO_GAIN_BITS)
    return bits[0] if single else bits


def servo_gains(faults: ServoFaults) -> np.ndarray:
    """The gains that model servo faults: ``speed_scale``, 0 where a servo is seized.

    A seized servo and a gain of 0 are the same servo in the simulator, bit for bit:
    a seized pectoral is commanded velocity 0, as a gain of 0 commands, so its motor
    holds the flipper where it is (its initial angle), and a seized caudal fin holds its
    current (initial) angle, as a caudal frequency of 0 does (``BatchWorld.set_actions``;
    ``tests/eea/test_model_space.py`` checks both, in deep water and at the surface).

    Returns:
        ``(3,)`` float64, left pectoral, right pectoral, caudal.
    """
    return np.where(np.asarray(faults.seized, dtype=bool), 0.0, np.asarray(faults.speed_scale, dtype=np.float64))


@dataclasses.dataclass(frozen=True)
class ModelSpace:
    """What a model genome holds: the flipper dimensions, and with ``servos`` the servo gains.

    Get one with :func:`get_model_space` (by name) or :func:`model_space_of` (by genome width).

    Attributes:
        name: ``"morphology"`` or ``"morphology+servos"`` (:data:`MODEL_SPACES`).
        servos: whether the genome appends the 12 gain bits.
    """

    name: str
    servos: bool

    @property
    def n_bits(self) -> int:
        """Genome length: 45, or 57 with the servo gains."""
        return MODEL_BITS + (sum(SERVO_GAIN_BITS) if self.servos else 0)

    @property
    def field_bits(self) -> tuple[int, ...]:
        """Bits of every field, in genome order."""
        return MODEL_FIELD_BITS + (SERVO_GAIN_BITS if self.servos else ())

    @property
    def fields(self) -> tuple[str, ...]:
        """Names of the decoded values: ``MORPHOLOGY_FIELDS``, then :data:`SERVO_GAIN_FIELDS`."""
        return MORPHOLOGY_FIELDS + (SERVO_GAIN_FIELDS if self.servos else ())

    @property
    def bounds(self) -> np.ndarray:
        """``(n, 2)`` [min, max] of every decoded value: OBJ_FIT's normalisation (eq. 4)."""
        return np.vstack([MORPHOLOGY_BOUNDS, SERVO_GAIN_BOUNDS]) if self.servos else MORPHOLOGY_BOUNDS

    def decode(self, genomes) -> np.ndarray:
        """``(P, n)`` (or ``(n,)``) values of ``(P, n_bits)`` model genomes: the 9 dimensions
        (:func:`decode_models`), then the 3 gains (:func:`decode_gains`)
        with ``servos``.

        Raises:
            ValueError: a genome of another width, or an entry that is not 0 or 1.
        """
        if not self.servos:
            return decode_models(genomes)
        g = np.asarray(genomes)
        if g.ndim not in (1, 2) or g.shape[-1] != self.n_bits:
            raise ValueError(f"{self.name} genomes must have shape ({self.n_bits},) or (P, {self.n_bits}), "
                             f"got {g.shape}")
        return np.concatenate([decode_models(g[..., :MODEL_BITS]), decode_gains(g[..., MODEL_BITS:])], axis=-1)

    def encode(self, values) -> np.ndarray:
        """The nearest model genomes ``(P, n_bits)`` (or ``(n_bits,)``) of ``(P, n)`` values.

        Raises:
            ValueError: values of another width, or a value outside its range or not finite.
        """
        if not self.servos:
            return encode_models(values)
        v = np.asarray(values, dtype=np.float64)
        n = len(self.fields)
        if v.ndim not in (1, 2) or v.shape[-1] != n:
            raise ValueError(f"{self.name} values must have shape ({n},) or (P, {n}), got {v.shape}")
        return np.concatenate([encode_models(v[..., :9]), encode_gains(v[..., 9:])], axis=-1)

    def morphologies(self, values) -> np.ndarray:
        """``(..., 9)`` the flipper dimensions of decoded values."""
        return np.asarray(values)[..., :9]

    def faults(self, values) -> list[ServoFaults] | None:
        """The servo faults that simulate ``(P, n)`` decoded models: one
        ``ServoFaults(speed_scale=gains)`` per model with ``servos``, else None (healthy servos)."""
        if not self.servos:
            return None
        return [ServoFaults(speed_scale=tuple(row)) for row in np.atleast_2d(values)[:, 9:].tolist()]

    def truth(self, damage: str) -> np.ndarray:
        """``(n,)`` the values of the damaged robot (the oracle of OBJ_FIT, eq. 4): the damaged
        morphology, then with ``servos`` the gains of its faults (:func:`servo_gains`).

        Raises:
            ValueError: on an unknown damage name.
        """
        preset = get_damage(damage)
        dims = preset.apply().to_array()
        return np.concatenate([dims, servo_gains(preset.faults)]) if self.servos else dims


#: The model spaces by name (``EEAConfig.model_space``); ``morphology`` is the paper's.
MODEL_SPACES: dict[str, ModelSpace] = {s.name: s for s in (ModelSpace("morphology", False),
                                                           ModelSpace("morphology+servos", True))}


def get_model_space(space) -> ModelSpace:
    """The :class:`ModelSpace` called ``space`` (a ModelSpace is returned as it is).

    Raises:
        ValueError: on an unknown name (the message lists the valid names).
    """
    if isinstance(space, ModelSpace):
        return space
    try:
        return MODEL_SPACES[space]
    except (KeyError, TypeError):
        raise ValueError(f"unknown model space {space!r}; valid names: {', '.join(MODEL_SPACES)}") from None


def model_space_of(n_bits: int) -> ModelSpace:
    """The first model space whose genomes are ``n_bits`` long (45: morphology, 57:
    morphology+servos).

    Raises:
        ValueError: if no space has genomes of that length.
    """
    for space in MODEL_SPACES.values():
        if space.n_bits == n_bits:
            return space
    raise ValueError(f"no model space has {n_bits}-bit genomes; "
                     f"{', '.join(f'{s.name}: {s.n_bits}' for s in MODEL_SPACES.values())}")
