"""The mission's video, drawn after the mission from its trajectory rows (aquafish.mission_video)."""

import imageio.v3 as iio
import numpy as np
import pytest

from aquafish.mission_video import ANGLE_COLUMNS, mission_events, mission_track, write_mission_video
from aquafish_gym import Morphology

HEALTHY = Morphology.healthy().to_array()
NO_LEFT = Morphology.healthy().replace(left_pectoral_x=0.0).to_array()


def _rows(n=21, onset_s=1.0):
    phases = ["gait"] * (n // 2) + ["stop"] * 2 + ["experiment"] * 2 + ["new_gait"] * (n - n // 2 - 4)
    return [{"time_s": round(0.1 * i, 6), "x": 0.0, "y": 0.05 * i, "z": 0.0, "yaw_deg": 2.0 * i,
             "speed_along_heading": 0.5, "phase": phases[i], "damaged": int(0.1 * i >= onset_s),
             **dict(zip(ANGLE_COLUMNS, (0.3 * i, -0.3 * i, 0.2)))} for i in range(n)]


def test_the_track_has_the_damaged_flippers_from_the_onset_and_the_reports_events():
    track = mission_track(_rows(), HEALTHY, NO_LEFT)
    assert track.phase[0] == "gait" and track.phase[-1] == "new_gait"
    np.testing.assert_allclose(track.flipper_sizes[9].ravel(), HEALTHY)
    np.testing.assert_allclose(track.flipper_sizes[10].ravel(), NO_LEFT)
    np.testing.assert_allclose(track.angles_rad[3], [0.9, -0.9, 0.2])
    events = mission_events({"onset_s": 1.0, "alarm_s": 1.2, "recovered_s": None})
    assert [(e.name, e.time_s) for e in events] == [("damage onset", 1.0), ("alarm", 1.2)]
    with pytest.raises(ValueError, match="left_pectoral_rad"):
        mission_track([{k: v for k, v in r.items() if k != "left_pectoral_rad"} for r in _rows()], HEALTHY, NO_LEFT)


def test_the_mission_video_is_720p_with_a_frame_every_fifth_of_a_second(tmp_path):
    report = {"damage": "left_pectoral_missing", "onset_s": 0.5, "alarm_s": 0.6, "recovered_s": 0.8,
              "preset": "smoke", "seed": 0}
    path = write_mission_video(_rows(11, onset_s=0.5), report, tmp_path / "mission", HEALTHY, NO_LEFT)
    assert path.parent == tmp_path and path.stem == "mission" and path.suffix in (".mp4", ".gif")
    frames = iio.imread(path, index=None, **({"plugin": "FFMPEG"} if path.suffix == ".mp4" else {}))
    assert frames.shape[:3] == (6, 720, 1280)  # 1 s, a frame every 0.2 s
