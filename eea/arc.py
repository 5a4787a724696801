"""Arcs and intervals of initial flipper angles for In-Band inference (paper section 3.3).

In-Band inference takes the initial angles of the K best models for each flipper and
stores the *smallest inclusive* range that holds them; PERFORM() then samples initial
angles uniformly from that range (setFlippers()).

* Pectoral flippers turn continuously, so their angles live on a circle of period 2*pi
  and the smallest inclusive range is an *arc*, which may wrap through 0: angles 6.2 and
  0.1 rad give the arc starting at 6.2 of width about 0.183, not [0.1, 6.2].
  Use :func:`smallest_inclusive_arc`.
* The caudal fin oscillates within [-30, 30] degrees ([-pi/6, pi/6] rad) and never wraps:
  treat its angles as points on a line with :func:`smallest_inclusive_interval`, and pass
  ``period=None`` to :func:`sample_arc`, :func:`in_arc` and :func:`widen_arc`.

A range is always ``(start, width)``: the points ``start + t`` for ``0 <= t <= width``,
taken modulo ``period`` (or not at all when ``period`` is None). Angles are in radians by
default, but any unit works if ``period`` is given in it.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "angle_distance",
    "in_arc",
    "sample_arc",
    "smallest_inclusive_arc",
    "smallest_inclusive_interval",
    "widen_arc",
]

TWO_PI = 2.0 * np.pi


def _check_period(period) -> float | None:
    if period is None:
        return None
    try:
        valid = bool(np.isfinite(period) and period > 0)
    except TypeError:
        valid = False
    if not valid:
        raise ValueError(f"period must be a finite number > 0 or None, got {period!r}")
    return float(period)


def _wrap(x, period: float):
    """x modulo period in [0, period) (np.mod may round a tiny negative up to period)."""
    w = np.mod(x, period)
    return np.where(w >= period, 0.0, w)


def _check_angles(angles, name: str) -> np.ndarray:
    a = np.asarray(angles, dtype=np.float64)
    if a.ndim != 1 or a.size == 0:
        raise ValueError(f"{name} must have shape (K,) with K >= 1, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinity")
    return a


def _as_float(x, name: str) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {x!r}") from None


def _check_range(start, width, period: float | None) -> tuple[float, float]:
    start, width = _as_float(start, "start"), _as_float(width, "width")
    if not np.isfinite(start):
        raise ValueError(f"start must be finite, got {start!r}")
    upper = np.inf if period is None else period
    if not (0.0 <= width <= upper):  # also rejects NaN
        raise ValueError(f"width must be in [0, {upper}], got {width!r}")
    return start, width


def angle_distance(a, b, period: float | None = TWO_PI) -> np.ndarray:
    """Distance between angles: the shorter way round the circle, or ``|a - b|`` on a line.

    Used to score inference: the error of an inferred initial angle against the true one
    (inference error is measured beside OBJ_FIT).

    Args:
        a: angles of any shape (radians unless ``period`` says otherwise).
        b: angles of a shape broadcastable with ``a``'s, in the same unit.
        period: the circle's period (default 2 pi), or None for the caudal fin's line.

    Returns:
        Broadcast-shaped float64 distances in [0, period / 2] (in [0, inf) for None):
        6.2 and 0.1 rad are about 0.183 apart, not 6.1.

    Raises:
        ValueError: if ``period`` is not a finite number > 0 or None, or an angle is not finite.
    """
    period = _check_period(period)
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("angles contain NaN or infinity")
    if period is None:
        return np.abs(a - b)
    d = _wrap(a - b, period)
    return np.minimum(d, period - d)


def smallest_inclusive_arc(angles_rad, period: float = TWO_PI) -> tuple[float, float]:
    """Smallest arc of the circle [0, period) that contains every angle.

    The arc is the complement of the largest gap between circularly consecutive angles
    (the first such gap on ties).

    Args:
        angles_rad: ``(K,)`` angles, any real values (taken modulo ``period``), K >= 1.
        period: circumference of the circle, default 2*pi (radians).

    Returns:
        ``(start, width)``: start in [0, period) is one of the input angles (wrapped) and
        width in [0, period); the arc runs counter-clockwise from start. One angle (or K
        equal angles) gives width 0.

    Raises:
        ValueError: if ``angles_rad`` is not a non-empty 1-D finite array, or ``period``
            is not a finite number > 0.
    """
    period = _check_period(period)
    if period is None:
        raise ValueError("period must be a finite number > 0; use smallest_inclusive_interval")
    a = np.sort(_wrap(_check_angles(angles_rad, "angles_rad"), period))
    gaps = np.diff(a, append=a[0] + period)  # gap after each sorted angle
    k = int(np.argmax(gaps))
    start = a[(k + 1) % a.size]
    width = max(period - gaps[k], 0.0)
    return float(start), float(min(width, np.nextafter(period, 0.0)))


def smallest_inclusive_interval(values) -> tuple[float, float]:
    """Smallest interval of the real line containing every value (no wrap-around).

    For angles that cannot wrap, e.g. the caudal fin's initial angle in [-pi/6, pi/6].

    Args:
        values: ``(K,)`` finite values, K >= 1.

    Returns:
        ``(start, width)`` = ``(min(values), max(values) - min(values))``.

    Raises:
        ValueError: if ``values`` is not a non-empty 1-D finite array.
    """
    v = _check_angles(values, "values")
    return float(v.min()), float(v.max() - v.min())


def in_arc(angle, start: float, width: float, period: float | None = TWO_PI,
           atol: float = 1e-9):
    """Whether angles lie on the arc (or interval when ``period`` is None).

    Args:
        angle: scalar or array of angles (any real values when ``period`` is given).
        start: start of the arc.
        width: width in [0, period] (or >= 0 for an interval).
        period: circumference, default 2*pi; None for a linear interval.
        atol: tolerance at both ends, absorbs floating-point round-off.

    Returns:
        bool, or a bool array shaped like ``angle``.

    Raises:
        ValueError: if ``angle`` or ``start`` is not finite, ``width`` is out of range, or
            ``period`` is invalid.
    """
    period = _check_period(period)
    start, width = _check_range(start, width, period)
    x = np.asarray(angle, dtype=np.float64)
    if not np.all(np.isfinite(x)):
        raise ValueError("angle contains NaN or infinity")
    if period is None:
        return (x >= start - atol) & (x <= start + width + atol)
    offset = _wrap(x - start, period)  # counter-clockwise distance from start
    return (offset <= width + atol) | (offset >= period - atol)


def sample_arc(start: float, width: float, rng: np.random.Generator, size=None,
               period: float | None = TWO_PI):
    """Angles drawn uniformly on an arc (the paper's setFlippers()).

    Args:
        start: start of the arc (any finite value; taken modulo ``period``).
        width: width in [0, period] (or >= 0 for an interval when ``period`` is None).
        rng: the source of randomness.
        size: output shape as for ``Generator.uniform`` (None gives a float).
        period: circumference, default 2*pi; None samples the interval
            [start, start + width] without wrapping.

    Returns:
        float or array of shape ``size``: angles in [0, period) (or in the interval).

    Raises:
        ValueError: if ``start`` is not finite, ``width`` is out of range, ``rng`` is not
            a ``numpy.random.Generator``, or ``period`` is invalid.
    """
    period = _check_period(period)
    start, width = _check_range(start, width, period)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    x = start + rng.uniform(0.0, width, size=size)
    if period is not None:
        x = _wrap(x, period)
    return float(x) if size is None else x


def widen_arc(start: float, width: float, fraction: float = 0.2,
              period: float | None = TWO_PI) -> tuple[float, float]:
    """Extend an arc by ``fraction`` of its width past each end (paper section 4.3: 20%).

    Lets In-Band inference "walk" the inferred range toward good angles just outside it.

    Args:
        start: start of the arc.
        width: width in [0, period] (or >= 0 for an interval).
        fraction: extension on each side as a fraction of ``width``, >= 0.
        period: circumference, default 2*pi; None for a linear interval (the caller
            intersects the result with the mechanical range, e.g. the caudal fin's sweep).

    Returns:
        ``(start, width)`` of the widened range: ``start - fraction * width`` (wrapped
        into [0, period)) and ``width * (1 + 2 * fraction)``, at most ``period`` (a
        widened arc that would overlap itself is the whole circle).

    Raises:
        ValueError: if ``start`` is not finite, ``width`` or ``fraction`` is out of
            range, or ``period`` is invalid.
    """
    period = _check_period(period)
    start, width = _check_range(start, width, period)
    fraction = _as_float(fraction, "fraction")
    if not (np.isfinite(fraction) and fraction >= 0):
        raise ValueError(f"fraction must be a finite number >= 0, got {fraction!r}")
    new_start, new_width = start - fraction * width, width * (1.0 + 2.0 * fraction)
    if period is None:
        return float(new_start), float(new_width)
    return float(_wrap(new_start, period)), float(min(new_width, period))
