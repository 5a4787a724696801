"""Gait controllers: map the IMU observation and the clock to AquaFish-v0's action.

A :class:`Controller` has ``reset()`` (start of an episode) and
``act(obs (12,), time_s) -> action (3,) in [-1, 1]`` (another task's observation may be
longer). :class:`RandomController` is the random-policy baseline and
:class:`ConstantController` the open-loop one (one fixed action); two kinds are learned:

* :class:`NEATController`: a neat-python genome decoded to ``neat.nn.FeedForwardNetwork``
  (or ``neat.nn.RecurrentNetwork`` when the config has ``feed_forward = False``; the CTRNN
  is not used, its ``advance()`` has a double-buffer bug in neat-python 2.0.0).
* :class:`SB3PolicyController`: a stable-baselines3 model (PPO, SAC, or sb3-contrib's RecurrentPPO) trained on
  AquaFish-v0 wrapped in :class:`~gait.clock.ClockObservation`.

Both see the same 14 inputs (:func:`gait.clock.with_clock`). :func:`load_controller`
reads either from disk.
"""

from __future__ import annotations

import importlib.util
import pickle
import zipfile
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import neat
import numpy as np

from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import FileError, read_json, read_pickle
from gait.clock import CLOCK_DIM, CLOCK_PERIOD_S, OBS_DIM, check_clock_period, with_clock

#: File names inside a run directory that :func:`load_controller` looks for.
NEAT_CONTROLLER_FILE = "best_controller.pkl"
SB3_MODEL_FILE = "model.zip"
#: SB3 algorithms that :func:`load_controller` and :mod:`gait.rl` know: stable-baselines3's PPO
#: and SAC, and sb3-contrib's ``RecurrentPPO`` (an LSTM policy, which can tell a damage from
#: the robot's response within an episode).
SB3_ALGOS = ("ppo", "sac", "recurrent_ppo")


@runtime_checkable
class Controller(Protocol):
    """What the rollout needs from a controller."""

    def reset(self) -> None:
        """Clear any internal state before an episode."""

    def act(self, obs: np.ndarray, time_s: float) -> np.ndarray:
        """Return the action ``(3,)`` in [-1, 1] for observation ``obs (12,)`` at ``time_s``."""


class ConstantController:
    """An open-loop baseline: the same action at every step (e.g. the caudal fin alone at 1 Hz).

    Args:
        action: ``(3,)`` env action in [-1, 1]: left, right pectoral speed, caudal frequency
            (``(0, 0, 1)``: pectorals still, caudal fin at 1 Hz).

    Raises:
        ValueError: wrong shape, NaN, or an entry outside [-1, 1].
    """

    def __init__(self, action):
        arr = np.asarray(action, dtype=np.float64)
        if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(np.abs(arr) > 1.0):
            raise ValueError(f"action must be 3 finite numbers in [-1, 1] (left, right pectoral, caudal), got {action!r}")
        self.action = arr

    def reset(self) -> None:
        """Nothing to clear."""

    def act(self, obs: np.ndarray, time_s: float) -> np.ndarray:
        """Return a copy of the constant action ``(3,)``."""
        return self.action.copy()

    def __repr__(self) -> str:
        return f"ConstantController({self.action.tolist()})"


class HeadingHoldController:
    """A hand-made feedback baseline: paddle ahead and steer back to the initial heading.

    Differential paddling on the yaw error (yaw is read off the IMU part of the observation,
    ``atan2(obs[2], obs[5])``: 0 is the initial heading, counter-clockwise positive). With
    ``u = gain * yaw`` (rad), the paddle on the side the robot must turn towards eases off:
    ``left = base_left + max(-u, 0)``, ``right = base_right + max(u, 0)`` (clipped to
    [-1, 1]); the caudal command stays ``base_caudal``. On the surface swimmer ``(-1, -1,
    1)`` is full paddling backwards under water and the tail at 1 Hz.

    Args:
        base: ``(3,)`` env action in [-1, 1] with no heading error.
        gain: ``u`` per radian of yaw error (>= 0); 0 is :class:`ConstantController`.

    Raises:
        ValueError: a bad ``base`` (as :class:`ConstantController`) or a negative or
            non-finite ``gain``.
    """

    def __init__(self, base=(-1.0, -1.0, 1.0), gain: float = 2.0) -> None:
        self.base = ConstantController(base).action
        if not np.isfinite(gain) or gain < 0:
            raise ValueError(f"gain must be a finite number >= 0 (per radian of yaw error), got {gain!r}")
        self.gain = float(gain)

    def reset(self) -> None:
        """Nothing to clear (the error is read from each observation)."""

    def act(self, obs: np.ndarray, time_s: float) -> np.ndarray:
        """The action ``(3,)`` for observation ``obs`` (the IMU's sin/cos of roll, pitch, yaw first)."""
        u = self.gain * float(np.arctan2(obs[2], obs[5]))
        action = self.base.copy()
        action[0] += max(-u, 0.0)
        action[1] += max(u, 0.0)
        return np.clip(action, -1.0, 1.0)

    def __repr__(self) -> str:
        return f"HeadingHoldController(base={self.base.tolist()}, gain={self.gain})"


class RandomController:
    """Uniform random actions in [-1, 1]^3: the "learned nothing" baseline of every task.

    Args:
        seed: seeds the action stream; :meth:`reset` restarts it, so every episode of one
            controller sees the same actions (comparable across starts and robots).
    """

    def __init__(self, seed: int = 0) -> None:
        self.seed = int(seed)
        self.reset()

    def reset(self) -> None:
        """Restart the action stream from ``seed``."""
        self._rng = np.random.default_rng(self.seed)

    def act(self, obs: np.ndarray, time_s: float) -> np.ndarray:
        """A fresh uniform action ``(3,)`` float64 in [-1, 1]."""
        return self._rng.uniform(-1.0, 1.0, 3)

    def __repr__(self) -> str:
        return f"RandomController(seed={self.seed})"


class NEATController:
    """A NEAT network driving the robot from the IMU and the clock.

    Args:
        genome: a ``neat.DefaultGenome`` evolved with ``config``.
        config: the ``neat.Config``: one input per observation entry plus the clock (14
            for AquaFish-v0), 3 outputs.
        clock_period_s: period of the clock input (s).

    Raises:
        ValueError: the config has no observation inputs besides the clock or not 3
            outputs, or a bad period.
    """

    def __init__(self, genome, config: neat.Config, clock_period_s: float = CLOCK_PERIOD_S):
        gc = config.genome_config
        if gc.num_inputs <= CLOCK_DIM or gc.num_outputs != 3:
            raise ValueError(f"NEAT config must have num_inputs = observation size + {CLOCK_DIM} (clock; "
                             f"{OBS_DIM + CLOCK_DIM} for AquaFish-v0) and num_outputs = 3 (servo commands), "
                             f"got {gc.num_inputs} and {gc.num_outputs}")
        self.genome = genome
        self.config = config
        self.clock_period_s = check_clock_period(clock_period_s)
        self._net = None

    @property
    def feed_forward(self) -> bool:
        """True for a feed-forward network, False for a recurrent one."""
        return bool(self.config.genome_config.feed_forward)

    def reset(self) -> None:
        """Build the network from the genome (a recurrent network starts at zero state)."""
        if self.feed_forward:
            self._net = neat.nn.FeedForwardNetwork.create(self.genome, self.config)
        else:
            self._net = neat.nn.RecurrentNetwork.create(self.genome, self.config)

    def act(self, obs, time_s: float) -> np.ndarray:
        """Return the action ``(3,)`` float64 in [-1, 1] (network outputs, clipped).

        Raises:
            ValueError: ``obs`` is not ``(num_inputs - 2,)``.
        """
        if self._net is None:
            self.reset()
        inputs = with_clock(obs, time_s, self.clock_period_s)
        if len(inputs) != self.config.genome_config.num_inputs:
            raise ValueError(f"this network takes {self.config.genome_config.num_inputs - CLOCK_DIM} observation "
                             f"entries, got {len(inputs) - CLOCK_DIM}")
        out = self._net.activate(inputs.tolist())
        return np.clip(np.asarray(out, dtype=np.float64), -1.0, 1.0)

    def save(self, path) -> Path:
        """Pickle the controller (genome, config, clock period) to ``path`` atomically; return it.

        Raises:
            OSError: as :func:`aquafish_gym.files.atomic_write`.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, pickle.dumps(self, protocol=pickle.HIGHEST_PROTOCOL))
        return path

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_net"] = None  # rebuilt from the genome on reset()
        return state

    def __repr__(self) -> str:
        kind = "feed-forward" if self.feed_forward else "recurrent"
        n_hidden = len(self.genome.nodes) - self.config.genome_config.num_outputs
        n_conn = sum(c.enabled for c in self.genome.connections.values())
        return f"NEATController(genome {self.genome.key}, {kind}, {n_hidden} hidden, {n_conn} connections, clock {self.clock_period_s} s)"


class SB3PolicyController:
    """A stable-baselines3 policy trained on an AquaFish task with the clock appended.

    Args:
        model: a loaded ``stable_baselines3`` model whose observation space is
            ``(n + 2,)`` (``(14,)`` for AquaFish-v0).
        clock_period_s: the clock period used in training (s).
        deterministic: use the policy's mean action (True) or sample it.

    Raises:
        ValueError: the model's observation space is not 1-D with more than 2 entries.
    """

    def __init__(self, model, clock_period_s: float = CLOCK_PERIOD_S, deterministic: bool = True):
        shape = tuple(model.observation_space.shape)
        if len(shape) != 1 or shape[0] <= CLOCK_DIM:
            raise ValueError(f"the policy must observe an observation plus the {CLOCK_DIM} clock entries "
                             f"({OBS_DIM + CLOCK_DIM} for AquaFish-v0), got shape {shape}")
        self.model = model
        self.clock_period_s = check_clock_period(clock_period_s)
        self.deterministic = bool(deterministic)
        self.reset()

    def reset(self) -> None:
        """Start an episode: clear a recurrent policy's memory (an MLP policy has none)."""
        self._state, self._episode_start = None, np.ones(1, dtype=bool)

    def act(self, obs, time_s: float) -> np.ndarray:
        """Return the policy's action ``(3,)`` float64, clipped to [-1, 1]; a recurrent policy
        carries its hidden state to the next call of the episode."""
        action, self._state = self.model.predict(with_clock(obs, time_s, self.clock_period_s), state=self._state,
                                                 episode_start=self._episode_start, deterministic=self.deterministic)
        self._episode_start = np.zeros(1, dtype=bool)
        return np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)

    @classmethod
    def load(cls, path, algo: str, clock_period_s: float = CLOCK_PERIOD_S, deterministic: bool = True) -> "SB3PolicyController":
        """Load a saved SB3 model (``.zip``) of algorithm ``algo`` (:data:`SB3_ALGOS`).

        Raises:
            ValueError: an unknown algorithm.
            MissingExtraError: stable-baselines3 is not installed (the ``[rl]`` extra).
        """
        algo_cls = sb3_algorithm(algo)
        return cls(algo_cls.load(str(path), device="cpu"), clock_period_s, deterministic)

    def __repr__(self) -> str:
        return f"SB3PolicyController({type(self.model).__name__}, clock {self.clock_period_s} s)"


#: How to install the packages of the RL baselines.
RL_EXTRA_INSTALL = "pip install 'aquafish[rl]'"


class MissingExtraError(ValueError):
    """An optional dependency is not installed; the message names the extra to install.

    A ``ValueError`` (not an ``ImportError``), so that the command line reports it as one line.
    """


def require_rl(what: str, algo: str = "ppo", *, training: bool = False, alternative: str = "") -> None:
    """Check, without importing them, that the ``[rl]`` extra's packages are installed.

    Args:
        what: what needs them (the start of the message, e.g. ``"loading model.zip"``).
        algo: the algorithm (:data:`SB3_ALGOS`); ``recurrent_ppo`` also needs sb3-contrib.
        training: also check pandas (SB3 reads the learning curve with it).
        alternative: appended to the message (e.g. how to do without the extra).

    Raises:
        MissingExtraError: a package is missing; the message names it and :data:`RL_EXTRA_INSTALL`.
    """
    modules = ["stable_baselines3", "torch"] + (["sb3_contrib"] if algo == "recurrent_ppo" else []) + \
        (["pandas"] if training else [])
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        raise MissingExtraError(f"{what} needs the [rl] extra ({', '.join(missing)} not installed): "
                                f"{RL_EXTRA_INSTALL}{alternative}")


def sb3_algorithm(algo: str):
    """Return the class for ``algo`` (:data:`SB3_ALGOS`), imported lazily.

    Raises:
        ValueError: an unknown algorithm name.
        MissingExtraError: stable-baselines3 or torch (or sb3-contrib, for ``recurrent_ppo``)
            is missing (install the ``[rl]`` extra).
    """
    if algo not in SB3_ALGOS:
        raise ValueError(f"unknown RL algorithm {algo!r}; allowed: {', '.join(SB3_ALGOS)}")
    require_rl(f"the {algo} algorithm", algo)
    try:
        import stable_baselines3
        if algo == "recurrent_ppo":
            import sb3_contrib
    except ImportError as err:
        raise MissingExtraError(f"the {algo} algorithm needs the [rl] extra, which cannot be imported "
                                f"({type(err).__name__}: {err}): {RL_EXTRA_INSTALL}") from err
    if algo == "recurrent_ppo":
        return sb3_contrib.RecurrentPPO
    return {"ppo": stable_baselines3.PPO, "sac": stable_baselines3.SAC}[algo]


def sb3_sidecar(model_path) -> Path:
    """Path of the JSON file describing an SB3 model: ``model.zip`` -> ``model.json``."""
    return Path(model_path).with_suffix(".json")


def load_controller(path) -> Controller:
    """Load a controller saved by ``aquafish gait`` or ``aquafish rl``.

    Args:
        path: a NEAT controller pickle (``.pkl``), an SB3 model (``.zip``, with the
            ``.json`` written next to it by :func:`gait.train_rl`), or a run directory
            containing ``best_controller.pkl`` or ``model.zip``. Pickles execute code when
            loaded: load only files you trust.

    Raises:
        ValueError: no such file, an unknown file type, or a pickle that is not a controller;
            :class:`~aquafish_gym.rundir.FileError` for a truncated or garbled file.
    """
    path = Path(path)
    if path.is_dir():
        for name in (NEAT_CONTROLLER_FILE, SB3_MODEL_FILE):
            if (path / name).is_file():
                return load_controller(path / name)
        raise ValueError(f"{path} holds neither {NEAT_CONTROLLER_FILE} nor {SB3_MODEL_FILE}")
    if not path.is_file():
        raise ValueError(f"no controller file {path}")
    if path.suffix == ".pkl":
        controller = read_pickle(path, what="controller")
        if not isinstance(controller, Controller):
            raise ValueError(f"{path} does not hold a controller (got {type(controller).__name__})")
        return controller
    if path.suffix == ".zip":
        sidecar = sb3_sidecar(path)
        if not sidecar.is_file():
            raise ValueError(f"{path}: missing {sidecar.name} (algo and clock period, written by train_rl)")
        meta = read_json(sidecar)
        try:
            return SB3PolicyController.load(path, meta.get("algo"), meta.get("clock_period_s", CLOCK_PERIOD_S))
        except (EOFError, KeyError, zipfile.BadZipFile, pickle.UnpicklingError) as err:
            raise FileError(path, f"is not a readable SB3 model: truncated or corrupt ({type(err).__name__}: {err})") \
                from None
    raise ValueError(f"unknown controller file {path}; expected a .pkl (NEAT), a .zip (SB3) or a run directory")
