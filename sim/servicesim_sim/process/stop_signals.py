"""The signals that stop the simulator: Ctrl-C's (SIGINT), a process manager's (SIGTERM) and a
closed terminal's (SIGHUP).

Kept apart from :mod:`servicesim_sim.ros.node`, which imports rclpy, so that the command can take
them over first thing (:mod:`servicesim_sim.__main__`) and a stop while it starts is one line.

A stop signal the command was started with ignored stays ignored, as Unix programs keep it:
``nohup python -m servicesim_sim`` outlives its terminal (SIGHUP), and a shell's background job
ignores Ctrl-C. (The simulator a run starts gets every stop signal back at its default from
the run, which stops it with one.)
"""

from __future__ import annotations

import signal

__all__ = ["STOP_SIGNALS", "handled", "note_ignored_at_start"]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

_ignored_at_start: frozenset[int] = frozenset()


def note_ignored_at_start() -> None:
    """Remember the stop signals the process was started with ignored; call it before any
    handler is put in place."""
    global _ignored_at_start
    _ignored_at_start = frozenset(number for number in STOP_SIGNALS
                                  if signal.getsignal(number) is signal.SIG_IGN)


def handled() -> tuple[int, ...]:
    """The stop signals to handle: those the process was not started with ignored."""
    return tuple(number for number in STOP_SIGNALS if number not in _ignored_at_start)
