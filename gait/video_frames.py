"""Video frames of swimming robots drawn with matplotlib from their recorded state (no renderer).

A frame (default 1280 x 720 px) shows each robot (:class:`SwimTrack`) from above in a view
that follows it over a world grid of 1 unit (8 cm): the body (the capsule of
:mod:`aquafish_gym.robot`, radius 0.5, length 1.625 units) at its position and yaw, a dot at
its head, the path swum so far, and the three flippers with their sizes from the morphology:

* the pectorals turn about the body's lateral axis, so from above their fore-aft extent is
  the projection of the turned box (``|cos(angle)|`` of their length, plus their thickness);
  drawn paler while their tip is below the body's plane (``sin(angle) > 0``);
* the caudal fin swings about the vertical axis at the tail.

As the top view alone cannot tell a pectoral angle from its mirror image, every panel has
one dial per flipper whose hand shows the angle: pectorals seen from the side with the head
to the right (angle 0, "arms back", points left; a positive angle turns the tip down),
the caudal fin seen from above with the head up (angle 0 points down, a positive angle
swings the tip to the robot's right).

With one track, a timeline strip along the bottom can show the track's phases and events
(e.g. a mission's damage onset, alarm and new gait): the strip is revealed up to a cursor at
the current time, an event's line appears once it has happened and a banner names it for
a few seconds, and an overview map shows the whole path so far.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import numpy as np

from aquafish_gym.robot import BODY_CYLINDER_LENGTH, BODY_LENGTH, BODY_RADIUS, CAUDAL_HINGE_Y, PECTORAL_HINGE_Y

#: The flippers in :meth:`aquafish_gym.BatchWorld.joint_angles` order, and their colours.
FLIPPER_NAMES = ("left pectoral", "right pectoral", "caudal")
FLIPPER_COLOURS = ("#1f77b4", "#e7298a", "#a6761d")
BODY_COLOUR, PATH_COLOUR, HEAD_COLOUR = "#9aa3b5", "#2b8cbe", "#252525"
#: Timeline colours of a mission's phases and events (:mod:`aquafish.mission`).
PHASE_COLOURS = {"gait": "#b3cde3", "stop": "#fed9a6", "experiment": "#fbb4ae", "new_gait": "#ccebc5"}
PHASE_LABELS = {"gait": "gait", "stop": "stop", "experiment": "experiment", "new_gait": "new gait"}
#: Width and height of a frame (pixels): 720p.
FRAME_SIZE = (1280, 720)


@dataclasses.dataclass(frozen=True)
class VideoEvent:
    """A moment marked on a timeline: ``name`` at ``time_s`` (simulated s), drawn in ``colour``."""

    name: str
    time_s: float
    colour: str


@dataclasses.dataclass(frozen=True)
class SwimTrack:
    """One robot's recorded swim, one sample per row (typically every 0.1 s control step).

    Attributes:
        label: the panel's name (a controller or ``"mission"``).
        time_s: ``(T,)`` simulated seconds, non-decreasing.
        xy: ``(T, 2)`` body position in the world's x-y plane (units; +y the initial heading).
        yaw_deg: ``(T,)`` heading (degrees, counter-clockwise from +y, the IMU's yaw).
        angles_rad: ``(T, 3)`` flipper angles (rad): left, right pectoral, caudal.
        flipper_sizes: ``(3, 3)`` or ``(T, 3, 3)`` flipper boxes (units; ``(9,)`` or ``(T, 9)``,
            the morphology's nine values, are reshaped), per sample when the morphology
            changes (a damage's onset); stored as ``(T, 3, 3)``.
        phase: ``(T,)`` phase names (keys of :data:`PHASE_COLOURS`) or None.

    Raises:
        ValueError: inconsistent shapes, non-finite values or an unknown phase.
    """

    label: str
    time_s: np.ndarray
    xy: np.ndarray
    yaw_deg: np.ndarray
    angles_rad: np.ndarray
    flipper_sizes: np.ndarray
    phase: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.time_s, dtype=np.float64)
        n = t.shape[0] if t.ndim == 1 else 0
        if n == 0:
            raise ValueError(f"SwimTrack {self.label!r}: time_s must be a non-empty (T,) array, got shape {t.shape}")
        fields = {"time_s": (t, (n,)), "xy": (self.xy, (n, 2)), "yaw_deg": (self.yaw_deg, (n,)),
                  "angles_rad": (self.angles_rad, (n, 3))}
        for name, (value, shape) in fields.items():
            arr = np.asarray(value, dtype=np.float64)
            if arr.shape != shape or not np.isfinite(arr).all():
                raise ValueError(f"SwimTrack {self.label!r}: {name} must be a finite {shape} array, "
                                 f"got shape {arr.shape}")
            object.__setattr__(self, name, arr)
        if np.any(np.diff(t) < 0):
            raise ValueError(f"SwimTrack {self.label!r}: time_s must be non-decreasing")
        sizes = np.asarray(self.flipper_sizes, dtype=np.float64)
        if sizes.shape == (9,) or sizes.shape == (n, 9):
            sizes = sizes.reshape(*sizes.shape[:-1], 3, 3)
        if sizes.shape not in ((3, 3), (n, 3, 3)) or not np.isfinite(sizes).all() or (sizes < 0).any():
            raise ValueError(f"SwimTrack {self.label!r}: flipper_sizes must be (3, 3) or ({n}, 3, 3) sizes >= 0 "
                             f"(units), got shape {sizes.shape}")
        object.__setattr__(self, "flipper_sizes", np.broadcast_to(sizes, (n, 3, 3)))
        if self.phase is not None:
            phase = tuple(self.phase)
            if len(phase) != n or not set(phase) <= set(PHASE_COLOURS):
                raise ValueError(f"SwimTrack {self.label!r}: phase must hold {n} names from {list(PHASE_COLOURS)}")
            object.__setattr__(self, "phase", phase)

    def __len__(self) -> int:
        return self.time_s.shape[0]

    @property
    def distance(self) -> np.ndarray:
        """``(T,)`` displacement along the initial heading (+y) since the first sample (units)."""
        return self.xy[:, 1] - self.xy[0, 1]

    def speed(self, k: int, span_s: float = 1.0) -> float:
        """Speed along +y (units/s) over the ``span_s`` seconds up to sample ``k`` (0 at the start)."""
        j = int(np.searchsorted(self.time_s, self.time_s[k] - span_s - 1e-9))
        dt = self.time_s[k] - self.time_s[j]
        return float((self.xy[k, 1] - self.xy[j, 1]) / dt) if dt > 0 else 0.0


# -- geometry (body frame: x to the robot's right, y forward; units) -------------------------------------------


def body_outline(points: int = 40) -> np.ndarray:
    """``(points, 2)`` the capsule seen from above (a stadium along y) in the body frame (units)."""
    half = max(points // 2, 4)
    a = np.linspace(0.0, math.pi, half)
    front = np.c_[BODY_RADIUS * np.cos(a), BODY_CYLINDER_LENGTH / 2 + BODY_RADIUS * np.sin(a)]
    return np.r_[front, -front]


def flipper_outlines(sizes, angles) -> list[np.ndarray | None]:
    """The three flippers seen from above in the body frame: ``(4, 2)`` polygons (units), None
    for a flipper without area.

    Args:
        sizes: ``(3, 3)`` boxes (pectorals: span, length, thickness; caudal: thickness,
            length, height), the morphology's nine values reshaped.
        angles: ``(3,)`` joint angles (rad) as :mod:`aquafish_gym.robot` defines them.
    """
    sizes = np.asarray(sizes, dtype=np.float64).reshape(3, 3)
    out: list[np.ndarray | None] = []
    for k, side in ((0, -1.0), (1, 1.0)):  # pectorals: about the lateral (x) axis at the body's side
        span, length, thick = sizes[k]
        if span <= 0 or length <= 0:
            out.append(None)
            continue
        c, s = math.cos(angles[k]), math.sin(angles[k])
        ys = [y * c - z * s for y in (0.0, -length) for z in (-thick / 2, thick / 2)]  # the turned box's corners
        y0, y1 = PECTORAL_HINGE_Y + min(ys), PECTORAL_HINGE_Y + max(ys)
        x0, x1 = sorted((side * BODY_RADIUS, side * (BODY_RADIUS + span)))
        out.append(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))
    thick, length, _ = sizes[2]
    if length <= 0:
        out.append(None)
    else:  # caudal: about the vertical axis at the tail; its tip at (sin a, -cos a) * length
        box = np.array([[-thick / 2, 0.0], [thick / 2, 0.0], [thick / 2, -length], [-thick / 2, -length]])
        c, s = math.cos(angles[2]), math.sin(angles[2])
        out.append(box @ np.array([[c, s], [-s, c]]) + [0.0, CAUDAL_HINGE_Y])
    return out


def to_world(points, xy, yaw_deg: float) -> np.ndarray:
    """Body-frame points ``(n, 2)`` in the world's x-y plane (units) for a body at ``xy`` with yaw ``yaw_deg``."""
    a = math.radians(yaw_deg)
    c, s = math.cos(a), math.sin(a)
    return np.asarray(points, dtype=np.float64) @ np.array([[c, s], [-s, c]]) + np.asarray(xy, dtype=np.float64)


def dial_hand(flipper: int, angle_rad: float) -> np.ndarray:
    """``(2,)`` unit vector (right, up) of a dial's hand: pectorals (0, 1) seen from the side
    with the head to the right (the tip's direction, ``(-cos a, -sin a)``), the caudal fin (2)
    from above with the head up (``(sin a, -cos a)``)."""
    if flipper not in (0, 1, 2):
        raise ValueError(f"flipper must be 0 (left pectoral), 1 (right pectoral) or 2 (caudal), got {flipper!r}")
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([s, -c]) if flipper == 2 else np.array([-c, -s])


def check_frame_size(size) -> tuple[int, int]:
    """``size`` as ``(width, height)`` pixels: integers >= 640 x 368, multiples of 16 (H.264 macro blocks).

    Raises:
        ValueError: anything else.
    """
    try:
        width, height = (int(v) for v in size)
        ok = (width, height) == tuple(size)
    except (TypeError, ValueError):
        ok = False
    if not ok or width < 640 or height < 368 or width % 16 or height % 16:
        raise ValueError(f"size must be (width >= 640, height >= 368) pixels, multiples of 16, got {size!r}")
    return width, height


def speedup_text(speedup: float) -> str:
    """``"10x real time"``: simulated seconds per second of video."""
    return f"{speedup:.3g}x real time" if speedup >= 1 else f"{1 / speedup:.3g}x slow motion"


# -- the figure --------------------------------------------------------------------------------------------------


class FrameRenderer:
    """Draws frames of one or more :class:`SwimTrack` side by side (one panel each).

    What does not move (titles, dial faces, the timeline's phases, the overview's axes) is
    drawn once; a frame redraws only the regions that change (the views, the dials, the
    timeline, and a text when its words change): about 20 ms a 1280 x 720 frame against 90 ms
    for redrawing the figure (measured on the 2-core machine). The readouts (distance,
    speed) change four times per second of video (they would be unreadable at the frame rate).

    Args:
        tracks: the panels, left to right; all with the same number of samples ``T``.
        title: the first line of the header.
        speedup: simulated seconds per second of video, stated in the header.
        events: marked on the timeline (one track only).
        timeline: a timeline strip and an overview map (default: with one track that has
            phases or events).
        size: ``(width, height)`` pixels, multiples of 16 (H.264 macro blocks), at least 640 x 368.
        view_units: world width (units) each panel's top view shows (default 8 for one
            panel, 6 for more).
        banner_s: simulated seconds an event's banner stays (default 3 s of video).

    Raises:
        ValueError: no tracks, tracks of different lengths, a bad size or speed-up, or a
            timeline with more than one track.
    """

    #: Readout updates per second of video.
    READOUT_HZ = 4.0

    def __init__(self, tracks: Sequence[SwimTrack], *, title: str = "", speedup: float = 1.0,
                 events: Sequence[VideoEvent] = (), timeline: bool | None = None,
                 size: tuple[int, int] = FRAME_SIZE, view_units: float | None = None, banner_s: float | None = None):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        self.tracks = list(tracks)
        if not self.tracks or not all(isinstance(t, SwimTrack) for t in self.tracks):
            raise ValueError("FrameRenderer needs at least one SwimTrack")
        if len({len(t) for t in self.tracks}) != 1:
            raise ValueError(f"the tracks must have the same number of samples, got {[len(t) for t in self.tracks]}")
        width, height = check_frame_size(size)
        if isinstance(speedup, bool) or not isinstance(speedup, (int, float)) or not math.isfinite(speedup) \
                or speedup <= 0:
            raise ValueError(f"speedup must be a positive number (simulated s per video s), got {speedup!r}")
        self.events = sorted(events, key=lambda e: e.time_s)
        self.timeline = (len(self.tracks) == 1 and (bool(self.events) or self.tracks[0].phase is not None)) \
            if timeline is None else bool(timeline)
        if self.timeline and len(self.tracks) != 1:
            raise ValueError(f"a timeline needs exactly one track, got {len(self.tracks)}")
        self.size, self.speedup = (width, height), float(speedup)
        self.view_units = float(view_units) if view_units else (8.0 if len(self.tracks) == 1 else 6.0)
        self.banner_s = float(banner_s) if banner_s is not None else 3.0 * self.speedup
        self._readout_s = self.speedup / self.READOUT_HZ
        self._plt = plt
        self.fig = plt.figure(figsize=(width / 100, height / 100), dpi=100, facecolor="white")
        self._fs = height / 720  # text scales with the frame
        self._groups: dict = {}  # what a frame redraws: axes (always) or a text (when it changes) -> artists
        self._drawn: dict = {}  # text -> (its last signature, its last pixel box)
        self._background = self._buffer = None
        self.fig.text(0.01, 0.985, title, fontsize=15 * self._fs, va="top", weight="bold")
        self._clock = self._text(self.fig.text(0.01, 0.935, "", fontsize=13 * self._fs, va="top"))
        self.fig.text(0.125, 0.935, f"simulated;  the video runs at {speedup_text(self.speedup)}",
                      fontsize=13 * self._fs, va="top")
        self.panels = [self._panel(i, track) for i, track in enumerate(self.tracks)]
        self._strip = self._timeline(self.tracks[0]) if self.timeline else None

    def _add(self, artist, group):
        artist.set_animated(True)
        self._groups.setdefault(group, []).append(artist)
        return artist

    def _text(self, text):
        return self._add(text, text)

    # -- layout
    def _panel(self, i: int, track: SwimTrack) -> dict:
        from matplotlib.collections import LineCollection
        from matplotlib.patches import Circle, Polygon, Rectangle

        fs, n = self._fs, len(self.tracks)
        if self.timeline:  # one panel: the view on the left, dials and the overview on the right
            view_rect, dial_x0, dial_w, dial_y, dial_h = [0.01, 0.2, 0.62, 0.68], 0.665, 0.105, 0.545, 0.17
        else:
            w = 1.0 / n
            view_rect, dial_x0, dial_w, dial_y, dial_h = [i * w + 0.01, 0.245, w - 0.02, 0.545], i * w + 0.01, \
                (w - 0.02) / 3, 0.05, 0.155
            self.fig.text(i * w + 0.01, 0.895, track.label, fontsize=14 * fs, va="top", weight="bold")
        ax = self.fig.add_axes(view_rect)
        ax.set_facecolor("#f4f8fb")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_autoscale_on(False)
        px_w, px_h = view_rect[2] * self.size[0], view_rect[3] * self.size[1]
        half = (self.view_units / 2, self.view_units / 2 * px_h / px_w)
        grid = self._add(ax.add_collection(LineCollection([], colors="#d5dde6", linewidths=0.8 * fs)), ax)
        path = self._add(ax.plot([], [], color=PATH_COLOUR, lw=2 * fs)[0], ax)
        body = self._add(ax.add_patch(Polygon(np.zeros((3, 2)), closed=True, fc=BODY_COLOUR, ec="#3b3f4a",
                                              lw=1.2 * fs)), ax)
        flippers = [self._add(ax.add_patch(Polygon(np.zeros((3, 2)), closed=True, fc=FLIPPER_COLOURS[k],
                                                   ec="#222222", lw=0.8 * fs)), ax) for k in range(3)]
        head = self._add(ax.add_patch(Circle((0, 0), 0.09, fc=HEAD_COLOUR, ec="none")), ax)
        label = None if self.timeline else self._text(self.fig.text(i / n + 0.01, 0.845, "", fontsize=11 * fs,
                                                                    va="top", linespacing=1.3))
        dials = []
        for k in range(3):
            rect = [dial_x0 + k * dial_w, dial_y, dial_w, dial_h]
            dax = self.fig.add_axes(rect)
            dax.set_xlim(-1.25, 1.25)
            dax.set_ylim(-1.25, 1.25)
            dax.set_aspect("equal", adjustable="box")
            dax.set_axis_off()
            dax.add_patch(Circle((0, 0), 1.0, fc="white", ec="#777777", lw=1.2 * fs))
            zero = dial_hand(k, 0.0)
            dax.plot([0.8 * zero[0], zero[0]], [0.8 * zero[1], zero[1]], color="#555555", lw=2.5 * fs)
            if k == 2:  # a body from above, head up, for the caudal fin
                dax.add_patch(Rectangle((-0.18, 0.0), 0.36, 0.9, fc=BODY_COLOUR, ec="none", alpha=0.6))
            else:  # a body from the side, head to the right, for a pectoral
                dax.add_patch(Rectangle((-0.5, -0.18), 1.4, 0.36, fc=BODY_COLOUR, ec="none", alpha=0.6))
            hand = self._add(dax.plot([0, 0], [0, 0], color=FLIPPER_COLOURS[k], lw=5 * fs,
                                      solid_capstyle="butt")[0], dax)
            self._add(dax.add_patch(Circle((0, 0), 0.09, fc="#333333")), dax)
            self.fig.text(rect[0] + rect[2] / 2, dial_y, FLIPPER_NAMES[k], ha="center", va="top",
                          fontsize=9.5 * fs, color=FLIPPER_COLOURS[k])
            dials.append((dax, hand))
        note = "dials: pectorals from the side (head →), caudal from above (head ↑)"
        grid_note = "grid: 1 unit = 8 cm; the robot's path in blue"
        if self.timeline:
            self.fig.text(dial_x0, dial_y + dial_h + 0.005, note, fontsize=8.5 * fs, va="bottom", color="#444444")
            self.fig.text(view_rect[0], view_rect[1] - 0.005, grid_note, fontsize=8.5 * fs, va="top",
                          color="#444444")
        elif i == 0:
            self.fig.text(0.01, 0.006, f"{grid_note}; {note}", fontsize=8.5 * fs, va="bottom", color="#444444")
        return {"ax": ax, "half": half, "grid": grid, "path": path, "body": body, "flippers": flippers,
                "head": head, "label": label, "dials": dials, "track": track}

    def _timeline(self, track: SwimTrack) -> dict:
        from matplotlib.colors import ListedColormap
        from matplotlib.patches import Patch, Rectangle

        fs = self._fs
        t0, t1 = float(track.time_s[0]), float(track.time_s[-1])
        t1 = t1 if t1 > t0 else t0 + 1.0
        rect = [0.04, 0.085, 0.92, 0.05]
        ax = self.fig.add_axes(rect)
        ax.set_xlim(t0, t1)
        ax.set_ylim(0, 1)
        ax.set_yticks([])
        ax.tick_params(labelsize=9 * fs, length=3, pad=1)
        ax.set_xlabel("simulated time (s)", fontsize=9 * fs, labelpad=1, loc="left")
        if track.phase is not None:
            names = list(PHASE_COLOURS)
            codes = np.array([names.index(p) for p in track.phase])[None]
            ax.imshow(codes, aspect="auto", extent=(t0, t1, 0, 1), cmap=ListedColormap(list(PHASE_COLOURS.values())),
                      vmin=-0.5, vmax=len(names) - 0.5, interpolation="nearest")
            ax.legend(handles=[Patch(fc=c, label=PHASE_LABELS[p]) for p, c in PHASE_COLOURS.items()], ncol=4,
                      loc="upper right", bbox_to_anchor=(1.0, -0.45), fontsize=9 * fs, frameon=False,
                      borderaxespad=0.0, handlelength=1.5, columnspacing=1.2)
        future = self._add(ax.add_patch(Rectangle((t0, 0), t1 - t0, 1, fc="#f2f2f2", ec="none")), ax)
        marks = []
        last_px = []  # (x in pixels, row) of each event name so far: two rows when names would touch
        for e in self.events:
            px = (e.time_s - t0) / (t1 - t0) * rect[2] * self.size[0]
            row = 1 if last_px and px - last_px[-1][0] < 120 * fs and last_px[-1][1] == 0 else 0
            last_px.append((px, row))
            line = self._add(ax.axvline(e.time_s, color=e.colour, lw=3 * fs), ax)
            text = self._add(ax.text(e.time_s, 1.08 + 0.5 * row, e.name, color=e.colour, fontsize=10 * fs,
                                     ha="center", va="bottom", weight="bold", clip_on=False), "events")
            marks.append((e, line, text))
        cursor = self._add(ax.axvline(t0, color="black", lw=2 * fs), ax)
        view = self.panels[0]["ax"]
        banner = self._add(view.text(0.5, 0.96, "", transform=view.transAxes, ha="center", va="top",
                                     fontsize=20 * fs, weight="bold", color="white",
                                     bbox=dict(boxstyle="round,pad=0.4", fc="black", ec="none")), view)
        status = self._text(self.fig.text(0.655, 0.87, "", fontsize=11.5 * fs, va="top", linespacing=1.45))
        phase = self._text(self.fig.text(0.99, 0.975, "", fontsize=16 * fs, va="top", ha="right", weight="bold",
                                         bbox=dict(boxstyle="round,pad=0.4", fc="white", ec="#444444")))
        mini_rect = [0.70, 0.225, 0.28, 0.23]
        mini = self.fig.add_axes(mini_rect)
        mini.tick_params(labelsize=8 * fs, length=2, pad=1)
        mini.set_title("whole path so far (units)", fontsize=9 * fs, pad=2)
        lo, hi = track.xy.min(axis=0) - 1.0, track.xy.max(axis=0) + 1.0
        centre, extent = (lo + hi) / 2, hi - lo
        aspect = (mini_rect[2] * self.size[0]) / (mini_rect[3] * self.size[1])  # equal scales on x and y
        extent = np.maximum(extent, [extent[1] * aspect, extent[0] / aspect])
        mini.set_xlim(centre[0] - extent[0] / 2, centre[0] + extent[0] / 2)
        mini.set_ylim(centre[1] - extent[1] / 2, centre[1] + extent[1] / 2)
        mini.grid(True, color="#e0e0e0", lw=0.5)
        mini_path = self._add(mini.plot([], [], color=PATH_COLOUR, lw=1.2 * fs)[0], mini)
        mini_dot = self._add(mini.plot([], [], "o", color=HEAD_COLOUR, ms=5 * fs)[0], mini)
        top = (rect[1] + rect[3]) * self.size[1]  # the band above the strip where the events' names go
        self._events_box = (top, top + 40 * fs, 0.0, float(self.size[0]))
        return {"ax": ax, "future": future, "marks": marks, "cursor": cursor, "banner": banner, "t1": t1,
                "status": status, "phase": phase, "mini_path": mini_path, "mini_dot": mini_dot}

    # -- drawing
    def draw(self, k: int, *, rgba: bool = False) -> np.ndarray:
        """The frame at sample ``k`` of every track: ``(height, width, 3)`` uint8 RGB, a copy.

        With ``rgba``: the canvas's own ``(height, width, 4)`` RGBA buffer, no copy (a video
        writer's fast path), valid until the next ``draw``.

        Raises:
            ValueError: ``k`` is not a sample index.
        """
        n = len(self.tracks[0])
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not -n <= k < n:
            raise ValueError(f"k must be a sample index in [0, {n}), got {k!r}")
        k = int(k) % n
        time_s = self.tracks[0].time_s
        # the readouts' sample: the last at or before a multiple of the readout period
        q = math.floor(time_s[k] / self._readout_s + 1e-9) * self._readout_s
        r = min(max(int(np.searchsorted(time_s, q + 1e-9, side="right")) - 1, 0), k)
        self._clock.set_text(f"t = {float(time_s[k]):.1f} s")
        for panel in self.panels:
            self._update_panel(panel, k, r)
        if self._strip is not None:
            self._update_timeline(self._strip, self.tracks[0], k, r)
        self._blit()
        return self._buffer if rgba else self._buffer[:, :, :3].copy()

    def _blit(self) -> None:
        """Redraw what changed onto the background (everything, the first time)."""
        canvas = self.fig.canvas
        if self._background is None:
            canvas.draw()  # everything that does not move (the moving artists are animated)
            self._buffer = np.asarray(canvas.buffer_rgba())
            self._background = self._buffer.copy()
        renderer = canvas.get_renderer()
        dirty = []  # first every changed region is restored, then its artists drawn
        for key, artists in self._groups.items():
            if key == "events":
                signature = tuple(a.get_visible() for a in artists)
                if self._drawn.get(key, (None,))[0] == signature:
                    continue
                self._restore(self._events_box)
                self._drawn[key] = (signature, None)
            elif hasattr(key, "get_text"):  # a text: when its words, colour or visibility change
                box = key.get_bbox_patch()
                signature = (key.get_text(), key.get_visible(), key.get_color(), box and box.get_facecolor())
                last, old = self._drawn.get(key, (None, None))
                if last == signature:
                    continue
                pad = (0.9 * key.get_fontsize() if box else 1.0) * self.fig.dpi / 72  # a bbox's pad and edge
                new = self._box(key.get_window_extent(renderer), pad)
                for b in (old, new):
                    if b is not None:
                        self._restore(b)
                self._drawn[key] = (signature, new)
            else:  # an axes: always
                self._restore(self._box(key.get_window_extent(renderer), 1.0))
            dirty.append(artists)
        for artists in dirty:
            for artist in artists:
                if artist.get_visible():
                    self.fig.draw_artist(artist)

    def _box(self, bbox, pad: float) -> tuple[float, float, float, float]:
        """A display box (pixels from the bottom left) as ``(bottom, top, left, right)`` padded by ``pad`` px."""
        return bbox.y0 - pad, bbox.y1 + pad, bbox.x0 - pad, bbox.x1 + pad

    def _restore(self, box) -> None:
        bottom, top, left, right = box
        h, w = self.size[1], self.size[0]
        r0, r1 = max(0, int(h - math.ceil(top))), min(h, int(h - math.floor(bottom)))
        c0, c1 = max(0, int(math.floor(left))), min(w, int(math.ceil(right)))
        if r1 > r0 and c1 > c0:
            self._buffer[r0:r1, c0:c1] = self._background[r0:r1, c0:c1]

    def _update_panel(self, panel: dict, k: int, r: int) -> None:
        track, ax = panel["track"], panel["ax"]
        x, y = track.xy[k]
        yaw = float(track.yaw_deg[k])
        hx, hy = panel["half"]
        ax.set_xlim(x - hx, x + hx)
        ax.set_ylim(y - hy, y + hy)
        gx, gy = np.arange(math.ceil(x - hx), x + hx), np.arange(math.ceil(y - hy), y + hy)  # a 1-unit world grid
        panel["grid"].set_segments([[(v, y - hy), (v, y + hy)] for v in gx] + [[(x - hx, v), (x + hx, v)] for v in gy])
        panel["path"].set_data(track.xy[: k + 1, 0], track.xy[: k + 1, 1])
        panel["body"].set_xy(to_world(body_outline(), (x, y), yaw))
        panel["head"].center = tuple(to_world([[0.0, BODY_LENGTH / 2 - 0.22]], (x, y), yaw)[0])
        angles = track.angles_rad[k]
        for j, (patch, outline) in enumerate(zip(panel["flippers"], flipper_outlines(track.flipper_sizes[k], angles))):
            patch.set_visible(outline is not None)
            if outline is not None:
                patch.set_xy(to_world(outline, (x, y), yaw))
                patch.set_alpha(0.45 if j < 2 and math.sin(angles[j]) > 0 else 1.0)  # a pectoral's tip below
        for j, (_, hand) in enumerate(panel["dials"]):
            u, v = dial_hand(j, float(angles[j]))
            hand.set_data([0.0, u], [0.0, v])
        if panel["label"] is not None:
            d = float(track.distance[r])
            panel["label"].set_text(f"{d:+.2f} units ({d * 0.08:+.2f} m) along the heading\n"
                                    f"speed {track.speed(r):+.2f} units/s (1 s mean)")

    def _update_timeline(self, strip: dict, track: SwimTrack, k: int, r: int) -> None:
        t = float(track.time_s[k])
        strip["future"].set_x(t)
        strip["future"].set_width(max(strip["t1"] - t, 0.0))
        strip["cursor"].set_xdata([t, t])
        latest = None
        for e, line, text in strip["marks"]:
            shown = t >= e.time_s - 1e-9
            line.set_visible(shown)
            text.set_visible(shown)
            if shown and t - e.time_s < self.banner_s:
                latest = e
        banner = strip["banner"]
        banner.set_visible(latest is not None)
        if latest is not None:
            banner.set_text(f"{latest.name} at {latest.time_s:.1f} s")
            banner.get_bbox_patch().set_facecolor(latest.colour)
        phase = track.phase[k] if track.phase is not None else None
        strip["phase"].set_visible(phase is not None)
        if phase is not None:
            strip["phase"].set_text(f"phase: {PHASE_LABELS[phase]}")
            strip["phase"].get_bbox_patch().set_facecolor(PHASE_COLOURS[phase])
        d = float(track.distance[r])
        done = [e for e in self.events if t >= e.time_s - 1e-9]
        strip["status"].set_text(f"distance along the heading: {d:+.2f} units ({d * 0.08:+.2f} m)\n"
                                 f"speed along it (1 s mean): {track.speed(r):+.2f} units/s\n"
                                 + (f"last event: {done[-1].name} at {done[-1].time_s:.1f} s" if done
                                    else "no event yet"))
        strip["mini_path"].set_data(track.xy[: k + 1, 0], track.xy[: k + 1, 1])
        strip["mini_dot"].set_data([track.xy[k, 0]], [track.xy[k, 1]])

    # -- pixel geometry (for tests and overlays)
    def pixel(self, ax, points) -> np.ndarray:
        """``(n, 2)`` pixel (column, row; row 0 at the top) of data points ``(n, 2)`` of axes ``ax``
        as the last frame drew them."""
        xy = ax.transData.transform(np.asarray(points, dtype=np.float64).reshape(-1, 2))
        return np.c_[xy[:, 0], self.size[1] - xy[:, 1]]

    def dial_axes(self, panel: int, flipper: int):
        """The axes of panel ``panel``'s dial of ``flipper`` (0-2; data units: the dial's radius is 1)."""
        return self.panels[panel]["dials"][flipper][0]

    def view_axes(self, panel: int = 0):
        """The axes of panel ``panel``'s top view (data units: world units)."""
        return self.panels[panel]["ax"]

    def close(self) -> None:
        """Free the figure."""
        self._plt.close(self.fig)

    def __enter__(self) -> "FrameRenderer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = ["FLIPPER_COLOURS", "FLIPPER_NAMES", "FRAME_SIZE", "FrameRenderer", "PHASE_COLOURS", "SwimTrack",
           "VideoEvent", "body_outline", "check_frame_size", "dial_hand", "flipper_outlines", "speedup_text",
           "to_world"]
