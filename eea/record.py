"""What a run leaves on disk and how to read it back (paper section 4; docs/self_modeling.md).

A run directory holds ``config.json`` (the :class:`~eea.config.EEAConfig`, nested:
:meth:`~eea.config.EEAConfig.to_dict`; a flat one written before the sections loads too),
``rounds.csv`` (one row per round, columns :data:`ROUND_COLUMNS`) and the checkpoint
``state.pkl``; a run with ``lineages`` >= 2 also ``lineages.csv`` (:func:`write_lineages`, from
the history of :class:`eea.search.lineages.Lineages`); a finished ``morphology+servos`` run also
``fault_check.json`` (:mod:`eea.fault_check`: its final model against fault hypotheses,
and the self-model kept, :attr:`RunResult.self_model`). A run's target experiments can be
written to and read from a plain-array file (:func:`save_experiments`,
:func:`load_experiments`; a mission keeps its recovery's so). Columns of ``rounds.csv``:

* ``round`` (1-based), ``objective_fitness`` (eq. 4 of the best model, an oracle),
  ``model_fitness`` (its MOD_FIT, eq. 3), ``action_fitness`` (ACT_FIT, eq. 1, of the
  action performed);
* ``model_<field>``: the best model's 9 dimensions (simulator units,
  ``aquafish_gym.MORPHOLOGY_FIELDS`` order);
* only in the ``morphology+servos`` model space (``EEAConfig.model_space``, not the paper's;
  :func:`round_columns`), right after them: ``model_left_pectoral_gain``,
  ``model_right_pectoral_gain``, ``model_caudal_gain`` (the best model's servo gains) and
  ``true_left_pectoral_gain``, ``true_right_pectoral_gain``, ``true_caudal_gain`` (the
  target's: its faults' ``speed_scale``, 0 where seized), and ``objective_fitness`` is over
  the 12 values (:func:`eea.fitness.objective_fitness`). The paper's space's file is
  unchanged;
* ``action_left_pectoral_rev_s``, ``action_right_pectoral_rev_s``, ``action_caudal_hz``:
  the action performed on the target this round;
* ``true_<flipper>_rad`` and ``inferred_<flipper>_rad``: the newest experiment's true
  initial angles and the inferred ones (middle of its context's ranges) at the end of the
  round, flippers ``left`` and ``right`` pectoral and ``caudal`` (e.g. ``true_left_rad``);
  :attr:`RunResult.inference_error_deg` turns them into the inference error;
* ``target_experiments``, ``simulations`` (model simulations run, cache hits excluded) and
  ``wall_seconds``, all cumulative.

Floats are written with ``repr`` (round-trip exact), so two runs can be compared byte for
byte (``wall_seconds`` aside).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from aquafish_gym import ACTION_FIELDS, MORPHOLOGY_FIELDS, Morphology, ServoFaults, get_damage
from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import FileError, read_json
from aquafish_gym.simulator import AT_REST
from eea.checkpoint import CONFIG_FILE
from eea.config import EEAConfig
from eea.encoding import SERVO_GAIN_FIELDS, get_model_space, model_space_of, servo_gains
from eea.experiment import FLIPPERS, Experiment, angle_errors_deg
from eea.fault_check import FaultCheck, read_fault_check
from eea.fitness import objective_fitness

__all__ = ["CONFIG_FILE", "GAIN_COLUMNS", "LINEAGES_FILE", "LINEAGE_COLUMNS", "ROUNDS_FILE", "ROUND_COLUMNS",
           "RunResult", "TRUE_GAIN_COLUMNS", "check_rounds", "lineage_columns", "load_experiments", "load_result",
           "read_rounds", "read_config", "read_csv", "round_columns", "round_row", "save_experiments", "write_config",
           "write_csv", "write_lineages", "write_rounds"]

ROUNDS_FILE = "rounds.csv"
MODEL_COLUMNS = tuple(f"model_{name}" for name in MORPHOLOGY_FIELDS)
ACTION_COLUMNS = tuple(f"action_{name}" for name in ACTION_FIELDS)
ROUND_COLUMNS: tuple[str, ...] = (
    "round", "objective_fitness", "model_fitness", "action_fitness", *MODEL_COLUMNS, *ACTION_COLUMNS,
    *(f"true_{f}_rad" for f in FLIPPERS), *(f"inferred_{f}_rad" for f in FLIPPERS),
    "target_experiments", "simulations", "wall_seconds",
)
_INT_COLUMNS = ("round", "target_experiments", "simulations")
#: The ``morphology+servos`` space's extra columns: the best model's servo gains and the target's.
GAIN_COLUMNS = tuple(f"model_{name}" for name in SERVO_GAIN_FIELDS)
TRUE_GAIN_COLUMNS = tuple(f"true_{name}" for name in SERVO_GAIN_FIELDS)
_SERVO_ROUND_COLUMNS = (*ROUND_COLUMNS[:4 + len(MODEL_COLUMNS)], *GAIN_COLUMNS, *TRUE_GAIN_COLUMNS,
                        *ROUND_COLUMNS[4 + len(MODEL_COLUMNS):])


def round_columns(model_space="morphology") -> tuple[str, ...]:
    """The columns of ``rounds.csv`` in a model space: :data:`ROUND_COLUMNS` in the paper's
    ``morphology``; with ``morphology+servos`` also :data:`GAIN_COLUMNS` and
    :data:`TRUE_GAIN_COLUMNS`, after the ``model_<field>`` columns.

    Raises:
        ValueError: on an unknown model space.
    """
    return _SERVO_ROUND_COLUMNS if get_model_space(model_space).servos else ROUND_COLUMNS


@dataclasses.dataclass(frozen=True)
class RunResult:
    """A run's config and per-round records.

    Attributes:
        out_dir: the run directory.
        config: the run's :class:`~eea.config.EEAConfig`.
        rounds: one dict per finished round, keys :data:`ROUND_COLUMNS` (ints and floats).
    """

    out_dir: Path
    config: EEAConfig
    rounds: list

    @property
    def finished(self) -> bool:
        """Whether all ``config.rounds`` rounds are done."""
        return len(self.rounds) >= self.config.rounds

    @property
    def target_morphology(self) -> Morphology:
        """The target's true morphology: the run's damage applied to the healthy robot (the
        oracle of OBJ_FIT, eq. 4)."""
        return get_damage(self.config.damage).apply()

    @property
    def model_space(self):
        """The run's :class:`~eea.encoding.ModelSpace` (``config.model_space``)."""
        return get_model_space(self.config.model_space)

    @property
    def true_model(self) -> np.ndarray:
        """``(n,)`` the target's values in the run's model space (the oracle of OBJ_FIT): its 9
        dimensions, and in ``morphology+servos`` its 3 servo gains (:meth:`ModelSpace.truth`)."""
        return self.model_space.truth(self.config.damage)

    @property
    def best_model(self) -> np.ndarray:
        """``(n,)`` the final round's best model in the run's model space: its 9 dimensions, and
        in ``morphology+servos`` its 3 servo gains.

        Raises:
            ValueError: if no round has finished yet.
        """
        dims = self.best_morphology.to_array()
        if not self.model_space.servos:
            return dims
        return np.concatenate([dims, [self.rounds[-1][c] for c in GAIN_COLUMNS]])

    @property
    def fault_check(self) -> "FaultCheck | None":
        """The check of the final model against fault hypotheses
        (:class:`eea.fault_check.FaultCheck`, ``fault_check.json``), or None: in the ``morphology``
        space, before the last round is done, or when the record is of an earlier round (a run
        extended since) or of other hypotheses (:meth:`~eea.fault_check.FaultCheck.is_current`).

        Raises:
            FileError: (a ``ValueError``) a corrupt ``fault_check.json``.
        """
        if not self.model_space.servos or not self.rounds:
            return None
        check = read_fault_check(self.out_dir)
        return check if check is not None and check.is_current(self.rounds[-1]["round"]) else None

    @property
    def self_model(self) -> np.ndarray:
        """``(n,)`` the run's self-model: in ``morphology+servos`` the model its check against
        fault hypotheses kept (:mod:`eea.fault_check`) once made, else (and in the paper's
        ``morphology`` space) :attr:`best_model`.

        Raises:
            ValueError: if no round has finished yet.
        """
        check = self.fault_check
        return self.best_model if check is None else check.model.copy()

    @property
    def self_model_morphology(self) -> Morphology:
        """The dimensions of :attr:`self_model` as a :class:`~aquafish_gym.Morphology`."""
        return Morphology.from_array(self.self_model[:len(MORPHOLOGY_FIELDS)])

    @property
    def self_model_objective_fitness(self) -> float:
        """OBJ_FIT (eq. 4) of :attr:`self_model` (the final round's ``objective_fitness`` when
        no check has changed the model)."""
        return float(objective_fitness(self.self_model, self.true_model, self.model_space.bounds))

    @property
    def best_morphology(self) -> Morphology:
        """The final round's best model as a :class:`~aquafish_gym.Morphology` (its dimensions;
        its servo gains, in ``morphology+servos``, are in :attr:`best_model`).

        Raises:
            ValueError: if no round has finished yet.
        """
        if not self.rounds:
            raise ValueError(f"run {self.out_dir} has no finished round yet")
        return Morphology.from_array([self.rounds[-1][c] for c in MODEL_COLUMNS])

    @property
    def objective_fitness(self) -> list[float]:
        """OBJ_FIT of every finished round, in order."""
        return [row["objective_fitness"] for row in self.rounds]

    @property
    def inference_error_deg(self) -> np.ndarray:
        """How far each round's inferred initial angles are from the true ones.

        Returns:
            ``(rounds, 3)`` degrees, flippers (left, right pectoral, caudal): the distance
            between ``inferred_<flipper>_rad`` and ``true_<flipper>_rad`` of the round's
            experiment, the short way round the circle for the pectorals (at most 180) and
            on the line for the caudal fin (at most 60). ``known``: all 0; ``none``: the
            distance of the true angles from the zero state.
        """
        if not self.rounds:
            return np.zeros((0, 3))
        true = np.array([[row[f"true_{f}_rad"] for f in FLIPPERS] for row in self.rounds])
        inferred = np.array([[row[f"inferred_{f}_rad"] for f in FLIPPERS] for row in self.rounds])
        return angle_errors_deg(inferred, true)


def round_row(record, target_morphology: Morphology, wall_seconds: float, *, model_space="morphology",
              target_faults: ServoFaults | None = None) -> dict:
    """The ``rounds.csv`` row of a :class:`eea.round.RoundRecord`.

    Args:
        record: the round.
        target_morphology: the target's true morphology (the oracle of OBJ_FIT, eq. 4).
        wall_seconds: cumulative wall seconds of the run after this round.
        model_space: the run's model space (name or :class:`~eea.encoding.ModelSpace`).
        target_faults: the target's servo faults (``morphology+servos``: its true gains,
            :func:`eea.encoding.servo_gains`; None: healthy servos).

    Returns:
        A dict with keys :func:`round_columns` (ints and floats).
    """
    space = get_model_space(model_space)
    values = space.decode(record.best_genome)
    truth = target_morphology.to_array()
    if space.servos:
        truth = np.concatenate([truth, servo_gains(target_faults or ServoFaults())])
    experiment = record.experiment
    row = {"round": int(record.number),
           "objective_fitness": objective_fitness(values, truth, space.bounds),
           "model_fitness": float(record.model_fitness), "action_fitness": float(record.action_fitness)}
    row.update(zip(MODEL_COLUMNS, values[:9].tolist()))
    if space.servos:
        row.update(zip(GAIN_COLUMNS, values[9:].tolist()))
        row.update(zip(TRUE_GAIN_COLUMNS, truth[9:].tolist()))
    row.update(zip(ACTION_COLUMNS, np.asarray(record.action, dtype=float).tolist()))
    row.update({f"true_{f}_rad": a for f, a in zip(FLIPPERS, experiment.true_angles.tolist())})
    row.update({f"inferred_{f}_rad": a for f, a in zip(FLIPPERS, experiment.context.estimate().tolist())})
    row.update({"target_experiments": experiment.index + 1, "simulations": int(record.simulations),
                "wall_seconds": float(wall_seconds)})
    return row


def write_config(out_dir: str | os.PathLike, config: EEAConfig) -> None:
    """Write ``config.json`` atomically."""
    atomic_write(Path(out_dir) / CONFIG_FILE, (json.dumps(config.to_dict(), indent=2) + "\n").encode())


def read_config(out_dir: str | os.PathLike) -> EEAConfig | None:
    """The config in ``out_dir/config.json``, or None if there is none.

    Raises:
        FileError: (a ``ValueError``) the file is not valid JSON or not a valid config; the
            message names the file and the problem.
        OSError: the file cannot be read.
    """
    path = Path(out_dir) / CONFIG_FILE
    if not path.exists():
        return None
    data = read_json(path)
    try:
        return EEAConfig.from_dict(data)
    except (ValueError, TypeError) as err:
        raise FileError(path, f"is not a valid EEA config ({err})") from None


def write_csv(path: str | os.PathLike, columns: Sequence[str], rows: Iterable[dict]) -> None:
    """Rewrite the CSV file ``path`` atomically: a header of ``columns``, then one line per
    dict of ``rows``, floats as ``repr`` (round-trip exact).

    Raises:
        ValueError: if a row has a key not in ``columns``.
    """
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})
    atomic_write(path, buffer.getvalue().encode())


def read_csv(path: str | os.PathLike, int_columns: Iterable[str] = ()) -> tuple[tuple[str, ...], list[dict]]:
    """The header and the rows of a CSV file written by :func:`write_csv`.

    Returns:
        ``(columns, rows)``: the header's column names, and one dict per line with the values
        of ``int_columns`` as ``int`` and every other value as ``float``.

    Raises:
        FileError: (a ``ValueError``) a line has too few or too many values (a truncated
            file) or a value does not parse as its column's type; the message names the file
            and the line.
        OSError: the file cannot be read.
    """
    int_columns = frozenset(int_columns)
    rows = []
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            for row in reader:
                line = reader.line_num
                if None in row or None in row.values():
                    raise FileError(path, f"line {line} has {'more' if None in row else 'fewer'} values than the "
                                          "header (a truncated or edited file)")
                rows.append({k: _parse(v, int if k in int_columns else float, path, line, k) for k, v in row.items()})
            return tuple(reader.fieldnames or ()), rows
    except (csv.Error, UnicodeDecodeError) as err:
        raise FileError(path, f"is not a readable CSV file ({err})") from None


def _parse(text: str, kind: type, path, line: int, column: str):
    try:
        return kind(text)
    except ValueError:
        raise FileError(path, f"line {line}, column {column}: {text!r} is not {'an int' if kind is int else 'a number'}") \
            from None


def write_rounds(out_dir: str | os.PathLike, rows: list, model_space="morphology") -> None:
    """Rewrite ``rounds.csv`` with all ``rows`` atomically (floats as ``repr``; the columns of
    the run's model space, :func:`round_columns`)."""
    write_csv(Path(out_dir) / ROUNDS_FILE, round_columns(model_space), rows)


def read_rounds(out_dir: str | os.PathLike, model_space=None) -> list[dict]:
    """Rows of ``out_dir/rounds.csv`` as dicts of ints and floats ([] if there is no file).

    The file is checked: its header is :data:`ROUND_COLUMNS` (or the ``morphology+servos``
    space's :func:`round_columns`, and with ``model_space`` given, that space's), every value
    is finite, and the rounds are 1, 2, 3, ... (unique and consecutive).

    Raises:
        FileError: (a ``ValueError``) the file breaks one of these rules or is not a
            readable CSV file; the message names the file, the line and the problem.
        OSError: the file cannot be read.
    """
    path = Path(out_dir) / ROUNDS_FILE
    if not path.exists():
        return []
    try:
        columns, rows = read_csv(path, _INT_COLUMNS)
        check_rounds(path, columns, rows, model_space)
    except FileError as err:  # the checkpoint holds the rows: a resume rewrites the file
        raise FileError(path, err.problem,
                        "run the same `aquafish eea` command again to rewrite it from the checkpoint (state.pkl), "
                        "or restore it from a copy") from None
    return rows


def check_rounds(path: str | os.PathLike, columns: Sequence[str], rows: Sequence[dict], model_space=None) -> None:
    """Check the rows of a ``rounds.csv`` (see :func:`read_rounds`).

    Args:
        model_space: the run's model space; None: the one the columns name (the servo gains'
            columns make it ``morphology+servos``).

    Raises:
        FileError: a column is missing or unknown, a value is not finite, or the rounds are
            not 1, 2, 3, ... in order.
    """
    if model_space is None:
        model_space = "morphology+servos" if any(c in GAIN_COLUMNS for c in columns) else "morphology"
    expected = round_columns(model_space)
    missing = [c for c in expected if c not in columns]
    unknown = [c for c in columns if c not in expected]
    if missing or unknown:
        raise FileError(path, "is not a rounds.csv: " + "; ".join(
            part for part in (f"missing columns {missing}" if missing else "",
                              f"unknown columns {unknown}" if unknown else "") if part))
    for i, row in enumerate(rows):
        line = i + 2  # the header is line 1
        bad = [k for k, v in row.items() if not np.isfinite(v)]
        if bad:
            raise FileError(path, f"line {line} (round {row['round']}) has non-finite values in {bad}")
        if row["round"] != i + 1:
            problem = ("repeats round" if any(r["round"] == row["round"] for r in rows[:i])
                       else "skips to round" if row["round"] > i + 1 else "goes back to round")
            raise FileError(path, f"line {line} {problem} {row['round']}; the rounds must be 1, 2, 3, ... in order")


def load_result(out_dir: str | os.PathLike) -> RunResult:
    """Read a (finished or partial) run from its directory.

    Raises:
        ValueError: if ``out_dir`` holds no ``config.json``.
    """
    config = read_config(out_dir)
    if config is None:
        raise ValueError(f"{out_dir} is not an EEA run directory (no {CONFIG_FILE})")
    return RunResult(Path(out_dir), config, read_rounds(out_dir, config.model_space))


#: A lineage run's per-round record of every lineage (:func:`write_lineages`): ``round``
#: (1-based), ``lineage`` (0-based), ``chosen`` (1 if its model was the round's model, else 0),
#: ``model_fitness`` (the lineage's own MOD_FIT, eq. 3, under its own angles),
#: ``selection_fitness`` (MOD_FIT under the round's equal angle fit) and ``model_<field>``
#: (its best model's 9 dimensions, simulator units, ``aquafish_gym.MORPHOLOGY_FIELDS`` order; in
#: the ``morphology+servos`` model space also its servo gains, ``model_<servo>_gain``,
#: :func:`lineage_columns`).
LINEAGES_FILE = "lineages.csv"
LINEAGE_COLUMNS: tuple[str, ...] = ("round", "lineage", "chosen", "model_fitness", "selection_fitness",
                                    *(f"model_{name}" for name in MORPHOLOGY_FIELDS))


def lineage_columns(model_space="morphology") -> tuple[str, ...]:
    """The columns of ``lineages.csv`` in a model space: :data:`LINEAGE_COLUMNS`, and the servo
    gains' ``model_<servo>_gain`` after them in ``morphology+servos``."""
    space = get_model_space(model_space)
    return LINEAGE_COLUMNS + (tuple(f"model_{name}" for name in SERVO_GAIN_FIELDS) if space.servos else ())


def write_lineages(out_dir: str | os.PathLike, history: Sequence[dict]) -> None:
    """Rewrite ``out_dir/lineages.csv`` atomically from a
    :class:`~eea.search.lineages.Lineages` ``history`` (its ``genomes``, ``chosen``,
    ``model_fitness`` and ``selection_fitness`` per round).

    One row per round and lineage, columns :func:`lineage_columns` of the genomes' model space
    (:data:`LINEAGE_COLUMNS` in the paper's), floats as ``repr`` (round-trip exact, as
    ``rounds.csv``).
    """
    rows = []
    space = model_space_of(history[0]["genomes"].shape[1]) if history else get_model_space("morphology")
    for number, h in enumerate(history, start=1):
        for lineage, values in enumerate(space.decode(h["genomes"])):
            rows.append({"round": number, "lineage": lineage, "chosen": int(lineage == h["chosen"]),
                         "model_fitness": float(h["model_fitness"][lineage]),
                         "selection_fitness": float(h["selection_fitness"][lineage]),
                         **{f"model_{name}": float(v) for name, v in zip(space.fields, values)}})
    write_csv(Path(out_dir) / LINEAGES_FILE, lineage_columns(space), rows)


#: The arrays of an experiments file (:func:`save_experiments`), one row per experiment.
_EXPERIMENT_ARRAYS = ("index", "action", "imu_log", "summary", "true_angles", "context_starts", "context_widths",
                      "context_confidence")


def save_experiments(path: str | os.PathLike, experiments) -> None:
    """Write ``experiments`` to ``path`` (a NumPy ``.npz`` of plain arrays, no pickle), atomically.

    The arrays, E = len(experiments) rows each: ``index`` (E,), ``action`` (E, 3),
    ``imu_log`` (E, steps, 3) in degrees, ``summary`` (E, 3, steps // 2 + 1),
    ``true_angles`` (E, 3) rad, the contexts' ``context_starts`` (E, 3),
    ``context_widths`` (E, 3) rad and ``context_confidence`` (E,), and ``start_motion``
    (E, 7) (:attr:`eea.experiment.Experiment.start_motion`). :func:`load_experiments`
    reads them back, so a run's target experiments can be scored again offline (a mission's
    self-model checked anew, say).

    Raises:
        ValueError: ``experiments`` is empty or its IMU logs differ in length.
    """
    buffer = io.BytesIO()
    np.savez(buffer, **experiment_arrays(tuple(e.state_dict() for e in experiments)))
    atomic_write(Path(path), buffer.getvalue())


def experiment_arrays(states) -> dict[str, np.ndarray]:
    """The arrays of :func:`save_experiments` from the experiments' state dicts
    (:meth:`eea.experiment.Experiment.state_dict`).

    Raises:
        ValueError: ``states`` is empty or its IMU logs differ in length.
    """
    states = tuple(states)
    if not states:
        raise ValueError("no experiments to save")
    shapes = {np.shape(state["imu_log"]) for state in states}
    if len(shapes) != 1:
        raise ValueError(f"experiments of different lengths cannot share one file: IMU logs {sorted(shapes)}")
    return {**{name: np.array([state[name] for state in states])
               for name in ("index", "action", "imu_log", "summary", "true_angles", "start_motion")},
            **{f"context_{key}": np.array([state["context"][key] for state in states])
               for key in ("starts", "widths", "confidence")}}


def load_experiments(path: str | os.PathLike) -> tuple[Experiment, ...]:
    """The experiments :func:`save_experiments` wrote to ``path``, oldest first (a file written
    before experiments had a ``start_motion`` gives experiments started at rest).

    Raises:
        FileError: ``path`` is missing, not such a file (no pickle is ever loaded), or its
            arrays do not fit together.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            return experiments_from_arrays(data)
    except FileNotFoundError:
        raise FileError(path, "does not exist", "give the experiments file a run wrote") from None
    except (OSError, KeyError, ValueError, TypeError) as err:
        raise FileError(path, f"is not an experiments file ({type(err).__name__}: {err})",
                        "give the experiments file a run wrote") from None


def experiments_from_arrays(data) -> tuple[Experiment, ...]:
    """The experiments of :func:`experiment_arrays`' arrays (``data``: a mapping or an open
    ``np.load`` of them; without ``start_motion``, every experiment starts at rest).

    Raises:
        KeyError, ValueError, TypeError: an array is missing or they do not fit together.
    """
    arrays = {name: data[name] for name in _EXPERIMENT_ARRAYS}
    files = data.files if hasattr(data, "files") else list(data)
    motion = data["start_motion"] if "start_motion" in files else np.tile(AT_REST, (len(arrays["index"]), 1))
    rows = zip(*(arrays[name] for name in _EXPERIMENT_ARRAYS), motion, strict=True)
    return tuple(Experiment.from_state_dict({
        "index": i, "action": a, "imu_log": log, "summary": summ, "true_angles": true,
        "context": {"starts": starts.tolist(), "widths": widths.tolist(), "confidence": float(c)},
        "start_motion": m})
        for i, a, log, summ, true, starts, widths, c, m in rows)
