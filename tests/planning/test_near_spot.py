"""As near to an unreachable waypoint as the way allows: a room shut by people in its door.

The map is :func:`tests.planning.test_give_way.office`: a 1.6 m corridor along x (y = 4.0 .. 5.6)
with a room to the north (x = 7 .. 13, y = 5.8 .. 9.0) behind a 1.1 m door (x = 9.45 .. 10.55).
The robot stands in the corridor east of the door; a walker stands in the doorway, as two of the
office's walkers who meet head-on there stand for good.
"""

from __future__ import annotations

import math

import numpy as np

from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.near_spot import NEAR_PEOPLE_KEEP, near_spot
from bt_servicesim.planning.rules import RFID_RANGE
from tests.planning.test_give_way import office

ROBOT = Pose2D(14.0, 4.8, math.pi)
IN_THE_DOOR = np.array([[10.0, 5.7]])
IN_THE_ROOM = (11.0, 7.0)


def test_a_waypoint_in_a_room_shut_by_someone_in_its_door_is_heard_from_the_corridor() -> None:
    spot = near_spot(office(), robot=ROBOT, target=IN_THE_ROOM, people=IN_THE_DOOR)
    assert spot is not None
    assert 4.0 < spot.y < 5.6, "in the corridor, behind the room's wall"
    distance = math.dist((spot.x, spot.y), IN_THE_ROOM)
    assert distance <= RFID_RANGE
    assert distance < 1.9  # the corridor's edge under the waypoint: 7.0 - (5.6 - 0.35)
    assert math.dist((spot.x, spot.y), tuple(IN_THE_DOOR[0])) >= NEAR_PEOPLE_KEEP
    assert abs(math.atan2(IN_THE_ROOM[1] - spot.y, IN_THE_ROOM[0] - spot.x) - spot.yaw) < 1e-6


def test_with_nobody_in_the_way_the_waypoint_itself_is_the_spot() -> None:
    spot = near_spot(office(), robot=ROBOT, target=IN_THE_ROOM)
    assert spot is not None
    assert math.dist((spot.x, spot.y), IN_THE_ROOM) < 0.05


def test_a_waypoint_beyond_rfid_range_of_anywhere_reachable_has_no_spot() -> None:
    deep = (11.0, 8.5)  # 3.25 m from the nearest reachable corridor cell
    assert near_spot(office(), robot=ROBOT, target=deep, people=IN_THE_DOOR) is None


def test_the_spot_keeps_clear_of_someone_standing_beside_the_waypoint() -> None:
    beside = np.array([[12.0, 4.8]])  # in the corridor, where the spot would otherwise be
    target = (12.0, 6.2)
    spot = near_spot(office(room=False), robot=ROBOT, target=target, people=beside)
    assert spot is not None
    assert math.dist((spot.x, spot.y), (12.0, 4.8)) >= NEAR_PEOPLE_KEEP
    assert math.dist((spot.x, spot.y), target) <= RFID_RANGE


def test_no_route_to_the_spot_squeezes_between_two_people_who_wait_for_each_other() -> None:
    """Two walkers 1.5 m apart across the corridor: the gap between them would let the robot's
    centre pass 0.75 m from each, and there it would stand held up by them, as they by it."""
    pair = np.array([[12.0, 4.05], [12.0, 5.55]])
    beyond = (11.0, 4.8)  # just west of the pair, along the corridor
    spot = near_spot(office(room=False), robot=ROBOT, target=beyond, people=pair)
    assert spot is not None
    assert spot.x > 12.0, "on the robot's side of the pair"
    assert min(math.dist((spot.x, spot.y), tuple(person)) for person in pair) >= NEAR_PEOPLE_KEEP
