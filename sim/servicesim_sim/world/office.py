"""The ServiceSim office, the default world: its building authored as data, and its generator.

The building reproduces the layout of the office in OSRF's ServiceSim competition (2018): a
49 x 23 m floor with a row of rooms along the north side, meeting rooms in the middle, private
cubicles in the west, public cubicle desks and a cafe in the east, bathrooms and a lobby with
the lift along the south side. Positions were read off the competition's published static map
(0.05 m per cell, origin (-30, -30), 1200 x 1200 cells) and written down here as round numbers,
so world coordinates match the original's target areas, which are copied as facts.

Everything is plain data, so the building can be read and changed like a drawing:

* ``OUTLINE`` - the building's outer wall, a closed rectilinear polygon. Inside is free floor,
  outside is unknown.
* ``ROOMS`` - the 19 rooms, each a box of wall centre lines with one door. Rooms with no target
  area had a closed door in the original's shipped world; here every room is open by default,
  and ``--closed-doors`` writes the variant with those doors shut (:data:`CLOSED_IN_SHIPPED`).
  (Their names are not in the competition's data; ours follow its naming scheme.)
* ``WALLS`` - free-standing walls: the lobby's partitions.
* ``FURNITURE`` - solid blocks: the public cubicle desk crosses and the cafe's desk bank.
* ``CUBICLE_CLUSTERS`` - the private cubicles: two rows of booths back to back, each booth with
  a 0.55 m entrance (too narrow for the robot; the target strips lie in front of them).
* ``TARGET_AREAS`` - the 70 target areas, exactly as the competition defines them.
* ``IDLING_AREAS`` - the 19 boxes where the competition's idlers stand, each with the way they
  face (facts of its ``worlds/idling_humans.erb``; one box there has min and max x swapped,
  written here low to high).
* ``WALKER_ROUTES`` - the competition's walker loops, their waypoints as facts of its
  ``worlds/trajectory_*.erb``, and ``SHIPPED_WALKERS``, the shipped world file's ten walkers on
  them (route, first waypoint, speed), which the shipped task plays.

Doors are 1.2 m wide (the original's are about 1.05 m) so that a robot whose planner inflates
obstacles by 0.35-0.4 m still fits through. ``python -m servicesim_sim.world.office`` rasterises the
building into ``worlds/office/map.pgm`` and writes ``map.yaml`` and ``world.yaml`` beside it;
the output is deterministic, and a test checks the committed files equal a fresh generation.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import NoReturn

import numpy as np
from numpy.typing import NDArray

from servicesim_sim.world.files import DEFAULT_WORLD

RESOLUTION = 0.05  # metres per cell
ORIGIN = (-30.0, -30.0)  # world position of the lower-left corner of the map
SIZE = 1200  # cells in x and in y
WALL = 0.10  # thickness of building walls
PARTITION = 0.05  # thickness of cubicle partitions
DOOR = 1.2  # width of every door
FREE_PIXEL, OCCUPIED_PIXEL, UNKNOWN_PIXEL = 254, 0, 205  # map_saver's trinary values
OVERLAP = 1e-6  # a block marks every cell it overlaps by more than this, metres

Point = tuple[float, float]


# --------------------------------------------------------------------------- building parts
@dataclass(frozen=True)
class Block:
    """A solid axis-aligned rectangle: a piece of wall or furniture."""

    min_x: float
    min_y: float
    max_x: float
    max_y: float


@dataclass(frozen=True)
class Wall:
    """A straight axis-aligned wall along its centre line, with door gaps cut into it.

    ``doors`` are the centres of the gaps along the wall (x for a wall running east-west, y for
    one running north-south). The wall reaches half its thickness beyond its end points, so
    walls meeting at a corner join.
    """

    start: Point
    end: Point
    doors: tuple[float, ...] = ()
    thickness: float = WALL

    def blocks(self) -> Iterator[Block]:
        (x0, y0), (x1, y1) = self.start, self.end
        horizontal = y0 == y1
        if not horizontal and x0 != x1:
            raise ValueError(f"wall {self.start}-{self.end} is not axis-aligned")
        low, high = sorted((x0, x1) if horizontal else (y0, y1))
        half = self.thickness / 2.0
        edges = [low - half]
        for door in sorted(self.doors):
            edges += [door - DOOR / 2.0, door + DOOR / 2.0]
        edges.append(high + half)
        across = y0 if horizontal else x0
        for first, last in zip(edges[::2], edges[1::2], strict=True):
            if horizontal:
                yield Block(first, across - half, last, across + half)
            else:
                yield Block(across - half, first, across + half, last)


@dataclass(frozen=True)
class Room:
    """A room: a box of wall centre lines and one door in one of its sides."""

    name: str
    low: Point  # south-west corner
    high: Point  # north-east corner
    door_side: str  # "north", "south", "east" or "west"
    door_at: float  # the door's centre along that side

    def walls(self, *, closed: bool = False) -> tuple[Wall, ...]:
        """The four walls, the door a gap in one of them unless ``closed`` (then it is wall)."""
        (x0, y0), (x1, y1) = self.low, self.high
        sides = {"south": ((x0, y0), (x1, y0)), "north": ((x0, y1), (x1, y1)),
                 "west": ((x0, y0), (x0, y1)), "east": ((x1, y0), (x1, y1))}
        return tuple(Wall(start, end,
                          (self.door_at,) if side == self.door_side and not closed else ())
                     for side, (start, end) in sides.items())


@dataclass(frozen=True)
class CubicleCluster:
    """Two rows of private cubicle booths back to back, ``booths`` wide.

    The south row opens south through a gap at each booth's east end, the north row opens
    north at each booth's west end, as in the original's cubicle furniture.
    """

    west_x: float
    south_y: float
    booths: int
    booth_width: float = 1.8
    row_depth: float = 1.225
    entrance: float = 0.55

    def walls(self) -> Iterator[Wall]:
        x0, y0, width = self.west_x, self.south_y, self.booth_width
        y_back, y1 = y0 + self.row_depth, y0 + 2 * self.row_depth
        yield Wall((x0, y_back), (x0 + self.booths * width, y_back), thickness=PARTITION)
        for booth in range(self.booths):
            west, east = x0 + booth * width, x0 + (booth + 1) * width
            yield Wall((west, y0), (east - self.entrance, y0), thickness=PARTITION)
            yield Wall((west + self.entrance, y1), (east, y1), thickness=PARTITION)
        for booth in range(self.booths + 1):
            x = x0 + booth * width
            yield Wall((x, y0), (x, y1), thickness=PARTITION)


def desk_cross(centre: Point, *, arm: float = 3.7, width: float = 1.5) -> tuple[Block, Block]:
    """A plus-shaped desk island of four public cubicle desks around ``centre``."""
    x, y = centre
    return (Block(x - arm / 2, y - width / 2, x + arm / 2, y + width / 2),
            Block(x - width / 2, y - arm / 2, x + width / 2, y + arm / 2))


# --------------------------------------------------------------------------- the office
OUTLINE: tuple[Point, ...] = (
    (-27.3, -0.05), (21.2, -0.05), (21.2, 16.45), (21.0, 16.45), (21.0, 22.55),
    (-23.0, 22.55), (-23.0, 21.05), (-27.6, 21.05), (-27.6, 4.55), (-27.3, 4.55),
)

ROOMS: tuple[Room, ...] = (
    # North row, doors onto the north corridor.
    Room("PrivateOfficeC", (-23.0, 19.45), (-18.4, 22.55), "south", -20.7),
    Room("PrivateOfficeB", (-18.4, 19.45), (-13.8, 22.55), "south", -16.1),
    Room("PrivateOfficeA", (-13.8, 19.45), (-9.2, 22.55), "south", -11.5),
    Room("PrivateBathroomB", (-9.2, 19.45), (-6.1, 22.55), "south", -6.9),
    Room("PrivateBathroomA", (-6.1, 19.45), (-3.0, 22.55), "south", -3.8),
    Room("PublicMeetingRoomE", (2.7, 19.45), (7.3, 22.55), "south", 5.0),
    Room("PublicMeetingRoomD", (7.3, 19.45), (11.9, 22.55), "south", 9.6),
    Room("PublicMeetingRoomA", (11.9, 16.45), (21.0, 22.55), "south", 18.7),
    # North-west corner office.
    Room("PrivateOfficeD", (-27.6, 14.95), (-23.0, 21.05), "east", 18.7),
    # The meeting block in the middle of the floor, doors east and west.
    Room("PrivateMeetingRoomA", (-4.7, 4.45), (-0.1, 10.55), "west", 6.8),
    Room("PrivateMeetingRoomB", (-4.7, 10.55), (-0.1, 16.7), "west", 12.9),
    Room("PublicMeetingRoomB", (-0.1, 4.45), (4.5, 10.55), "east", 8.3),
    Room("PublicMeetingRoomC", (-0.1, 10.55), (4.5, 16.7), "east", 14.4),
    # South-west row, doors onto the west hall.
    Room("PrivateMeetingRoomC", (-27.3, -0.05), (-21.2, 4.55), "north", -25.0),
    Room("PrivateMeetingRoomD", (-21.2, -0.05), (-15.1, 4.55), "north", -18.9),
    Room("PrivateMeetingRoomE", (-15.1, -0.05), (-9.0, 4.55), "north", -12.8),
    # South-east: the public bathrooms and the cafe.
    Room("PublicBathroomA", (7.4, -0.05), (10.5, 3.1), "north", 8.2),
    Room("PublicBathroomB", (10.5, -0.05), (13.6, 3.1), "north", 11.3),
    Room("PublicCafe", (13.6, -0.05), (21.2, 10.55), "west", 5.3),
)

WALLS: tuple[Wall, ...] = (
    Wall((-9.0, 4.55), (-6.05, 4.55)),  # lobby, west side: leaves a 1.25 m way to the west hall
    Wall((4.5, 3.1), (7.4, 3.1)),  # lobby, east side: leaves a 1.25 m way to the bathrooms
)

FURNITURE: tuple[Block, ...] = (
    *desk_cross((9.0, 7.5)),  # public cubicles 25
    *desk_cross((9.0, 13.5)),  # public cubicles 26
    Block(13.6, 10.5, 21.2, 11.4),  # the cafe's desk bank (public cubicles 27-30 face it)
    *(Block(13.55 + 1.9 * desk, 11.4, 14.35 + 1.9 * desk, 12.5) for desk in range(4)),
)

CUBICLE_CLUSTERS: tuple[CubicleCluster, ...] = tuple(
    CubicleCluster(west_x=west_x, south_y=south_y, booths=booths)
    for west_x, booths in ((-21.0, 4), (-12.0, 3))  # clusters 31-33 and 34-36
    for south_y in (6.3, 10.8, 15.3)
)

TARGET_AREAS: tuple[tuple[str, Point, Point], ...] = (
    ("PublicBathroomA", (6.75, 3.0), (9.75, 4.5)),
    ("PublicBathroomB", (9.85, 3.0), (12.85, 4.5)),
    ("PublicCafe", (13.7, 3.0), (16.7, 6.0)),
    ("PublicMeetingRoomA", (18.0, 16.5), (21.0, 19.5)),
    ("PublicMeetingRoomB", (1.5, 7.5), (4.5, 10.5)),
    ("PublicMeetingRoomD", (8.9, 19.5), (11.9, 22.5)),
    ("PublicMeetingRoomE", (4.3, 19.5), (7.3, 22.5)),
    ("PrivateMeetingRoomA", (-4.6, 4.5), (-1.6, 7.5)),
    ("PrivateBathroomA", (-5.25, 18.0), (-2.25, 19.5)),
    ("PrivateOfficeC", (-21.4, 19.5), (-18.4, 22.5)),
    ("PrivateOfficeD", (-26.0, 18.0), (-23.0, 21.0)),
    ("PublicCubicle_25_1", (6.0, 4.5), (9.0, 7.5)),
    ("PublicCubicle_25_2", (6.0, 7.5), (9.0, 10.5)),
    ("PublicCubicle_25_3", (9.0, 4.5), (12.0, 7.5)),
    ("PublicCubicle_25_4", (9.0, 7.5), (12.0, 10.5)),
    ("PublicCubicle_26_1", (6.0, 10.5), (9.0, 13.5)),
    ("PublicCubicle_26_2", (6.0, 13.5), (9.0, 16.5)),
    ("PublicCubicle_26_3", (9.0, 10.5), (12.0, 13.5)),
    ("PublicCubicle_26_4", (9.0, 13.5), (12.0, 16.5)),
    ("PublicCubicle_27", (13.6, 12.6), (15.6, 13.6)),
    ("PublicCubicle_28", (15.5, 12.6), (17.5, 13.6)),
    ("PublicCubicle_29", (17.4, 12.6), (19.4, 13.6)),
    ("PublicCubicle_30", (19.3, 12.6), (21.3, 13.6)),
    ("PrivateCubicle_31_1", (-21.0, 4.775), (-19.2, 6.275)),
    ("PrivateCubicle_31_2", (-21.0, 8.725), (-19.2, 10.225)),
    ("PrivateCubicle_31_3", (-19.2, 4.775), (-17.4, 6.275)),
    ("PrivateCubicle_31_4", (-19.2, 8.725), (-17.4, 10.225)),
    ("PrivateCubicle_31_5", (-17.4, 4.775), (-15.6, 6.275)),
    ("PrivateCubicle_31_6", (-17.4, 8.725), (-15.6, 10.225)),
    ("PrivateCubicle_31_7", (-15.6, 4.775), (-13.8, 6.275)),
    ("PrivateCubicle_31_8", (-15.6, 8.725), (-13.8, 10.225)),
    ("PrivateCubicle_32_1", (-21.0, 9.275), (-19.2, 10.775)),
    ("PrivateCubicle_32_2", (-21.0, 13.225), (-19.2, 14.725)),
    ("PrivateCubicle_32_3", (-19.2, 9.275), (-17.4, 10.775)),
    ("PrivateCubicle_32_4", (-19.2, 13.225), (-17.4, 14.725)),
    ("PrivateCubicle_32_5", (-17.4, 9.275), (-15.6, 10.775)),
    ("PrivateCubicle_32_6", (-17.4, 13.225), (-15.6, 14.725)),
    ("PrivateCubicle_32_7", (-15.6, 9.275), (-13.8, 10.775)),
    ("PrivateCubicle_32_8", (-15.6, 13.225), (-13.8, 14.725)),
    ("PrivateCubicle_33_1", (-21.0, 13.775), (-19.2, 15.275)),
    ("PrivateCubicle_33_2", (-21.0, 17.725), (-19.2, 19.225)),
    ("PrivateCubicle_33_3", (-19.2, 13.775), (-17.4, 15.275)),
    ("PrivateCubicle_33_4", (-19.2, 17.725), (-17.4, 19.225)),
    ("PrivateCubicle_33_5", (-17.4, 13.775), (-15.6, 15.275)),
    ("PrivateCubicle_33_6", (-17.4, 17.725), (-15.6, 19.225)),
    ("PrivateCubicle_33_7", (-15.6, 13.775), (-13.8, 15.275)),
    ("PrivateCubicle_33_8", (-15.6, 17.725), (-13.8, 19.225)),
    ("PrivateCubicle_34_1", (-12.0, 4.775), (-10.2, 6.275)),
    ("PrivateCubicle_34_2", (-12.0, 8.725), (-10.2, 10.225)),
    ("PrivateCubicle_34_3", (-10.2, 4.775), (-8.4, 6.275)),
    ("PrivateCubicle_34_4", (-10.2, 8.725), (-8.4, 10.225)),
    ("PrivateCubicle_34_5", (-8.4, 4.775), (-6.6, 6.275)),
    ("PrivateCubicle_34_6", (-8.4, 8.725), (-6.6, 10.225)),
    ("PrivateCubicle_35_1", (-12.0, 9.275), (-10.2, 10.775)),
    ("PrivateCubicle_35_2", (-12.0, 13.225), (-10.2, 14.725)),
    ("PrivateCubicle_35_3", (-10.2, 9.275), (-8.4, 10.775)),
    ("PrivateCubicle_35_4", (-10.2, 13.225), (-8.4, 14.725)),
    ("PrivateCubicle_35_5", (-8.4, 9.275), (-6.6, 10.775)),
    ("PrivateCubicle_35_6", (-8.4, 13.225), (-6.6, 14.725)),
    ("PrivateCubicle_36_1", (-12.0, 13.775), (-10.2, 15.275)),
    ("PrivateCubicle_36_2", (-12.0, 17.725), (-10.2, 19.225)),
    ("PrivateCubicle_36_3", (-10.2, 13.775), (-8.4, 15.275)),
    ("PrivateCubicle_36_4", (-10.2, 17.725), (-8.4, 19.225)),
    ("PrivateCubicle_36_5", (-8.4, 13.775), (-6.6, 15.275)),
    ("PrivateCubicle_36_6", (-8.4, 17.725), (-6.6, 19.225)),
    ("PrivateCafe", (-25.5, 4.5), (-22.5, 7.5)),
    ("BackEntrance", (-3.0, 18.3), (1.5, 21.3)),
    ("FrontElevator", (-1.5, 0.0), (1.5, 2.7)),
    ("FrontCouchA", (-7.5, 0.0), (-4.5, 4.5)),
    ("FrontCouchB", (3.75, 0.0), (6.0, 2.25)),
)

# Where the idlers stand: (min corner, max corner, yaw). North-facing is pi/2.
HALF_PI, QUARTER_PI = math.pi / 2.0, math.pi / 4.0
IDLING_AREAS: tuple[tuple[Point, Point, float], ...] = (
    ((-3.97, 0.26), (-2.12, 0.40), math.pi),  # lobby, by FrontCouchA
    ((-3.16, 3.32), (-2.52, 3.88), 0.0),
    ((-0.39, 17.0), (0.26, 17.61), math.pi),  # south of BackEntrance
    ((1.69, 20.54), (2.31, 20.96), -HALF_PI),
    ((19.82, 14.23), (20.49, 15.84), -HALF_PI),  # east, by PublicCubicle_30
    ((17.11, 7.15), (18.98, 7.86), -QUARTER_PI),  # in the PublicCafe
    ((17.5, 4.07), (18.73, 4.70), 0.0),
    ((16.81, 1.11), (20.42, 1.74), 0.0),
    ((5.55, 2.48), (5.92, 2.88), 0.0),  # by FrontCouchB
    ((1.82, 0.29), (2.35, 1.62), -HALF_PI),  # lobby, east of FrontElevator
    ((-26.2, 5.01), (-25.74, 6.85), HALF_PI),  # PrivateCafe
    ((-26.6, 11.17), (-26.4, 14.49), -HALF_PI),  # west wall
    ((-25.3, 15.28), (-25.1, 15.56), math.pi),
    ((-27.26, 17.31), (-27.24, 19.59), HALF_PI),  # PrivateOfficeD
    ((-2.56, 21.54), (-1.68, 22.16), 0.0),  # BackEntrance
    ((5.98, 18.75), (8.7, 19.2), 0.0),  # north corridor
    ((10.63, 18.36), (11.45, 19.14), -QUARTER_PI),
    ((12.57, 16.88), (16.95, 17.64), math.pi),
    ((12.46, 21.22), (17.82, 22.25), 0.0),  # PublicMeetingRoomA
)

# The competition's shipped task. The guest's yaw is ours (the original's is random).
SHIPPED_PICK_UP, SHIPPED_DROP_OFF = "FrontElevator", "PrivateCubicle_32_1"
SHIPPED_GUEST = {"name": "human_20843", "x": -0.043, "y": 1.512, "yaw": 1.5708}
SHIPPED_START = {"area": "PublicBathroomB", "x": 10.975, "y": 3.75, "yaw": 3.14}
PEOPLE = {"walkers": 10, "idlers": 30}
AMCL_INITIAL_POSE = (-24.469, 6.278, 0.15)  # the competitor's AMCL launch file's initial pose
WALKER_ROUTES: tuple[tuple[str, int, tuple[Point, ...]], ...] = (
    # (name, weight, waypoints): the original's walker loops (worlds/trajectory_*.erb), each
    # walked one way; the weight counts its entries in the world's list of 12 (service.world.erb
    # 298-311 lists public_a, public_b and middle twice), of which each walker draws one
    ("private_a", 1, (
        (-6.16816, 18.587), (-12.4968, 18.6143), (-12.4028, 14.6816), (-6.1741, 14.5956),
    )),
    ("private_b", 1, (
        (-12.4711, 13.7521), (-12.5163, 10.117987), (-6.171264, 10.116618), (-6.2575, 13.6915),
    )),
    ("private_c", 1, (
        (-12.52011, 5.16458), (-10.9879, 5.74511), (-8.9867, 5.11785), (-6.08475, 5.70235),
        (-6.15453, 9.26386), (-12.6079, 9.35446),
    )),
    ("private_d", 1, (
        (-13.2529, 18.580999), (-22.38113, 18.87678), (-23.494101, 18.9972), (-23.4842, 20.4646),
        (-26.001801, 20.2019), (-26.606701, 18.231199), (-23.3948, 18.7012),
        (-22.129801, 18.5949), (-21.9725, 14.8722), (-13.4044, 14.7422),
    )),
    ("private_e", 1, (
        (-13.3706, 13.7295), (-13.2745, 10.315), (-21.4146, 10.113), (-23.207399, 10.4149),
        (-25.7551, 10.2685), (-25.962799, 13.9653), (-22.680201, 13.8011),
    )),
    ("private_f", 1, (
        (-13.418113, 9.5487), (-21.608414, 9.4787), (-22.565878, 7.074205),
        (-25.294289, 6.835807), (-23.635027, 5.355711), (-13.40267, 5.40426),
    )),
    ("public_a", 2, (
        (20.506599, 19.421101), (20.538099, 17.3319), (19.028212, 17.399599),
        (18.885065, 15.7129), (11.0484, 15.652), (10.0429, 17.692699), (7.8387, 17.7792),
        (6.33662, 16.371099), (6.51252, 11.1019), (10.4842, 11.0926), (12.5155, 13.2793),
        (18.30191, 13.4166), (18.697857, 15.7464), (18.697857, 20.0874),
    )),
    ("public_b", 2, (
        (14.846853, 7.988438), (16.0257, 8.12129), (16.195299, 1.99335), (14.1699, 1.91747),
        (14.176, 5.385326), (12.1254, 5.385326), (10.3737, 3.89311), (7.96763, 4.71297),
        (6.41362, 5.11439), (6.32939, 8.46126), (7.37067, 9.849683), (10.5193, 9.81355),
        (12.1611, 8.39257), (13.1988, 5.185326), (14.704, 5.185326),
    )),
    ("middle", 2, (
        (5.73804, 0.57919), (4.92099, 1.79494), (3.97233, 2.61649), (3.80775, 3.75994),
        (5.260433, 3.78449), (5.164691, 17.968399), (2.06448, 18.5096), (0.880134, 19.172422),
        (0.629188, 20.632648), (-1.98216, 21.1175), (-1.29948, 19.322399), (-3.52062, 17.694099),
        (-5.25849, 17.376499), (-5.2171, 4.85426), (-6.80757, 2.21765), (-5.42005, 0.928583),
        (-3.5244, 0.95478), (0.133735, 2.10273), (3.57247, 2.54955), (4.24307, 1.33246),
    )),
)
SHIPPED_WALKERS = (  # (route, first waypoint, speed m/s) of the shipped world file's walkers
    # (worlds/service.world 39892-41563), played by the shipped task
    ("private_b", 0, 1.1672),
    ("private_b", 1, 1.1871),
    ("middle", 19, 1.1589),
    ("public_a", 12, 1.1307),
    ("private_d", 0, 1.1557),
    ("public_a", 1, 1.0997),
    ("private_a", 0, 1.0064),
    ("public_b", 6, 1.1434),
    ("public_b", 5, 1.0516),
    ("public_b", 12, 0.9195),
)
SHIPPED_DRIFT_TIMES = (487, 654, 889, 1038, 1313, 1606, 1767, 1881, 2164, 2463, 2643, 2745, 2966,
                       3171, 3418, 3581, 3862, 3989, 4145, 4358, 4616, 4892, 5039, 5306, 5515,
                       5653, 5925, 6043, 6335, 6619)
"""The shipped task's drift times in world sim seconds (``worlds/service.world`` 43207-43265, the
FollowActorPlugin's ``drift_time`` elements); a seeded task draws its own by the rule below."""
DRIFT = {"start_s": 200.0, "min_interval_s": 100.0, "max_interval_s": 300.0, "count": 30,
         "times": list(SHIPPED_DRIFT_TIMES)}


def closed_in_shipped() -> frozenset[str]:
    """The rooms whose door was shut in the original's shipped world: those with no target
    area (``worlds/room.erb``: a room with a closed door is no target)."""
    targets = {name for name, _, _ in TARGET_AREAS}
    return frozenset(room.name for room in ROOMS if room.name not in targets)


CLOSED_IN_SHIPPED = closed_in_shipped()


def obstacle_blocks(closed: frozenset[str] = frozenset()) -> Iterator[Block]:
    """Every solid block of the building: outer walls, rooms (the ``closed`` ones' doors shut),
    walls, furniture, cubicles."""
    corners = (*OUTLINE, OUTLINE[0])
    for start, end in pairwise(corners):
        yield from Wall(start, end).blocks()
    for room in ROOMS:
        for wall in room.walls(closed=room.name in closed):
            yield from wall.blocks()
    for wall in WALLS:
        yield from wall.blocks()
    yield from FURNITURE
    for cluster in CUBICLE_CLUSTERS:
        for wall in cluster.walls():
            yield from wall.blocks()


# --------------------------------------------------------------------------- rasterising
def rasterise(closed: frozenset[str] = frozenset()) -> np.ndarray:
    """The map as PGM pixels in image order (row 0 at the top, the map's north edge)."""
    pixels = np.full((SIZE, SIZE), UNKNOWN_PIXEL, dtype=np.uint8)
    pixels[inside_outline(OUTLINE)] = FREE_PIXEL
    for block in obstacle_blocks(closed):
        rows, cols = block_cells(block)
        pixels[rows, cols] = OCCUPIED_PIXEL
    return np.flipud(pixels).copy()


def block_cells(block: Block) -> tuple[slice, slice]:
    """The ``(rows, cols)`` slices (OccupancyGrid order) of the cells ``block`` overlaps."""

    def span(low: float, high: float, origin: float) -> slice:
        first = math.floor((low - origin) / RESOLUTION + OVERLAP / RESOLUTION)
        last = math.ceil((high - origin) / RESOLUTION - OVERLAP / RESOLUTION)
        return slice(max(first, 0), min(max(last, 0), SIZE))

    return span(block.min_y, block.max_y, ORIGIN[1]), span(block.min_x, block.max_x, ORIGIN[0])


def inside_outline(outline: Sequence[Point]) -> np.ndarray:
    """Cells (OccupancyGrid order) whose centres lie inside a rectilinear polygon (even-odd)."""
    centres = ORIGIN[1] + (np.arange(SIZE) + 0.5) * RESOLUTION
    crossings = np.zeros((SIZE, SIZE + 1), dtype=np.int32)
    corners = (*outline, outline[0])
    for (x0, y0), (x1, y1) in pairwise(corners):
        if x0 != x1:
            continue  # only the north-south edges cross a row
        rows = (centres >= min(y0, y1)) & (centres < max(y0, y1))
        first_col = math.ceil((x0 - ORIGIN[0]) / RESOLUTION - 0.5)
        crossings[rows, min(max(first_col, 0), SIZE)] += 1
    inside: NDArray[np.bool_] = (np.cumsum(crossings, axis=1)[:, :SIZE] % 2) == 1
    return inside


# --------------------------------------------------------------------------- writing files
def pgm_bytes(pixels: np.ndarray) -> bytes:
    """A binary (P5) PGM image of ``pixels``."""
    height, width = pixels.shape
    comment = "# ServiceSim office, made by python -m servicesim_sim.world.office"
    header = f"P5\n{comment}\n{width} {height}\n255\n"
    return header.encode("ascii") + pixels.astype(np.uint8).tobytes()


def map_yaml() -> str:
    return (
        "image: map.pgm\n"
        f"resolution: {RESOLUTION}\n"
        f"origin: [{ORIGIN[0]}, {ORIGIN[1]}, 0.0]\n"
        "negate: 0\n"
        "occupied_thresh: 0.65\n"
        "free_thresh: 0.196\n"
        "mode: trinary\n"
    )


def world_yaml(*, closed_doors: bool = False) -> str:
    name, rooms = ("office_closed_doors", "the shipped world's doors shut") if closed_doors else (
        "office", "every room open")
    lines = [
        "# The ServiceSim office. Generated by `python -m servicesim_sim.world.office` from",
        "# office.py; edit office.py, not this file.",
        f"name: {name}",
        f"description: The office of OSRF's ServiceSim competition (2018), {rooms}.",
        "map: map.yaml",
        "areas:",
        *(f"  {name}: {{min: [{low[0]!r}, {low[1]!r}], max: [{high[0]!r}, {high[1]!r}]}}"
          for name, low, high in TARGET_AREAS),
        "task:",
        f"  pick_up: {SHIPPED_PICK_UP}",
        f"  drop_off: {SHIPPED_DROP_OFF}",
        f"  guest: {_flow(SHIPPED_GUEST)}",
        f"  start: {_flow(SHIPPED_START)}",
        f"people: {_flow(PEOPLE)}",
        "idling_areas:",
        *(f"  - {{min: [{low[0]!r}, {low[1]!r}], max: [{high[0]!r}, {high[1]!r}], "
          f"yaw: {round(yaw, 5)!r}}}" for low, high, yaw in IDLING_AREAS),
        f"drift: {_flow(DRIFT)}",
        f"amcl_initial_pose: [{', '.join(repr(value) for value in AMCL_INITIAL_POSE)}]",
        "walker_routes:",
        *(f"  - {{name: {name}, weight: {weight}, waypoints: "
          f"[{', '.join(f'[{x!r}, {y!r}]' for x, y in points)}]}}"
          for name, weight, points in WALKER_ROUTES),
        "walkers:",
        *(f"  - {{route: {route}, start: {start}, speed: {speed!r}}}"
          for route, start, speed in SHIPPED_WALKERS),
    ]
    return "\n".join(lines) + "\n"


def _flow(mapping: Mapping[str, object]) -> str:
    """A one-line YAML flow mapping of plain names and numbers."""
    return "{" + ", ".join(f"{key}: {value}" for key, value in mapping.items()) + "}"


def write_world(directory: Path, *, closed_doors: bool = False) -> list[Path]:
    """Write map.pgm, map.yaml and world.yaml into ``directory``; return their paths.

    ``closed_doors``: the variant with the doors the shipped world had shut."""
    directory.mkdir(parents=True, exist_ok=True)
    closed = CLOSED_IN_SHIPPED if closed_doors else frozenset()
    files = {
        "map.pgm": pgm_bytes(rasterise(closed)),
        "map.yaml": map_yaml().encode("utf-8"),
        "world.yaml": world_yaml(closed_doors=closed_doors).encode("utf-8"),
    }
    written = []
    for name, content in files.items():
        path = directory / name
        path.write_bytes(content)
        written.append(path)
    return written


class OneLineArgumentParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog="python -m servicesim_sim.world.office",
                                     description="Regenerate the office world's files.")
    parser.add_argument("--out", type=Path, default=DEFAULT_WORLD.parent,
                        help="directory to write into (default: the package's worlds/office)")
    parser.add_argument("--closed-doors", action="store_true",
                        help="shut the doors the original's shipped world had shut (the rooms "
                             "with no target area)")
    args = parser.parse_args(argv)
    try:
        written = write_world(args.out, closed_doors=args.closed_doors)
    except OSError as error:
        print(f"{parser.prog}: error: {args.out}: {error.strerror or error}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
