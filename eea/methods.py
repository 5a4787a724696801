"""Methods and budgets: the two axes of every self-modeling run, by name.

A **method** is how the EEA copes with the unknown initial flipper angles: the paper's four
context-inference strategies (section 3.3, 3.4) and the best method found beyond the paper.
A **budget** is how much search each round gets (rounds, populations, generations). They
are independent: any method runs at any budget::

    config = EEAConfig.from_method("profile_lineages", budget="reduced", damage="caudal_half")
    eea.config.method_of(config)      # "profile_lineages"

``aquafish eea --method M --budget B``, ``aquafish study --methods M1,M2 --budget B`` and
``aquafish case-study --method M`` take the same names. :attr:`Method.simulations_per_round`
is measured (rounds.csv ``simulations`` after 10 rounds / 10, reduced budget,
``left_pectoral_half``): the paper's four on the surface swimmer, seeds 0-4
(docs/results/surface_paper4_lph); ``profile_lineages`` in deep water, seeds 0-9
(docs/results/lph_lin2).
"""

from __future__ import annotations

import dataclasses

__all__ = ["BEST_METHOD", "BUDGETS", "METHODS", "PAPER_METHODS", "Method", "budget_fields", "method_fields"]


@dataclasses.dataclass(frozen=True)
class Method:
    """One named self-modeling method.

    Attributes:
        name: the registry key (also the study directory of its runs).
        summary: one line: what it does, and where it comes from.
        fields: the settings it sets, by flat name (:data:`eea.config.FLAT_FIELDS`; the rest keep
            their defaults).
        simulations_per_round: measured mean robot simulations per round at the ``reduced``
            budget (10 rounds, ``left_pectoral_half``; module docstring).
        paper: whether the paper defines it.
    """

    name: str
    summary: str
    fields: dict
    simulations_per_round: int
    paper: bool


#: The methods by name: the paper's four strategies, then the best method beyond the paper.
METHODS: dict[str, Method] = {m.name: m for m in (
    Method("known", "the target's initial angles are given to every model simulation (paper 3.3; a bound, "
           "not a method a robot can use)", {"inference": "known"}, 7_500, True),
    Method("none", "every experiment is assumed to start from zero angles (paper 3.3)",
           {"inference": "none"}, 7_600, True),
    Method("in_band", "models are scored over a sampled arc of angles inferred from the best K models "
           "(paper 3.4, In-Band)", {"inference": "in_band"}, 8_900, True),
    Method("out_of_band", "an inner GA fits one angle set per experiment to the best models every few "
           "generations (paper 3.4, Out-of-Band)", {"inference": "out_of_band"}, 8_500, True),
    Method("profile_lineages", "per-model angles fitted to every experiment (angle profile), robust and "
           "diverse exploration, CMA-ES with a carried covariance and a kept global share, contender "
           "refinement and an angle library, in two estimation lineages (not the paper's)",
           {"inference": "profile", "exploration_angles": 4, "exploration_diversity": 0.05,
            "estimation_search": "cma", "cma_carry_condition": 100.0, "cma_global_share": 8,
            "profile_refine": 10, "profile_contenders": 3, "profile_library": 8, "cma_global_keep": 3,
            "lineages": 2}, 73_000, False),
)}

#: The best method measured (docs/self_modeling.md): the case study's self-model by default.
BEST_METHOD = "profile_lineages"

#: The paper's four strategies (paper section 4, Figures 5-10).
PAPER_METHODS: tuple[str, ...] = tuple(name for name, m in METHODS.items() if m.paper)

#: Budgets by name: the fields each sets, by flat name (the rest keep the paper's values,
#: section 4). A budget sets the fields of every strategy; a config keeps those of the strategy
#: it runs (:meth:`eea.config.EEAConfig.from_method`).
#: ``smoke`` is a seconds-long pipeline check; ``quick`` the case study's quick EEA;
#: ``reduced`` about a quarter of the paper's simulations per run (every study table);
#: ``medium`` the paper's populations and generations over 10 rounds; ``paper`` the paper's.
BUDGETS: dict[str, dict] = {
    "smoke": dict(duration_s=0.32, rounds=2, estimation_population=12, estimation_generations=3,
                  exploration_population=4, exploration_generations=2, exploration_models=3, k_best=2,
                  oob_period=2, oob_sample=2, oob_population=3, oob_generations=2),
    "quick": dict(rounds=8, estimation_population=25, estimation_generations=30, exploration_population=12,
                  exploration_generations=8, exploration_models=8, oob_period=10, oob_population=8,
                  oob_generations=6),
    "reduced": dict(rounds=10, estimation_generations=30, exploration_generations=10, oob_period=10),
    "medium": dict(rounds=10),
    "paper": {},
}


def method_fields(name: str) -> dict:
    """The config fields of the method ``name``.

    Raises:
        ValueError: unknown method (the message lists the valid names).
    """
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; valid names: {', '.join(METHODS)}")
    return dict(METHODS[name].fields)


def budget_fields(name: str) -> dict:
    """The config fields of the budget ``name``.

    Raises:
        ValueError: unknown budget (the message lists the valid names).
    """
    if name not in BUDGETS:
        raise ValueError(f"unknown budget {name!r}; valid names: {', '.join(BUDGETS)}")
    return dict(BUDGETS[name])
