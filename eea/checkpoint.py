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
"""

from __future__ import annotations

import dataclasses
import os
import pickle
from pathlib import Path

from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import FileError, read_pickle
from eea.compat import RenamingUnpickler

__all__ = ["CONFIG_FILE", "STATE_FILE", "RunState", "load_state", "save_state"]

STATE_FILE = "state.pkl"
#: The run's manifest (its :class:`~eea.config.EEAConfig`), beside which alone a checkpoint is read.
CONFIG_FILE = "config.json"
_VERSION = 1

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
