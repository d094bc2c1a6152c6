"""The simulator's command-line arguments, for its command and for an episode reset.

One parser serves both ways a simulator is told what to play: ``python -m servicesim_sim``'s
command line, and the reset service (:mod:`servicesim_sim.ros.episodes`), whose request carries the
same arguments, so that a reset episode is played from exactly what a cold start would be. The
command exits with status 2 and one line on a bad argument; a reset is refused with that line
(:class:`RefusingArgumentParser`) and the simulator plays on.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import NoReturn

EXIT_BAD_INPUT = 2
PROG = "python -m servicesim_sim"


class ArgumentRefused(ValueError):  # noqa: N818 -- a refusal, as the reset answers it
    """An argument a reset cannot take; the message is one line naming it."""


class OneLineArgumentParser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def build_parser(parser_class: type[argparse.ArgumentParser] = OneLineArgumentParser
                 ) -> argparse.ArgumentParser:
    from servicesim_sim.model.camera import RATE_HZ

    parser = parser_class(prog=PROG, description="The ServiceSim simulator node.")
    parser.add_argument("--world", help="world file (default: the ServiceSim office)")
    parser.add_argument("--seed", type=int, help="randomise the task (default: the shipped task)")
    parser.add_argument("--speed", type=float, default=1.0,
                        help="1 = real time, larger = faster, 0 = as fast as possible")
    parser.add_argument("--difficulty", choices=("default", "hard"), default="default",
                        help="preset of the difficulty knobs")
    parser.add_argument("--guest-out-of-range", action="store_true",
                        help="place the guest beyond RFID range of the pick-up area centre")
    parser.add_argument("--drift-scale", type=float,
                        help="scale the drift schedule, in world time (<1 = earlier and more "
                             "frequent drifts)")
    parser.add_argument("--nav-abort-probability", type=float,
                        help="probability that a navigation goal aborts")
    parser.add_argument("--rfid-dropout", type=float, help="probability an RFID message is lost")
    parser.add_argument("--service-latency", type=float,
                        help="sim seconds before a referee service answers")
    parser.add_argument("--odom-drift", type=float,
                        help="encoder calibration error of odometry (default 0: exact)")
    parser.add_argument("--localisation-noise", type=float,
                        help="metres (and radians) of noise on the localisation estimate")
    parser.add_argument("--camera-rate", type=float, default=RATE_HZ,
                        help=f"camera frames per sim second while someone subscribes "
                             f"(0 = off; default {RATE_HZ:g}, the original's)")
    parser.add_argument("--guest-path", choices=("trail", "straight"),
                        help="how the guest follows: along the robot's trail (default) or "
                             "straight at the robot through walls (the original)")
    parser.add_argument("--walker-routes", choices=("world", "random"),
                        help="the walkers' loops: the world's (default; the office: the "
                             "original's) or random loops of ours")
    parser.add_argument("--nav-params", metavar="FILE",
                        help="the robot's navigation parameters, a Nav2 parameters file "
                             "(default: the original servicebot's move_base configuration; "
                             "docs/reference/navigation.md)")
    parser.add_argument("--await-lockstep", type=float, default=0.0, metavar="SECONDS",
                        help="hold at the first period until a lockstep client joins, for up "
                        "to SECONDS of wall time, so that the task starts at the same sim "
                        "time in every run (default 0: do not wait)")
    return parser



class RefusingArgumentParser(argparse.ArgumentParser):
    """The parser for a reset's arguments: a problem raises :class:`ArgumentRefused`, never
    exits (the simulator serves on) and never prints."""

    def error(self, message: str) -> NoReturn:
        raise ArgumentRefused(message)

    def exit(self, status: int = 0, message: str | None = None) -> NoReturn:
        raise ArgumentRefused(message or "--help and --version are not arguments of a reset")

    def print_help(self, file: object = None) -> None:
        return None


def parse_reset_arguments(arguments: Sequence[str]) -> argparse.Namespace:
    """A reset's arguments as the command's, or :class:`ArgumentRefused` naming the problem."""
    return build_parser(RefusingArgumentParser).parse_args(list(arguments))
