"""eea.replay: a run's experiments rebuilt from rounds.csv and config.json alone."""

import numpy as np
import pytest

from eea.checkpoint import load_state
from eea.experiment import Experiment
from eea.replay import replay_run
from eea.run import run


def test_rebuilt_experiments_equal_the_runs_bit_for_bit(tmp_path, tiny_config):
    run(tiny_config(inference="out_of_band", duration_s=0.32, rounds=3, seed=4), tmp_path, progress=False)
    result, experiments = replay_run(tmp_path)
    stored = [Experiment.from_state_dict(e) for e in load_state(tmp_path).experiments]
    assert len(experiments) == len(stored) == len(result.rounds) == 3
    for i, (mine, theirs) in enumerate(zip(experiments, stored)):
        assert mine.index == i
        np.testing.assert_array_equal(mine.imu_log, theirs.imu_log)
        np.testing.assert_array_equal(mine.summary, theirs.summary)
        np.testing.assert_array_equal(mine.action, theirs.action)
        np.testing.assert_array_equal(mine.true_angles, theirs.true_angles)
    # the run as it stood after round 2: its first two rows and experiments
    early, two = replay_run(tmp_path, rounds=2)
    assert early.rounds == result.rounds[:2] and len(two) == 2
    np.testing.assert_array_equal(two[1].imu_log, stored[1].imu_log)
    for bad in (0, 4):
        with pytest.raises(ValueError, match=rf"rounds must be 1..3 \(its finished rounds\), got {bad}"):
            replay_run(tmp_path, rounds=bad)


def test_replay_rejects_what_is_not_a_run(tmp_path):
    with pytest.raises(ValueError, match="not an EEA run directory"):
        replay_run(tmp_path / "nothing")
