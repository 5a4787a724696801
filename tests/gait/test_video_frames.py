"""Video frames drawn from a recorded swim (gait.video_frames): size, body, flippers, dials, events."""

import math

import numpy as np
import pytest

from aquafish_gym import Morphology
from gait.video import frame_indices
from gait.video_frames import (BODY_COLOUR, FLIPPER_COLOURS, FrameRenderer, SwimTrack, VideoEvent,
                               flipper_outlines, speedup_text)

HEALTHY = Morphology.healthy().to_array()
ONSET = "#d62728"


def _rgb(hex_colour):
    return np.array([int(hex_colour[i:i + 2], 16) for i in (1, 3, 5)])


def _mask(frame, hex_colour, tol=12):
    return np.abs(frame.astype(int) - _rgb(hex_colour)).max(axis=2) <= tol


def _track(yaw_deg, angles, phase=None, label="gait"):
    """A robot standing at the origin, one sample every 0.1 s with the given yaw and angles."""
    n = len(yaw_deg)
    return SwimTrack(label, np.arange(n) * 0.1, np.zeros((n, 2)), yaw_deg, angles, HEALTHY, phase)


def _box(renderer, ax):
    """``(row0, row1, col0, col1)`` of an axes in the frame."""
    b = ax.get_window_extent()
    h = renderer.size[1]
    return int(h - b.y1) + 2, int(h - b.y0) - 2, int(b.x0) + 2, int(b.x1) - 2


def test_a_frame_is_720p_and_states_its_speedup():
    assert speedup_text(10.0) == "10x real time" and speedup_text(2) == "2x real time"
    with FrameRenderer([_track([0.0], [[0.0, 0.0, 0.0]])], speedup=10.0) as r:
        frame = r.draw(0)
    assert frame.shape == (720, 1280, 3) and frame.dtype == np.uint8
    with pytest.raises(ValueError, match="multiples of 16"):
        FrameRenderer([_track([0.0], [[0.0, 0.0, 0.0]])], size=(1000, 720))
    with pytest.raises(ValueError, match="exactly one track"):
        FrameRenderer([_track([0.0], [[0, 0, 0]]), _track([0.0], [[0, 0, 0]])], timeline=True)


def test_the_pectorals_top_view_extent_is_cos_of_the_angle_and_the_caudal_swings_to_the_right():
    length, thick = HEALTHY[1], HEALTHY[2]
    for a in (0.0, 0.6, math.pi / 2, 2.5, math.pi):
        left, right, _ = flipper_outlines(HEALTHY, [a, a, 0.0])
        fore_aft = np.ptp(left[:, 1])
        assert fore_aft == pytest.approx(abs(math.cos(a)) * length + abs(math.sin(a)) * thick)
        assert left[:, 0].max() == pytest.approx(-0.5) and right[:, 0].min() == pytest.approx(0.5)
    back, front = flipper_outlines(HEALTHY, [0.0, 0.0, 0.0])[0], flipper_outlines(HEALTHY, [math.pi, 0.0, 0.0])[0]
    assert back[:, 1].max() <= 1e-9 < front[:, 1].max()  # arms back at 0, forward at pi
    caudal = flipper_outlines(HEALTHY, [0.0, 0.0, 0.4])[2]
    assert caudal[:, 0].mean() > 0.1  # a positive caudal angle swings the tip to the robot's right (+x)
    missing = flipper_outlines(Morphology.healthy().replace(left_pectoral_x=0.0).to_array(), [0, 0, 0])
    assert missing[0] is None and missing[1] is not None


@pytest.mark.parametrize("flipper", [0, 2])
def test_a_dial_hand_points_where_its_angle_says(flipper):
    # pectoral dials are side views, head to the right: 0 is "arms back" (left), pi/2 tip down;
    # the caudal dial is a top view, head up: 0 points back (down), +0.5 rad swings to the right
    cases = {0: [(0.0, (-1.0, 0.0)), (math.pi / 2, (0.0, -1.0))],
             2: [(0.5, (math.sin(0.5), -math.cos(0.5))), (-0.5, (-math.sin(0.5), -math.cos(0.5)))]}[flipper]
    angles = np.zeros((2, 3))
    angles[:, flipper] = [a for a, _ in cases]
    colour = FLIPPER_COLOURS[flipper]
    with FrameRenderer([_track([0.0, 0.0], angles)]) as r:
        ax = r.dial_axes(0, flipper)
        for k, (_, (u, v)) in enumerate(cases):
            frame = r.draw(k)
            on = r.pixel(ax, [0.7 * u, 0.7 * v])[0].round().astype(int)
            other = cases[1 - k][1]
            off = r.pixel(ax, [0.7 * other[0], 0.7 * other[1]])[0].round().astype(int)
            assert _mask(frame, colour)[on[1], on[0]], f"no hand at {(u, v)} for angle {cases[k][0]}"
            assert not _mask(frame, colour)[off[1], off[0]]


def test_the_body_turns_with_its_yaw():
    with FrameRenderer([_track([0.0, 90.0], np.zeros((2, 3)))]) as r:
        r0, r1, c0, c1 = _box(r, r.view_axes())
        extents = []
        for k in (0, 1):
            view = r.draw(k)[r0:r1, c0:c1]
            rows, cols = np.nonzero(_mask(view, BODY_COLOUR, tol=4))
            extents.append((np.ptp(cols), np.ptp(rows), cols.mean()))
            caudal = np.nonzero(_mask(view, FLIPPER_COLOURS[2], tol=4))
            if k == 1:  # yaw 90: the head points to -x (left), so the tail fin is right of the body
                assert caudal[1].mean() > cols.mean() + 20
            else:  # yaw 0: head up, the tail fin below the body
                assert caudal[0].mean() > rows.mean() + 20
    (w0, h0, _), (w1, h1, _) = extents
    assert h0 > 1.4 * w0  # the capsule's long axis vertical at yaw 0 (length 1.625, width 1.0)
    assert w1 > 1.4 * h1  # and horizontal at yaw 90


def test_the_onset_is_marked_only_once_it_has_happened_and_its_banner_goes():
    n = 120  # 12 s; the onset at 5 s; a banner lasts 2 s
    track = _track(np.zeros(n), np.zeros((n, 3)), phase=("gait",) * n)
    with FrameRenderer([track], speedup=5.0, banner_s=2.0, events=[VideoEvent("damage onset", 5.0, ONSET)]) as r:
        r0, r1, c0, c1 = _box(r, r.view_axes())
        before, just_after, later = (r.draw(k) for k in (45, 55, 110))
    assert not _mask(before, ONSET, 3).any()
    assert _mask(just_after, ONSET, 3).sum() > 500  # the line, its name and the banner
    assert _mask(just_after[r0:r1, c0:c1], ONSET, 3).sum() > 300  # the banner over the view
    assert _mask(later, ONSET, 3).any() and not _mask(later[r0:r1, c0:c1], ONSET, 3).any()


def test_a_frame_drawn_after_others_is_the_frame_drawn_afresh():
    n = 60
    t = np.arange(n) * 0.1
    track = SwimTrack("m", t, np.c_[np.sin(t), 0.3 * t], 40 * t, np.c_[t, -t, 0.4 * np.sin(6 * t)], HEALTHY,
                      ("gait",) * 20 + ("new_gait",) * 20 + ("stop",) * 20)  # "stop" is shorter than "new gait"
    events = [VideoEvent("damage onset", 1.0, ONSET), VideoEvent("alarm", 2.5, "#ff7f0e")]
    with FrameRenderer([track], speedup=2.0, events=events) as a:
        for k in (0, 12, 25, 35):  # the phase badge grows ("new gait"), then shrinks ("stop") at 52
            a.draw(k)
        late = a.draw(52)
    with FrameRenderer([track], speedup=2.0, events=events) as b:
        fresh = b.draw(52)
    assert np.array_equal(late, fresh)


def test_frame_indices_take_the_first_sample_at_or_after_each_frame_time_and_the_last():
    assert frame_indices(np.arange(21) * 0.1, 0.2).tolist() == list(range(0, 21, 2))
    t = np.array([0.0, 0.1, 0.2, 0.25, 0.35, 0.45, 0.5])  # an experiment's samples off the 0.1 s grid
    assert frame_indices(t, 0.2).tolist() == [0, 2, 5, 6]
    with pytest.raises(ValueError, match="seconds_per_frame"):
        frame_indices(t, 0.0)


def test_a_swim_track_checks_its_shapes():
    with pytest.raises(ValueError, match="xy"):
        SwimTrack("x", [0.0, 0.1], np.zeros((3, 2)), [0, 0], np.zeros((2, 3)), HEALTHY)
    with pytest.raises(ValueError, match="flipper_sizes"):
        SwimTrack("x", [0.0], np.zeros((1, 2)), [0], np.zeros((1, 3)), HEALTHY[:6])
    with pytest.raises(ValueError, match="phase"):
        SwimTrack("x", [0.0], np.zeros((1, 2)), [0], np.zeros((1, 3)), HEALTHY, ("swim",))
