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
  model genomes, so the true morphology reproduces the target (sim = 1, eq. 2) and the
  ideal baseline can reach OBJ_FIT = 1 (paper Figure 5). On a closed grid none of the
  healthy dimensions is a level: the nearest grid robot reached only sim ~ 0.994 and
  models far from the truth fitted the target better than it did.
* Action genome, 18 bits, closed: 6 per servo; left pectoral speed in [-0.5, 0.5] rev/s,
  right pectoral speed in [-0.5, 0.5] rev/s, caudal frequency in [0, 1] Hz (section 3.2;
  the ranges are ``aquafish_gym.ACTION_BOUNDS``), so full speed either way and 1 Hz are
  commands.

Genomes may be given as bool, integer or float arrays whose entries are exactly 0 or 1;
encoders return ``uint8``.
"""

from __future__ import annotations

import numpy as np

from aquafish_gym import ACTION_BOUNDS, MORPHOLOGY_BOUNDS

__all__ = [
    "ACTION_BITS",
    "ACTION_FIELD_BITS",
    "MODEL_BITS",
    "MODEL_FIELD_BITS",
    "decode_actions",
    "decode_fields",
    "decode_models",
    "encode_actions",
    "encode_fields",
    "encode_models",
    "genome_keys",
    "genomes_from_keys",
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
    v = np.asarray(values, dtype=np.float64)
    v2, single = _as_2d(v, widths.size, "values", "one value per field")
    if not np.all(np.isfinite(v2)):
        raise ValueError("values must be finite (found NaN or infinity)")
    lo, hi = bounds[:, 0], bounds[:, 1]
    frac = (v2 - lo) / (hi - lo)
    outside = (frac < -_RANGE_TOLERANCE) | (frac > 1 + _RANGE_TOLERANCE)
    if np.any(outside):
        row, col = np.argwhere(outside)[0]
        raise ValueError(
            f"values[{row}, {col}] = {v2[row, col]!r} is outside its range "
            f"[{lo[col]}, {hi[col]}]"
        )
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
