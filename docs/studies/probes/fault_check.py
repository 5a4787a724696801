"""A finished self-model run's final model against fault hypotheses about the design (docs/studies/recovery.md).

For every finished ``morphology+servos`` run under the given directories (the experiments'
IMU logs from its checkpoint, ``state.pkl``; a published run keeps none, and its experiments
are simulated again from ``rounds.csv``'s actions and true angles by
:func:`eea.replay.rebuild_experiments`, the same logs bit for bit), this fits the initial angles of the
run's final model and of the 97 hypotheses of :func:`eea.inference.selection.fault_hypotheses`
(25 servo faults: the design morphology, pectoral gains -1, -0.5, 0, 0.5, 1 each; 20 pectoral
flipper faults: one pectoral flipper halved in length or lost, the other pectoral's gain at
those levels; 52 caudal faults: the caudal servo dead or at half gain, or the fin halved or
lost, beside healthy pectorals or one pectoral fault) on all the run's experiments
(:func:`eea.fault_check.check_final_model`, the check every such run now ends with: a screen of
3 generations and 1 scan cycle with a compass polish of its best 24, then the best 8 fitted again in two rounds of 10 generations
and 2 scan cycles that start each from the others' angles too, then the gains of the best 2
polished, one step of 0.125 at a time; it does not write into the run) and prints one JSON line per run: the damage, the true,
final and chosen gains, whether each has both pectoral signs right (as the recovery benchmark
judges them: a lost flipper's servo is not judged), the MOD_FITs, the chosen model's pectoral
lengths, the three best candidates (gains, lengths, MOD_FIT), the simulations and seconds.

    python docs/studies/probes/fault_check.py runs/lean1
    python docs/studies/probes/fault_check.py docs/results/mirror_signed_flip   # published: replayed
    python docs/studies/probes/fault_check.py --bare-screen runs/lean1_check    # a cheaper screen

``--reuse-screen`` (a ``--estimation-search hypotheses`` run, whose profile strategy holds every
hypothesis' fitted angles in its checkpoint) makes the check with those angles as its screen
(``check_fault_hypotheses(screen_angles=...)``: scored once, nothing fitted), the rest as today,
and gives the recorded check beside it the same way.

``--bare-screen`` makes the check with a screen that only fits (its 3 generations, no scan cycle
and no compass polish: ``check_fault_hypotheses(screen_scan_cycles=0, screen_polish_top=0)``),
the rest as today; the line then also gives the run's recorded check (``recorded_gains``,
``recorded_procedure``) to compare with. The screen is about 80 % of today's check; bare, about
a tenth of itself.

About 150,000 simulations a run of 8-9 experiments of 1.28 s (about 4.5 minutes on one core).
Before 2026-11-27 the check had the 25 servo faults only (about 38,000 simulations), then the
45 servo and pectoral flipper faults, all fitted at the refit's budget (about 68,000), then the 97
without the gain polish (about 128,000); the rows in ``docs/results/fault_check/`` say which
check wrote them.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from eea.analysis.plot import find_runs
from eea.checkpoint import load_state
from eea.evaluation import Evaluator
from eea.experiment import Experiment
from aquafish_gym import Morphology
from eea.fault_check import FAULT_CHECK_SEED, FaultCheck, check_final_model, search_screen
from eea.inference import Profile
from eea.inference.selection import check_fault_hypotheses
from eea.identification import pectoral_signs_right
from eea.record import load_result
from eea.replay import rebuild_experiments


def _search_screen(result, state, final: np.ndarray) -> np.ndarray:
    """The screen a ``hypotheses`` run's profile strategy fitted for the check of ``final``
    (:func:`eea.fault_check.search_screen` over the strategy restored from the checkpoint).

    Raises:
        ValueError: the run is no ``hypotheses`` run, or its checkpoint holds no angles for a candidate.
    """
    strategy = Profile()
    strategy.load_state_dict(state.inference if state is not None else {})
    screen = search_screen(result.config, strategy, final, len(state.experiments) if state is not None else 0)
    if screen is None:
        raise ValueError(f"{result.out_dir}: --reuse-screen needs the checkpoint of an --estimation-search "
                         f"hypotheses run whose strategy holds every candidate's angles")
    return screen


def check_run(run_dir, bare_screen: bool = False, reuse_screen: bool = False) -> dict:
    """The check of one finished run (see the module docstring); its JSON line as a dict."""
    result, state = load_result(run_dir), load_state(run_dir)
    if result.config.model_space != "morphology+servos":
        raise ValueError(f"{run_dir}: a morphology+servos run is needed, got {result.config.model_space}")
    experiments = ([Experiment.from_state_dict(e) for e in state.experiments] if state is not None
                   else rebuild_experiments(result))
    final, truth = np.asarray(result.best_model, dtype=float), result.true_model
    with Evaluator.for_config(result.config, workers=1, model_space="morphology+servos") as evaluator:
        if bare_screen:
            started, simulations = time.perf_counter(), evaluator.simulations
            selection = check_fault_hypotheses(final, Morphology.healthy().to_array(), experiments, evaluator,
                                               FAULT_CHECK_SEED, screen_scan_cycles=0, screen_polish_top=0)
            check = FaultCheck(len(result.rounds), selection.models, selection.model_fitness, selection.index,
                               evaluator.simulations - simulations, time.perf_counter() - started, "bare screen")
        elif reuse_screen:
            check = check_final_model(final, experiments, evaluator, len(result.rounds),
                                      screen_angles=_search_screen(result, state, final))
        else:
            check = check_final_model(final, experiments, evaluator, len(result.rounds))
    order = np.argsort(-check.model_fitness, kind="stable")
    chosen = check.model
    return {"run": str(run_dir), "damage": result.config.damage, "true_gains": truth[9:].tolist(),
            "final_gains": final[9:].tolist(), "final_signs": pectoral_signs_right(final, truth),
            "final_fit": round(float(check.model_fitness[0]), 4),
            "chosen": "final" if check.index == 0 else "hypothesis", "chosen_gains": chosen[9:].tolist(),
            "chosen_signs": pectoral_signs_right(chosen, truth),
            "chosen_fit": round(float(check.model_fitness[check.index]), 4),
            "chosen_pectoral_lengths": chosen[[1, 4]].tolist(),
            "top3": [[check.models[i, 9:11].tolist(), check.models[i, [1, 4]].tolist(),
                      round(float(check.model_fitness[i]), 4)] for i in order[:3]],
            "simulations": check.simulations, "seconds": round(check.wall_seconds),
            "experiments": "checkpoint" if state is not None else "replayed"} | ({
            "screen": "bare" if bare_screen else "reused",
            "recorded_gains": None if result.fault_check is None else result.fault_check.model[9:].tolist(),
            "recorded_simulations": None if result.fault_check is None else result.fault_check.simulations,
            "recorded_procedure": None if result.fault_check is None else result.fault_check.procedure}
        if bare_screen or reuse_screen else {})


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", help="directories searched for finished morphology+servos runs")
    parser.add_argument("--bare-screen", action="store_true",
                        help="screen by the fit alone (no scan cycle, no polish); the rest as today's check")
    parser.add_argument("--reuse-screen", action="store_true",
                        help="screen by the angles a hypotheses run's strategy holds (nothing fitted); the rest as "
                             "today's check")
    args = parser.parse_args(argv)
    if args.bare_screen and args.reuse_screen:
        parser.error("--bare-screen and --reuse-screen are two different screens: give one")
    for result in find_runs(args.dirs):
        if result.config.model_space == "morphology+servos":  # the paper's morphology runs have no servo gains
            print(json.dumps(check_run(result.out_dir, args.bare_screen, args.reuse_screen)), flush=True)


if __name__ == "__main__":
    main()
