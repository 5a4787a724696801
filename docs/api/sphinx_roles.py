"""Griffe extension for the API reference (mkdocs.yml): Sphinx roles in docstrings as links.

The docstrings cross-reference with Sphinx roles (``:class:`~aquafish_gym.Morphology```,
``:func:`run_round```), which Markdown would show verbatim. This rewrites each role into an
optional autorefs cross-reference: a link where the target is documented in the reference,
plain code where it is not (a private helper, a name from another library). A name without
dots is resolved in the scope of the object whose docstring names it; ``~`` shows only its
last part, as in Sphinx.
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|attr|data|exc|obj|const):`(~?)([^`<>]+?)`")


def _identifier(obj: griffe.Object, target: str) -> str:
    """The full path ``target`` names in ``obj``'s scope (as written where it cannot be resolved)."""
    target = target.lstrip(".")
    head, _, rest = target.partition(".")
    try:
        resolved = obj.resolve(head)
    except (griffe.NameResolutionError, griffe.AliasResolutionError, KeyError):
        return target
    return f"{resolved}.{rest}" if rest else resolved


def rewrite(obj: griffe.Object, text: str) -> str:
    """``text`` with its Sphinx roles replaced by optional autorefs cross-references."""

    def link(match: re.Match) -> str:
        tilde, target = match.groups()
        shown = target.rsplit(".", 1)[-1] if tilde else target.lstrip(".")
        identifier = html.escape(_identifier(obj, target), quote=True)
        return f'<autoref identifier="{identifier}" optional><code>{html.escape(shown)}</code></autoref>'

    return ROLE.sub(link, text)


class SphinxRoles(griffe.Extension):
    """Rewrite the Sphinx roles of every docstring of a loaded package."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        self._walk(pkg, seen=set())

    def _walk(self, obj: griffe.Object, seen: set[str]) -> None:
        if obj.path in seen:
            return
        seen.add(obj.path)
        if obj.docstring is not None:
            obj.docstring.value = rewrite(obj, obj.docstring.value)
        for member in obj.members.values():
            if not member.is_alias:
                self._walk(member, seen)
