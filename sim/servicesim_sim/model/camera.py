"""The robot's front camera: a cheap pinhole picture of walls, floor, ceiling and people.

The original robot carried a 640x480 rgb8 camera with a 1.0629 rad horizontal field of view
at 24 frames a sim second, and OSRF's later example found a lost guest in it as a blue shirt
over red trousers, judging distance as 550·1.5 / (blob height in pixels). This camera keeps
exactly what that needs and little else:

* A pinhole model at the robot's origin, facing its yaw, 1.0 m above the floor, square pixels
  (fx = fy = (width / 2) / tan(hfov / 2), about 545 at the defaults).
* Walls by ray casting on the occupancy map, one ray per group of columns, grey shaded by
  distance; floor and ceiling are flat colours. Unknown cells and the map's edge are walls.
* People as flat figures (head, shirt, trousers) drawn far to near, each column only where the
  figure is nearer than that column's wall, so someone behind a wall is hidden.
  Trousers and shirt together are 1.5 m tall. The guest wears a blue shirt over red trousers;
  everyone else gets colours chosen from their name, never a blue shirt and never red trousers,
  so the guest's combination is theirs alone.

A :class:`FrontCamera` keeps what depends only on the map; :func:`render_front_camera` is the
one-call form and reuses the camera of the last map it was given.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # the argument parser reads this module's rate: no map, no scipy
    from servicesim_sim.world.files import OccupancyMap

WIDTH = 640
HEIGHT = 480
HFOV = 1.0629  # radians
RATE_HZ = 24.0  # the original's FrontCamera update_rate (servicebot.urdf)
CAMERA_HEIGHT = 1.0  # metres above the floor
WALL_HEIGHT = 2.5
COLUMNS_PER_RAY = 4
MAX_RANGE = 40.0  # metres; a ray that hits nothing sees a wall this far away
MARCH_CHUNK = 160  # samples per ray marched at a time
NEAREST_FIGURE = 0.2  # metres; nearer people are not drawn

# A figure, bottom to top, in metres: (name of part, bottom, top, width)
TROUSERS = ("trousers", 0.0, 0.8, 0.34)
SHIRT = ("shirt", 0.8, 1.5, 0.46)
HEAD = ("head", 1.52, 1.75, 0.2)
WIDEST_PART = max(TROUSERS[3], SHIRT[3], HEAD[3])

Colour = tuple[int, int, int]
CEILING: Colour = (214, 212, 204)
FLOOR: Colour = (126, 116, 100)
WALL: Colour = (190, 186, 176)
SKIN: Colour = (222, 184, 150)
GUEST_SHIRT: Colour = (20, 40, 230)  # blue
GUEST_TROUSERS: Colour = (210, 25, 25)  # red
OTHER_SHIRTS: tuple[Colour, ...] = (
    (60, 150, 70), (232, 200, 60), (236, 236, 232), (110, 110, 112),
    (232, 132, 40), (140, 92, 52), (180, 70, 150), (30, 120, 110))
OTHER_TROUSERS: tuple[Colour, ...] = (
    (38, 38, 44), (92, 92, 100), (190, 170, 128), (72, 98, 66), (58, 76, 122), (112, 84, 60))

Pose = tuple[float, float, float]
PersonState = tuple[str, str, float, float]  # (name, role, x, y)



def outfit(name: str, *, guest_name: str) -> tuple[Colour, Colour]:
    """(shirt, trousers) colours: blue over red for the guest, from the name for anyone else."""
    if name == guest_name:
        return GUEST_SHIRT, GUEST_TROUSERS
    code = zlib.crc32(name.encode())
    return (OTHER_SHIRTS[code % len(OTHER_SHIRTS)],
            OTHER_TROUSERS[(code // len(OTHER_SHIRTS)) % len(OTHER_TROUSERS)])


@dataclass
class FrontCamera:
    """A pinhole camera rendering one occupancy map at a fixed image size."""

    occupancy_map: OccupancyMap
    width: int = WIDTH
    height: int = HEIGHT
    hfov: float = HFOV
    _walls: np.ndarray = field(init=False, repr=False)
    _walls_flat: np.ndarray = field(init=False, repr=False)
    _focal_length: float = field(init=False, repr=False)
    _ray_angles: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.width < COLUMNS_PER_RAY or self.height < 2 or not 0.0 < self.hfov < math.pi:
            raise ValueError(f"camera {self.width}x{self.height}, hfov {self.hfov}: "
                             "needs at least 4x2 pixels and 0 < hfov < pi")
        blocked = np.asarray(self.occupancy_map.blocked_mask(), dtype=bool)
        self._walls = np.pad(blocked, 1, constant_values=True)  # the map's edge is a wall
        self._walls_flat = self._walls.ravel()  # one flat lookup costs a third of a 2-D one
        self._focal_length = (self.width / 2.0) / math.tan(self.hfov / 2.0)
        centres = np.arange(0, self.width, COLUMNS_PER_RAY) + COLUMNS_PER_RAY / 2.0
        self._ray_angles = np.arctan((self.width / 2.0 - centres) / self.focal_length)

    @property
    def focal_length(self) -> float:
        """fx = fy in pixels (worked out once, with the rays)."""
        return self._focal_length

    def render(self, *, robot: Pose, people: Sequence[PersonState],
               guest_name: str) -> np.ndarray:
        """The picture seen from ``robot`` (x, y, yaw): uint8, (height, width, 3), rgb8."""
        depths, along_x = self._cast(robot)
        image = np.empty((self.height, self.width, 3), dtype=np.uint8)
        self._draw_room(image, depths, along_x)
        column_depths = np.repeat(depths, COLUMNS_PER_RAY)[:self.width]
        for depth, lateral, name in self._people_in_front(robot, people):
            self._draw_figure(image, column_depths, depth=depth, lateral=lateral,
                              outfit=outfit(name, guest_name=guest_name))
        return image

    # ------------------------------------------------------------------ walls
    def wall_depths(self, robot: Pose) -> np.ndarray:
        """Forward depth (metres along the optical axis) of the wall seen by each ray."""
        return self._cast(robot)[0]

    def _cast(self, robot: Pose) -> tuple[np.ndarray, np.ndarray]:
        """Each ray's wall depth, and whether it met a wall face running along x."""
        x, y, yaw = robot
        cos, sin = np.cos(yaw + self._ray_angles), np.sin(yaw + self._ray_angles)
        resolution = self.occupancy_map.resolution
        start_col = (x - self.occupancy_map.origin_x) / resolution + 1.0  # +1: the padding
        start_row = (y - self.occupancy_map.origin_y) / resolution + 1.0
        ranges = np.full(self._ray_angles.size, MAX_RANGE / resolution)
        along_x = np.zeros(self._ray_angles.size, dtype=bool)
        pending = np.arange(self._ray_angles.size)
        done = 0.0
        while pending.size and done * resolution < MAX_RANGE:
            along = done + np.arange(1, MARCH_CHUNK + 1, dtype=float)  # cells; one per sample
            rows = self._cells(start_row + sin[pending, None] * along, self._walls.shape[0])
            cols = self._cells(start_col + cos[pending, None] * along, self._walls.shape[1])
            hits = self._walls_flat[rows * self._walls.shape[1] + cols]  # as _walls[rows, cols]
            found = np.flatnonzero(hits.any(axis=1))
            first = hits[found].argmax(axis=1)
            rays = pending[found]
            ranges[rays], along_x[rays] = self._entry(
                origin=(start_row, start_col), direction=(sin[rays], cos[rays]),
                last=along[first], hit=(rows[found, first], cols[found, first]))
            pending, done = np.delete(pending, found), done + MARCH_CHUNK
        depths = np.clip(ranges * resolution, resolution, MAX_RANGE) * np.cos(self._ray_angles)
        return depths, along_x

    def _entry(self, *, origin: tuple[float, float], direction: tuple[np.ndarray, np.ndarray],
               last: np.ndarray, hit: tuple[np.ndarray, np.ndarray],
               ) -> tuple[np.ndarray, np.ndarray]:
        """Where rays enter a wall (in cells) and whether through a face running along x.

        The sample one cell before ``last`` was free and the one at ``last`` lies in the wall
        cell ``hit``; in between a ray crosses at most one row and one column boundary, so it
        passes at most one cell between them, and that cell decides which crossing is the entry.
        ``origin`` and ``hit`` are (row, col) in padded-grid units, ``direction`` (sin, cos).
        """
        (row0, col0), (sin, cos), (hit_row, hit_col) = origin, direction, hit
        prev_row = self._cells(row0 + sin * (last - 1.0), self._walls.shape[0])
        prev_col = self._cells(col0 + cos * (last - 1.0), self._walls.shape[1])
        with np.errstate(divide="ignore", invalid="ignore"):
            row_cross = np.where(prev_row != hit_row,
                                 (np.maximum(prev_row, hit_row) - row0) / sin, -np.inf)
            col_cross = np.where(prev_col != hit_col,
                                 (np.maximum(prev_col, hit_col) - col0) / cos, -np.inf)
        row_first = row_cross < col_cross
        between = self._walls[np.where(row_first, hit_row, prev_row),
                              np.where(row_first, prev_col, hit_col)]
        both = (prev_row != hit_row) & (prev_col != hit_col)
        early = both & between
        entry = np.where(early, np.minimum(row_cross, col_cross),
                         np.maximum(row_cross, col_cross))
        along_x = np.where(early, row_first, row_cross > col_cross)
        return np.clip(entry, 0.0, last), along_x

    @staticmethod
    def _cells(coordinates: np.ndarray, size: int) -> np.ndarray:
        """Padded-grid indices; anything off the map lands on the wall of padding."""
        cells: NDArray[np.intp] = np.clip(coordinates, 0, size - 1).astype(np.intp)
        return cells

    def _draw_room(self, image: np.ndarray, depths: np.ndarray, along_x: np.ndarray) -> None:
        """Ceiling above the horizon, floor below, and each ray's wall over both, from its
        top to its bottom row.

        A ray's wall spans the horizon (its top lies above it, its bottom below), so each
        ray's columns are three runs: ceiling, wall, floor. Every pixel is looked up at once
        from a palette of the rays' three colours, each as wide as a ray: drawn a run at a
        time, a frame would pay numpy's per-call costs hundreds of times.
        """
        height, rays = self.height, depths.size
        fx, centre = self.focal_length, height / 2.0
        tops = np.clip(np.rint(centre - fx * (WALL_HEIGHT - CAMERA_HEIGHT) / depths), 0,
                       height).astype(int)
        bottoms = np.clip(np.rint(centre + fx * CAMERA_HEIGHT / depths), 0,
                          height).astype(int)
        shade = np.clip(1.0 - depths / 30.0, 0.35, 1.0) * np.where(along_x, 0.86, 1.0)
        colours = shade[:, None] * np.asarray(WALL, dtype=float)
        palette = np.empty((rays, 3, COLUMNS_PER_RAY, 3), dtype=np.uint8)
        palette[:, 0] = CEILING
        palette[:, 1] = colours[:, None, :]  # cast to uint8 as drawing a ray's run casts it
        palette[:, 2] = FLOOR
        rows = np.arange(height)[:, None]
        runs = (rows >= tops).astype(np.intp) + (rows >= bottoms)  # 0, 1, 2: which run
        runs += np.arange(rays) * 3
        drawn = image if rays * COLUMNS_PER_RAY == self.width else np.empty(
            (height, rays * COLUMNS_PER_RAY, 3), dtype=np.uint8)
        np.take(palette.reshape(rays * 3, -1), runs, axis=0,
                out=drawn.reshape(height, rays, -1))
        if drawn is not image:
            image[...] = drawn[:, :self.width]

    # ------------------------------------------------------------------ people
    @staticmethod
    def _people_in_front(robot: Pose,
                         people: Sequence[PersonState]) -> list[tuple[float, float, str]]:
        """(forward depth, leftward offset, name) of people ahead of the camera, far first."""
        x, y, yaw = robot
        cos, sin = math.cos(yaw), math.sin(yaw)
        ahead = []
        for name, _role, px, py in people:
            dx, dy = px - x, py - y
            depth = dx * cos + dy * sin
            if depth >= NEAREST_FIGURE:
                ahead.append((depth, -dx * sin + dy * cos, name))
        return sorted(ahead, reverse=True)

    def _draw_figure(self, image: np.ndarray, column_depths: np.ndarray, *, depth: float,
                     lateral: float, outfit: tuple[Colour, Colour]) -> None:
        """The figure's parts, each in the columns where its wall lies behind it; nothing
        when no column of its widest part does (the others' columns lie within those)."""
        shirt, trousers = outfit
        scale = self.focal_length / depth
        middle = self.width / 2.0 - lateral * scale
        left, right = self._columns(middle=middle, scale=scale, width=WIDEST_PART)
        if left >= right or not (column_depths[left:right] > depth).any():
            return
        for (_part, bottom, top, width), colour in ((TROUSERS, trousers), (SHIRT, shirt),
                                                    (HEAD, SKIN)):
            self._draw_part(image, column_depths, depth=depth, middle=middle, scale=scale,
                            span=(bottom, top, width), colour=colour)

    def _columns(self, *, middle: float, scale: float, width: float) -> tuple[int, int]:
        """The image columns [left, right) of a part ``width`` metres wide centred on column
        ``middle``, ``scale`` pixels to the metre."""
        return (max(0, round(middle - width / 2.0 * scale)),
                min(self.width, round(middle + width / 2.0 * scale)))

    def _draw_part(self, image: np.ndarray, column_depths: np.ndarray, *, depth: float,
                   middle: float, scale: float, span: tuple[float, float, float],
                   colour: Colour) -> None:
        bottom, top, width = span
        left, right = self._columns(middle=middle, scale=scale, width=width)
        upper = max(0, round(self.height / 2.0 - (top - CAMERA_HEIGHT) * scale))
        lower = min(self.height, round(self.height / 2.0 - (bottom - CAMERA_HEIGHT) * scale))
        if left >= right or upper >= lower:
            return
        seen = column_depths[left:right] > depth
        image[upper:lower, left:right][:, seen] = colour


_last_camera: list[FrontCamera] = []


def render_front_camera(*, robot: Pose, people: Sequence[PersonState], guest_name: str,
                        occupancy_map: OccupancyMap, width: int = WIDTH,
                        height: int = HEIGHT, hfov: float = HFOV) -> np.ndarray:
    """The front camera's picture (uint8, (height, width, 3), rgb8) from ``robot`` (x, y, yaw).

    ``people`` are (name, role, x, y); the one called ``guest_name`` wears blue over red.
    """
    camera = _last_camera[0] if _last_camera else None
    if camera is None or (camera.occupancy_map is not occupancy_map or camera.width != width
                          or camera.height != height or camera.hfov != hfov):
        camera = FrontCamera(occupancy_map, width=width, height=height, hfov=hfov)
        _last_camera[:] = [camera]
    return camera.render(robot=robot, people=people, guest_name=guest_name)
