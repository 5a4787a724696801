"""eea.inference.selection: fault hypotheses about the design, and the check of a found self-model against them."""

import numpy as np
import pytest

from aquafish_gym import Morphology
from eea.behaviour import behaviour_summary
from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.fitness import model_fitness_from_similarities
from eea.experiment import Context, Experiment
from eea.inference.selection import (FAULT_GAIN_LEVELS, GAIN_POLISH_MARGIN, check_fault_hypotheses, fault_hypotheses,
                                     gain_neighbours, select_model)
from eea.target import Target

DESIGN = Morphology.healthy().to_array()


def test_servo_hypotheses_are_every_pectoral_gain_pair_at_the_design():
    h = fault_hypotheses(DESIGN)[:25]
    np.testing.assert_array_equal(h[:, :9], np.tile(DESIGN, (25, 1)))
    assert {(l, r) for l, r in h[:, 9:11]} == {(l, r) for l in FAULT_GAIN_LEVELS for r in FAULT_GAIN_LEVELS}
    assert np.all(h[:, 11] == 1.0) and h[0, 9:11].tolist() == [-1.0, -1.0] and h[1, 9:11].tolist() == [-1.0, -0.5]
    assert fault_hypotheses(DESIGN, (0.0, 1.0))[:4, 9:].tolist() == [[0, 0, 1], [0, 1, 1], [1, 0, 1], [1, 1, 1]]


def test_flipper_hypotheses_shorten_or_remove_one_pectoral_beside_every_gain_of_the_other():
    h = fault_hypotheses(DESIGN)
    assert h.shape == (25 + 4 * 5 + 4 * 13, 12)
    # (left x, y, z), (right x, y, z): the healthy design's 0.25, 1, 0.0625 each
    expected = [([0.25, 0.5, 0.0625], [0.25, 1.0, 0.0625]), ([0.0, 0.0, 0.0], [0.25, 1.0, 0.0625]),
                ([0.25, 1.0, 0.0625], [0.25, 0.5, 0.0625]), ([0.25, 1.0, 0.0625], [0.0, 0.0, 0.0])]
    for block, (left, right) in enumerate(expected):
        rows = h[25 + 5 * block: 30 + 5 * block]
        np.testing.assert_array_equal(rows[:, :6], np.tile(left + right, (5, 1)))
        np.testing.assert_array_equal(rows[:, 6:9], np.tile(DESIGN[6:], (5, 1)))  # the caudal fin as designed
        faulty, other = (9, 10) if block < 2 else (10, 9)
        assert np.all(rows[:, faulty] == 1.0) and rows[:, other].tolist() == list(FAULT_GAIN_LEVELS)
        assert np.all(rows[:, 11] == 1.0)
    assert fault_hypotheses(DESIGN, (0.0, 1.0)).shape == (4 + 4 * 2 + 4 * (5 + 2), 12)


def test_caudal_hypotheses_put_each_caudal_fault_beside_healthy_pectorals_or_one_pectoral_fault():
    h = fault_hypotheses(DESIGN)[45:]
    halved_left, lost_left = DESIGN.copy(), DESIGN.copy()
    halved_left[1], lost_left[:3] = 0.5, 0.0
    caudal = [(0.0, DESIGN[6:]), (0.5, DESIGN[6:]), (1.0, [0.25, 0.4375, 0.375]), (1.0, [0.0, 0.0, 0.0])]
    for block, (gain, fin) in enumerate(caudal):  # dead, weak servo; fin halved (caudal_y 0.875 -> 0.4375), lost
        rows = h[13 * block: 13 * block + 13]
        np.testing.assert_array_equal(rows[:, 11], gain)
        np.testing.assert_array_equal(rows[:, 6:9], np.tile(fin, (13, 1)))
        # healthy pectorals, the left gain at -1, -0.5, 0, 0.5, the right likewise, then the flipper faults
        assert rows[:9, 9:11].tolist() == [[1, 1], [-1, 1], [-0.5, 1], [0, 1], [0.5, 1], [1, -1], [1, -0.5], [1, 0],
                                           [1, 0.5]]
        np.testing.assert_array_equal(rows[:9, :6], np.tile(DESIGN[:6], (9, 1)))
        np.testing.assert_array_equal(rows[9, :6], halved_left[:6])
        np.testing.assert_array_equal(rows[10, :6], lost_left[:6])
        np.testing.assert_array_equal(rows[11, :6], np.r_[DESIGN[:3], 0.25, 0.5, 0.0625])
        np.testing.assert_array_equal(rows[12, :6], np.r_[DESIGN[:3], 0.0, 0.0, 0.0])
        assert np.all(rows[9:, 9:11] == 1.0)
    assert len(np.unique(fault_hypotheses(DESIGN), axis=0)) == 97  # no hypothesis twice


@pytest.mark.parametrize("kwargs, match", [({"design": np.zeros(8)}, "9 flipper dimensions"),
                                           ({"levels": ()}, "one or more pectoral gains"),
                                           ({"levels": (1.5,)}, r"in \[-1, 1\]")])
def test_bad_hypotheses_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        fault_hypotheses(**{"design": DESIGN, **kwargs})


def _experiments(damage, actions, steps=64, seed=0):
    target = Target(damage, steps, np.random.default_rng(seed))
    out = []
    for i, action in enumerate(actions):
        log, true = target.perform(np.array(action))
        out.append(Experiment(i, np.array(action), log, behaviour_summary(log, signed=True), true,
                              Context.exact(np.zeros(3))))
    return out


#: A rough fit for the fast tests: two pectoral gain levels (40 hypotheses), a screen without
#: scan, 4 candidates refitted (two rounds) with 2 generations, no gain polish.
QUICK_FIT = {"levels": (-1.0, 1.0), "screen_generations": 1, "screen_scan_cycles": 0, "refit": 4, "generations": 2,
             "scan_cycles": 1, "polish": 0}


def test_the_check_refits_the_screens_best_in_rounds_that_share_their_angles():
    """Stage 0 is select_model's screen of all the candidates (seed; with the compass polish on
    all of them, screen_polish_top >= their number, it is select_model's polished fit to the
    bit); the `refit` best of it are fitted again in `refit_rounds` rounds (seed + 1, seed + 2),
    each from every refitted candidate's angles so far, and keep their best fit; no other
    candidate changes."""
    experiments = _experiments("reversed_left_pectoral", [(0.45, 0.4, 0.5)], steps=32)
    found = np.concatenate([DESIGN, [1.0, -1.0, 1.0]])
    candidates = np.vstack([found[None], fault_hypotheses(DESIGN, (-1.0, 1.0))])
    with Evaluator(32, model_space="morphology+servos", summary="signed_dft", workers=1) as ev:
        sel = check_fault_hypotheses(found, DESIGN, experiments, ev, 3, **QUICK_FIT,
                                     screen_polish_top=len(candidates))
        screen = select_model(candidates, experiments, ev, np.random.default_rng(3), generations=1, scan_cycles=0)
        best = np.argsort(-screen.model_fitness, kind="stable")[:4]
        fitness, angles = screen.model_fitness.copy(), screen.angles.copy()
        for stage in (1, 2):
            shared = np.stack([np.tile(angles[b], (4, 1, 1)) for b in best])  # set s: candidate s's angles for all
            again = select_model(candidates[best], experiments, ev, np.random.default_rng(3 + stage), generations=2,
                                 scan_cycles=1, start=shared)
            better = again.model_fitness > fitness[best]
            fitness[best[better]], angles[best[better]] = again.model_fitness[better], again.angles[better]
    rest = np.setdiff1d(np.arange(len(candidates)), best)
    np.testing.assert_array_equal(sel.model_fitness[rest], screen.model_fitness[rest])
    np.testing.assert_array_equal(sel.angles[rest], screen.angles[rest])
    np.testing.assert_array_equal(sel.model_fitness, fitness)
    np.testing.assert_array_equal(sel.angles, angles)
    assert np.all(sel.model_fitness[best] >= screen.model_fitness[best])
    assert sel.index in best and sel.index == int(np.argmax(sel.model_fitness))


def test_a_screen_without_the_polish_scores_the_fits_angles_at_a_fraction_of_the_cost():
    """select_model(polish=False): the same fit (same seed) and scan, no compass polish; each
    model's MOD_FIT is eq. 3 of its returned angles' similarities, at most the polished fit's,
    for fewer simulations; the check's screen takes it through screen_polish_top=0."""
    experiments = _experiments("reversed_left_pectoral", [(0.45, 0.4, 0.5), (-0.3, 0.2, 0.8)], steps=32)
    found = np.concatenate([DESIGN, [1.0, -1.0, 1.0]])
    candidates = np.vstack([found[None], fault_hypotheses(DESIGN, (-1.0, 1.0))])
    with Evaluator(32, model_space="morphology+servos", summary="signed_dft", workers=1) as ev:
        before = ev.simulations
        bare = select_model(candidates, experiments, ev, np.random.default_rng(5), generations=1, scan_cycles=0,
                            polish=False)
        bare_cost, before = ev.simulations - before, ev.simulations
        polished = select_model(candidates, experiments, ev, np.random.default_rng(5), generations=1, scan_cycles=0)
        polished_cost = ev.simulations - before
        rescored = model_fitness_from_similarities(
            ev.similarities(ev.model_space.encode(candidates), experiments, bare.angles))
        check = check_fault_hypotheses(found, DESIGN, experiments, ev, 5, **QUICK_FIT, screen_polish_top=0)
    np.testing.assert_allclose(bare.model_fitness, rescored, rtol=0, atol=1e-12)
    assert np.all(bare.model_fitness <= polished.model_fitness + 1e-12)
    assert np.any(bare.model_fitness < polished.model_fitness)
    assert bare_cost < polished_cost / 2
    rest = np.setdiff1d(np.arange(len(candidates)), np.argsort(-bare.model_fitness, kind="stable")[:4])
    np.testing.assert_array_equal(check.model_fitness[rest], bare.model_fitness[rest])  # the screen, unrefitted


def test_a_screen_given_its_angles_scores_them_and_fits_nothing():
    """screen_angles: the candidates' angles are scored once each (1 + H models x E experiments
    simulations) instead of fitted; handed the angles the fitted screen found, the check makes
    the same later stages and ends where the fitted check ends, with the screen's fit saved."""
    experiments = _experiments("reversed_left_pectoral", [(0.45, 0.4, 0.5), (-0.3, 0.2, 0.8)], steps=32)
    found = np.concatenate([DESIGN, [1.0, -1.0, 1.0]])
    candidates = np.vstack([found[None], fault_hypotheses(DESIGN, (-1.0, 1.0))])

    def evaluator():
        return Evaluator(32, model_space="morphology+servos", summary="signed_dft", workers=1)

    with evaluator() as ev:
        fitted = check_fault_hypotheses(found, DESIGN, experiments, ev, 5, **QUICK_FIT, screen_polish_top=0)
        fitted_cost = ev.simulations
    with evaluator() as ev:                       # the check's screen alone: its seed, its fit
        screen = select_model(candidates, experiments, ev, np.random.default_rng(5), generations=1, scan_cycles=0,
                              polish=False)
        screen_cost = ev.simulations
    with evaluator() as ev:
        given = check_fault_hypotheses(found, DESIGN, experiments, ev, 5, **QUICK_FIT, screen_polish_top=0,
                                       screen_angles=screen.angles)
        given_cost = ev.simulations
        with pytest.raises(ValueError, match=r"screen_angles must be \(1 \+ H, E, 3\)"):
            check_fault_hypotheses(found, DESIGN, experiments, ev, 5, **QUICK_FIT, screen_angles=screen.angles[:, :1])
    np.testing.assert_array_equal(given.model_fitness, fitted.model_fitness)
    np.testing.assert_array_equal(given.angles, fitted.angles)
    assert given.index == fitted.index
    distinct = len(np.unique(get_model_space("morphology+servos").encode(candidates), axis=0))
    assert screen_cost > distinct * len(experiments)
    assert given_cost == fitted_cost - screen_cost + distinct * len(experiments)


def test_the_screens_polish_goes_to_its_best_only():
    """screen_polish_top=K: the unpolished screen ranks the candidates; its K best get the
    compass polish (their MOD_FIT no lower), every other candidate that is not refitted keeps
    the unpolished screen's fit to the bit, and the polish costs in proportion to K."""
    experiments = _experiments("reversed_left_pectoral", [(0.45, 0.4, 0.5), (-0.3, 0.2, 0.8)], steps=32)
    found = np.concatenate([DESIGN, [1.0, -1.0, 1.0]])
    candidates = np.vstack([found[None], fault_hypotheses(DESIGN, (-1.0, 1.0))])
    costs = {}
    with Evaluator(32, model_space="morphology+servos", summary="signed_dft", workers=1) as ev:
        bare = select_model(candidates, experiments, ev, np.random.default_rng(5), generations=1, scan_cycles=0,
                            polish=False)
        for k in (0, 10):
            before = ev.simulations
            costs[k] = (check_fault_hypotheses(found, DESIGN, experiments, ev, 5, **{**QUICK_FIT, "refit_rounds": 1},
                                               screen_polish_top=k), ev.simulations - before)
    top = np.argsort(-bare.model_fitness, kind="stable")[:10]
    (none, none_cost), (ten, ten_cost) = costs[0], costs[10]
    assert len(ten.models) == len(none.models) == len(candidates)  # no gain polish (QUICK_FIT)
    # a refit only raises a fit and nothing else moves, so the refitted 4 are the final best 4
    refitted = np.argsort(-ten.model_fitness, kind="stable")[:4]
    rest = np.setdiff1d(np.arange(len(candidates)), np.union1d(top, refitted))
    np.testing.assert_array_equal(ten.model_fitness[rest], bare.model_fitness[rest])
    np.testing.assert_array_equal(ten.angles[rest], bare.angles[rest])
    polished = np.setdiff1d(top, refitted)
    assert len(polished) >= 6 and np.all(ten.model_fitness[polished] >= bare.model_fitness[polished])
    assert np.any(ten.model_fitness[polished] > bare.model_fitness[polished])
    assert ten_cost > none_cost


@pytest.mark.parametrize("top", [-1, True, 2.5])
def test_the_screens_polish_takes_a_count(top):
    model = np.concatenate([DESIGN, [1.0, 1.0, 1.0]])
    with pytest.raises(ValueError, match="screen_polish_top must be an int >= 0"):
        check_fault_hypotheses(model, DESIGN, [], None, 0, screen_polish_top=top)


def test_gain_neighbours_move_one_gain_to_the_grid_level_nearest_one_step_away():
    model = np.concatenate([DESIGN, [-1.0, 0.25, 0.125]])
    moved = gain_neighbours(model)
    np.testing.assert_array_equal(moved[:, :9], np.tile(DESIGN, (len(moved), 1)))
    # -1 has no level below and -0.875 is not a level (the grid's next is -0.75); the caudal grid
    # steps by 0.0625 but the move is 0.125, and it has 0 below 0.125 (0.0625 is not a level)
    assert moved[:, 9:].tolist() == [[-0.75, 0.25, 0.125], [-1.0, 0.125, 0.125], [-1.0, 0.375, 0.125],
                                     [-1.0, 0.25, 0.0], [-1.0, 0.25, 0.25]]
    assert gain_neighbours(np.concatenate([DESIGN, [1.0, 1.0, 1.0]]))[:, 9:].tolist() == [
        [0.875, 1.0, 1.0], [1.0, 0.875, 1.0], [1.0, 1.0, 0.875]]
    with pytest.raises(ValueError, match="12 finite values"):
        gain_neighbours(np.r_[DESIGN, np.nan, 1.0, 1.0])


def test_the_gain_polish_climbs_from_the_best_candidates_one_gain_step_at_a_time():
    """After the screen and the refits, the polish (seed + 3 on) fits the best distinct candidate
    and its gain neighbours from its angles, duels the best neighbour from both their angles, and
    moves while the neighbour fits better by more than the margin; the end point is appended.
    Replayed step by step."""
    experiments = _experiments('{"gains": [1, 0.5, 1]}', [(0.45, 0.4, 0.5), (-0.3, 0.5, 0.2)], steps=32)
    found = np.concatenate([DESIGN, [1.0, 1.0, 1.0]])
    fit = {**QUICK_FIT, "polish": 1, "polish_steps": 3}
    with Evaluator(32, model_space="morphology+servos", summary="signed_dft", workers=1) as ev:
        sel = check_fault_hypotheses(found, DESIGN, experiments, ev, 3, **fit)
        plain = check_fault_hypotheses(found, DESIGN, experiments, ev, 3, **{**fit, "polish": 0})
        n, seeds = len(plain.models), iter(range(6, 100))
        start = int(np.argmax(plain.model_fitness))
        current, best, angles = plain.models[start], plain.model_fitness[start], plain.angles[start]

        def again(trial, starts):
            return select_model(trial, experiments, ev, np.random.default_rng(next(seeds)), generations=2,
                                scan_cycles=1, start=starts)

        for step in range(3):
            trial = np.vstack([current[None], gain_neighbours(current)])
            first = again(trial, np.repeat(angles[None], len(trial), axis=0))
            if first.model_fitness[0] > best:
                best, angles = first.model_fitness[0], first.angles[0]
            j = 1 + int(np.argmax(first.model_fitness[1:]))
            if first.model_fitness[j] <= best + GAIN_POLISH_MARGIN:
                break
            duel = again(trial[[0, j]], np.stack([np.stack([angles] * 2), np.stack([first.angles[j]] * 2)]))
            if duel.model_fitness[0] > best:
                best, angles = duel.model_fitness[0], duel.angles[0]
            challenger, its_angles = max((first.model_fitness[j], first.angles[j]), (duel.model_fitness[1], duel.angles[1]),
                                         key=lambda pair: pair[0])
            if challenger <= best + GAIN_POLISH_MARGIN:
                break
            current, best, angles = trial[j], challenger, its_angles
    np.testing.assert_array_equal(sel.models[:n], plain.models)
    np.testing.assert_array_equal(sel.model_fitness[:n], plain.model_fitness)
    assert len(sel.models) == n + 1 and sel.index == n  # the polish moved, and its end point is kept
    np.testing.assert_array_equal(sel.models[n], current)
    assert sel.model_fitness[n] == best > plain.model_fitness[start] + GAIN_POLISH_MARGIN
    np.testing.assert_array_equal(sel.angles[n], angles)


@pytest.mark.slow
def test_the_gain_polish_names_a_weak_servo_between_the_hypotheses_levels():
    """A right servo at gain 0.25 (the hypotheses hold 0 and 0.5, and a halved right flipper): at
    the check's own budget the kept model holds the right servo weak, 0.125-0.375, the rest healthy
    (about 3 minutes)."""
    actions = [(0.45, 0.4, 0.5), (-0.3, 0.5, 0.2), (0.1, -0.4, 0.6), (0.5, 0.1, 0.3)]
    experiments = _experiments('{"gains": [1, 0.25, 1]}', actions, steps=128)
    found = np.concatenate([DESIGN, [1.0, 1.0, 1.0]])
    with Evaluator(128, model_space="morphology+servos", summary="signed_dft", workers=1) as ev:
        sel = check_fault_hypotheses(found, DESIGN, experiments, ev, 0)
    np.testing.assert_array_equal(sel.model[:9], DESIGN)
    assert sel.model[9] == 1.0 and 0.125 <= sel.model[10] <= 0.375 and sel.model[11] == 1.0


def test_the_check_replaces_a_mirror_image_model_by_the_true_fault():
    """A reversed left servo: a self-model with the mirror-image fault (left healthy, right reversed)
    and a morphology bent away from the design loses to the hypothesis (-1, +1) at the design."""
    experiments = _experiments("reversed_left_pectoral", [(0.45, 0.4, 0.5), (-0.3, 0.5, 0.2)])
    mirror = np.concatenate([DESIGN * np.array([1.2, 0.8, 1, 1, 1.3, 1, 1, 1, 1]), [1.0, -1.0, 1.0]])
    with Evaluator(64, model_space="morphology+servos", summary="signed_dft", workers=1) as ev:
        sel = check_fault_hypotheses(mirror, DESIGN, experiments, ev, 0, **QUICK_FIT)
    assert sel.models.shape == (41, 12) and sel.index != 0
    assert sel.model[9:].tolist() == [-1.0, 1.0, 1.0]
    assert sel.model_fitness[sel.index] > sel.model_fitness[0]


@pytest.mark.slow
def test_the_check_keeps_a_model_no_hypothesis_explains_better():
    """A found model that no hypothesis beats (the truth: three faults, a reversed left servo, a
    halved right flipper and a weak caudal servo; no hypothesis has more than two) keeps its place."""
    fault = '{"gains": [-1, 1, 0.5], "scale": {"right_pectoral_y": 0.5}}'
    experiments = _experiments(fault, [(0.45, 0.4, 0.5), (-0.3, 0.5, 0.2)])
    truth = np.concatenate([Target(fault, 64, np.random.default_rng(0)).morphology.to_array(), [-1.0, 1.0, 0.5]])
    with Evaluator(64, model_space="morphology+servos", summary="signed_dft", workers=1) as ev:
        sel = check_fault_hypotheses(truth, DESIGN, experiments, ev, 0, **QUICK_FIT)
    assert sel.index == 0


@pytest.mark.slow
def test_the_check_finds_a_halved_flipper_a_search_took_for_a_servo_fault():
    """A halved left flipper: a found model with a slightly reversed left servo at the design (as a
    benchmark run ended) loses to the hypothesis of the halved flipper with healthy servos, at the
    check's own fit budget (its screen and refit; about 3 minutes). With a rougher fit the fault
    classes are not told apart on a few short experiments."""
    actions = [(0.45, 0.4, 0.5), (-0.3, 0.5, 0.2), (0.1, -0.4, 0.6), (0.5, 0.1, 0.3)]
    experiments = _experiments("left_pectoral_half", actions, steps=128)
    found = np.concatenate([DESIGN, [-0.125, 0.875, 1.0]])
    with Evaluator(128, model_space="morphology+servos", summary="signed_dft", workers=1) as ev:
        sel = check_fault_hypotheses(found, DESIGN, experiments, ev, 0)
    assert sel.model[9:].tolist() == [1.0, 1.0, 1.0]
    np.testing.assert_array_equal(sel.model[:9], DESIGN * np.array([1, 0.5, 1, 1, 1, 1, 1, 1, 1]))
    assert sel.model_fitness[sel.index] > sel.model_fitness[0]


def test_the_model_must_be_a_servo_self_model_and_the_refit_at_least_one():
    with pytest.raises(ValueError, match="12 values of a morphology"):
        check_fault_hypotheses(DESIGN, DESIGN, [], None, 0)
    model = np.concatenate([DESIGN, [1.0, 1.0, 1.0]])
    with pytest.raises(ValueError, match="refit and refit_rounds must be >= 1, got 8 and 0"):
        check_fault_hypotheses(model, DESIGN, [], None, 0, refit_rounds=0)
    with pytest.raises(ValueError, match="polish must be >= 0 and polish_steps >= 1, got -1 and 3"):
        check_fault_hypotheses(model, DESIGN, [], None, 0, polish=-1)
