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
reads either from disk, and runs no code from the file: a NEAT controller is saved as JSON
(``best_controller.json``: genome, NEAT config text, clock period; see
:meth:`NEATController.to_dict`), a pickle is refused, and an SB3 model's pickled
(``:serialized:``) entries are rebuilt from safe information instead of being unpickled
(:meth:`SB3PolicyController.load`).
"""

from __future__ import annotations

import collections
import importlib.util
import json
import math
import os
import pickle
import tempfile
import zipfile
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import neat
import numpy as np

from aquafish_gym.files import MAX_INPUT_BYTES, InputFileError, atomic_write, parse_json
from aquafish_gym.rundir import FileError, read_json
from gait.clock import CLOCK_DIM, CLOCK_PERIOD_S, OBS_DIM, ClockObservation, check_clock_period, with_clock
from gait.envs import DEFAULT_ENV_ID, make_env

#: File names inside a run directory that :func:`load_controller` looks for.
NEAT_CONTROLLER_FILE = "best_controller.json"
#: The ``format`` and ``version`` fields of a saved NEAT controller (:meth:`NEATController.to_dict`).
NEAT_CONTROLLER_FORMAT, NEAT_CONTROLLER_VERSION = "aquafish NEAT controller", 1
#: What :func:`load_controller` says to a pickle (``.pkl``), which it never loads.
PICKLE_REFUSED = ("pickled controllers are not loaded, because unpickling runs code (a file from someone else could "
                  "do anything); run `aquafish gait` again to get best_controller.json, or convert a pickle you made "
                  "yourself once in Python: import pickle; pickle.load(open('best_controller.pkl', 'rb'))"
                  ".save('best_controller.json') (docs/gaits.md)")
SB3_MODEL_FILE = "model.zip"
#: The most nodes and connections a saved NEAT genome may have (:meth:`NEATController.from_dict`):
#: a gait evolves tens of them; neat-python builds a network in time that grows with nodes
#: squared times connections, so a crafted genome of 300,000 nodes would run for hours.
MAX_GENOME_NODES, MAX_GENOME_CONNECTIONS = 500, 5000
#: The most bytes an SB3 ``model.zip`` may unpack to, summed over its entries as its directory
#: declares them (checked before any entry is read; a policy of this project is well under a megabyte).
MAX_SB3_UNPACKED_BYTES = 256 * 2**20
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

    def network(self):
        """A new network of the genome (``neat.nn.FeedForwardNetwork`` or, recurrent, at zero state):
        ``network().activate(inputs)`` with the ``num_inputs`` inputs of :meth:`act` returns its
        3 outputs, before clipping."""
        if self.feed_forward:
            return neat.nn.FeedForwardNetwork.create(self.genome, self.config)
        return neat.nn.RecurrentNetwork.create(self.genome, self.config)

    def reset(self) -> None:
        """Build the network from the genome (a recurrent network starts at zero state)."""
        self._net = self.network()

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

    def to_dict(self) -> dict[str, Any]:
        """The controller as JSON-ready data (no code): what :meth:`save` writes.

        Keys: ``format`` and ``version`` (:data:`NEAT_CONTROLLER_FORMAT`, :data:`NEAT_CONTROLLER_VERSION`),
        ``clock_period_s``, ``num_inputs``, ``neat_config`` (the config as neat-python's INI text,
        ``num_inputs`` included) and ``genome``: ``key``, ``fitness`` and lists of ``nodes``
        (``key`` and every gene attribute: ``bias``, ``response``, ``activation``,
        ``aggregation``, ``time_constant``) and ``connections`` (``key`` ``[in, out]``,
        ``innovation``, ``weight``, ``enabled``), in the genome's order (the network sums its inputs
        in that order). Floats are written exactly (JSON round-trips them).
        """
        def genes(items, conn: bool):
            return [{"key": list(k) if conn else k, **({"innovation": g.innovation} if conn else {}),
                     **{a.name: getattr(g, a.name) for a in g._gene_attributes}} for k, g in items]

        genome = self.genome
        return {"format": NEAT_CONTROLLER_FORMAT, "version": NEAT_CONTROLLER_VERSION,
                "clock_period_s": self.clock_period_s, "num_inputs": self.config.genome_config.num_inputs,
                "neat_config": _config_text(self.config),
                "genome": {"key": genome.key, "fitness": genome.fitness,
                           "nodes": genes(genome.nodes.items(), False),
                           "connections": genes(genome.connections.items(), True)}}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "NEATController":
        """Rebuild a controller from :meth:`to_dict`'s data: the same network, bit for bit.

        Raises:
            ValueError: another format or version, a missing or mistyped field, a NEAT
                config neat-python rejects, more than :data:`MAX_GENOME_NODES` nodes or
                :data:`MAX_GENOME_CONNECTIONS` connections (checked before any gene is
                read), a gene value that is not finite, an activation or aggregation
                function neat-python does not know, or a connection from or to a node the
                genome does not have; the message names the field
                (``genome.nodes[3].activation``).
        """
        if not isinstance(data, dict) or data.get("format") != NEAT_CONTROLLER_FORMAT:
            raise ValueError(f"not a saved NEAT controller (format must be {NEAT_CONTROLLER_FORMAT!r})")
        if data.get("version") != NEAT_CONTROLLER_VERSION:
            raise ValueError(f"NEAT controller format version {data.get('version')!r}; this AquaFish reads "
                             f"version {NEAT_CONTROLLER_VERSION}")
        try:
            config = _config_from_text(data["neat_config"])
            if config.genome_config.num_inputs != data["num_inputs"]:
                raise ValueError(f"num_inputs {data['num_inputs']} differs from the config's "
                                 f"{config.genome_config.num_inputs}")
            g = data["genome"]
            nodes, connections = _gene_list(g, "nodes", MAX_GENOME_NODES), _gene_list(g, "connections",
                                                                                     MAX_GENOME_CONNECTIONS)
            genome = config.genome_type(int(g["key"]))
            genome.fitness = g["fitness"]
            gc = config.genome_config
            for i, node in enumerate(nodes):
                gene = _gene(gc.node_gene_type(int(node["key"])), node, f"genome.nodes[{i}]")
                for name, functions in (("activation", gc.activation_defs),
                                        ("aggregation", gc.aggregation_function_defs)):
                    if not functions.is_valid(getattr(gene, name)):
                        raise ValueError(f"genome.nodes[{i}].{name}: unknown {name} function "
                                         f"{_short(getattr(gene, name))}")
                genome.nodes[gene.key] = gene
            sources = set(gc.input_keys) | set(genome.nodes)
            for i, conn in enumerate(connections):
                key = tuple(int(k) for k in conn["key"])
                if len(key) != 2:
                    raise ValueError(f"genome.connections[{i}].key: {_short(conn['key'])} is not [in, out]")
                if key[0] not in sources or key[1] not in genome.nodes:
                    raise ValueError(f"genome.connections[{i}].key: {list(key)} joins a node the genome does not have")
                gene = gc.connection_gene_type(key, innovation=int(conn["innovation"]))
                genome.connections[key] = _gene(gene, conn, f"genome.connections[{i}]")
            return cls(genome, config, data["clock_period_s"])
        except (KeyError, TypeError, AttributeError, AssertionError) as err:
            raise ValueError(f"a field is missing or mistyped ({type(err).__name__}: {err})") from None

    def save(self, path) -> Path:
        """Write the controller as JSON (:meth:`to_dict`) to ``path`` atomically; return it.

        Raises:
            OSError: as :func:`aquafish_gym.files.atomic_write`.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, json.dumps(self.to_dict(), indent=1).encode())
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


def _config_text(config: neat.Config) -> str:
    """``config`` as neat-python's INI text (``neat.Config.save`` writes every parameter)."""
    with tempfile.TemporaryDirectory() as tmp:
        config.save(os.path.join(tmp, "neat_config.ini"))
        return Path(tmp, "neat_config.ini").read_text()


def _config_from_text(text: str) -> neat.Config:
    """The ``neat.Config`` (default genome, reproduction, species and stagnation) of INI ``text``."""
    if not isinstance(text, str):
        raise TypeError(f"neat_config must be INI text, got {type(text).__name__}")
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "neat_config.ini").write_text(text)
        try:
            return neat.Config(neat.DefaultGenome, neat.DefaultReproduction, neat.DefaultSpeciesSet,
                               neat.DefaultStagnation, os.path.join(tmp, "neat_config.ini"))
        except Exception as err:  # neat-python raises bare Exception, RuntimeError, configparser errors
            raise ValueError(f"its NEAT config is not valid ({type(err).__name__}: {err})") from None


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:80] + "..."


def _gene_list(genome: dict[str, Any], name: str, most: int) -> list:
    """``genome[name]``, a list of at most ``most`` genes (refused before any is read)."""
    genes = genome[name]
    if not isinstance(genes, list):
        raise ValueError(f"genome.{name} must be a list of genes, got {type(genes).__name__}")
    if len(genes) > most:
        raise ValueError(f"genome.{name} has {len(genes)} genes; a saved gait has at most {most} (gaits evolve tens)")
    return genes


def _gene(gene, fields: dict[str, Any], where: str = "gene"):
    """Set every gene attribute of ``gene`` from ``fields`` (checked types, finite numbers); return ``gene``.

    Raises:
        ValueError: a value of the wrong type or not finite, naming ``where`` and the attribute.
    """
    if not isinstance(fields, dict):
        raise ValueError(f"{where} must be a JSON object, got {type(fields).__name__}")
    for attr in gene._gene_attributes:
        if attr.name not in fields:
            raise ValueError(f"{where}.{attr.name} is missing")
        value = fields[attr.name]
        kind = {"FloatAttribute": (int, float), "BoolAttribute": bool, "StringAttribute": str}.get(
            type(attr).__name__, object)
        if isinstance(value, bool) and kind != bool or not isinstance(value, kind):
            raise ValueError(f"{where}.{attr.name}: {_short(value)} is not a {type(attr).__name__[:-9].lower()}")
        if kind == (int, float) and not math.isfinite(value):
            raise ValueError(f"{where}.{attr.name}: {value!r} is not a finite number")
        setattr(gene, attr.name, float(value) if kind == (int, float) else value)
    return gene


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
    def load(cls, path, algo: str, clock_period_s: float = CLOCK_PERIOD_S, deterministic: bool = True,
             meta: dict[str, Any] | None = None) -> "SB3PolicyController":
        """Load a saved SB3 model (``.zip``) of algorithm ``algo`` (:data:`SB3_ALGOS`), running no code from it.

        SB3 saves some entries of the zip's ``data`` JSON as cloudpickles (``:serialized:``):
        the spaces, the policy class, the schedules, buffers. None is unpickled: each is
        given to SB3 as a ``custom_objects`` entry rebuilt from safe information (the spaces
        of the task ``meta["env_id"]`` with the clock, the policy class of the algorithm's
        ``meta["fingerprint"]["hyperparams"]["policy"]``, constant schedules: the model is
        for prediction). The weights are read by ``torch.load(weights_only=True)`` (SB3 >= 2.9).

        Args:
            path: the ``model.zip``.
            algo: its algorithm.
            clock_period_s: as the constructor.
            deterministic: as the constructor.
            meta: the sidecar ``model.json`` (:func:`sb3_sidecar`) as a dict (default ``{}``).

        Raises:
            ValueError: an unknown algorithm; :class:`~aquafish_gym.rundir.FileError` (one
                line naming the file and the field) if the zip's entries declare more than
                :data:`MAX_SB3_UNPACKED_BYTES` (checked before any is unpacked), its ``data``
                is not JSON or holds a pickled entry this cannot rebuild, it was saved with
                another policy class or observation shape than ``meta`` names, its
                ``policy_kwargs`` are not the policy's, its weights do not fit, or a weight
                is not finite.
            MissingExtraError: stable-baselines3 is not installed (the ``[rl]`` extra).
        """
        algo_cls = sb3_algorithm(algo)
        custom = _sb3_custom_objects(Path(path), algo_cls, algo, meta or {})
        try:
            model = algo_cls.load(str(path), device="cpu", custom_objects=custom)
        except (TypeError, AttributeError, RuntimeError, AssertionError, KeyError, IndexError, ValueError) as err:
            if isinstance(err, FileError):
                raise
            # what the checks of _sb3_custom_objects cannot see: weights of another shape (net_arch,
            # the task's observation), a setting SB3 refuses
            what = " ".join(" ".join(str(err).split()).split(":", 1)[-1].split()) or type(err).__name__
            raise FileError(path, f"cannot be loaded as the {algo} model that {sb3_sidecar(path).name} describes "
                                  f"(algo, env_id, fingerprint.hyperparams.policy; its data's policy_kwargs): "
                                  f"{type(err).__name__}: {what[:240]}",
                            "give a model.zip with the model.json that `aquafish rl` wrote beside it") from None
        bad = next((name for name, weights in model.policy.state_dict().items()
                    if weights.is_floating_point() and not bool(weights.isfinite().all())), None)
        if bad is not None:
            raise FileError(path, f"policy.pth: the weights {bad} are not all finite (NaN or infinite)",
                            "give a model.zip written by `aquafish rl`")
        return cls(model, clock_period_s, deterministic)

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


def _sb3_custom_objects(path: Path, algo_cls, algo: str, meta: dict[str, Any]) -> dict[str, Any]:
    """A safe replacement for every pickled (``:serialized:``) entry of the SB3 model ``path``.

    Raises:
        FileError: no readable ``data`` JSON, or a pickled entry with no safe replacement.
    """
    from stable_baselines3.common.type_aliases import TrainFreq, TrainFrequencyUnit
    from stable_baselines3.common.utils import FloatSchedule

    try:
        with zipfile.ZipFile(path) as archive:
            _check_unpacked_sizes(path, archive)
            data = parse_json(archive.read("data"), source=path)
    except InputFileError as err:
        raise FileError(path, f"is not a readable SB3 model: its data {err.problem}") from None
    except (KeyError, UnicodeDecodeError, json.JSONDecodeError, zipfile.BadZipFile, EOFError) as err:
        raise FileError(path, f"is not a readable SB3 model: no valid data JSON ({type(err).__name__}: {err})") \
            from None
    if not isinstance(data, dict):
        raise FileError(path, "is not a readable SB3 model: its data is not a JSON object")
    serialized = sorted(k for k, v in data.items() if isinstance(v, dict) and ":serialized:" in v)
    fingerprint = meta.get("fingerprint") if isinstance(meta.get("fingerprint"), dict) else {}
    hp = fingerprint.get("hyperparams") if isinstance(fingerprint.get("hyperparams"), dict) else {}
    policy = hp.get("policy", "MlpLstmPolicy" if algo == "recurrent_ppo" else "MlpPolicy")
    if not isinstance(policy, str) or policy not in algo_cls.policy_aliases:
        raise FileError(sb3_sidecar(path), f"fingerprint.hyperparams.policy: {_short(policy)} is no policy {algo} "
                                           f"knows ({', '.join(algo_cls.policy_aliases)})", "give the model.json that "
                                           "`aquafish rl` wrote beside the model")
    _check_policy(path, data, algo, policy, algo_cls.policy_aliases[policy])

    def constant(value, default: float):
        return FloatSchedule(float(value) if isinstance(value, (int, float)) and not isinstance(value, bool)
                               else default)

    env = ClockObservation(make_env("healthy", env_id=meta.get("env_id", DEFAULT_ENV_ID)),
                           meta.get("clock_period_s", CLOCK_PERIOD_S))
    try:
        spaces = {"observation_space": env.observation_space, "action_space": env.action_space}
    finally:
        env.close()
    for key, space in spaces.items():  # the shapes SB3 saved readable beside the pickled spaces
        shape = data[key].get("_shape") if isinstance(data.get(key), dict) else None
        if isinstance(shape, list) and shape != list(space.shape):
            raise FileError(path, f"data.{key}: its shape {_short(shape)} is not the {list(space.shape)} of the task "
                                  f"{meta.get('env_id', DEFAULT_ENV_ID)} with the clock that {sb3_sidecar(path).name} "
                                  "names (env_id)", "give a model.zip with the model.json that `aquafish rl` wrote "
                                                    "beside it")
    window = data.get("_stats_window_size", 100) if isinstance(data.get("_stats_window_size"), int) else 100
    safe = {**spaces, "policy_class": algo_cls.policy_aliases[policy],
            "lr_schedule": constant(data.get("learning_rate"), 3e-4),
            "clip_range": constant(hp.get("clip_range"), 0.2), "clip_range_vf": None,
            "train_freq": TrainFreq(1, TrainFrequencyUnit.STEP),
            "rollout_buffer_class": None, "replay_buffer_class": None,  # None: the algorithm's default
            "_last_obs": None, "_last_episode_starts": None, "_last_original_obs": None,
            "ep_info_buffer": collections.deque(maxlen=window), "ep_success_buffer": collections.deque(maxlen=window)}
    unknown = [k for k in serialized if k not in safe]
    if unknown:
        raise FileError(path, f"holds pickled entries {unknown} in its data, which are not loaded (unpickling runs "
                              "code)", "train the model again with `aquafish rl`")
    return {k: safe[k] for k in serialized}


def _check_unpacked_sizes(path: Path, archive: zipfile.ZipFile) -> None:
    """Refuse a zip whose entries unpack to more than :data:`MAX_SB3_UNPACKED_BYTES` together, or
    whose ``data`` entry is larger than an input file may be, before any entry is read.

    ``zipfile`` never unpacks more than an entry's declared size (a lie is a CRC or length
    error), so the declared sizes bound what reading the zip can take.
    """
    infos = archive.infolist()
    total = sum(info.file_size for info in infos)
    if total > MAX_SB3_UNPACKED_BYTES:
        raise FileError(path, f"is not a usable SB3 model: its {len(infos)} entries unpack to {total:,} bytes, more "
                              f"than the {MAX_SB3_UNPACKED_BYTES:,} a policy of this project can take (a zip bomb?); "
                              "it was not unpacked", "give a model.zip written by `aquafish rl`")
    data = next((info for info in infos if info.filename == "data"), None)
    if data is not None and data.file_size > MAX_INPUT_BYTES:
        raise FileError(path, f"is not a usable SB3 model: its data entry unpacks to {data.file_size:,} bytes, more "
                              f"than {MAX_INPUT_BYTES:,}; it was not unpacked",
                        "give a model.zip written by `aquafish rl`")


#: The widest layer and the most layers a saved policy's ``net_arch`` may have.
_NET_ARCH_WIDTH, _NET_ARCH_LAYERS = 65536, 64


def _check_policy(path: Path, data: dict[str, Any], algo: str, policy: str, policy_cls) -> None:
    """Refuse an SB3 model whose data does not fit the algorithm and policy its ``model.json``
    names, naming the field: the policy class it was saved with (readable beside the pickle),
    and its ``policy_kwargs`` (keys the policy takes, a ``net_arch`` of positive widths)."""
    fix = "give a model.zip with the model.json that `aquafish rl` wrote beside it"
    saved = data.get("policy_class")
    if isinstance(saved, dict) and isinstance(saved.get("__module__"), str) and isinstance(saved.get("__init__"), str):
        name = saved["__init__"].removeprefix("<function ").split(".__init__", 1)[0]
        if (saved["__module__"], name) != (policy_cls.__module__, policy_cls.__qualname__):
            raise FileError(path, f"data.policy_class: it holds a {saved['__module__'][:80]}.{name[:80]} policy, "
                                  f"not the {policy_cls.__module__}.{policy_cls.__qualname__} of {algo} {policy} that "
                                  f"{sb3_sidecar(path).name} names (algo, fingerprint.hyperparams.policy)", fix)
    kwargs = data.get("policy_kwargs", {})
    if kwargs is None or (isinstance(kwargs, dict) and ":serialized:" in kwargs):
        return  # none, or pickled (refused unread by the caller)
    if not isinstance(kwargs, dict):
        raise FileError(path, f"data.policy_kwargs: {_short(kwargs)} is not a JSON object", fix)
    import inspect

    taken = set(inspect.signature(policy_cls.__init__).parameters) - {"self", "observation_space", "action_space",
                                                                     "lr_schedule"}
    for key, value in kwargs.items():
        if key not in taken:
            raise FileError(path, f"data.policy_kwargs.{key[:80]}: not a setting of {algo} {policy}", fix)
        if key.endswith(("_fn", "_class")):  # a class or function: SB3 pickles those, so plain JSON is no class
            raise FileError(path, f"data.policy_kwargs.{key}: {_short(value)} is not a class SB3 saved", fix)
    arch = kwargs.get("net_arch")
    if arch is None:
        return
    nets = arch if isinstance(arch, dict) else {"": arch}
    for net, widths in nets.items():
        where = f"data.policy_kwargs.net_arch{'.' + str(net)[:80] if net else ''}"
        if not isinstance(widths, list) or len(widths) > _NET_ARCH_LAYERS or not all(
                isinstance(w, int) and not isinstance(w, bool) and 1 <= w <= _NET_ARCH_WIDTH for w in widths):
            raise FileError(path, f"{where}: {_short(widths)} is not a list of at most {_NET_ARCH_LAYERS} layer widths "
                                  f"in [1, {_NET_ARCH_WIDTH}]", fix)


def sb3_sidecar(model_path) -> Path:
    """Path of the JSON file describing an SB3 model: ``model.zip`` -> ``model.json``."""
    return Path(model_path).with_suffix(".json")


def load_controller(path) -> Controller:
    """Load a controller saved by ``aquafish gait`` or ``aquafish rl``.

    No file runs code when loaded, so a controller from someone else is safe to load.

    Args:
        path: a NEAT controller (``.json``, written by :meth:`NEATController.save`), an SB3
            model (``.zip``, with the ``.json`` written next to it by :func:`gait.train_rl`),
            or a run directory containing ``best_controller.json`` or ``model.zip``.

    Raises:
        ValueError: no such file, an unknown file type, or a pickle (``.pkl``: never loaded,
            unpickling runs code; the message says how to convert one's own);
            :class:`~aquafish_gym.rundir.FileError` for a truncated, garbled or foreign file;
            :class:`MissingExtraError` for an SB3 model without the ``[rl]`` extra.
    """
    path = Path(path)
    if path.is_dir():
        for name in (NEAT_CONTROLLER_FILE, SB3_MODEL_FILE, "best_controller.pkl"):
            if (path / name).is_file():
                return load_controller(path / name)
        raise ValueError(f"{path} holds neither {NEAT_CONTROLLER_FILE} nor {SB3_MODEL_FILE}")
    if not path.is_file():
        raise ValueError(f"no controller file {path}")
    if path.suffix == ".pkl":
        raise ValueError(f"{path}: {PICKLE_REFUSED}")
    if path.suffix == ".json":
        try:
            return NEATController.from_dict(read_json(path))
        except FileError:
            raise
        except ValueError as err:
            raise FileError(path, f"is not a NEAT controller: {err}",
                            "give a best_controller.json written by `aquafish gait`") from None
    if path.suffix == ".zip":
        sidecar = sb3_sidecar(path)
        if not sidecar.is_file():
            raise ValueError(f"{path}: missing {sidecar.name} (algo and clock period, written by train_rl)")
        meta = read_json(sidecar)
        try:
            return SB3PolicyController.load(path, meta.get("algo"), meta.get("clock_period_s", CLOCK_PERIOD_S),
                                            meta=meta)
        except (EOFError, KeyError, zipfile.BadZipFile, pickle.UnpicklingError) as err:
            raise FileError(path, f"is not a readable SB3 model: truncated or corrupt ({type(err).__name__}: {err})") \
                from None
    raise ValueError(f"unknown controller file {path}; expected a .json (NEAT), a .zip (SB3) or a run directory")
