"""``python -m servicesim_sim --world … --seed … --speed …``: the simulator alone.

Bad arguments and broken world files give one line on stderr and exit status 2; the ROS graph is
only touched once the world has loaded and been set in motion (its task drawn, its people
placed), so a world that loads but cannot be played is one line too.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from typing import NoReturn

EXIT_BAD_INPUT = 2
PROG = "python -m servicesim_sim"


class OneLineArgumentParser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    from servicesim_sim.camera import RATE_HZ

    parser = OneLineArgumentParser(prog=PROG, description="The ServiceSim simulator node.")
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
    parser.add_argument("--await-lockstep", type=float, default=0.0, metavar="SECONDS",
                        help="hold at the first period until a lockstep client joins, for up "
                        "to SECONDS of wall time, so that the task starts at the same sim "
                        "time in every run (default 0: do not wait)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from servicesim_sim.settings import SettingsError, playable_engine, settings_from_arguments

    try:
        settings = settings_from_arguments(args)
        engine = playable_engine(settings)
    except SettingsError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if not os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE"):
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    from servicesim_sim.environment import apply_environment_defaults
    apply_environment_defaults()  # loopback by default; no shared memory left behind
    from servicesim_sim.node import run_simulator

    return run_simulator(settings, engine=engine)


if __name__ == "__main__":
    sys.exit(main())
