"""The doorways near a box: where a guest left standing in the box could shut a door.

A dropped-off guest stands where they stopped, for good, and a walker who meets anyone in its
lane waits as long as they stand (the original's ``TrajectoryActorPlugin``). A guest left just
inside a door therefore holds the next walker bound through it in the doorway, and the robot,
still inside, cannot leave (hard seed 4 of the evaluation: the guest left 1.3 m inside the
office cafe's only door). :func:`doorways_near` finds the doorways of the map within
:data:`~bt_servicesim.planning.goals.DOORWAY_KEEP` of a box, so the drop-off goal can leave the
guest clear of them.

Pure: numpy and the occupancy grid, no ROS, no py_trees.
"""

from __future__ import annotations

import math

import numpy as np

from bt_servicesim.planning.geometry import Box, Point
from bt_servicesim.planning.give_way import DOORWAY_WIDTH, doorway
from bt_servicesim.planning.goals import DOORWAY_KEEP, distance_to_box
from bt_servicesim.planning.occupancy import OccupancyGrid2D

__all__ = ["doorways_near"]

PROBE_SPACING = 0.2
"""Metres between the points probed for a doorway (narrower than any door's half-width)."""
MIN_HALF_WIDTH = 0.3
"""Metres of clearance below which a probe stands beside a jamb rather than in a doorway's
middle (a door is at least 0.6 m wide for a person to walk through)."""
SAME_DOORWAY = 0.6
"""Metres within which two doorway centres found are the same doorway."""
MIDDLE_CLEARANCE = 0.8
"""Share of half a doorway's width that its middle keeps from every wall: between two jambs
the nearest walls are the jambs, while two walls meeting at a corner, which also face each
other across a narrow gap, leave the middle of that gap near the corner."""


def doorways_near(grid: OccupancyGrid2D, box: Box) -> list[Point]:
    """Centres of the map's doorways (openings at most
    :data:`~bt_servicesim.planning.give_way.DOORWAY_WIDTH` wide between facing jambs, with room
    on both sides) within :data:`~bt_servicesim.planning.goals.DOORWAY_KEEP` of ``box``.

    Probed on a :data:`PROBE_SPACING` lattice over the box grown by that distance, at the
    points whose clearance from walls is that of a doorway's middle; an opening whose middle
    lies nearer a wall than its jambs (:data:`MIDDLE_CLEARANCE`) is a corner, not a doorway.
    """
    xs = np.arange(box.min_x - DOORWAY_KEEP, box.max_x + DOORWAY_KEEP + 1e-9, PROBE_SPACING)
    ys = np.arange(box.min_y - DOORWAY_KEEP, box.max_y + DOORWAY_KEEP + 1e-9, PROBE_SPACING)
    px, py = (grid_xy.ravel() for grid_xy in np.meshgrid(xs, ys))
    clearance = grid.clearances_at(px, py)
    middle = (clearance >= MIN_HALF_WIDTH) & (clearance <= DOORWAY_WIDTH / 2.0)
    found: list[Point] = []
    for x, y in zip(px[middle], py[middle], strict=True):
        opening = doorway(grid, float(x), float(y))
        if opening is None or float(distance_to_box(box, opening.x, opening.y)) > DOORWAY_KEEP:
            continue
        if grid.clearance(opening.x, opening.y) < MIDDLE_CLEARANCE * opening.width / 2.0:
            continue  # a corner
        if all(math.dist((opening.x, opening.y), other) > SAME_DOORWAY for other in found):
            found.append((opening.x, opening.y))
    return found

