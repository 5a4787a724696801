"""Did a self-model name the target's servo faults? The judgement of identification (not the
paper's): the faulty servo and the sign of its gain, beside OBJ_FIT (:mod:`eea.fitness`), the
other measure of a model against the truth.

A ``morphology+servos`` model and the truth are ``(12,)`` arrays: the 9 dimensions of
:data:`aquafish_gym.MORPHOLOGY_FIELDS`, then the servo gains of the left pectoral, right
pectoral and caudal servos (:meth:`eea.encoding.ModelSpace.truth`; a seized servo's gain is 0,
:func:`eea.encoding.servo_gains`). Three judgements of a model: every faulty servo named with
its sign and size (:func:`servo_faults_named`), or on the right part (:func:`fault_parts_named`),
and both pectoral signs alone (:func:`pectoral_signs_right`, the judgement of the
``reversed_left_pectoral`` studies).
"""

from __future__ import annotations

import numpy as np

from aquafish_gym import MORPHOLOGY_FIELDS, Morphology

__all__ = ["SERVO_PARTS", "fault_parts_named", "faulty_servos", "healthy_servos_named_faulty", "pectoral_signs_right",
           "servo_faults_named"]

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
