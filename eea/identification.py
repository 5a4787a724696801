"""Did a self-model name the target's servo faults? The judgement of identification (not the
paper's): the faulty servo and the sign of its gain, beside OBJ_FIT (:mod:`eea.fitness`), the
other measure of a model against the truth.

A ``morphology+servos`` model and the truth are ``(12,)`` arrays: the 9 dimensions of
:data:`aquafish_gym.MORPHOLOGY_FIELDS`, then the servo gains of the left pectoral, right
pectoral and caudal servos (:meth:`eea.encoding.ModelSpace.truth`; a seized servo's gain is 0,
:func:`eea.encoding.servo_gains`). Three judgements of a model: every faulty servo named with
its sign and size (:func:`servo_faults_named`), or on the right part (:func:`fault_parts_named`),
and both pectoral signs alone (:func:`pectoral_signs_right`, the judgement of the
``reversed_left_pectoral`` studies). These are lenient: a healthy servo the model holds faulty
is no miss (:func:`healthy_servos_named_faulty` counts those apart).

The strict judgement (:func:`identification`) names the kind of every part: its servo
(:data:`SERVO_KINDS`, from the gain, :func:`servo_kind`) and its flipper (:data:`FLIPPER_KINDS`,
from the span and length against the design's, :func:`flipper_kind`), and counts a model right
only when every part's kinds are the truth's, so a false fault is a miss as well;
:func:`identification_confusion` counts the parts' classes of many judgements, truth against
model.
"""

from __future__ import annotations

import numpy as np

from aquafish_gym import MORPHOLOGY_FIELDS, Morphology

__all__ = ["FLIPPER_KINDS", "FLIPPER_LOST_BELOW", "FLIPPER_PRESENT_FROM", "GAIN_DEAD_BELOW", "GAIN_HEALTHY_FROM",
           "PART_CLASSES", "SERVO_KINDS", "SERVO_PARTS", "fault_parts_named", "faulty_servos", "flipper_kind",
           "healthy_servos_named_faulty", "identification", "identification_confusion", "part_kinds",
           "pectoral_signs_right", "servo_faults_named", "servo_kind"]

#: The servos in gain order, each named by its flipper's field prefix.
SERVO_PARTS = ("left_pectoral", "right_pectoral", "caudal")

_N_DIMS = len(MORPHOLOGY_FIELDS)


_DESIGN = Morphology.healthy().to_array()


def _split(model, truth) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The model's and the truth's gains ``(3,)`` and which flippers the truth still has ``(3,)``."""
    m, t = (np.asarray(a, dtype=np.float64) for a in (model, truth))
    if m.shape != (_N_DIMS + 3,) or t.shape != (_N_DIMS + 3,):
        raise ValueError(f"model and truth must be ({_N_DIMS + 3},) morphology+servos arrays (9 dimensions, "
                         f"3 gains); got shapes {m.shape} and {t.shape}")
    if not (np.isfinite(m).all() and np.isfinite(t).all()):
        raise ValueError("model and truth must be finite")
    dims = dict(zip(MORPHOLOGY_FIELDS, t[:_N_DIMS]))
    present = np.array([dims[f"{p}_x"] > 0 and dims[f"{p}_y"] > 0 for p in SERVO_PARTS])
    return m[_N_DIMS:], t[_N_DIMS:], present


def faulty_servos(truth) -> np.ndarray:
    """``(3,)`` bool: the truth's servos that are faulty (gain other than 1: reversed, weak, dead
    or seized) and whose flipper is there (a lost flipper's servo moves nothing, so no
    experiment shows its gain; it is not judged).

    Args:
        truth: ``(12,)`` the target's ``morphology+servos`` values.

    Raises:
        ValueError: not a finite ``(12,)`` array.
    """
    return _judged(truth, truth)[3]


def _judged(model, truth) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The gains ``(3,)`` of ``model`` and ``truth``, the servos named by their gain (below 1, on
    the truth's side of 0) and the judged ones (:func:`faulty_servos`), each ``(3,)`` bool."""
    m, t, present = _split(model, truth)
    return m, t, (m < 1.0) & (np.sign(m) == np.sign(t)), (t != 1.0) & present


def servo_faults_named(model, truth) -> bool | None:
    """Whether ``model`` names every faulty servo of ``truth`` with the sign of its gain.

    A judged servo (:func:`faulty_servos`) is named when the model's gain for it is below the
    design's 1 and on the truth's side of 0 (``np.sign`` equal): a reversed servo needs a
    negative gain, a weak one a gain in (0, 1), a dead or seized one a gain of exactly 0.

    Args:
        model: ``(12,)`` the self-model (9 dimensions, 3 gains).
        truth: ``(12,)`` the target's values, likewise.

    Returns:
        None when the truth has no judged faulty servo (a fault of the morphology only, or
        a servo fault on a lost flipper), else whether every judged one is named.

    Raises:
        ValueError: not finite ``(12,)`` arrays.
    """
    _, _, by_gain, judged = _judged(model, truth)
    return bool(np.all(by_gain[judged])) if judged.any() else None


def fault_parts_named(model, truth) -> bool | None:
    """Whether ``model`` puts every faulty servo's fault on the right part, by its gain or its
    flipper: a looser judgement than :func:`servo_faults_named`, since a weak servo and a
    shorter flipper, or a dead servo and a lost flipper, move the robot alike.

    A judged servo (:func:`faulty_servos`) is named when :func:`servo_faults_named` would name
    it, or when the truth's gain is in (0, 1) (weak) and the model's flipper on that servo is
    shorter or narrower than the design's (length ``_x`` or width ``_y`` below it), or when
    the truth's gain is 0 (dead or seized) and the model's flipper there has length or
    width 0. A reversed servo is named by a negative gain only.

    Args:
        model: ``(12,)`` the self-model (9 dimensions, 3 gains).
        truth: ``(12,)`` the target's values, likewise.

    Returns:
        None when the truth has no judged faulty servo, else whether every judged one is named.

    Raises:
        ValueError: not finite ``(12,)`` arrays.
    """
    _, t, by_gain, judged = _judged(model, truth)
    if not judged.any():
        return None
    dims = np.asarray(model, dtype=np.float64)[:_N_DIMS].reshape(3, 3)[:, :2]  # (servo, (x, y))
    design = _DESIGN.reshape(3, 3)[:, :2]
    by_flipper = np.where(t == 0.0, (dims == 0).any(axis=1), (t > 0) & (t < 1) & (dims < design).any(axis=1))
    return bool(np.all((by_gain | by_flipper)[judged]))


def healthy_servos_named_faulty(model, truth) -> int:
    """How many of the truth's healthy servos (gain 1, flipper there) the model holds at
    another gain (a false alarm of identification; reported beside :func:`servo_faults_named`).

    Args:
        model: ``(12,)`` the self-model.
        truth: ``(12,)`` the target's values.

    Raises:
        ValueError: not finite ``(12,)`` arrays.
    """
    m, t, present = _split(model, truth)
    return int(np.sum((t == 1.0) & present & (m != 1.0)))


def pectoral_signs_right(model, truth) -> bool | None:
    """Whether both pectoral gains of ``model`` are on the truth's side of 0 (``np.sign`` equal:
    a reversed servo needs a negative gain, a healthy or weak one a positive gain, a dead or
    seized one 0). A pectoral whose flipper the truth has lost is not judged: its servo moves
    nothing, so no experiment shows its gain.

    Args:
        model: ``(12,)`` the self-model (9 dimensions, 3 gains).
        truth: ``(12,)`` the target's values, likewise.

    Returns:
        None when the truth has lost both pectoral flippers, else the verdict.

    Raises:
        ValueError: not finite ``(12,)`` arrays.
    """
    m, t, present = _split(model, truth)
    judged = present[:2]
    return bool(np.all((np.sign(m[:2]) == np.sign(t[:2]))[judged])) if judged.any() else None


# -- the strict judgement: the kind of every part ------------------------------------------------

#: The kinds of a servo, from its gain (:func:`servo_kind`): healthy (1 or near it), weak (a
#: fraction), dead (0: dead or seized, :func:`eea.encoding.servo_gains`), reversed (negative).
SERVO_KINDS: tuple[str, ...] = ("healthy", "weak", "dead", "reversed")
#: The kinds of a flipper, from its span and length against the design's (:func:`flipper_kind`).
FLIPPER_KINDS: tuple[str, ...] = ("present", "shortened", "lost")
#: The 12 classes of a part, ``"servo kind/flipper kind"`` (``"weak/present"``), the servo's kind
#: varying slowest: the rows and columns of :func:`identification_confusion`.
PART_CLASSES: tuple[str, ...] = tuple(f"{s}/{f}" for s in SERVO_KINDS for f in FLIPPER_KINDS)

#: A gain with ``|gain| <`` this (gain units) is a dead servo's; a gain at or below its negative
#: a reversed one's. Halfway between a dead servo's 0 and the weakest weak gain the sampled
#: faults draw (0.2; :data:`aquafish_gym.faults.SAMPLED_KINDS`), so every sampled truth falls on
#: its own side. On the model's gain grid (:mod:`eea.encoding`) only the level 0 is dead, since
#: the levels next to it are +-0.125, and a hypothesis's half-reversed -0.5 is reversed.
GAIN_DEAD_BELOW = 0.1
#: A gain of at least this (gain units) is a healthy servo's; one in ``[GAIN_DEAD_BELOW, this)``
#: a weak one's. Halfway between the strongest weak gain the sampled faults draw (0.8) and the
#: healthy 1, so a weak truth modelled at its nearest grid level (0.75 for a pectoral, 0.8125
#: for the caudal) stays weak. A polished caudal gain of 0.9375 (the caudal level next to 1)
#: counts healthy; a pectoral gain of 0.875 (the pectoral level next to 1, one polish step of
#: :data:`eea.inference.selection.GAIN_POLISH_STEP`) counts weak.
GAIN_HEALTHY_FROM = 0.9
#: A flipper whose span (``_x``) or length (``_y``) is below this fraction of the design's is
#: lost. Halfway between a lost flipper's 0 and the shortest shortening the sampled faults draw
#: (length x 0.25), so a truth's lost flipper (span and length 0) and a model with the length
#: at the lowest grid level above 0 (1/16 of the design's) are lost, every sampled shortening not.
FLIPPER_LOST_BELOW = 0.125
#: A flipper whose span and length are both at least this fraction of the design's is present;
#: below it (and not lost) shortened. Halfway between the longest shortening the sampled faults
#: draw (length x 0.75) and the design's 1, so the hypotheses' halved length and the presets'
#: ``*_half`` are shortened; a flipper larger than the design's is present (no fault makes one).
FLIPPER_PRESENT_FROM = 0.875

_DESIGN_SPAN_LENGTH = _DESIGN.reshape(3, 3)[:, :2]  # (part, (span x, length y))


def _part_index(part: str) -> int:
    if part not in SERVO_PARTS:
        raise ValueError(f"part must be one of {', '.join(SERVO_PARTS)}, got {part!r}")
    return SERVO_PARTS.index(part)


def servo_kind(gain, part: str = "left_pectoral") -> str:
    """The kind of a servo from its gain: ``"reversed"`` (gain <= -:data:`GAIN_DEAD_BELOW`),
    ``"dead"`` (``|gain| <`` :data:`GAIN_DEAD_BELOW`: dead or seized), ``"weak"`` (below
    :data:`GAIN_HEALTHY_FROM`) or ``"healthy"``.

    Args:
        gain: the servo's gain (a float; gain units, 1 the design's).
        part: the servo's part in :data:`SERVO_PARTS`: a pectoral's gain is in [-1, 1], the
            caudal's in [0, 1] (it never turns the wrong way).

    Raises:
        ValueError: an unknown part, or a gain that is not a finite number in the part's range.
    """
    lo = 0.0 if _part_index(part) == 2 else -1.0
    try:
        g = float(gain)
    except (TypeError, ValueError):
        g = np.nan
    if not np.isfinite(g) or not lo <= g <= 1.0:
        raise ValueError(f"the {part} servo's gain must be a finite number in [{lo:g}, 1], got {gain!r}")
    if g <= -GAIN_DEAD_BELOW:
        return "reversed"
    if abs(g) < GAIN_DEAD_BELOW:
        return "dead"
    return "weak" if g < GAIN_HEALTHY_FROM else "healthy"


def flipper_kind(dims, part: str) -> str:
    """The kind of a flipper from its dimensions against the design's (:meth:`aquafish_gym.Morphology.healthy`):
    ``"lost"`` when its span or its length is below :data:`FLIPPER_LOST_BELOW` of the design's,
    else ``"shortened"`` when one of them is below :data:`FLIPPER_PRESENT_FROM` of it, else
    ``"present"``. The thickness (``_z``) is not read: no fault changes it alone (a lost flipper
    has span and length 0 as well).

    Args:
        dims: ``(3,)`` the flipper's span, length and thickness (``_x``, ``_y``, ``_z``;
            simulator units, each >= 0).
        part: the flipper's part in :data:`SERVO_PARTS`.

    Raises:
        ValueError: an unknown part, or ``dims`` not 3 finite numbers >= 0.
    """
    i = _part_index(part)
    d = np.asarray(dims, dtype=np.float64) if not isinstance(dims, str) else np.array([np.nan])
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.any(d < 0):
        raise ValueError(f"the {part} flipper's dims must be 3 finite numbers >= 0 (span x, length y, thickness z; "
                         f"simulator units), got {np.asarray(dims).tolist()!r}")
    fraction = float(np.min(d[:2] / _DESIGN_SPAN_LENGTH[i]))
    if fraction < FLIPPER_LOST_BELOW:
        return "lost"
    return "shortened" if fraction < FLIPPER_PRESENT_FROM else "present"


def _values(values, name: str) -> np.ndarray:
    """``values`` as a finite ``(12,)`` float array (ValueError naming ``name`` otherwise)."""
    v = np.asarray(values, dtype=np.float64)
    if v.shape != (_N_DIMS + 3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be a finite ({_N_DIMS + 3},) morphology+servos array (9 dimensions, 3 gains), "
                         f"got shape {v.shape}" + ("" if v.shape != (_N_DIMS + 3,) else " with a value not finite"))
    return v


def _side(values: np.ndarray, i: int, part: str) -> dict:
    """One part of a ``(12,)`` array: its servo's and flipper's kinds, its gain and its dims."""
    dims, gain = values[3 * i:3 * i + 3], float(values[_N_DIMS + i])
    return {"servo": servo_kind(gain, part), "flipper": flipper_kind(dims, part), "gain": gain,
            "dims": dims.tolist()}


def part_kinds(values) -> dict[str, dict[str, str]]:
    """The kinds of the three parts of a ``morphology+servos`` array.

    Args:
        values: ``(12,)`` the 9 dimensions of :data:`aquafish_gym.MORPHOLOGY_FIELDS` (simulator
            units), then the gains of the left pectoral, right pectoral and caudal servos.

    Returns:
        ``{part: {"servo": kind, "flipper": kind}}`` for each part of :data:`SERVO_PARTS`
        (:func:`servo_kind`, :func:`flipper_kind`).

    Raises:
        ValueError: not a finite ``(12,)`` array, a negative dimension, or a gain out of its
            servo's range (pectorals [-1, 1], caudal [0, 1]).
    """
    v = _values(values, "values")
    return {part: {k: _side(v, i, part)[k] for k in ("servo", "flipper")} for i, part in enumerate(SERVO_PARTS)}


def identification(model, truth) -> dict:
    """The strict judgement of a self-model against the truth, part by part.

    Each part (:data:`SERVO_PARTS`) of either array has a servo kind (:func:`servo_kind`) and a
    flipper kind (:func:`flipper_kind`). The model names a part when its flipper kind is the
    truth's and so is its servo kind, except that the servo of a flipper the truth has lost is
    not judged: it moves nothing, so no experiment shows its gain. The model identifies the
    truth strictly when it names every part: every faulty part named with its kind (and so a
    servo with the sign of its gain), and no healthy part held faulty. Unlike
    :func:`servo_faults_named`, a healthy servo held weak, or a flipper held shortened, is a
    miss, and a shorter flipper does not stand in for a weak servo. For the truths of the
    sampled faults and the presets and a model whose gains are on the gain grid
    (:mod:`eea.encoding`), ``strict`` implies that :func:`servo_faults_named` is not False.

    Args:
        model: ``(12,)`` the self-model: 9 dimensions (simulator units), then 3 gains (left
            pectoral, right pectoral, caudal).
        truth: ``(12,)`` the target's values, likewise (:meth:`eea.encoding.ModelSpace.truth`).

    Returns:
        A JSON-serialisable dict: ``strict`` (bool), ``gain_abs_error`` (3 floats: the absolute
        error of each gain, that of a lost flipper's servo too), ``morphology_abs_error``
        (float: the mean absolute error over the 9 dimensions, simulator units) and ``parts``:
        per part ``{"truth": side, "model": side, "servo_judged": bool, "named": bool}``, each
        side ``{"servo": kind, "flipper": kind, "gain": float, "dims": [x, y, z]}``.

    Raises:
        ValueError: not finite ``(12,)`` arrays, a negative dimension, or a gain out of its
            servo's range (pectorals [-1, 1], caudal [0, 1]).
    """
    m, t = _values(model, "model"), _values(truth, "truth")
    parts = {}
    for i, part in enumerate(SERVO_PARTS):
        sides = {"truth": _side(t, i, part), "model": _side(m, i, part)}
        judged = sides["truth"]["flipper"] != "lost"
        named = (sides["model"]["flipper"] == sides["truth"]["flipper"]
                 and (not judged or sides["model"]["servo"] == sides["truth"]["servo"]))
        parts[part] = {**sides, "servo_judged": judged, "named": named}
    return {"strict": all(p["named"] for p in parts.values()),
            "gain_abs_error": np.abs(m[_N_DIMS:] - t[_N_DIMS:]).tolist(),
            "morphology_abs_error": float(np.mean(np.abs(m[:_N_DIMS] - t[:_N_DIMS]))),
            "parts": parts}


def identification_confusion(identifications) -> dict[str, dict[str, int]]:
    """How often each class of part (:data:`PART_CLASSES`) of the truth was modelled as each class.

    Every part of every judgement is counted once, in the row of the truth's class and the
    column of the model's. Where the truth has lost the flipper, the servo is not judged
    (:func:`identification`), so the model's class takes the truth's servo kind: such a part
    counts on the diagonal exactly when the model holds the flipper lost. So the off-diagonal
    counts are the parts not named, the diagonal the parts named.

    Args:
        identifications: an iterable of :func:`identification` dicts (or their JSON read
            back); None entries (a cell without a self-model of servo gains) are skipped.

    Returns:
        ``{truth class: {model class: count}}``, every one of the 12 classes in both, in the
        order of :data:`PART_CLASSES` (JSON-serialisable).

    Raises:
        ValueError: an entry that is not an identification dict, or a kind outside
            :data:`SERVO_KINDS` and :data:`FLIPPER_KINDS`.
    """
    counts = {row: dict.fromkeys(PART_CLASSES, 0) for row in PART_CLASSES}
    for n, ident in enumerate(identifications):
        if ident is None:
            continue
        try:
            parts = [ident["parts"][part] for part in SERVO_PARTS]
            pairs = [(p["truth"]["servo"], p["truth"]["flipper"],
                      p["model"]["servo"] if p["servo_judged"] else p["truth"]["servo"], p["model"]["flipper"])
                     for p in parts]
        except (KeyError, TypeError):
            raise ValueError(f"identifications must be identification dicts (eea.identification.identification) "
                             f"or None; entry {n} is not: {ident!r:.80}") from None
        for ts, tf, ms, mf in pairs:
            row, col = f"{ts}/{tf}", f"{ms}/{mf}"
            if row not in counts or col not in counts:
                raise ValueError(f"entry {n}: a part's class must be one of {', '.join(PART_CLASSES)}, got "
                                 f"{row!r} modelled as {col!r}")
            counts[row][col] += 1
    return counts
