"""``python -m bt_servicesim.run``: one mission, simulator and executive, start to report.

It starts the simulator in its own process (real DDS between them), runs the mission tree on
sim time, shows progress in the terminal, stops both cleanly on Ctrl-C and writes
``report.json`` with the score, checkpoints and penalties *as the referee counted them*.

Exit status: 0 when the referee counted all four checkpoints, 1 when the mission failed,
2 on bad input (one line on stderr naming the problem), 130 on Ctrl-C.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from bt_servicesim.cli import OneLineArgumentParser, UsageError, error_line
from bt_servicesim.mission.settings import DEFAULT_TIME_LIMIT_S, EXECUTIVES, RunSettings
from bt_servicesim.ros.environment import apply_localhost_defaults
from bt_servicesim.tree.loading import (
    DEFAULT_TREE,
    MissionTreeError,
    load_mission_tree,
    phases_of,
)

if TYPE_CHECKING:
    from rclpy.node import Node

    from bt_servicesim.tree.executive import Executive

PROG = "python -m bt_servicesim.run"
ExecutiveFactory = Callable[["Node"], "Executive"]



def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(
        prog=PROG,
        description="Run the ServiceSim mission: simulator + behaviour-tree executive.",
    )
    parser.add_argument("--world", type=Path, help="world file (default: the ServiceSim office)")
    parser.add_argument("--seed", type=int, help="randomise the task with this seed "
                        "(default: the world's shipped task)")
    parser.add_argument("--speed", type=float, default=10.0,
                        help="sim speed: 1 = real time, 0 = as fast as possible (default 10)")
    parser.add_argument("--tree", type=Path, default=DEFAULT_TREE, help="mission tree XML")
    parser.add_argument("--out", type=Path, help="run directory (default runs/<timestamp>/)")
    parser.add_argument("--time-limit", type=float, default=DEFAULT_TIME_LIMIT_S,
                        help="mission time limit in sim seconds (default 900)")
    parser.add_argument("--headless", action="store_true",
                        help="plain log lines instead of a live view")
    parser.add_argument("--executive", choices=EXECUTIVES, default="bt",
                        help="which executive runs the mission: the behaviour tree (bt) or "
                        "the seed's state machine (baseline)")
    parser.add_argument("--sim-arg", action="append", default=[], metavar="ARG",
                        help="extra argument passed to the simulator (repeatable)")
    return parser


def settings_from(args: argparse.Namespace) -> RunSettings:
    """Check every argument before anything starts."""
    if args.world is not None and not args.world.is_file():
        raise UsageError(f"--world {args.world}: no such file")
    if args.seed is not None and args.seed < 0:
        raise UsageError(f"--seed {args.seed}: must be 0 or more")
    if not args.speed >= 0.0:
        raise UsageError(f"--speed {args.speed}: must be 0 or more")
    if not args.time_limit > 0.0:
        raise UsageError(f"--time-limit {args.time_limit}: must be more than 0")
    out = args.out or Path("runs") / datetime.now().strftime("%Y%m%d-%H%M%S-%f")
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out}: exists and is not a directory")
    return RunSettings(
        world=args.world, seed=args.seed, speed=args.speed, tree=args.tree, out=out,
        time_limit_s=args.time_limit, headless=args.headless, executive=args.executive,
    )


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        settings = settings_from(args)
        make_executive = executive_factory(settings)
        settings.out.mkdir(parents=True, exist_ok=True)
    except (UsageError, MissionTreeError, OSError) as error:
        return error_line(PROG, error)
    apply_localhost_defaults()
    os.environ.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 101))
    from bt_servicesim.mission.run import MissionRun  # rclpy only once the input is good

    return MissionRun(
        settings=settings, make_executive=make_executive, extra_sim_args=tuple(args.sim_arg),
    ).execute()


def executive_factory(settings: RunSettings) -> ExecutiveFactory:
    """Check what the chosen executive needs (the tree file) and say how to make it on a node.

    rclpy is imported only when the factory is called, after every input has been checked.
    """
    if settings.executive == "baseline":
        def make_baseline(node: Node) -> Executive:
            from bt_servicesim.evaluation.baseline import SeedStateMachine

            return SeedStateMachine(node=node, seed=settings.seed,
                                    time_limit_s=settings.time_limit_s)

        return make_baseline
    root = load_mission_tree(settings.tree, time_limit_s=settings.time_limit_s)
    phases = phases_of(settings.tree)

    def make_tree(node: Node) -> Executive:
        from bt_servicesim.tree.executive import MissionExecutive

        return MissionExecutive(node=node, root=root, phases=phases)

    return make_tree


if __name__ == "__main__":
    sys.exit(main())
