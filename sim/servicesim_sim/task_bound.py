"""The kinematic lower bound of a task: how fast a perfect robot could possibly finish it.

Design intent: an evaluation asks how far each mission ran from the physical limit. The limit
is the task sim time no executive can beat: the shortest route that meets the rules, driven at
the robot's top speed (:data:`servicesim_sim.model.robot.MAX_SPEED`), plus the waits the rules
force. It is computed from the same scenario the simulator plays for the same (world, seed,
sim args) (:func:`servicesim_sim.model.playable.playable_engine`), with the simulator's own
constants, so it needs nothing the executive may know and never runs the simulator.

The route, checkpoint by checkpoint (the referee's rules,
:mod:`servicesim_sim.model.task_rules`):

1. from the start pose until the robot's origin is in the pick-up area (checkpoint 1);
2. on until it is within :data:`~servicesim_sim.model.task_rules.PICKUP_RANGE_M` (2 m,
   straight-line distance, walls or not) of the waiting guest (a pick-up is valid only after
   checkpoint 1);
3. on until the robot's origin has been in the drop-off area: the drop-off needs the guest's
   origin inside it, and the guest walks the robot's trail (the default ``trail`` guest), so
   the robot was there first; but a guest picked up walks straight to where the robot stood
   first, and if that walk crosses the area (adjoining areas) the drop-off may come at once.
   The ``straight`` guest walks through walls and is lost 4 m behind
   (:data:`~servicesim_sim.model.guest.LOST_DISTANCE`), so for it the robot need only come within
   4 m of the area;
4. back until its origin is in the start area (checkpoint 4).

Left out, so that the bound stays a bound: the guest's lag (it stops 1.2 m behind, so a robot
usually drives about that far past the area's edge, but that can lie on its way back), turns
(a differential drive may turn while it drives, or reverse), and the service latency of the
``hard`` set (a call is answered while the robot drives on). No rule forces a stop: the guest
walks faster (0.8 m/s) than the robot drives, so it never holds the robot up; the original has
no dwell time. So the waits are zero and the bound is the route's length over the top speed.
The one assumption about the guest: it reaches the drop-off area along the robot's trail; a
guest pushed there by a robot closing in (it steps aside) or cutting across a loop of the trail
could in principle enter the area where the robot never was; no executive does so on purpose.

The route's length is a lower bound on the shortest path by construction
(:mod:`servicesim_sim.navigation.geodesic`): one search per checkpoint, each starting where the
last one reached (its area's nodes, at their distances), on the corner lattice of the cells the
robot's body fits in. Each leg is the bound path's share; they add up to the bound plus the
junctions' slack (a few centimetres).

``python -m servicesim_sim.task_bound --seed 7 --difficulty hard`` prints one bound as JSON; with
``--episodes FILE`` (a JSON list of ``{"world", "seed", "sim_args"}``) a list of them, one per
entry, in order. Bad input is one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
from numpy.typing import NDArray

from servicesim_sim.model.guest import LOST_DISTANCE
from servicesim_sim.model.referee import CHECKPOINT_NAMES
from servicesim_sim.model.robot import BODY_RADIUS, MAX_SPEED, WallClearance
from servicesim_sim.model.scenario import Scenario
from servicesim_sim.model.task_rules import PICKUP_RANGE_M
from servicesim_sim.navigation.geodesic import LatticeGraph, Search
from servicesim_sim.world.files import AreaBox, World, load_world

PROG = "python -m servicesim_sim.task_bound"
EXIT_BAD_INPUT = 2
EXIT_OUTPUT_CLOSED = 141  # 128 + SIGPIPE
JUNCTIONS = 4  # start and return (halves), entering the pick-up area, the pick-up, the drop-off
FORCED_WAITS_S = 0.0  # see the module docstring: no rule makes the robot stop


class TaskBoundError(ValueError):
    """A task without a bound (an area the robot cannot reach); one line."""


@dataclass(frozen=True)
class Leg:
    """One checkpoint's share of the bound path: its length and where it ends."""

    checkpoint: str
    length_m: float
    bound_s: float
    end: tuple[float, float]


@dataclass(frozen=True)
class TaskBound:
    """The kinematic lower bound of one task, and its legs."""

    bound_s: float
    length_m: float
    legs: tuple[Leg, ...]
    speed_m_s: float
    waits_s: float
    slack_m: float
    excess_ratio: float

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "legs": [asdict(leg) for leg in self.legs]}


def free_lattice(world: World) -> LatticeGraph:
    """The search graph of a world: the cells where the robot's body clears every wall."""
    walls = WallClearance(world.map)
    occupancy = world.map
    return LatticeGraph(walls.grid >= BODY_RADIUS, resolution=occupancy.resolution,
                        origin=(occupancy.origin_x, occupancy.origin_y))


def task_bound(world: World, scenario: Scenario, *,
               lattice: LatticeGraph | None = None) -> TaskBound:
    """The bound of ``scenario`` on ``world``; ``lattice``: :func:`free_lattice` of the world,
    when it is reused for many scenarios."""
    lattice = lattice or free_lattice(world)
    task = scenario.task
    regions, robot_in, walked_in = _checkpoint_regions(lattice, world, scenario)
    start = lattice.cell_corners(task.start_x, task.start_y)
    if start.size == 0:
        raise TaskBoundError(f"the start ({task.start_x:g}, {task.start_y:g}) is not where the "
                             "robot fits")
    # each search needs to settle only where the next one starts (walked_in is part of the
    # pick-up's region), the last the start area
    searches = [lattice.search(start, np.zeros(start.size), targets=regions[0])]
    for name, region, targets in zip(CHECKPOINT_NAMES[:2], regions[:2], (regions[1], robot_in),
                                     strict=True):
        searches.append(lattice.search(*_seeds([(searches[-1], region)], name), targets=targets))
    searches.append(lattice.search(*_seeds([(searches[2], robot_in), (searches[1], walked_in)],
                                           CHECKPOINT_NAMES[2]), targets=regions[3]))
    route = _route(searches, regions[3])
    return _bound(lattice, route, _junctions(route, regions))


def _checkpoint_regions(lattice: LatticeGraph, world: World, scenario: Scenario) -> tuple[
        tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
    """Where each checkpoint can be done (one mask per checkpoint, over the nodes, each grown
    by the snap radius); for the drop-off also its two ways apart: the robot in the area, or a
    pick-up from where the guest's straight walk to the robot crosses it."""
    task, areas, grow = scenario.task, world.areas, lattice.snap_radius()
    drop_off_reach = LOST_DISTANCE if scenario.difficulty.guest_path == "straight" else 0.0
    drop_off = areas[task.drop_off]
    pick_up_reach = np.hypot(lattice.x - task.guest_x,
                             lattice.y - task.guest_y) <= PICKUP_RANGE_M + grow
    walked_in = pick_up_reach & _segments_meet_box(
        (task.guest_x, task.guest_y), lattice.x, lattice.y, drop_off, grow + drop_off_reach)
    robot_in = _near_box(lattice, drop_off, grow + drop_off_reach)
    regions = (_near_box(lattice, areas[task.pick_up], grow), pick_up_reach,
               robot_in | walked_in, _near_box(lattice, areas[task.start_area], grow))
    return regions, robot_in, walked_in


def _segments_meet_box(start: tuple[float, float], xs: np.ndarray, ys: np.ndarray,
                       box: AreaBox, grow: float) -> np.ndarray:
    """Whether each straight segment from ``start`` to ``(xs, ys)`` passes through the box
    grown by ``grow`` (clipped as Liang and Barsky do)."""
    low, high = np.zeros(xs.shape), np.ones(xs.shape)
    for origin, ends, lowest, highest in ((start[0], xs, box.min_x - grow, box.max_x + grow),
                                          (start[1], ys, box.min_y - grow, box.max_y + grow)):
        delta = ends - origin
        with np.errstate(divide="ignore", invalid="ignore"):
            first, second = (lowest - origin) / delta, (highest - origin) / delta
        moving = delta != 0.0
        low = np.where(moving, np.maximum(low, np.minimum(first, second)), low)
        high = np.where(moving, np.minimum(high, np.maximum(first, second)), high)
        if not lowest <= origin <= highest:
            high = np.where(moving, high, -1.0)  # parallel to this side's slab, outside it
    return low <= high


def _near_box(lattice: LatticeGraph, box: AreaBox, reach: float) -> np.ndarray:
    """Nodes within ``reach`` (straight-line) of the box."""
    dx = np.maximum(np.maximum(box.min_x - lattice.x, lattice.x - box.max_x), 0.0)
    dy = np.maximum(np.maximum(box.min_y - lattice.y, lattice.y - box.max_y), 0.0)
    near: NDArray[np.bool_] = np.hypot(dx, dy) <= reach
    return near


def _seeds(reached: list[tuple[Search, np.ndarray]],
           checkpoint: str) -> tuple[np.ndarray, np.ndarray]:
    """Where the next search starts: the nodes of each region its search reached, at their
    distances (the least, for a node in more than one)."""
    nodes = np.concatenate([np.flatnonzero(region & np.isfinite(search.distances))
                            for search, region in reached])
    values = np.concatenate([search.distances[region & np.isfinite(search.distances)]
                             for search, region in reached])
    if nodes.size == 0:
        raise TaskBoundError(f"checkpoint {checkpoint!r}: the robot cannot reach where it "
                             "is done")
    order = np.lexsort((values, nodes))
    nodes, values = nodes[order], values[order]
    first = np.concatenate([[True], nodes[1:] != nodes[:-1]])
    return nodes[first], values[first]


def _route(searches: list[Search], start_area: np.ndarray) -> list[int]:
    """The nodes of the bound path, start to end: each search's way, back from its end."""
    final = searches[-1].distances
    reached = np.flatnonzero(start_area & np.isfinite(final))
    if reached.size == 0:
        raise TaskBoundError(f"checkpoint {CHECKPOINT_NAMES[3]!r}: the robot cannot reach "
                             "the start area")
    route = [int(reached[np.argmin(final[reached])])]
    for search in reversed(searches):
        route = search.way_to(route[0])[:-1] + route
    return route


def _junctions(route: list[int], regions: tuple[np.ndarray, ...]) -> list[int]:
    """Where on the route each checkpoint is first done (indices), in order: ties in the
    search leave several ways of equal length, and the referee books the first."""
    junctions, position = [], 0
    for region in regions:
        position = next(index for index in range(position, len(route)) if region[route[index]])
        junctions.append(position)
    return junctions


def _bound(lattice: LatticeGraph, route: list[int], junctions: list[int]) -> TaskBound:
    nodes = np.array(route)
    steps = np.hypot(np.diff(lattice.x[nodes]), np.diff(lattice.y[nodes]))
    along = np.concatenate([[0.0], np.cumsum(steps)]) / lattice.ratio
    reached = [0.0] + [float(along[index]) for index in junctions]
    legs = tuple(
        Leg(checkpoint=name, length_m=round(later - earlier, 3),
            bound_s=round((later - earlier) / MAX_SPEED, 3),
            end=(round(float(lattice.x[route[index]]), 3),
                 round(float(lattice.y[route[index]]), 3)))
        for name, earlier, later, index in zip(CHECKPOINT_NAMES, reached[:-1], reached[1:],
                                               junctions, strict=True))
    slack = lattice.junction_slack(JUNCTIONS)
    length = max(0.0, float(along[-1]) - slack)
    return TaskBound(bound_s=round(length / MAX_SPEED + FORCED_WAITS_S, 3),
                     length_m=round(length, 3), legs=legs, speed_m_s=MAX_SPEED,
                     waits_s=FORCED_WAITS_S, slack_m=round(slack, 3),
                     excess_ratio=round(lattice.ratio, 6))


# ------------------------------------------------------------------------------ the command
class BoundInputError(ValueError):
    """Bad arguments or a bad episodes file; the message is one line."""


def build_parser() -> argparse.ArgumentParser:
    """The simulator's own arguments (a task is what they make it), and ``--episodes``."""
    from servicesim_sim.arguments import build_parser as simulator_parser

    parser = simulator_parser()
    parser.prog = PROG
    parser.description = "The kinematic lower bound of the task a simulator run would play."
    parser.add_argument("--episodes", metavar="FILE",
                        help='a JSON list of {"world": path or null, "seed": int or null, '
                             '"sim_args": [...]}: one bound per entry')
    return parser


class Bounder:
    """Bounds for simulator arguments; worlds and their lattices are loaded once."""

    def __init__(self) -> None:
        self._lattices: dict[Path, LatticeGraph] = {}
        self._worlds: dict[Path, World] = {}  # one command's files do not change under it

    def _load(self, path: str | Path) -> World:
        resolved = Path(path).resolve()
        if resolved not in self._worlds:
            self._worlds[resolved] = load_world(path)
        return self._worlds[resolved]

    def bound(self, args: argparse.Namespace) -> dict[str, Any]:
        from servicesim_sim.model.scenario import ScenarioError
        from servicesim_sim.settings import SettingsError, playable_engine, settings_from_arguments

        try:
            settings = settings_from_arguments(args, load=self._load)
            scenario = playable_engine(settings).scenario  # the task the simulator would play
        except (SettingsError, ScenarioError) as error:
            raise BoundInputError(str(error)) from error
        world = settings.world
        lattice = self._lattices.get(world.path)
        if lattice is None:
            lattice = self._lattices[world.path] = free_lattice(world)
        try:
            bound = task_bound(world, scenario, lattice=lattice)
        except TaskBoundError as error:
            raise BoundInputError(f"{world.path}: {error}") from error
        return {"world": str(world.path), "seed": settings.seed, **bound.as_dict()}


def episode_arguments(entry: Any, number: int) -> list[str]:
    """The simulator arguments of one ``--episodes`` entry."""
    where = f"episode {number}"
    if not isinstance(entry, dict):
        raise BoundInputError(f"{where}: must be an object with world, seed and sim_args")
    unknown = sorted(set(entry) - {"world", "seed", "sim_args"})
    if unknown:
        raise BoundInputError(f"{where}: unknown key {unknown[0]!r}")
    world, seed, sim_args = entry.get("world"), entry.get("seed"), entry.get("sim_args", [])
    if world is not None and not isinstance(world, str):
        raise BoundInputError(f"{where}: world must be a path or null")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise BoundInputError(f"{where}: seed must be an integer or null")
    if not isinstance(sim_args, list) or not all(isinstance(a, str) for a in sim_args):
        raise BoundInputError(f"{where}: sim_args must be a list of strings")
    return ([] if world is None else ["--world", world]) + (
        [] if seed is None else ["--seed", str(seed)]) + sim_args


def read_episodes(path: str) -> list[Any]:
    try:
        entries = json.loads(Path(path).read_text())
    except OSError as error:
        raise BoundInputError(f"--episodes {path}: {error.strerror or error}") from error
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise BoundInputError(f"--episodes {path}: not JSON ({error})") from error
    if not isinstance(entries, list):
        raise BoundInputError(f"--episodes {path}: must hold a JSON list of episodes")
    return entries


def parse_entry(parser: argparse.ArgumentParser, arguments: list[str],
                number: int) -> argparse.Namespace:
    """The entry's arguments parsed as the simulator would, or a one-line error naming it."""
    def refuse(message: str) -> NoReturn:
        raise BoundInputError(f"episode {number}: {message}")

    parser.error = refuse  # type: ignore[method-assign]  # raise, do not exit, inside a batch
    return parser.parse_args(arguments)


def run(argv: Sequence[str] | None) -> Any:
    parser = build_parser()
    args = parser.parse_args(argv)
    bounder = Bounder()
    if args.episodes is None:
        return bounder.bound(args)
    if args.world is not None or args.seed is not None:
        raise BoundInputError("--episodes: give the world and seed in the file, not as "
                              "arguments")
    entries = read_episodes(args.episodes)
    arguments = [episode_arguments(entry, number) for number, entry in enumerate(entries)]
    bounds = []
    for number, entry_arguments in enumerate(arguments):
        try:
            bounds.append(bounder.bound(parse_entry(build_parser(), entry_arguments, number)))
        except BoundInputError as error:
            message = str(error)
            raise BoundInputError(message if message.startswith("episode ")
                                  else f"episode {number}: {message}") from error
    return bounds


def main(argv: Sequence[str] | None = None) -> int:
    try:
        result = run(argv)
    except BoundInputError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        json.dump(result, sys.stdout, indent=1)
        sys.stdout.write("\n")
        sys.stdout.flush()
    except BrokenPipeError:  # the reader went away (| head): quietly, as SIGPIPE ends a tool
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # the flush at exit must not meet the pipe
        os.close(devnull)
        return EXIT_OUTPUT_CLOSED
    return 0


if __name__ == "__main__":
    sys.exit(main())
