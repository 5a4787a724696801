"""The independent oracle gait (aquafish.oracle): seeds apart from the procedure's, the budget,
the choice of the best run."""

from types import SimpleNamespace

import pytest

from aquafish import oracle
from aquafish.case_study import PRESETS, run_case_study
from aquafish.oracle import (ORACLE_BUDGET_FACTOR, ORACLE_RUNS, PROCEDURE_SEED_LIMIT, SELECTION_EPISODES,
                             SELECTION_SEED, check_procedure_seed, neat_budget, oracle_seeds, select_oracle)
from gait.robots import Robot


def test_no_seed_a_procedure_derives_meets_an_oracle_seed():
    # a procedure of seed s draws its starts and evaluation episodes from s, s + 1, ... (fewer than 1,000)
    highest = check_procedure_seed(PROCEDURE_SEED_LIMIT - 1) + 999
    runs = oracle_seeds()
    assert len(runs) == ORACLE_RUNS >= 3 and len(set(runs)) == ORACLE_RUNS
    assert min(runs) > highest and SELECTION_SEED > highest
    # each run's starts (as many as a paper-budget gait's), and the selection's, stay apart
    episodes = [set(range(s, s + PRESETS["paper"].gait_episodes)) for s in runs]
    episodes.append(set(range(SELECTION_SEED, SELECTION_SEED + SELECTION_EPISODES)))
    assert sum(map(len, episodes)) == len(set().union(*episodes))
    assert max(runs) < 2 ** 32 and SELECTION_SEED + SELECTION_EPISODES < 2 ** 32  # NumPy's global seed


@pytest.mark.parametrize("seed", [PROCEDURE_SEED_LIMIT, -1, 2.0, True])
def test_a_procedure_seed_that_could_meet_the_oracles_is_refused(seed, tmp_path):
    with pytest.raises(ValueError, match="seed"):
        check_procedure_seed(seed)
    with pytest.raises(ValueError, match="seed"):
        run_case_study("smoke", "reversed_left_pectoral", seed, tmp_path / "cs")
    assert not (tmp_path / "cs").exists()


def test_the_budget_is_the_product_and_the_oracle_has_the_factor_more_generations():
    assert neat_budget(12, 30, 2) == {"generations": 12, "population": 30, "starts": 2, "episodes": 720}
    assert ORACLE_BUDGET_FACTOR >= 3


def test_the_best_run_on_its_own_starts_is_the_oracle_and_a_tie_goes_to_the_first(monkeypatch):
    calls = []

    def fake_score(controller, native, target, *, seed, episodes, episode_duration_s):
        calls.append((seed, episodes, episode_duration_s))
        return SimpleNamespace(target_distance=controller)

    monkeypatch.setattr(oracle.gait, "score_transfer", fake_score)
    robot = Robot.__new__(Robot)
    chosen = select_oracle([3.0, 7.5, 7.5], robot, 60.0, generations=12, population=30, starts=2)  # the procedure's
    assert chosen.chosen == 1 and chosen.controller == 7.5
    assert calls == [(SELECTION_SEED, SELECTION_EPISODES, 60.0)] * 3
    record = chosen.record()
    assert record["budget"] == {"generations": 36, "population": 30, "starts": 2, "episodes": 2160, "runs": 3}
    assert record["seeds"] == oracle_seeds() and record["selection"]["distances"] == [3.0, 7.5, 7.5]
    with pytest.raises(ValueError, match="3 runs"):
        select_oracle([1.0, 2.0], robot, 20.0, generations=3, population=6, starts=1)
