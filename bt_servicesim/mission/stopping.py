"""How a run is stopped from outside: every stop signal is Ctrl-C, and clean-up is not cut short.

A run can be asked to stop by Ctrl-C (SIGINT), by ``kill`` or a process manager (SIGTERM), or by
its terminal closing (SIGHUP). All three take the same way out: the tree is stopped so that
behaviours cancel what they have in flight, the simulator is stopped, the records are closed
(an MCAP file needs its summary written to be read) and the report says how the run ended.
Inside ``with StopSignals()``, SIGINT arrives as Python's ``KeyboardInterrupt`` and SIGTERM and
SIGHUP raise :class:`Terminated`. While the mission runs, :meth:`StopSignals.defer` keeps a
signal out of the callbacks that rclpy's executor runs: it is noted, and :class:`BetweenSpins`
raises it once the executor's turn is over, where the run handles it (raised inside a callback,
it reached rclpy's C++ executor, which logged it as a fatal error before it came out). A second
signal while the first waits for its turn is raised at once, so that a tick stuck in a
behaviour still gives way to Ctrl-C. Once clean-up has begun, :meth:`StopSignals.hold` keeps a
further signal from interrupting it: it is remembered, and the process still exits as it was
told. Only a user who insists -- :data:`FORCE_AFTER` stop signals during clean-up -- ends the
process at once (a clean-up that hung would otherwise leave only SIGKILL): the second says so,
the third exits with 128 + the first signal, leaving the records as last written (a report
still ``running``, as after SIGKILL) and its children to their parent-death signal. An
evaluation is stopped the same way as a run.

A stop signal the process was started with ignored stays ignored, as Unix programs keep it:
``nohup`` ignores SIGHUP so that a long evaluation outlives the terminal, and a shell ignores
SIGINT in its background jobs. (The run handled it all the same, and ``nohup python -m
bt_servicesim.evaluate`` stopped when its terminal closed.) A child this project starts and
stops itself (a run's simulator, an evaluation's episodes and warm pairs, each in a session of
its own, out of the terminal's reach) gets the stop signals back at their defaults, so that the
SIGINT its parent stops it with is not ignored.

A closed standard output is a stop too: ``run ... | head -3`` stops the run once ``head`` has
its lines, as a Unix tool stops when SIGPIPE kills it. Python ignores SIGPIPE (a write to a
closed pipe raises ``BrokenPipeError`` instead), and it stays ignored: a handler would also fire
when a monitor's client hangs up on one of the run's sockets. Inside ``with StopSignals()``,
``sys.stdout`` is watched instead (:class:`WatchedOutput`): the first write that finds the pipe
closed points the output at ``/dev/null`` and stops the run as SIGPIPE would, the way a stop
signal is taken at that moment (raised, deferred or, during clean-up, noted), so the records
are closed, the report says ``interrupted (SIGPIPE)`` and the exit status is 128 + SIGPIPE.

A SIGKILL cannot be caught. A child started with :func:`parent_death_signal` (a run's
simulator, an evaluation's episodes) gets SIGTERM from the kernel the moment its parent is gone.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType, TracebackType
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    from rclpy.executors import Executor

from bt_servicesim.cli import output_closed

__all__ = ["STOP_SIGNALS", "BetweenSpins", "StopSignals", "Terminated", "WatchedOutput",
           "exit_code_for", "parent_death_signal", "signal_of", "stop_for"]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>
FORCE_AFTER = 3
"""Stop signals during clean-up after which the process ends at once (see the module docstring)."""


class Terminated(BaseException):
    """SIGTERM or SIGHUP, raised where the run was; a ``BaseException`` like ``KeyboardInterrupt``,
    so that no ``except Exception`` on the way swallows it."""

    def __init__(self, signal_number: int) -> None:
        super().__init__(signal.Signals(signal_number).name)
        self.signal_number = signal_number


def _raise_terminated(signal_number: int, _frame: FrameType | None) -> None:
    raise Terminated(signal_number)


def exit_code_for(stop: BaseException) -> int:
    """128 + the signal's number, as a shell reports a process a signal ended."""
    return 128 + signal_of(stop)


def parent_death_signal(parent: int) -> Callable[[], None]:
    """What an episode runs before its program: SIGTERM to it when the evaluation is gone.

    SIGTERM is a stop signal to the run (it stops its simulator and writes its report), so an
    evaluation that is killed outright (SIGKILL, the OOM killer) leaves no episode running on
    and writing into its directory. ``prctl`` is looked up here, in the parent: the child
    only calls it, between fork and exec, where nothing may take a lock. (Linux ties the signal
    to the thread that started the child, not the process: each episode's thread waits for its
    episode to end, so it outlives it.)
    """
    prctl = ctypes.CDLL(None, use_errno=True).prctl

    def in_the_child() -> None:
        for number in STOP_SIGNALS:  # ours to stop: what the user's shell ignored is not
            signal.signal(number, signal.SIG_DFL)
        prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
        if os.getppid() != parent:  # the evaluation died before the request took effect
            os.kill(os.getpid(), signal.SIGTERM)

    return in_the_child


class StopSignals:
    """How an evaluation is stopped from outside: Ctrl-C (SIGINT), SIGTERM and SIGHUP alike.

    Inside ``with StopSignals()``, a stop signal raises in the main thread (``KeyboardInterrupt``
    or :class:`~bt_servicesim.mission.stopping.Terminated`), wherever the evaluation was:
    planning, starting episodes or waiting for them. :meth:`hold` turns that off for the
    clean-up -- stopping the episodes under way, writing the results -- during which a stop
    signal is only noted. The first signal decides the exit status (128 + its number). On the
    way out the handlers are put back as they were. Outside the main thread Python delivers no
    signals, and nothing is changed.
    """

    def __init__(self) -> None:
        self.received: list[int] = []
        self._previous: dict[int, Any] = {}
        self._previous_stdout: TextIO | None = None
        self._deferred = False
        self._held = False
        self._noted_in_clean_up = 0
        self._main = threading.current_thread() is threading.main_thread()
        self._handled: tuple[int, ...] = ()
        """The stop signals handled here: those the process was not started with ignored."""

    def __enter__(self) -> StopSignals:
        if self._main:
            self._previous = {number: signal.getsignal(number) for number in STOP_SIGNALS}
            self._handled = tuple(number for number, handler in self._previous.items()
                                  if handler is not signal.SIG_IGN)
            self._install(lambda number: signal.default_int_handler
                          if number == signal.SIGINT else _raise_terminated)
            self._previous_stdout = sys.stdout
            sys.stdout = WatchedOutput(sys.stdout, on_closed=self.output_closed)  # innermost
        return self

    def _install(self, handler_for: Callable[[int], Any]) -> None:
        for number in self._handled:
            signal.signal(number, handler_for(number))

    def defer(self) -> None:
        """From now on a stop signal is noted, and raised by :meth:`raise_deferred` (a second
        one, while the first still waits, is raised at once, wherever the process is)."""
        self._deferred = True
        self._install(lambda _number: self._defer)

    def raise_deferred(self) -> None:
        """Raise the stop signal that :meth:`defer` noted, if one came; else nothing."""
        if self._deferred and self.received:
            raise stop_for(self.received.pop(0))

    def hold(self, stop: BaseException | None = None) -> None:
        """From now on a stop signal is only noted; ``stop`` is one that was raised."""
        self._deferred = False
        self._held = True
        if stop is not None:
            self.received.insert(0, signal_of(stop))
        self._install(lambda _number: self._note)

    @property
    def first(self) -> int | None:
        """The signal that stopped the evaluation, if one did."""
        return self.received[0] if self.received else None

    def exit_status(self, code: int) -> int:
        """``code``, or 128 + the first stop signal if one came and ``code`` does not say so
        (the signal came only during the clean-up, when it was noted)."""
        return code if self.first is None or code >= 128 else 128 + self.first

    def _note(self, signal_number: int, _frame: FrameType | None) -> None:
        self.received.append(signal_number)
        self._noted_in_clean_up += 1
        name = signal.Signals(signal_number).name
        if self._noted_in_clean_up == FORCE_AFTER - 1:
            print(f"{name} during clean-up: records are being closed; one more stop signal "
                  "ends the process at once", file=sys.stderr, flush=True)
        elif self._noted_in_clean_up >= FORCE_AFTER:
            print(f"stopped at once by {name} during clean-up: records not written yet are "
                  "lost", file=sys.stderr, flush=True)
            os._exit(128 + self.received[0])

    def output_closed(self) -> None:
        """Standard output's reader went away: a stop as SIGPIPE, taken as a stop signal is
        now (raised in the main thread before :meth:`defer`, else noted for its turn)."""
        in_main_thread = threading.current_thread() is threading.main_thread()
        if self._held or self._deferred or not in_main_thread:
            self.received.append(int(signal.SIGPIPE))
            return
        raise Terminated(signal.SIGPIPE)

    def _defer(self, signal_number: int, _frame: FrameType | None) -> None:
        if self.received:  # the first still waits for its turn: the user insists
            raise stop_for(self.received.pop(0))
        self.received.append(signal_number)

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 _traceback: TracebackType | None) -> None:
        if self._main:
            for number, handler in self._previous.items():
                signal.signal(number, handler if handler is not None else signal.SIG_DFL)
            if self._previous_stdout is not None:
                sys.stdout, self._previous_stdout = self._previous_stdout, None


class WatchedOutput:
    """A text stream (``sys.stdout``) that calls ``on_closed`` once when its pipe's reader has
    gone away, and from then on writes to ``/dev/null``; everything else is the stream's own."""

    def __init__(self, stream: TextIO, *, on_closed: Callable[[], None]) -> None:
        while isinstance(stream, WatchedOutput):  # a nested StopSignals: the inner one decides
            stream = stream._stream
        self._stream: TextIO = stream
        self._on_closed = on_closed
        self.closed_by_reader = False

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._reader_gone()
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._reader_gone()

    def _reader_gone(self) -> None:
        if self.closed_by_reader:
            return
        self.closed_by_reader = True
        output_closed()
        self._on_closed()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


class BetweenSpins:
    """An executor whose ``spin_once`` raises a deferred stop signal when its turn is over.

    The run spins its node through one of these while :meth:`StopSignals.defer` is in force, so
    a signal is raised between two turns of the executor and never inside a callback. Every
    other attribute is the executor's own.
    """

    def __init__(self, executor: Executor, stops: StopSignals) -> None:
        self._executor = executor
        self._stops = stops

    def spin_once(self, timeout_sec: float | None = None) -> None:
        self._stops.raise_deferred()
        self._executor.spin_once(timeout_sec=timeout_sec)
        self._stops.raise_deferred()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._executor, name)


def stop_for(signal_number: int) -> BaseException:
    """The exception a stop signal raises inside ``with StopSignals()``: to raise one that was
    only noted, where it can be handled."""
    if signal_number == signal.SIGINT:
        return KeyboardInterrupt()
    return Terminated(signal_number)


def signal_of(stop: BaseException) -> int:
    """The signal a stop exception stands for."""
    return stop.signal_number if isinstance(stop, Terminated) else int(signal.SIGINT)
