"""``aquafish case-study``, ``study``, ``plot``, ``compare``, ``diagnose``, ``damages`` and
``baselines``."""

from __future__ import annotations

import argparse
from pathlib import Path

from aquafish_gym.argtypes import (add_alias, add_config_option, add_episode_duration, add_no_progress, add_processes,
                                   add_workers, csv_list, damage_list, int_at_least, json_object, path, seed_below)
from aquafish_gym.rundir import check_output_dir, check_output_file, run_lock
from eea.cli import add_config_flags, config_fields, config_flag_names, given_flags
from eea import INFERENCE_NAMES
from eea.methods import BEST_METHOD, METHODS, PAPER_METHODS


#: The case-study budgets (:data:`aquafish.case_study.PRESETS`, spelled out: importing it here
#: would cost every command its imports; tests/aquafish/test_cli_flags.py checks they agree).
CASE_STUDY_BUDGETS = ("smoke", "quick", "medium", "paper")
#: The seeds of a procedure (case study, recovery cell, mission): below
#: :data:`aquafish.oracle.PROCEDURE_SEED_LIMIT` (spelled out for the same reason; a test checks it).
PROCEDURE_SEED_LIMIT = 1_000_000
#: ``--budget`` of the commands that run case studies (case-study, recovery).
CASE_STUDY_BUDGET_HELP = ("the case study's budget (aquafish.case_study.PRESETS): smoke (a pipeline check), quick "
                          "(~4-5 min on 2 cores), medium (over 15 min) or paper (the paper's settings); its EEA runs get the "
                          "aquafish eea --budget of the same name")

#: EEA settings that are no flags of ``aquafish study``: the study sets them per run
#: (``--methods``, ``--durations``, ``--replicates``, ``--first-seed`` give inference, duration
#: and seed)
#: and runs every run serially (``--processes`` runs at once). Every other
#: :class:`~eea.config.EEAConfig` field is a flag, as in ``aquafish eea``.
STUDY_EXCLUDED = ("inference", "duration_s", "seed", "workers")


def _case_study(args: argparse.Namespace) -> int:
    from aquafish.case_study import run_case_study

    check_output_dir(args.out)
    report = run_case_study(args.budget, args.damage, args.seed, args.out, method=args.method,
                            model_space=args.model_space, behaviour_summary=args.behaviour_summary,
                            episode_duration_s=args.episode_duration_s,
                            video=args.video, workers=args.workers, progress=not args.no_progress,
                            self_model_fields=args.self_model_fields)
    print((Path(args.out) / "report.md").read_text())
    video = f", {report['video']}" if report.get("video") else ""
    print(f"wrote {Path(args.out) / 'report.md'}, report.json{video} ({report['wall_seconds'] / 60:.1f} min)")
    return 0


def _study(args: argparse.Namespace) -> int:
    from aquafish.study import StudySpec, run_study

    names = config_flag_names(STUDY_EXCLUDED)
    base = {"workers": 1, **config_fields(args, names)}  # flat: every run keeps what its strategy and search use
    fixed = list(given_flags(args, names))  # flags given win over the methods' fields
    spec = StudySpec(args.conditions, args.durations, args.replicates, base, first_seed=args.first_seed, fixed=fixed)
    dirs = run_study(spec, args.out, backend=args.backend, address=args.address, processes=args.processes,
                     progress=not args.no_progress)
    print(f"{len(dirs)} runs under {args.out}; plot them with: aquafish plot {args.out}")
    return 0


def _plot(args: argparse.Namespace) -> int:
    from eea.analysis.plot import plot_runs

    out = Path(args.out) if args.out is not None else Path(args.dirs[0]) / "objective_fitness.png"
    check_output_file(out, "--out")
    print(plot_runs(args.dirs, out))
    print(f"wrote {out}")
    return 0


def _compare(args: argparse.Namespace) -> int:
    from eea.analysis.compare import compare_variants, comparison_table, parse_variant, plot_variants
    from eea.analysis.plot import find_runs

    if args.out is not None:
        check_output_file(args.out, "--out")
    variants: dict[str, list] = {}
    for label, path in map(parse_variant, args.variants):  # a label given again: more of its runs
        variants.setdefault(label, []).append(path)
    summary = compare_variants({label: find_runs(paths) for label, paths in variants.items()},
                               rounds=args.rounds, level=args.level)
    print(comparison_table(summary, baseline=args.baseline))
    left_out = {label: s.left_out for label, s in summary.items() if s.left_out}
    if left_out:
        print("runs left out (round not finished): " + ", ".join(f"{k} {v}" for k, v in left_out.items()))
    if args.out:
        print(f"wrote {plot_variants(summary, args.out)}")
    return 0


def _diagnose(args: argparse.Namespace) -> int:
    from eea.analysis.diagnosis import diagnose_run
    from eea.analysis.plot import find_runs

    print(f"{'run':<40} {'inference':<12} {'E':>3} {'final@inf':>9} {'true@inf':>9} {'final@true':>10} "
          f"{'true@true':>9} {'final@own':>9} {'true@own':>9} {'true@new':>9} {f'true@+{args.refine}':>9} "
          f"{'seen':>6} {'best OBJ':>8} {'better':>6} {'err run L/R/C':>13} {'err floor':>11}  failure")
    for result in find_runs(args.dirs):
        d = diagnose_run(result.out_dir, workers=args.workers, profile_generations=args.profile_generations,
                         refine=args.refine)
        new, refined, closest = ("-" if v is None else f"{v:.4f}" for v in (d.true_proposed, d.true_refined,
                                                                              d.closest_seen))
        seen, better = ("-" if v is None else str(v) for v in (d.seen, d.better_seen))
        err_run, err_floor = ("/".join(f"{x:.0f}" for x in v) for v in (d.run_error_deg, d.floor_error_deg))
        print(f"{str(d.out_dir):<40} {d.inference:<12} {d.experiments:>3} {d.final_inferred:>9.4f} "
              f"{d.true_inferred:>9.4f} {d.final_true_angles:>10.4f} {d.true_true_angles:>9.4f} "
              f"{d.final_profiled:>9.4f} {d.true_profiled:>9.4f} {new:>9} {refined:>9} "
              f"{seen:>6} {closest:>8} {better:>6} {err_run:>13} {err_floor:>11}  {d.verdict}")
    return 0


def _baselines(args: argparse.Namespace) -> int:
    from aquafish.task_table import BaselineBudget, check_ppo_extra, format_table, task_table

    check_ppo_extra(args.ppo_timesteps)  # before the output directory is created
    check_output_dir(args.out)
    budget = BaselineBudget(args.neat_generations, args.neat_population, args.neat_episodes, args.ppo_timesteps,
                            args.seed, args.workers)
    with run_lock(args.out, command="baselines"):  # a second writer fails at once; each learner's directory is locked too
        rows = task_table(args.out, env_ids=args.envs, budget=budget, starts=args.starts, eval_seed=args.eval_seed,
                          progress=not args.no_progress)
    print(format_table(rows, args.starts))
    print(f"wrote {args.out}/task_table.md and task_table.json")
    return 0


def _damages(args: argparse.Namespace) -> int:
    from aquafish.damage_table import GaitBudget, check_damages, damage_list_lines, damage_table, format_table

    if args.list:
        print("\n".join(damage_list_lines()))
        return 0
    if args.out is None:
        raise ValueError("--out is required (the output directory), unless --list")
    check_damages(args.damages)  # before the output directory is created
    check_output_dir(args.out)
    budget = GaitBudget(args.generations, args.population_size, args.episodes_per_genome, args.seed, args.workers)
    with run_lock(args.out, command="damages"):  # a second writer fails at once; each gait's directory is locked too
        rows = damage_table(args.out, damages=args.damages, budget=budget, starts=args.starts,
                            eval_seed=args.eval_seed, verbose=args.verbose,
                            progress=not args.no_progress)
    print(format_table(rows, args.starts))
    print(f"wrote {Path(args.out) / 'damage_table.md'} and damage_table.json")
    return 0


def add_commands(sub) -> None:
    c = sub.add_parser("case-study", help="damage-recovery case study (paper section 5): self-model, evolve gaits, transfer")
    add_alias(c, c.add_argument("--budget", default="quick", choices=CASE_STUDY_BUDGETS,
                                help=f"{CASE_STUDY_BUDGET_HELP} (default: quick)"),
              "--preset")
    c.add_argument("--method", default=BEST_METHOD, choices=list(METHODS),
                   help=f"the self-model's method (default {BEST_METHOD}, the best; eea.methods); unless the "
                        "self-model is out_of_band in morphology, the paper's out_of_band run in morphology is a "
                        "row too")
    c.add_argument("--model-space", default="morphology+servos", choices=["morphology", "morphology+servos"],
                   help="the self-model's model space (default morphology+servos: the nine flipper dimensions and a "
                        "gain per servo, which the self-model gait's robot gets as servo faults); the plain-EEA and "
                        "out-of-band rows keep the paper's morphology")
    c.add_argument("--behaviour-summary", default="signed_dft", choices=["dft", "signed_dft"],
                   help="the self-model's behaviour summary (default signed_dft: the zero-frequency term keeps its "
                        "sign, so a reversed left servo and a reversed right one differ); the other rows keep the "
                        "paper's dft")
    add_alias(c, add_episode_duration(c, None, "the budget's, 20 s as in the paper; over 60 s a veering gait loses "
                                              "distance", note="gait evolution, transfer and video"),
              "--episode-duration")
    c.add_argument("--video", action=argparse.BooleanOptionalAction, default=True,
                   help="write recovery.mp4 (recovery.gif without imageio-ffmpeg): the damaged robot from above "
                        "under the healthy, self-model and oracle gaits (default: on)")
    c.add_argument("--damage", default="left_pectoral_half",
                   help="damage of the target robot: a preset name (aquafish damages --list), a JSON fault inline or "
                        "as FILE.json (keys scale, seized, gains) or sampled:SEED (default left_pectoral_half)")
    c.add_argument("--seed", type=seed_below(PROCEDURE_SEED_LIMIT), default=0, help="seeds every run (default 0)")
    c.add_argument("--out", type=path, default="case_study_out",
                   help="output directory (finished steps are reused; default case_study_out)")
    c.add_argument("--self-model-fields", type=json_object, default=None, metavar="JSON",
                   help="EEA settings of the self-model's run over the budget's own (with the default method, quick and "
                        "medium: aquafish.case_study.HYPOTHESES_SELF_MODEL_FIELDS, the ranked fault hypotheses) and "
                        "its method's, as a "
                        "JSON object of aquafish eea's flags by flat name, inline or as FILE.json, e.g. "
                        "'{\"estimation_generations\": 30}' (default: none; the other rows keep theirs); the report "
                        "records both")
    add_workers(c, None, "all cores")
    add_no_progress(c, "round, generation or training chunk")
    add_config_option(c)
    c.set_defaults(func=_case_study)

    s = sub.add_parser("study", help="many resumable EEA runs: conditions x durations x replicates (Figures 5-10)")
    s.add_argument("--methods", type=csv_list(str, choices=(*METHODS, *INFERENCE_NAMES)), default=PAPER_METHODS,
                   dest="conditions", help=f"methods, comma-separated (eea.methods; default the paper's four): "
                   f"{', '.join(METHODS)}; an inference strategy name that is no method (profile) sets only the inference")
    s.add_argument("--durations", type=csv_list(float), default=(1.28, 2.56, 5.12, 10.24), help="experiment durations (s)")
    s.add_argument("--replicates", type=int_at_least(1), default=25,
                   help="seeds S..S+N-1 per (condition, duration), S the --first-seed")
    s.add_argument("--first-seed", type=seed_below(), default=0,
                   help="the first seed S (default 0); shards of one study's seeds can share its --out one "
                        "after the other (a running study locks its --out; shards at once need an --out each, "
                        "which aquafish compare joins under one label)")
    s.add_argument("--out", required=True, type=path, help="study directory")
    s.add_argument("--backend", choices=["local", "ray"], default="local", help="local process pool or Ray tasks")
    s.add_argument("--address", default=None,
                   help="Ray cluster address (ray.init: 'auto', HOST:PORT or ray://HOST:PORT; default: start a local "
                        "Ray). A token-authenticated cluster (Ray's RAY_AUTH_MODE=token) needs RAY_AUTH_MODE=token and "
                        "its token in RAY_AUTH_TOKEN (or RAY_AUTH_TOKEN_PATH, or ~/.ray/auth_token) in this "
                        "command's environment")
    add_processes(s, None, "all cores", note="the local backend's process pool; each run evaluates serially")
    add_config_option(s)
    add_config_flags(s, exclude=STUDY_EXCLUDED)
    add_no_progress(s, "finished run")
    s.set_defaults(func=_study)

    p = sub.add_parser("plot", help="plot mean objective fitness vs round per condition and duration (Figures 5-10)")
    p.add_argument("dirs", nargs="+", help="study or run directories (searched recursively)")
    add_alias(p, p.add_argument("--out", "-o", type=path, default=None,
                                help="PNG path (default: FIRST_DIR/objective_fitness.png)"), "--output")
    p.set_defaults(func=_plot)

    m = sub.add_parser("compare", help="variants on the same seeds: final OBJ_FIT, Welch's p against a baseline, "
                                       "rounds to a level, angle errors, simulations per round (eea.analysis.compare)")
    m.add_argument("variants", nargs="+", metavar="LABEL=DIR",
                   help="a variant's label and its runs' directory (searched recursively; one run per seed); "
                        "a label given again adds another directory's runs (e.g. seeds 0-9 and 10-19 kept apart)")
    m.add_argument("--baseline", default=None, help="label p is computed against (default: the first variant)")
    m.add_argument("--rounds", type=int_at_least(1), default=None,
                   help="round compared (default: the shortest planned run); runs short of it are left out")
    m.add_argument("--level", type=float, default=0.9, help="OBJ_FIT level whose first round is reported (default 0.9)")
    add_alias(m, m.add_argument("--out", "-o", type=path, default=None, help="also draw the mean curves to this PNG"),
              "--output")
    m.set_defaults(func=_compare)

    d = sub.add_parser("diagnose", help="search, inference or identifiability failure? MOD_FIT of the final and the "
                                        "true morphology under the inferred, the true and their own fitted initial "
                                        "angles, per run; for profile runs also the truth under the angles it would start from if "
                                        "proposed (true@new); how many models the run scored (seen), the "
                                        "closest to the truth (best OBJ) and how many beat the final model "
                                        "(better); the median angle error of the run's final inferred angles and "
                                        "of the truth's own fitted ones (err run, err floor; degrees) (eea.analysis.diagnosis)")
    d.add_argument("dirs", nargs="+", help="study or run directories (searched recursively; read as data: config.json, "
                                           "rounds.csv and run_data.npz, never a checkpoint)")
    add_workers(d, 1, note="the simulations that diagnose each run")
    d.add_argument("--profile-generations", type=int_at_least(1), default=40,
                   help="generations of the per-model angle fit of both models (eea.inference.profile.Profile.fit; default: 40)")
    d.add_argument("--refine", type=int_at_least(0), default=0,
                   help="profile runs: also the proposed truth after this many rounds of contender refinement "
                        "(column true@+R; what --profile-refine R would buy; default: 0 = not computed)")
    d.set_defaults(func=_diagnose)


    t = sub.add_parser("damages", help="which damages a gait must adapt to: healthy gait vs a gait evolved on the "
                                       "damaged robot, per damage (aquafish.damage_table); --list lists the "
                                       "presets and sampled faults")
    t.add_argument("--list", action="store_true",
                   help="print the presets and what sampled:SEED gives for seeds 0-9, and exit (writes nothing)")
    t.add_argument("--out", type=path, default=None, help="output directory (gaits are evolved once and reused; required "
                                               "unless --list)")
    t.add_argument("--damages", type=damage_list, default=None,
                   help="comma-separated damages (default: every preset but none): preset names, JSON faults "
                        "inline or as FILE.json (keys scale, seized, gains), sampled:SEED")
    t.add_argument("--generations", type=int_at_least(1), default=30, help="NEAT generations per gait (default 30)")
    t.add_argument("--population-size", type=int_at_least(2), default=50, help="NEAT genomes per generation (default 50)")
    t.add_argument("--episodes-per-genome", type=int_at_least(1), default=2, help="training starts per genome (default 2)")
    t.add_argument("--starts", type=int_at_least(1), default=10, help="fresh starts per gait and robot (default 10)")
    t.add_argument("--seed", type=seed_below(), default=0, help="NEAT seed and first training start (default 0)")
    t.add_argument("--eval-seed", type=seed_below(), default=1000, help="seed of the first fresh start (default 1000)")
    add_workers(t, 1, note="each gait's NEAT evaluations")
    t.add_argument("--verbose", action="store_true", help="NEAT's per-generation report")
    add_no_progress(t, "generation")
    add_config_option(t)
    t.set_defaults(func=_damages)

    b = sub.add_parser("baselines", help="random policy, NEAT and PPO on every task of the env family "
                                         "(aquafish.task_table)")
    b.add_argument("--out", required=True, type=path, help="output directory (learners are trained once and reused)")
    b.add_argument("--envs", type=csv_list(str), default=None, help="task ids (default: every registered task)")
    b.add_argument("--neat-generations", type=int_at_least(1), default=10, help="NEAT generations per task (default 10)")
    b.add_argument("--neat-population", type=int_at_least(2), default=30, help="NEAT genomes per generation (default 30)")
    b.add_argument("--neat-episodes", type=int_at_least(1), default=3, help="NEAT training starts per genome (default 3)")
    b.add_argument("--ppo-timesteps", type=int_at_least(0), default=100_000, help="PPO env steps per task; 0: no PPO (default 1e5; more than 0 needs the [rl] extra)")
    b.add_argument("--starts", type=int_at_least(1), default=10, help="fresh starts per task and learner (default 10)")
    b.add_argument("--seed", type=seed_below(), default=0, help="training seed (default 0)")
    b.add_argument("--eval-seed", type=seed_below(), default=1000, help="seed of the first fresh start (default 1000)")
    add_workers(b, 1, note="each NEAT run's evaluations")
    add_no_progress(b, "generation or training chunk")
    add_config_option(b)
    b.set_defaults(func=_baselines)
