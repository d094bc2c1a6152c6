"""Find the guest in the front camera's picture: a blue shirt directly over red trousers.

OSRF's later ServiceSim example (release 0.3.x) re-acquired a lost guest with the robot's
front camera: the guest wears a blue shirt over red trousers, a combination nobody else wears,
and the height of that blob in pixels gives the distance (550 · 1.5 m / height, 550 px being
that camera's focal length and 1.5 m the height of shirt and trousers together). This module
does the same with numpy alone, as a camera pipeline on a real robot would, not by exact
colours:

- colours are judged in HSV: a pixel is *blue* or *red* by its hue, with a saturation and a
  value that rule out greys, skin, walls, floor and dark shadow (:data:`BLUE_HUES`,
  :data:`RED_HUES`, :data:`MIN_SATURATION`, :data:`MIN_VALUE`). Shading scales value, not hue
  or saturation, so a shaded shirt is still blue;
- the blue pixels are grouped into runs of columns (a person partly hidden behind another is
  two runs); a run is the guest when red begins right below its blue
  (:data:`MAX_GAP_SHARE` of the shirt's height at most) and both are big enough
  (:data:`MIN_PART_PX`): blue trousers under another shirt, or a blue thing with nothing red
  below, are someone or something else;
- the bearing comes from the blob's centre column and the focal length
  (fx = (width / 2) / tan(hfov / 2)), positive to the left as a ROS yaw; the distance from
  its height as the example's, with this camera's focal length. A blob cut off by the
  picture's edge (a guest nearer than about 2.3 m, whose trousers leave the picture at the
  bottom) looks shorter than it is, so the distance is an overestimate
  (:attr:`GuestSighting.clipped`);
- :func:`look_turns` plans a look round in steps: first towards where the guest was last
  heard, then on the same way round, each step less than the field of view, a full turn in all;
- :func:`camera_goal` turns a sighting taken from a pose into a goal :data:`STAND_OFF` short of
  the guest on the line of sight, facing them, moved to the nearest reachable free spot if
  that one is not.

Pure: numpy and the project's occupancy grid; no ROS, no py_trees.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bt_servicesim.planning.geometry import Point, Pose2D
from bt_servicesim.planning.goals import ROBOT_CLEARANCE
from bt_servicesim.planning.occupancy import OccupancyGrid2D

__all__ = [
    "GUEST_HEIGHT",
    "STAND_OFF",
    "CameraModel",
    "GuestSighting",
    "camera_goal",
    "find_guest",
    "guest_masks",
    "guest_position",
    "look_turns",
]

GUEST_HEIGHT = 1.5
"""Metres from the trousers' hems to the shirt's collar: the example's 1.5."""
STAND_OFF = 1.6
"""Metres short of the guest that the robot drives to, as the example did: within the
referee's 2.0 m pick-up reach, clear of the 0.75 m approximation zone."""
BLUE_HUES = (200.0, 260.0)
"""Degrees of hue that are the shirt's blue."""
RED_HUES = (340.0, 15.0)
"""Degrees of hue that are the trousers' red (wrapping through 0)."""
MIN_SATURATION = 0.6
"""Below this a colour is too grey to be the shirt or the trousers (denim and skin are)."""
MIN_VALUE = 0.15
"""Below this a pixel is too dark for its hue to mean anything."""
MIN_PART_PX = 4
"""Pixels the shirt and the trousers each span at least, across and down: smaller is noise
or a guest too far away to be told apart (about 30 m)."""
MAX_GAP_SHARE = 0.15
"""The most rows between shirt and trousers, as a share of the shirt's height (a belt)."""
COLUMN_GAP = 2
"""Columns without blue that still join two runs of blue into one."""
MAX_SIGHTING_DISTANCE = 30.0
"""Metres: a farther estimate is noise (the lidar's reach)."""
BYSTANDER_BERTH = 1.0
"""Metres the goal keeps from anyone else standing near the guest (centre to centre: the
referee books approximation within 0.75 m of the robot's body)."""
GOAL_SLACK = 0.6
"""Metres the goal may move from the line of sight to free floor clear of bystanders."""


@dataclass(frozen=True)
class CameraModel:
    """A pinhole camera: image size and horizontal field of view (the original's defaults)."""

    width: int = 640
    height: int = 480
    hfov: float = 1.0629

    @property
    def focal_length(self) -> float:
        """fx = fy in pixels."""
        return (self.width / 2.0) / math.tan(self.hfov / 2.0)


@dataclass(frozen=True)
class GuestSighting:
    """The guest in one picture: where they stand from the camera, and the blob seen."""

    bearing: float
    """Radians from the optical axis, positive to the left."""
    distance: float
    """Metres from the camera to the guest (along the line of sight)."""
    column: float
    """The blob's centre column, in pixels from the left edge."""
    height_px: int
    """The blob's height: from the shirt's top row to the trousers' bottom row."""
    clipped: bool
    """Whether the blob touches the picture's top or bottom edge (distance overestimated)."""


def guest_masks(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(blue, red) boolean masks of an RGB image (height, width, 3) of uint8, by HSV.

    The hue ranges are tested in integers, without computing the hue itself: where blue is
    the largest channel the hue is 240 + 60 (r - g) / (max - min) degrees, where red is, it is
    60 (g - b) / (max - min) (modulo 360), so each range is a pair of linear inequalities.
    """
    pixels = np.asarray(image)
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        raise ValueError(f"an RGB image has shape (height, width, 3), not {pixels.shape}")
    red, green, blue = (pixels[..., channel].astype(np.int16) for channel in range(3))
    high = np.maximum(np.maximum(red, green), blue)
    spread = high - np.minimum(np.minimum(red, green), blue)
    coloured = ((high >= round(MIN_VALUE * 255.0)) & (spread > 0)
                & (spread * 100 >= round(MIN_SATURATION * 100) * high))
    is_blue = coloured & (blue == high) & _within(red - green, spread,
                                                  (BLUE_HUES[0] - 240.0) / 60.0,
                                                  (BLUE_HUES[1] - 240.0) / 60.0)
    is_red = coloured & (red == high) & _within(green - blue, spread,
                                                (RED_HUES[0] - 360.0) / 60.0, RED_HUES[1] / 60.0)
    return is_blue, is_red


def _within(difference: np.ndarray, spread: np.ndarray, low: float, high: float) -> np.ndarray:
    """Where low <= difference / spread <= high, in integers (spread > 0; bounds to 1/120)."""
    scaled = difference * 120
    inside: np.ndarray = (scaled >= round(low * 120) * spread) & (scaled <= round(high * 120)
                                                                  * spread)
    return inside


def find_guest(image: np.ndarray, camera: CameraModel | None = None) -> GuestSighting | None:
    """The guest's blob in ``image`` (RGB, uint8, (height, width, 3)), nearest first; None if
    there is no blue shirt over red trousers big enough to be sure."""
    camera = camera if camera is not None else CameraModel(
        width=int(np.asarray(image).shape[1]), height=int(np.asarray(image).shape[0]))
    blue, red = guest_masks(image)
    best: GuestSighting | None = None
    for first, last in _column_runs(blue.sum(axis=0) >= MIN_PART_PX):
        sighting = _sighting_in(blue[:, first:last + 1], red[:, first:last + 1],
                                first=first, camera=camera)
        if sighting is not None and (best is None or sighting.height_px > best.height_px):
            best = sighting
    return best


def _column_runs(columns: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) of each run of True columns at least MIN_PART_PX wide, short gaps bridged."""
    runs: list[tuple[int, int]] = []
    for index in np.flatnonzero(columns):
        column = int(index)
        if runs and column - runs[-1][1] <= COLUMN_GAP + 1:
            runs[-1] = (runs[-1][0], column)
        else:
            runs.append((column, column))
    return [(first, last) for first, last in runs if last - first + 1 >= MIN_PART_PX]


def _sighting_in(blue: np.ndarray, red: np.ndarray, *, first: int,
                 camera: CameraModel) -> GuestSighting | None:
    """The guest in one run of columns (``blue`` and ``red`` cut to it), if red lies below blue."""
    width = blue.shape[1]
    shirt = _row_span(blue.sum(axis=1) >= max(1.0, 0.3 * width))
    if shirt is None or shirt[1] - shirt[0] + 1 < MIN_PART_PX:
        return None
    red_rows = red.sum(axis=1) >= max(1.0, 0.2 * width)
    gap = max(2, math.ceil(MAX_GAP_SHARE * (shirt[1] - shirt[0] + 1)))
    below = red_rows[shirt[1] + 1:shirt[1] + 2 + gap]
    if not below.any():
        return None
    top_of_trousers = shirt[1] + 1 + int(np.argmax(below))
    trousers = _row_span(red_rows[top_of_trousers:])
    assert trousers is not None  # top_of_trousers is a red row
    bottom = top_of_trousers + trousers[1]
    if trousers[1] + 1 < MIN_PART_PX or int(red[top_of_trousers:bottom + 1].any(axis=0).sum()) \
            < MIN_PART_PX:
        return None
    _, columns = np.nonzero(blue[shirt[0]:shirt[1] + 1])
    column = first + float(columns.mean()) + 0.5
    height = bottom - shirt[0] + 1
    return _measure(camera, column=column, height=height,
                    clipped=shirt[0] == 0 or bottom == red.shape[0] - 1)


def _row_span(rows: np.ndarray) -> tuple[int, int] | None:
    """(first, last) of the first run of True rows, gaps of a row or two bridged; None if none."""
    marked = np.flatnonzero(rows)
    if marked.size == 0:
        return None
    breaks = np.flatnonzero(np.diff(marked) > 3)
    last = marked[breaks[0]] if breaks.size else marked[-1]
    return int(marked[0]), int(last)


def _measure(camera: CameraModel, *, column: float, height: int,
             clipped: bool) -> GuestSighting | None:
    """Bearing from the column, distance from the height (the pinhole's depth, along the ray)."""
    focal = camera.focal_length
    bearing = math.atan((camera.width / 2.0 - column) / focal)
    distance = focal * GUEST_HEIGHT / height / math.cos(bearing)
    if distance > MAX_SIGHTING_DISTANCE:
        return None
    return GuestSighting(bearing=bearing, distance=distance, column=column, height_px=height,
                         clipped=clipped)


def guest_position(robot: Pose2D, sighting: GuestSighting) -> Point:
    """Where the guest stands in the map, seen from ``robot`` (the camera faces its yaw)."""
    heading = robot.yaw + sighting.bearing
    return (robot.x + sighting.distance * math.cos(heading),
            robot.y + sighting.distance * math.sin(heading))


def camera_goal(robot: Pose2D, sighting: GuestSighting, grid: OccupancyGrid2D, *,
                stand_off: float = STAND_OFF, bystanders: Sequence[Point] = ()) -> Pose2D | None:
    """A goal ``stand_off`` short of the guest on the line of sight, facing them.

    A guest already within ``stand_off`` gives the robot's own spot, turned to them. A goal
    that is not free with the robot's clearance, or lies within :data:`BYSTANDER_BERTH` of
    someone else near the guest (``bystanders``, from the costmap), moves to the nearest
    reachable spot that is, within :data:`GOAL_SLACK`; None if there is none.
    """
    gx, gy = guest_position(robot, sighting)
    heading = robot.yaw + sighting.bearing
    ahead = sighting.distance - stand_off
    if ahead <= 0.0:
        return Pose2D(robot.x, robot.y, heading)
    x, y = robot.x + ahead * math.cos(heading), robot.y + ahead * math.sin(heading)
    allowed = grid.reachable_from(robot.x, robot.y, ROBOT_CLEARANCE)
    if bystanders:
        allowed = _clear_of(grid, allowed, bystanders)
    spot = grid.nearest_free(x, y, clearance=ROBOT_CLEARANCE, max_radius=GOAL_SLACK,
                             within=allowed)
    if spot is None:
        return None
    return Pose2D(spot[0], spot[1], math.atan2(gy - spot[1], gx - spot[0]))


def _clear_of(grid: OccupancyGrid2D, allowed: np.ndarray, people: Sequence[Point]) -> np.ndarray:
    """``allowed`` without the cells within BYSTANDER_BERTH of any of ``people``."""
    clear = allowed.copy()
    for px, py in people:
        window = grid.window(px - BYSTANDER_BERTH, py - BYSTANDER_BERTH,
                             px + BYSTANDER_BERTH, py + BYSTANDER_BERTH)
        near = (window.xs[None, :] - px) ** 2 + (window.ys[:, None] - py) ** 2 \
            < BYSTANDER_BERTH ** 2
        clear[window.rows, window.cols] &= ~near
    return clear


def look_turns(robot: Pose2D, *, towards: Pose2D | None, step: float) -> list[float]:
    """The turns (radians, positive to the left) before each look of a full look round.

    The first faces ``towards`` (no turn without it, or when the robot stands on it); the rest
    go on the same way round in ``step``s until the looks have faced every way.
    """
    if not 0.0 < step < math.pi:
        raise ValueError(f"a look round needs a step between 0 and pi, not {step}")
    first = 0.0
    if towards is not None and math.hypot(towards.x - robot.x, towards.y - robot.y) > 0.3:
        bearing = math.atan2(towards.y - robot.y, towards.x - robot.x) - robot.yaw
        first = math.atan2(math.sin(bearing), math.cos(bearing))
    looks = math.ceil(2.0 * math.pi / step)
    return [first] + [math.copysign(step, first if first != 0.0 else 1.0)] * (looks - 1)
