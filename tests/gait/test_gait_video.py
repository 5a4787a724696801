"""The recovery video: controllers side by side from above (gait.video)."""

import imageio.v3 as iio
import numpy as np
import pytest

import gait.video
from gait import ConstantController
from gait.video import record_video, video_path


@pytest.mark.parametrize("mp4", [True, False])
def test_record_video_writes_mp4_or_gif_fallback(tmp_path, monkeypatch, mp4):
    if mp4 and not gait.video.mp4_available():
        pytest.skip("imageio-ffmpeg (the [video] extra) is not installed")
    monkeypatch.setattr(gait.video, "mp4_available", lambda: mp4)
    controllers = {"straight": ConstantController([0.5, 0.5, 1.0]), "turning": ConstantController([1.0, -1.0, 1.0])}
    path = record_video(controllers, "reversed_left_pectoral", tmp_path / "clip.anything", episode_duration_s=1.0,
                        frame_every=2, panel_px=64, title="test")
    assert path == tmp_path / ("clip.mp4" if mp4 else "clip.gif") and path == video_path(tmp_path / "clip")
    frames = iio.imread(path, index=None, **({"plugin": "FFMPEG"} if mp4 else {}))
    assert frames.shape[0] == 10 // 2 + 1 + 1 or frames.shape[0] >= 5  # a frame every 2 steps and the last
    assert frames.shape[1] % 16 == 0 and frames.shape[2] % 16 == 0 and frames.std() > 1


def test_record_video_needs_controllers(tmp_path):
    with pytest.raises(ValueError, match="at least one"):
        record_video({}, "healthy", tmp_path / "x")
    with pytest.raises(ValueError, match="frame_every"):
        record_video({"a": ConstantController([0, 0, 0])}, "healthy", tmp_path / "x", frame_every=0)
