"""Transfer scoring (Figure 12): native vs target distances and trajectories."""

import json

import numpy as np
import pytest
from gait_helpers import SHORT_S

from aquafish_gym import Morphology
from gait import evolve_gait, plot_transfer, rollout, save_transfer, score_transfer


def test_transfer_to_own_morphology_gives_native_score(tmp_path):
    result = evolve_gait(None, generations=2, population_size=4, seed=2, workers=1, episode_duration_s=SHORT_S, verbose=False)
    t = score_transfer(result.best_controller, Morphology.healthy(), "healthy", seed=2, episode_duration_s=SHORT_S)
    assert t.native_distance == t.target_distance == result.best_fitness
    np.testing.assert_array_equal(t.native_trajectory, t.target_trajectory)
    assert t.transfer_ratio == pytest.approx(1.0)


def test_transfer_to_damaged_target(controller, tmp_path):
    t = score_transfer(controller, "healthy", "left_pectoral_half", seed=1, episode_duration_s=SHORT_S)
    assert t.target.damage == "left_pectoral_half" and t.native.damage == "none"
    np.testing.assert_array_equal(t.native_rollout.initial_angles, t.target_rollout.initial_angles)
    assert t.target_distance == rollout(controller, "left_pectoral_half", seed=1, episode_duration_s=SHORT_S).distance
    assert t.native_distance != t.target_distance
    assert t.native_trajectory.shape == t.target_trajectory.shape == (21, 2)

    png = plot_transfer([t, t], tmp_path / "fig12.png", titles=["(a)", "(b)"])
    assert png.stat().st_size > 1000
    # 4.2 x 4.4 inches per panel at 120 dpi; six panels wrap to two rows of four
    import matplotlib.image
    assert matplotlib.image.imread(png).shape[:2] == (528, 1008)
    assert matplotlib.image.imread(plot_transfer([t] * 6, tmp_path / "six.png")).shape[:2] == (1056, 2016)
    data = json.loads(save_transfer([t], tmp_path / "t.json").read_text())
    assert data[0]["target_distance"] == t.target_distance
    assert len(data[0]["target_trajectory"]) == 21


def test_several_episodes_pair_starts_and_average(controller):
    t = score_transfer(controller, "healthy", "left_pectoral_half", seed=3, episodes=3, episode_duration_s=SHORT_S)
    assert t.episodes == 3
    for k in range(3):  # episode k: seed 3 + k on both robots, the same initial angles
        np.testing.assert_array_equal(t.native_rollouts[k].initial_angles, t.target_rollouts[k].initial_angles)
        alone = rollout(controller, "left_pectoral_half", seed=3 + k, episode_duration_s=SHORT_S).distance
        # the episodes run at once on one vector env: episode 0 exact, the others to round-off
        assert t.target_distances[k] == alone if k == 0 else t.target_distances[k] == pytest.approx(alone, abs=1e-9)
    assert len({tuple(r.initial_angles) for r in t.native_rollouts}) == 3
    assert t.native_distance == pytest.approx(t.native_distances.mean())
    assert t.target_distance == pytest.approx(sum(t.target_distances) / 3)
    np.testing.assert_array_equal(t.target_trajectory, t.target_rollouts[0].trajectory)
    assert t.to_dict()["target_distances"] == t.target_distances.tolist()


@pytest.mark.parametrize("kw, match", [({"episodes": 0}, "episodes"), ({"episodes": 2, "initial_angles": [0, 0, 0]}, "fixed")])
def test_bad_episode_counts_raise(controller, kw, match):
    with pytest.raises(ValueError, match=match):
        score_transfer(controller, "healthy", "healthy", episode_duration_s=0.5, **kw)


def test_plot_transfer_errors(controller, tmp_path):
    t = score_transfer(controller, "healthy", "healthy", episode_duration_s=0.5)
    with pytest.raises(ValueError, match="no transfer results"):
        plot_transfer([], tmp_path / "x.png")
    with pytest.raises(ValueError, match="one entry per result"):
        plot_transfer([t], tmp_path / "x.png", titles=["a", "b"])
