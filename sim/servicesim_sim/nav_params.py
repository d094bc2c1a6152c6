"""``python -m servicesim_sim.nav_params [FILE]``: the robot's navigation parameters, checked.

Reads a Nav2 parameters file as the simulator's ``--nav-params`` does and prints what the
robot's navigation makes of it (the inscribed radius, the inflations of walls and of people, the
goal checker's tolerances, when it plans again); without a file, the default, the original
servicebot's. A file the simulator would refuse is one line on stderr and exit status 2. The
run and the evaluation check ``--nav-params`` with it before they start anything, without
importing the simulator.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from servicesim_sim.arguments import EXIT_BAD_INPUT, OneLineArgumentParser
from servicesim_sim.navigation.parameters import (
    SERVICEBOT,
    InflationLayer,
    NavigationParameters,
    NavigationParametersError,
    load_navigation_parameters,
)

PROG = "python -m servicesim_sim.nav_params"


def describe(parameters: NavigationParameters) -> list[str]:
    """The parameters as lines a person reads."""
    costmap, checker = parameters.costmap, parameters.goal_checker

    def inflations(layers: tuple[InflationLayer, ...]) -> str:
        return ", ".join(f"to {layer.inflation_radius:g} m, cost scaling "
                         f"{layer.cost_scaling_factor:g}" for layer in layers) or "none"

    return [f"inscribed radius: {costmap.inscribed_radius:g} m",
            f"walls inflated: {inflations(costmap.walls)}",
            f"people inflated: {inflations(costmap.people)}",
            f"goal tolerance: {checker.xy_goal_tolerance:g} m, "
            f"{checker.yaw_goal_tolerance:g} rad",
            f"navigation tree: {parameters.navigation_tree} ("
            + ("plans again every second" if parameters.replans_every_second
               else "plans again when people stand on the path") + ")"]


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog=PROG, description=(
        "Check a Nav2 parameters file as the simulator's --nav-params reads it, and print what "
        "the robot's navigation makes of it (no file: the servicebot's default)."))
    parser.add_argument("file", nargs="?", help="a Nav2 parameters file (YAML)")
    args = parser.parse_args(argv)
    try:
        parameters = (SERVICEBOT if args.file is None
                      else load_navigation_parameters(args.file))
    except NavigationParametersError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print("\n".join(describe(parameters)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
