"""How fast the simulator's planner plans on a world map (the default office unless told).

``python benchmarks/planner.py [--pairs N] [--seed S] [--world FILE]`` prints:

* the one-off set-up: the costmap (distance transform, inflation) and the planner's grid graph;
* the headline plan across the whole building, (10.9, 3.75) to (-20.1, 10.0);
* plan times over N random start/goal pairs of free costmap cells: median, p90, p99, max;
* the same with the costmap changed before every plan (people marked or cleared), so each plan
  also recomputes the edge weights, as in a run where people move.

Times are wall-clock on this machine and vary with its load; nothing here is asserted.
Bad arguments or a broken world file give one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable, Sequence
from functools import partial
from typing import TypeVar

import numpy as np

from bt_servicesim.cli import OneLineArgumentParser

T = TypeVar("T")

HEADLINE = ((10.9, 3.75), (-20.1, 10.0))


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/planner.py",
                                   description="Plan times of the simulator's planner.")
    parser.add_argument("--pairs", type=int, default=300, help="random start/goal pairs")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random pairs")
    parser.add_argument("--world", help="world file (default: the ServiceSim office)")
    return parser


def milliseconds(seconds: list[float]) -> str:
    ms = np.asarray(seconds) * 1e3
    return (f"median {np.median(ms):6.1f} ms  p90 {np.percentile(ms, 90):6.1f} ms  "
            f"p99 {np.percentile(ms, 99):6.1f} ms  max {ms.max():6.1f} ms")


def timed(action: Callable[[], T]) -> tuple[float, T]:
    started = time.perf_counter()
    result = action()
    return time.perf_counter() - started, result


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.pairs < 1:
        build_parser().error(f"--pairs {args.pairs}: must be 1 or more")
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")  # no ROS used; policy
    from servicesim_sim.navigation.costmap import INSCRIBED, Costmap
    from servicesim_sim.navigation.planner import Planner
    from servicesim_sim.world.files import DEFAULT_WORLD, WorldError, load_world

    try:
        world = load_world(args.world or DEFAULT_WORLD)
    except WorldError as error:
        build_parser().error(str(error))
    except OSError as error:
        build_parser().error(f"{args.world}: {error.strerror or error}")
    costmap_s, costmap = timed(lambda: Costmap(world.map))
    planner_s, planner = timed(lambda: Planner(costmap))
    frame = costmap.frame
    print(f"map {world.map.width}x{world.map.height} at {world.map.resolution} m; costmap "
          f"{frame.cols}x{frame.rows} at {frame.resolution:.2f} m, "
          f"{int((costmap.static < INSCRIBED).sum())} traversable cells")
    print(f"set-up: costmap {costmap_s * 1e3:.0f} ms, planner graph {planner_s * 1e3:.0f} ms")

    headline = [timed(lambda: planner.plan(*HEADLINE)) for _ in range(20)]
    plan = headline[0][1]
    outcome = (f"{len(plan.waypoints)} waypoints" if plan.waypoints
               else f"failed {plan.error_code}: {plan.error_msg}")
    print(f"headline {HEADLINE[0]} -> {HEADLINE[1]} ({outcome}): "
          + milliseconds([seconds for seconds, _ in headline]))

    rng = np.random.default_rng(args.seed)
    free_rows, free_cols = np.nonzero(costmap.static < INSCRIBED)
    picks = rng.integers(len(free_rows), size=(args.pairs, 2))
    pairs = [(frame.centre_of(int(free_rows[a]), int(free_cols[a])),
              frame.centre_of(int(free_rows[b]), int(free_cols[b]))) for a, b in picks]
    results = [timed(partial(planner.plan, *pair)) for pair in pairs]
    found = sum(1 for _, result in results if result.waypoints is not None)
    print(f"{args.pairs} random pairs ({found} with a path, the rest cut off): "
          + milliseconds([seconds for seconds, _ in results]))

    people = [frame.centre_of(int(free_rows[i]), int(free_cols[i]))
              for i in rng.integers(len(free_rows), size=40)]
    changed = []
    for index, pair in enumerate(pairs):
        if index % 2:
            costmap.clear()
        else:
            costmap.observe(*pair[0], 0.0, people, now=float(index))
        changed.append(timed(partial(planner.plan, *pair))[0])
    print("after a costmap change each time:  " + milliseconds(changed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
