"""Videos of swimming robots from above: controllers side by side (the case study's recovery
video), and the writer the mission's video shares.

:func:`record_video` runs every controller on the same robot from the same start (one
AquaFish-v0 episode each, in lockstep, no rendering), records each robot's position, yaw and
flipper angles every control step, and draws the frames from that record with
:class:`gait.video_frames.FrameRenderer` (1280 x 720 px, one panel per controller: the robot
from above with its flippers turning, its path, one dial per flipper, its distance so far).
The env's own renderer (PyBullet's TinyRenderer, ``render_mode="rgb_array"``) needs the live
world and, at 1280 x 720, takes longer per frame than this drawing to show a grey capsule
with red boxes; a drawing from the record also lets the mission write its video afterwards.

:func:`write_frames` writes frames as they are drawn: an mp4 (H.264) when imageio's ffmpeg
plugin is installed (the ``[video]`` extra, ``imageio-ffmpeg``), else an animated GIF
(Pillow) of at most :data:`GIF_MAX_FRAMES` frames (every k-th frame, each shown k times
longer: the same speed-up).
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from typing import Mapping

import numpy as np

from aquafish_gym.env import FRAME_SKIP
from aquafish_gym.params import DT_S
from gait.controller import Controller
from gait.envs import EPISODE_DURATION_S, make_env
from gait.video_frames import FrameRenderer, SwimTrack, check_frame_size

#: Playback rate of the case study's video (frames per second): with a frame every control
#: step (0.1 s simulated) it runs at 2x real time.
VIDEO_FPS = 20
#: Simulated seconds per control step.
CONTROL_S = FRAME_SKIP * DT_S
#: A GIF holds at most this many frames (a 1280 x 720 GIF frame is ~100-300 kB).
GIF_MAX_FRAMES = 150


def mp4_available() -> bool:
    """Whether imageio can write mp4 here (its ffmpeg plugin, ``imageio-ffmpeg``, is installed)."""
    return importlib.util.find_spec("imageio_ffmpeg") is not None


def video_path(stem) -> Path:
    """``stem`` with the suffix :func:`write_frames` writes here: ``.mp4``, or ``.gif`` without an encoder."""
    return Path(stem).with_suffix(".mp4" if mp4_available() else ".gif")


def check_fps(fps) -> float:
    """``fps`` (video frames per second) as a float.

    Raises:
        ValueError: not a positive finite number.
    """
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not math.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a positive number of video frames per second, got {fps!r}")
    return float(fps)


def frame_indices(time_s, seconds_per_frame: float) -> np.ndarray:
    """Sample indices of a video with a frame every ``seconds_per_frame`` simulated seconds:
    for every multiple of it up to the last sample, the first sample at or after it, and the
    last sample (``(n_frames,)`` int, increasing).

    Raises:
        ValueError: ``time_s`` is not a non-empty non-decreasing ``(T,)`` array, or
            ``seconds_per_frame`` is not positive.
    """
    t = np.asarray(time_s, dtype=np.float64)
    if t.ndim != 1 or t.size == 0 or np.any(np.diff(t) < 0):
        raise ValueError(f"time_s must be a non-empty non-decreasing (T,) array, got shape {t.shape}")
    if isinstance(seconds_per_frame, bool) or not isinstance(seconds_per_frame, (int, float)) \
            or not math.isfinite(seconds_per_frame) or seconds_per_frame <= 0:
        raise ValueError(f"seconds_per_frame must be a positive number of simulated seconds, got {seconds_per_frame!r}")
    marks = t[0] + np.arange(0.0, t[-1] - t[0] + 1e-9, seconds_per_frame)
    idx = np.minimum(np.searchsorted(t, marks - 1e-9), t.size - 1)
    return np.unique(np.r_[idx, t.size - 1])


def write_frames(renderer: FrameRenderer, indices, path, fps: float) -> Path:
    """Draw ``renderer``'s frames at sample ``indices`` and write them at ``fps`` to ``path``
    (its suffix replaced by :func:`video_path`'s), streaming (no frame list in memory for an
    mp4). A GIF keeps every k-th frame (at most :data:`GIF_MAX_FRAMES`) at ``fps / k``.
    Written to a ``.partial`` name first, so a video with the final name is complete.

    Returns:
        The path written.

    Raises:
        ValueError: no indices or a non-positive ``fps``.
    """
    import imageio.v2 as imageio

    indices = np.asarray(indices, dtype=int)
    if indices.ndim != 1 or indices.size == 0:
        raise ValueError("write_frames needs at least one frame index")
    fps = check_fps(fps)
    path = video_path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.stem + ".partial" + path.suffix)
    try:
        if path.suffix == ".mp4":
            with imageio.get_writer(partial, format="FFMPEG", mode="I", fps=fps, codec="libx264", quality=5,
                                    macro_block_size=16, pixelformat="yuv420p", ffmpeg_log_level="error") as writer:
                for k in indices:
                    writer.append_data(renderer.draw(int(k), rgba=True))  # ffmpeg takes RGBA as it is
        else:
            _write_gif(renderer, indices, partial, fps)
        partial.replace(path)
    finally:
        partial.unlink(missing_ok=True)
    return path


def _write_gif(renderer: FrameRenderer, indices: np.ndarray, path: Path, fps: float) -> None:
    """Every k-th frame (at most :data:`GIF_MAX_FRAMES`), each shown k / ``fps`` s, 255 colours."""
    from PIL import Image

    step = math.ceil(indices.size / GIF_MAX_FRAMES)
    pages = (Image.fromarray(renderer.draw(int(k))).quantize(255, method=Image.Quantize.FASTOCTREE)
             for k in indices[::step])
    first = next(pages)
    first.save(path, format="GIF", save_all=True, append_images=pages, duration=round(1000 * step / fps), loop=0)


def record_video(controllers: Mapping[str, Controller], robot, path, *, seed: int = 0,
                 episode_duration_s: float = EPISODE_DURATION_S, frame_every: int = 1, fps: float = VIDEO_FPS,
                 size: tuple[int, int] = (1280, 720), title: str | None = None) -> Path:
    """Write a video of ``controllers`` (label -> controller) swimming ``robot``, seen from above.

    Args:
        controllers: one panel per entry, left to right; the labels title the panels.
        robot: the robot they all swim (anything :func:`gait.robots.as_robot` takes).
        path: output file; its suffix is replaced by :func:`video_path`'s (``.mp4`` or ``.gif``).
        seed: ``reset(seed=)`` of every episode (the same initial flipper angles for all).
        episode_duration_s: simulated seconds.
        frame_every: control steps (0.1 s each) per video frame.
        fps: playback frames per second; the video runs at ``frame_every * 0.1 * fps`` x real
            time (2x by default), stated on every frame.
        size: ``(width, height)`` of a frame (pixels, multiples of 16).
        title: the header's first line.

    Returns:
        The path written.

    Raises:
        ValueError: no controllers, a bad ``frame_every``, ``fps`` or ``size``, or an invalid
            robot, seed or duration.
    """
    if not controllers:
        raise ValueError("record_video needs at least one controller")
    if isinstance(frame_every, bool) or not isinstance(frame_every, (int, np.integer)) or frame_every < 1:
        raise ValueError(f"frame_every must be an integer >= 1 (control steps per frame), got {frame_every!r}")
    fps = check_fps(fps)
    size = check_frame_size(size)
    labels = list(controllers)
    tracks = _swim(controllers, robot, seed, episode_duration_s)
    seconds_per_frame = int(frame_every) * CONTROL_S
    with FrameRenderer(tracks, title=title or f"{len(labels)} gaits from above", speedup=seconds_per_frame * fps,
                       size=size) as renderer:
        return write_frames(renderer, frame_indices(tracks[0].time_s, seconds_per_frame), path, fps)


def _swim(controllers: Mapping[str, Controller], robot, seed: int, episode_duration_s: float) -> list[SwimTrack]:
    """Run every controller for one episode in lockstep; its record every control step."""
    labels = list(controllers)
    envs = [make_env(robot, episode_duration_s=episode_duration_s) for _ in labels]
    records: list[list[tuple]] = [[] for _ in labels]
    try:
        obs = []
        for env, label, rec in zip(envs, labels, records):
            controllers[label].reset()
            o, info = env.reset(seed=int(seed))
            obs.append([o, info])
            rec.append(_state(env, info))
        done = False
        while not done:
            for env, label, s, rec in zip(envs, labels, obs, records):
                o, _, terminated, truncated, info = env.step(controllers[label].act(s[0], s[1]["time_s"]))
                s[0], s[1] = o, info
                rec.append(_state(env, info))
                done = done or terminated or truncated
        sizes = [env.unwrapped.morphology.to_array() for env in envs]
    finally:
        for env in envs:
            env.close()
    tracks = []
    for label, rec, size in zip(labels, records, sizes):
        a = np.array(rec)
        tracks.append(SwimTrack(label, a[:, 0], a[:, 1:3], a[:, 3], a[:, 4:7], size))
    return tracks


def _state(env, info) -> tuple:
    """``(time_s, x, y, yaw_deg, left, right, caudal angle)`` of a single-robot env now."""
    world = env.unwrapped.world
    return (float(info["time_s"]), float(info["x_position"]), float(info["y_position"]),
            float(world.imu_rpy_deg()[0, 2]), *world.joint_angles()[0].tolist())


__all__ = ["CONTROL_S", "GIF_MAX_FRAMES", "VIDEO_FPS", "check_fps", "frame_indices", "mp4_available",
           "record_video", "video_path", "write_frames"]
