"""Maps and costmaps made up for a test: :func:`grid_message`, :func:`cells`, :func:`fill`,
:func:`open_room`, and :func:`costmap_of` (navigation's costmap with people on it)."""

from __future__ import annotations

import numpy as np
from nav_msgs.msg import OccupancyGrid

from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import Costmap2D

RESOLUTION = 0.05


def grid_message(
    values: np.ndarray, resolution: float = RESOLUTION, origin: tuple[float, float] = (0.0, 0.0)
) -> OccupancyGrid:
    """A message whose row 0 lies at origin y, as the map topic has it."""
    message = OccupancyGrid()
    message.header.frame_id = "map"
    message.info.resolution = resolution
    message.info.height, message.info.width = values.shape
    message.info.origin.position.x, message.info.origin.position.y = origin
    message.data = values.astype(np.int8).ravel().tolist()
    return message


def cells(width_m: float, height_m: float) -> np.ndarray:
    """A free grid of ``width_m`` x ``height_m`` at :data:`RESOLUTION`."""
    return np.zeros((round(height_m / RESOLUTION), round(width_m / RESOLUTION)), dtype=np.int8)


def fill(values: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int = 100) -> None:
    """Mark the cells of the rectangle [x0, x1] x [y0, y1] (origin at 0, 0)."""
    values[round(y0 / RESOLUTION):round(y1 / RESOLUTION),
           round(x0 / RESOLUTION):round(x1 / RESOLUTION)] = value


def costmap_of(grid: OccupancyGrid2D, people: list[tuple[float, float]], *,
               stamp_s: float = 0.0) -> Costmap2D:
    """Navigation's costmap over ``grid`` as the simulator draws it: walls lethal, each person
    lethal within 0.3 m of their centre and inscribed (99) out to 0.55 m."""
    xs = grid.origin_x + (np.arange(grid.width) + 0.5) * grid.resolution
    ys = grid.origin_y + (np.arange(grid.height) + 0.5) * grid.resolution
    gx, gy = np.meshgrid(xs, ys)
    values = np.where(grid.values >= 100, 100, 0).astype(np.int8)
    for px, py in people:
        gap = np.hypot(gx - px, gy - py)
        values = np.where(gap <= 0.55, np.maximum(values, 99), values)
        values = np.where(gap <= 0.3, 100, values)
    return Costmap2D(values=values.astype(np.int8), origin_x=grid.origin_x,
                     origin_y=grid.origin_y, resolution=grid.resolution, stamp_s=stamp_s)


def open_room(size: float = 14.0) -> OccupancyGrid2D:
    """A square room with 0.1 m walls round it."""
    values = cells(size, size)
    for wall in ((0, 0, size, 0.1), (0, size - 0.1, size, size),
                 (0, 0, 0.1, size), (size - 0.1, 0, size, size)):
        fill(values, *wall)
    return OccupancyGrid2D.from_message(grid_message(values))
