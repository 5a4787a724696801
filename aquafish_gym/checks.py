"""Argument checks shared by every package: one message for one kind of mistake."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["DuplicateKeyError", "MESSAGE_VALUE_CHARS", "check_int", "check_seconds", "check_weight", "check_yaw_deg",
           "json_loads_unique_keys", "short_json", "short_repr"]

#: The most characters of a value that a message quotes (:func:`short_repr`).
MESSAGE_VALUE_CHARS = 80


def short_json(value, limit: int = MESSAGE_VALUE_CHARS) -> str:
    """``value`` as JSON text for a message about a JSON file's field (``null``, ``true``,
    ``"abc"``, ``NaN``; what JSON cannot hold as its ``str``), at most ``limit`` characters: a
    longer text keeps its first ``limit - 3`` and ends in ``...``.

    Args:
        value: a value read from a JSON file.
        limit: the characters kept (>= 4).

    Returns:
        The text.
    """
    import json

    text = json.dumps(value, default=str)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def short_repr(value, limit: int = MESSAGE_VALUE_CHARS) -> str:
    """``repr(value)`` for a message, at most about ``limit`` characters: a longer one keeps its
    start and says how long it was (``[1, 1, 1, 1, ... (2000000 items)]``, ``'1111... (5000
    characters)'``), so that a huge value never fills a message.

    Args:
        value: anything; a ``str`` is quoted as ``repr`` quotes it.
        limit: the characters of ``repr`` kept.

    Returns:
        The text.
    """
    if isinstance(value, str) and len(value) > limit:
        return repr(value[:limit]) + f"... ({len(value)} characters)"
    sized = isinstance(value, (list, tuple, dict, set, frozenset))
    if sized and len(value) > limit:  # not repr'd whole
        head = list(value.items() if isinstance(value, dict) else value)[:limit]
        text = repr(dict(head) if isinstance(value, dict) else head)
    else:
        text = repr(value)
    if len(text) <= limit:
        return text
    return text[:limit] + "..." + (f" ({len(value)} item{'s' * (len(value) != 1)})" if sized else "")


def check_int(name: str, value, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` as an ``int`` if it is an integer (``bool`` excluded) within the bounds.

    Args:
        name: how the message names the argument (e.g. ``"steps"``, ``"EEAConfig.rounds"``).
        value: the argument; ``int`` and NumPy integers are accepted.
        minimum: inclusive lower bound (None: unbounded).
        maximum: inclusive upper bound (None: unbounded).

    Returns:
        ``int(value)``.

    Raises:
        ValueError: ``"<name> must be an int >= <minimum>, got <value!r>"`` (and ``<=
            <maximum>`` when bounded above) if ``value`` is not an integer or out of range.
    """
    ok = not isinstance(value, (bool, np.bool_)) and isinstance(value, (int, np.integer))
    ok = ok and (minimum is None or value >= minimum) and (maximum is None or value <= maximum)
    if not ok:
        bounds = " and ".join(b for b in (f">= {minimum}" if minimum is not None else "",
                                          f"<= {maximum}" if maximum is not None else "") if b)
        raise ValueError(f"{name} must be an int{' ' + bounds if bounds else ''}, got {value!r}")
    return int(value)


def check_seconds(name: str, value) -> float:
    """``value`` as a ``float`` if it is a finite number of seconds > 0 (``bool`` excluded;
    ``int``, ``float`` and NumPy floats are accepted).

    Raises:
        ValueError: ``"<name> must be a positive number of seconds, got <value!r>"`` otherwise.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) \
            or not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
    return float(value)


def check_weight(name: str, value) -> float:
    """``value`` as a ``float`` if it is a finite number >= 0 (``bool`` excluded; a reward,
    cost or penalty weight).

    Raises:
        ValueError: ``"<name> must be a number >= 0, got <value!r>"`` otherwise.
    """
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a number >= 0, got {value!r}")
    return float(value)


def check_yaw_deg(name: str, value, note: str = "") -> float:
    """``value`` as a ``float`` if it is a heading in degrees in [-180, 180] (``bool`` excluded;
    counter-clockwise from +y, as the env's ``initial_yaw_deg``).

    Args:
        name: how the message names the argument.
        value: the argument; ``int``, ``float`` and NumPy numbers are accepted.
        note: text the message puts after the range (e.g. what the heading is).

    Raises:
        ValueError: ``"<name> must be a number of degrees in [-180, 180]<note>, got <value!r>"``
            if ``value`` is not a number, not finite or out of range.
    """
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
    if not ok or not math.isfinite(float(value)) or abs(float(value)) > 180.0:
        raise ValueError(f"{name} must be a number of degrees in [-180, 180]{note}, got {value!r}")
    return float(value)


class DuplicateKeyError(ValueError):
    """A JSON object names one key twice (which :func:`json.loads` would silently resolve to the last)."""


def json_loads_unique_keys(text: str):
    """``json.loads(text)``, refusing an object that gives a key twice, JSON nested too deeply
    and an integer too long to convert (:func:`aquafish_gym.files.parse_json`).

    Raises:
        DuplicateKeyError: ``"key '<key>' given twice"``.
        aquafish_gym.files.InputFileError: nested more than
            :data:`~aquafish_gym.files.MAX_JSON_DEPTH` deep, or an integer too long (a
            ``ValueError`` whose message is the problem alone).
        json.JSONDecodeError: ``text`` is not valid JSON.
    """
    from aquafish_gym.files import parse_json

    def pairs(items):
        seen = set()
        for key, _ in items:
            if key in seen:
                raise DuplicateKeyError(f"key {key!r} given twice")
            seen.add(key)
        return dict(items)

    return parse_json(text, object_pairs_hook=pairs)
