"""How a run is stopped from outside: every stop signal is Ctrl-C, and clean-up is not cut short.

A run can be asked to stop by Ctrl-C (SIGINT), by ``kill`` or a process manager (SIGTERM), or by
its terminal closing (SIGHUP). All three take the same way out: the tree is stopped so that
behaviours cancel what they have in flight, the simulator is stopped, the records are closed
(an MCAP file needs its summary written to be read) and the report says how the run ended.
SIGINT arrives as Python's ``KeyboardInterrupt``; :func:`stop_signals_raise` makes SIGTERM and
SIGHUP raise :class:`Terminated`. Once clean-up has begun, :func:`hold_stop_signals` keeps a
second signal from interrupting it: it is remembered, and the run still exits as it was told.

A SIGKILL cannot be caught; the simulator then goes with the run on its own
(:mod:`bt_servicesim.mission.simulator_process`).
"""

from __future__ import annotations

import signal
from types import FrameType

__all__ = ["STOP_SIGNALS", "Terminated", "exit_code_for", "hold_stop_signals",
           "stop_signals_raise"]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class Terminated(BaseException):
    """SIGTERM or SIGHUP, raised where the run was; a ``BaseException`` like ``KeyboardInterrupt``,
    so that no ``except Exception`` on the way swallows it."""

    def __init__(self, signal_number: int) -> None:
        super().__init__(signal.Signals(signal_number).name)
        self.signal_number = signal_number


def _raise_terminated(signal_number: int, _frame: FrameType | None) -> None:
    raise Terminated(signal_number)


def stop_signals_raise() -> None:
    """SIGTERM and SIGHUP raise :class:`Terminated`; SIGINT raises ``KeyboardInterrupt``."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _raise_terminated)
    signal.signal(signal.SIGHUP, _raise_terminated)


def hold_stop_signals() -> list[int]:
    """From now on a stop signal is only noted in the returned list (clean-up goes on)."""
    received: list[int] = []

    def note(signal_number: int, _frame: FrameType | None) -> None:
        received.append(signal_number)

    for number in STOP_SIGNALS:
        signal.signal(number, note)
    return received


def exit_code_for(stop: BaseException) -> int:
    """128 + the signal's number, as a shell reports a process a signal ended."""
    if isinstance(stop, Terminated):
        return 128 + stop.signal_number
    return 128 + signal.SIGINT
