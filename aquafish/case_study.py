"""The damage-recovery case study (paper section 5, Figures 11 and 12).

1. The target is the healthy robot with a named damage.
2. It self-models with the EEA: ``none`` (plain EEA) and the self-model's inference
   (default ``out_of_band``, the paper's; when another is chosen, ``out_of_band`` runs too
   and stays a row).
3. NEAT gaits are evolved for the healthy morphology, every EEA model, and the true
   damaged robot (the oracle: what recovery could reach at best); with the ``[rl]`` extra,
   PPO is also trained on the self-model.
4. Each controller swims on its native robot and on the damaged target, from the same
   starts.
5. ``report.md`` / ``report.json`` and the figures are written to the output directory.
   The controllers have stable keys (:data:`CONTROLLER_KEYS`), and :func:`verdict` says
   whether the damage breaks the healthy gait and how much of the oracle the self-model
   gait recovers.

Every step writes into its own sub-directory and is skipped when its result exists, so an
interrupted case study resumes where it stopped.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import time
from pathlib import Path

import numpy as np

import eea
import gait
from aquafish_gym import MORPHOLOGY_BOUNDS, MORPHOLOGY_FIELDS, Morphology, get_damage
from aquafish_gym.drawing import plot_morphologies
from aquafish_gym.checks import check_int
from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import check_output_dir, run_lock
from eea.config import EEAConfig


@dataclasses.dataclass(frozen=True)
class CaseStudyPreset:
    """Settings of one case-study preset.

    Attributes:
        eea: EEA settings shared by both self-modeling runs (inference is set per run).
        gait_population, gait_generations: NEAT settings for every gait.
        gait_episodes: starts (initial flipper angles) per NEAT genome evaluation; the
            fitness is the mean distance. One start overfits the gait to it.
        transfer_episodes: paired starts per transfer score (native and target); the
            report gives mean distances.
        rl_timesteps: PPO training steps (0 disables the RL baseline).
    """

    eea: dict
    gait_population: int
    gait_generations: int
    rl_timesteps: int
    gait_episodes: int = 1
    transfer_episodes: int = 1


#: ``report.json`` keys of the controllers: gait evolved on ... (``ppo``: PPO on the self-model).
CONTROLLER_KEYS: dict[str, str] = {
    "healthy": "the healthy robot",
    "plain_eea": "the plain-EEA model",
    "self_model": "the self-model",
    "out_of_band": "the out-of-band model (paper)",
    "true_damaged": "the true damaged robot (oracle)",
    "ppo": "PPO on the self-model",
}
#: Goals of the verdict: the healthy gait keeps at most this share of the oracle on the
#: target (the damage breaks it), and the self-model gait reaches at least this share of
#: the oracle and this multiple of the healthy gait (it recovers).
BREAKS_SHARE, RECOVERS_SHARE, RECOVERS_OVER_HEALTHY = 0.5, 0.8, 1.5

PRESETS: dict[str, CaseStudyPreset] = {
    # about 10-15 minutes on 2 cores
    "quick": CaseStudyPreset(
        eea=dict(duration_s=1.28, rounds=8, estimation_population=25, estimation_generations=30,
                 exploration_population=12, exploration_generations=8, exploration_models=8,
                 oob_period=10, oob_population=8, oob_generations=6),
        gait_population=30, gait_generations=12, rl_timesteps=20_000, gait_episodes=2, transfer_episodes=5,
    ),
    # a minutes-long end-to-end check of the whole pipeline (used by the tests)
    "smoke": CaseStudyPreset(
        eea=dict(duration_s=0.32, rounds=2, estimation_population=6, estimation_generations=3,
                 exploration_population=4, exploration_generations=2, exploration_models=3,
                 k_best=2, oob_period=2, oob_sample=2, oob_population=3, oob_generations=2),
        gait_population=6, gait_generations=2, rl_timesteps=256, gait_episodes=2, transfer_episodes=2,
    ),
    # about an hour on 2 cores: the paper's EEA populations and generations, 10 rounds
    "medium": CaseStudyPreset(
        eea=dict(duration_s=1.28, rounds=10), gait_population=50, gait_generations=20, rl_timesteps=100_000,
        gait_episodes=3, transfer_episodes=10,
    ),
    # the paper's settings (section 4 and 5): hours per EEA run
    "paper": CaseStudyPreset(eea=dict(duration_s=1.28, rounds=25), gait_population=150, gait_generations=100,
                             rl_timesteps=1_000_000, gait_episodes=3, transfer_episodes=10),
}


def _rl_available() -> bool:
    return importlib.util.find_spec("stable_baselines3") is not None


def run_case_study(preset: str, damage: str, seed: int, out_dir, *, inference: str = "out_of_band",
                   workers: int | None = None, progress: bool = True) -> dict:
    """Run the case study and write its report; return the report as a dict.

    Args:
        preset: ``"smoke"``, ``"quick"``, ``"medium"`` or ``"paper"`` (:data:`PRESETS`).
        damage: damage name applied to the healthy robot to make the target.
        seed: seeds every EEA run, gait evolution and RL run.
        out_dir: output directory (created; finished steps found there are reused).
        inference: the self-model's inference strategy (:data:`eea.INFERENCE_NAMES`).
        workers: processes for evaluation (default: all cores).
        progress: show progress bars.

    Raises:
        ValueError: unknown preset, damage or inference, a bad seed or worker count, or an
            ``out_dir`` that cannot be written (all checked before anything is created); an
            ``out_dir`` that another process is writing (:class:`~aquafish_gym.rundir.BusyError`)
            or whose steps were made with other settings (:class:`~aquafish_gym.rundir.MismatchError`,
            naming the fields).
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; valid: {sorted(PRESETS)}")
    settings = PRESETS[preset]
    target = get_damage(damage).apply()
    check_int("seed", seed, 0)
    if workers is not None:
        check_int("workers", workers, 1)
    runs = {"plain_eea": "none", "self_model": inference}
    if inference != "out_of_band":
        runs["out_of_band"] = "out_of_band"
    configs = {key: EEAConfig(inference=strategy, damage=damage, seed=seed, **settings.eea,
                              **({"workers": workers} if workers else {})) for key, strategy in runs.items()}
    out = check_output_dir(out_dir)
    with run_lock(out):
        return _run_locked(preset, settings, damage, target, seed, out, inference, workers, progress, runs, configs)


def _run_locked(preset: str, settings: CaseStudyPreset, damage: str, target: Morphology, seed: int, out: Path,
                inference: str, workers: int | None, progress: bool, runs: dict, configs: dict) -> dict:
    """The body of :func:`run_case_study`, under the lock of ``out``."""
    t0 = time.perf_counter()

    # 2. self-model
    eea_results = {}
    for key, strategy in runs.items():
        run_dir = out / f"eea_{strategy}"
        eea.run(configs[key], run_dir, progress=progress)
        eea_results[key] = eea.load_result(run_dir)
    models = {key: result.best_morphology for key, result in eea_results.items()}

    # 3. gaits: native robots are morphologies, the oracle's is the damaged robot (faults included)
    natives = {"healthy": Morphology.healthy(), **models, "true_damaged": gait.as_robot(damage)}
    controllers = {}
    for key, native in natives.items():
        controllers[key] = gait.evolve_or_load_gait(  # a finished gait is reused, an interrupted one resumed
            native, out / f"gait_{key}", generations=settings.gait_generations,
            population_size=settings.gait_population, seed=seed, workers=workers,
            episodes_per_genome=settings.gait_episodes, progress=progress)
    if settings.rl_timesteps and _rl_available():
        path = gait.train_or_load_rl("ppo", models["self_model"], settings.rl_timesteps, seed, out / "rl_ppo_self_model",
                                     progress=progress)
        controllers["ppo"] = gait.load_controller(path)
        natives["ppo"] = models["self_model"]

    # 4. transfer to the damaged target
    target_robot = gait.as_robot(damage)
    transfers = {key: gait.score_transfer(controllers[key], natives[key], target_robot, seed=seed,
                                          episodes=settings.transfer_episodes) for key in controllers}

    # 5. report
    panels = [(target, f"(a) target: {damage}")] + [
        (models[key], f"({chr(98 + i)}) {CONTROLLER_KEYS[key].removeprefix('the ')}") for i, key in enumerate(models)]
    figures = {
        "morphologies": plot_morphologies([m for m, _ in panels], [t for _, t in panels],
                                          out / "fig11_morphologies.png").name,
        "trajectories": gait.plot_transfer(list(transfers.values()), out / "fig12_trajectories.png",
                                           titles=[f"({chr(97 + i)}) gait of {CONTROLLER_KEYS[key].removeprefix('the ')}"
                                                   for i, key in enumerate(transfers)]).name,
    }
    controllers_report = {
        key: {"native_distance": t.native_distance, "target_distance": t.target_distance,
              "native_distances": t.native_distances.tolist(), "target_distances": t.target_distances.tolist()}
        for key, t in transfers.items()
    }
    report = {
        "preset": preset, "damage": damage, "seed": seed, "inference": inference,
        "settings": dataclasses.asdict(settings),
        "target_morphology": _dims(target),
        "models": {
            key: {
                "inference": runs[key],
                "morphology": _dims(models[key]),
                "objective_fitness": float(result.rounds[-1]["objective_fitness"]),
                "initial_angle_error_deg": dict(zip(("left", "right", "caudal"),
                                                    result.inference_error_deg[-1].round(2).tolist())),
                "target_experiments": int(result.rounds[-1]["target_experiments"]),
            }
            for key, result in eea_results.items()
        },
        "controllers": controllers_report,
        "verdict": verdict(controllers_report),
        "figures": figures,
        "wall_seconds": time.perf_counter() - t0,
    }
    atomic_write(out / "report.json", json.dumps(report, indent=2).encode())
    atomic_write(out / "report.md", render_report(report).encode())
    return report


def verdict(controllers: dict) -> dict:
    """Does the damage break the healthy gait, and how much of it does the self-model gait recover?

    From the mean distances on the damaged target (``target_distance``) of the
    ``healthy``, ``plain_eea``, ``self_model`` and ``true_damaged`` (oracle) controllers.

    Returns:
        ``breaks`` (the oracle swims forward and the healthy gait keeps at most
        :data:`BREAKS_SHARE` of it), ``self_model_share`` and ``plain_eea_share`` (share
        of the oracle's distance; None when the oracle does not swim forward),
        ``recovers`` (share >= :data:`RECOVERS_SHARE` and at least
        :data:`RECOVERS_OVER_HEALTHY` times the healthy gait), ``plain_eea_below``
        (the plain-EEA gait does worse than the self-model gait) and ``line``, one
        sentence for the report.

    Raises:
        KeyError: a controller is missing.
    """
    d = {key: float(controllers[key]["target_distance"]) for key in ("healthy", "plain_eea", "self_model", "true_damaged")}
    oracle = d["true_damaged"]
    swims = oracle > 0
    share = {key: d[key] / oracle if swims else None for key in ("healthy", "plain_eea", "self_model")}
    breaks = swims and share["healthy"] <= BREAKS_SHARE
    recovers = swims and share["self_model"] >= RECOVERS_SHARE and d["self_model"] >= RECOVERS_OVER_HEALTHY * d["healthy"] \
        and d["self_model"] > d["healthy"]
    plain_below = d["plain_eea"] < d["self_model"]
    if not swims:
        line = (f"The oracle gait does not swim forward on the damaged robot ({oracle:.2f} units): "
                "there is nothing to recover.")
    else:
        line = (f"The damage {'breaks' if breaks else 'does not break'} the healthy gait (it keeps "
                f"{share['healthy']:.0%} of the oracle gait's {oracle:.2f} units on the damaged robot). "
                f"The self-model gait {'recovers' if recovers else 'does not recover'}: "
                f"{share['self_model']:.0%} of the oracle, {_times(d['self_model'], d['healthy'])} the healthy gait; "
                f"the plain-EEA gait reaches {share['plain_eea']:.0%} "
                f"({'less than' if plain_below else 'at least as much as'} the self-model gait).")
    return {"breaks": bool(breaks), "recovers": bool(recovers), "plain_eea_below": bool(plain_below),
            "self_model_share": share["self_model"], "plain_eea_share": share["plain_eea"],
            "healthy_share": share["healthy"], "line": line}


def _times(a: float, b: float) -> str:
    return f"{a / b:.1f}x" if b > 0 else f"{a:.2f} units against {b:.2f} for"


def _dims(m: Morphology) -> dict[str, float]:
    return dict(zip(MORPHOLOGY_FIELDS, m.to_array().round(4).tolist()))


def render_report(report: dict) -> str:
    """Markdown report: the verdict, the recovered morphologies beside the target, and the transfer table."""
    lines = [f"# Damage-recovery case study: `{report['damage']}` ({report['preset']} preset, seed {report['seed']})", "",
             f"**Verdict.** {report['verdict']['line']}", ""]
    lines += ["## Recovered morphologies (paper Figure 11)", "", "![morphologies](" + report["figures"]["morphologies"] + ")", ""]
    m = report["models"]
    keys = list(m)
    lines += ["| dimension | range | target | " + " | ".join(f"{CONTROLLER_KEYS[k].removeprefix('the ')} "
                                                           f"(inference `{m[k]['inference']}`)" for k in keys) + " |",
              "|---|---|---|" + "---|" * len(keys)]
    for name, (lo, hi) in zip(MORPHOLOGY_FIELDS, MORPHOLOGY_BOUNDS):
        lines.append(f"| {name} | [{lo:g}, {hi:g}] | {report['target_morphology'][name]:.3f} | "
                     + " | ".join(f"{m[k]['morphology'][name]:.3f}" for k in keys) + " |")
    lines.append("| **objective fitness** (eq. 4) | | 1.000 | " + " | ".join(f"{m[k]['objective_fitness']:.3f}" for k in keys) + " |")
    lines.append("| target experiments used | | | " + " | ".join(str(m[k]["target_experiments"]) for k in keys) + " |")
    errors = [m[k]["initial_angle_error_deg"] for k in keys]
    if any(errors):
        lines.append("| initial-angle error, last experiment (deg: left, right, caudal) | | | " + " | ".join(
            f"{e['left']:.1f}, {e['right']:.1f}, {e['caudal']:.1f}" if e else "(not inferred)" for e in errors) + " |")
    lines += ["", "## Gait transfer (paper Figure 12)", "", "![trajectories](" + report["figures"]["trajectories"] + ")", ""]
    episodes = report["settings"]["transfer_episodes"]
    lines += [f"Forward distance in 20 s along the initial heading (units; 1 unit = 8 cm): mean over {episodes} "
              f"starts (initial flipper angles of seeds {report['seed']}..{report['seed'] + episodes - 1}, the same "
              "on both robots), with the range over starts; the figure shows the first start.", ""]
    lines += ["| gait evolved on (`report.json` key) | on its native robot | on the damaged target |", "|---|---|---|"]
    for key, c in report["controllers"].items():
        cells = [f"{np.mean(d):.2f} ({min(d):.2f} to {max(d):.2f})" for d in (c["native_distances"], c["target_distances"])]
        lines.append(f"| {CONTROLLER_KEYS[key]} (`{key}`) | {cells[0]} | {cells[1]} |")
    lines += ["", f"Wall time: {report['wall_seconds'] / 60:.1f} min.", ""]
    return "\n".join(lines)
