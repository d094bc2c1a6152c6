"""Where people stand near the robot, read off navigation's costmap.

A robot knows people only through its sensors. Nav2 (and the competition's ``move_base``) turn
the lidar's hits into marks on the costmap they publish (``global_costmap/costmap``, a
``nav_msgs/OccupancyGrid`` in ``map``): a person is a disc of lethal cells (100) in open floor,
ringed by inscribed and inflated ones. :func:`people_on_costmap` finds those discs and gives each
one's centre: where that person stands, as well as the costmap knows it (marks lag by up to a
publish period, and people out of the lidar's view stay where they were last seen).

Only lethal cells count: the inscribed rings of two people a metre apart (a guest and a walker
it holds up) run together, their lethal discs do not. Lethal cells at a wall are the wall's own;
a person standing against a wall, or in a doorway, still leaves most of their disc in open floor.

Pure: numpy and scipy's labelling, no ROS, no py_trees.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bt_servicesim.planning.occupancy import OccupancyGrid2D

__all__ = ["LETHAL", "WALL_MARGIN", "Costmap2D", "people_on_costmap", "people_within", "window_of"]

LETHAL = 100
"""The ``OccupancyGrid`` value of an obstacle's own cells, as Nav2's publisher translates its
costs (inscribed cells are 99)."""
WALL_MARGIN = 0.15
"""Metres from the static map's walls within which a lethal cell is put down to the walls: a
coarse costmap cell takes the nearest wall of the map cells it covers."""
MIN_CELLS = 3
"""A disc of fewer cells is noise, not a person (a person's is about 0.6 m across)."""
PERSON_DISC_RADIUS = 0.3
"""Metres: half a person's disc of lethal cells."""
_FOUR_CONNECTED = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool)
"""scipy's default structure for labelling a plane, given rather than built at every call."""


@dataclass(frozen=True)
class Costmap2D:
    """A costmap as published: ``values`` (rows grow with +y, columns with +x) from the
    origin, in the ``map`` frame, stamped with the sim time it was published at.

    Its repr leaves the values out, as the static map's does: the tree log writes the repr of
    every new blackboard value, and numpy took a millisecond to summarise the grid each time.
    """

    values: np.ndarray = field(repr=False)
    origin_x: float
    origin_y: float
    resolution: float
    stamp_s: float

    @classmethod
    def from_message(cls, message: object) -> Costmap2D:
        """From a ``nav_msgs/OccupancyGrid``; ``ValueError`` names what is wrong with it."""
        info = message.info  # type: ignore[attr-defined]
        values = np.asarray(message.data, dtype=np.int8).ravel()  # type: ignore[attr-defined]
        width, height = int(info.width), int(info.height)
        if width <= 0 or height <= 0 or values.size != width * height:
            raise ValueError(f"costmap of {width} x {height} cells with {values.size} values")
        if not info.resolution > 0.0:
            raise ValueError(f"costmap resolution {info.resolution}: must be more than 0")
        stamp = message.header.stamp  # type: ignore[attr-defined]
        return cls(values=values.reshape(height, width),
                   origin_x=float(info.origin.position.x), origin_y=float(info.origin.position.y),
                   resolution=float(info.resolution),
                   stamp_s=stamp.sec + stamp.nanosec * 1e-9)


def people_on_costmap(costmap: Costmap2D, walls: OccupancyGrid2D, *, x: float, y: float,
                      reach: float) -> np.ndarray:
    """Centres of the people's discs on ``costmap`` within ``reach`` metres (in x and in y) of
    (x, y), nearest first; shape (n, 2), read-only. ``walls`` is the static map.

    Navigation publishes its costmap once a sim second and the tree asks at every tick, mostly
    the same question (is anyone at this spot, near this box): the answers on the latest
    costmap are kept (:class:`_Answers`) and handed out again while it is the latest.
    """
    answers = _answers
    if answers.costmap is not costmap or answers.walls is not walls:
        answers.start(costmap, walls)
    key = (x, y, reach)
    found = answers.found.get(key)
    if found is None:
        if len(answers.found) >= _Answers.KEPT:
            answers.found.clear()
        found = answers.found[key] = _found_on(costmap, walls, x=x, y=y, reach=reach)
        found.flags.writeable = False
    return found


class _Answers:
    """The answers :func:`people_on_costmap` gave on one costmap over one map, by question."""

    KEPT = 64
    """Questions kept at most; the tree asks a handful between two costmaps."""

    def __init__(self) -> None:
        self.costmap: Costmap2D | None = None
        self.walls: OccupancyGrid2D | None = None
        self.found: dict[tuple[float, float, float], np.ndarray] = {}

    def start(self, costmap: Costmap2D, walls: OccupancyGrid2D) -> None:
        """Forget the answers on the last costmap: ``costmap`` is the one asked about now."""
        self.costmap, self.walls, self.found = costmap, walls, {}


_answers = _Answers()


def window_of(costmap: Costmap2D, *, x: float, y: float,
              reach: float) -> tuple[int, int, int, int] | None:
    """The costmap's cells within ``reach`` of (x, y) along each axis, as ``(row0, row1, col0,
    col1)`` slice bounds, clipped to the costmap; None when nothing of it is that near."""
    res = costmap.resolution
    rows, cols = costmap.values.shape
    col0 = max(int(np.floor((x - reach - costmap.origin_x) / res)), 0)
    row0 = max(int(np.floor((y - reach - costmap.origin_y) / res)), 0)
    col1 = min(int(np.ceil((x + reach - costmap.origin_x) / res)), cols)
    row1 = min(int(np.ceil((y + reach - costmap.origin_y) / res)), rows)
    if col0 >= col1 or row0 >= row1:
        return None
    return row0, row1, col0, col1


def _found_on(costmap: Costmap2D, walls: OccupancyGrid2D, *, x: float, y: float,
              reach: float) -> np.ndarray:
    """:func:`people_on_costmap`, worked out.

    A few dozen of the window's thousands of cells are lethal, so only those are looked at: their
    centres, their clearance from the walls, and each disc's cell count and centre summed per
    label (``np.bincount``, as scipy's ``ndimage.mean`` sums them, cell by cell in row order:
    the same centres, bit for bit, for half the CPU)."""
    bounds = window_of(costmap, x=x, y=y, reach=reach)
    if bounds is None:
        return np.zeros((0, 2))
    row0, row1, col0, col1 = bounds
    res = costmap.resolution
    window = costmap.values[row0:row1, col0:col1] >= LETHAL
    lethal_rows, lethal_cols = np.nonzero(window)
    xs = costmap.origin_x + ((lethal_cols + col0) + 0.5) * res
    ys = costmap.origin_y + ((lethal_rows + row0) + 0.5) * res
    open_floor = walls.clearances_at(xs, ys) > WALL_MARGIN
    if not open_floor.any():  # nothing lethal here, or only the walls: nobody to label
        return np.zeros((0, 2))
    window[lethal_rows[~open_floor], lethal_cols[~open_floor]] = False
    from scipy import ndimage  # when computing, as planning.occupancy says why

    labels, count = ndimage.label(window, structure=_FOUR_CONNECTED)
    disc = labels[lethal_rows[open_floor], lethal_cols[open_floor]]
    sizes = np.bincount(disc, minlength=count + 1)[1:]
    centres = np.column_stack([
        np.bincount(disc, weights=xs[open_floor], minlength=count + 1)[1:] / sizes,
        np.bincount(disc, weights=ys[open_floor], minlength=count + 1)[1:] / sizes,
    ])[sizes >= MIN_CELLS]
    order = np.argsort(np.hypot(centres[:, 0] - x, centres[:, 1] - y), kind="stable")
    return centres[order]


def people_within(costmap: Costmap2D, walls: OccupancyGrid2D, *, x: float, y: float,
                  radius: float) -> np.ndarray:
    """Centres of the people's discs on ``costmap`` no more than ``radius`` metres from (x, y),
    nearest first; shape (n, 2). The costmap is searched a body's width beyond ``radius``, so
    that a disc the circle cuts is found whole, at its true centre."""
    people = people_on_costmap(costmap, walls, x=x, y=y, reach=radius + 2 * PERSON_DISC_RADIUS)
    return people[np.hypot(people[:, 0] - x, people[:, 1] - y) <= radius]
