"""How far an evaluation has got, for a person watching it and for its logs.

On a terminal, one live bar drawn by tqdm: episodes done of all, the rate, the time left and the
failures so far, redrawn in place (its clock every second, even while no episode ends).
Anywhere else (a log file, CI, a pipe) no bar is drawn: each finished episode prints one plain
line, which says the same and which episode it was and how it ended -- logs and CI read those
lines, so their text is kept as it has always been (one line, broken here at the ``|``)::

    [######........................] 2/10 episodes, 1 failed, 0m41s elapsed, ~2m44s left  |
    bt random #0 (seed 0): completed, score 2209.8

A stream that fails (the terminal hung up, the pipe closed) ends the progress output, never the
evaluation.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, TextIO

from tqdm import tqdm

__all__ = ["Progress", "as_minutes", "row_line"]

BAR_WIDTH = 30  # characters of the plain line's bar
LIVE_FORMAT = ("{percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} episodes "
               "[{elapsed}<{remaining}, {rate_fmt}{postfix}]")
DEFAULT_COLUMNS = 100  # of the live bar, when the terminal does not say
TICK_S = 1.0  # wall seconds between redraws of the live bar's clock while no episode ends


class Progress:
    """Episodes done of ``total``: a live tqdm bar on a terminal, plain lines elsewhere."""

    def __init__(self, total: int, stream: TextIO | None = None) -> None:
        self.total, self.done, self.failed = total, 0, 0
        self.stream: TextIO | None = stream or sys.stderr
        self.started = time.monotonic()
        self.bar: tqdm[Any] | None = _live_bar(total, self.stream) if _is_terminal(
            self.stream) else None
        self._closed = threading.Event()
        if self.bar is not None:
            threading.Thread(target=self._tick, name="progress-clock", daemon=True).start()

    @property
    def live(self) -> bool:
        """Whether a live bar is drawn (the stream is a terminal that has not failed)."""
        return self.bar is not None

    def advance(self, row: dict[str, Any]) -> None:
        """Count one finished episode (its row) and show it."""
        self.done += 1
        self.failed += not row["completed"]
        if self.bar is not None:
            self._guarded(self._redraw)
        else:
            self._write(f"{self.plain_bar()}  {row_line(row)}\n")

    def close(self) -> None:
        """Leave the bar as it ended, on a line of its own."""
        self._closed.set()
        if self.bar is not None:
            self._guarded(self.bar.close)
            self.bar = None

    def plain_bar(self) -> str:
        """The plain line's account: done of all, failures, time spent and left."""
        filled = round(BAR_WIDTH * self.done / self.total) if self.total else BAR_WIDTH
        elapsed = time.monotonic() - self.started
        left = elapsed / self.done * (self.total - self.done) if self.done else 0.0
        return (f"[{'#' * filled}{'.' * (BAR_WIDTH - filled)}] {self.done}/{self.total} "
                f"episodes, {self.failed} failed, {as_minutes(elapsed)} elapsed, "
                f"~{as_minutes(left)} left")

    def _redraw(self) -> None:
        assert self.bar is not None
        self.bar.set_postfix_str(f"{self.failed} failed", refresh=False)
        self.bar.update(1)

    def _tick(self) -> None:
        while not self._closed.wait(TICK_S):
            bar = self.bar
            if bar is None:
                return
            self._guarded(bar.refresh)

    def _guarded(self, action: Callable[[], object]) -> None:
        """Do ``action`` on the bar; a failing stream ends the progress output."""
        try:
            action()
        except (OSError, ValueError):
            bar, self.stream, self.bar = self.bar, None, None
            self._closed.set()
            if bar is not None:  # let tqdm forget it (its last words fail)
                with contextlib.suppress(OSError, ValueError):
                    bar.close()

    def _write(self, text: str) -> None:
        if self.stream is None:
            return
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):
            self.stream = None


def _is_terminal(stream: TextIO | None) -> bool:
    try:
        return stream is not None and stream.isatty()
    except (OSError, ValueError):
        return False


def _live_bar(total: int, stream: TextIO | None) -> tqdm[Any] | None:
    """tqdm's bar on ``stream``, as wide as the terminal; None if the stream fails at once.

    The size is given, not left to tqdm: a terminal that reports no rows (a pseudo-terminal
    nobody sized, as ``script`` makes) would make tqdm hide its only bar.
    """
    columns, rows = _terminal_size(stream)
    with contextlib.suppress(OSError, ValueError):
        return tqdm(total=total, file=stream, unit="episode", bar_format=LIVE_FORMAT,
                    ncols=columns if columns > 0 else DEFAULT_COLUMNS, nrows=max(rows, 2),
                    position=0, smoothing=0.1, postfix="0 failed")
    return None


def _terminal_size(stream: TextIO | None) -> tuple[int, int]:
    """The terminal's columns and rows; zeros if it cannot say."""
    try:
        size = os.get_terminal_size(stream.fileno())  # type: ignore[union-attr]
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        return 0, 0
    return size.columns, size.lines


def row_line(row: dict[str, Any]) -> str:
    """Which episode a row is and how it ended, in words."""
    seed = "shipped" if row["episode_seed"] is None else f"seed {row['episode_seed']}"
    verdict = (f"completed, score {row['score']:.1f}" if row["completed"]
               else f"failed: {row['failure']}")
    return f"{row['executive']} {row['scenario']} #{row['episode']} ({seed}): {verdict}"


def as_minutes(seconds: float) -> str:
    """``12m05s``."""
    return f"{int(seconds // 60)}m{int(seconds % 60):02d}s"
