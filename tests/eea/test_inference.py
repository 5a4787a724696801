"""Inference strategies: one contract for all, and the angles each one sends to the simulator."""

import numpy as np
import pytest

from eea.arc import in_arc
from eea.estimation import Estimation
from eea.evaluation import Evaluator
from eea.experiment import CAUDAL_LIMIT_RAD, Context
from eea.inference import INFERENCE_NAMES, INFERENCE_STRATEGIES, InBand, OutOfBand, make_inference

TWO_PI = 2 * np.pi


@pytest.fixture(params=INFERENCE_NAMES)
def strategy(request, tiny_config):
    config = tiny_config(inference=request.param)
    return make_inference(config.inference, config.ga)


def test_contract_every_strategy(strategy, make_experiment):
    """Same API test for every registered strategy (evosax-style registry fixture)."""
    rng = np.random.default_rng(0)
    exps = [make_experiment(0), make_experiment(1, true_angles=(6.0, 0.2, -0.3))]
    exps = tuple(e.with_context(strategy.new_context(e.true_angles)) for e in exps)
    assert all(isinstance(e.context, Context) for e in exps)
    given = exps
    exps = strategy.begin_round(exps)
    genomes = np.random.default_rng(1).integers(0, 2, (5, 45), dtype=np.uint8)
    with Evaluator(16) as ev:
        exps = strategy.before_generation(0, genomes[:4], exps, ev, rng, genomes=genomes)
    angles = strategy.angles(exps, genomes, rng)
    assert angles.shape == (5, 2, 3)
    assert np.all((angles[..., :2] >= 0) & (angles[..., :2] < TWO_PI)) and np.all(np.abs(angles[..., 2]) <= CAUDAL_LIMIT_RAD)
    exps = strategy.after_generation(np.zeros((5, 45), np.uint8), angles, np.arange(5.0), exps)
    exps = strategy.end_round(exps)
    assert len(exps) == 2 and exps[-1].context.confidence == 1.0      # every strategy ends a round locked in
    assert [e.index for e in exps] == [0, 1] and all(e.imu_log is g.imu_log for e, g in zip(exps, given))
    assert given[-1].context == strategy.new_context(given[-1].true_angles)   # the inputs were not modified
    assert strategy.angles([], np.zeros((3, 45), np.uint8), rng).shape == (3, 0, 3)


def test_registry_and_unknown_name():
    assert INFERENCE_NAMES == ("known", "none", "in_band", "out_of_band", "profile")
    assert all(cls.name == name for name, cls in INFERENCE_STRATEGIES.items())
    with pytest.raises(ValueError, match="valid names: known, none, in_band, out_of_band, profile"):
        make_inference("guess")


def test_known_and_none_contexts(make_experiment):
    truth = np.array([5.5, 0.25, -0.4])
    known, none = make_inference("known"), make_inference("none")
    three = np.zeros((3, 45), np.uint8)
    np.testing.assert_array_equal(known.angles([make_experiment(0, context=known.new_context(truth))], three,
                                               np.random.default_rng()), np.tile(truth, (3, 1, 1)))
    np.testing.assert_array_equal(none.angles([make_experiment(0, context=none.new_context(truth))], three,
                                              np.random.default_rng()), np.zeros((3, 1, 3)))


def test_in_band_arc_wraps_through_zero_and_locks(make_experiment):
    s = InBand(k_best=3, confidence=0.5)
    exps = [make_experiment(0, context=s.new_context(np.zeros(3)))]
    assert exps[0].context == Context.unknown(0.5)
    angles = np.zeros((5, 1, 3))
    angles[:, 0] = [[6.2, 3.0, 0.3], [0.1, 3.2, -0.2], [1.5, 1.0, 0.4], [0.05, 3.1, 0.0], [3.0, 5.0, 0.1]]
    fitness = np.array([0.9, 0.8, 0.1, 0.7, 0.2])      # best three: rows 0, 1, 3
    exps = s.after_generation(np.zeros((5, 45), np.uint8), angles, fitness, exps)
    ctx = exps[0].context
    assert ctx.starts[0] == pytest.approx(6.2) and ctx.widths[0] == pytest.approx(0.1 + TWO_PI - 6.2)  # 0.183, not 6.15
    assert ctx.starts[1] == pytest.approx(3.0) and ctx.widths[1] == pytest.approx(0.2)
    assert ctx.starts[2] == pytest.approx(-0.2) and ctx.widths[2] == pytest.approx(0.5)   # caudal: plain interval
    assert ctx.confidence == 0.5
    sampled = ctx.with_confidence(1.0).sample(np.random.default_rng(0), 300)
    assert np.all(in_arc(sampled[:, 0], 6.2, ctx.widths[0])) and sampled[:, 0].min() < 0.1
    exps = s.end_round(exps)
    assert exps[0].context.confidence == 1.0
    widened = InBand(3, 0.5, widen=0.2).infer_context(angles[[0, 1, 3], 0], 0.5)
    assert widened.widths[0] == pytest.approx(1.4 * (0.1 + TWO_PI - 6.2))
    assert widened.starts[2] == pytest.approx(-0.3)


class PeakedEvaluator:
    """Fake evaluator: similarity falls off with the circular distance to a known angle set."""

    def __init__(self, peak):
        self.peak, self.calls = np.asarray(peak), []

    def similarities(self, genomes, experiments, angles):
        self.calls.append((np.array(genomes), np.array(angles)))
        d = np.abs((angles - self.peak + np.pi) % TWO_PI - np.pi)
        return 1.0 - d.mean(axis=-1)


def test_out_of_band_finds_the_angles_that_best_explain_the_target(make_experiment):
    peak = [6.1, 0.2, -0.3]
    s = OutOfBand(period=35, sample=2, population=20, generations=15, bits=8)
    exps = [make_experiment(0), make_experiment(1, context=s.new_context(np.zeros(3)))]
    exps = s.begin_round(exps)
    fake = PeakedEvaluator(peak)
    models = np.random.default_rng(0).integers(0, 2, (6, 45), dtype=np.uint8)
    exps = s.before_generation(0, models, exps, fake, np.random.default_rng(1))
    assert len(fake.calls) == 15                                      # one batched evaluation per inner generation
    genomes, angles = fake.calls[0]
    assert genomes.shape == (20 * 2, 45) and angles.shape == (40, 1, 3)
    np.testing.assert_array_equal(genomes[:2], models[:2])            # the sample: the 2 best-ranked models
    np.testing.assert_array_equal(angles[0], angles[1])               # each candidate scored on every sample model
    est = exps[-1].context.estimate()
    assert exps[-1].context.confidence == 1.0 and exps[-1].context.widths == (0.0, 0.0, 0.0)
    assert np.abs((est - peak + np.pi) % TWO_PI - np.pi).max() < 0.25
    before = exps[-1].context
    exps = s.before_generation(34, models, exps, fake, np.random.default_rng(2))   # not a multiple of the period
    assert exps[-1].context == before and len(fake.calls) == 15
    exps = s.before_generation(35, models, exps, fake, np.random.default_rng(2))   # generation 35: infers again
    assert len(fake.calls) == 30
    first = fake.calls[15][1][::2, 0]
    assert np.any(np.all(np.abs(first - before.estimate()) < TWO_PI / 256, axis=1))  # seeded with current angles


def test_out_of_band_scores_the_candidate_angles_with_the_best_sample_models(make_experiment):
    """optAng's models are the ``sample`` best of the ranked models (all of them when fewer)."""
    models = np.eye(45, dtype=np.uint8)[:12]                          # 12 distinct models, row i has bit i
    fake = PeakedEvaluator([1.0, 1.0, 0.0])
    best = OutOfBand(period=1, sample=3, population=4, generations=1)
    exps = best.begin_round([make_experiment(0, context=best.new_context(np.zeros(3)))])
    best.before_generation(0, models, exps, fake, np.random.default_rng(3))
    np.testing.assert_array_equal(fake.calls[-1][0][:3], models[:3])       # the best 3
    best.before_generation(0, models[:2], exps, fake, np.random.default_rng(0))
    assert len(fake.calls[-1][0]) == 4 * 2                                  # fewer models than the sample: all


class PeakPerExperiment:
    """Fake evaluator: each experiment's similarity peaks at its own angle set (by index)."""

    def __init__(self, peaks):
        self.peaks, self.calls = np.asarray(peaks), []

    def similarities(self, genomes, experiments, angles):
        self.calls.append(np.array(angles))
        peaks = self.peaks[[e.index for e in experiments]]                  # (E, 3)
        d = np.abs((angles - peaks + np.pi) % TWO_PI - np.pi)
        return 1.0 - d.mean(axis=-1)                                         # (P, E)

def test_out_of_band_newest_never_touches_older_experiments(make_experiment):
    s = OutOfBand(period=10, sample=2, population=6, generations=3)
    old = Context.exact([0.5, 0.5, 0.0])
    exps = [make_experiment(0, context=old), make_experiment(1, context=s.new_context(np.zeros(3)))]
    fake = PeakPerExperiment([[3.0, 0.1, -0.3], [6.0, 2.0, 0.0]])
    exps = s.before_generation(0, np.zeros((2, 45), np.uint8), exps, fake, np.random.default_rng(1))
    assert exps[0].context == old and all(c.shape == (12, 1, 3) for c in fake.calls)


# -- what reaches the simulator ------------------------------------------------------


def _estimate(config, experiments, spy, generations=2):
    rng = np.random.default_rng(0)
    strategy = make_inference(config.inference, config.ga)
    estimation = Estimation.from_settings(config.estimation, config.ga, config.model_space, rng)
    with Evaluator(16) as ev:
        return estimation.run(experiments, strategy, ev, rng, generations).experiments


def _angles_by_action(spy, action):
    angles = np.concatenate([c["initial_angles"] for c in spy.calls])
    actions = np.concatenate([c["actions"] for c in spy.calls])
    return angles[np.all(actions == action, axis=1)]


def test_known_sends_the_true_angles(tiny_config, simulator_spy, make_experiment):
    exps = [make_experiment(0, action=(0.1, 0.1, 0.1), true_angles=(5.9, 0.4, -0.2)),
            make_experiment(1, action=(0.2, 0.2, 0.2), true_angles=(0.7, 3.3, 0.3))]
    _estimate(tiny_config(inference="known"), exps, simulator_spy)
    for e in exps:
        sent = _angles_by_action(simulator_spy, e.action)
        assert len(sent) > 0
        np.testing.assert_allclose(sent, np.tile(e.true_angles, (len(sent), 1)), atol=1e-6)


def test_none_sends_the_zero_state(tiny_config, simulator_spy, make_experiment):
    exps = [make_experiment(0, true_angles=(5.9, 0.4, -0.2))]
    exps = [exps[0].with_context(make_inference("none").new_context(exps[0].true_angles))]
    _estimate(tiny_config(inference="none"), exps, simulator_spy)
    sent = np.concatenate([c["initial_angles"] for c in simulator_spy.calls])
    assert len(sent) > 0 and np.all(sent == 0.0)


def test_in_band_sends_locked_ranges_and_samples_the_newest(tiny_config, simulator_spy, make_experiment):
    locked = Context((6.0, 1.0, -0.1), (0.5, 0.2, 0.1), 1.0)             # an earlier round's arc, wraps through 0
    exps = [make_experiment(0, action=(0.1, 0.1, 0.1), context=locked),
            make_experiment(1, action=(0.2, 0.2, 0.2), context=Context.unknown(0.5))]
    inferred = _estimate(tiny_config(inference="in_band", estimation_population=20), exps, simulator_spy, generations=3)
    old = _angles_by_action(simulator_spy, exps[0].action)
    assert np.all(in_arc(old[:, 0], 6.0, 0.5, atol=2e-6)) and np.all(in_arc(old[:, 1], 1.0, 0.2, atol=2e-6))
    assert np.all((old[:, 2] >= -0.1 - 1e-6) & (old[:, 2] <= 1e-6))
    new = _angles_by_action(simulator_spy, exps[1].action)
    assert len(np.unique(new[:, 0])) == len(new)                          # sampled, never a fixed point
    ctx = inferred[1].context
    assert ctx.confidence == 1.0 and ctx.widths[0] < TWO_PI               # an arc was inferred, then locked


def test_out_of_band_sends_the_inferred_angles(tiny_config, simulator_spy, make_experiment):
    exps = [make_experiment(0, action=(0.1, 0.1, 0.1)),
            make_experiment(1, action=(0.2, 0.2, 0.2), context=OutOfBand().new_context(np.zeros(3)))]
    config = tiny_config(inference="out_of_band", oob_period=5, oob_bits=4)
    inferred = _estimate(config, exps, simulator_spy, generations=2)
    sent = _angles_by_action(simulator_spy, exps[1].action)
    grid = TWO_PI / 16
    assert np.allclose(np.round(sent[:, :2] / grid) * grid, sent[:, :2], atol=1e-6)   # candidates on the 4-bit grid
    best = inferred[1].context.estimate()
    last_call = simulator_spy.calls[-1]                                    # the final estimation generation
    rows = np.all(last_call["actions"] == exps[1].action, axis=1)
    assert rows.any()                                                      # new children (cached rows are not re-sent)
    np.testing.assert_allclose(last_call["initial_angles"][rows], np.tile(best, (rows.sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(_angles_by_action(simulator_spy, exps[0].action),
                               np.tile(exps[0].true_angles, (len(_angles_by_action(simulator_spy, exps[0].action)), 1)),
                               atol=1e-6)
