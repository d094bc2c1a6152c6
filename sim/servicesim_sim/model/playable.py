"""Whether a task can be played: the robot's navigation must find a way from its start to the
pick-up area, on to the drop-off area and back to the start area, with every idler in place.

The original's idlers stand in curated idling areas, clear of every target; a world of our own
(idlers placed anywhere, a random task) may put one in the only doorway of a room, and a task
behind it cannot be played: the robot fails checkpoint 1 for the whole run. So a task the
simulator draws is checked once the people are placed, and drawn again from the seed when it
cannot be played (deterministically: the n-th draw of a seed is always the same); a world's
fixed task that the walls alone make unplayable is refused, in one line. A draw whose walkers
find no free waypoint to start at (a short loop whose other waypoints the drawn guest and
robot start crowd, :class:`~servicesim_sim.model.people.WalkerStartError`) is drawn again
alike: the original's world generator failed there and was run again.

The check is made on a costmap of its own (:data:`PASSAGE`): the static layer with each idler
marked as the lidar would mark them, cells below inscribed cost passable, and the areas reached
when the passable cells connected to the robot's start meet their boxes. It keeps the robot's
half-width, 0.25 m, off walls and idlers' marks whatever navigation parameters the robot was
given (``--nav-params``): which task a seed plays is the simulator's, never the robot's. The
guest's own spot must be reached too (a guest drawn out of range waits outside the pick-up area).

Walkers move on and the guest follows, so neither counts as such; but on the world's routes a
walker waits as long as someone stands in its lane, and an idler or the guest waiting to be
picked up never moves on: each walker that would stop for good so (and those that would queue
behind it) is marked where it would stand, as an idler is
(:meth:`~servicesim_sim.model.people.Crowd.held_for_good`, the people model's own lane rule).
"""

from __future__ import annotations

import weakref

import numpy as np
from scipy import ndimage

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.people import IDLER, WalkerStartError
from servicesim_sim.model.scenario import Difficulty, ScenarioError, make_scenario
from servicesim_sim.navigation.costmap import INSCRIBED, Costmap
from servicesim_sim.navigation.parameters import (
    SERVICEBOT,
    CostmapParameters,
    InflationLayer,
    NavigationParameters,
)
from servicesim_sim.world.files import AreaBox, OccupancyMap, World

GUEST = "the guest"  # unreachable_areas' name for the guest's spot
MAX_DRAWS = 20  # draws of a seed's task (or of a fixed task's people) before giving up
START_ESCAPE_M = 0.5  # a start (or the guest's spot) in lethal cost may reach passable floor
# this far off
PASSAGE = CostmapParameters(inscribed_radius=0.25, walls=(InflationLayer(),),
                            people=(InflationLayer(),))
"""The playability check's costmap: passable where the servicebot's half-width (its footprint
is 0.5 m wide) clears walls and idlers; only the inscribed radius counts."""

_PASSAGE_COSTMAPS: weakref.WeakKeyDictionary[OccupancyMap, Costmap] = (
    weakref.WeakKeyDictionary())


def passage_costmap(occupancy_map: OccupancyMap) -> Costmap:
    """The map's :data:`PASSAGE` costmap, built once per loaded map (its marks never change:
    the check asks :meth:`Costmap.costs_with`)."""
    costmap = _PASSAGE_COSTMAPS.get(occupancy_map)
    if costmap is None:
        costmap = _PASSAGE_COSTMAPS[occupancy_map] = Costmap(occupancy_map, layers=PASSAGE)
    return costmap


def unreachable_areas(engine: SimEngine, *, with_idlers: bool = True) -> list[str]:
    """The task's areas (pick-up, drop-off, start; in that order, then :data:`GUEST` for the
    guest's spot, where the robot goes to fetch them wherever they wait) the robot's
    navigation cannot reach from its start, with the people who stand for good
    (:func:`standing_for_good`) in place unless ``with_idlers`` is False."""
    costmap = passage_costmap(engine.world.map)
    costs = costmap.costs_with(standing_for_good(engine) if with_idlers else [])
    labels, _ = ndimage.label(costs < INSCRIBED, structure=np.ones((3, 3), dtype=bool))
    task = engine.scenario.task
    region = _region_at(costmap, labels, task.start_x, task.start_y)
    names = (task.pick_up, task.drop_off, task.start_area)
    cut_off = [name for name in names
               if region == 0 or not _meets(costmap, labels, region, engine.world.areas[name])]
    if region == 0 or not _near(costmap, labels, region, task.guest_x, task.guest_y):
        cut_off.append(GUEST)
    return cut_off


def standing_for_good(engine: SimEngine) -> list[tuple[float, float]]:
    """Where people will stand for good before the guest is picked up: every idler, and each
    walker an idler or the waiting guest holds in its lane (with those queued behind it,
    :meth:`~servicesim_sim.model.people.Crowd.held_for_good`)."""
    idlers = [(x, y) for _, role, x, y in engine.crowd.states() if role == IDLER]
    guest = engine.scenario.task
    return idlers + engine.crowd.held_for_good(others=[(guest.guest_x, guest.guest_y)])


def _region_at(costmap: Costmap, labels: np.ndarray, x: float, y: float) -> int:
    """The passable region the robot at (x, y) is in, or may escape to; 0 for none."""
    frame = costmap.frame
    row, col = frame.cell_of(x, y)
    reach = int(np.ceil(START_ESCAPE_M / frame.resolution))
    row0, col0 = max(row - reach, 0), max(col - reach, 0)
    window = labels[row0:row + reach + 1, col0:col + reach + 1]
    found = np.argwhere(window > 0)
    if found.size == 0:
        return 0
    nearest = found[np.argmin(np.hypot(found[:, 0] + row0 - row, found[:, 1] + col0 - col))]
    return int(window[nearest[0], nearest[1]])


def _meets(costmap: Costmap, labels: np.ndarray, region: int, box: AreaBox) -> bool:
    frame = costmap.frame
    row0, col0 = frame.cell_of(box.min_x, box.min_y)
    row1, col1 = frame.cell_of(box.max_x, box.max_y)
    row0, col0 = max(row0, 0), max(col0, 0)
    return bool(np.any(labels[row0:row1 + 1, col0:col1 + 1] == region))


def _near(costmap: Costmap, labels: np.ndarray, region: int, x: float, y: float) -> bool:
    """Whether the region has a cell within :data:`START_ESCAPE_M` of (x, y)."""
    frame = costmap.frame
    row0, col0 = frame.cell_of(x - START_ESCAPE_M, y - START_ESCAPE_M)
    row1, col1 = frame.cell_of(x + START_ESCAPE_M, y + START_ESCAPE_M)
    row0, col0 = max(row0, 0), max(col0, 0)
    rows, cols = np.nonzero(labels[row0:row1 + 1, col0:col1 + 1] == region)
    return bool(np.any(np.hypot((cols + col0 + 0.5) * frame.resolution + frame.origin_x - x,
                                (rows + row0 + 0.5) * frame.resolution + frame.origin_y - y)
                       <= START_ESCAPE_M))


def playable_engine(world: World, *, seed: int | None, difficulty: Difficulty | None = None,
                    navigation: NavigationParameters = SERVICEBOT) -> SimEngine:
    """The engine of the seed's first playable draw (without a seed: the world's fixed task,
    its people drawn again while idlers cut it off), its robot navigating with
    ``navigation``, or :class:`ScenarioError` saying why there is none."""
    crowded: WalkerStartError | None = None
    for draw in range(MAX_DRAWS):
        scenario = make_scenario(world, seed=seed, difficulty=difficulty, draw=draw)
        try:
            engine = SimEngine(world=world, scenario=scenario, navigation=navigation)
        except WalkerStartError as error:
            crowded = error
            continue
        if not unreachable_areas(engine):
            return engine
        walled_off = unreachable_areas(engine, with_idlers=False)
        if walled_off and scenario.seed is None:
            raise ScenarioError(f"{world.path}: the task cannot be played: navigation finds no "
                                f"way from the robot's start to {', '.join(walled_off)}")
    what = f"seed {seed}" if seed is not None else "the fixed task"
    if crowded is not None:
        raise ScenarioError(f"{world.path}: {what}: no playable task in {MAX_DRAWS} draws "
                            f"(the last: {crowded})")
    raise ScenarioError(f"{world.path}: {what}: no playable task in {MAX_DRAWS} draws (people "
                        f"standing for good or walls cut the robot off from an area or the "
                        f"guest in every one)")
