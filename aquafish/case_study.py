"""The damage-recovery case study (paper section 5, Figures 11 and 12).

1. The target is the healthy robot with a named damage.
2. It self-models twice with the EEA: ``none`` (plain EEA) and ``out_of_band``.
3. NEAT gaits are evolved for (a) the healthy morphology, (b) the plain-EEA model and
   (c) the out-of-band model; with the ``[rl]`` extra, PPO is also trained on (c).
4. Each controller swims on its native morphology and on the damaged target.
5. ``report.md`` / ``report.json`` and the figures are written to the output directory.

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
from aquafish_gym.files import atomic_write
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
    # the paper's settings (section 4 and 5): hours per EEA run
    "paper": CaseStudyPreset(eea=dict(duration_s=1.28, rounds=25), gait_population=150, gait_generations=100,
                             rl_timesteps=1_000_000, gait_episodes=3, transfer_episodes=10),
}


def _rl_available() -> bool:
    return importlib.util.find_spec("stable_baselines3") is not None


def run_case_study(preset: str, damage: str, seed: int, out_dir, *, workers: int | None = None, progress: bool = True) -> dict:
    """Run the case study and write its report; return the report as a dict.

    Args:
        preset: ``"quick"`` or ``"paper"`` (:data:`PRESETS`).
        damage: damage name applied to the healthy robot to make the target.
        seed: seeds every EEA run, gait evolution and RL run.
        out_dir: output directory (created; finished steps found there are reused).
        workers: processes for evaluation (default: all cores).
        progress: show progress bars.

    Raises:
        ValueError: unknown preset or damage.
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; valid: {sorted(PRESETS)}")
    settings = PRESETS[preset]
    target_damage = get_damage(damage)
    target = target_damage.apply(Morphology.healthy())
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()

    # 2. self-model twice
    models, eea_results = {}, {}
    for inference in ("none", "out_of_band"):
        config = EEAConfig(inference=inference, damage=damage, seed=seed, **settings.eea,
                           **({"workers": workers} if workers else {}))
        run_dir = out / f"eea_{inference}"
        eea.run(config, run_dir, progress=progress)
        result = eea.load_result(run_dir)
        models[inference] = result.best_morphology
        eea_results[inference] = result

    # 3. gaits
    natives = {"healthy": Morphology.healthy(), "plain EEA model": models["none"], "out-of-band EEA model": models["out_of_band"]}
    controllers = {}
    for label, morphology in natives.items():
        gait_dir = out / ("gait_" + label.split()[0].replace("-", "_"))
        controllers[label] = gait.evolve_or_load_gait(  # a finished gait is reused, an interrupted one resumed
            morphology, gait_dir, generations=settings.gait_generations, population_size=settings.gait_population,
            seed=seed, workers=workers, episodes_per_genome=settings.gait_episodes, progress=progress)
    if settings.rl_timesteps and _rl_available():
        rl_dir = out / "rl_ppo_out_of_band"
        path = rl_dir / "model.zip"
        if not (rl_dir / "model.json").exists():
            path = gait.train_rl("ppo", models["out_of_band"], settings.rl_timesteps, seed, rl_dir, progress=progress)
        controllers["PPO on out-of-band model"] = gait.load_controller(path)
        natives["PPO on out-of-band model"] = models["out_of_band"]

    # 4. transfer to the damaged target
    target_robot = gait.as_robot(damage)
    transfers = {label: gait.score_transfer(controllers[label], natives[label], target_robot, seed=seed,
                                            episodes=settings.transfer_episodes) for label in controllers}

    # 5. report
    figures = {
        "morphologies": plot_morphologies([target, models["none"], models["out_of_band"]],
                                          [f"(a) target: {damage}", "(b) plain EEA (none)", "(c) out-of-band EEA"],
                                          out / "fig11_morphologies.png").name,
        "trajectories": gait.plot_transfer(list(transfers.values()), out / "fig12_trajectories.png",
                                           titles=[f"({chr(97 + i)}) {label}" for i, label in enumerate(transfers)]).name,
    }
    report = {
        "preset": preset, "damage": damage, "seed": seed,
        "settings": dataclasses.asdict(settings),
        "target_morphology": _dims(target),
        "models": {
            inference: {
                "morphology": _dims(models[inference]),
                "objective_fitness": float(eea_results[inference].rounds[-1]["objective_fitness"]),
                "initial_angle_error_deg": dict(zip(("left", "right", "caudal"),
                                                    eea_results[inference].inference_error_deg[-1].round(2).tolist())),
                "target_experiments": int(eea_results[inference].rounds[-1]["target_experiments"]),
            }
            for inference in models
        },
        "controllers": {
            label: {"native_distance": t.native_distance, "target_distance": t.target_distance,
                    "native_distances": t.native_distances.tolist(), "target_distances": t.target_distances.tolist()}
            for label, t in transfers.items()
        },
        "figures": figures,
        "wall_seconds": time.perf_counter() - t0,
    }
    atomic_write(out / "report.json", json.dumps(report, indent=2).encode())
    atomic_write(out / "report.md", render_report(report).encode())
    return report


def _dims(m: Morphology) -> dict[str, float]:
    return dict(zip(MORPHOLOGY_FIELDS, m.to_array().round(4).tolist()))


def render_report(report: dict) -> str:
    """Markdown report: the recovered morphologies beside the target, and the transfer table."""
    lines = [f"# Damage-recovery case study: `{report['damage']}` ({report['preset']} preset, seed {report['seed']})", ""]
    lines += ["## Recovered morphologies (paper Figure 11)", "", "![morphologies](" + report["figures"]["morphologies"] + ")", ""]
    header = "| dimension | range | target | plain EEA (`none`) | out-of-band EEA |"
    lines += [header, "|---|---|---|---|---|"]
    for name, (lo, hi) in zip(MORPHOLOGY_FIELDS, MORPHOLOGY_BOUNDS):
        lines.append(f"| {name} | [{lo:g}, {hi:g}] | {report['target_morphology'][name]:.3f} | "
                     f"{report['models']['none']['morphology'][name]:.3f} | {report['models']['out_of_band']['morphology'][name]:.3f} |")
    m = report["models"]
    lines.append(f"| **objective fitness** (eq. 4) | | 1.000 | {m['none']['objective_fitness']:.3f} | {m['out_of_band']['objective_fitness']:.3f} |")
    lines.append(f"| target experiments used | | | {m['none']['target_experiments']} | {m['out_of_band']['target_experiments']} |")
    err = m["out_of_band"]["initial_angle_error_deg"]
    if err:
        lines.append(f"| initial-angle error, last experiment (deg: left, right, caudal) | | | (not inferred) | "
                     f"{err['left']:.1f}, {err['right']:.1f}, {err['caudal']:.1f} |")
    lines += ["", "## Gait transfer (paper Figure 12)", "", "![trajectories](" + report["figures"]["trajectories"] + ")", ""]
    episodes = report["settings"]["transfer_episodes"]
    lines += [f"Forward distance in 20 s along the initial heading (units; 1 unit = 8 cm): mean over {episodes} "
              f"starts (initial flipper angles of seeds {report['seed']}..{report['seed'] + episodes - 1}, the same "
              "on both robots), with the range over starts; the figure shows the first start.", ""]
    lines += ["| controller evolved on | on its native morphology | on the damaged target |", "|---|---|---|"]
    for label, c in report["controllers"].items():
        cells = [f"{np.mean(d):.2f} ({min(d):.2f} to {max(d):.2f})" for d in (c["native_distances"], c["target_distances"])]
        lines.append(f"| {label} | {cells[0]} | {cells[1]} |")
    lines += ["", f"Wall time: {report['wall_seconds'] / 60:.1f} min.", ""]
    return "\n".join(lines)
