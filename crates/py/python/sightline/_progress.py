"""Progress reports of long bakes (``sightline.bake``, ``bake_cells``, ``sightline.ray.bake``).

A ``progress`` argument is one of:

- ``None`` (the default): a one-line display on stderr, rewritten in place, when stderr is a
  terminal; nothing otherwise (logs and pipes stay clean);
- ``False``: nothing; ``True``: the display even when stderr is not a terminal;
- a callable, called as ``progress(cells_done, cells_total, rays)`` from the thread that
  called the bake: ``rays`` counts the rays cast so far (by finished cells and, for local
  bakes, those under way). It is called at most about five times a second, and once more at
  the end with ``cells_done == cells_total``; an exception from it stops the bake and is
  raised by the bake.
"""

from __future__ import annotations

import sys
import time
from typing import Callable, Optional, Union

ProgressCallback = Callable[[int, int, int], object]
ProgressArg = Union[None, bool, ProgressCallback]

__all__ = ["ProgressArg", "ProgressCallback", "StderrProgress", "resolve"]


class StderrProgress:
    """``sightline: cells 3/10, 1.2M rays, 4.1 s`` on one line of stderr, rewritten in place."""

    def __init__(self, what: str = "cells") -> None:
        self.what = what
        self.start = time.monotonic()

    def __call__(self, done: int, total: int, rays: int) -> None:
        seconds = time.monotonic() - self.start
        line = f"sightline: {self.what} {done}/{total}, {_count(rays)} rays, {seconds:.1f} s"
        # "\r" returns to the line's start and "\x1b[K" clears what a longer line left there.
        end = "\n" if done >= total else ""
        sys.stderr.write(f"\r{line}\x1b[K{end}")
        sys.stderr.flush()


def _count(n: int) -> str:
    for unit, size in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if n >= size:
            return f"{n / size:.1f}{unit}"
    return str(n)


def _stderr_is_terminal() -> bool:
    try:
        return sys.stderr is not None and sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced by an object without isatty, or closed
        return False


def resolve(progress: ProgressArg, what: str = "cells") -> Optional[ProgressCallback]:
    """The callback a ``progress`` argument stands for (``None``: no reports)."""
    if progress is None:
        return StderrProgress(what) if _stderr_is_terminal() else None
    if progress is False:
        return None
    if progress is True:
        return StderrProgress(what)
    if callable(progress):
        return progress
    raise TypeError(
        f"progress must be None, True, False or a callable, got {type(progress).__name__}"
    )
