"""The guest as the robot's sensors meet it: the names an RFID reading carries (:data:`GUEST`,
:data:`OTHER`), readings along a drive at the robot's speed (:func:`drive`), and an approach
goal checked against the guest (:func:`check_approach`)."""

from __future__ import annotations

import itertools
import math

from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.guest_localisation import RfidHistory, RfidReading
from bt_servicesim.planning.occupancy import OccupancyGrid2D

GUEST = "human_20843"
OTHER = "human_99999"
RFID_RANGE = 2.0
SPEED = 0.5  # m/s, the robot's navigation limit
RFID_PERIOD = 0.1  # s between RFID messages


def drive(history: RfidHistory, path: list[tuple[float, float]], guest: tuple[float, float],
          *, start: float = 0.0, stop_on_hearing: bool = False) -> float:
    """Drive ``path`` (straight legs) at SPEED, hearing the guest within RFID_RANGE every
    RFID_PERIOD, as the simulator's sensor does; returns the time.

    With ``stop_on_hearing`` the drive ends at the first reading naming the guest, as
    exploration does."""
    now = start
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        steps = max(1, round(math.dist((x0, y0), (x1, y1)) / (SPEED * RFID_PERIOD)))
        for k in range(steps + 1):
            x, y = x0 + (x1 - x0) * k / steps, y0 + (y1 - y0) * k / steps
            heard = math.dist((x, y), guest) <= RFID_RANGE
            history.add(RfidReading(now, x, y, frozenset({GUEST, OTHER} if heard else {OTHER})))
            now += RFID_PERIOD
            if heard and stop_on_hearing:
                return now
    return now


def check_approach(goal: Pose2D | None, grid: OccupancyGrid2D, robot: Pose2D,
                   guest: tuple[float, float]) -> None:
    """The approach goal puts the robot within pick-up reach of the guest without crowding
    them, on free space it can reach, facing them."""
    assert goal is not None
    to_guest = math.dist((goal.x, goal.y), guest)
    assert 0.75 < to_guest <= 1.8, f"goal {goal} is {to_guest:.2f} m from the guest"
    assert grid.is_free(goal.x, goal.y, 0.35)
    assert grid.reachable_from(robot.x, robot.y, 0.35)[grid.world_to_cell(goal.x, goal.y)]
    facing = math.atan2(guest[1] - goal.y, guest[0] - goal.x)
    assert abs(math.remainder(goal.yaw - facing, 2.0 * math.pi)) < math.pi / 2.0
