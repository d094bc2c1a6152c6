"""``python -m servicesim_sim --world … --seed … --speed …``: the simulator alone.

Bad arguments and broken world files give one line on stderr and exit status 2; the ROS graph is
only touched once the world has loaded and been set in motion (its task drawn, its people
placed), so a world that loads but cannot be played is one line too. The arguments are
:mod:`servicesim_sim.arguments`'s, which the reset service takes as well.

A stop signal (Ctrl-C, SIGTERM, SIGHUP) ends a running simulator with status 0
(:func:`servicesim_sim.ros.node.run_simulator`); one that comes while it is still starting (its
imports, the world, ROS) ends it in one line with 128 + the signal, as an interrupted command.
One the command was started with ignored (``nohup``'s SIGHUP) stays ignored.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Sequence
from types import FrameType

from servicesim_sim.arguments import EXIT_BAD_INPUT, PROG, build_parser
from servicesim_sim.process.stop_signals import handled, note_ignored_at_start


class StoppedWhileStarting(BaseException):
    """A stop signal before the simulator's own handlers were in place."""

    def __init__(self, signal_number: int) -> None:
        super().__init__(signal.Signals(signal_number).name)
        self.signal_number = signal_number


def _stopped_while_starting(signal_number: int, _frame: FrameType | None) -> None:
    raise StoppedWhileStarting(signal_number)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    note_ignored_at_start()
    for number in handled():  # until run_simulator puts its own in place
        signal.signal(number, _stopped_while_starting)
    try:
        return _play(args)
    except StoppedWhileStarting as stop:
        print(f"{PROG}: stopped by {stop} while starting", file=sys.stderr)
        return 128 + stop.signal_number


def _play(args: argparse.Namespace) -> int:
    from servicesim_sim.settings import SettingsError, playable_engine, settings_from_arguments

    try:
        settings = settings_from_arguments(args)
        engine = playable_engine(settings)
    except SettingsError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if not os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE"):
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    from servicesim_sim.process.environment import apply_environment_defaults
    apply_environment_defaults()  # loopback by default; no shared memory left behind
    from servicesim_sim.ros.node import run_simulator

    return run_simulator(settings, engine=engine)


if __name__ == "__main__":
    sys.exit(main())
