"""A damage monitor: notice, while a gait swims, that the robot no longer swims as it should.

:class:`DamageMonitor` watches the forward speed the IMU reports (the body-frame forward
velocity, observation entry 10, units/s; 1 unit = 8 cm) averaged over a trailing window of
``window_s`` seconds, and raises an alarm when that mean leaves the healthy range of the gait
on the current self-model, ``[lower, upper]``. The range is calibrated by :func:`calibrate`
on healthy swimming of the self-model (the healthy robot before any damage) from random
initial flipper angles (the servos have no position feedback, so the angles a mission starts
from are unknown), and kept in a :class:`MonitorCalibration`, a small frozen dataclass that
is saved as JSON beside the self-model (:meth:`MonitorCalibration.save`).

Why the speed and not the paper's behaviour similarity (equation 2) between the IMU's window
and the self-model's predicted window for the same commands: with the initial flipper angles
unknown the self-model cannot be started in the robot's state, and the healthy robot's own
similarity to its replayed self-model spreads as widely as most damages move it. Measured on
a healthy NEAT gait (docs/main_job.md, "Noticing damage"): the speed separates every preset
damage from healthy swimming with no false alarm (23 of 24 missions alarmed within 10 s);
the similarity never separates ``caudal_half`` and falls below its threshold in only part of
the windows after several other damages (18-78 %), so its early alarms are largely chance.

Start heading: AquaFish-v0 has no water current and its physics is the same in every
horizontal direction, and the speed is measured in the body frame, so the robot's motion does
not depend on its heading; the calibration varies the initial angles only. A gait may still
swim slower at some headings (a NEAT network reads the yaw); per-heading ranges were measured
and did not help (docs/main_job.md, "Heading bins, measured and not kept").
"""

from __future__ import annotations

import collections
import copy
import dataclasses
import json
import math
from pathlib import Path
from typing import Any, Iterable

import gymnasium as gym
import numpy as np

import aquafish_gym  # registers the AquaFish tasks  # noqa: F401
from aquafish_gym.checks import check_int
from aquafish_gym.env import FRAME_SKIP
from aquafish_gym.files import atomic_write
from aquafish_gym.params import DT_S

__all__ = ["CALIBRATION_FILE", "DamageMonitor", "MonitorCalibration", "calibrate", "forward_speeds",
           "healthy_range", "window_means", "FORWARD_SPEED_INDEX"]

#: Index of the body-frame forward velocity (units/s) in AquaFish-v0's observation.
FORWARD_SPEED_INDEX = 10
#: The file name of a calibration saved beside a self-model.
CALIBRATION_FILE = "monitor_calibration.json"
#: The ``format`` and ``version`` fields of a saved calibration.
CALIBRATION_FORMAT, CALIBRATION_VERSION = "aquafish damage monitor calibration", 1
#: AquaFish-v0's control period (s): one observation per control step.
CONTROL_PERIOD_S = FRAME_SKIP * DT_S


def _check_positive(name: str, value, what: str) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not (ok and math.isfinite(float(value)) and float(value) > 0):
        raise ValueError(f"{name} must be a finite number > 0 ({what}), got {value!r}")
    return float(value)


def _check_nonnegative(name: str, value, what: str) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not (ok and math.isfinite(float(value)) and float(value) >= 0):
        raise ValueError(f"{name} must be a finite number >= 0 ({what}), got {value!r}")
    return float(value)


def window_steps(window_s: float, control_period_s: float = CONTROL_PERIOD_S) -> int:
    """Samples in a window of ``window_s`` seconds: ``round(window_s / control_period_s)``.

    Raises:
        ValueError: ``window_s`` not a finite number > 0, or shorter than one control period.
    """
    window_s = _check_positive("window_s", window_s, "seconds of swimming averaged")
    steps = int(round(window_s / control_period_s))
    if steps < 1:
        raise ValueError(f"window_s must be at least one control period ({control_period_s:g} s), got {window_s!r}")
    return steps


def window_means(speeds, window: int) -> np.ndarray:
    """Trailing means of ``window`` samples along the last axis.

    Args:
        speeds: ``(..., T)`` samples (units/s), T >= ``window``.
        window: samples per mean (>= 1).

    Returns:
        ``(..., T - window + 1)`` float64: entry j is the mean of samples ``j .. j + window - 1``
        (so entry j ends at sample ``j + window - 1``).

    Raises:
        ValueError: ``window`` not an int >= 1, or fewer than ``window`` samples.
    """
    check_int("window (samples)", window, 1)
    x = np.asarray(speeds, dtype=np.float64)
    if x.ndim < 1 or x.shape[-1] < window:
        raise ValueError(f"speeds must have at least window = {window} samples along the last axis, got shape {x.shape}")
    return np.lib.stride_tricks.sliding_window_view(x, window, axis=-1).mean(axis=-1)


def healthy_range(values, quantile: float = 0.0, margin: float = 0.25) -> tuple[float, float, float]:
    """The healthy range of a windowed signal: ``(lower, median, upper)``.

    ``lower = q_lo - margin * (median - q_lo)`` and ``upper = q_hi + margin * (q_hi - median)``
    with ``q_lo``, ``q_hi`` the ``quantile`` and ``1 - quantile`` quantiles of ``values``
    (``numpy.quantile``, linear interpolation; quantile 0 is the minimum and the maximum):
    the healthy spread on each side of the median, widened by ``margin`` of itself.

    Args:
        values: healthy window means (units/s), any shape, at least one.
        quantile: in [0, 0.5).
        margin: >= 0, the fraction of each side's spread added to it.

    Raises:
        ValueError: no values, a NaN or infinity, or a bad ``quantile`` or ``margin``.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    if v.size == 0 or not np.all(np.isfinite(v)):
        raise ValueError(f"values must be at least one finite number, got {v.size} values "
                         f"{'with NaN or infinity' if v.size else ''}".rstrip())
    q = _check_nonnegative("quantile", quantile, "the quantile of the healthy values each side, in [0, 0.5)")
    if q >= 0.5:
        raise ValueError(f"quantile must be in [0, 0.5) (0: the healthy minimum and maximum), got {quantile!r}")
    m = _check_nonnegative("margin", margin, "the fraction of the healthy spread added each side")
    lo, median, hi = np.quantile(v, [q, 0.5, 1.0 - q])
    return float(lo - m * (median - lo)), float(median), float(hi + m * (hi - median))


@dataclasses.dataclass(frozen=True)
class MonitorCalibration:
    """The healthy range of a gait's windowed forward speed on a self-model.

    Attributes:
        lower, upper: the healthy range of the window's mean forward speed (units/s); an
            alarm is raised outside it.
        median: the healthy windows' median (units/s), for reports.
        window_s: the window (s of swimming averaged).
        warmup_s: swimming (s) before the first window may start: the robot starts at rest
            and the gait needs this long to reach its speed; the monitor is blind until
            ``warmup_s + window_s`` after its reset.
        quantile, margin: how the range was set (:func:`healthy_range`).
        control_period_s: seconds per observation (AquaFish-v0's 0.1 s).
        episodes: healthy episodes calibrated on; ``seeds`` their ``reset`` seeds.
        episode_duration_s: simulated seconds per episode.
        robot: the self-model's description (:meth:`gait.robots.Robot.to_dict`), or {}.

    Raises:
        ValueError: ``lower > upper``, a non-finite number, or a bad window, warm-up or period.
    """

    lower: float
    upper: float
    median: float
    window_s: float
    warmup_s: float
    quantile: float = 0.0
    margin: float = 0.25
    control_period_s: float = CONTROL_PERIOD_S
    episodes: int = 0
    seeds: tuple[int, ...] = ()
    episode_duration_s: float = 0.0
    robot: dict = dataclasses.field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self) -> None:
        for name in ("lower", "upper", "median"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)):
                raise ValueError(f"MonitorCalibration.{name} must be a finite number of units/s, got {value!r}")
        if self.lower > self.upper:
            raise ValueError(f"MonitorCalibration.lower must be <= upper, got {self.lower!r} > {self.upper!r}")
        _check_positive("MonitorCalibration.control_period_s", self.control_period_s, "seconds per observation")
        window_steps(self.window_s, self.control_period_s)
        _check_nonnegative("MonitorCalibration.warmup_s", self.warmup_s, "seconds before the first window")
        object.__setattr__(self, "seeds", tuple(int(s) for s in self.seeds))

    @property
    def window(self) -> int:
        """Samples per window."""
        return window_steps(self.window_s, self.control_period_s)

    @property
    def warmup(self) -> int:
        """Samples skipped before the first window: ``ceil(warmup_s / control_period_s)``."""
        return int(math.ceil(self.warmup_s / self.control_period_s - 1e-9))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields, with ``format``, ``version`` and ``signal``."""
        d = dataclasses.asdict(self)
        d["seeds"] = list(self.seeds)
        return {"format": CALIBRATION_FORMAT, "version": CALIBRATION_VERSION, "signal": "forward_speed"} | d

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "MonitorCalibration":
        """The calibration :meth:`to_dict` wrote.

        Raises:
            ValueError: not a dict of this format and version, a missing or unknown field, or
                a value the constructor refuses.
        """
        if not isinstance(data, dict) or data.get("format") != CALIBRATION_FORMAT:
            raise ValueError(f"not a damage monitor calibration (format must be {CALIBRATION_FORMAT!r})")
        if data.get("version") != CALIBRATION_VERSION or data.get("signal") != "forward_speed":
            raise ValueError(f"unsupported calibration version {data.get('version')!r} or signal "
                             f"{data.get('signal')!r}; this code reads version {CALIBRATION_VERSION}, forward_speed")
        fields = {f.name for f in dataclasses.fields(cls)}
        values = {k: v for k, v in data.items() if k not in ("format", "version", "signal")}
        unknown, missing = set(values) - fields, {"lower", "upper", "median", "window_s", "warmup_s"} - set(values)
        if unknown or missing:
            raise ValueError(f"calibration fields: unknown {sorted(unknown)}, missing {sorted(missing)}")
        return cls(**values)

    def save(self, path) -> Path:
        """Write the calibration as JSON (atomically); a directory gets :data:`CALIBRATION_FILE`
        inside it, beside the self-model. Returns the file written."""
        path = Path(path)
        if path.is_dir():
            path = path / CALIBRATION_FILE
        atomic_write(path, (json.dumps(self.to_dict(), indent=2) + "\n").encode())
        return path

    @classmethod
    def load(cls, path) -> "MonitorCalibration":
        """Read a calibration :meth:`save` wrote (a file, or a directory holding :data:`CALIBRATION_FILE`).

        Raises:
            OSError: the file cannot be read; ValueError: not valid JSON or not a calibration, no
                regular file, too large or nested too deeply
                (:func:`aquafish_gym.files.read_input`, :func:`aquafish_gym.files.parse_json`).
        """
        from aquafish_gym.files import parse_json, read_input

        path = Path(path)
        if path.is_dir():
            path = path / CALIBRATION_FILE
        try:
            data = parse_json(read_input(path), source=path)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ValueError(f"{path} is not valid JSON: {exc}") from None
        return cls.from_dict(data)


class DamageMonitor:
    """Streaming alarm on the windowed forward speed, one observation per control step.

    ``update(observation, info)`` after every ``reset`` and ``step`` of AquaFish-v0 (the
    observation ``reset`` returns included: it is sample 0, taken at rest). The first
    :attr:`MonitorCalibration.warmup` samples are skipped; from then on, once ``window``
    samples are held, the mean of the last ``window`` is compared with ``[lower, upper]``.
    The alarm latches: once raised, ``update`` returns True until :meth:`reset`.

    Args:
        calibration: the :class:`MonitorCalibration` of the gait on the self-model.

    Attributes:
        alarm: whether the alarm has been raised since the last reset.
        alarm_time_s: the time of the sample that raised it (s since the reset: ``info["time_s"]``
            when given, else samples x control period), or None.
        last_mean: the latest window mean (units/s), or None before the first full window.

    Raises:
        ValueError: ``calibration`` is not a :class:`MonitorCalibration`.
    """

    def __init__(self, calibration: MonitorCalibration):
        if not isinstance(calibration, MonitorCalibration):
            raise ValueError(f"calibration must be a MonitorCalibration, got {type(calibration).__name__}")
        self.calibration = calibration
        self._window = calibration.window
        self._warmup = calibration.warmup
        self.reset()

    def reset(self) -> None:
        """Forget every sample and the alarm (a new episode, or a new gait after recovery)."""
        self._samples: collections.deque[float] = collections.deque(maxlen=self._window)
        self._count = 0
        self.alarm = False
        self.alarm_time_s: float | None = None
        self.last_mean: float | None = None

    def update(self, observation, info: dict | None = None) -> bool:
        """Take one observation; return whether the alarm is raised (latched).

        Args:
            observation: AquaFish-v0's observation ``(>= 11,)`` (entry 10: body-frame forward
                velocity, units/s).
            info: the env's info (``time_s`` is used for :attr:`alarm_time_s`), or None.

        Raises:
            ValueError: an observation with fewer than 11 entries or a non-finite speed.
        """
        obs = np.asarray(observation, dtype=np.float64).ravel()
        if obs.size <= FORWARD_SPEED_INDEX:
            raise ValueError(f"observation must be AquaFish-v0's (>= 11 entries, entry {FORWARD_SPEED_INDEX} the "
                             f"forward speed), got shape {obs.shape}")
        return self.update_speed(obs[FORWARD_SPEED_INDEX], None if info is None else info.get("time_s"))

    def update_speed(self, speed: float, time_s: float | None = None) -> bool:
        """:meth:`update` with the forward speed alone (units/s) and its time (s) or None.

        Raises:
            ValueError: ``speed`` not a finite number.
        """
        try:
            speed = float(speed)
        except (TypeError, ValueError):
            speed = math.nan
        if not math.isfinite(speed):
            raise ValueError("the forward speed must be a finite number of units/s")
        index = self._count
        self._count += 1
        if index < self._warmup:
            return self.alarm
        self._samples.append(speed)
        if len(self._samples) < self._window:
            return self.alarm
        self.last_mean = float(np.mean(np.fromiter(self._samples, dtype=np.float64)))
        cal = self.calibration
        if not self.alarm and not (cal.lower <= self.last_mean <= cal.upper):
            self.alarm = True
            self.alarm_time_s = float(time_s) if time_s is not None else index * cal.control_period_s
        return self.alarm


def _check_seeds(seeds) -> list[int]:
    try:
        seeds = list(seeds)
    except TypeError:
        raise ValueError(f"seeds must be a non-empty sequence of distinct ints >= 0, got {seeds!r}") from None
    if not seeds or len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be a non-empty sequence of distinct ints >= 0, got {seeds!r}")
    return [check_int("seeds (each)", s, 0) for s in seeds]


def forward_speeds(controller, robot="healthy", seeds: Iterable[int] = (0,), episode_duration_s: float = 60.0, *,
                   damage: str | None = None, damage_onset_s: float | None = None,
                   max_world_robots: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Swim ``controller`` on ``robot`` from each seed at once (the vector env) and record the IMU speed.

    Every sub-env has its own copy of ``controller`` (``copy.deepcopy``, then ``reset()``),
    driven by its own observation and ``info["time_s"]`` as :func:`gait.rollout.rollout` does.

    Args:
        controller: a :class:`gait.controller.Controller` (any kind).
        robot: anything :func:`gait.robots.as_robot` takes (default the healthy robot).
        seeds: ``reset`` seeds, one episode each (they draw the initial flipper angles).
        episode_duration_s: simulated seconds per episode (> 0).
        damage: a damage for the robot (a preset, JSON fault or ``sampled:SEED``), or None.
        damage_onset_s: when ``damage`` comes in force (s), None: from the start.
        max_world_robots: robots per PyBullet world.

    Returns:
        ``(speeds, damaged)``, both ``(len(seeds), T + 1)``: the body-frame forward velocity
        (units/s) of the observation of ``reset`` and of each of the T control steps, and
        ``info["damaged"]`` with it.

    Raises:
        ValueError: bad seeds, duration, robot, damage or onset (the env's message).
    """
    from gait.robots import as_robot

    seeds = _check_seeds(seeds)
    _check_positive("episode_duration_s", episode_duration_s, "simulated seconds per episode")
    robot = as_robot(robot)
    kwargs = robot.env_kwargs()
    if damage is not None:
        if robot.damage != "none" or robot.faults is not None:
            raise ValueError(f"damage can only be added to a robot without one, got robot {robot.label!r}")
        kwargs["damage"] = damage
    if damage_onset_s is not None:
        kwargs["damage_onset_s"] = damage_onset_s
    envs = gym.make_vec("AquaFish-v0", num_envs=len(seeds), vectorization_mode="vector_entry_point",
                        max_world_robots=max_world_robots, episode_duration_s=float(episode_duration_s), **kwargs)
    controllers = [copy.deepcopy(controller) for _ in seeds]
    for c in controllers:
        c.reset()
    try:
        obs, info = envs.reset(seed=seeds)
        speeds, damaged = [obs[:, FORWARD_SPEED_INDEX].copy()], [np.asarray(info["damaged"], dtype=bool).copy()]
        while True:
            actions = np.array([c.act(o, t) for c, o, t in zip(controllers, obs, info["time_s"])], dtype=np.float64)
            obs, _, _, truncated, info = envs.step(actions)
            speeds.append(obs[:, FORWARD_SPEED_INDEX].copy())
            damaged.append(np.asarray(info["damaged"], dtype=bool).copy())
            if truncated.all():
                break
    finally:
        envs.close()
    return np.stack(speeds, axis=1), np.stack(damaged, axis=1)


def calibrate(controller, robot="healthy", seeds: Iterable[int] = range(12), *, window_s: float = 6.0,
              warmup_s: float = 6.0, episode_duration_s: float = 120.0, quantile: float = 0.0,
              margin: float = 0.25) -> MonitorCalibration:
    """Calibrate the monitor of ``controller`` on healthy swimming of ``robot`` (the self-model).

    One episode per seed, each from the random initial flipper angles its seed draws; every
    window of ``window_s`` starting at or after ``warmup_s`` (every sample step) is a healthy
    value, and the range is :func:`healthy_range` of them.

    Args:
        controller: the gait (a :class:`gait.controller.Controller`).
        robot: the self-model (anything :func:`gait.robots.as_robot` takes; default healthy).
        seeds: ``reset`` seeds of the healthy episodes (distinct ints >= 0; keep them apart
            from the seeds a false-alarm measurement uses).
        window_s: seconds per window (> 0, at least one control period).
        warmup_s: seconds before the first window (>= 0).
        episode_duration_s: simulated seconds per episode; at least ``warmup_s + window_s``.
        quantile: as :func:`healthy_range`.
        margin: as :func:`healthy_range`.

    Returns:
        The :class:`MonitorCalibration`.

    Raises:
        ValueError: any argument out of range (named), or the env's message for a bad robot.
    """
    from gait.robots import as_robot

    seeds = _check_seeds(seeds)
    window = window_steps(window_s)
    warmup_s = _check_nonnegative("warmup_s", warmup_s, "seconds before the first window")
    episode_duration_s = _check_positive("episode_duration_s", episode_duration_s, "simulated seconds per episode")
    if episode_duration_s < warmup_s + window_s:
        raise ValueError(f"episode_duration_s must be at least warmup_s + window_s = {warmup_s + window_s:g} s, "
                         f"got {episode_duration_s!r}")
    healthy_range([0.0], quantile, margin)  # checks quantile and margin before any swimming
    robot = as_robot(robot)
    speeds, _ = forward_speeds(controller, robot, seeds, episode_duration_s)
    probe = MonitorCalibration(0.0, 0.0, 0.0, window_s, warmup_s)
    lower, median, upper = healthy_range(window_means(speeds[:, probe.warmup:], window), quantile, margin)
    return MonitorCalibration(lower=lower, upper=upper, median=median, window_s=float(window_s), warmup_s=warmup_s,
                              quantile=float(quantile), margin=float(margin), episodes=len(seeds), seeds=tuple(seeds),
                              episode_duration_s=episode_duration_s, robot=robot.to_dict())
