"""Experiments on the target and their context (paper sections 3.2 and 3.3).

An *experiment* is an action performed on the target robot, the target's recorded response
(IMU log and its behaviour summary) and a *context*: per flipper, the range of initial
angles the models should start from, and a confidence that the true angle lies in it. The
true initial angles are kept in the experiment for the record (inference error, the
``known`` oracle) but models see only the context.

Angles are in radians, flipper order (left pectoral, right pectoral, caudal). Pectoral
angles live on the circle [0, 2 pi) (0 = arms back) and their ranges are arcs that may wrap
through 0; the caudal angle lies in its sweep [-30 deg, 30 deg] and its range is a plain
interval (:mod:`eea.arc`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquafish_gym import SimParams
from aquafish_gym.simulator import AT_REST, validate_start_motion
from eea.arc import TWO_PI, angle_distance, sample_arc

__all__ = [
    "ANGLE_RESOLUTION_RAD", "CAUDAL_LIMIT_RAD", "FLIPPERS", "PERIODS", "Context", "Experiment", "angle_errors_deg",
    "check_params",
    "quantise_angles", "random_angles", "with_newest_context",
]

#: Half sweep of the caudal fin (rad): initial caudal angles lie in [-limit, limit]. The
#: simulator's default sweep (``SimParams.caudal_amplitude_deg``); :func:`check_params`
#: refuses simulator parameters with another one.
CAUDAL_LIMIT_RAD: float = SimParams().caudal_amplitude_rad
#: Short names of the three flippers in angle order (left pectoral, right pectoral, caudal
#: fin), as in the ``true_<flipper>_rad`` columns of ``rounds.csv``.
FLIPPERS: tuple[str, ...] = ("left", "right", "caudal")
#: Period of each flipper's angle (rad); None = not circular (the caudal fin).
PERIODS: tuple[float | None, ...] = (TWO_PI, TWO_PI, None)
#: Grid of simulated initial angles (rad). Angles are snapped to it before every simulation,
#: so a cached result and a fresh simulation of the same key are bit-for-bit equal.
ANGLE_RESOLUTION_RAD: float = 1e-6
_PECTORAL_LEVELS = round(TWO_PI / ANGLE_RESOLUTION_RAD)


def check_params(params: SimParams | None) -> SimParams:
    """The simulator parameters of a run's target and models (``None``: the defaults).

    Raises:
        ValueError: if ``params`` is not a :class:`~aquafish_gym.SimParams`, or its caudal
            sweep differs from :data:`CAUDAL_LIMIT_RAD`, on which the EEA's initial-angle
            space (contexts, random angles, the out-of-band genome) is built.
    """
    params = SimParams() if params is None else params
    if not isinstance(params, SimParams):
        raise ValueError(f"params must be an aquafish_gym.SimParams, got {type(params).__name__}")
    if params.caudal_amplitude_rad != CAUDAL_LIMIT_RAD:
        raise ValueError(f"the EEA's initial-angle space assumes a caudal sweep of +-{np.degrees(CAUDAL_LIMIT_RAD):g} deg, "
                         f"got SimParams.caudal_amplitude_deg = {params.caudal_amplitude_deg!r}")
    return params


def quantise_angles(angles_rad) -> tuple[np.ndarray, np.ndarray]:
    """Snap initial angles to the :data:`ANGLE_RESOLUTION_RAD` grid.

    Args:
        angles_rad: ``(n, 3)`` radians (left, right pectoral: any finite value; caudal
            within the sweep, up to round-off).

    Returns:
        ``(levels, angles)``: ``(n, 3)`` int64 grid indices (pectorals wrapped into
        [0, 2 pi)) usable as cache keys, and the ``(n, 3)`` float64 angles they stand for
        (pectorals in [0, 2 pi), caudal clipped to the sweep).

    Raises:
        ValueError: if the shape is not ``(n, 3)`` or an angle is not finite.
    """
    a = np.asarray(angles_rad, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"angles_rad must have shape (n, 3), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("angles_rad contains NaN or infinity")
    levels = np.rint(a / ANGLE_RESOLUTION_RAD).astype(np.int64)
    levels[:, :2] = np.mod(levels[:, :2], _PECTORAL_LEVELS)
    values = levels * ANGLE_RESOLUTION_RAD
    values[:, 2] = np.clip(values[:, 2], -CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD)
    return levels, values


def angle_errors_deg(angles, true_angles) -> np.ndarray:
    """Per-flipper inference error of initial angles against the true ones.

    Args:
        angles: ``(n, 3)`` initial angles (rad; left, right pectoral, caudal).
        true_angles: ``(n, 3)`` the true ones, likewise.

    Returns:
        ``(n, 3)`` degrees: the short way round the circle for the pectorals (at most 180),
        on the line for the caudal fin (:data:`PERIODS`).

    Raises:
        ValueError: if an angle is not finite (:func:`eea.arc.angle_distance`).
    """
    angles, true_angles = np.asarray(angles, dtype=np.float64), np.asarray(true_angles, dtype=np.float64)
    return np.degrees(np.stack([angle_distance(angles[:, i], true_angles[:, i], period)
                                for i, period in enumerate(PERIODS)], axis=1))


def random_angles(rng: np.random.Generator, n: int) -> np.ndarray:
    """Uniformly random initial angles: the target's, and PERFORM()'s randomizeFlipperPositions().

    Args:
        rng: the source of randomness.
        n: number of angle sets.

    Returns:
        ``(n, 3)`` float64 radians: pectorals uniform in [0, 2 pi), caudal uniform in
        [-CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD].
    """
    pectoral = rng.uniform(0.0, TWO_PI, size=(n, 2))
    caudal = rng.uniform(-CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD, size=(n, 1))
    return np.concatenate([pectoral, caudal], axis=1)


@dataclasses.dataclass(frozen=True)
class Context:
    """Inferred initial-angle ranges of one experiment and the confidence in them (paper 3.3).

    Range i is ``(starts[i], widths[i])``: the arc from ``starts[i]`` counter-clockwise over
    ``widths[i]`` rad for the pectorals (may wrap through 0), the interval
    ``[starts[i], starts[i] + widths[i]]`` for the caudal fin.

    Attributes:
        starts: ``(3,)`` range starts (rad); pectorals in [0, 2 pi).
        widths: ``(3,)`` range widths (rad); pectorals in [0, 2 pi], caudal so that the
            interval lies within the caudal sweep.
        confidence: probability in [0, 1] that PERFORM() samples from the ranges rather
            than random angles.

    Raises:
        ValueError: on wrong lengths, NaN, a width out of range, a caudal interval outside
            the sweep, or a confidence outside [0, 1].
    """

    starts: tuple[float, float, float]
    widths: tuple[float, float, float]
    confidence: float

    def __post_init__(self) -> None:
        starts = np.asarray(self.starts, dtype=np.float64)
        widths = np.asarray(self.widths, dtype=np.float64)
        if starts.shape != (3,) or widths.shape != (3,):
            raise ValueError(f"Context starts and widths need 3 entries (left, right, caudal), got {self.starts!r}, {self.widths!r}")
        if not (np.all(np.isfinite(starts)) and np.all(np.isfinite(widths))):
            raise ValueError("Context starts and widths must be finite (rad)")
        starts[:2] = np.mod(starts[:2], TWO_PI)
        starts[:2][starts[:2] >= TWO_PI] = 0.0
        if np.any(widths < 0) or np.any(widths[:2] > TWO_PI):
            raise ValueError(f"Context widths must be in [0, 2 pi] (rad), got {widths.tolist()}")
        tol = 1e-9
        if starts[2] < -CAUDAL_LIMIT_RAD - tol or starts[2] + widths[2] > CAUDAL_LIMIT_RAD + tol:
            raise ValueError(f"Context caudal interval [{starts[2]}, {starts[2] + widths[2]}] must lie within "
                             f"[-{CAUDAL_LIMIT_RAD:.6f}, {CAUDAL_LIMIT_RAD:.6f}] rad")
        if not 0.0 <= float(self.confidence) <= 1.0:
            raise ValueError(f"Context confidence must be in [0, 1], got {self.confidence!r}")
        object.__setattr__(self, "starts", tuple(starts.tolist()))
        object.__setattr__(self, "widths", tuple(widths.tolist()))
        object.__setattr__(self, "confidence", float(self.confidence))

    @classmethod
    def exact(cls, angles_rad) -> "Context":
        """A point context: the given ``(3,)`` angles with confidence 1 (``known``, ``none``)."""
        a = np.asarray(angles_rad, dtype=np.float64)
        if a.shape != (3,):
            raise ValueError(f"angles_rad must have shape (3,), got {a.shape}")
        return cls(tuple(a.tolist()), (0.0, 0.0, 0.0), 1.0)

    @classmethod
    def unknown(cls, confidence: float = 0.0) -> "Context":
        """Every angle possible: full circles for the pectorals, the whole caudal sweep."""
        return cls((0.0, 0.0, -CAUDAL_LIMIT_RAD), (TWO_PI, TWO_PI, 2 * CAUDAL_LIMIT_RAD), confidence)

    def with_confidence(self, confidence: float) -> "Context":
        """The same ranges with another confidence (paper: setConfidence)."""
        return dataclasses.replace(self, confidence=confidence)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Initial angles of ``n`` model simulations, the paper's PERFORM() (section 3.3).

        For each simulation, with probability ``confidence`` all three angles are drawn
        uniformly from the ranges (setFlippers), otherwise from :func:`random_angles`
        (randomizeFlipperPositions). The number of random draws does not depend on the
        outcomes.

        Returns:
            ``(n, 3)`` float64 radians; pectorals in [0, 2 pi), caudal within the sweep.
        """
        use_range = rng.random(n) < self.confidence
        ranged = np.column_stack([
            sample_arc(s, w, rng, size=n, period=period)
            for s, w, period in zip(self.starts, self.widths, PERIODS)
        ])
        ranged[:, 2] = np.clip(ranged[:, 2], -CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD)
        return np.where(use_range[:, None], ranged, random_angles(rng, n))

    def estimate(self) -> np.ndarray:
        """``(3,)`` point estimate (rad): the middle of each range (pectorals wrapped to [0, 2 pi))."""
        mid = np.asarray(self.starts) + 0.5 * np.asarray(self.widths)
        mid[:2] = np.mod(mid[:2], TWO_PI)
        return mid


@dataclasses.dataclass(frozen=True, eq=False)
class Experiment:
    """One action performed on the target and its recorded response (paper section 3.2).

    Immutable: an inference strategy that refines the context returns a new experiment
    (:meth:`with_context`), which the estimation phase passes on.

    Attributes:
        index: position in the run's experiment list (0-based); part of cache keys.
        action: ``(3,)`` servo command: left, right pectoral speed (rev/s), caudal (Hz).
        imu_log: ``(steps, 3)`` target's roll, pitch, yaw (degrees, yaw unwrapped).
        summary: ``(3, steps // 2 + 1)`` behaviour summary of ``imu_log``
            (:func:`eea.behaviour.behaviour_summary`).
        true_angles: ``(3,)`` the target's true initial angles (rad). Hidden from the
            models except under the ``known`` strategy.
        context: the inferred ranges and confidence the models use.
        start_motion: ``(7,)`` what the target's IMU measured at the experiment's start, which
            every model's simulation of it starts from: its roll and pitch as a yaw-free unit
            quaternion (x, y, z, w) and its angular velocity (rad/s, world axes turned by its
            yaw) (:func:`aquafish_gym.simulator.validate_start_motion`). Default
            :data:`~aquafish_gym.simulator.AT_REST` (level, still): the paper's target starts
            every experiment at rest; a mission's robot starts after a stop that leaves it rolling.

    Raises:
        ValueError: a ``start_motion`` that is not a valid ``(7,)`` start motion.
    """

    index: int
    action: np.ndarray
    imu_log: np.ndarray
    summary: np.ndarray
    true_angles: np.ndarray
    context: Context
    start_motion: np.ndarray = dataclasses.field(default_factory=lambda: np.array(AT_REST))

    def __post_init__(self) -> None:
        if not (isinstance(self.start_motion, np.ndarray) and not self.start_motion.flags.writeable):
            object.__setattr__(self, "start_motion", validate_start_motion(self.start_motion, 1)[0])
        for name in ("action", "imu_log", "summary", "true_angles", "start_motion"):
            value = getattr(self, name)
            if isinstance(value, np.ndarray) and value.dtype == np.float64 and not value.flags.writeable:
                continue  # already a read-only copy (with_context shares it)
            array = np.array(value, dtype=np.float64)  # a private, read-only copy
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    def with_context(self, context: Context) -> "Experiment":
        """The same experiment with another context (paper: setFlippers, setConfidence)."""
        return dataclasses.replace(self, context=context)

    @property
    def at_rest(self) -> bool:
        """Whether the target started this experiment level and still (:data:`AT_REST`)."""
        return bool(np.array_equal(self.start_motion, AT_REST))

    def state_dict(self) -> dict:
        """Plain data (numbers, lists, arrays) for the run checkpoint."""
        return {"index": self.index, "action": self.action, "imu_log": self.imu_log, "summary": self.summary,
                "true_angles": self.true_angles, "context": dataclasses.asdict(self.context),
                "start_motion": self.start_motion}

    @classmethod
    def from_state_dict(cls, state: dict) -> "Experiment":
        """Inverse of :meth:`state_dict` (a state written before ``start_motion`` existed starts at rest)."""
        ctx = state["context"]
        return cls(int(state["index"]), np.asarray(state["action"]), np.asarray(state["imu_log"]),
                   np.asarray(state["summary"]), np.asarray(state["true_angles"]),
                   Context(tuple(ctx["starts"]), tuple(ctx["widths"]), ctx["confidence"]),
                   np.asarray(state.get("start_motion", AT_REST), dtype=np.float64))


def with_newest_context(experiments, context: Context) -> tuple[Experiment, ...]:
    """``experiments`` (oldest first) with the newest one's context replaced by ``context``."""
    experiments = tuple(experiments)
    return experiments[:-1] + (experiments[-1].with_context(context),)
