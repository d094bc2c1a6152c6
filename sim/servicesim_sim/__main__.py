"""``python -m servicesim_sim --world … --seed … --speed …``: the simulator alone.

Bad arguments and broken world files give one line on stderr and exit status 2; the ROS graph is
only touched once the world has loaded and been set in motion (its task drawn, its people
placed), so a world that loads but cannot be played is one line too. The arguments are
:mod:`servicesim_sim.arguments`'s, which the reset service takes as well.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence

from servicesim_sim.arguments import EXIT_BAD_INPUT, PROG, build_parser


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
