"""What lets runs written by earlier versions load: their ``config.json`` and ``state.pkl``.

Every allowance for an older run's files is here, and nowhere else in the packages:

* :func:`upgrade_flat_fields`: a ``config.json`` (or a ``study.json`` ``base``, or a
  checkpoint's config) written before :class:`eea.config.EEAConfig` nested its sections holds
  every setting flat, by the names of the command-line flags, some of them as older versions
  wrote them; it becomes today's flat fields, which :meth:`eea.config.EEAConfig.from_dict`
  nests through the one mapping table (:data:`eea.config.FLAT_FIELDS`).
* :data:`RETIRED_FIELDS`, :data:`RETIRED_VALUES` and :func:`strip_retired` (flat), and
  :data:`RETIRED_SECTION_FIELDS` and :func:`strip_retired_sections` (nested): a ``config.json``
  written before a variant was retired holds the variant's switch.
  :func:`upgrade_flat_fields` drops such a field when it has its default (the run
  did not use the variant) and refuses the file otherwise (the run did: rerun it at the commit
  docs/studies/retired_variants.md names, which also records what each variant was and why it
  was retired).
* :data:`MODULE_RENAMES`, :class:`RenamingUnpickler` and :func:`loads`: classes are pickled by
  module path, and checkpoints written before :mod:`eea.search` and :mod:`eea.inference` became
  packages name the old paths (:func:`eea.checkpoint.load_state` reads ``state.pkl`` through the
  unpickler, :meth:`eea.search.cma.CMAModelSearch.from_state_dict` the search pickled inside it).
* :func:`upgrade_cma_search` and :func:`upgrade_estimation_state`: the attributes and keys that
  older checkpoints lack or still hold, set to what the run they describe did.

This module imports nothing of :mod:`eea`, so any module may use it without an import cycle.
"""

from __future__ import annotations

import io
import pickle

__all__ = ["MODULE_RENAMES", "RETIRED_FIELDS", "RETIRED_SECTION_FIELDS", "RETIRED_VALUES", "RenamingUnpickler",
           "loads", "strip_retired", "strip_retired_sections", "upgrade_cma_search", "upgrade_estimation_state",
           "upgrade_flat_fields"]

#: Fields of retired variants (docs/studies/retired_variants.md) and the default
#: each had: a ``config.json`` written before holds them, and loads (:func:`strip_retired`)
#: if each has its default, i.e. the run did not use the retired variant.
RETIRED_FIELDS: dict[str, object] = {
    "cma_global_period": 0, "cma_global_first_round": 2, "profile_contender_distance": 0.0,
    "profile_inherit": "hamming", "profile_library_newcomers": 0, "profile_select": 0, "profile_select_refine": 30,
    "profile_fine_steps": 0, "profile_polish": 0, "profile_scan": 0, "exploration_spread_weight": 1.0,
    "model_similarity": "paper", "oob_experiments": "newest",
    "cma_global_flip": 0,  # the global share started at the gain-flipped local best (measured at eac968c)
    "oob_draw": "best",  # out-of-band's optAng scored by a random sample of the models (last ran at e5577a9)
}

#: Retired values of fields that stay, by field: a ``config.json`` holding one was written by
#: a run of a retired variant (docs/studies/retired_variants.md) and does not load.
RETIRED_VALUES: dict[str, tuple] = {
    "cma_flip_gains": (2,),  # the pectoral gains injected at their fault classes (last ran at eed7c8d)
    "model_space": ("morphology_nonzero",),  # the grid one level up, no zero-size flipper (last ran at e5577a9)
}

#: Fields of retired variants inside a nested ``config.json``'s sections: by the section and the
#: name of its variant (``inference``'s strategy), each field with the default it had. A
#: ``config.json`` written before the field's retirement holds it (:func:`strip_retired_sections`).
RETIRED_SECTION_FIELDS: dict[tuple[str, str], dict[str, object]] = {
    ("inference", "out_of_band"): {"draw": "best"},  # the flat field oob_draw (last ran at e5577a9)
}


def strip_retired(data: dict) -> dict:
    """``data`` (a ``config.json``) without the fields of :data:`RETIRED_FIELDS`.

    Raises:
        ValueError: a retired field with another value than its default, or a value of
            :data:`RETIRED_VALUES` (the run used a retired variant; rerun it at the commit
            docs/studies/retired_variants.md names).
    """
    for name in set(data) & set(RETIRED_FIELDS):
        if data[name] != RETIRED_FIELDS[name]:
            raise ValueError(f"EEAConfig.{name} = {data[name]!r}: this run used a retired variant "
                             f"(docs/studies/retired_variants.md names the commit that runs it); only its "
                             f"default {RETIRED_FIELDS[name]!r} loads")
    _refuse_retired_values(data)
    return {k: v for k, v in data.items() if k not in RETIRED_FIELDS}


def _refuse_retired_values(data: dict) -> None:
    """Raise ValueError if a field of ``data`` holds a value of :data:`RETIRED_VALUES`."""
    for name in set(data) & set(RETIRED_VALUES):
        if data[name] in RETIRED_VALUES[name]:
            raise ValueError(f"EEAConfig.{name} = {data[name]!r}: this run used a retired variant "
                             f"(docs/studies/retired_variants.md names the commit that runs it)")


def strip_retired_sections(data: dict) -> dict:
    """A nested ``config.json`` (:meth:`eea.config.EEAConfig.to_dict`) without the fields of
    :data:`RETIRED_SECTION_FIELDS` in its sections.

    Raises:
        ValueError: a retired field with another value than its default, or a run field with a
            value of :data:`RETIRED_VALUES` (the run used a retired variant; rerun it at the
            commit docs/studies/retired_variants.md names).
    """
    _refuse_retired_values(data)
    data = dict(data)
    for (section, variant), retired in RETIRED_SECTION_FIELDS.items():
        fields = data.get(section)
        if not isinstance(fields, dict) or fields.get("name") != variant:
            continue
        for name in set(fields) & set(retired):
            if fields[name] != retired[name]:
                raise ValueError(f"EEAConfig.{section}.{name} = {fields[name]!r}: this run used a retired "
                                 f"variant (docs/studies/retired_variants.md names the commit that runs it); "
                                 f"only its default {retired[name]!r} loads")
        data[section] = {k: v for k, v in fields.items() if k not in retired}
    return data


def upgrade_flat_fields(data: dict) -> dict:
    """Flat fields written by an earlier version as today's flat fields: a ``waterline`` absent
    is deep water (None), and the fields of :data:`RETIRED_FIELDS` at their defaults are dropped
    (:func:`strip_retired`). What :meth:`eea.config.EEAConfig.from_dict` nests, and what a ``study.json``
    ``base`` (flat: the study's flags) is compared by.

    Args:
        data: ``{flat name: value}``.

    Raises:
        ValueError: as :func:`strip_retired` (a retired variant).
    """
    if "waterline" not in data:  # written before the surface swimmer: a deep-water run
        data = {**data, "waterline": None}
    return strip_retired(data)


#: Old module path -> new, for classes pickled before their module moved (when
#: :mod:`eea.search` and :mod:`eea.inference` became packages). Every name a moved module defined is
#: found in its new module (``eea.search.registry`` re-exports ``ModelGA``). ``eea.inference``
#: kept its path: it is now a package that re-exports the paper's strategies.
MODULE_RENAMES: dict[str, str] = {
    "eea.cma_search": "eea.search.cma",
    "eea.model_search": "eea.search.registry",
    "eea.lineages": "eea.search.lineages",
    "eea.strategy": "eea.inference.strategy",
    "eea.profile": "eea.inference.profile",
    "eea.selection": "eea.inference.selection",
}


class RenamingUnpickler(pickle.Unpickler):
    """A :class:`pickle.Unpickler` that looks classes of moved modules up under their new path
    (:data:`MODULE_RENAMES`)."""

    def find_class(self, module: str, name: str):
        return super().find_class(MODULE_RENAMES.get(module, module), name)


def loads(data: bytes):
    """:func:`pickle.loads` through :class:`RenamingUnpickler` (for pickles nested in a
    checkpoint, such as the CMA search's state)."""
    return RenamingUnpickler(io.BytesIO(data)).load()


def upgrade_cma_search(search) -> None:
    """Bring a :class:`~eea.search.cma.CMAModelSearch` unpickled from an older checkpoint up to
    date, in place: the attributes added since get the values that reproduce what it did, and
    those of retired variants are dropped."""
    if not hasattr(search, "_asked"):  # written before ask/tell misuse was checked
        search._asked = search._x is not None
    if not hasattr(search, "global_share"):  # written before the global share
        search.global_share, search._global_es = 0, None
    if not hasattr(search, "carry_condition"):  # written before the carried covariance
        search.carry_condition = 0.0
    if not hasattr(search, "global_keep"):  # written before the kept global lineage
        search.global_keep, search._global_best_x, search._global_restarts = 0, None, 0
    for retired in ("global_period", "global_first_round", "_restarts", "_incumbent", "_local_best_x"):
        search.__dict__.pop(retired, None)  # written before global restarts were retired


def upgrade_estimation_state(state: dict) -> dict:
    """An :meth:`eea.estimation.Estimation.state_dict` of an older checkpoint in today's form:
    its search under ``"search"`` (``"ga"`` before the CMA-ES search) and a ``"round"``
    (absent before ``exploration_diversity``)."""
    state = dict(state)
    if "search" not in state:
        state["search"] = state.pop("ga")
    state.setdefault("round", {})
    return state
