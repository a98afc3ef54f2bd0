"""One-line progress bars on a terminal for the ``xface`` commands (tables, large maps,
studies, the bench): off with ``--quiet`` or when stderr is not a terminal."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TextIO, TypeVar

__all__ = ["ProgressBar", "terminal_progress"]


class ProgressBar:
    """``label [####......] done/total unit, elapsed s, about N s left`` on ``stream``,
    redrawn in place; :meth:`close` ends the line once something was drawn."""

    def __init__(self, stream: TextIO, label: str, unit: str = "designs") -> None:
        self.stream, self.label, self.unit = stream, label, unit
        self.started = time.monotonic()
        self.shown = False
        self._width = 0  # characters of the line drawn last

    def draw(self, done: int, total: int, elapsed: float, note: str = "") -> None:
        """Redraw at ``done`` of ``total`` after ``elapsed`` seconds; ``note`` follows the
        counts (e.g. `` (2 already done)``)."""
        width = 30
        filled = width if total == 0 else width * done // total
        eta = f", about {elapsed / done * (total - done):.0f} s left" if done else ""
        line = (
            f"{self.label} [{'#' * filled}{'.' * (width - filled)}] {done}/{total} "
            f"{self.unit}{note}, {elapsed:.0f} s{eta} "
        )
        self.stream.write(f"\r{line}")
        self.stream.flush()
        self.shown = True
        self._width = len(line)

    def clear(self) -> None:
        """Blank the line drawn last, so a line printed next on the same terminal (stdout)
        does not run on after the bar; the next :meth:`draw` brings the bar back."""
        if self._width:
            self.stream.write(f"\r{' ' * self._width}\r")
            self.stream.flush()
            self._width = 0

    def step(self, done: int, total: int) -> None:
        """:meth:`draw` timed from the bar's creation: a ``progress(done, total)`` callback."""
        self.draw(done, total, time.monotonic() - self.started)

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()


Bar = TypeVar("Bar", bound=ProgressBar)


@contextmanager
def terminal_progress(quiet: bool, make: Callable[[TextIO], Bar]) -> Iterator[Bar | None]:
    """The bar ``make(sys.stderr)`` for the block (closed after it), or None when ``quiet``
    or stderr is not a terminal."""
    bar = None if quiet or not sys.stderr.isatty() else make(sys.stderr)
    try:
        yield bar
    finally:
        if bar is not None:
            bar.close()
