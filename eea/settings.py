"""The base of every settings section of :class:`eea.config.EEAConfig` (GA, CMA-ES, in-band,
out-of-band, profile, exploration): a frozen dataclass that names its fields' config names in
``CONFIG_FIELDS`` and is built from a config by :meth:`ConfigSection.from_config`."""

from __future__ import annotations

from typing import ClassVar

__all__ = ["ConfigSection"]


class ConfigSection:
    """Mixin of a settings section: ``CONFIG_FIELDS`` maps each field to its ``EEAConfig`` name."""

    #: Each field's name in :class:`eea.config.EEAConfig` (set by every section).
    CONFIG_FIELDS: ClassVar[dict[str, str]] = {}

    @classmethod
    def from_config(cls, config):
        """The section of an :class:`eea.config.EEAConfig` (validated again by the section)."""
        return cls(**{name: getattr(config, field) for name, field in cls.CONFIG_FIELDS.items()})
