"""The recovery video: controllers side by side from above (gait.video)."""

import imageio.v3 as iio
import pytest

import gait.video
from gait import ConstantController
from gait.video import record_video, video_path


@pytest.mark.parametrize("mp4", [True, False])
def test_record_video_writes_720p_mp4_or_gif_fallback(tmp_path, monkeypatch, mp4):
    if mp4 and not gait.video.mp4_available():
        pytest.skip("imageio-ffmpeg (the [video] extra) is not installed")
    monkeypatch.setattr(gait.video, "mp4_available", lambda: mp4)
    monkeypatch.setattr(gait.video, "GIF_MAX_FRAMES", 3)  # a GIF keeps every 2nd of the 6 frames
    controllers = {"straight": ConstantController([0.5, 0.5, 1.0]), "turning": ConstantController([1.0, -1.0, 1.0])}
    path = record_video(controllers, "reversed_left_pectoral", tmp_path / "clip.anything", episode_duration_s=1.0,
                        frame_every=2, title="test")
    assert path == tmp_path / ("clip.mp4" if mp4 else "clip.gif") and path == video_path(tmp_path / "clip")
    assert not list(tmp_path.glob("*.partial*"))
    frames = iio.imread(path, index=None, **({"plugin": "FFMPEG"} if mp4 else {}))
    # 1 s at a frame every 2 control steps: t = 0, 0.2, ..., 1.0
    assert frames.shape[:3] == ((6, 720, 1280) if mp4 else (3, 720, 1280)) and frames.std() > 1
    if not mp4:  # every 2nd frame, shown twice as long: still 2x real time
        assert iio.immeta(path, index=0)["duration"] == 2 * 1000 / gait.video.VIDEO_FPS


def test_record_video_checks_its_arguments(tmp_path):
    with pytest.raises(ValueError, match="at least one"):
        record_video({}, "healthy", tmp_path / "x")
    with pytest.raises(ValueError, match="frame_every"):
        record_video({"a": ConstantController([0, 0, 0])}, "healthy", tmp_path / "x", frame_every=0)
    with pytest.raises(ValueError, match="fps"):
        record_video({"a": ConstantController([0, 0, 0])}, "healthy", tmp_path / "x", fps=0)
    with pytest.raises(ValueError, match="multiples of 16"):
        record_video({"a": ConstantController([0, 0, 0])}, "healthy", tmp_path / "x", size=(1280, 700))
    assert not list(tmp_path.iterdir())
