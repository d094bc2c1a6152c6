"""Warm pairs: a simulator and an executive process kept alive from one episode to the next.

The evaluation's side of :mod:`bt_servicesim.warm_worker` (docs/reference/evaluation.md, "Warm
episodes"). A :class:`WarmPair` starts the worker (which starts its simulator) the first time
it is asked to play, sends it one episode at a time on its stdin and reads the worker's one
reply line per episode from a pipe of its own, within the episode's wall-time limit.

A pair is trusted only while it behaves. One whose worker died, that outlives the episode's
limit, whose reply is not the episode's (garbage, another run id) or that was stopped with the
evaluation is stopped with its whole process tree and never used again: the evaluation starts
a new pair for its next episode, and the episode gets the reason as its failure. Each pair
keeps its own and its simulator's output in a directory of its own (``worker.log``,
``sim.log``); each episode's output goes to its ``run.log``, as a cold run's does.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from bt_servicesim.evaluation.process_tree import stop_process_tree
from bt_servicesim.evaluation.settings import INTERRUPTED
from bt_servicesim.ros.environment import apply_localhost_defaults

__all__ = ["PairOutcome", "WarmPair"]

WORKER_MODULE = "bt_servicesim.warm_worker"
CLOSE_WAIT_S = 15.0
"""Wall seconds a pair gets to stop its simulator and exit once it has no more episodes."""
EPISODES_PER_PAIR = 100
"""Episodes a pair plays before it is let go for a new one: a bound on what a long-lived process
may pile up. Measured over 24 short episodes on one pair, the simulator's RSS grew from 197 MB
to about 430 MB in the first 13 and then stayed there (the executive's about 250 to 400 MB),
and no episode's engine, node or run stayed alive in Python; a new pair costs one start-up
(about 10 s) per hundred episodes."""
LOOK_S = 0.25
"""Wall seconds between looks at the evaluation's stop request while waiting for a reply."""


@dataclass
class PairOutcome:
    """What became of one episode played on a pair."""

    returncode: int | None
    """The run's exit status as the worker replied it; else the worker's, if it ended."""
    failure: str | None = None
    """Why the pair could not play the episode to its end (then it is replaced)."""


class WarmPair:
    """One worker process and its simulator; see the module docstring."""

    def __init__(self, *, log_dir: Path, die_with_us: Callable[[], None]) -> None:
        self.log_dir = log_dir
        self._die_with_us = die_with_us
        self.process: subprocess.Popen[bytes] | None = None
        self.broken = False
        """Stopped or found misbehaving: never to be used again."""
        self.played = 0
        """Episodes it was given."""
        self._replies: int | None = None
        self._buffer = b""
        self._limit_text = ""

    # ---------------------------------------------------------------- life
    def _start(self) -> None:
        self.log_dir.mkdir(parents=True, exist_ok=True)
        environment = dict(os.environ)
        apply_localhost_defaults(environment)
        reading, writing = os.pipe()
        try:
            with (self.log_dir / "worker.log").open("ab") as log:
                self.process = subprocess.Popen(
                    [sys.executable, "-m", WORKER_MODULE, "--log-dir", str(self.log_dir),
                     "--reply-fd", str(writing)],
                    stdin=subprocess.PIPE, stdout=log, stderr=subprocess.STDOUT,
                    env=environment, pass_fds=(writing,), start_new_session=True,
                    preexec_fn=self._die_with_us)
        except BaseException:
            os.close(reading)
            raise
        finally:
            os.close(writing)
        self._replies = reading

    def close(self) -> None:
        """No more episodes: the worker stops its simulator and exits (stopped if it does not)."""
        if self.process is None:
            self._close_pipe()
            return
        if self.process.poll() is None:
            with contextlib.suppress(OSError):
                self._stdin().close()
            try:
                self.process.wait(timeout=CLOSE_WAIT_S)
            except subprocess.TimeoutExpired:
                stop_process_tree(self.process)
        self._close_pipe()

    def kill(self) -> None:
        """Stop the worker and its simulator for good (SIGINT, then SIGKILL)."""
        self.broken = True
        if self.process is not None:
            stop_process_tree(self.process)
        self._close_pipe()

    def _close_pipe(self) -> None:
        if self._replies is not None:
            os.close(self._replies)
            self._replies = None

    # ---------------------------------------------------------------- play
    @property
    def worn_out(self) -> bool:
        """It has played :data:`EPISODES_PER_PAIR` episodes: time for a new pair."""
        return self.played >= EPISODES_PER_PAIR

    @property
    def alive(self) -> bool:
        """Not known to be broken, and its worker (if started) still running."""
        return not self.broken and (self.process is None or self.process.poll() is None)

    def play(self, line: str, *, run_id: str, timeout_s: float,
             stopping: Callable[[], bool]) -> PairOutcome:
        """Play the episode that ``line`` describes (a ``WarmEpisode`` line of the worker)
        within ``timeout_s`` wall seconds, the pair's start-up included; its outcome. A pair
        that could not is stopped."""
        deadline = time.monotonic() + timeout_s
        self.played += 1
        self._limit_text = (f"episode wall-time limit of {timeout_s:g} s exceeded; stopped")
        if self.process is None:
            self._start()
            ready = self._reply(deadline, stopping)
            if not isinstance(ready, dict) or ready.get("ready") is not True:
                return self._give_up(ready, "starting")
        try:
            self._stdin().write(line.encode())
            self._stdin().flush()
        except OSError as error:
            return self._give_up(_Ended(f"the warm pair's worker did not take the episode: "
                                        f"{error}"), "taking the episode")
        reply = self._reply(deadline, stopping)
        if isinstance(reply, dict) and reply.get("run_id") == run_id \
                and isinstance(reply.get("exit_code"), int):
            code = int(reply["exit_code"])
            if reply.get("goes_on") is not True:  # stopped, or its simulator died
                self.kill()
            return PairOutcome(returncode=code)
        return self._give_up(reply, "playing the episode")

    def _stdin(self) -> IO[bytes]:
        assert self.process is not None and self.process.stdin is not None
        return self.process.stdin

    def _give_up(self, reply: Any, doing: str) -> PairOutcome:
        """Stop the pair, and say why the episode did not end as an episode should."""
        if isinstance(reply, _Ended):
            failure = reply.text
        else:
            text = reply if isinstance(reply, str) else json.dumps(reply)
            failure = f"the warm pair's worker answered garbage while {doing}: {text[:160]}"
        if not (isinstance(reply, _Ended) and reply.text == INTERRUPTED):
            failure += "; the pair was replaced"
        self.kill()
        return PairOutcome(returncode=None if self.process is None else self.process.returncode,
                           failure=failure)

    def _reply(self, deadline: float, stopping: Callable[[], bool]) -> Any:
        """The worker's next reply line, parsed; a :class:`_Ended` if none came, or the line
        as text if it is not JSON."""
        while b"\n" not in self._buffer:
            if stopping():
                return _Ended(INTERRUPTED)
            if time.monotonic() > deadline:
                return _Ended(self._limit_text)
            assert self._replies is not None
            ready, _, _ = select.select([self._replies], [], [], LOOK_S)
            if not ready:
                continue
            chunk = os.read(self._replies, 65536)
            if not chunk:  # the worker is gone: its end of the pipe closed
                return _Ended(self._death())
            self._buffer += chunk
        line, _, self._buffer = self._buffer.partition(b"\n")
        try:
            return json.loads(line)
        except ValueError:
            return line.decode(errors="replace").strip()

    def _death(self) -> str:
        assert self.process is not None
        try:
            code = self.process.wait(timeout=CLOSE_WAIT_S)
        except subprocess.TimeoutExpired:
            return "the warm pair's worker closed its reply pipe and hangs"
        if code < 0:
            with contextlib.suppress(ValueError):
                return f"the warm pair's worker was killed by {signal.Signals(-code).name}"
        return f"the warm pair's worker exited with code {code}"


@dataclass(frozen=True)
class _Ended:
    """No reply: why."""

    text: str
