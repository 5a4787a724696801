"""eea.search.lineages: independent estimation lineages sharing each round's experiment, one selected per round."""

import csv

import numpy as np
import pytest

from aquafish_gym import get_damage
from eea.checkpoint import load_state
from eea.analysis.diagnosis import diagnose_run
from eea.encoding import MODEL_BITS, decode_models, encode_models
from eea.inference.selection import select_model
from eea.estimation import Estimation, EstimationResult
from eea.evaluation import Evaluator
from eea.experiment import Context
from eea.fitness import model_fitness_from_similarities, objective_fitness
from eea.inference import make_inference
from eea.search.lineages import (LineageStrategies, Lineages, chosen_inference_state, estimation_from_state,
                                 make_estimation)
from eea.analysis.lineage_report import lineage_objective_fitness
from eea.inference.profile import Profile
from eea.record import LINEAGE_COLUMNS, LINEAGES_FILE, MODEL_COLUMNS
from eea.run import run

TRUTH = encode_models(get_damage("left_pectoral_half").apply().to_array()[None])[0]
HEALTHY = encode_models(get_damage("none").apply().to_array()[None])[0]


@pytest.fixture
def experiments(lph_experiments):
    return lph_experiments


class FixedLineage:
    """An estimation stand-in whose search always ends at one model, with given angles as its contexts."""

    def __init__(self, genome, angles, ranked):
        self.genome, self.angles, self.ranked, self.seen = genome, np.asarray(angles, float), ranked, []

    def run(self, experiments, strategy, evaluator, rng, generations, on_generation=None):
        self.seen.append(tuple(experiments))
        exps = tuple(e.with_context(Context.exact(self.angles[e.index])) for e in experiments)
        return EstimationResult(exps, self.genome, 0.5)

    def ranked_models(self, limit=None, min_distance=0.0):
        return self.ranked if limit is None else self.ranked[:limit]


def test_the_truth_started_at_its_true_angles_scores_exactly_one(experiments):
    # select_model's start: the truth given its true angles keeps MOD_FIT 1 (eq. 2 of identical responses),
    # which no random start of a 1-generation fit reaches; the healthy robot stays below
    true = np.stack([e.true_angles for e in experiments])
    models = decode_models(np.stack([HEALTHY, TRUTH]))
    start = np.stack([np.zeros((2, 3)), true])
    evaluator = Evaluator(64)
    with_start = select_model(models, experiments, evaluator, np.random.default_rng(0), generations=1,
                              scan_cycles=0, start=start)
    assert with_start.index == 1 and with_start.model_fitness[1] == pytest.approx(1.0, abs=1e-12)
    assert with_start.model_fitness[0] < 0.99
    without = select_model(models, experiments, evaluator, np.random.default_rng(0), generations=1, scan_cycles=0)
    assert without.model_fitness[1] < with_start.model_fitness[1]
    # several start sets: the true angles in the second set are found as well as alone
    sets = np.stack([np.zeros_like(start), start])
    from_sets = select_model(models, experiments, evaluator, np.random.default_rng(0), generations=1,
                             scan_cycles=0, start=sets)
    assert from_sets.model_fitness[1] == pytest.approx(1.0, abs=1e-12)
    with pytest.raises(ValueError, match=r"start must be \(N, E, 3\) = \(2, 2, 3\) or \(S, N, E, 3\), "
                                         r"got \(2, 1, 3\)"):
        select_model(models, experiments, evaluator, np.random.default_rng(0), start=start[:, :1])


def test_the_round_model_is_the_lineage_whose_model_fits_best_under_an_equal_fit(experiments):
    true = np.stack([e.true_angles for e in experiments])
    wrong = FixedLineage(HEALTHY, np.zeros((2, 3)), HEALTHY[None])
    right = FixedLineage(TRUTH, true, TRUTH[None])
    lineages = Lineages([wrong, right], select_generations=1, select_scan_cycles=0)
    strategies = LineageStrategies([Profile(), Profile()])
    evaluator = Evaluator(64)
    # round 1 sees the first experiment, round 2 both: each lineage gets only the experiment new to it
    first = lineages.run(experiments[:1], strategies, evaluator, np.random.default_rng(1), 1)
    # as a run does: the experiments of round 1 come back with the chosen model's angles, then the new one
    second = lineages.run((*first.experiments, experiments[1]), strategies, evaluator, np.random.default_rng(1), 1)
    assert [len(s) for s in right.seen] == [1, 2] and [len(s) for s in wrong.seen] == [1, 2]
    # each lineage keeps its own context of the old experiment, not the chosen model's angles
    assert wrong.seen[1][0].context.estimate() == pytest.approx(np.zeros(3))
    assert right.seen[1][0].context.estimate() == pytest.approx(true[0])
    assert first.experiments[0].context.estimate() == pytest.approx(true[0])
    for result in (first, second):
        assert np.array_equal(result.best_genome, TRUTH)
        assert result.best_fitness == pytest.approx(1.0, abs=1e-12)
    # the returned experiments carry the chosen model's fitted angles, and MOD_FIT is eq. 3 under them
    angles = np.stack([e.context.estimate() for e in second.experiments])[None]
    sims = evaluator.similarities(TRUTH[None], experiments, angles)
    assert model_fitness_from_similarities(sims)[0] == pytest.approx(second.best_fitness)
    assert [h["chosen"] for h in lineages.history] == [1, 1]
    h = lineages.history[-1]
    assert h["selection_fitness"][1] > h["selection_fitness"][0] and list(h["model_fitness"]) == [0.5, 0.5]


def test_the_exploration_sees_every_lineage_best_first_and_each_model_once():
    a, b, c, d = (np.full(MODEL_BITS, v, dtype=np.uint8) for v in (0, 1, 0, 1))
    c[0], d[0] = 1, 0   # four distinct genomes
    one = FixedLineage(a, np.zeros((1, 3)), np.stack([a, c, b]))
    two = FixedLineage(b, np.zeros((1, 3)), np.stack([b, d]))
    ranked = Lineages([one, two]).ranked_models()
    np.testing.assert_array_equal(ranked, np.stack([a, b, c, d]))      # a, b | c, d | (b again: dropped)
    np.testing.assert_array_equal(Lineages([one, two]).ranked_models(limit=3), np.stack([a, b, c]))


def test_a_lineage_run_resumes_exactly_and_records_each_lineage(tiny_config, tmp_path):
    config = tiny_config(inference="profile", lineages=2, rounds=3)
    whole = run(config, tmp_path / "whole", progress=False)
    run(config.replace(rounds=2), tmp_path / "split", progress=False)
    resumed = run(config, tmp_path / "split", progress=False)
    for a, b in zip(whole.rounds, resumed.rounds):
        assert {k: v for k, v in a.items() if k != "wall_seconds"} == {k: v for k, v in b.items() if k != "wall_seconds"}
    state = load_state(tmp_path / "whole")
    history = state.estimation["history"]
    assert len(history) == 3 and len(state.inference["lineages"]) == 2
    for row, h in zip(whole.rounds, history):
        # the round's model is the chosen lineage's best, its MOD_FIT the selection's
        assert h["chosen"] == int(np.argmax(h["selection_fitness"]))
        chosen = decode_models(h["genomes"][h["chosen"]][None])[0]
        assert row["model_fitness"] == pytest.approx(h["selection_fitness"][h["chosen"]])
        np.testing.assert_allclose([row[k] for k in MODEL_COLUMNS], chosen)
    lineages = estimation_from_state(state.estimation, np.random.default_rng(0))
    assert isinstance(lineages, Lineages) and all(len(e) == 3 for e in lineages._experiments)
    # diagnose reads the chosen lineage's remembered angles
    chosen = history[-1]["chosen"]
    assert chosen_inference_state(state.estimation, state.inference) is state.inference["lineages"][chosen]
    diagnosis = diagnose_run(tmp_path / "whole", profile_generations=1, refine=1)
    assert diagnosis.true_proposed is not None and diagnosis.true_refined is not None
    # each lineage's OBJ_FIT (eq. 4) per round; the chosen column is rounds.csv's
    objective, picks = lineage_objective_fitness(tmp_path / "whole")
    assert objective.shape == (3, 2) and list(picks) == [h["chosen"] for h in history]
    truth = get_damage(config.damage).apply().to_array()
    assert objective[1, 0] == objective_fitness(decode_models(history[1]["genomes"][:1])[0], truth)
    assert [row["objective_fitness"] for row in whole.rounds] == list(objective[np.arange(3), picks])
    # lineages.csv records the same, exactly, so a run published without its checkpoint tells it too
    with open(tmp_path / "whole" / LINEAGES_FILE, newline="") as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == LINEAGE_COLUMNS and len(rows) == 3 * 2
    assert [int(r["chosen"]) for r in rows] == [int(lineage == h["chosen"]) for h in history for lineage in range(2)]
    assert [float(r["selection_fitness"]) for r in rows] == [f for h in history for f in h["selection_fitness"]]
    assert [float(r["model_fitness"]) for r in rows] == [f for h in history for f in h["model_fitness"]]
    (tmp_path / "whole" / "state.pkl").unlink()
    from_csv, csv_picks = lineage_objective_fitness(tmp_path / "whole")
    np.testing.assert_array_equal(from_csv, objective)
    np.testing.assert_array_equal(csv_picks, picks)
    assert (tmp_path / "split" / LINEAGES_FILE).read_text() == (tmp_path / "whole" / LINEAGES_FILE).read_text()
    (tmp_path / "cut").mkdir()
    (tmp_path / "cut" / LINEAGES_FILE).write_text("".join((tmp_path / "whole" / LINEAGES_FILE).read_text().splitlines(True)[:-1]))
    with pytest.raises(ValueError, match="has 5 rows, not 3 rounds x 2 lineages"):
        lineage_objective_fitness(tmp_path / "cut")
    with pytest.raises(ValueError, match="no lineages.csv and no checkpoint of a run with lineages >= 2"):
        lineage_objective_fitness(tmp_path / "nothing")


def test_one_lineage_is_the_plain_estimation_and_bad_lineages_raise(tiny_config):
    rng = np.random.default_rng(0)
    one, three = tiny_config(), tiny_config(lineages=3)
    assert type(make_estimation(one.estimation, one.ga, one.model_space, rng)) is Estimation
    assert isinstance(make_estimation(three.estimation, three.ga, three.model_space, rng), Lineages)
    with pytest.raises(ValueError, match="EEAConfig.lineages"):
        tiny_config(lineages=0)
    with pytest.raises(ValueError, match="at least 2 estimations, got 1"):
        Lineages([Estimation.from_settings(one.estimation, one.ga, one.model_space, rng)])
    with pytest.raises(ValueError, match="at least 2 strategies, got 1"):
        LineageStrategies([Profile()])
    with pytest.raises(ValueError, match="share one name"):
        LineageStrategies([Profile(), make_inference("none")])
    strategies = LineageStrategies([Profile(), Profile()])
    with pytest.raises(ValueError, match="2 states"):
        strategies.load_state_dict({"lineages": [{}]})
