"""``aquafish doctor``: which simulator path is active (compiled step or NumPy), why, and how to get the compiled one."""

from __future__ import annotations

import argparse

__all__ = ["add_commands"]


def _doctor(args: argparse.Namespace) -> int:
    from aquafish_gym import native

    print("\n".join(native.status()))
    return 0 if native.available() else 1


def add_commands(sub) -> None:
    """Add the ``doctor`` sub-command to an argparse ``subparsers`` object."""
    d = sub.add_parser("doctor", help="say whether the compiled simulator step is active, and if not why and how to get it",
                       description="Print which simulator path is active: the compiled step, or the NumPy path with the "
                                   "reason and how to get the compiled one. Exit status 0 if the compiled step is "
                                   "active, 1 if not.")
    d.set_defaults(func=_doctor)
