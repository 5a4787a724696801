"""A video of controllers swimming side by side, seen from above, with their trajectories traced.

:func:`record_video` runs every controller on the same robot from the same start (one
AquaFish-v0 episode each, in lockstep) with ``render_mode="rgb_array"`` and the ``"top"``
camera (straight down, following the robot, the initial heading up the frame). Each frame
shows one panel per controller: the rendered robot, the path it has swum so far (projected
with the camera's matrices, :meth:`aquafish_gym.env.AquaFishEnv.camera_matrices`), and the
distance so far. Frames are written with imageio: an mp4 (H.264) when imageio's ffmpeg
plugin is installed (the ``[video]`` extra, ``imageio-ffmpeg``), else an animated GIF
(Pillow). Keep videos small: ``frame_every`` control steps per frame, ``panel_px`` pixels per
panel.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Mapping

import numpy as np

from gait.controller import Controller
from gait.rollout import EPISODE_DURATION_S, make_env

#: Playback rate of the video (frames per second).
VIDEO_FPS = 10


def mp4_available() -> bool:
    """Whether imageio can write mp4 here (its ffmpeg plugin, ``imageio-ffmpeg``, is installed)."""
    return importlib.util.find_spec("imageio_ffmpeg") is not None


def video_path(stem) -> Path:
    """``stem`` with the suffix :func:`record_video` writes here: ``.mp4``, or ``.gif`` without an encoder."""
    return Path(stem).with_suffix(".mp4" if mp4_available() else ".gif")


def project(points: np.ndarray, view: np.ndarray, proj: np.ndarray, width: int, height: int) -> np.ndarray:
    """Pixel coordinates ``(n, 2)`` (column, row; row 0 at the top) of world points ``(n, 3)``
    under the ``(4, 4)`` view and projection matrices (column-vector convention)."""
    h = np.c_[np.asarray(points, dtype=np.float64), np.ones(len(points))] @ (proj @ view).T
    ndc = h[:, :3] / h[:, 3:4]
    return np.c_[(ndc[:, 0] + 1) * 0.5 * width, (1 - ndc[:, 1]) * 0.5 * height]


def record_video(controllers: Mapping[str, Controller], robot, path, *, seed: int = 0,
                 episode_duration_s: float = EPISODE_DURATION_S, frame_every: int = 5, panel_px: int = 160,
                 camera_distance: float = 7.0, title: str | None = None) -> Path:
    """Write a video of ``controllers`` (label -> controller) swimming ``robot`` from above.

    Args:
        controllers: one panel per entry, in order; the labels title the panels.
        robot: the robot they all swim (anything :func:`gait.robots.as_robot` takes).
        path: output file; its suffix is replaced by :func:`video_path`'s (``.mp4`` or ``.gif``).
        seed: ``reset(seed=)`` of every episode (the same initial flipper angles for all).
        episode_duration_s: simulated seconds.
        frame_every: control steps (0.1 s each) per video frame; played at :data:`VIDEO_FPS`.
        panel_px: width and height of each panel's render (pixels).
        camera_distance: height of the camera above the robot (units; 7 shows about 8 units across).
        title: a line above the panels.

    Returns:
        The path written.

    Raises:
        ValueError: no controllers, or an invalid robot, seed or duration.
    """
    import imageio.v3 as iio
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not controllers:
        raise ValueError("record_video needs at least one controller")
    if int(frame_every) < 1:
        raise ValueError(f"frame_every must be >= 1, got {frame_every!r}")
    path = video_path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    labels = list(controllers)
    envs = [make_env(robot, episode_duration_s=episode_duration_s, render_mode="rgb_array", camera="top",
                     camera_distance=camera_distance, width=panel_px, height=panel_px) for _ in labels]
    # a figure whose pixel size is a multiple of 16 (H.264 macro blocks)
    dpi = 80
    width_px = int(np.ceil(len(labels) * (panel_px + 16) / 16) * 16)
    height_px = int(np.ceil((panel_px + 48) / 16) * 16)
    fig, axes = plt.subplots(1, len(labels), figsize=(width_px / dpi, height_px / dpi), dpi=dpi, squeeze=False)
    axes = axes[0]
    if title:
        fig.suptitle(title, fontsize=8)
    frames = []
    try:
        state = []
        for env, label in zip(envs, labels):
            controllers[label].reset()
            obs, info = env.reset(seed=int(seed))
            state.append([obs, info, [(info["x_position"], info["y_position"], info["z_position"])]])
        step, done = 0, False
        while not done:
            if step % int(frame_every) == 0:
                frames.append(_frame(fig, axes, envs, labels, state, panel_px))
            for env, label, s in zip(envs, labels, state):
                obs, _, terminated, truncated, info = env.step(controllers[label].act(s[0], s[1]["time_s"]))
                s[0], s[1] = obs, info
                s[2].append((info["x_position"], info["y_position"], info["z_position"]))
                done = done or terminated or truncated
            step += 1
        frames.append(_frame(fig, axes, envs, labels, state, panel_px))
    finally:
        plt.close(fig)
        for env in envs:
            env.close()
    if path.suffix == ".mp4":
        iio.imwrite(path, np.stack(frames), plugin="FFMPEG", fps=VIDEO_FPS, codec="libx264", macro_block_size=16)
    else:
        iio.imwrite(path, np.stack(frames), duration=1000 / VIDEO_FPS, loop=0)
    return path


def _frame(fig, axes, envs, labels, state, panel_px: int) -> np.ndarray:
    """Draw one frame: every panel's render, its traced path and distance; return ``(H, W, 3)`` uint8."""
    for ax, env, label, (_, info, path) in zip(axes, envs, labels, state):
        ax.clear()
        ax.imshow(env.render(), interpolation="nearest")
        view, proj = env.unwrapped.camera_matrices()
        px = project(np.asarray(path), view, proj, panel_px, panel_px)
        ax.plot(px[:, 0], px[:, 1], color="tab:blue", lw=1.2)
        ax.set_xlim(0, panel_px)
        ax.set_ylim(panel_px, 0)
        ax.set_axis_off()
        ax.set_title(f"{label}\n{info['time_s']:.0f} s, {info['distance']:.1f} units", fontsize=7)
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()


__all__ = ["VIDEO_FPS", "mp4_available", "project", "record_video", "video_path"]
