"""aquafish.task_table: baselines on every task, measured on the same fresh starts."""

import json

import numpy as np
import pytest

from aquafish.task_table import BaselineBudget, format_table, task_table
from gait import RandomController, load_controller, rollout

TINY = BaselineBudget(neat_generations=1, neat_population=4, neat_episodes=1, ppo_timesteps=0)


def test_rows_are_the_returns_on_the_fresh_starts_and_learners_are_reused(tmp_path):
    rows = task_table(tmp_path, env_ids=["AquaFishHeading-v0"], budget=TINY, starts=2, eval_seed=50, progress=False)
    assert [(r["env_id"], r["learner"]) for r in rows] == [("AquaFishHeading-v0", "random policy"),
                                                            ("AquaFishHeading-v0", "NEAT")]
    random_row, neat_row = rows
    expected = [rollout(RandomController(0), seed=50 + k, env_id="AquaFishHeading-v0").episode_return for k in (0, 1)]
    assert random_row["returns"] == expected and random_row["return_mean"] == pytest.approx(np.mean(expected))
    neat = load_controller(tmp_path / "AquaFishHeading-v0" / "neat" / "best_controller.json")
    assert neat_row["returns"][1] == rollout(neat, seed=51, env_id="AquaFishHeading-v0").episode_return
    saved = json.loads((tmp_path / "task_table.json").read_text())
    assert saved["rows"] == rows and "| `AquaFishHeading-v0` | NEAT |" in (tmp_path / "task_table.md").read_text()
    # a second call reuses the trained NEAT controller: identical rows
    assert task_table(tmp_path, env_ids=["AquaFishHeading-v0"], budget=TINY, starts=2, eval_seed=50, progress=False) == rows


def test_bad_settings_raise(tmp_path):
    with pytest.raises(ValueError, match="unknown env id"):
        task_table(tmp_path, env_ids=["Swimmer-v5"], budget=TINY)
    with pytest.raises(ValueError, match="starts"):
        task_table(tmp_path, budget=TINY, starts=0)
    with pytest.raises(ValueError, match="ppo_timesteps"):
        BaselineBudget(ppo_timesteps=-1)


def test_format_table_has_one_line_per_row():
    row = {"env_id": "AquaFish-v0", "learner": "NEAT", "return_mean": 7.5, "return_std": 0.25, "distance_mean": 7.5,
           "train_wall_s": 90.0}
    text = format_table([row, row | {"learner": "random policy", "train_wall_s": 0.0}], 10)
    assert "| `AquaFish-v0` | NEAT | 7.50 ± 0.25 | 7.50 | 1.5 min |" in text
    assert "| `AquaFish-v0` | random policy | 7.50 ± 0.25 | 7.50 | - |" in text
