"""The mission's video (``mission.mp4``, or ``.gif``): drawn after the mission from its trajectory.

The mission records the robot's position, yaw and flipper angles every control step
(``trajectory.csv``); :func:`write_mission_video` draws from those rows (no rendering while
the robot swims): the robot from above with its flippers turning, its path, one dial per
flipper, the phase, and a timeline with the damage onset, the alarm and the new gait marked
(each named in a banner when it happens), a frame every :data:`MISSION_SECONDS_PER_FRAME`
simulated seconds played at :data:`MISSION_FPS` (5x real time).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gait.video import check_fps, frame_indices, write_frames
from gait.video_frames import FrameRenderer, SwimTrack, VideoEvent

#: Simulated seconds per frame (5 frames per caudal beat at its fastest, 1 Hz) and playback rate:
#: 0.2 s x 25 fps = 5x real time (a 300 s mission plays in 60 s).
MISSION_SECONDS_PER_FRAME, MISSION_FPS = 0.2, 25.0
#: The report's events drawn on the timeline: (report key, name, colour), as in ``timeline.png``.
MISSION_EVENTS = (("onset_s", "damage onset", "#d62728"), ("alarm_s", "alarm", "#ff7f0e"),
                  ("recovered_s", "new gait", "#2ca02c"))
#: ``trajectory.csv``'s flipper angle columns, in :meth:`aquafish_gym.BatchWorld.joint_angles` order.
ANGLE_COLUMNS = ("left_pectoral_rad", "right_pectoral_rad", "caudal_rad")


def mission_track(rows: list[dict], healthy_sizes, damaged_sizes) -> SwimTrack:
    """The mission's rows (``trajectory.csv``'s: ``time_s``, ``x``, ``y``, ``yaw_deg``,
    ``phase``, ``damaged`` and :data:`ANGLE_COLUMNS`) as a :class:`SwimTrack`; the flippers are
    ``healthy_sizes`` ``(9,)`` (units) until ``damaged`` is 1, ``damaged_sizes`` after.

    Raises:
        ValueError: no rows, or a row without one of those columns (named).
    """
    if not rows:
        raise ValueError("the mission's video needs at least one trajectory row")
    need = ("time_s", "x", "y", "yaw_deg", "phase", "damaged", *ANGLE_COLUMNS)
    missing = [c for c in need if c not in rows[0]]
    if missing:
        raise ValueError(f"the mission's trajectory rows lack {missing} (columns: {list(rows[0])})")
    damaged = np.array([bool(r["damaged"]) for r in rows])
    sizes = np.where(damaged[:, None], np.asarray(damaged_sizes, dtype=np.float64).reshape(1, 9),
                     np.asarray(healthy_sizes, dtype=np.float64).reshape(1, 9))
    return SwimTrack("mission", [r["time_s"] for r in rows], [[r["x"], r["y"]] for r in rows],
                     [r["yaw_deg"] for r in rows], [[r[c] for c in ANGLE_COLUMNS] for r in rows], sizes,
                     tuple(r["phase"] for r in rows))


def mission_events(report: dict) -> list[VideoEvent]:
    """The report's onset, alarm and new gait (those that happened) as timeline events."""
    return [VideoEvent(name, float(report[key]), colour) for key, name, colour in MISSION_EVENTS
            if report.get(key) is not None]


def write_mission_video(rows: list[dict], report: dict, stem, healthy_sizes, damaged_sizes, *,
                        seconds_per_frame: float = MISSION_SECONDS_PER_FRAME, fps: float = MISSION_FPS) -> Path:
    """Write the mission's video from its trajectory ``rows`` and ``report`` (``damage``,
    ``onset_s``, ``preset``, ``seed`` and the events of :data:`MISSION_EVENTS`) to ``stem``
    with :func:`gait.video.video_path`'s suffix.

    Args:
        rows: the trajectory (see :func:`mission_track`).
        report: the mission's report.
        stem: output path without suffix.
        healthy_sizes: ``(9,)`` the morphology before the onset (simulator units).
        damaged_sizes: ``(9,)`` the morphology after the onset (simulator units).
        seconds_per_frame: simulated seconds per frame.
        fps: playback frames per second.

    Returns:
        The path written.

    Raises:
        ValueError: bad rows (:func:`mission_track`), ``seconds_per_frame`` or ``fps``.
    """
    fps = check_fps(fps)
    track = mission_track(rows, healthy_sizes, damaged_sizes)
    indices = frame_indices(track.time_s, seconds_per_frame)
    title = (f"mission: {report['damage']} from {report['onset_s']:g} s "
             f"({report['preset']} preset, seed {report['seed']})")
    with FrameRenderer([track], title=title, speedup=seconds_per_frame * fps,
                       events=mission_events(report)) as renderer:
        return write_frames(renderer, indices, stem, fps)


__all__ = ["ANGLE_COLUMNS", "MISSION_EVENTS", "MISSION_FPS", "MISSION_SECONDS_PER_FRAME", "mission_events",
           "mission_track", "write_mission_video"]
