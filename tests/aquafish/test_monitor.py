"""The damage monitor (aquafish.monitor): streaming alarm, healthy range, calibration file."""

import json
from pathlib import Path

import numpy as np
import pytest

from aquafish.monitor import (CALIBRATION_FILE, DamageMonitor, MonitorCalibration, calibrate, healthy_range,
                              window_means)

ROOT = Path(__file__).parents[2]


def _calibration(**kw):
    """Window 1 s (10 samples), warm-up 0.5 s (5 samples), range [0.6, 0.8] units/s."""
    fields = dict(lower=0.6, upper=0.8, median=0.7, window_s=1.0, warmup_s=0.5)
    return MonitorCalibration(**(fields | kw))


def _obs(speed):
    obs = np.zeros(12)
    obs[10] = speed
    return obs


def test_constant_healthy_speed_raises_no_alarm():
    monitor = DamageMonitor(_calibration())
    assert not any(monitor.update(_obs(0.7), {"time_s": 0.1 * k}) for k in range(1000))
    assert monitor.last_mean == pytest.approx(0.7) and monitor.alarm_time_s is None


def test_warm_up_at_rest_raises_no_alarm():
    monitor = DamageMonitor(_calibration())
    # 5 samples at rest are skipped, then healthy swimming
    assert not any(monitor.update(_obs(0.0 if k < 5 else 0.7)) for k in range(100))


def test_speed_drop_alarms_within_the_window():
    monitor = DamageMonitor(_calibration())
    for k in range(50):
        assert not monitor.update(_obs(0.7), {"time_s": 0.1 * k})
    # a drop to 0.4 at sample 50: the 10-sample mean is 0.7 - 0.03 j after j low samples, below
    # 0.6 from j = 4 on (0.58), so the alarm comes at sample 53, within the 10-sample window
    raised = [monitor.update(_obs(0.4), {"time_s": 0.1 * k}) for k in range(50, 60)]
    assert raised == [False] * 3 + [True] * 7
    assert monitor.alarm_time_s == pytest.approx(5.3)
    assert monitor.update(_obs(0.7))  # latched
    monitor.reset()
    assert not monitor.alarm and monitor.alarm_time_s is None and monitor.last_mean is None


def test_speed_above_the_range_alarms_too():
    monitor = DamageMonitor(_calibration())
    assert any(monitor.update(_obs(0.9)) for _ in range(15))


def test_window_means():
    np.testing.assert_allclose(window_means([1.0, 2.0, 3.0, 6.0], 2), [1.5, 2.5, 4.5])
    with pytest.raises(ValueError, match="window"):
        window_means([1.0], 2)


def test_healthy_range_is_the_hand_computed_quantile_and_margin():
    values = np.arange(11.0)  # 0 .. 10: median 5; quantile 0.1 -> 1 and 9
    assert healthy_range(values, quantile=0.0, margin=0.0) == (0.0, 5.0, 10.0)
    assert healthy_range(values, quantile=0.1, margin=0.5) == pytest.approx((1 - 0.5 * 4, 5.0, 9 + 0.5 * 4))
    assert healthy_range([0.70, 0.72, 0.66], quantile=0.0, margin=0.25) == pytest.approx(
        (0.66 - 0.25 * 0.04, 0.70, 0.72 + 0.25 * 0.02))


@pytest.mark.parametrize("kwargs, match", [
    (dict(values=[]), "values"), (dict(values=[np.nan]), "values"), (dict(values=[1.0], quantile=0.5), "quantile"),
    (dict(values=[1.0], quantile=-0.1), "quantile"), (dict(values=[1.0], margin=-1), "margin"),
    (dict(values=[1.0], margin=True), "margin")])
def test_healthy_range_refuses_bad_inputs(kwargs, match):
    with pytest.raises(ValueError, match=match):
        healthy_range(**kwargs)


def test_calibration_json_round_trip(tmp_path):
    cal = _calibration(episodes=2, seeds=(3, 4), episode_duration_s=60.0, robot={"label": "healthy"})
    data = json.loads(json.dumps(cal.to_dict()))
    assert data["format"] == "aquafish damage monitor calibration" and data["signal"] == "forward_speed"
    again = MonitorCalibration.from_dict(data)
    assert again == cal and again.robot == {"label": "healthy"} and again.seeds == (3, 4)
    path = cal.save(tmp_path)  # a directory: beside the self-model
    assert path == tmp_path / CALIBRATION_FILE
    assert MonitorCalibration.load(tmp_path) == cal
    assert (cal.window, cal.warmup) == (10, 5)


@pytest.mark.parametrize("data, match", [
    ({"format": "other"}, "not a damage monitor calibration"),
    (_calibration().to_dict() | {"version": 99}, "version"),
    (_calibration().to_dict() | {"extra": 1}, "unknown"),
    ({k: v for k, v in _calibration().to_dict().items() if k != "lower"}, "missing")])
def test_calibration_from_dict_refuses_other_data(data, match):
    with pytest.raises(ValueError, match=match):
        MonitorCalibration.from_dict(data)


@pytest.mark.parametrize("kwargs, match", [
    (dict(lower=0.9), "lower must be <= upper"), (dict(upper=np.inf), "upper"), (dict(window_s=0), "window_s"),
    (dict(window_s=0.01), "at least one control period"), (dict(warmup_s=-1), "warmup_s")])
def test_calibration_refuses_bad_fields(kwargs, match):
    with pytest.raises(ValueError, match=match):
        _calibration(**kwargs)


def test_monitor_refuses_bad_inputs():
    with pytest.raises(ValueError, match="calibration"):
        DamageMonitor({"lower": 0})
    monitor = DamageMonitor(_calibration())
    with pytest.raises(ValueError, match="observation"):
        monitor.update(np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        monitor.update(_obs(np.nan))


@pytest.mark.parametrize("kwargs, match", [
    (dict(seeds=[]), "seeds"), (dict(seeds=[1, 1]), "seeds"), (dict(seeds=[-1]), "seeds"),
    (dict(window_s=-1.0), "window_s"), (dict(warmup_s=np.nan), "warmup_s"),
    (dict(episode_duration_s=5.0), "episode_duration_s"), (dict(quantile=0.7), "quantile"),
    (dict(margin=-0.1), "margin")])
def test_calibrate_refuses_bad_inputs(kwargs, match):
    from gait.controller import ConstantController

    with pytest.raises(ValueError, match=match):
        calibrate(ConstantController([0, 0, 1]), **({"seeds": [0]} | kwargs))


def test_reversed_servo_alarms_after_the_onset_not_before():
    """End to end: the shipped healthy NEAT gait, calibrated on six short healthy episodes,
    watches a mission whose left pectoral servo reverses at 20 s (the robot then swims at half
    its speed, docs/main_job.md "Noticing damage")."""
    import gymnasium as gym

    from gait import load_controller

    gait = load_controller(ROOT / "docs/results/damage_monitor")
    cal = calibrate(gait, "healthy", seeds=range(6), window_s=6.0, warmup_s=6.0, episode_duration_s=40.0)
    monitor = DamageMonitor(cal)
    env = gym.make("AquaFish-v0", damage="reversed_left_pectoral", damage_onset_s=20.0, episode_duration_s=32.0)
    gait.reset()
    obs, info = env.reset(seed=50)
    alarms = [(info["time_s"], monitor.update(obs, info))]
    done = False
    while not done:
        obs, _, _, done, info = env.step(gait.act(obs, info["time_s"]))
        alarms.append((info["time_s"], monitor.update(obs, info)))
    env.close()
    assert not any(alarm for t, alarm in alarms if t <= 20.0)
    assert monitor.alarm and 20.0 < monitor.alarm_time_s <= 30.0
