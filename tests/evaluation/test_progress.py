"""Progress of an evaluation: a live bar on a terminal, the plain lines elsewhere, and a stream
that fails never ends the evaluation."""

from __future__ import annotations

import io
import os
import re
import select
import time
from typing import Any

from bt_servicesim.evaluation.progress import TICK_S, Progress


class Terminal(io.StringIO):
    """What a terminal looks like to the progress: ``isatty()`` says yes."""

    def isatty(self) -> bool:
        return True


class HungUp(Terminal):
    """A terminal that hung up after ``fails_after`` writes."""

    def __init__(self, fails_after: int, terminal: bool = True, errno: int = 5) -> None:
        super().__init__()
        self.fails_after, self.terminal, self.errno = fails_after, terminal, errno

    def isatty(self) -> bool:
        return self.terminal

    def write(self, text: str) -> int:
        if self.fails_after <= 0:
            raise OSError(self.errno, "the terminal hung up")
        self.fails_after -= 1
        return super().write(text)


def row(*, completed: bool, seed: int | None = 3, episode: int = 0) -> dict[str, Any]:
    return {"executive": "bt", "scenario": "random" if seed is not None else "default",
            "episode": episode, "episode_seed": seed, "completed": completed,
            "score": 2209.84 if completed else None,
            "failure": None if completed else "the mission tree ended with FAILURE"}


def test_off_a_terminal_each_episode_is_one_plain_line_as_before() -> None:
    stream = io.StringIO()
    progress = Progress(4, stream)
    assert not progress.live
    progress.advance(row(completed=True))
    progress.advance(row(completed=False, seed=None, episode=1))
    progress.close()
    first, second = stream.getvalue().splitlines()
    assert re.fullmatch(r"\[#{8}\.{22}\] 1/4 episodes, 0 failed, 0m00s elapsed, ~0m00s left  "
                        r"bt random #0 \(seed 3\): completed, score 2209\.8", first), first
    assert re.fullmatch(r"\[#{15}\.{15}\] 2/4 episodes, 1 failed, 0m00s elapsed, ~0m00s left  "
                        r"bt default #1 \(shipped\): failed: the mission tree ended with "
                        r"FAILURE", second), second
    assert "\r" not in stream.getvalue() and "\x1b" not in stream.getvalue()


def test_on_a_terminal_one_live_bar_counts_done_failed_rate_and_time_left() -> None:
    stream = Terminal()
    progress = Progress(3, stream)
    assert progress.live
    progress.advance(row(completed=False))
    time.sleep(0.2)  # past tqdm's least interval between redraws
    progress.advance(row(completed=True))
    progress.close()
    text = stream.getvalue()
    last = text.rstrip("\n").split("\r")[-1]
    assert re.search(r"2/3 episodes \[\d\d:\d\d<\d\d:\d\d, +[\d.]+(episode/s|s/episode), "
                     r"1 failed\]", last), last
    assert "bt random #0" not in text, "no plain line per episode on a terminal"
    assert text.endswith("\n"), "the bar ends on a line of its own"


def test_the_live_bar_keeps_its_clock_going_between_episodes() -> None:
    stream = Terminal()
    progress = Progress(2, stream)
    drawn = stream.getvalue().count("\r")
    deadline = time.monotonic() + 30 * TICK_S  # a generous bound on a loaded machine
    while stream.getvalue().count("\r") <= drawn and time.monotonic() < deadline:
        time.sleep(0.05)
    assert stream.getvalue().count("\r") > drawn, "redrawn while no episode ended"
    progress.close()
    closed = stream.getvalue()
    time.sleep(1.5 * TICK_S)
    assert stream.getvalue() == closed, "nothing drawn once closed"


def test_a_stream_that_fails_ends_the_progress_never_the_evaluation() -> None:
    for terminal, errno in ((True, 5), (True, 32), (False, 5), (False, 32)):  # EIO, EPIPE
        stream = HungUp(fails_after=1, terminal=terminal, errno=errno)
        progress = Progress(3, stream)
        for _ in range(3):
            progress.advance(row(completed=False))
        progress.close()
        assert progress.done == 3 and progress.failed == 3
        assert stream.fails_after == 0, "it wrote until the stream failed"
    for errno in (5, 32):
        Progress(1, HungUp(fails_after=0, errno=errno)).advance(row(completed=True))


def read_all(terminal: int, *, quiet_s: float = 0.5) -> str:
    """What was written to a pseudo-terminal's other end: the kernel hands it on in pieces,
    later on a busy machine, so read until nothing more comes for ``quiet_s``."""
    pieces = []
    while select.select([terminal], [], [], quiet_s)[0]:
        pieces.append(os.read(terminal, 65536))
    return b"".join(pieces).decode(errors="replace")


def test_a_pseudo_terminal_that_reports_no_size_still_gets_the_bar() -> None:
    main, child = os.openpty()  # a new pseudo-terminal: 0 columns, 0 rows
    try:
        with open(child, "w", closefd=False) as stream:
            assert stream.isatty() and os.get_terminal_size(child).lines == 0
            progress = Progress(2, stream)
            progress.advance(row(completed=True))
            progress.close()
        drawn = read_all(main)
    finally:
        os.close(main)
        os.close(child)
    assert "1/2 episodes" in drawn and "0 failed" in drawn, drawn
