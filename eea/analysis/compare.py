"""Compare EEA variants on the same seeds: the table a study's claims rest on.

:mod:`eea.analysis.plot` groups runs by (inference, duration), the paper's figure layout. Comparing
*variants* (the same inference with another search, refinement or exploration setting)
needs the runs paired by seed instead, a baseline that means "learned nothing" or "the
paper's method", and the numbers a reader asks for first: the final OBJ_FIT (eq. 4) per
seed, Welch's p on the seeds both variants ran, how many runs reach a level of OBJ_FIT and
when, the median initial-angle error per flipper, the cost in simulations per round and, for runs
with servo gains in the model (``morphology+servos``), how many found both pectoral gains on
the truth's side of 0 (Fisher's exact test against the baseline)::

    variants = {"out_of_band": find_runs(["runs/oob/out_of_band"]),
                "profile": find_runs(["runs/profile/profile"])}
    print(comparison_table(compare_variants(variants, rounds=10), baseline="out_of_band"))

``aquafish compare LABEL=DIR ...`` prints the same table (and draws the mean curves).
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from aquafish_gym.files import save_figure
from eea.analysis.plot import welch_p_value
from eea.identification import pectoral_signs_right
from eea.record import GAIN_COLUMNS, MODEL_COLUMNS, RunResult

__all__ = ["VariantSummary", "compare_variants", "comparison_table", "fisher_p_value", "parse_variant",
           "plot_variants"]


@dataclasses.dataclass(frozen=True)
class VariantSummary:
    """One variant's runs at round R, keyed by seed.

    Attributes:
        label: the variant's name.
        rounds: R, the round compared (every run counted has finished it).
        seeds: ``(n,)`` the seeds of the runs counted, ascending.
        final: ``(n,)`` OBJ_FIT (eq. 4) at round R, seed for seed.
        reached: ``(n,)`` the first round (1-based) whose OBJ_FIT is >= ``level``, 0 if none
            up to R.
        level: the OBJ_FIT level of ``reached``.
        curve: ``(R,)`` mean OBJ_FIT per round over the runs.
        median_error_deg: ``(3,)`` median initial-angle error (degrees; left, right pectoral,
            caudal) over rounds 1..R of every run (:attr:`~eea.record.RunResult.inference_error_deg`).
        simulations_per_round: mean over the runs of the model simulations run by round R
            (cache hits excluded), divided by R.
        wall_seconds: mean over the runs of the wall seconds to the end of round R (the
            machine's and its load's, not the method's alone).
        left_out: runs that had not finished round R (not counted).
        signs_right: ``(n,)`` bool, seed for seed: whether the round-R model's two pectoral
            gains have the truth's signs (:func:`eea.identification.pectoral_signs_right`); None for
            runs without servo gains in the model, or whose target lost both pectoral flippers.
        self_model_final: ``(n,)`` OBJ_FIT of each run's self-model
            (:attr:`~eea.record.RunResult.self_model`: the model its check against fault
            hypotheses kept, else the round-R model), seed for seed; None unless every run is
            ``morphology+servos`` and R is its last round.
        self_model_signs_right: ``(n,)`` bool, :attr:`signs_right` of the self-models; None as
            ``self_model_final`` (or as :attr:`signs_right`).
        checked: ``(n,)`` bool, whether each run's self-model comes from a check made by today's
            procedure (:attr:`~eea.record.RunResult.fault_check`); None as ``self_model_final``.
    """

    label: str
    rounds: int
    seeds: np.ndarray
    final: np.ndarray
    reached: np.ndarray
    level: float
    curve: np.ndarray
    median_error_deg: np.ndarray
    simulations_per_round: float
    left_out: int
    signs_right: np.ndarray | None = None
    wall_seconds: float = float("nan")
    self_model_final: np.ndarray | None = None
    self_model_signs_right: np.ndarray | None = None
    checked: np.ndarray | None = None

    @property
    def mean(self) -> float:
        """Mean final OBJ_FIT."""
        return float(self.final.mean())

    @property
    def std(self) -> float:
        """Population standard deviation (ddof 0) of the final OBJ_FIT."""
        return float(self.final.std())

    def _rows(self, seeds) -> list[int]:
        """The rows of the given seeds, in their order (each must be counted)."""
        index = {int(s): i for i, s in enumerate(self.seeds)}
        return [index[int(s)] for s in seeds]

    def final_on(self, seeds) -> np.ndarray:
        """``(len(seeds),)`` final OBJ_FIT of the given seeds, in their order (each must be counted)."""
        return self.final[self._rows(seeds)]

    def signs_right_on(self, seeds) -> np.ndarray:
        """``(len(seeds),)`` :attr:`signs_right` of the given seeds, in their order (each must be
        counted; runs with servo gains only)."""
        return self.signs_right[self._rows(seeds)]


def fisher_p_value(right_a: int, n_a: int, right_b: int, n_b: int) -> float:
    """Two-sided p of Fisher's exact test that two variants succeed equally often.

    Args:
        right_a: successes of one variant (0 <= right_a <= n_a).
        n_a: its runs (>= 1).
        right_b: successes of the other (0 <= right_b <= n_b).
        n_b: its runs (>= 1).

    Returns:
        The p-value in [0, 1] (``scipy.stats.fisher_exact`` on the 2 x 2 table).

    Raises:
        ValueError: counts out of range.
    """
    if not (0 <= right_a <= n_a and 0 <= right_b <= n_b and n_a >= 1 and n_b >= 1):
        raise ValueError(f"counts must satisfy 0 <= right <= n, n >= 1; got {right_a}/{n_a} and {right_b}/{n_b}")
    from scipy.stats import fisher_exact

    return float(fisher_exact([[right_a, n_a - right_a], [right_b, n_b - right_b]])[1])


def parse_variant(text: str) -> tuple[str, Path]:
    """``"LABEL=DIR"`` -> ``(LABEL, Path(DIR))``, the command line's variant syntax.

    Raises:
        ValueError: if ``text`` has no ``=`` or an empty label or directory.
    """
    label, sep, path = text.partition("=")
    if not sep or not label.strip() or not path.strip():
        raise ValueError(f"a variant is LABEL=DIR (e.g. profile=runs/study/profile), got {text!r}")
    return label.strip(), Path(path.strip())


def _summarise(label: str, results: list[RunResult], rounds: int, level: float) -> VariantSummary:
    by_seed: dict[int, RunResult] = {}
    for r in results:
        if r.config.seed in by_seed:
            raise ValueError(f"variant {label!r} has two runs with seed {r.config.seed} ({by_seed[r.config.seed].out_dir} "
                             f"and {r.out_dir}); point it at one condition's directory")
        by_seed[r.config.seed] = r
    done = {s: r for s, r in sorted(by_seed.items()) if len(r.rounds) >= rounds}
    if not done:
        raise ValueError(f"variant {label!r}: none of its {len(by_seed)} runs has finished round {rounds}")
    values = np.array([r.objective_fitness[:rounds] for r in done.values()])  # (n, R)
    above = values >= level
    reached = np.where(above.any(axis=1), above.argmax(axis=1) + 1, 0)
    errors = np.concatenate([r.inference_error_deg[:rounds] for r in done.values()])
    sims = np.mean([r.rounds[rounds - 1]["simulations"] / rounds for r in done.values()])
    signs = None
    if all(r.model_space.servos for r in done.values()):
        verdicts = [pectoral_signs_right([r.rounds[rounds - 1][c] for c in (*MODEL_COLUMNS, *GAIN_COLUMNS)],
                                         r.true_model) for r in done.values()]
        signs = None if None in verdicts else np.array(verdicts)
    wall = np.mean([r.rounds[rounds - 1]["wall_seconds"] for r in done.values()])
    self_final = self_signs = checked = None
    if all(r.model_space.servos and len(r.rounds) == rounds for r in done.values()):
        self_final = np.array([r.self_model_objective_fitness for r in done.values()])
        checked = np.array([r.fault_check is not None for r in done.values()])
        verdicts = [pectoral_signs_right(r.self_model, r.true_model) for r in done.values()]
        self_signs = None if None in verdicts else np.array(verdicts)
    return VariantSummary(label, rounds, np.array(list(done)), values[:, -1], reached, float(level),
                          values.mean(axis=0), np.median(errors, axis=0), float(sims), len(by_seed) - len(done),
                          signs, float(wall), self_final, self_signs, checked)


def compare_variants(variants: dict[str, list[RunResult]], rounds: int | None = None,
                     level: float = 0.9) -> dict[str, VariantSummary]:
    """Summarise every variant's runs at the same round.

    Args:
        variants: ``{label: runs}`` (e.g. :func:`eea.analysis.plot.find_runs` of one condition's
            directory), in table order.
        rounds: the round R compared; None: the smallest ``config.rounds`` of all runs (the
            planned length). Runs that have not finished round R are left out and counted.
        level: the OBJ_FIT level whose first round is reported, in (0, 1].

    Returns:
        ``{label: VariantSummary}`` in the order given.

    Raises:
        ValueError: if there is no variant, a variant has no run or two runs with the same
            seed, none of a variant's runs has finished round R, ``rounds`` < 1 or ``level``
            is outside (0, 1].
    """
    if not variants:
        raise ValueError("compare_variants needs at least one variant")
    empty = [label for label, runs in variants.items() if not runs]
    if empty:
        raise ValueError(f"variants without runs: {', '.join(empty)}")
    if rounds is None:
        rounds = min(r.config.rounds for runs in variants.values() for r in runs)
    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)) or rounds < 1:
        raise ValueError(f"rounds must be an integer >= 1, got {rounds!r}")
    if not 0.0 < level <= 1.0:
        raise ValueError(f"level must be in (0, 1], got {level!r}")
    return {label: _summarise(label, runs, int(rounds), level) for label, runs in variants.items()}


def comparison_table(summary: dict[str, VariantSummary], baseline: str | None = None) -> str:
    """A Markdown table, one row per variant.

    Columns: variant; seeds; final OBJ_FIT mean ± std (ddof 0) and per seed; Welch's
    two-sided p (:func:`eea.analysis.plot.welch_p_value`) against ``baseline`` on the seeds both ran
    (their number in brackets; "-" for the baseline itself or when undefined); runs that
    reach the level, and their median first round; runs ending >= 0.95;
    median angle error L / R / C (degrees); simulations per round; wall minutes a run to
    round R (mean; the machine's and its load's); and, when some variant has
    servo gains in its model, runs with both pectoral signs right and Fisher's exact p
    (:func:`fisher_p_value`) against the baseline on the seeds both ran ("-" where a variant
    has no gains); and, when some variant's round R is its runs' last, the self-models'
    OBJ_FIT (the models their checks against fault hypotheses kept) and their runs with both
    signs right, with Fisher's p against the baseline's self-models, and how many runs were
    checked by today's procedure when not all were (the others' self-model is the round-R model).

    Args:
        summary: from :func:`compare_variants`.
        baseline: the label p is computed against; None: the first variant.

    Raises:
        ValueError: if ``baseline`` is not a label of ``summary``.
    """
    if not summary:
        raise ValueError("comparison_table needs at least one variant")
    baseline = next(iter(summary)) if baseline is None else baseline
    if baseline not in summary:
        raise ValueError(f"baseline {baseline!r} is not a variant; variants: {', '.join(summary)}")
    base = summary[baseline]
    gains = any(s.signs_right is not None for s in summary.values())
    selves = any(s.self_model_final is not None for s in summary.values())
    lines = [f"| variant | seeds | final OBJ_FIT (round {base.rounds}) | per seed | p vs {baseline} (seeds) | "
             f"reach {base.level:g} (median round) | >= 0.95 | median angle error L / R / C (°) | simulations per round |"
             " wall min a run |" + (f" pectoral signs right (Fisher p vs {baseline}) |" if gains else "")
             + (f" self-model OBJ_FIT (after the check) | self-model signs right (Fisher p vs {baseline}) |"
                if selves else ""),
             "|---|---|---|---|---|---|---|---|---|---|" + ("---|" if gains else "") + ("---|---|" if selves else "")]
    for label, s in summary.items():
        common = np.intersect1d(s.seeds, base.seeds)
        p = np.nan if label == baseline else welch_p_value(s.final_on(common), base.final_on(common))
        p_text = "-" if np.isnan(p) else f"{p:.2g} ({len(common)})"
        hit = s.reached[s.reached > 0]
        reach = f"{len(hit)}/{len(s.seeds)}" + (f" ({np.median(hit):g})" if len(hit) else "")
        consecutive = len(s.seeds) > 1 and np.array_equal(s.seeds, np.arange(s.seeds[0], s.seeds[-1] + 1))
        seeds = f"{s.seeds[0]}-{s.seeds[-1]}" if consecutive else ",".join(map(str, s.seeds))
        errors = " / ".join(f"{e:.0f}" for e in s.median_error_deg)
        row = (f"| {label} | {seeds} | {s.mean:.3f} ± {s.std:.3f} | {' '.join(f'{v:.3f}' for v in s.final)} | "
               f"{p_text} | {reach} | {int((s.final >= 0.95).sum())}/{len(s.seeds)} | {errors} | "
               f"{s.simulations_per_round:.0f} | {s.wall_seconds / 60:.1f} |")
        if gains:
            row += f" {_signs_text(s, base, label == baseline, 'signs_right')} |"
        if selves:
            final = ("-" if s.self_model_final is None
                     else f"{s.self_model_final.mean():.3f} ± {s.self_model_final.std():.3f}")
            signs = _signs_text(s, base, label == baseline, "self_model_signs_right")
            if s.checked is not None and not s.checked.all():
                signs += f"; {int(s.checked.sum())} checked"
            row += f" {final} | {signs} |"
        lines.append(row)
    return "\n".join(lines)


def _signs_text(s: VariantSummary, base: VariantSummary, is_baseline: bool, field: str) -> str:
    """``"k/n"`` of the runs with ``field`` (:attr:`VariantSummary.signs_right` or
    :attr:`~VariantSummary.self_model_signs_right`) true, with Fisher's p against the
    baseline's on the seeds both ran, or ``"-"``."""
    mine_all, theirs_all = getattr(s, field), getattr(base, field)
    if mine_all is None:
        return "-"
    text = f"{int(mine_all.sum())}/{len(s.seeds)}"
    if is_baseline or theirs_all is None:
        return text
    common = np.intersect1d(s.seeds, base.seeds)
    if not len(common):
        return text
    mine, theirs = mine_all[s._rows(common)], theirs_all[base._rows(common)]
    p = fisher_p_value(int(mine.sum()), len(common), int(theirs.sum()), len(common))
    return f"{text} (p {p:.2g}, {len(common)})"


def plot_variants(summary: dict[str, VariantSummary], out_png: str | os.PathLike) -> Path:
    """Mean OBJ_FIT against round, one line per variant (the number of runs in the legend).

    Args:
        summary: from :func:`compare_variants`.
        out_png: output image path (parent directories are created; written atomically).

    Returns:
        The PNG's path.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for label, s in summary.items():
        ax.plot(np.arange(1, s.rounds + 1), s.curve, "-o", markersize=3, label=f"{label} (n={len(s.seeds)})")
    ax.axhline(0.70, color="grey", linestyle=":", label="a random model (≈ 0.70)")
    ax.set_xlabel("EEA round")
    ax.set_ylabel("mean objective fitness")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    try:
        return save_figure(fig, out_png, format="png", dpi=120)
    finally:
        plt.close(fig)
