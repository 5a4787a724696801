"""The last step of a ``morphology+servos`` run: its final model against fault hypotheses.

The self-model search in ``morphology+servos`` (not the paper's space) can end on a model that
explains the experiments with a wrong servo sign and a morphology bent to fit: under its own
fitted initial angles the truth scores a higher MOD_FIT, but the search does not get there
(docs/studies/recovery.md). A robot knows the morphology it was built to, and a servo fault
leaves that morphology as it was, a flipper fault its servos; so after the last round,
:func:`eea.run` fits the initial angles of the final model and of 97 fault hypotheses about the
design (:func:`eea.inference.selection.fault_hypotheses`, one or two faults on different parts:
pectoral gains -1, -0.5, 0, 0.5, 1 each; one pectoral flipper shortened to half its length or
lost, beside the other pectoral's gain at those levels; the caudal servo dead or at half gain, or
the caudal fin halved or lost, beside healthy pectorals or one pectoral fault) on all the run's
experiments and keeps the highest MOD_FIT (eq. 3): the run's **self-model**
(:attr:`eea.record.RunResult.self_model`). The fit has stages (a cheap screen of all 98
candidates, the best 24 of it given a compass polish, then the best 8 fitted again in two
rounds that start each from the others' angles too, each keeping its best fit, then the servo
gains of the best 2 polished one step of 0.125 at a time:
:func:`~eea.inference.selection.check_fault_hypotheses`). It costs about 105,000 simulations
on a lean mission's 8 experiments (about 140,000 before 2026-11-28, when the screen polished
all 98).

The record is ``DIR/fault_check.json`` (:class:`FaultCheck`), written atomically once the last
round is done; a run extended by more rounds, or checked by another procedure (a record made
before the caudal faults joined the hypotheses, before the gain polish, or before the screen
polished only its best 24), is checked again
(:meth:`FaultCheck.is_current`).
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
from pathlib import Path
from typing import Sequence

import numpy as np

from aquafish_gym import Morphology
from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import FileError, read_json
from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.experiment import Experiment
from eea.inference import Profile
from eea.inference.selection import check_fault_hypotheses, fault_hypotheses

__all__ = ["FAULT_CHECK_FILE", "FAULT_CHECK_PROCEDURE", "FAULT_CHECK_PROCEDURE_GIVEN_SCREEN", "FAULT_CHECK_SEED",
           "FaultCheck", "check_candidates", "check_final_model", "search_screen",
           "read_fault_check", "write_fault_check"]

#: The check's record in a run directory.
FAULT_CHECK_FILE = "fault_check.json"
#: Seed of the angle fit's random starts: fixed, so a finished run is checked alike whenever (and
#: by whichever command) the check is made.
FAULT_CHECK_SEED = 0
#: The name of the check :func:`check_final_model` makes (its stages at their defaults), kept in
#: every record: a record of another procedure is made again. Records made before the name was
#: kept (no gain polish) have none.
FAULT_CHECK_PROCEDURE = "screen polished on its best 24, 2 shared refits of 8, gain polish of 2 x 3"
#: The same check with the screen's fit skipped: the angles the run's ``hypotheses`` search
#: (:mod:`eea.search.hypotheses`) fitted to every candidate round by round are its screen
#: (``screen_angles``; in measurement).
FAULT_CHECK_PROCEDURE_GIVEN_SCREEN = ("the search's angles as the screen, polished on its best 24, 2 shared refits "
                                      "of 8, gain polish of 2 x 3")


@dataclasses.dataclass(frozen=True)
class FaultCheck:
    """The outcome of :func:`check_final_model`.

    Attributes:
        round: the round whose final model was checked (1-based; the run's last).
        models: ``(98 + P, 12)`` the candidates (``morphology+servos`` values: 9 dimensions in
            simulator units, then the left, right pectoral and caudal servo gains): row 0 the
            final model, then the 97 hypotheses, then the P (0-2) polished models.
        model_fitness: ``(98 + P,)`` each candidate's MOD_FIT (eq. 3) under its own fitted angles.
        index: the kept row (the highest MOD_FIT; 0 when nothing fits better than the final model).
        simulations: model simulations the check ran.
        wall_seconds: how long it took.
        procedure: the check's procedure (:data:`FAULT_CHECK_PROCEDURE` when made today; ""
            in a record made before the name was kept).
    """

    round: int
    models: np.ndarray
    model_fitness: np.ndarray
    index: int
    simulations: int
    wall_seconds: float
    procedure: str = ""

    @property
    def final_model(self) -> np.ndarray:
        """``(12,)`` the run's final model, as the search left it."""
        return self.models[0]

    @property
    def model(self) -> np.ndarray:
        """``(12,)`` the kept model: the run's self-model."""
        return self.models[self.index]

    @property
    def polished(self) -> bool:
        """Whether the kept model is a polished one (a row after the hypotheses)."""
        return self.index > len(fault_hypotheses(Morphology.healthy().to_array()))

    def is_current(self, round_number: int) -> bool:
        """Whether this record is the check :func:`check_final_model` makes today of a run whose
        last round is ``round_number``: of that round, by today's procedure
        (:data:`FAULT_CHECK_PROCEDURE`, or :data:`FAULT_CHECK_PROCEDURE_GIVEN_SCREEN` for a run
        whose search gave the screen's angles) and against today's hypotheses
        (:func:`eea.inference.selection.fault_hypotheses` at the design)."""
        hypotheses = fault_hypotheses(Morphology.healthy().to_array())
        return (self.round == round_number
                and self.procedure in (FAULT_CHECK_PROCEDURE, FAULT_CHECK_PROCEDURE_GIVEN_SCREEN)
                and np.array_equal(self.models[1:1 + len(hypotheses)], hypotheses))

    def to_dict(self) -> dict:
        """A JSON-ready dict (floats round-trip exact)."""
        return {"round": self.round, "index": self.index, "models": self.models.tolist(),
                "model_fitness": self.model_fitness.tolist(), "simulations": self.simulations,
                "wall_seconds": self.wall_seconds, "procedure": self.procedure}

    @classmethod
    def from_dict(cls, data: dict) -> "FaultCheck":
        """The inverse of :meth:`to_dict`.

        Raises:
            ValueError: a missing key, or arrays of the wrong shape.
        """
        models = np.asarray(data["models"], dtype=np.float64)
        fitness = np.asarray(data["model_fitness"], dtype=np.float64)
        index = int(data["index"])
        if models.ndim != 2 or models.shape[1] != 12 or fitness.shape != (len(models),) \
                or not 0 <= index < len(models):
            raise ValueError(f"models {models.shape}, model_fitness {fitness.shape} and index {index} do not agree")
        return cls(int(data["round"]), models, fitness, index, int(data["simulations"]), float(data["wall_seconds"]),
                   str(data.get("procedure", "")))


def check_candidates(model) -> np.ndarray:
    """``(98, 12)`` the check's candidates for a final ``(12,)`` model: the model, then the
    fault hypotheses about the healthy design (:func:`eea.inference.selection.fault_hypotheses`)."""
    return np.vstack([np.asarray(model, dtype=np.float64)[None], fault_hypotheses(Morphology.healthy().to_array())])


def search_screen(config, strategy, model, n_experiments: int) -> np.ndarray | None:
    """The screen a run's own search fitted for the check of its final ``(12,)`` model: with
    ``estimation_search="hypotheses"`` and the ``profile`` strategy, the ``(98, E, 3)`` angles the
    strategy remembers for every candidate (:func:`check_candidates`) on the ``n_experiments``
    experiments; None otherwise (the check fits its own screen), or when a candidate has none.

    Args:
        config: the run's :class:`eea.config.EEAConfig`.
        strategy: the run's inference strategy after its last round.
        model: the final model's values.
        n_experiments: E, the run's experiments.
    """
    if config.estimation.search.name != "hypotheses" or not isinstance(strategy, Profile):
        return None
    genomes = get_model_space(config.model_space).encode(check_candidates(model))
    return strategy.remembered_angles(genomes, n_experiments)


def check_final_model(model, experiments: Sequence[Experiment], evaluator: Evaluator, round_number: int,
                      screen_angles=None) -> FaultCheck:
    """Check a run's final ``morphology+servos`` model against fault hypotheses about the
    design (the healthy morphology): :func:`eea.inference.selection.check_fault_hypotheses` at
    its defaults (:data:`FAULT_CHECK_PROCEDURE`), the starts of its stages drawn from
    :data:`FAULT_CHECK_SEED` on; with ``screen_angles`` ``(98, E, 3)``, the angles its
    candidates (:func:`check_candidates`) already hold, as its screen
    (:data:`FAULT_CHECK_PROCEDURE_GIVEN_SCREEN`; in measurement).

    Args:
        model: ``(12,)`` the final model's values.
        experiments: all the run's target experiments, E >= 1.
        evaluator: an :class:`~eea.evaluation.Evaluator` of the ``morphology+servos`` space, the
            run's length and behaviour summary.
        round_number: the round the model is from (kept in the record).
        screen_angles: None, or ``(98, E, 3)`` angles (rad), see above.

    Raises:
        ValueError: as :func:`~eea.inference.selection.check_fault_hypotheses` raises.
    """
    started, simulations = time.perf_counter(), evaluator.simulations
    selection = check_fault_hypotheses(model, Morphology.healthy().to_array(), experiments, evaluator,
                                       FAULT_CHECK_SEED, screen_angles=screen_angles)
    return FaultCheck(int(round_number), selection.models, selection.model_fitness, selection.index,
                      int(evaluator.simulations - simulations), time.perf_counter() - started,
                      FAULT_CHECK_PROCEDURE if screen_angles is None else FAULT_CHECK_PROCEDURE_GIVEN_SCREEN)


def write_fault_check(out_dir: str | os.PathLike, check: FaultCheck) -> None:
    """Write ``out_dir/fault_check.json`` atomically."""
    atomic_write(Path(out_dir) / FAULT_CHECK_FILE, (json.dumps(check.to_dict(), indent=1) + "\n").encode())


def read_fault_check(out_dir: str | os.PathLike) -> FaultCheck | None:
    """The check recorded in ``out_dir`` (None if there is none).

    Raises:
        FileError: (a ``ValueError``) the file is not valid JSON or not a check record.
    """
    path = Path(out_dir) / FAULT_CHECK_FILE
    if not path.is_file():
        return None
    data = read_json(path)
    try:
        return FaultCheck.from_dict(data)
    except (KeyError, TypeError, ValueError) as err:
        raise FileError(path, f"is not a fault-check record ({err})") from None
