"""Progress that reads well on a terminal and in a log file.

:func:`progress_bar` gives a tqdm bar when standard error is a terminal and otherwise a
:class:`LineProgress`: the same ``update``/``set_postfix``/``set_postfix_str``/``close``
interface, printing one plain line (no carriage return) to standard error per ``update``,
i.e. per round, generation, run or training chunk. Redirected to a file (``make demo > log
2>&1``), a run's progress is then a few readable lines instead of every bar refresh.
"""

from __future__ import annotations

import sys
import time

from tqdm.auto import tqdm

__all__ = ["LineProgress", "interactive", "progress_bar"]


def interactive() -> bool:
    """Whether standard error is a terminal (a tqdm bar redraws in place there)."""
    isatty = getattr(sys.stderr, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # a closed stream
        return False


class LineProgress:
    """Progress as one plain line per :meth:`update` on standard error (see the module).

    Args:
        total: the count at the end (None: unknown).
        initial: the count already done (a resumed run).
        desc: the line's label.
        unit: what is counted (``"round"``, ``"gen"``, ``"run"``, ``"step"``).
    """

    def __init__(self, total: int | None = None, initial: int = 0, desc: str = "", unit: str = "it"):
        self.total, self.n, self.desc, self.unit = total, initial, desc, unit
        self.initial = initial
        self.postfix = ""
        self.start = time.monotonic()

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        """Set the text shown after the count on the next line (prints nothing)."""
        self.postfix = str(s)

    def set_postfix(self, ordered_dict=None, refresh: bool = True, **kwargs) -> None:
        """Set the postfix from ``key=value`` pairs, as tqdm does (prints nothing)."""
        items = {**(ordered_dict or {}), **kwargs}
        self.postfix = ", ".join(f"{k}={str(v).strip()}" for k, v in items.items())

    def update(self, n: int = 1) -> None:
        """Add ``n`` to the count and print one line: ``DESC: N/TOTAL UNIT [elapsed<left, rate, postfix]``."""
        self.n += n
        elapsed = time.monotonic() - self.start
        rate = (self.n - self.initial) / elapsed if elapsed > 0 else 0.0  # this session's, as tqdm's
        times = tqdm.format_interval(elapsed)
        if self.total is not None and rate > 0:
            times += "<" + tqdm.format_interval(max(self.total - self.n, 0) / rate)
        if rate > 0:
            times += f", {rate:.3g} {self.unit}/s" if rate >= 1 else f", {1 / rate:.3g} s/{self.unit}"
        total = "?" if self.total is None else self.total
        postfix = f", {self.postfix}" if self.postfix else ""
        print(f"{self.desc}: {self.n}/{total} {self.unit} [{times}{postfix}]", file=sys.stderr, flush=True)

    def close(self) -> None:
        """Nothing to clean up (every line is already written)."""

    def __enter__(self) -> "LineProgress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def progress_bar(total: int | None = None, *, initial: int = 0, desc: str = "", unit: str = "it",
                 disable: bool = False):
    """A progress display over ``total`` units: a tqdm bar on a terminal, else a :class:`LineProgress`.

    Args:
        total: the count at the end (None: unknown).
        initial: the count already done (a resumed run).
        desc: the label.
        unit: what is counted, singular.
        disable: show nothing (a disabled tqdm bar, with the same interface).
    """
    if disable:
        return tqdm(total=total, initial=initial, disable=True)
    if interactive():
        return tqdm(total=total, initial=initial, desc=desc, unit=unit)
    return LineProgress(total, initial, desc, unit)
