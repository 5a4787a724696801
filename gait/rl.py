"""Reinforcement-learning baselines (stable-baselines3 PPO and SAC) on AquaFish-v0.

Optional: needs the ``[rl]`` extra (stable-baselines3, torch on CPU); imported lazily so
the rest of :mod:`gait` works without it. The policy observes AquaFish-v0's observation with
the clock appended (:class:`gait.clock.ClockObservation`), exactly what a NEAT controller
sees, and the trained model is scored with the same rollout and transfer protocol. Training
steps the ``n_envs`` sub-envs as robots of one PyBullet world (:mod:`gait.sb3_vec_env`,
the same observations and rewards as SB3's ``DummyVecEnv`` over ``n_envs`` single envs
of :func:`make_rl_env`, up to the vector env's position round-off).
Hyperparameters come from ``gait/rl_hyperparams.yml`` (RL Zoo conventions).
"""

from __future__ import annotations

import contextlib
import copy
import json
import os
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

from aquafish_gym.checks import check_int
from aquafish_gym.files import atomic_write, read_input
from aquafish_gym.rundir import MismatchError, check_fingerprint, check_output_dir, read_json, run_lock
from gait.clock import CLOCK_PERIOD_S, ClockObservation, check_clock_period
from gait.controller import (SB3_ALGOS, SB3_MODEL_FILE, SB3PolicyController, require_rl, sb3_algorithm,
                             sb3_sidecar)
from gait.plots import plot_learning_curve
from gait.robots import Robot, as_robot
from gait.envs import DEFAULT_ENV_ID, EPISODE_DURATION_S, check_env_id, make_env
from gait.rollout import rollout

#: The hyperparameter file kept next to this module.
HYPERPARAMS_FILE = Path(__file__).with_name("rl_hyperparams.yml")
#: Zoo keys interpreted here; every other key goes to the algorithm's constructor.
_ZOO_KEYS = ("n_timesteps", "policy", "n_envs", "normalize", "policy_kwargs")
#: Zoo keys this loader does not implement (rejected rather than silently ignored).
_UNSUPPORTED = ("frame_stack", "env_wrapper", "vec_env_wrapper", "callback", "normalize_kwargs", "monitor_kwargs")


def read_hyperparams_section(algo: str, path=None, env_id: str = DEFAULT_ENV_ID) -> dict[str, Any]:
    """The raw ``algo -> env_id`` mapping of an RL-Zoo-style YAML file (a fresh copy).

    Raises:
        ValueError: unknown algorithm, missing file or section.
    """
    if algo not in SB3_ALGOS:
        raise ValueError(f"unknown RL algorithm {algo!r}; allowed: {', '.join(SB3_ALGOS)}")
    path = Path(path) if path is not None else HYPERPARAMS_FILE
    if not path.is_file():
        raise ValueError(f"no hyperparameter file {path}")
    try:
        data = yaml.safe_load(read_input(path).decode("utf-8")) or {}
    except yaml.YAMLError as err:
        raise ValueError(f"{path}: not valid YAML ({' '.join(str(err).split())})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not UTF-8 text; a hyperparameter file is YAML") from None
    except RecursionError:
        raise ValueError(f"{path}: nested too deeply; a hyperparameter file is a few levels of mappings") from None
    try:
        section = data[algo][env_id]
    except (KeyError, TypeError):
        raise ValueError(f"{path}: no section {algo} -> {env_id}") from None
    if not isinstance(section, dict):
        raise ValueError(f"{path}: {algo} -> {env_id} must be a mapping")
    return copy.deepcopy(section)


def load_hyperparams(algo: str, path=None, env_id: str = DEFAULT_ENV_ID) -> dict[str, Any]:
    """Read and check the settings of ``algo`` for the task ``env_id`` (RL Zoo conventions).

    Returns:
        A fresh dict with ``n_timesteps`` (int), ``policy``, ``n_envs`` (int),
        ``policy_kwargs`` (dict) and the algorithm's own keyword arguments (``lin_``
        schedules turned into callables).

    Raises:
        ValueError: unknown algorithm, missing file/section/keys, or an unsupported key.
    """
    hp = read_hyperparams_section(algo, path, env_id)
    where = f"{path or HYPERPARAMS_FILE}: {algo} -> {env_id}"
    bad = sorted(set(hp) & set(_UNSUPPORTED))
    if bad:
        raise ValueError(f"{where}: Zoo key(s) {bad} are not supported by gait.rl")
    if hp.pop("normalize", False):
        raise ValueError(f"{where}: normalize must be false (VecNormalize is not supported)")
    if "policy" not in hp or "n_timesteps" not in hp:
        raise ValueError(f"{where}: 'policy' and 'n_timesteps' are required")
    if not isinstance(hp.setdefault("policy_kwargs", {}), dict):
        raise ValueError(f"{where}: policy_kwargs must be a mapping, got {hp['policy_kwargs']!r}")
    hp["n_timesteps"] = int(float(hp["n_timesteps"]))
    hp["n_envs"] = int(hp.get("n_envs", 1))
    for key, value in hp.items():
        if key not in _ZOO_KEYS and isinstance(value, str) and value.startswith("lin_"):
            hp[key] = _linear_schedule(float(value[4:]))
    return hp


def _linear_schedule(initial: float) -> Callable[[float], float]:
    def schedule(progress_remaining: float) -> float:
        return progress_remaining * initial

    return schedule


def timesteps_to_train(model, requested: int) -> int:
    """The env steps ``model.learn(total_timesteps=requested)`` will train: SB3 collects whole
    rollouts, so ``requested`` is rounded up to a multiple of ``n_steps x n_envs`` (PPO,
    RecurrentPPO) or of ``train_freq x n_envs`` (SAC, a step-based ``train_freq``)."""
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm

    if isinstance(model, OnPolicyAlgorithm):
        chunk = model.n_steps * model.n_envs
    else:
        freq = getattr(model, "train_freq", None)
        step_unit = freq is not None and getattr(freq.unit, "value", None) == "step"
        chunk = freq.frequency * model.n_envs if step_unit else model.n_envs
    return -(-int(requested) // chunk) * chunk


def _bar_label(algo: str, robot: Robot, env_id: str) -> str:
    """``PPO on <robot>``, and the task unless it is AquaFish-v0 (as NEAT's ``NEAT gait on <robot>``)."""
    return f"{algo.upper()} on {robot.label}" + ("" if env_id == DEFAULT_ENV_ID else f" ({env_id})")


def training_bar(total_timesteps: int, desc: str, disable: bool = False):
    """An SB3 callback showing progress over env steps, with the mean return of the last 100
    episodes (SB3's ``ep_info_buffer``) and the best such mean.

    ``total_timesteps`` should be what is trained (:func:`timesteps_to_train`). On a terminal
    it is a tqdm bar updated every step; otherwise (:func:`aquafish_gym.progress.progress_bar`)
    one line per training chunk: at the end of a rollout, once at least 1% of the total has
    passed since the last line (so PPO prints one line per rollout, SAC one per 1%).
    (SB3's own ``progress_bar=True`` needs the ``rich`` package; this needs only tqdm.)
    """
    from stable_baselines3.common.callbacks import BaseCallback

    from aquafish_gym.progress import LineProgress, progress_bar

    class TrainingBar(BaseCallback):
        def _on_training_start(self) -> None:
            self.bar = progress_bar(total_timesteps, desc=desc, unit="step", disable=disable)
            self.lines = isinstance(self.bar, LineProgress)
            self.best = -np.inf

        def _returns(self) -> None:
            episodes = self.model.ep_info_buffer
            if episodes:
                mean = float(np.mean([e["r"] for e in episodes]))
                self.best = max(self.best, mean)
                self.bar.set_postfix(mean_return=f"{mean:.3f}", best=f"{self.best:.3f}")

        def _on_step(self) -> bool:
            if not self.lines:
                self.bar.update(self.training_env.num_envs)
                if self.n_calls % 50 == 0:
                    self._returns()
            return True

        def _on_rollout_end(self) -> None:
            if self.lines and self.num_timesteps - self.bar.n >= max(1, total_timesteps // 100):
                self._returns()
                self.bar.update(self.num_timesteps - self.bar.n)

        def _on_training_end(self) -> None:
            if self.lines and self.num_timesteps > self.bar.n:
                self._returns()
                self.bar.update(self.num_timesteps - self.bar.n)
            self.bar.close()

    return TrainingBar()


def make_rl_env(robot: Robot, *, episode_duration_s: float = EPISODE_DURATION_S, clock_period_s: float = CLOCK_PERIOD_S,
                env_id: str = DEFAULT_ENV_ID):
    """The task ``env_id`` for ``robot`` with the clock appended: observation ``(n + 2,)`` (14 for AquaFish-v0)."""
    return ClockObservation(make_env(robot, episode_duration_s=episode_duration_s, env_id=env_id), clock_period_s)


def train_rl(algo: str, morphology=None, timesteps: int | None = None, seed: int = 0, out_dir="runs/rl", *,
             damage: str = "none", hyperparams_path=None, episode_duration_s: float = EPISODE_DURATION_S,
             clock_period_s: float = CLOCK_PERIOD_S, eval_seed: int = 0, num_threads: int | None = None,
             verbose: int = 0, env_id: str = DEFAULT_ENV_ID, progress: bool = True) -> Path:
    """Train a PPO or SAC policy on an AquaFish task (default AquaFish-v0), save it, and score it.

    Args:
        algo: "ppo" or "sac".
        morphology: the robot (``Morphology``, 9 numbers, ``Robot`` or robot string; default healthy).
        timesteps: env steps (default: the file's ``n_timesteps``).
        seed: seeds SB3 (torch, NumPy, the envs' initial angles).
        out_dir: writes ``model.zip``, ``model.json`` (algo, clock period, robot, settings,
            score), ``hyperparams.yml`` (the settings used), ``monitor/monitor.csv`` (every
            training episode's return, length and wall time, SB3's ``VecMonitor``)
            and ``learning_curve.png``.
        damage: damage applied to ``morphology``.
        hyperparams_path: YAML file (default ``gait/rl_hyperparams.yml``).
        episode_duration_s: simulated seconds per training episode.
        clock_period_s: period of the clock input (s).
        eval_seed: episode seed of the final score (the deterministic policy, 20 s).
        num_threads: torch CPU threads (None: torch's default).
        verbose: SB3 verbosity (0, 1, 2).
        env_id: the task (``aquafish_gym.ENV_IDS``); its section of the YAML file is used.
        progress: show progress over the env steps trained (:func:`training_bar`) with the mean
            and best episode return.

    Returns:
        Path of ``model.zip`` (load it with :func:`gait.load_controller`). ``model.json``
        records ``timesteps``, the env steps actually trained (PPO trains whole rollouts of
        ``n_steps x n_envs`` steps, so it can exceed the ``timesteps_requested``), and the
        run's ``fingerprint`` (the settings that define the model).

    Raises:
        ValueError: invalid algorithm, robot, hyperparameters or counts; an ``out_dir`` that
            cannot be written (checked before anything is created), that another process is
            writing (:class:`~aquafish_gym.rundir.BusyError`), or that already holds a
            trained model (:class:`~aquafish_gym.rundir.MismatchError`; nothing is overwritten).
        MissingExtraError: stable-baselines3, torch or pandas (for SB3's ``load_results``) is
            missing (install the ``[rl]`` extra); raised before anything is created.
    """
    require_rl(f"training {algo}", algo, training=True)
    algo_cls = sb3_algorithm(algo)
    from stable_baselines3.common.monitor import load_results

    from gait.sb3_vec_env import make_clock_vec_env

    import pandas  # noqa: F401  (load_results needs it: fail now, not after training)

    robot = as_robot(morphology if morphology is not None else "healthy", damage=damage)
    clock_period_s = check_clock_period(clock_period_s)
    env_id = check_env_id(env_id)
    hp = load_hyperparams(algo, hyperparams_path, env_id)
    n_timesteps = hp.pop("n_timesteps") if timesteps is None else timesteps
    check_int("timesteps", n_timesteps, 1)
    check_int("seed", seed, 0)
    check_int("eval_seed", eval_seed, 0)
    if num_threads is not None:
        check_int("num_threads", num_threads, 1)
    hp.pop("n_timesteps", None)
    fingerprint = rl_fingerprint(algo, robot, n_timesteps, seed, hyperparams_path, episode_duration_s,
                                 clock_period_s, env_id)
    out_dir = check_output_dir(out_dir)
    make_rl_env(robot, episode_duration_s=episode_duration_s, clock_period_s=clock_period_s, env_id=env_id).close()
    with run_lock(out_dir, command="rl"):
        model_path = out_dir / SB3_MODEL_FILE
        if sb3_sidecar(model_path).is_file():
            recorded = _recorded_fingerprint(sb3_sidecar(model_path))
            check_fingerprint(out_dir, recorded, fingerprint, "use another --out (nothing was overwritten)")
            raise MismatchError(f"{out_dir} already holds this trained model ({SB3_MODEL_FILE}); use another --out "
                                "or delete it to train again (nothing was overwritten)")
        return _train(algo_cls, algo, robot, int(n_timesteps), seed, out_dir, hp, hyperparams_path, episode_duration_s,
                      clock_period_s, eval_seed, num_threads, verbose, env_id, progress, fingerprint,
                      make_clock_vec_env, load_results)


def rl_fingerprint(algo: str, robot: Robot, timesteps: int, seed: int, hyperparams_path, episode_duration_s: float,
                   clock_period_s: float, env_id: str) -> dict[str, Any]:
    """The settings that define a trained model (recorded in ``model.json`` as ``fingerprint``)."""
    return {"algo": algo, "env_id": env_id, "robot": robot.to_dict(), "seed": int(seed), "timesteps": int(timesteps),
            "episode_duration_s": float(episode_duration_s), "clock_period_s": float(clock_period_s),
            "hyperparams": read_hyperparams_section(algo, hyperparams_path, env_id)}


def _recorded_fingerprint(sidecar: Path) -> dict[str, Any]:
    """The fingerprint in a ``model.json`` (built from its fields for one written before fingerprints)."""
    meta = read_json(sidecar)
    if "fingerprint" in meta:
        return meta["fingerprint"]
    return {k: meta[k] for k in ("algo", "env_id", "robot", "seed", "timesteps", "episode_duration_s", "clock_period_s")
            if k in meta}


def _train(algo_cls, algo, robot, n_timesteps, seed, out_dir, hp, hyperparams_path, episode_duration_s, clock_period_s,
           eval_seed, num_threads, verbose, env_id, progress, fingerprint, make_clock_vec_env, load_results) -> Path:
    """Train, save and score (the body of :func:`train_rl`, under the run lock)."""
    policy, n_envs = hp.pop("policy"), hp.pop("n_envs")
    if num_threads is not None:
        import torch

        torch.set_num_threads(int(num_threads))

    # an unfinished earlier run's episode logs (e.g. the per-env 0.monitor.csv, ... of the
    # DummyVecEnv stack) would join this run's learning curve: this run rewrites the log
    for stale in (out_dir / "monitor").glob("*monitor.csv"):
        stale.unlink()
    from gait.sb3_vec_env import MONITOR_FILE

    # the n_envs sub-envs are robots of one PyBullet world (gait.sb3_vec_env), not n_envs single envs
    with _naming_the_monitor_file(out_dir / "monitor" / MONITOR_FILE):
        venv = make_clock_vec_env(robot, n_envs, seed=seed, monitor_dir=out_dir / "monitor",
                                  episode_duration_s=episode_duration_s, clock_period_s=clock_period_s, env_id=env_id)
        model = algo_cls(policy, venv, seed=seed, device="cpu", verbose=verbose, **hp)
        if hp.get("tensorboard_log") is None:
            model.set_logger(quiet_logger(verbose))
        start = time.perf_counter()
        model.learn(total_timesteps=int(n_timesteps),  # the bar counts the whole rollouts SB3 trains
                    callback=training_bar(timesteps_to_train(model, n_timesteps), _bar_label(algo, robot, env_id),
                                          disable=not progress))
        wall_time_s = time.perf_counter() - start
        venv.close()
    model_path = out_dir / SB3_MODEL_FILE
    model.save(model_path)

    score = rollout(SB3PolicyController(model, clock_period_s), robot, seed=eval_seed, env_id=env_id)
    meta = {
        "algo": algo, "env_id": env_id, "clock_period_s": clock_period_s, "robot": robot.to_dict(), "seed": seed,
        "timesteps": int(model.num_timesteps), "timesteps_requested": int(n_timesteps),
        "episode_duration_s": episode_duration_s, "wall_time_s": wall_time_s,
        "eval_seed": eval_seed, "eval_distance": score.distance, "eval_return": score.episode_return,
        "eval_initial_angles_rad": score.initial_angles.tolist(), "fingerprint": fingerprint,
    }
    used = read_hyperparams_section(algo, hyperparams_path, env_id) | {"n_timesteps": int(n_timesteps)}
    atomic_write(out_dir / "hyperparams.yml", yaml.safe_dump({algo: {env_id: used}}, sort_keys=False).encode())
    # return, length and wall time (s since the first env started) of every episode, in time order
    curve = load_results(str(out_dir / "monitor"))[["r", "l", "t"]].to_numpy(dtype=np.float64)
    if len(curve):
        plot_learning_curve(curve, out_dir / "learning_curve.png", title=f"{algo.upper()} on {robot.label}")
    atomic_write(sb3_sidecar(model_path), json.dumps(meta, indent=1).encode())  # last: marks a finished run
    return model_path


def quiet_logger(verbose: int = 0):
    """SB3's logger of a training without TensorBoard, made here so that SB3 makes no directory.

    Left to itself, ``learn()`` configures a logger that creates an empty ``SB3-<date>``
    directory in the system's temporary folder at every training (even with ``verbose=0``,
    when it writes nothing). This one writes what SB3's would (``verbose`` >= 1: the training
    table to standard output; 0: nothing) and has no folder.

    Args:
        verbose: SB3's verbosity.

    Returns:
        A ``stable_baselines3.common.logger.Logger`` for ``model.set_logger``.
    """
    import sys

    from stable_baselines3.common.logger import HumanOutputFormat, Logger

    return Logger(folder=None, output_formats=[HumanOutputFormat(sys.stdout)] if verbose >= 1 else [])


@contextlib.contextmanager
def _naming_the_monitor_file(path: Path):
    """Name ``path`` in an ``OSError`` that names no file: SB3's ``VecMonitor`` writes its episode
    log itself, and a full disk while it writes would otherwise be reported without it."""
    try:
        yield
    except OSError as err:
        if err.filename is not None:
            raise
        raise OSError(err.errno, err.strerror or str(err), os.fspath(path)) from err


def train_or_load_rl(algo: str, morphology, timesteps: int | None, seed: int, out_dir, **kwargs: Any) -> Path:
    """``out_dir/model.zip``, trained by :func:`train_rl` unless a finished one is there.

    A run is finished when its ``model.json`` exists (:func:`train_rl` writes it after the
    model). The case study and the task table train through this, so repeating a command
    reuses its policies (the RL counterpart of :func:`gait.evolve_or_load_gait`).

    Args:
        algo: as :func:`train_rl`.
        morphology: as :func:`train_rl`.
        timesteps: as :func:`train_rl`.
        seed: as :func:`train_rl`.
        out_dir: as :func:`train_rl`.
        **kwargs: as :func:`train_rl`.

    Raises:
        MismatchError: if the finished model was trained with other settings (the fields are
            named; :class:`~aquafish_gym.rundir.MismatchError`). When training, what
            :func:`train_rl` raises.
    """
    model_path = check_output_dir(out_dir) / SB3_MODEL_FILE
    if sb3_sidecar(model_path).is_file():
        kw = {k: kwargs[k] for k in ("damage", "hyperparams_path", "episode_duration_s", "clock_period_s", "env_id")
              if k in kwargs}
        robot = as_robot(morphology if morphology is not None else "healthy", damage=kw.pop("damage", "none"))
        hyperparams_path, env_id = kw.get("hyperparams_path"), kw.get("env_id", DEFAULT_ENV_ID)
        if timesteps is None:
            timesteps = load_hyperparams(algo, hyperparams_path, env_id)["n_timesteps"]
        wanted = rl_fingerprint(algo, robot, timesteps, seed, hyperparams_path,
                                kw.get("episode_duration_s", EPISODE_DURATION_S),
                                kw.get("clock_period_s", CLOCK_PERIOD_S), env_id)
        check_fingerprint(Path(out_dir), _recorded_fingerprint(sb3_sidecar(model_path)), wanted,
                          "use another --out for these settings, or the settings it was trained with")
        return model_path
    return train_rl(algo, morphology, timesteps, seed, out_dir, **kwargs)
