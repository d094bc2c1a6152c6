"""Where the guest stands, from RFID name lists and odometry alone, and how to close in on them.

RFID says only *who* is within 2.0 m of the robot, ten times a sim second, and says nothing at all
while nobody is near. Exploration stops the moment the guest's name first appears, i.e. with the
guest at the very edge of range — exactly the distance at which the referee's pick-up starts to
refuse. So the mission closes in before asking for the guest:

- :class:`RecordRfidReadings` runs every tick beside the topic readers and keeps a bounded
  :class:`RfidHistory`: each new RFID message with the robot's position then, and, after a
  silence long enough not to be a lost message, an empty reading (nobody in range) now and then.
- :func:`estimate_guest` is range-only localisation on that history: the guest stands on a free
  cell within 2.0 m of where the robot heard them and beyond 2.0 m of where it recently did not.
  Each cell of the map near the sightings counts the robot positions it contradicts; the cells
  that contradict fewest are the guest's possible spots and their centroid is the estimate. So
  a silence misread as absence, or a guest who moved, leaves the best cells, not an empty set.
- :func:`approach_goal` picks a reachable spot, about 1.4 m from the estimate (the referee
  books "approximation" every physics step while a person is within 0.75 m of the robot's
  body, i.e. 1.0 m of its centre), from which most of the possible spots lie within pick-up
  reach. An estimate from an edge sighting is a crescent; the robot closes in, hears more and
  estimates again. Given where the guest is to be led (``leave_towards``), it stands on the
  guest's side towards there: a robot that must drive past the guest it just picked up
  crowds them, and a guest following the robot's trail first walks back to where the robot
  stood. It keeps off walls where it can (the referee books objects within 0.35 m too).
- Others stand near the guest too (the competition's idlers have areas by the pick-ups): RFID
  names them beside the guest. The guest is always picked out by name, and
  :func:`locate_bystanders` locates everyone else heard lately the same way, so that
  :func:`approach_goal` keeps the robot more than 1.0 m (centre to centre: the referee books
  "approximation" within 0.75 m of the robot's body) from where they may stand.
- :class:`GuestSteadilyInRange` holds the pick-up back until every reading over the last half
  sim second, taken while the robot stands, names the guest.

Only the latest run of sightings locates the guest (a guest who followed the robot and then
drifted has moved since the older ones; :class:`GuestApproachGoal`'s ``sighting_gap`` says how
long a pause ends a run); readings where they were not heard count from the last
:data:`MEMORY` sim seconds.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from bt_servicesim.planning.geometry import Point, Pose2D
from bt_servicesim.planning.goals import PERSON_CLEARANCE, ROBOT_CLEARANCE
from bt_servicesim.planning.occupancy import OccupancyGrid2D, Window
from bt_servicesim.planning.rules import PICKUP_REACH, RFID_PERIOD, RFID_RANGE

__all__ = [
    "GuestEstimate",
    "RfidHistory",
    "RfidReading",
    "approach_goal",
    "estimate_guest",
    "locate_bystanders",
]


HISTORY_LENGTH = 1200
"""Readings kept: two sim minutes at the sensor's 10 Hz."""
SILENCE = 0.35
"""Sim seconds without an RFID message after which nobody is taken to be in range (the sensor
is silent then; three lost messages in a row are rarer than one in a hundred)."""
READING_PERIOD = RFID_PERIOD
"""The sensor's period: silence is recorded as an empty reading at most this often."""
MEMORY = 60.0
"""Sim seconds of readings without the guest that still constrain where they are."""
SIGHTING_GAP = 5.0
"""A pause longer than this between sightings starts a new run of sightings (by default: a
guest who may have moved; a guest waiting to be picked up stands still, and the mission may
then allow any pause within :data:`MEMORY`)."""
RANGE_TOLERANCE = 0.1
"""Metres of slack at the RFID range's edge (odometry and a tick's travel)."""
ESTIMATE_SPACING = 0.1
"""Metres between the cells the estimate weighs."""
POSITION_ROUNDING = 0.1
"""Readings whose robot positions agree to this are one piece of evidence."""
APPROACH_DISTANCE = 1.4
"""Metres from the estimate an approach goal prefers: between :data:`TOO_CLOSE` and reach."""
APPROACH_RADIUS = 1.8
"""How far from the estimate an approach goal may lie."""
TOO_CLOSE = 1.1
"""A possible spot this close to a goal puts the robot in the guest's personal space (the
referee's 0.75 m from the body's edge is 1.0 m from the robot's centre)."""
CLOSE_ENOUGH = 1.5
"""A robot this near the estimate need not move if no spot is clearly better ..."""
STAY_SLACK = 0.1
"""... clearly better meaning this much more of the possible spots in reach."""
WALL_BERTH = 0.6
"""Clearance (m from the robot's centre) below which the referee books "approximation" to an
object: 0.35 m from the body's edge."""
WALL_WEIGHT = 0.15
"""Score lost by a goal right at :data:`ROBOT_CLEARANCE` from a wall."""
DEPARTURE_WEIGHT = 0.3
"""Score gained by a goal a clear :data:`DEPARTURE_SCALE` ahead of the guest on the way out
(and lost by one as far behind them)."""
PASSING_BERTHS = ((1.0, 0.2), (0.75, 0.4))
"""(berth, penalty): an approach spot the robot cannot reach keeping ``berth`` metres (centre
to centre) from every spot where the guest may stand scores ``penalty`` less, the penalties
adding up. Within 1.0 m the referee books approximation (0.75 m from the body's edge); within
0.75 m of a person's centre a squeeze past them risks contact (0.5 m)."""
PASSING_WINDOW = 1.5
"""Metres beyond :data:`APPROACH_RADIUS` around the estimate within which the berths are kept
(the possible spots lie well inside)."""
DEPARTURE_SCALE = 1.0
"""Metres of route, ahead of or behind the guest, over which the departure term saturates."""
BYSTANDER_RECENT = 1.0
"""Sim seconds: everyone but the guest that RFID named this recently is a bystander."""
MOST_BYSTANDERS = 6
"""Bystanders located at most (the nearest few matter; each costs an estimate)."""
BYSTANDER_BERTH = 1.0
"""Metres, centre to centre, within which the referee books approximation to a person."""
BYSTANDER_WEIGHT = 0.5
"""Score lost by a goal within :data:`BYSTANDER_BERTH` of every spot a bystander may stand on
(half the pick-up reach's worth: reach still comes first)."""
STEADY_FOR = 0.5
"""Sim seconds of readings that must all name the guest before a pick-up."""
STEADY_READINGS = 3
"""At least this many readings in that time (lost messages thin them out)."""
STEADY_PATIENCE = 2.5
"""Sim seconds :class:`GuestSteadilyInRange` waits for a steady reading before failing."""


# ============================================================================ the history
@dataclass(frozen=True)
class RfidReading:
    """Who the RFID sensor had in range at sim time ``stamp``, with the robot at (x, y)."""

    stamp: float
    x: float
    y: float
    names: frozenset[str]


class RfidHistory:
    """The latest RFID readings, oldest first, at most ``length`` of them."""

    def __init__(self, length: int = HISTORY_LENGTH) -> None:
        self._readings: deque[RfidReading] = deque(maxlen=length)

    def __repr__(self) -> str:
        if not self._readings:
            return "RfidHistory(empty)"
        return f"RfidHistory({len(self._readings)} readings, last at {self.latest.stamp:.1f} s)"

    def __len__(self) -> int:
        return len(self._readings)

    def __iter__(self) -> Iterator[RfidReading]:
        return iter(self._readings)

    @property
    def latest(self) -> RfidReading:
        return self._readings[-1]

    def add(self, reading: RfidReading) -> None:
        self._readings.append(reading)

    def since(self, stamp: float) -> list[RfidReading]:
        """The readings taken at or after ``stamp``, oldest first."""
        recent: list[RfidReading] = []
        for reading in reversed(self._readings):
            if reading.stamp < stamp:
                break
            recent.append(reading)
        return recent[::-1]


# ============================================================================ the estimate
@dataclass(frozen=True)
class GuestEstimate:
    """Where the guest may stand: the possible spots and their centroid."""

    x: float
    y: float
    spots: np.ndarray
    """(n, 2) centres of the cells contradicting fewest robot positions."""
    sightings: int
    """Distinct robot positions the guest was heard from."""


def estimate_guest(
    history: Iterable[RfidReading], guest: str, grid: OccupancyGrid2D, now: float,
    sighting_gap: float = SIGHTING_GAP,
) -> GuestEstimate | None:
    """Range-only estimate of the guest's position; None if they have not been heard lately.

    The guest's latest run of sightings (no pause over ``sighting_gap``) gives the
    positions they were within RFID range of; every reading of the last :data:`MEMORY` sim
    seconds without them, a position they were beyond it. Cells where a person may stand
    (:data:`PERSON_CLEARANCE` from walls) near the sightings are scored by how
    many distinct positions they contradict; those contradicting fewest are the possible
    spots (none, when the readings agree).
    """
    readings = [reading for reading in history if reading.stamp >= now - MEMORY]
    heard = _latest_sightings(readings, guest, sighting_gap)
    if heard.size == 0:
        return None
    unheard = _distinct([(r.x, r.y) for r in readings if guest not in r.names])
    cells = _candidate_cells(grid, heard)
    if cells.size == 0:
        return None
    contradictions = (_count_beyond(cells, heard, RFID_RANGE + RANGE_TOLERANCE)
                      + _count_within(cells, unheard, RFID_RANGE - RANGE_TOLERANCE))
    spots = cells[contradictions == contradictions.min()]
    centre = spots.mean(axis=0)
    return GuestEstimate(float(centre[0]), float(centre[1]), spots, len(heard))


def _latest_sightings(readings: list[RfidReading], guest: str, gap: float) -> np.ndarray:
    """Distinct robot positions of the guest's latest run of sightings, (k, 2)."""
    stamps = [r.stamp for r in readings if guest in r.names]
    if not stamps:
        return np.zeros((0, 2))
    start = stamps[0]
    for before, after in itertools.pairwise(stamps):
        if after - before > gap:
            start = after
    return _distinct([(r.x, r.y) for r in readings if guest in r.names and r.stamp >= start])


def _distinct(points: list[Point]) -> np.ndarray:
    """The points rounded to :data:`POSITION_ROUNDING`, without repeats, (k, 2)."""
    if not points:
        return np.zeros((0, 2))
    rounded = np.round(np.asarray(points, dtype=float) / POSITION_ROUNDING) * POSITION_ROUNDING
    return np.unique(rounded, axis=0)


def _candidate_cells(grid: OccupancyGrid2D, heard: np.ndarray) -> np.ndarray:
    """Centres (n, 2) of cells a person may stand on within range of some sighting."""
    reach = RFID_RANGE + RANGE_TOLERANCE
    (min_x, min_y), (max_x, max_y) = heard.min(axis=0) - reach, heard.max(axis=0) + reach
    window = grid.window(min_x, min_y, max_x, max_y)
    if window.is_empty:
        return np.zeros((0, 2))
    stride = max(1, round(ESTIMATE_SPACING / grid.resolution))
    xs, ys = np.meshgrid(window.xs[::stride], window.ys[::stride])
    room = grid.clearances[window.rows, window.cols][::stride, ::stride]
    cells = np.column_stack([xs[room >= PERSON_CLEARANCE], ys[room >= PERSON_CLEARANCE]])
    near = _count_within(cells, heard, reach) > 0
    return cells[near]


def _distances(cells: np.ndarray, points: np.ndarray) -> np.ndarray:
    distances: NDArray[np.float64] = np.hypot(cells[:, None, 0] - points[None, :, 0],
                                              cells[:, None, 1] - points[None, :, 1])
    return distances


def _count_within(cells: np.ndarray, points: np.ndarray, radius: float) -> np.ndarray:
    """For each cell, how many points lie within ``radius``."""
    if points.size == 0:
        return np.zeros(len(cells), dtype=int)
    counts: NDArray[np.intp] = (_distances(cells, points) <= radius).sum(axis=1)
    return counts


def _count_beyond(cells: np.ndarray, points: np.ndarray, radius: float) -> np.ndarray:
    """For each cell, how many points lie farther than ``radius``."""
    if points.size == 0:
        return np.zeros(len(cells), dtype=int)
    counts: NDArray[np.intp] = (_distances(cells, points) > radius).sum(axis=1)
    return counts


def locate_bystanders(history: RfidHistory, guest: str, grid: OccupancyGrid2D,
                      now: float) -> list[GuestEstimate]:
    """Where the others RFID named in the last :data:`BYSTANDER_RECENT` sim seconds may stand,
    each estimated as the guest is (at most :data:`MOST_BYSTANDERS`, the most often heard)."""
    heard = [name for reading in history.since(now - BYSTANDER_RECENT)
             for name in reading.names if name != guest]
    names = sorted(set(heard), key=lambda name: (-heard.count(name), name))
    located = (estimate_guest(history, name, grid, now) for name in names[:MOST_BYSTANDERS])
    return [estimate for estimate in located if estimate is not None]


# ============================================================================ the approach
def approach_goal(
    estimate: GuestEstimate, grid: OccupancyGrid2D, robot: Pose2D,
    leave_towards: Point | None = None, bystanders: Sequence[GuestEstimate] = (),
) -> Pose2D | None:
    """A reachable spot near the estimate, facing it, from which the guest is within reach.

    Every reachable cell within :data:`APPROACH_RADIUS` of the estimate is scored by the share
    of the possible spots within :data:`PICKUP_REACH` of it, less the share within
    :data:`TOO_CLOSE`, less a little for straying from :data:`APPROACH_DISTANCE` from the
    estimate and for the distance from the robot, less a little for a wall within
    :data:`WALL_BERTH`. With ``leave_towards``, cells ahead of the guest on the route there
    score up to :data:`DEPARTURE_WEIGHT` more and cells behind them as much less. For a compact
    estimate the best cell lies about 1.4 m from it, on the robot's side when nothing says
    otherwise. A cell the robot could only reach by passing close to where the guest may stand
    scores less (:data:`PASSING_BERTHS`; a waiting guest does not step aside, so in a narrow
    corridor the way past them is a squeeze, or contact): when the guest stands between the
    robot and the way out, the robot goes round to their far side if it can, passes them now
    if it can do so safely (they stand still; a guest following the robot is harder to pass),
    and otherwise stays on its side. A cell within :data:`BYSTANDER_BERTH` of where
    ``bystanders`` may stand scores up to :data:`BYSTANDER_WEIGHT` less each. For an
    estimate split in two (a robot that drove a straight line cannot tell
    its left from its right) it may lie between the two halves.
    None if the robot already stands :data:`CLOSE_ENOUGH` and no cell scores clearly better
    (:data:`STAY_SLACK`), or nothing near is reachable.
    """
    cells = _reachable_near(estimate, grid, grid.reachable_from(robot.x, robot.y,
                                                                ROBOT_CLEARANCE))
    if cells.size == 0:
        return None
    here_and_cells = np.vstack([[robot.x, robot.y], cells])
    scores = _score(estimate, here_and_cells, robot) + _wall_berth(grid, here_and_cells)
    if leave_towards is not None:
        scores += _departure(estimate, grid, here_and_cells, leave_towards)
    for berth, penalty in PASSING_BERTHS:
        scores[~_reachable_keeping(berth, estimate, grid, robot, here_and_cells)] -= penalty
    for other in bystanders:
        near_other = _distances(here_and_cells, other.spots) < BYSTANDER_BERTH
        scores -= BYSTANDER_WEIGHT * near_other.mean(axis=1)
    here, scores = scores[0], scores[1:]
    near = math.hypot(estimate.x - robot.x, estimate.y - robot.y) <= CLOSE_ENOUGH
    if near and here >= scores.max() - STAY_SLACK:
        return None
    spot = cells[int(np.argmax(scores))]
    yaw = math.atan2(estimate.y - spot[1], estimate.x - spot[0])
    return Pose2D(float(spot[0]), float(spot[1]), yaw)


def _reachable_near(
    estimate: GuestEstimate, grid: OccupancyGrid2D, reachable: np.ndarray
) -> np.ndarray:
    """Centres (n, 2) of reachable cells within APPROACH_RADIUS of the estimate, about
    :data:`ESTIMATE_SPACING` apart (finer would only cost time: the goal tolerance is 0.3 m)."""
    window = grid.window(estimate.x - APPROACH_RADIUS, estimate.y - APPROACH_RADIUS,
                         estimate.x + APPROACH_RADIUS, estimate.y + APPROACH_RADIUS)
    if window.is_empty:
        return np.zeros((0, 2))
    stride = max(1, round(ESTIMATE_SPACING / grid.resolution))
    xs, ys = np.meshgrid(window.xs[::stride], window.ys[::stride])
    keep = reachable[window.rows, window.cols][::stride, ::stride] & (
        np.hypot(xs - estimate.x, ys - estimate.y) <= APPROACH_RADIUS)
    return np.column_stack([xs[keep], ys[keep]])


def _score(estimate: GuestEstimate, cells: np.ndarray, robot: Pose2D) -> np.ndarray:
    """How well each cell (n, 2) serves as the place to ask for the guest from."""
    distances = _distances(cells, estimate.spots)
    in_reach = (distances <= PICKUP_REACH).mean(axis=1)
    crowding = (distances < TOO_CLOSE).mean(axis=1)
    off_ring = np.abs(np.hypot(cells[:, 0] - estimate.x, cells[:, 1] - estimate.y)
                      - APPROACH_DISTANCE)
    travel = np.hypot(cells[:, 0] - robot.x, cells[:, 1] - robot.y)
    scores: NDArray[np.float64] = in_reach - crowding - 0.1 * off_ring - 1e-3 * travel
    return scores


def _wall_berth(grid: OccupancyGrid2D, cells: np.ndarray) -> np.ndarray:
    """0 for cells with :data:`WALL_BERTH` of clearance, down to −:data:`WALL_WEIGHT` at
    :data:`~bt_servicesim.planning.goals.ROBOT_CLEARANCE`."""
    rows, cols = _cells_of(grid, cells)
    shortfall = (WALL_BERTH - grid.clearances[rows, cols]) / (WALL_BERTH - ROBOT_CLEARANCE)
    berth: NDArray[np.float64] = -WALL_WEIGHT * np.clip(shortfall, 0.0, 1.0)
    return berth


def _departure(estimate: GuestEstimate, grid: OccupancyGrid2D, cells: np.ndarray,
               leave_towards: Point) -> np.ndarray:
    """How far ahead of the guest each cell lies on the route to ``leave_towards``, scaled to
    ±:data:`DEPARTURE_WEIGHT`; 0 everywhere when no route is known.

    The guest's own route length is taken through the best cell (cells around them have
    room for the robot; they may stand closer to a wall than that)."""
    routes = grid.routes_from(*leave_towards, ROBOT_CLEARANCE)
    if routes is None:
        return np.zeros(len(cells))
    to_exit = routes.distances_at(cells[:, 0], cells[:, 1])
    guest_to_exit = np.min(to_exit + np.hypot(cells[:, 0] - estimate.x, cells[:, 1] - estimate.y))
    if not np.isfinite(guest_to_exit):
        return np.zeros(len(cells))
    departure: NDArray[np.float64] = DEPARTURE_WEIGHT * np.clip(
        (guest_to_exit - to_exit) / DEPARTURE_SCALE, -1.0, 1.0)
    return departure


def _reachable_keeping(berth: float, estimate: GuestEstimate, grid: OccupancyGrid2D,
                       robot: Pose2D, cells: np.ndarray) -> np.ndarray:
    """Which cells the robot reaches keeping ``berth`` from every possible spot of the guest,
    by any way through the building (round a block of rooms, say); all of them when the robot
    already stands that close (nothing to tell)."""
    reach = APPROACH_RADIUS + PASSING_WINDOW
    window = grid.window(estimate.x - reach, estimate.y - reach,
                         estimate.x + reach, estimate.y + reach)
    everywhere = np.ones(len(cells), dtype=bool)
    if window.is_empty:
        return everywhere
    spots = np.zeros((len(window.ys), len(window.xs)), dtype=bool)
    rows, cols = _window_indices(grid, window, np.vstack([estimate.spots,
                                                          [[estimate.x, estimate.y]]]))
    spots[rows, cols] = True
    from scipy import ndimage  # when computing, as planning.occupancy says why

    open_cells = grid.passable(ROBOT_CLEARANCE).copy()
    open_cells[window.rows, window.cols] &= (
        ndimage.distance_transform_edt(~spots) * grid.resolution >= berth)
    labels, _count = ndimage.label(open_cells, structure=np.ones((3, 3), dtype=bool))
    robot_rows, robot_cols = _cells_of(grid, np.array([[robot.x, robot.y]]))
    robot_label = labels[robot_rows[0], robot_cols[0]]
    if robot_label == 0:
        return everywhere
    cell_rows, cell_cols = _cells_of(grid, cells)
    reachable: NDArray[np.bool_] = labels[cell_rows, cell_cols] == robot_label
    return reachable


def _window_indices(grid: OccupancyGrid2D, window: Window,
                    points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column of each point (n, 2) within ``window``, clipped to it."""
    rows, cols = _cells_of(grid, points, clip=False)
    return (np.clip(rows - window.rows.start, 0, len(window.ys) - 1),
            np.clip(cols - window.cols.start, 0, len(window.xs) - 1))


def _cells_of(grid: OccupancyGrid2D, points: np.ndarray,
              clip: bool = True) -> tuple[np.ndarray, np.ndarray]:
    rows = np.floor((points[:, 1] - grid.origin_y) / grid.resolution).astype(np.intp)
    cols = np.floor((points[:, 0] - grid.origin_x) / grid.resolution).astype(np.intp)
    if not clip:
        return rows, cols
    return np.clip(rows, 0, grid.height - 1), np.clip(cols, 0, grid.width - 1)


# ============================================================================ behaviours




