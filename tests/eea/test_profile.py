"""eea.inference.profile: every model finds and keeps its own best initial angles."""

import numpy as np
import pytest

import eea
from eea.inference.profile import Profile

TWO_PI = 2 * np.pi


class PeakPerModel:
    """Fake evaluator: model m's similarity in experiment e peaks at angles that depend on m and e."""

    def __init__(self):
        self.rows = 0

    def peak(self, genome, index):
        seed = int(genome[:8].dot(1 << np.arange(8))) * 7 + index
        rng = np.random.default_rng(seed)
        return np.array([rng.uniform(0, TWO_PI), rng.uniform(0, TWO_PI), rng.uniform(-0.5, 0.5)])

    def similarities(self, genomes, experiments, angles):
        self.rows += len(genomes) * len(experiments)
        out = np.empty((len(genomes), len(experiments)))
        for i, g in enumerate(genomes):
            for j, e in enumerate(experiments):
                d = np.abs((angles[i, j] - self.peak(g, e.index) + np.pi) % TWO_PI - np.pi)
                out[i, j] = 1.0 - d.mean() / np.pi
        return out


def test_each_model_climbs_to_its_own_angles_and_scores_only_rise(make_experiment):
    s = Profile(proposals=3, initial=8)
    exps = (make_experiment(0), make_experiment(1))
    genomes = np.random.default_rng(0).integers(0, 2, (4, 45), dtype=np.uint8)
    fake = PeakPerModel()
    rng = np.random.default_rng(1)
    history = []
    for generation in range(40):
        exps = s.before_generation(generation, genomes, exps, fake, rng, genomes=genomes)
        angles = s.angles(exps, genomes, rng)
        scores = fake.similarities(genomes, exps, angles)
        history.append(scores)
        exps = s.after_generation(genomes, angles, scores.mean(axis=1), exps)
    history = np.array(history)
    assert np.all(np.diff(history, axis=0) >= 0)                 # a model's remembered angles never get worse
    assert history[-1].min() > 0.97                              # every model near its own peak
    for m, g in enumerate(genomes):                              # ... and the peaks differ between models
        for e in exps:
            err = np.abs((angles[m, e.index] - fake.peak(g, e.index) + np.pi) % TWO_PI - np.pi)
            assert err.max() < 0.15
    best = int(np.argmax(history[-1].mean(axis=1)))
    np.testing.assert_array_equal(exps[1].context.estimate(), angles[best, 1])   # contexts: the best model's


def test_a_new_model_inherits_its_nearest_parent_angles(make_experiment):
    s = Profile(proposals=1, initial=4)
    exps = (make_experiment(0),)
    parent = np.zeros((1, 45), np.uint8)
    fake = PeakPerModel()
    rng = np.random.default_rng(0)
    for g in range(30):
        exps = s.before_generation(g, parent, exps, fake, rng, genomes=parent)
    remembered = s.angles(exps, parent, rng)
    child = parent.copy()
    child[0, 44] = 1                                              # differs in a bit the fake ignores: same peak
    rows = fake.rows
    s.before_generation(30, child, exps, fake, rng, genomes=child)
    assert fake.rows - rows <= 2 + 1                              # inherited angles scored, proposals; no random starts
    child_angles = s.angles(exps, child, rng)
    assert fake.similarities(child, exps, child_angles)[0, 0] >= fake.similarities(parent, exps, remembered)[0, 0]


def _trained_on_one_parent(make_experiment, fake_class=PeakPerModel):
    """Two experiments, the all-zero parent, a fake evaluator and a Profile that has fitted
    the parent's angles for 30 generations (the state later Profiles start from)."""
    exps = (make_experiment(0), make_experiment(1))
    parent = np.zeros((1, 45), np.uint8)
    fake = fake_class()
    trained = Profile(proposals=2, initial=4)
    rng = np.random.default_rng(0)
    for g in range(30):
        exps = trained.before_generation(g, parent, exps, fake, rng, genomes=parent)
    return exps, parent, fake, trained, rng


def test_contender_refinement_climbs_only_the_fittest_new_model(make_experiment):
    exps, parent, fake, trained, rng = _trained_on_one_parent(make_experiment)
    children = np.repeat(parent, 3, axis=0)
    children[1, 0], children[2, 1] = 1, 1                         # bits the fake reads: their own peaks
    results = {}
    for refine in (0, 25):
        s = Profile(proposals=2, initial=4, refine=refine, contenders=1)
        s.load_state_dict(trained.state_dict())
        rows = fake.rows
        s.before_generation(30, children, exps, fake, np.random.default_rng(5), genomes=children)
        angles = s.angles(exps, children, rng)
        results[refine] = (fake.rows - rows, fake.similarities(children, exps, angles).mean(axis=1))
    (rows0, fit0), (rows25, fit25) = results[0], results[25]
    assert rows25 - rows0 == 25 * 2 * len(exps)                  # K R proposals E extra simulations
    newcomer = 1 + int(np.argmax(fit0[1:]))                       # the fittest new model before refinement
    assert fit25[newcomer] > max(fit0[newcomer], 0.97)            # ... climbs near its own peak
    others = [m for m in range(3) if m != newcomer]               # the incumbent and the other newcomer: untouched
    np.testing.assert_array_equal(fit25[others], fit0[others])

def test_starting_angles_are_own_then_nearest_remembered_then_random():
    s = Profile()
    near, far = np.zeros(45, np.uint8), np.ones(45, np.uint8)
    a_near, a_far = np.full((2, 3), 0.25), np.full((2, 3), 1.5)
    s.load_state_dict({"memory": {near.tobytes(): (a_near, np.ones(2)), far.tobytes(): (a_far, np.ones(2))}})
    newcomer = near.copy()
    newcomer[:3] = 1                                              # 3 bits from `near`, 42 from `far`
    rng = np.random.default_rng(0)
    got = s.starting_angles(np.stack([far, newcomer]), 3, rng)    # a third experiment nobody has angles for
    assert got.shape == (2, 3, 3)
    np.testing.assert_array_equal(got[0, :2], a_far)              # its own
    np.testing.assert_array_equal(got[1, :2], a_near)             # the nearest remembered model's
    assert not np.allclose(got[:, 2], got[0, 0])                  # new experiment: drawn, not copied
    assert np.all((got[:, 2, :2] >= 0) & (got[:, 2, :2] < TWO_PI))

def test_the_library_keeps_the_best_sets_at_least_the_spacing_apart():
    from eea.inference.profile import LIBRARY_SPACING_RAD
    s = Profile(library=3)
    sets = np.array([[0.0, 0.0, 0.0],          # best
                     [0.3, 0.1, 0.0],          # within 0.5 rad of it: dropped
                     [6.2, 1.0, 0.0],          # 1.0 away on the right pectoral (0.08 on the left, across 2 pi)
                     [0.0, 0.0, 0.2],          # caudal 0.2 counts 0.6: kept
                     [3.0, 3.0, 0.0]])         # 4th best of the spaced ones: over L
    scores = np.array([0.99, 0.98, 0.97, 0.96, 0.95])
    s._add_to_library(sets[:, None, None], scores[:, None, None])   # (C, U = 1, E = 1, 3)
    angles, sims = s.library_sets(0)
    np.testing.assert_array_equal(angles, sets[[0, 2, 3]])
    np.testing.assert_array_equal(sims, scores[[0, 2, 3]])
    s._add_to_library(np.array([[[[0.1, 0.0, 0.0]]], [[[3.0, 3.0, 0.0]]]]), np.array([[[0.995]], [[0.975]]]))
    angles, sims = s.library_sets(0)                                   # a better set displaces its near neighbour
    np.testing.assert_array_equal(angles, [[0.1, 0.0, 0.0], [3.0, 3.0, 0.0], [6.2, 1.0, 0.0]])
    assert LIBRARY_SPACING_RAD == 0.5 and s.library_sets(1)[0].shape == (0, 3)


def test_a_contender_tries_every_library_set_before_its_refinement(make_experiment):
    exps, parent, fake, trained, rng = _trained_on_one_parent(make_experiment)
    child = parent.copy()
    child[0, 2] = 1                                               # its own peaks, far from the parent's
    peaks = np.stack([fake.peak(child[0], e.index) for e in exps])
    state = trained.state_dict()
    decoy = np.array([1.0, 1.0, 0.0])
    state["library"] = [(np.stack([peaks[e], decoy]), np.array([0.9, 0.8])) for e in range(len(exps))]
    results = {}
    for library in (0, 2):
        s = Profile(proposals=2, initial=4, refine=1, contenders=1, library=library)
        s.load_state_dict(state)
        rows = fake.rows
        s.before_generation(30, child, exps, fake, np.random.default_rng(5), genomes=child)
        results[library] = (fake.rows - rows, fake.similarities(child, exps, s.angles(exps, child, rng)).mean())
    (rows0, fit0), (rows2, fit2) = results[0], results[2]
    assert rows2 - rows0 == 1 * 2 * len(exps)                    # K L E more simulations
    assert fit2 > 0.999 > 0.9 > fit0                             # the library held its peaks; inherited angles did not

@pytest.mark.parametrize("library", [0, 3])
def test_profile_run_resumes_exactly(tmp_path, tiny_config, library):
    import csv
    config = tiny_config(inference="profile", rounds=3, profile_proposals=1, profile_initial=2,
                         profile_refine=2 if library else 0, profile_library=library)
    eea.run(config, tmp_path / "straight", progress=False)
    eea.run(config.replace(rounds=2), tmp_path / "resumed", progress=False)
    eea.run(config, tmp_path / "resumed", progress=False)

    def rows(d):
        with open(tmp_path / d / "rounds.csv", newline="") as f:
            return [{k: v for k, v in r.items() if k != "wall_seconds"} for r in csv.DictReader(f)]
    assert rows("straight") == rows("resumed") and len(rows("straight")) == 3


def test_bad_settings_raise(tiny_config):
    with pytest.raises(ValueError, match="proposals"):
        Profile(proposals=0)
    with pytest.raises(ValueError, match="refine >= 0"):
        Profile(refine=-1)
    with pytest.raises(ValueError, match="profile_contenders"):
        tiny_config(inference="profile", profile_contenders=0)
    with pytest.raises(ValueError, match="profile_initial"):
        tiny_config(inference="profile", profile_initial=0)
    with pytest.raises(ValueError, match="unknown keys"):
        Profile().load_state_dict({"memo": {}})
    with pytest.raises(ValueError, match="Profile library must be an int >= 0"):
        Profile(library=-1)
    with pytest.raises(ValueError, match="profile_library"):
        tiny_config(inference="profile", profile_library=-1)


def test_fit_finds_each_models_own_peak_and_keeps_a_perfect_start(make_experiment):
    exps = (make_experiment(0), make_experiment(1), make_experiment(2))
    genomes = np.random.default_rng(3).integers(0, 2, (3, 45), dtype=np.uint8)
    fake = PeakPerModel()
    angles, fitness = Profile(proposals=3, initial=8).fit(genomes, exps, fake, np.random.default_rng(0), 40)
    assert angles.shape == (3, 3, 3) and fitness.shape == (3,)
    # fitness is eq. 3 of the returned angles, and every model sits near its own peak
    np.testing.assert_allclose(fitness, fake.similarities(genomes, exps, angles).mean(axis=1))
    assert fitness.min() > 0.97
    # a start at the exact peaks scores 1 and is kept whatever the search tries after it
    peaks = np.array([[fake.peak(g, e.index) for e in exps] for g in genomes])
    peaks[..., :2] %= TWO_PI
    angles, fitness = Profile(proposals=3, initial=8).fit(genomes, exps, fake, np.random.default_rng(0), 5, start=peaks)
    np.testing.assert_array_equal(fitness, 1.0)
    np.testing.assert_array_equal(angles, peaks)


def test_fit_rejects_bad_input(make_experiment):
    genomes = np.zeros((2, 45), np.uint8)
    with pytest.raises(ValueError, match="distinct genomes"):
        Profile().fit(genomes, (make_experiment(0),), PeakPerModel(), np.random.default_rng(0), 1)
    with pytest.raises(ValueError, match="at least one experiment"):
        Profile().fit(genomes[:1], (), PeakPerModel(), np.random.default_rng(0), 1)
    with pytest.raises(ValueError, match="generations must be >= 1"):
        Profile().fit(genomes[:1], (make_experiment(0),), PeakPerModel(), np.random.default_rng(0), 0)


class CappedPeaks(PeakPerModel):
    """PeakPerModel whose model m tops out at ``cap(m)`` < 1: the models differ in how well
    they can fit, as morphologies do (bit 1 set: 0.99, else 0.95)."""

    def similarities(self, genomes, experiments, angles):
        caps = np.where(np.asarray(genomes)[:, 1] == 1, 0.99, 0.95)
        return caps[:, None] * super().similarities(genomes, experiments, angles)

def test_polish_climbs_every_cone_to_within_half_its_finest_step(make_experiment):
    from eea.inference.profile import POLISH_ITERATIONS, POLISH_STEPS_RAD

    np.testing.assert_allclose(POLISH_STEPS_RAD[[0, -1]], [[0.1, 0.02], [0.1 / 32, 0.02 / 32]])
    exps = tuple(make_experiment(i) for i in range(3))
    genomes = np.random.default_rng(0).integers(0, 2, (4, 45), dtype=np.uint8)
    fake = PeakPerModel()
    peaks = np.array([[fake.peak(g, e.index) for e in exps] for g in genomes])          # (U, E, 3)
    offsets = np.random.default_rng(1).uniform(-1, 1, peaks.shape) * [0.14, 0.14, 0.028]  # within 1.4 steps
    angles = peaks + offsets
    angles[..., :2] %= TWO_PI
    sims = fake.similarities(genomes, exps, angles)
    before, fake.rows = sims.copy(), 0
    Profile().polish_angles(genomes, angles, sims, exps, fake)
    assert fake.rows <= 6 * len(genomes) * len(exps) * POLISH_ITERATIONS * len(POLISH_STEPS_RAD)
    error = np.abs((angles - peaks + np.pi) % TWO_PI - np.pi)
    # a separable cone: after step s converged every angle is within s/2, and a step of s/2
    # needs at most one move per angle, i.e. POLISH_ITERATIONS = 3
    assert np.all(error[..., :2] <= POLISH_STEPS_RAD[-1, 0] / 2 + 1e-12)
    assert np.all(error[..., 2] <= POLISH_STEPS_RAD[-1, 1] / 2 + 1e-12)
    np.testing.assert_allclose(sims, fake.similarities(genomes, exps, angles))          # the kept scores are theirs
    assert np.all(sims >= before)


def test_polish_brings_the_true_morphology_back_to_its_true_angles():
    """Real physics: the truth at its true angles scores 1; 5 deg off, less; the polish recovers it."""
    from eea.evaluation import Evaluator
    from eea.encoding import encode_models
    from eea.experiment import Context, Experiment
    from eea.behaviour import behaviour_summary
    from eea.target import Target
    from aquafish_gym import SimParams

    deep = SimParams(waterline=None)  # the physics this was measured in
    target = Target("left_pectoral_half", 128, np.random.default_rng(3), deep)
    exps = []
    for i, action in enumerate([(0.45, -0.3, 0.6), (-0.4, 0.5, 0.2)]):
        log, true = target.perform(np.array(action))
        exps.append(Experiment(i, np.array(action), log, behaviour_summary(log), true, Context.exact(true)))
    truth = encode_models(target.morphology.to_array()[None])
    true = np.stack([e.true_angles for e in exps])[None]
    evaluator = Evaluator(128, params=deep)
    assert np.all(evaluator.similarities(truth, exps, true) == 1.0)
    angles = true + np.radians([[[5.0, -5.0, 1.0], [-5.0, 5.0, -1.0]]])
    sims = evaluator.similarities(truth, exps, angles)
    before = sims.copy()
    assert np.all(sims < 0.998)
    Profile().polish_angles(truth, angles, sims, exps, evaluator)
    np.testing.assert_allclose(sims, evaluator.similarities(truth, exps, angles))
    assert np.all(sims - before > 1e-3)
    # experiment 0 climbs back to its true angles; experiment 1's landscape is rugged at the
    # degree scale and the local search stops at a nearby maximum (0.9985, 3-4 deg off)
    assert sims[0, 0] > 0.99999
    assert np.degrees(np.abs((angles[0, 0] - true[0, 0] + np.pi) % TWO_PI - np.pi)).max() < 0.1
    assert sims.mean() > 0.999

def test_scan_finds_each_flippers_basin_anywhere_and_the_polish_then_its_peak(make_experiment, tiny_config):
    from eea.inference.profile import POLISH_STEPS_RAD, SCAN_CAUDAL, SCAN_PECTORAL

    exps = tuple(make_experiment(i) for i in range(2))
    genomes = np.random.default_rng(0).integers(0, 2, (3, 45), dtype=np.uint8)
    fake = PeakPerModel()
    peaks = np.array([[fake.peak(g, e.index) for e in exps] for g in genomes])
    far = peaks + [2.0, -2.5, 0.0]
    far[..., :2] %= TWO_PI
    far[..., 2] = np.where(peaks[..., 2] > 0, -0.52, 0.52)                             # the other end of the sweep
    profile, results = Profile(), {}
    for cycles in (0, 1):
        angles, sims = far.copy(), fake.similarities(genomes, exps, far)
        fake.rows = 0
        profile.scan_angles(genomes, angles, sims, exps, fake, cycles)
        assert fake.rows == cycles * (2 * SCAN_PECTORAL + SCAN_CAUDAL) * len(genomes) * len(exps)
        after_scan = np.abs((angles - peaks + np.pi) % TWO_PI - np.pi)
        if cycles:                                       # the nearest grid value of each flipper
            assert np.all(after_scan[..., :2] <= np.pi / SCAN_PECTORAL + 1e-12)
            assert np.all(after_scan[..., 2] <= 2 * 0.5235987755982988 / (SCAN_CAUDAL - 1) / 2 + 1e-12)
        profile.polish_angles(genomes, angles, sims, exps, fake)
        results[cycles] = np.abs((angles - peaks + np.pi) % TWO_PI - np.pi).max()
    assert results[1] <= POLISH_STEPS_RAD[-1, 0] / 2 + 1e-12                          # scanned, then polished: at the peak
    assert results[0] > 1.0                                                          # the polish alone stays far away
