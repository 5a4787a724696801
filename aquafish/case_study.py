"""The damage-recovery case study (paper section 5, Figures 11 and 12).

1. The target is the healthy robot with a named damage.
2. It self-models with the EEA: ``none`` (plain EEA, the paper's ``morphology`` model space)
   and the self-model (``self_model``: method default ``profile_lineages``, the best method
   (:mod:`eea.methods`), model space default ``morphology+servos``, so the model also holds a
   gain per servo). Unless the self-model is the paper's (``out_of_band`` in ``morphology``),
   the paper's ``out_of_band`` run in ``morphology`` runs too and stays a row. Every EEA run
   uses the preset's budget (:data:`eea.methods.BUDGETS`, the same name).
3. NEAT gaits are evolved for the healthy morphology, every EEA model (a
   ``morphology+servos`` model's gains become its robot's
   ``ServoFaults(speed_scale=gains)``: the gait is evolved on the model with its servos as
   modelled), the true damaged robot (the oracle, :mod:`aquafish.oracle`: the best of three
   runs with three times the gait budget and seeds no other row uses, so that no row equals it
   by construction) and,
   with the same budget, the healthy robot with a damage preset drawn per episode
   (``robust``, ``damage="random"``: a damage-robust gait, which needs no self-model). With
   the ``[rl]`` extra, PPO policies are trained on the self-model (``ppo``) and on the healthy
   robot with random damages (``robust_ppo``), each for as many env steps as one NEAT gait
   simulates (:attr:`CaseStudyPreset.rl_timesteps`).
4. Each controller swims on its native robot and on the damaged target, from the same
   starts, for ``episode_duration_s`` simulated seconds (gait evolution too; 20 s, the
   paper's, by default; the surface swimmer's veering costs distance over 60 s).
5. ``report.md`` / ``report.json``, the figures and ``recovery.mp4`` (a video of the damaged
   robot under the healthy, self-model and oracle gaits from above, 1280 x 720 at 2x real
   time, flippers and paths drawn; ``recovery.gif`` without imageio's ffmpeg plugin,
   :mod:`gait.video`) are written to the
   output directory. The controllers have stable keys (:data:`CONTROLLER_KEYS`), and
   :func:`verdict` says whether the damage breaks the healthy gait, how much of the oracle
   the self-model gait recovers, and which rows recover.

Every step writes into its own sub-directory and is skipped when its result exists, so an
interrupted case study resumes where it stopped. With ``shared_dir``, the rows that do not
depend on the damage (:data:`SHARED_KEYS`) are trained, or loaded when finished, there instead,
so case studies of one seed on several damages share them (:mod:`aquafish.recovery`). With
``all_rows=False`` (the recovery benchmark's default) the healthy and oracle gaits come first,
and the rest runs only when the damage breaks the healthy gait (:func:`breaks`); with
``triage_only`` too, nothing runs after them (a later run goes on from there). The report's
``stage_seconds`` holds the wall seconds of every stage
(``aquafish bench case_study_stages``).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.util
import json
import logging
import os
import shutil
import time
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

import numpy as np

import eea
import gait
from aquafish.oracle import (OracleGait, check_procedure_seed, neat_budget, oracle_jobs, ppo_budget,
                             select_oracle)
from aquafish_gym import DT_S, MORPHOLOGY_BOUNDS, MORPHOLOGY_FIELDS, Morphology, ServoFaults, get_damage
from aquafish_gym.drawing import plot_morphologies
from aquafish_gym.env import FRAME_SKIP
from aquafish_gym.checks import check_int, check_seconds
from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import BusyError, check_output_dir, read_json, run_lock, spawn_pool
from eea import EEAConfig
from eea.methods import BEST_METHOD
from eea.search.hypotheses import HYPOTHESIS_SPACE
from gait.controller import SB3_MODEL_FILE, sb3_sidecar
from gait.neat_evolution import SETTINGS_FILE as NEAT_SETTINGS_FILE
from gait.robots import RANDOM_DAMAGE, Robot
from gait.shared_pool import SharedPool
from gait.video import record_video

#: The paper's model space (the plain-EEA and out-of-band rows) and the self-model's default.
PAPER_MODEL_SPACE, DEFAULT_MODEL_SPACE = "morphology", "morphology+servos"
#: The self-model's default method: the best (docs/self_modeling.md).
DEFAULT_METHOD = BEST_METHOD
#: The paper's behaviour summary (the plain-EEA and out-of-band rows) and the self-model's default.
PAPER_SUMMARY, DEFAULT_SUMMARY = "dft", "signed_dft"
#: The servo gains a ``morphology+servos`` model holds, in order (``ServoFaults.speed_scale``).
GAIN_NAMES = ("left_pectoral_gain", "right_pectoral_gain", "caudal_gain")
#: The gaits shown in the recovery video (on the damaged robot), with their panel titles.
VIDEO_GAITS = {"healthy": "healthy gait", "self_model": "self-model gait", "true_damaged": "oracle gait"}


@dataclasses.dataclass(frozen=True)
class CaseStudyPreset:
    """Settings of one case-study preset.

    Attributes:
        budget: the EEA budget of every self-modeling run (:data:`eea.methods.BUDGETS`).
        gait_population, gait_generations: NEAT settings for every gait.
        gait_episodes: starts (initial flipper angles) per NEAT genome evaluation; the
            fitness is the mean distance. One start overfits the gait to it.
        transfer_episodes: paired starts per transfer score (native and target); the
            report gives mean distances.
        episode_duration_s: simulated seconds of every gait-evolution and transfer episode
            (20 s, the paper's; ``run_case_study(episode_duration_s=...)`` overrides it).
        self_model_fields: EEA settings of the self-model's run over its method's and
            budget's (flat names, :data:`eea.config.FLAT_FIELDS`) when it runs the default
            method (with another model space than ``morphology+servos``, fields that rank the
            fault hypotheses give way to :data:`LEAN_SELF_MODEL_FIELDS`);
            ``run_case_study(self_model_fields=...)`` goes over them.
    """

    budget: str
    gait_population: int
    gait_generations: int
    gait_episodes: int = 1
    transfer_episodes: int = 1
    episode_duration_s: float = 20.0
    self_model_fields: Mapping = dataclasses.field(default_factory=dict)

    @property
    def rl_timesteps(self) -> int:
        """Training env steps of each PPO row (``ppo`` on the self-model, ``robust_ppo`` with
        random damages; trained when stable-baselines3 is installed): as many as one NEAT gait
        simulates (population x generations x starts per genome x control steps per episode,
        0.1 s each), so a policy and a gait get the same training budget."""
        steps = int(round(self.episode_duration_s / (DT_S * FRAME_SKIP)))
        return self.gait_population * self.gait_generations * self.gait_episodes * steps


#: ``report.json`` keys of the controllers: gait evolved on ... (``ppo``: PPO on the self-model).
CONTROLLER_KEYS: dict[str, str] = {
    "healthy": "the healthy robot",
    "plain_eea": "the plain-EEA model",
    "self_model": "the self-model",
    "out_of_band": "the out-of-band model (paper)",
    "true_damaged": "the true damaged robot (oracle)",
    "robust": "random damages (damage-robust)",
    "ppo": "PPO on the self-model",
    "robust_ppo": "PPO on random damages (damage-robust)",
}
#: The damage-robust rows: trained on the healthy robot with a damage preset drawn per episode.
ROBUST_KEYS = ("robust", "robust_ppo")
#: The rows that do not depend on the damage (trained on the healthy robot, or on it with
#: random damages): ``run_case_study(shared_dir=...)`` trains or loads them there, so case
#: studies of one seed on several damages share them (``aquafish recovery``).
SHARED_KEYS = ("healthy", "robust", "robust_ppo")
#: How long a case study waits for a shared row's directory that another case study is
#: reading (its lock is held for the moment of a load) before it gives up with the BusyError.
SHARED_WAIT_S = 60.0
#: Goals of the verdict: the healthy gait keeps at most this share of the oracle on the
#: target (the damage breaks it), and the self-model gait reaches at least this share of
#: the oracle and this multiple of the healthy gait (it recovers).
BREAKS_SHARE, RECOVERS_SHARE, RECOVERS_OVER_HEALTHY = 0.5, 0.8, 1.5

#: The lean self-model search: one lineage, no profile refinement or angle library, 2 angle
#: sets per exploration action and 15 estimation generations a round (about 57,000 search
#: simulations in 8 rounds at ``quick`` against the full method's 400,000; the check after it
#: unchanged). Every mission's recovery and the ``quick`` and ``medium`` case studies' in
#: another model space than ``morphology+servos`` run it (docs/studies/recovery.md, "The lean
#: search in the case study").
LEAN_SELF_MODEL_FIELDS = MappingProxyType({"lineages": 1, "profile_refine": 0, "profile_library": 0,
                                           "exploration_angles": 2, "estimation_generations": 15})

#: The ranked fault hypotheses instead of a search (``estimation_search="hypotheses"``,
#: :mod:`eea.search.hypotheses`), the ``quick`` and ``medium`` case studies' self-model since
#: 2026-12-02 (docs/main_job.md for ``medium``): the lean search's exploration, the
#: estimation offering the check's 97 fault hypotheses about the design every generation (3 a
#: round, their angles fitted by the ``profile`` strategy), the exploration's candidates the
#: best-ranked of them (``exploration_diversity=0``), and the check given the angles the run
#: fitted as its screen.
#: About 83,000 simulations a run at ``quick`` against the lean search's 160,000; the truth on
#: 20 of 20 held-out ``reversed_left_pectoral`` seeds, every faulty servo named on 28 of 28
#: held-out sampled faults (docs/studies/recovery.md, "Ranking the fault hypotheses instead of
#: a search"). It needs the ``morphology+servos`` model space; in another the presets run
#: :data:`LEAN_SELF_MODEL_FIELDS`.
HYPOTHESES_SELF_MODEL_FIELDS = MappingProxyType({**LEAN_SELF_MODEL_FIELDS, "estimation_search": "hypotheses",
                                                 "estimation_generations": 3, "exploration_diversity": 0})

PRESETS: dict[str, CaseStudyPreset] = {
    # about 4.3 minutes on 2 idle cores, the independent oracle's 3 runs included (`make demo`):
    # the self-model ranks the fault hypotheses, PPO's cheaper updates
    "quick": CaseStudyPreset(
        budget="quick", gait_population=30, gait_generations=12, gait_episodes=2, transfer_episodes=5,
        self_model_fields=dict(HYPOTHESES_SELF_MODEL_FIELDS),  # a dict: a preset goes to PPO's processes (pickled)
    ),
    # a minutes-long end-to-end check of the whole pipeline (used by the tests)
    "smoke": CaseStudyPreset(
        budget="smoke", gait_population=6, gait_generations=2, gait_episodes=2, transfer_episodes=2,
    ),
    # the paper's EEA populations and generations, 10 rounds; the self-model ranks the fault
    # hypotheses (2026-12-02: 13-14 minutes on 2 idle cores on a fast day, 0.93x the lean search's
    # case study on the same day; the same rows as the lean and the full search on seeds 0-2)
    "medium": CaseStudyPreset(
        budget="medium", gait_population=50, gait_generations=20, gait_episodes=3, transfer_episodes=10,
        self_model_fields=dict(HYPOTHESES_SELF_MODEL_FIELDS),
    ),
    # the paper's settings (section 4 and 5): hours per EEA run
    "paper": CaseStudyPreset(budget="paper", gait_population=150, gait_generations=100, gait_episodes=3,
                             transfer_episodes=10),
}


#: Why the PPO rows are missing when they are (the report says so).
MISSING_RL = "stable-baselines3 is not installed (pip install 'aquafish[rl]')"


#: EEA settings the case study sets itself, which ``self_model_fields`` may not hold, and how
#: they are set instead.
CASE_STUDY_FIELDS = {"inference": "the method: --method / method=", "damage": "--damage / damage=",
                     "seed": "--seed / seed=", "model_space": "--model-space / model_space=",
                     "behaviour_summary": "--behaviour-summary / behaviour_summary=",
                     "workers": "--workers / workers=",
                     "waterline": "the case study's robots swim at the surface; deep water is for EEA studies"}


def _rl_available() -> bool:
    return importlib.util.find_spec("stable_baselines3") is not None


def run_case_study(preset: str, damage: str, seed: int, out_dir, *, method: str = DEFAULT_METHOD,
                   model_space: str = DEFAULT_MODEL_SPACE, behaviour_summary: str = DEFAULT_SUMMARY,
                   episode_duration_s: float | None = None,
                   video: bool = True, workers: int | None = None, progress: bool = True,
                   shared_dir=None, all_rows: bool = True, triage_only: bool = False,
                   self_model_fields: Mapping | None = None, oracle_dir=None) -> dict:
    """Run the case study and write its report; return the report as a dict.

    Args:
        preset: ``"smoke"``, ``"quick"``, ``"medium"`` or ``"paper"`` (:data:`PRESETS`).
        damage: damage applied to the healthy robot to make the target: a preset name, a JSON
            fault (inline or a ``.json`` file, recorded as its canonical JSON) or ``sampled:SEED``
            (:func:`aquafish_gym.get_damage`).
        seed: seeds every EEA run, gait evolution and RL run.
        out_dir: output directory (created; finished steps found there are reused).
        method: the self-model's method (:data:`eea.methods.METHODS`; default the best,
            ``profile_lineages``).
        model_space: the self-model's model space (``eea.MODEL_SPACES``): ``"morphology+servos"``
            (default: the nine dimensions and a gain per servo, which reach its gait's robot as
            ``ServoFaults(speed_scale=gains)``) or ``"morphology"`` (the paper's). The plain-EEA
            and out-of-band rows always use ``"morphology"``. In ``morphology+servos`` a CMA-ES
            self-model (the best method's search) also tries the best model with its pectoral
            gains' signs flipped at every restart (``cma_flip_gains``).
        behaviour_summary: the self-model's behaviour summary (``eea.behaviour.SUMMARIES``):
            ``"signed_dft"`` (default: the zero-frequency term signed, so the self-model can
            tell a reversed left servo from a reversed right one) or ``"dft"`` (the paper's,
            which the plain-EEA and out-of-band rows always use).
        episode_duration_s: simulated seconds of every gait-evolution, transfer and video
            episode (default: the preset's, 20 s). Runs of another length go to their own
            ``gait_<key>_<N>s`` directories, so both lengths can share ``out_dir``.
        video: write the recovery video (``recovery.mp4``, or ``.gif`` without imageio-ffmpeg).
        workers: processes for evaluation (default: all cores).
        progress: show progress bars.
        shared_dir: where the rows that do not depend on the damage (:data:`SHARED_KEYS`: the
            healthy and the damage-robust gaits, the damage-robust PPO policy) are trained, or
            loaded when finished (:func:`train_shared_rows` trains them beforehand); default
            ``out_dir``, like every other row. The report then records it as ``shared_dir``.
        all_rows: True (default): every row. False: first the healthy and the oracle gaits,
            scored on the damaged robot; when the damage does not break the healthy gait
            (:func:`breaks`), the report holds those two rows only (``"triaged": true``, no
            models, figures or video) and nothing else is run. A later run with ``all_rows``
            on the same ``out_dir`` adds the other rows (the two gaits are reused).
        triage_only: with ``all_rows`` False, stop after the triage whatever it finds: the
            report holds the two rows and says whether the damage breaks the healthy gait
            (``"triaged": true``). A later run without it on the same ``out_dir`` goes on
            from there (the recovery benchmark triages every cell before the rest).
        self_model_fields: :class:`~eea.config.EEAConfig` settings of the self-model's run, by
            flat name (:data:`eea.config.FLAT_FIELDS`), over the preset's
            (:attr:`CaseStudyPreset.self_model_fields`: with the default method, ``quick`` runs
            :data:`HYPOTHESES_SELF_MODEL_FIELDS`, as ``medium`` does)
            and its method's and budget's, e.g.
            ``{"estimation_generations": 30}`` (default: none). The other rows keep theirs. Not
            one the case study sets itself (:data:`CASE_STUDY_FIELDS`); the report records the
            preset's and these as ``self_model_fields``.
        oracle_dir: where the oracle's runs (:mod:`aquafish.oracle`) are evolved, or loaded
            when finished; default ``out_dir``. The oracle does not depend on ``seed``, so case
            studies of one damage, preset and duration can share it (``aquafish recovery``).

    Raises:
        ValueError: unknown preset, damage, method or model space, a bad seed, duration or
            worker count, ``triage_only`` with ``all_rows``, a self-model field that is unknown,
            out of its range or set by the case study itself, or an ``out_dir`` or ``shared_dir``
            that cannot be written (all checked before anything is created); an ``out_dir``
            that another process is writing
            (:class:`~aquafish_gym.rundir.BusyError`) or whose steps were made with other
            settings (:class:`~aquafish_gym.rundir.MismatchError`, naming the fields). A
            gait or PPO policy trained on an earlier self-model of the same run (its EEA run or
            check made again) is not an error: it is moved aside and trained again
            (:func:`retire_if_other_robot`).
    """
    settings = preset_settings(preset, episode_duration_s)
    resolved = get_damage(damage)
    damage, target = resolved.name, resolved.apply()  # canonical text: a JSON file is read once, recorded as its content
    check_procedure_seed(seed)
    if workers is not None:
        check_int("workers", workers, 1)
    if triage_only and all_rows:
        raise ValueError("triage_only=True needs all_rows=False (a triage runs the healthy and oracle rows only)")
    runs = {"plain_eea": ("none", PAPER_MODEL_SPACE, PAPER_SUMMARY),
            "self_model": (method, model_space, behaviour_summary)}
    if (method, model_space, behaviour_summary) != ("out_of_band", PAPER_MODEL_SPACE, PAPER_SUMMARY):
        runs["out_of_band"] = ("out_of_band", PAPER_MODEL_SPACE, PAPER_SUMMARY)
    own = own_self_model_fields(settings, self_model_fields, method, model_space, behaviour_summary)
    configs = {key: EEAConfig.from_method(name, settings.budget, damage=damage, seed=seed,
                                          **model_fields(name, space, summary, own if key == "self_model" else None),
                                          **({"workers": workers} if workers else {}))
               for key, (name, space, summary) in runs.items()}
    check_sizes(settings, configs, workers)
    out = check_output_dir(out_dir)
    shared = None if shared_dir is None else check_output_dir(shared_dir, "shared_dir")
    oracle = out if oracle_dir is None else check_output_dir(oracle_dir, "oracle_dir")
    with run_lock(out, command="case-study"):
        return _run_locked(preset, settings, damage, target, seed, out, method, model_space, video, workers,
                           progress, runs, configs, shared, all_rows, triage_only, own, oracle)


def check_sizes(settings: CaseStudyPreset, configs: Mapping[str, EEAConfig], workers: int | None = None) -> None:
    """Refuse, before anything is written, a case study (or a recovery benchmark's cells) that
    would fail or run out of memory part-way: episodes too short for a PPO row to train a single
    step (with the ``[rl]`` extra), gaits whose population and episodes cannot fit
    (:func:`gait.neat_evolution.check_gait_memory`, as ``aquafish gait`` refuses them) and EEA
    runs that cannot (:func:`eea.run.check_run_memory`, as ``aquafish eea`` refuses them; e.g.
    ``--self-model-fields`` with a population of 10**9).

    Args:
        settings: the preset, with the episode duration asked for.
        configs: the EEA runs' configs by row (``self_model``'s holds ``--self-model-fields``).
        workers: the evaluation processes of each gait (None: every core).

    Raises:
        ValueError: one line naming the setting.
    """
    from eea.run import check_run_memory
    from gait.neat_evolution import check_gait_memory

    if _rl_available() and settings.rl_timesteps < 1:
        raise ValueError(f"--episode-duration-s {settings.episode_duration_s:g} is shorter than half a control step "
                         f"({DT_S * FRAME_SKIP:g} s), so the PPO rows would train for 0 steps; give more than "
                         f"{DT_S * FRAME_SKIP / 2:g}")
    check_gait_memory(settings.gait_population, settings.episode_duration_s, workers or os.cpu_count() or 1)
    for key, config in configs.items():
        try:
            check_run_memory(config)
        except ValueError as err:
            if key != "self_model":
                raise
            raise ValueError(f"--self-model-fields: the self-model's EEA run with {err}") from None


def check_self_model_fields(fields: Mapping | None, budget: str, method: str = DEFAULT_METHOD,
                            model_space: str = DEFAULT_MODEL_SPACE,
                            behaviour_summary: str = DEFAULT_SUMMARY) -> dict:
    """``run_case_study``'s ``self_model_fields`` as a plain dict (``{}`` for None), checked by
    building the self-model's :class:`~eea.config.EEAConfig` with them.

    Args:
        fields: EEAConfig flat names -> values, or None.
        budget: the case study's EEA budget (its preset's).
        method: the self-model's method, as ``run_case_study``'s.
        model_space: the self-model's model space, as ``run_case_study``'s.
        behaviour_summary: the self-model's behaviour summary, as ``run_case_study``'s.

    Raises:
        ValueError: not a mapping of flat names; a name of :data:`CASE_STUDY_FIELDS` (the
            message names the argument that sets it); or, prefixed ``self_model_fields:``, an
            unknown name or a value out of range (:meth:`eea.config.EEAConfig.from_flat`).
    """
    if fields is None:
        return {}
    if not isinstance(fields, Mapping) or not all(isinstance(k, str) for k in fields):
        raise ValueError(f"self_model_fields must map EEAConfig flat names to values, got {fields!r}")
    for name in fields:
        if name in CASE_STUDY_FIELDS:
            raise ValueError(f"self_model_fields may not set {name!r}: the case study sets it "
                             f"({CASE_STUDY_FIELDS[name]})")
    own = dict(fields)
    try:
        EEAConfig.from_method(method, budget, **model_fields(method, model_space, behaviour_summary, own))
    except ValueError as err:
        raise ValueError(f"self_model_fields: {err}") from None
    return own


def own_self_model_fields(settings: CaseStudyPreset, fields: Mapping | None, method: str = DEFAULT_METHOD,
                          model_space: str = DEFAULT_MODEL_SPACE, behaviour_summary: str = DEFAULT_SUMMARY) -> dict:
    """The self-model run's settings of its own in a case study of ``settings``: the preset's
    (:attr:`CaseStudyPreset.self_model_fields`, when the self-model runs the default method)
    with ``fields`` over them, checked as :func:`check_self_model_fields` checks them.

    Raises:
        ValueError: as :func:`check_self_model_fields`, for ``fields`` alone or with the preset's.
    """
    own = check_self_model_fields(fields, settings.budget, method, model_space, behaviour_summary)
    if method != DEFAULT_METHOD or not settings.self_model_fields:
        return own
    preset = settings.self_model_fields
    if model_space != HYPOTHESIS_SPACE and preset.get("estimation_search") == "hypotheses":
        preset = LEAN_SELF_MODEL_FIELDS  # the fault hypotheses hold the design's servo gains
    return check_self_model_fields({**preset, **own}, settings.budget, method, model_space, behaviour_summary)


def format_self_model_fields(fields: Mapping) -> str:
    """``fields`` (EEAConfig flat names -> values) as Markdown: ```name = value``` items, by name,
    joined by commas; how the case study's report, the recovery summary and the mission table
    state a self-model's settings of its own."""
    return ", ".join(f"`{k} = {v!r}`" for k, v in sorted(fields.items()))


def preset_settings(preset: str, episode_duration_s: float | None = None) -> CaseStudyPreset:
    """The settings of ``preset``, with ``episode_duration_s`` (simulated seconds) when given.

    Raises:
        ValueError: an unknown preset, or a duration that is no positive finite number.
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; valid: {sorted(PRESETS)}")
    settings = PRESETS[preset]
    if episode_duration_s is not None:
        settings = dataclasses.replace(settings, episode_duration_s=check_seconds("episode_duration_s",
                                                                                   episode_duration_s))
    return settings


def train_shared_rows(preset: str, seed: int, shared_dir, *, episode_duration_s: float | None = None,
                      workers: int | None = None, progress: bool = True) -> list[Path]:
    """Train (or find finished) the rows that do not depend on the damage (:data:`SHARED_KEYS`)
    in ``shared_dir``, as :func:`run_case_study` with ``shared_dir`` would: the healthy gait,
    the damage-robust gait and, with the ``[rl]`` extra, the damage-robust PPO policy. Case
    studies of this preset, duration and seed given ``shared_dir`` then only load them.

    Returns:
        The rows' run directories.

    Raises:
        ValueError: an unknown preset, a bad seed, duration or worker count, a ``shared_dir``
            that cannot be written, one of its runs busy (:class:`~aquafish_gym.rundir.BusyError`)
            or made with other settings (:class:`~aquafish_gym.rundir.MismatchError`).
    """
    settings = preset_settings(preset, episode_duration_s)
    check_int("seed", seed, 0)
    if workers is not None:
        check_int("workers", workers, 1)
    shared = check_output_dir(shared_dir, "shared_dir")
    natives = _shared_natives()
    dirs = []
    for key in ("healthy", "robust"):
        dirs.append(shared / _gait_dir(key, settings.episode_duration_s))
        _evolve(natives[key], dirs[-1], settings, seed, workers, progress)
    if _rl_available():
        dirs.append(shared / _rl_dir("random_damage", settings.episode_duration_s))
        _train_ppo(natives["robust"], dirs[-1], settings, seed, progress)
    return dirs


def _shared_natives() -> dict[str, Robot]:
    """The native robots of the NEAT rows of :data:`SHARED_KEYS`: the healthy robot, and the
    healthy robot with a damage preset drawn per episode."""
    return {"healthy": Robot(Morphology.healthy(), "none", "healthy"),
            "robust": Robot(Morphology.healthy(), RANDOM_DAMAGE, "random damage")}


def _evolve(native: Robot, run_dir: Path, settings: CaseStudyPreset, seed: int, workers: int | None, progress: bool,
            pool: SharedPool | None = None):
    """The NEAT gait of ``native`` in ``run_dir`` with the preset's budget (a finished gait is
    reused, an interrupted one resumed); its worlds evaluated on ``pool`` when given."""
    return gait.evolve_or_load_gait(
        native, run_dir, generations=settings.gait_generations, population_size=settings.gait_population,
        seed=seed, workers=workers, episodes_per_genome=settings.gait_episodes,
        episode_duration_s=settings.episode_duration_s, progress=progress, shared=pool)


def _train_ppo(native: Robot, run_dir: Path, settings: CaseStudyPreset, seed: int, progress: bool) -> Path:
    """The PPO policy of ``native`` in ``run_dir`` for :attr:`CaseStudyPreset.rl_timesteps`
    (a finished one is reused); its ``model.zip``."""
    # one torch thread: the small MLP trains fastest so (1,070 steps/s against 205 with
    # torch's default of 2 threads, beside a 2-process study on the 2-core machine), and the
    # policy does not depend on the machine's core count
    return gait.train_or_load_rl("ppo", native, settings.rl_timesteps, seed, run_dir,
                                 episode_duration_s=settings.episode_duration_s, num_threads=1, progress=progress)


def _train_ppo_rows(jobs: dict[str, tuple[Robot, Path]], settings: CaseStudyPreset, seed: int, progress: bool,
                    processes: int) -> dict[str, Path]:
    """:func:`_train_ppo` of every ``key: (native, run_dir)``: one after the other, or with more
    than one process each in its own (a PPO row trains on one torch thread, so two rows fill two
    cores; each gives the policy it gives in-process: the same seeds, one thread)."""
    if processes == 1 or len(jobs) == 1:
        return {key: _train_ppo(native, run_dir, settings, seed, progress) for key, (native, run_dir) in jobs.items()}
    with spawn_pool(min(processes, len(jobs))) as pool:
        futures = {key: pool.submit(_train_ppo, native, run_dir, settings, seed, progress)
                   for key, (native, run_dir) in jobs.items()}
        return {key: future.result() for key, future in futures.items()}


#: The suffix a gait or policy directory trained on an earlier self-model is moved to.
REPLACED_SUFFIX = ".replaced"


def retire_if_other_robot(run_dir: Path, robot: Robot) -> bool:
    """Move aside a gait or PPO run in ``run_dir`` trained on another robot than ``robot``.

    A self-model row's gait is trained on the run's self-model; when that model changes (an EEA
    run made again, or its check against fault hypotheses recorded anew with other hypotheses),
    the gait or policy trained on the old model no longer belongs to the case study. It is
    renamed to ``<run_dir>.replaced`` (an older one there is deleted) and a warning names the
    directory, so the row is trained again on the new model instead of refusing to go on.
    A run of other settings on the same robot is left where it is (reusing it still raises
    :class:`~aquafish_gym.rundir.MismatchError`).

    Args:
        run_dir: a NEAT run (``fitness_settings.json``) or PPO run (``model.json``) directory;
            a missing or empty directory is left alone.
        robot: the robot the row trains on now.

    Returns:
        Whether the directory was moved aside.
    """
    for path in (run_dir / NEAT_SETTINGS_FILE, sb3_sidecar(run_dir / SB3_MODEL_FILE)):
        if path.is_file():
            recorded = read_json(path).get("robot")
            break
    else:
        return False
    if recorded == json.loads(json.dumps(robot.to_dict())):
        return False
    replaced = run_dir.with_name(run_dir.name + REPLACED_SUFFIX)
    if replaced.exists():
        shutil.rmtree(replaced)
    run_dir.rename(replaced)
    logging.getLogger(__name__).warning(
        "case-study: %s was trained on another self-model than this run's; moved to %s and trained again",
        run_dir, replaced.name)
    return True


def _rl_dir(name: str, duration_s: float) -> str:
    """``rl_ppo_<name>`` for the paper's 20 s episodes, ``rl_ppo_<name>_<N>s`` for others."""
    return f"rl_ppo_{name}" if duration_s == 20.0 else f"rl_ppo_{name}_{duration_s:g}s"


def _wait_if_busy(load, seconds: float = SHARED_WAIT_S):
    """``load()``, tried again while its directory is busy (another case study loading the same
    shared row), for up to ``seconds``.

    Raises:
        BusyError: still busy after ``seconds``.
    """
    deadline = time.monotonic() + seconds
    while True:
        try:
            return load()
        except BusyError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


def model_fields(method: str = DEFAULT_METHOD, model_space: str = DEFAULT_MODEL_SPACE,
                 behaviour_summary: str = DEFAULT_SUMMARY, own: Mapping | None = None) -> dict:
    """The :class:`~eea.config.EEAConfig` fields of a case-study model run beside its method
    and budget: the model space, the behaviour summary and, for a CMA-ES search in
    ``morphology+servos``, ``cma_flip_gains=1`` (every restart also tries the best model with
    its pectoral gains' signs flipped; docs/self_modeling.md), then the run's settings of its own
    ``own`` (flat names) over them; the search is ``own``'s ``estimation_search`` when it names one,
    else the method's. The defaults give the self-model's without settings of its own:
    ``EEAConfig.from_method(DEFAULT_METHOD, budget, **model_fields())``."""
    own = dict(own or {})
    search = own.get("estimation_search", EEAConfig.from_method(method).estimation.search.name)
    flips = {"cma_flip_gains": 1} if search == "cma" and model_space != PAPER_MODEL_SPACE else {}
    return {"model_space": model_space, "behaviour_summary": behaviour_summary, **flips, **own}


def eea_dir_name(method: str, space: str, summary: str) -> str:
    """``eea_<method>`` in the paper's model space and summary, ``_servos`` added in
    ``morphology+servos``, ``_signed`` with the signed summary."""
    return (f"eea_{method}" + ("" if space == PAPER_MODEL_SPACE else f"_{space.removeprefix('morphology+')}")
            + ("" if summary == PAPER_SUMMARY else "_signed"))


def _gait_dir(key: str, duration_s: float) -> str:
    """``gait_<key>`` for the paper's 20 s episodes, ``gait_<key>_<N>s`` for others."""
    return f"gait_{key}" if duration_s == 20.0 else f"gait_{key}_{duration_s:g}s"


def model_robot(result, label: str) -> Robot:
    """The robot a run's self-model (:attr:`eea.RunResult.self_model`: in ``morphology+servos``
    the model its check against fault hypotheses kept) describes: its morphology, and in
    ``morphology+servos`` its servo
    gains as ``ServoFaults(speed_scale=gains)`` (so a gait evolved on it meets the modelled
    servos, e.g. a reversed pectoral as gain -1).

    Args:
        result: an EEA run's :class:`eea.RunResult` (``eea.load_result``).
        label: the robot's label.
    """
    gains = _model_gains(result)
    faults = None if gains is None else ServoFaults(speed_scale=tuple(gains))
    return Robot(result.self_model_morphology, "none", label, faults)


def _model_gains(result) -> list[float] | None:
    """The self-model's servo gains of a ``morphology+servos`` run (None in ``morphology``)."""
    model = np.asarray(result.self_model, dtype=float)
    return None if model.size == len(MORPHOLOGY_FIELDS) else model[len(MORPHOLOGY_FIELDS):].tolist()


def _fault_check_report(result) -> dict | None:
    """A ``morphology+servos`` run's check for the report: the final model's servo gains and
    OBJ_FIT before the check, whether a hypothesis replaced it, whether the kept model's
    gains were polished and the check's ``procedure`` (:data:`eea.fault_check.FAULT_CHECK_PROCEDURE`
    when made by today's; None without a check)."""
    check = result.fault_check
    if check is None:
        return None
    return {"replaced": check.index != 0, "polished": check.polished,
            "final_servo_gains": dict(zip(GAIN_NAMES, check.final_model[len(MORPHOLOGY_FIELDS):].tolist())),
            "final_objective_fitness": float(result.rounds[-1]["objective_fitness"]),
            "simulations": check.simulations, "procedure": check.procedure}


def _true_gains(damage: str) -> list[float]:
    """The damaged target's servo gains: ``speed_scale``, 0 where a servo is seized."""
    faults = get_damage(damage).faults
    return [0.0 if seized else float(g) for seized, g in zip(faults.seized, faults.speed_scale)]


def _identification(models: dict, eea_results: dict, target: Morphology, damage: str) -> dict | None:
    """The report's ``identification``: the self-model's strict judgement against the target
    (:func:`eea.identification.identification` of the report's rounded dimensions and the
    gains); None without a self-model or when it holds no servo gains (``morphology`` space)."""
    from eea.identification import identification

    gains = _model_gains(eea_results["self_model"]) if "self_model" in eea_results else None
    if gains is None:
        return None
    dims, target_dims = _dims(models["self_model"]), _dims(target)
    return identification([dims[f] for f in MORPHOLOGY_FIELDS] + gains,
                          [target_dims[f] for f in MORPHOLOGY_FIELDS] + _true_gains(damage))


def _run_locked(preset: str, settings: CaseStudyPreset, damage: str, target: Morphology, seed: int, out: Path,
                method: str, model_space: str, video: bool, workers: int | None, progress: bool, runs: dict,
                configs: dict, shared: Path | None = None, all_rows: bool = True,
                triage_only: bool = False, own: dict | None = None, oracle_dir: Path | None = None) -> dict:
    """The body of :func:`run_case_study`, under the lock of ``out`` (the rows of
    :data:`SHARED_KEYS` in ``shared`` when given, the oracle's runs in ``oracle_dir``)."""
    t0 = time.perf_counter()
    processes = workers if workers is not None else (os.cpu_count() or 1)  # of the gaits and the PPO rows
    triage_s = 0.0 if triage_only else _triage_seconds(out)  # a triage run before, whose gaits are reused
    duration = settings.episode_duration_s
    stages: dict[str, float] = {}  # wall seconds per stage (a step found finished costs its loading)

    def timed(stage: str, fn):
        started = time.perf_counter()
        value = fn()
        stages[stage] = stages.get(stage, 0.0) + time.perf_counter() - started
        return value

    def base(key: str) -> Path:
        return shared if shared is not None and key in SHARED_KEYS else out

    eea_results = {}  # the EEA runs' results by row key (filled in step 2)

    def evolve(key: str, native: Robot, pool: SharedPool | None):
        def run(run_dir=base(key) / _gait_dir(key, duration)):
            if key in eea_results:  # trained on a self-model: not on one it no longer holds
                retire_if_other_robot(run_dir, native)
            return _evolve(native, run_dir, settings, seed, workers, progress, pool)

        # a shared gait may be being loaded by another case study at this moment: wait for it
        return _wait_if_busy(run) if base(key) is shared else run()

    target_robot = gait.as_robot(damage)
    oracle_base = out if oracle_dir is None else oracle_dir
    oracle: OracleGait | None = None

    def evolve_all(natives: dict[str, Robot]) -> dict:
        """Every row's gait and the oracle's runs (for the key ``true_damaged``: the best run,
        :func:`aquafish.oracle.select_oracle`), as one stage. With more than one worker all
        evolve at once on one shared pool (a quick generation is one world, which alone keeps
        one core busy), with the gaits they give one after the other."""
        nonlocal oracle
        rows = {key: native for key, native in natives.items() if key != "true_damaged"}
        runs = oracle_jobs(target_robot, oracle_base, generations=settings.gait_generations,
                           population_size=settings.gait_population, episodes_per_genome=settings.gait_episodes,
                           episode_duration_s=duration, workers=workers, progress=progress)
        if oracle_base is not out:  # another case study may be loading the shared oracle
            runs = [functools.partial(lambda job, pool: _wait_if_busy(lambda: job(pool)), job) for job in runs]
        if processes == 1:
            controllers = {key: evolve(key, native, None) for key, native in rows.items()}
            found = [job(None) for job in runs]
        else:
            with SharedPool(processes) as pool:
                done = pool.run_each([functools.partial(evolve, key, native, pool) for key, native in rows.items()]
                                     + [functools.partial(job, pool) for job in runs])
            controllers, found = dict(zip(rows, done[:len(rows)])), done[len(rows):]
        oracle = select_oracle(found, target_robot, duration, generations=settings.gait_generations,
                               population=settings.gait_population, starts=settings.gait_episodes)
        return {**controllers, "true_damaged": oracle.controller}

    def records(transfers: dict) -> dict:
        """The report's controllers: distances, and each one's ``budget`` and ``seeds``."""
        return {key: {"native_distance": t.native_distance, "target_distance": t.target_distance,
                      "native_distances": t.native_distances.tolist(), "target_distances": t.target_distances.tolist(),
                      **_provenance(key, settings, seed, oracle)}
                for key, t in transfers.items()}

    if not all_rows:  # 1. triage: does the damage break the healthy gait at all?
        natives = {"healthy": _shared_natives()["healthy"], "true_damaged": target_robot}
        controllers = timed("gaits", lambda: evolve_all(natives))
        transfers = {key: timed("transfer", lambda key=key: gait.score_transfer(
                         controllers[key], natives[key], target_robot, seed=seed,
                         episodes=settings.transfer_episodes, episode_duration_s=duration))
                     for key in controllers}
        healthy, oracle_distance = (transfers[k].target_distance for k in ("healthy", "true_damaged"))
        if triage_only or not breaks(healthy, oracle_distance):
            return _write_triaged(out, preset, settings, damage, target, seed, method, model_space, records(transfers),
                                  stages, time.perf_counter() - t0, shared, own)

    # 2. self-model
    for key, (name, space, summary) in runs.items():
        run_dir = out / eea_dir_name(name, space, summary)
        timed(f"eea_{key}", lambda key=key, run_dir=run_dir: eea.run(configs[key], run_dir, progress=progress))
        eea_results[key] = eea.load_result(run_dir)
    models = {key: result.self_model_morphology for key, result in eea_results.items()}

    # 3. gaits: native robots are the models (with their servo gains), the oracle's is the damaged
    # robot (faults included), the robust gait's the healthy robot with a damage drawn per episode
    shared_natives = _shared_natives()
    natives = {"healthy": shared_natives["healthy"],
               **{key: model_robot(result, key) for key, result in eea_results.items()},
               "true_damaged": gait.as_robot(damage),
               "robust": shared_natives["robust"]}

    controllers = timed("gaits", lambda: evolve_all(natives))
    if not _rl_available():
        logging.getLogger(__name__).warning("case-study: %s: the two PPO rows are left out", MISSING_RL)
    else:  # the two PPO rows, each for rl_timesteps
        rows = {"ppo": ("self_model", "self_model"), "robust_ppo": ("robust", "random_damage")}
        jobs = {}
        for key, (native, name) in rows.items():
            run_dir = base(key) / _rl_dir(name, duration)
            if native in eea_results:
                retire_if_other_robot(run_dir, natives[native])
            jobs[key] = natives[native], run_dir
        paths = timed("ppo", lambda: _train_ppo_rows(jobs, settings, seed, progress, processes))
        for key, (native, _) in rows.items():
            controllers[key] = gait.load_controller(paths[key])
            natives[key] = natives[native]

    # 4. transfer to the damaged target
    transfers = timed("transfer", lambda: {
        key: gait.score_transfer(controllers[key], natives[key], target_robot, seed=seed,
                                 episodes=settings.transfer_episodes, episode_duration_s=duration)
        for key in controllers})
    video_name = None
    if video:
        gaits = {title: controllers[key] for key, title in VIDEO_GAITS.items()}
        video_name = timed("video", lambda: record_video(
            gaits, target_robot, out / "recovery", seed=seed, episode_duration_s=duration,
            title=f"{damage}: the damaged robot from above, {duration:g} s").name)

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
    controllers_report = records(transfers)
    report = {
        "preset": preset, "damage": damage, "seed": seed, "method": method, "model_space": model_space,
        "self_model_fields": own or {}, "episode_duration_s": duration,
        "settings": {**dataclasses.asdict(settings), "rl_timesteps": settings.rl_timesteps},
        "target_morphology": _dims(target),
        "target_servo_gains": dict(zip(GAIN_NAMES, _true_gains(damage))),
        "models": {
            key: {
                "method": runs[key][0],
                "inference": configs[key].inference.name,
                "model_space": runs[key][1],
                "behaviour_summary": runs[key][2],
                "morphology": _dims(models[key]),
                "servo_gains": None if _model_gains(result) is None else dict(zip(GAIN_NAMES, _model_gains(result))),
                "objective_fitness": result.self_model_objective_fitness,
                "fault_check": _fault_check_report(result),
                "initial_angle_error_deg": dict(zip(("left", "right", "caudal"),
                                                    result.inference_error_deg[-1].round(2).tolist())),
                "target_experiments": int(result.rounds[-1]["target_experiments"]),
                "search_simulations": int(result.rounds[-1]["simulations"]),
            }
            for key, result in eea_results.items()
        },
        "controllers": controllers_report,
        "left_out": [] if _rl_available() else [f"the two PPO rows (`ppo`, `robust_ppo`): {MISSING_RL}"],
        "verdict": verdict(controllers_report),
        "identification": _identification(models, eea_results, target, damage),
        "figures": figures,
        "video": video_name,
        "wall_seconds": triage_s + time.perf_counter() - t0,
        "stage_seconds": stages,
        **({"shared_dir": str(shared)} if shared is not None else {}),
    }
    atomic_write(out / "report.json", json.dumps(report, indent=2).encode())
    atomic_write(out / "report.md", render_report(report).encode())
    return report


def breaks(healthy_distance: float, oracle_distance: float) -> bool:
    """Does a damage break the healthy gait? The oracle gait swims forward on the damaged robot
    and the healthy gait keeps at most :data:`BREAKS_SHARE` of its distance (units, mean over
    the transfer episodes; :func:`verdict`'s ``breaks``)."""
    return bool(oracle_distance > 0 and healthy_distance / oracle_distance <= BREAKS_SHARE)


def _triage_seconds(out: Path) -> float:
    """The wall seconds of the triage whose report ``out`` holds (0 without one): a case study that
    goes on from a triage counts them in its own ``wall_seconds``."""
    try:
        report = json.loads((out / "report.json").read_text())
    except (OSError, ValueError):
        return 0.0
    return float(report.get("wall_seconds", 0.0)) if isinstance(report, dict) and report.get("triaged") else 0.0


def _provenance(key: str, settings: CaseStudyPreset, seed: int, oracle: OracleGait | None) -> dict:
    """A controller's ``budget`` and ``seeds`` in the report: the oracle's record
    (:meth:`aquafish.oracle.OracleGait.record`) for ``true_damaged``; a PPO row's timesteps; a NEAT
    row's generations x population x starts; every row but the oracle made from ``seed``."""
    if key == "true_damaged":
        return oracle.record()
    if key in ("ppo", "robust_ppo"):
        return {"budget": ppo_budget(settings.rl_timesteps), "seeds": [seed]}
    return {"budget": neat_budget(settings.gait_generations, settings.gait_population, settings.gait_episodes),
            "seeds": [seed]}


def _write_triaged(out: Path, preset: str, settings: CaseStudyPreset, damage: str, target: Morphology, seed: int,
                   method: str, model_space: str, controllers: dict, stages: dict, wall_seconds: float,
                   shared: Path | None, own: dict | None = None) -> dict:
    """The report of a case study stopped at its triage (``all_rows=False``): the healthy and the
    oracle rows only (``controllers``: their records), because the damage does not break the
    healthy gait or because the triage was all that was asked (``triage_only``;
    ``verdict.breaks`` then says whether the rest is to run)."""
    healthy, oracle = (controllers[k]["target_distance"] for k in ("healthy", "true_damaged"))
    share = healthy / oracle if oracle > 0 else None
    broken = breaks(healthy, oracle)
    line = (f"The oracle gait does not swim forward on the damaged robot ({oracle:.2f} units): there is nothing "
            "to recover." if share is None else
            f"The damage {'breaks' if broken else 'does not break'} the healthy gait (it keeps {share:.0%} of the "
            f"oracle gait's {oracle:.2f} units on the damaged robot).") + (
            " The other rows are still to run." if broken else " The other rows were not run (triage).")
    report = {
        "preset": preset, "damage": damage, "seed": seed, "method": method, "model_space": model_space,
        "self_model_fields": own or {}, "episode_duration_s": settings.episode_duration_s,
        "settings": {**dataclasses.asdict(settings), "rl_timesteps": settings.rl_timesteps},
        "target_morphology": _dims(target), "target_servo_gains": dict(zip(GAIN_NAMES, _true_gains(damage))),
        "models": {}, "controllers": controllers, "triaged": True,
        "verdict": {"breaks": broken, "recovers": False, "plain_eea_below": False, "self_model_share": None,
                    "plain_eea_share": None, "healthy_share": share,
                    **{f"{key}_share": None for key in ROBUST_KEYS}, **{f"{key}_recovers": None for key in ROBUST_KEYS},
                    "recovering": [], "line": line},
        "figures": {}, "video": None, "wall_seconds": wall_seconds, "stage_seconds": stages,
        **({"shared_dir": str(shared)} if shared is not None else {}),
    }
    text = (f"# Damage-recovery case study: `{damage}` ({preset} preset, seed {seed}), triage only\n\n"
            f"**Verdict.** {line}\n\n| gait | distance on the damaged robot (units) |\n|---|---|\n"
            + "".join(f"| {CONTROLLER_KEYS[k]} | {c['target_distance']:.2f} |\n" for k, c in controllers.items()))
    atomic_write(out / "report.json", json.dumps(report, indent=2).encode())
    atomic_write(out / "report.md", text.encode())
    return report


def verdict(controllers: dict) -> dict:
    """Does the damage break the healthy gait, how much of it does the self-model gait recover,
    and which rows recover?

    From the mean distances on the damaged target (``target_distance``) of the
    ``healthy``, ``plain_eea``, ``self_model`` and ``true_damaged`` (oracle) controllers, and
    of the other rows present (``out_of_band``, ``robust``, ``ppo``, ``robust_ppo``).

    Returns:
        ``breaks`` (the oracle swims forward and the healthy gait keeps at most
        :data:`BREAKS_SHARE` of it), ``self_model_share``, ``plain_eea_share``,
        ``healthy_share`` and, when present, ``robust_share`` and ``robust_ppo_share`` (share
        of the oracle's distance; None when the oracle does not swim forward), ``recovers``
        (the self-model gait: share >= :data:`RECOVERS_SHARE` and at least
        :data:`RECOVERS_OVER_HEALTHY` times the healthy gait), ``plain_eea_below`` (the
        plain-EEA gait does worse than the self-model gait), ``robust_recovers`` and
        ``robust_ppo_recovers`` (the same test for the damage-robust rows; None without
        them), ``recovering`` (every row but the oracle and the healthy gait that
        passes the test, in row order) and ``line``, a few sentences for the report.

    Raises:
        KeyError: a required controller is missing.
    """
    d = {key: float(c["target_distance"]) for key, c in controllers.items()}
    for key in ("healthy", "plain_eea", "self_model", "true_damaged"):
        d[key]  # noqa: B018  (a missing required row raises KeyError)
    oracle = d["true_damaged"]
    swims = oracle > 0
    share = {key: d[key] / oracle if swims else None for key in d if key != "true_damaged"}

    def recovers_(key: str) -> bool:
        return bool(swims and share[key] >= RECOVERS_SHARE and d[key] >= RECOVERS_OVER_HEALTHY * d["healthy"]
                    and d[key] > d["healthy"])

    broken = breaks(d["healthy"], oracle)
    recovering = [key for key in d if key not in ("healthy", "true_damaged") and recovers_(key)]
    recovers = "self_model" in recovering
    plain_below = d["plain_eea"] < d["self_model"]
    robust = [key for key in ROBUST_KEYS if key in d]
    if not swims:
        line = (f"The oracle gait does not swim forward on the damaged robot ({oracle:.2f} units): "
                "there is nothing to recover.")
    else:
        line = (f"The damage {'breaks' if broken else 'does not break'} the healthy gait (it keeps "
                f"{share['healthy']:.0%} of the oracle gait's {oracle:.2f} units on the damaged robot). "
                f"The self-model gait {'recovers' if recovers else 'does not recover'}: "
                f"{share['self_model']:.0%} of the oracle, {_times(d['self_model'], d['healthy'])} the healthy gait; "
                f"the plain-EEA gait reaches {share['plain_eea']:.0%} "
                f"({'less than' if plain_below else 'at least as much as'} the self-model gait).")
        for key in robust:
            line += (f" The damage-robust {'gait' if key == 'robust' else 'PPO policy'} reaches "
                     f"{share[key]:.0%} of the oracle, {_times(d[key], d['healthy'])} the healthy gait.")
        line += (" Rows that recover (at least " f"{RECOVERS_SHARE:.0%} of the oracle and {RECOVERS_OVER_HEALTHY:g}x "
                 "the healthy gait): " + (", ".join(f"`{k}`" for k in recovering) if recovering else "none") + ".")
    return {"breaks": broken, "recovers": bool(recovers), "plain_eea_below": bool(plain_below),
            "self_model_share": share["self_model"], "plain_eea_share": share["plain_eea"],
            "healthy_share": share["healthy"],
            **{f"{key}_share": share.get(key) for key in ROBUST_KEYS},
            **{f"{key}_recovers": recovers_(key) if key in robust else None for key in ROBUST_KEYS},
            "recovering": recovering, "line": line}


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
                                                           f"(`{m[k].get('method', m[k]['inference'])}`, "
                                                           f"`{m[k].get('model_space', PAPER_MODEL_SPACE)}`"
                                                           f"{', `signed_dft`' if m[k].get('behaviour_summary') == 'signed_dft' else ''})"
                                                           for k in keys) + " |",
              "|---|---|---|" + "---|" * len(keys)]
    for name, (lo, hi) in zip(MORPHOLOGY_FIELDS, MORPHOLOGY_BOUNDS):
        lines.append(f"| {name} | [{lo:g}, {hi:g}] | {report['target_morphology'][name]:.3f} | "
                     + " | ".join(f"{m[k]['morphology'][name]:.3f}" for k in keys) + " |")
    lines.append("| **objective fitness** (eq. 4) | | 1.000 | " + " | ".join(f"{m[k]['objective_fitness']:.3f}" for k in keys) + " |")
    lines.append("| target experiments used | | | " + " | ".join(str(m[k]["target_experiments"]) for k in keys) + " |")
    if all("search_simulations" in m[k] for k in keys):
        lines.append("| robot simulations (search + check) | | | " + " | ".join(
            f"{m[k]['search_simulations']:,}" + (f" + {m[k]['fault_check']['simulations']:,}" if m[k].get("fault_check")
                                                 else "") for k in keys) + " |")
    if any(m[k].get("servo_gains") for k in keys):
        target_gains = report.get("target_servo_gains") or {}
        for name in GAIN_NAMES:
            lines.append(f"| {name.replace('_', ' ')} (servo) | [{0 if name == 'caudal_gain' else -1}, 1] | "
                         f"{target_gains.get(name, float('nan')):.3f} | " + " | ".join(
                             f"{m[k]['servo_gains'][name]:.3f}" if m[k].get("servo_gains") else "(not modelled)"
                             for k in keys) + " |")
    errors = [m[k]["initial_angle_error_deg"] for k in keys]
    if any(errors):
        lines.append("| initial-angle error, last experiment (deg: left, right, caudal) | | | " + " | ".join(
            f"{e['left']:.1f}, {e['right']:.1f}, {e['caudal']:.1f}" if e else "(not inferred)" for e in errors) + " |")
    if report.get("self_model_fields"):
        lines += ["", "The self-model's run has settings of its own over its method's and budget's: "
                  + format_self_model_fields(report["self_model_fields"]) + "."]
    for k in keys:
        check = m[k].get("fault_check")
        if check and check["replaced"]:
            final = ", ".join(f"{v:+.3f}" for v in check["final_servo_gains"].values())
            lines += ["", f"The {CONTROLLER_KEYS[k].removeprefix('the ')}'s search ended on servo gains ({final}) "
                      f"(objective fitness {check['final_objective_fitness']:.3f}); its check against fault "
                      "hypotheses about the design found a fault that explains the experiments better, shown above."]
    lines += ["", "## Gait transfer (paper Figure 12)", "", "![trajectories](" + report["figures"]["trajectories"] + ")", ""]
    episodes = report["settings"]["transfer_episodes"]
    duration = report.get("episode_duration_s", 20.0)
    lines += [f"Forward distance in {duration:g} s along the initial heading (units; 1 unit = 8 cm): mean over {episodes} "
              f"starts (initial flipper angles of seeds {report['seed']}..{report['seed'] + episodes - 1}, the same "
              "on both robots), with the range over starts; the figure shows the first start.", ""]
    lines += ["| gait evolved on (`report.json` key) | on its native robot | on the damaged target |", "|---|---|---|"]
    for key, c in report["controllers"].items():
        cells = [f"{np.mean(d):.2f} ({min(d):.2f} to {max(d):.2f})" for d in (c["native_distances"], c["target_distances"])]
        lines.append(f"| {CONTROLLER_KEYS[key]} (`{key}`) | {cells[0]} | {cells[1]} |")
    if "robust" in report["controllers"]:
        lines += ["", "The damage-robust gait (`robust`) is a NEAT gait evolved with the same budget as every other "
                  "gait (population, generations, starts per genome) on the healthy robot with a damage preset drawn "
                  "per start (`damage=\"random\"`, every preset including `none` and the target's damage); with K "
                  "starts per genome it meets at most K presets (drawn by the starts' seeds), the same ones for every genome."]
    if "robust_ppo" in report["controllers"]:
        lines += ["", "The damage-robust PPO policy (`robust_ppo`) is trained on the same robot with a new damage "
                  f"preset every episode, for {report['settings'].get('rl_timesteps', 0):,} env steps, as many as one "
                  "NEAT gait simulates (so is `ppo`, on the self-model). It observes the robot's state, so it can "
                  "react to a damage within an episode; a NEAT gait's network can too."]
    for what in report.get("left_out", []):
        lines += ["", f"Left out: {what}."]
    if report.get("video"):
        lines += ["", f"Video: [{report['video']}]({report['video']}), the damaged robot from above under the healthy, "
                  "self-model and oracle gaits (first start), flippers and paths drawn, 2x real time."]
    lines += ["", f"Wall time: {report['wall_seconds'] / 60:.1f} min.", ""]
    return "\n".join(lines)
