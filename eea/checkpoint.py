"""The run checkpoint: everything needed to continue an EEA run after its last round.

:class:`RunState` is saved after every finished round to ``DIR/state.pkl`` with
:func:`save_state`, which writes it atomically (:func:`aquafish_gym.files.atomic_write`:
temporary file, fsync, rename), so a kill at any moment leaves either the previous or the
new checkpoint, never half of one. A run resumed from it continues exactly as the
uninterrupted run would: the checkpoint holds the generator's bit-generator state, the
estimation search, the experiments with their contexts, the estimation cache and the
counters.

A checkpoint is a pickle, and unpickling runs code: a run directory is trusted like code.
:func:`load_state` unpickles ``state.pkl`` only beside the run's manifest ``config.json``, and
:func:`eea.run` compares that manifest with the settings asked for before it loads the
checkpoint, so a ``state.pkl`` planted alone, or in a directory of another run, is refused
unread.

Classes are pickled by module path. Checkpoints written before modules moved keep loading
through :class:`eea.compat.RenamingUnpickler` (:mod:`eea.compat` holds what lets runs written
by earlier versions load).

What a finished run is read for is also written as data, with every checkpoint:
``DIR/run_data.npz`` (:func:`save_run_data`, :func:`load_run_data`; a NumPy ``.npz`` of plain
arrays and one JSON text, loaded with ``allow_pickle=False``): the experiments (the arrays of
:func:`eea.record.save_experiments`, so :func:`eea.record.load_experiments` reads them too),
the evaluator's counter and estimation cache, the inference strategy's state and the lineage
the last round chose. ``aquafish diagnose`` reads only it (and ``config.json``,
``rounds.csv``), and where pickles are refused (:func:`aquafish_gym.rundir.refuse_pickles`: a
finished benchmark cell checked again) a finished run is checked against fault hypotheses from
it (:func:`eea.run`), so no command unpickles a directory it is given to read: only a resume or
an extension of a run in its own directory unpickles its ``state.pkl``.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import pickle
import stat
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import FileError, read_pickle
from eea.compat import RenamingUnpickler

__all__ = ["CONFIG_FILE", "RUN_DATA_FILE", "STATE_FILE", "RunData", "RunState", "load_run_data", "load_state",
           "save_run_data", "save_state"]

STATE_FILE = "state.pkl"
#: The run's manifest (its :class:`~eea.config.EEAConfig`), beside which alone a checkpoint is read.
CONFIG_FILE = "config.json"
#: What a finished run is read for, as data (:func:`save_run_data`), written with every checkpoint.
RUN_DATA_FILE = "run_data.npz"
_VERSION = 1
_DATA_VERSION = 1

@dataclasses.dataclass(frozen=True)
class RunState:
    """State of an EEA run after ``rounds_done`` finished rounds (frozen: a new one per round).

    Attributes:
        config: the run's :meth:`EEAConfig.to_dict` (nested; flat in a checkpoint written before
            the sections, which :meth:`EEAConfig.from_dict` reads through :mod:`eea.compat`).
        rounds_done: number of finished rounds.
        rng_state: ``numpy.random.Generator.bit_generator.state`` of the run's generator
            (empty before the first round).
        estimation: :meth:`eea.estimation.Estimation.state_dict` (empty before the first round).
        experiments: :meth:`eea.experiment.Experiment.state_dict` of every experiment.
        evaluator: :meth:`eea.evaluation.Evaluator.state_dict` (counter and cache).
        inference: the strategy's :meth:`~eea.inference.InferenceStrategy.state_dict`
            (empty for the paper's strategies).
        wall_seconds: wall time of the finished rounds (s), over all sessions.
        rows: the rounds.csv rows so far (one dict per round).
        version: the checkpoint format.
    """

    config: dict
    rounds_done: int = 0
    rng_state: dict = dataclasses.field(default_factory=dict)
    estimation: dict = dataclasses.field(default_factory=dict)
    experiments: tuple = ()
    evaluator: dict = dataclasses.field(default_factory=dict)
    inference: dict = dataclasses.field(default_factory=dict)
    wall_seconds: float = 0.0
    rows: tuple = ()
    version: int = _VERSION


def save_state(out_dir: str | os.PathLike, state: RunState) -> None:
    """Save ``state`` to ``out_dir/state.pkl`` atomically."""
    data = {f.name: getattr(state, f.name) for f in dataclasses.fields(state)}
    atomic_write(Path(out_dir) / STATE_FILE, pickle.dumps(data, protocol=pickle.HIGHEST_PROTOCOL))


def load_state(out_dir: str | os.PathLike) -> RunState | None:
    """The checkpoint in ``out_dir``, or None if there is none yet.

    The checkpoint is a pickle: it is read only beside its run's manifest (``config.json``),
    in a directory the caller has checked (see the module docstring); the run directory is
    trusted like code.

    Raises:
        FileError: (a ``ValueError``) the file has no ``config.json`` beside it (it is not
            read), is truncated or garbled, is not an EEA checkpoint, or was written by
            another checkpoint version; the message names it.
        OSError: the file cannot be read.
    """
    path = Path(out_dir) / STATE_FILE
    if not path.exists():
        return None
    if not (Path(out_dir) / CONFIG_FILE).is_file():
        raise FileError(path, f"has no {CONFIG_FILE} beside it: a checkpoint is loaded only in the run directory "
                              "that wrote it (unpickling runs code)",
                        f"restore {CONFIG_FILE} from a copy of the run, or delete {STATE_FILE} to start over")
    data = read_pickle(path, what="EEA checkpoint", unpickler=RenamingUnpickler)
    if not isinstance(data, dict) or not {"config", "rows", "experiments"} <= set(data):
        raise FileError(path, "is not an EEA checkpoint (state.pkl)")
    if data.get("version") != _VERSION:
        raise FileError(path, f"has checkpoint version {data.get('version')!r}, expected {_VERSION}",
                        "use the version of aquafish that wrote it, or another directory")
    data.setdefault("inference", {})  # checkpoints written before strategies could keep state (see eea.compat)
    known = {f.name for f in dataclasses.fields(RunState)}
    try:
        return RunState(**{**{k: v for k, v in data.items() if k in known}, "experiments": tuple(data["experiments"]),
                           "rows": tuple(data["rows"])})
    except TypeError as err:
        raise FileError(path, f"is not an EEA checkpoint ({err})") from None


# -- the run's data, without pickles ------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class RunData:
    """What :func:`load_run_data` reads from ``run_data.npz``: a run after ``rounds_done`` rounds.

    Attributes:
        config: the run's :meth:`EEAConfig.to_dict` (as the checkpoint's).
        rounds_done: finished rounds.
        experiments: the target experiments (:class:`~eea.experiment.Experiment`), oldest first.
        evaluator: :meth:`eea.evaluation.Evaluator.state_dict` (counter and estimation cache).
        inference: the strategy's :meth:`~eea.inference.InferenceStrategy.state_dict`.
        chosen_lineage: a lineage run's lineage chosen in the last round (None: no lineages).
    """

    config: dict
    rounds_done: int
    experiments: tuple
    evaluator: dict
    inference: dict
    chosen_lineage: int | None = None

    @property
    def chosen_inference(self) -> dict:
        """The inference state behind the final model: the chosen lineage's in a lineage run
        (:func:`eea.search.lineages.chosen_inference_state`), else :attr:`inference`."""
        if self.chosen_lineage is None:
            return self.inference
        return self.inference["lineages"][self.chosen_lineage]


def save_run_data(out_dir: str | os.PathLike, state: RunState) -> None:
    """Write ``out_dir/run_data.npz`` from the checkpoint ``state`` (after at least one round), atomically.

    Plain arrays only (no object arrays), and one JSON text ``run`` (the config, the counters,
    the inference state's structure, whose arrays and byte strings are arrays of the file).
    """
    from eea.experiment import Experiment
    from eea.record import experiment_arrays  # eea.record imports this module

    # through Experiment: an earlier version's experiment states (no start_motion) in today's form
    arrays = experiment_arrays([Experiment.from_state_dict(e).state_dict() for e in state.experiments])
    evaluator = dict(state.evaluator)
    cache = evaluator.pop("similarity_cache", {})
    keys = list(cache)
    arrays["cache_keys"] = np.frombuffer(b"".join(keys), dtype=np.uint8)
    arrays["cache_key_lengths"] = np.array([len(k) for k in keys], dtype=np.int64)
    arrays["cache_values"] = np.array([cache[k] for k in keys], dtype=np.float64)
    estimation = state.estimation or {}
    history = estimation.get("history") if "lineages" in estimation else None
    run = {"version": _DATA_VERSION, "config": state.config, "rounds_done": state.rounds_done,
           "evaluator": _encode(evaluator, arrays), "inference": _encode(state.inference, arrays),
           "chosen_lineage": int(history[-1]["chosen"]) if history else None}
    arrays["run"] = np.array(json.dumps(run))
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    atomic_write(Path(out_dir) / RUN_DATA_FILE, buffer.getvalue())


def load_run_data(out_dir: str | os.PathLike) -> RunData | None:
    """The run's data file (:func:`save_run_data`), or None if there is none: read with
    ``allow_pickle=False``, so nothing in it runs code, whoever made it.

    Raises:
        FileError: (a ``ValueError``) the file is not a regular file, is truncated or garbled, or
            is not a run's data (the message names it).
    """
    from eea.record import experiments_from_arrays  # eea.record imports this module

    path = Path(out_dir) / RUN_DATA_FILE
    if not os.path.lexists(path):
        return None
    fix = "run the same `aquafish eea` command in the run directory that made it to write it again"
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise FileError(path, "is not a regular file", fix)
        with np.load(path, allow_pickle=False) as data:
            run = json.loads(str(data["run"][()]))
            if not isinstance(run, dict) or run.get("version") != _DATA_VERSION:
                raise FileError(path, f"is not a run data file of version {_DATA_VERSION}", fix)
            arrays = {name: data[name] for name in data.files}
        experiments = experiments_from_arrays(arrays)
        lengths = arrays["cache_key_lengths"]
        blob = arrays["cache_keys"].tobytes()
        ends = np.cumsum(lengths)
        if lengths.ndim != 1 or (lengths < 0).any() or (ends[-1] if len(ends) else 0) != len(blob) \
                or arrays["cache_values"].shape != lengths.shape:
            raise ValueError("its estimation cache's arrays do not fit together")
        cache = {blob[end - n:end]: float(v) for n, end, v in zip(lengths.tolist(), ends.tolist(),
                                                                   arrays["cache_values"].tolist())}
        evaluator = _decode(run["evaluator"], arrays)
        if evaluator or cache:  # a checkpoint without an evaluator's state (an early version's) gives none
            evaluator = evaluator | {"similarity_cache": cache}
        inference = _decode(run["inference"], arrays)
        chosen = run["chosen_lineage"]
        rounds_done = run["rounds_done"]
        if not (isinstance(run["config"], dict) and isinstance(evaluator, dict) and isinstance(inference, dict)
                and isinstance(rounds_done, int) and rounds_done >= 1 and (chosen is None or isinstance(chosen, int))):
            raise ValueError("its fields are not a run's")
        if chosen is not None and not (isinstance(inference.get("lineages"), list)
                                       and 0 <= chosen < len(inference["lineages"])):
            raise ValueError("its chosen lineage is not one of its lineages")
        return RunData(run["config"], rounds_done, experiments, evaluator, inference, chosen)
    except FileError:
        raise
    except (OSError, EOFError, KeyError, IndexError, ValueError, TypeError, AttributeError, zipfile.BadZipFile,
            RecursionError) as err:
        raise FileError(path, f"is not a readable run data file ({type(err).__name__}: {err})", fix) from None


def _encode(value: Any, arrays: dict) -> Any:
    """``value`` (a checkpoint's plain data: dicts, lists, tuples, arrays, bytes, numbers, strings,
    None) as JSON, its arrays put in ``arrays`` (named ``x`` and a number) and referenced."""
    if value is None or isinstance(value, (bool, str, int, float)) and not isinstance(value, np.generic):
        return value
    if isinstance(value, (np.ndarray, np.generic)):
        array = np.asarray(value)
        if array.dtype.hasobject:
            raise TypeError("an object array has no place in a run's data")
        name = f"x{len(arrays)}"  # unique: the file's arrays only grow
        arrays[name] = array
        return {"a": name, "scalar": isinstance(value, np.generic)}
    if isinstance(value, bytes):
        return {"b": value.hex()}
    if isinstance(value, tuple):
        return {"t": [_encode(v, arrays) for v in value]}
    if isinstance(value, list):
        return [_encode(v, arrays) for v in value]
    if isinstance(value, dict):
        if all(isinstance(k, str) for k in value):
            return {"d": {k: _encode(v, arrays) for k, v in value.items()}}
        return {"m": [[_encode(k, arrays), _encode(v, arrays)] for k, v in value.items()]}
    raise TypeError(f"{type(value).__name__} has no place in a run's data")


def _decode(value: Any, arrays: dict) -> Any:
    """The inverse of :func:`_encode`."""
    if value is None or isinstance(value, (bool, str, int, float)):
        return value
    if isinstance(value, list):
        return [_decode(v, arrays) for v in value]
    if isinstance(value, dict) and len(value) == 2 and "a" in value:
        array = arrays[value["a"]]
        return array[()] if value["scalar"] else array
    if isinstance(value, dict) and len(value) == 1:
        (tag, inner), = value.items()
        if tag == "b":
            return bytes.fromhex(inner)
        if tag == "t":
            return tuple(_decode(v, arrays) for v in inner)
        if tag == "d":
            return {k: _decode(v, arrays) for k, v in inner.items()}
        if tag == "m":
            return {_decode(k, arrays): _decode(v, arrays) for k, v in inner}
    raise ValueError(f"{str(value)[:40]} is not a run data value")
