"""The run checkpoint: everything needed to continue an EEA run after its last round.

:class:`RunState` is saved after every finished round to ``DIR/state.pkl`` with
:func:`save_state`, which writes a temporary file in the same directory, flushes it to
disk and renames it over the old one (``os.replace``), so a kill at any moment leaves
either the previous or the new checkpoint, never half of one. A run resumed from it
continues exactly as the uninterrupted run would: the checkpoint holds the generator's
bit-generator state, the estimation GA, the experiments with their contexts, the
estimation cache and the counters.
"""

from __future__ import annotations

import dataclasses
import os
import pickle
import tempfile
from pathlib import Path

__all__ = ["STATE_FILE", "RunState", "atomic_write", "load_state", "save_state"]

STATE_FILE = "state.pkl"
_VERSION = 1


@dataclasses.dataclass
class RunState:
    """State of an EEA run after ``rounds_done`` finished rounds.

    Attributes:
        config: the run's :meth:`EEAConfig.to_dict`.
        rounds_done: number of finished rounds.
        rng_state: ``numpy.random.Generator.bit_generator.state`` of the run's generator.
        estimation: :meth:`eea.estimation.Estimation.state_dict`.
        experiments: :meth:`eea.experiment.Experiment.state_dict` of every experiment.
        evaluator: :meth:`eea.evaluation.Evaluator.state_dict` (counter and cache).
        wall_seconds: wall time of the finished rounds (s), over all sessions.
        rows: the rounds.csv rows so far (one dict per round).
    """

    config: dict
    rounds_done: int
    rng_state: dict
    estimation: dict
    experiments: list
    evaluator: dict
    wall_seconds: float
    rows: list
    version: int = _VERSION


def atomic_write(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (temporary file, fsync, ``os.replace``)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def save_state(out_dir: str | os.PathLike, state: RunState) -> None:
    """Save ``state`` to ``out_dir/state.pkl`` atomically."""
    atomic_write(Path(out_dir) / STATE_FILE, pickle.dumps(dataclasses.asdict(state), protocol=pickle.HIGHEST_PROTOCOL))


def load_state(out_dir: str | os.PathLike) -> RunState | None:
    """The checkpoint in ``out_dir``, or None if there is none yet.

    Raises:
        ValueError: if the file was written by another checkpoint version.
    """
    path = Path(out_dir) / STATE_FILE
    if not path.exists():
        return None
    with open(path, "rb") as f:
        data = pickle.load(f)
    if data.get("version") != _VERSION:
        raise ValueError(f"{path} has checkpoint version {data.get('version')!r}, expected {_VERSION}")
    return RunState(**data)
