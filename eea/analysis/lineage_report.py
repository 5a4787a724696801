"""Reports of lineage runs (``--lineages`` >= 2, :mod:`eea.search.lineages`): each lineage's OBJ_FIT
(eq. 4) per round, from ``lineages.csv`` or the checkpoint."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from eea.checkpoint import load_state
from eea.encoding import SERVO_GAIN_FIELDS, get_model_space, model_space_of
from eea.fitness import objective_fitness
from eea.record import LINEAGES_FILE, lineage_columns
from eea.record import load_result, read_csv

__all__ = ["lineage_objective_fitness"]


def _lineage_models(out_dir) -> tuple[np.ndarray, np.ndarray] | None:
    """``(R, N, n)`` the lineages' best models (n values of their model space: 9, or 12 with servo
    gains) and ``(R,)`` the chosen lineage of every finished round, from ``lineages.csv`` or else
    the checkpoint; None if neither holds a lineage run."""
    path = Path(out_dir) / LINEAGES_FILE
    if path.exists():
        columns, rows = read_csv(path, ("round", "lineage", "chosen"))
        space = get_model_space("morphology+servos" if f"model_{SERVO_GAIN_FIELDS[0]}" in columns else "morphology")
        expected = lineage_columns(space)
        if columns != expected:
            raise ValueError(f"{path}: columns {list(columns)}, expected {list(expected)}")
        if rows:
            rounds, lineages = max(r["round"] for r in rows), max(r["lineage"] for r in rows) + 1
            if len(rows) != rounds * lineages:
                raise ValueError(f"{path} has {len(rows)} rows, not {rounds} rounds x {lineages} lineages")
            models = np.array([[r[f"model_{name}"] for name in space.fields] for r in rows])
            chosen = np.array([r["lineage"] for r in rows if r["chosen"] == 1], dtype=int)
            return models.reshape(rounds, lineages, -1), chosen
    state = load_state(out_dir)
    if state is None or "lineages" not in state.estimation:
        return None
    history = state.estimation["history"]
    if not history:
        return np.zeros((0, 0, 0)), np.zeros(0, dtype=int)
    space = model_space_of(history[0]["genomes"].shape[1])
    return (np.array([space.decode(h["genomes"]) for h in history]),
            np.array([h["chosen"] for h in history], dtype=int))


def lineage_objective_fitness(out_dir) -> tuple[np.ndarray, np.ndarray]:
    """Each lineage's OBJ_FIT (eq. 4) round by round, from a lineage run's directory.

    OBJ_FIT needs the true morphology, an oracle the run never uses: this tells how often
    the round's selection kept the best lineage, and what one lineage alone would score.

    Args:
        out_dir: a run directory of a run with ``lineages`` >= 2: its ``lineages.csv``
            (:func:`write_lineages`), or else its checkpoint ``state.pkl`` (runs from before
            the file existed).

    Returns:
        ``(objective, chosen)``: ``(R, N)`` each lineage's best model's OBJ_FIT after each
        of the R finished rounds, and ``(R,)`` int the lineage chosen in each.

    Raises:
        ValueError: if ``out_dir`` holds neither file of a lineage run, or a ``lineages.csv``
            whose columns are not :data:`LINEAGE_COLUMNS` or whose rows are not rounds x lineages.
    """
    found = _lineage_models(out_dir)
    if found is None:
        raise ValueError(f"{out_dir} holds no {LINEAGES_FILE} and no checkpoint of a run with lineages >= 2")
    models, chosen = found
    result = load_result(out_dir)
    space, truth = result.model_space, result.true_model
    if models.size and models.shape[-1] != len(truth):
        raise ValueError(f"{out_dir}: the lineages' models have {models.shape[-1]} values, its model space "
                         f"{space.name} {len(truth)}")
    objective = np.array([[objective_fitness(values, truth, space.bounds) for values in per_round]
                          for per_round in models])
    return objective.reshape(len(models), -1), chosen
