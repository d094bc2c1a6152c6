"""Goal and waypoint behaviours on small synthetic maps, through their ports on the blackboard.

Each test draws a map (walls in a few rectangles), wires the behaviour's ports to blackboard
keys as the mission tree does, ticks it once and checks the result against the competition's
rules: goals free with room for the robot and reachable from it, the robot's origin inside the
pick-up box, the trailing guest inside the drop-off box, search waypoints covering the area.
"""

from __future__ import annotations

import itertools
import math
import xml.etree.ElementTree as ElementTree
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import pytest
from py_trees.blackboard import Blackboard
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

from bt_servicesim.behaviours.actions.goals import (
    DropOffGoal,
    DropOffRepositionGoal,
    ExplorationWaypoints,
    GiveWaySpot,
    GuestSearchWaypoints,
    JitterGoal,
    NearestReachableSpot,
    PickupGoal,
    ReturnGoal,
)
from bt_servicesim.behaviours.actions.next_waypoint import NextWaypoint
from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.planning.guest_localisation import RfidHistory
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.tree.loading import DEFAULT_TREE
from tests.fakes.guest import drive
from tests.fakes.leaves import wire
from tests.fakes.maps import cells, costmap_of, fill, grid_message, open_room
from tests.planning.test_give_way import ROBOT, office

Status = py_trees.common.Status
ROBOT_CLEARANCE = 0.35
TRAIL = 1.2  # the guest stops this far behind the robot
TOLERANCE = 0.3  # navigation stops within this of the goal
TREE = DEFAULT_TREE


def room_with_door() -> OccupancyGrid2D:
    """16 x 12 m; a wall at x = 8 .. 8.2 with a 1.2 m door at y = 5.0 .. 6.2."""
    values = cells(16.0, 12.0)
    fill(values, 8.0, 0.0, 8.2, 5.0)
    fill(values, 8.0, 6.2, 8.2, 12.0)
    return OccupancyGrid2D.from_message(grid_message(values))


def run(behaviour: Any, **inputs: Any) -> Any:
    """Wire every port to /<port>, put ``inputs`` there, tick once."""
    wire(behaviour, **inputs).tick_once()
    return behaviour


def output(behaviour: Any) -> Any:
    (port,) = behaviour.output_ports()
    return Blackboard.get(f"/{port}")


def depth(box: Box, x: float, y: float) -> float:
    """Signed distance to the box's boundary, positive inside."""
    return min(x - box.min_x, box.max_x - x, y - box.min_y, box.max_y - y)


def reachable(grid: OccupancyGrid2D, robot: Pose2D, x: float, y: float) -> bool:
    return bool(grid.reachable_from(robot.x, robot.y, ROBOT_CLEARANCE)[grid.world_to_cell(x, y)])


def assert_good_goal(grid: OccupancyGrid2D, robot: Pose2D, goal: Pose2D) -> None:
    assert grid.is_free(goal.x, goal.y, ROBOT_CLEARANCE), goal
    assert reachable(grid, robot, goal.x, goal.y), goal


def centred_box(width: float, height: float, centre: tuple[float, float] = (7.0, 7.0)) -> Box:
    cx, cy = centre
    return Box(cx - width / 2, cy - height / 2, cx + width / 2, cy + height / 2)


SHAPES = [(3.0, 3.0), (3.0, 1.5), (1.8, 1.5), (2.0, 1.0), (1.5, 1.8), (1.0, 2.0)]
SIDES = {"west": Pose2D(2.0, 7.0), "east": Pose2D(12.0, 7.2, math.pi),
         "south": Pose2D(7.3, 2.0, 1.6), "north": Pose2D(6.8, 12.0),
         "south-west": Pose2D(3.0, 4.0)}


# ----------------------------------------------------------------------------- pick-up
@pytest.mark.parametrize("shape", SHAPES)
def test_pickup_goal_lies_inside_the_box_for_every_shape(shape: tuple[float, float]) -> None:
    grid, robot, box = open_room(), Pose2D(2.0, 3.0), centred_box(*shape)
    goal = output(run(PickupGoal(), box=box, occupancy=grid, robot_pose=robot))
    assert_good_goal(grid, robot, goal)
    assert depth(box, goal.x, goal.y) >= TOLERANCE  # inside even if navigation stops short


@pytest.mark.parametrize("table", [None, (6.5, 6.5, 7.5, 7.5), (5.5, 6.0, 7.2, 8.0)])
def test_pickup_goal_brings_every_guest_spawn_point_into_rfid_range(
    table: tuple[float, float, float, float] | None,
) -> None:
    values = cells(14.0, 14.0)
    if table is not None:
        fill(values, *table)
    grid, robot, box = OccupancyGrid2D.from_message(grid_message(values)), Pose2D(2, 2), \
        centred_box(3.0, 3.0)
    behaviour = run(PickupGoal(), box=box, occupancy=grid, robot_pose=robot)
    goal = output(behaviour)
    assert behaviour.status == Status.SUCCESS
    assert_good_goal(grid, robot, goal)
    assert depth(box, goal.x, goal.y) >= TOLERANCE
    spawn = np.linspace(box.min_x + 1.0, box.max_x - 1.0, 11)  # 1 m padding in a 3x3 room
    farthest = max(math.dist((goal.x, goal.y), (x, y)) for x in spawn
                   for y in np.linspace(box.min_y + 1.0, box.max_y - 1.0, 11))
    assert farthest <= 2.0 - TOLERANCE
    nearest = min(math.dist((goal.x, goal.y), (x, y)) for x in spawn
                  for y in np.linspace(box.min_y + 1.0, box.max_y - 1.0, 11))
    assert nearest >= 0.5  # not driving onto a guest who may stand anywhere in the spawn area


def test_pickup_goal_stays_on_the_robot_side_facing_the_box_centre() -> None:
    grid, box = open_room(), centred_box(3.0, 3.0)
    for robot in SIDES.values():
        Blackboard.clear()
        goal = output(run(PickupGoal(), box=box, occupancy=grid, robot_pose=robot))
        robot_xy = (robot.x, robot.y)
        assert math.dist((goal.x, goal.y), robot_xy) < math.dist(box.centre, robot_xy) - 0.5
        towards_centre = math.atan2(box.centre[1] - goal.y, box.centre[0] - goal.x)
        assert abs(math.remainder(goal.yaw - towards_centre, math.tau)) < 0.05


def test_pickup_goal_only_where_the_robot_can_get() -> None:
    grid, box = room_with_door(), Box(9.0, 2.0, 12.0, 5.0)
    through_door = run(PickupGoal(), box=box, occupancy=grid, robot_pose=Pose2D(3.0, 3.0))
    assert through_door.status == Status.SUCCESS
    values = cells(16.0, 12.0)
    fill(values, 8.0, 0.0, 8.2, 12.0)  # the same wall without its door
    closed = OccupancyGrid2D.from_message(grid_message(values))
    Blackboard.clear()
    failed = run(PickupGoal(), box=box, occupancy=closed, robot_pose=Pose2D(3.0, 3.0))
    assert failed.status == Status.FAILURE
    assert failed.feedback_message == "no reachable free spot inside the pick-up box"


def test_pickup_goal_in_a_box_over_a_wall_keeps_off_the_wall() -> None:
    grid, robot, box = open_room(), Pose2D(5.0, 5.0), Box(-1.0, -1.0, 2.0, 2.0)
    goal = output(run(PickupGoal(), box=box, occupancy=grid, robot_pose=robot))
    assert_good_goal(grid, robot, goal)
    assert depth(box, goal.x, goal.y) >= TOLERANCE


def test_pickup_goal_keeps_clear_of_someone_standing_where_it_would_lie() -> None:
    """A walker standing in the pick-up box (waiting, for good, for a robot in its lane) where
    the goal would lie: the goal moves to where the box leaves a metre clear of them, still
    inside it and within reach of the guest's spawn area."""
    grid, robot, box = open_room(), Pose2D(2.0, 3.0), centred_box(3.0, 3.0)
    unseen = output(run(PickupGoal(), box=box, occupancy=grid, robot_pose=robot))
    walker = (unseen.x, unseen.y + 0.2)
    Blackboard.clear()
    behaviour = run(PickupGoal(), box=box, occupancy=grid, robot_pose=robot,
                    costmap=costmap_of(grid, [walker]))
    goal = output(behaviour)
    assert_good_goal(grid, robot, goal)
    assert depth(box, goal.x, goal.y) >= TOLERANCE
    assert math.dist((goal.x, goal.y), walker) >= 1.0
    seen = f"(1 people near: ({walker[0]:.1f}, {walker[1]:.1f}))"
    assert behaviour.feedback_message.endswith(seen)
    Blackboard.clear()
    nobody = output(run(PickupGoal(), box=box, occupancy=grid, robot_pose=robot,
                        costmap=costmap_of(grid, [])))
    assert (nobody.x, nobody.y) == (unseen.x, unseen.y)


# ----------------------------------------------------------------------------- drop-off
def trailing_spot(goal: Pose2D, short: float = 0.0) -> tuple[float, float]:
    """Where the guest stops: TRAIL behind the robot along its arrival heading (the goal's
    yaw), the robot having stopped ``short`` of the goal."""
    back = TRAIL + short
    return (goal.x - back * math.cos(goal.yaw), goal.y - back * math.sin(goal.yaw))


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("side", sorted(SIDES))
def test_drop_off_goal_leaves_the_trailing_guest_in_the_box(
    shape: tuple[float, float], side: str
) -> None:
    grid, robot, box = open_room(), SIDES[side], centred_box(*shape)
    behaviour = run(DropOffGoal(), box=box, occupancy=grid, robot_pose=robot)
    goal = output(behaviour)
    assert behaviour.status == Status.SUCCESS, behaviour.feedback_message
    assert_good_goal(grid, robot, goal)
    guest = trailing_spot(goal)
    assert depth(box, *guest) >= (0.3 if min(shape) >= 1.5 else 0.1)
    assert depth(box, *trailing_spot(goal, short=TOLERANCE)) > 0.0
    # in open space the robot drives straight at it: the guest spot lies on the robot's line
    heading = (math.cos(goal.yaw), math.sin(goal.yaw))
    to_guest = (guest[0] - robot.x, guest[1] - robot.y)
    assert abs(heading[0] * to_guest[1] - heading[1] * to_guest[0]) < 0.05
    assert heading[0] * to_guest[0] + heading[1] * to_guest[1] > 0.0


def test_drop_off_goal_keeps_clear_of_someone_standing_at_it_and_not_of_the_guest_in_tow(
) -> None:
    grid, box = open_room(), centred_box(3.0, 3.0)
    robot = Pose2D(4.0, 7.0)
    history = RfidHistory()
    drive(history, [(1.0, 7.0), (robot.x, robot.y)], guest=(40.0, 40.0))
    guest_in_tow = (robot.x - TRAIL, robot.y)
    alone = output(run(DropOffGoal(), box=box, occupancy=grid, robot_pose=robot))
    with_the_guest = run(DropOffGoal(), box=box, occupancy=grid, robot_pose=robot,
                         costmap=costmap_of(grid, [guest_in_tow]), rfid_history=history)
    assert output(with_the_guest) == alone  # the guest on the trail behind is left out
    assert with_the_guest.feedback_message.endswith("(nobody near)")
    someone = (alone.x, alone.y)
    beside = run(DropOffGoal(), box=box, occupancy=grid, robot_pose=robot,
                 costmap=costmap_of(grid, [guest_in_tow, someone]), rfid_history=history)
    goal = output(beside)
    assert beside.status == Status.SUCCESS, beside.feedback_message
    assert math.dist((goal.x, goal.y), someone) >= 1.0
    assert math.dist(trailing_spot(goal), someone) >= 1.0
    assert "1 people near" in beside.feedback_message


@pytest.mark.parametrize("robot", [Pose2D(3.0, 10.0), Pose2D(3.0, 1.0), Pose2D(2.0, 5.6)])
def test_drop_off_goal_behind_a_door_is_approached_through_the_door(robot: Pose2D) -> None:
    grid, box = room_with_door(), Box(8.2, 6.2, 11.2, 9.2)  # 3x3 inside, at the door corner
    behaviour = run(DropOffGoal(), box=box, occupancy=grid, robot_pose=robot)
    goal = output(behaviour)
    assert_good_goal(grid, robot, goal)
    guest = trailing_spot(goal)
    assert depth(box, *guest) >= 0.5, behaviour.feedback_message
    # the final straight leg, traced back from the guest spot, comes in through the door
    heading = (math.cos(goal.yaw), math.sin(goal.yaw))
    assert heading[0] > 0.0
    back_to_wall = (guest[0] - 8.1) / heading[0]
    crossing_y = guest[1] - back_to_wall * heading[1]
    assert 5.0 <= crossing_y <= 6.2
    assert grid.clear_lines(8.1, crossing_y, [goal.x], [goal.y], 0.2)[0]


@pytest.mark.parametrize("shape", [(3.0, 3.0), (1.8, 1.5)])
def test_drop_off_goal_keeps_a_robot_already_in_place_where_it_is(
    shape: tuple[float, float],
) -> None:
    grid, box = open_room(), centred_box(*shape)
    planned = output(run(DropOffGoal(), box=box, occupancy=grid, robot_pose=SIDES["west"]))
    for arrived in (planned, Pose2D(planned.x - 0.2, planned.y + 0.1, planned.yaw + 0.1)):
        Blackboard.clear()
        again = output(run(DropOffGoal(), box=box, occupancy=grid, robot_pose=arrived))
        assert again == arrived
    Blackboard.clear()
    facing_away = Pose2D(planned.x, planned.y, planned.yaw + math.pi)  # the guest ahead: move
    moved = output(run(DropOffGoal(), box=box, occupancy=grid, robot_pose=facing_away))
    assert math.dist((moved.x, moved.y), (planned.x, planned.y)) > 1.0
    assert depth(box, *trailing_spot(moved)) >= 0.3


def test_drop_off_reposition_pulls_a_guest_who_stopped_short_deeper_in() -> None:
    grid, box = open_room(), centred_box(1.8, 1.5)
    robot = Pose2D(7.5, 7.0, 0.0)  # the guest, 1.2 m behind, stands 0.2 m inside the edge
    behaviour = run(DropOffRepositionGoal(), box=box, occupancy=grid, robot_pose=robot)
    goal = output(behaviour)
    assert_good_goal(grid, robot, goal)
    assert math.dist((goal.x, goal.y), (robot.x, robot.y)) >= 0.5
    before = depth(box, *trailing_spot(robot))
    assert depth(box, *trailing_spot(goal)) >= before + 0.2
    assert "margin" in behaviour.feedback_message
    # the guest is behind: the cheap fix is to drive on straight ahead, not to turn round
    assert abs(goal.y - robot.y) < 1e-9 and goal.x - robot.x <= 1.5


@pytest.mark.parametrize(("robot", "along_long_axis"), [
    (Pose2D(10.0, 7.0, 0.0), True),  # went past the box: come back through it
    (Pose2D(7.0, 5.0, math.pi / 2), False),  # stopped short, across the box: only a way in
])
def test_drop_off_reposition_when_the_guest_is_outside(
    robot: Pose2D, along_long_axis: bool
) -> None:
    grid, box = open_room(), centred_box(2.0, 1.0)
    goal = output(run(DropOffRepositionGoal(), box=box, occupancy=grid, robot_pose=robot))
    assert_good_goal(grid, robot, goal)
    assert math.dist((goal.x, goal.y), (robot.x, robot.y)) >= 0.5
    assert depth(box, *trailing_spot(robot)) < 0.0
    assert depth(box, *trailing_spot(goal)) >= 0.1
    assert (abs(math.cos(goal.yaw)) > 0.9) is along_long_axis


def test_drop_off_reposition_with_a_wall_ahead_goes_another_way() -> None:
    values = cells(14.0, 14.0)
    fill(values, 8.6, 0.0, 9.0, 14.0)
    grid, box = OccupancyGrid2D.from_message(grid_message(values)), Box(6.9, 6.1, 8.4, 7.9)
    robot = Pose2D(8.2, 7.0, 0.0)  # nose to the wall: no room to pull forward
    guest = trailing_spot(robot)  # 0.1 m inside the box
    goal = output(run(DropOffRepositionGoal(), box=box, occupancy=grid, robot_pose=robot))
    assert_good_goal(grid, robot, goal)
    assert math.dist((goal.x, goal.y), (robot.x, robot.y)) >= 0.5
    assert depth(box, *trailing_spot(goal)) >= depth(box, *guest) + 0.2
    # the last leg, from the new guest spot to the goal, does not run through the guest
    leg = np.linspace(trailing_spot(goal), (goal.x, goal.y), 50)
    assert np.hypot(leg[:, 0] - guest[0], leg[:, 1] - guest[1]).min() >= 0.6


# ----------------------------------------------------------------------------- return, jitter
def test_return_goal_is_the_start_pose_itself_when_it_is_free() -> None:
    grid, start = open_room(), Pose2D(10.975, 3.75, 3.14)
    behaviour = run(ReturnGoal(), start_pose=start, occupancy=grid)
    assert behaviour.status == Status.SUCCESS
    assert output(behaviour) == start


def test_return_goal_is_snapped_near_the_start_when_it_is_cramped() -> None:
    grid, start = open_room(), Pose2D(0.3, 5.0, 1.0)  # 0.2 m from the wall
    goal = output(run(ReturnGoal(), start_pose=start, occupancy=grid))
    assert grid.is_free(goal.x, goal.y, ROBOT_CLEARANCE)
    assert math.dist((goal.x, goal.y), (start.x, start.y)) <= 0.5
    assert goal.yaw == start.yaw
    Blackboard.clear()
    values = cells(14.0, 14.0)
    fill(values, 0.0, 0.0, 6.0, 6.0)
    walled = OccupancyGrid2D.from_message(grid_message(values))
    failed = run(ReturnGoal(), start_pose=Pose2D(3.0, 3.0), occupancy=walled)
    assert failed.status == Status.FAILURE
    assert failed.feedback_message.startswith("no free spot for the robot near (3.00, 3.00")


def jitters(seed: int | None, grid: OccupancyGrid2D, goal: Pose2D, count: int = 5) -> list[Pose2D]:
    behaviour = run(JitterGoal(name="JitterGoal", seed=seed), goal=goal, occupancy=grid)
    results = [output(behaviour)]
    for _ in range(count - 1):
        behaviour.tick_once()
        results.append(output(behaviour))
    return results


def test_jitter_goal_moves_the_goal_a_little_onto_free_space_reproducibly() -> None:
    grid, goal = open_room(), Pose2D(0.6, 5.0, 0.5)  # near the wall: some draws need snapping
    first = jitters(7, grid, goal)
    for jittered in first:
        assert grid.is_free(jittered.x, jittered.y, ROBOT_CLEARANCE)
        assert 0.05 < math.dist((jittered.x, jittered.y), (goal.x, goal.y)) <= 0.3 * 2**0.5 + 0.3
        assert jittered.yaw == goal.yaw
    assert len(set(first)) == len(first)
    assert jitters(7, grid, goal) == first
    assert jitters(8, grid, goal) != first
    assert jitters(None, grid, goal) == jitters(None, grid, goal)  # seeded from the name


def test_jitter_goal_draws_from_the_runs_seed_unless_given_its_own() -> None:
    grid, goal = open_room(), Pose2D(3.0, 5.0)

    def draws(run_seed: int | None, seed: int | None = None) -> list[Pose2D]:
        Blackboard.clear()
        behaviour = JitterGoal(name="JitterGoal", seed=seed)
        behaviour.setup(run_seed=run_seed)
        wire(behaviour, goal=goal, occupancy=grid)
        results = []
        for _ in range(4):
            behaviour.tick_once()
            results.append(output(behaviour))
        return results

    assert draws(3) == draws(3)
    assert draws(3) != draws(4)
    assert draws(None) == jitters(None, grid, goal, count=4)  # no run seed: from the name
    assert draws(3, seed=7) == draws(4, seed=7)  # a seed of its own wins


def test_jitter_goal_keeps_the_goal_when_there_is_no_room() -> None:
    values = cells(14.0, 14.0)
    fill(values, 0.0, 0.0, 14.0, 14.0)
    fill(values, 5.0, 5.0, 5.5, 5.5, value=0)  # a pocket too small for the robot
    goal = Pose2D(5.25, 5.25)
    behaviour = run(JitterGoal(seed=1), goal=goal,
                    occupancy=OccupancyGrid2D.from_message(grid_message(values)))
    assert behaviour.status == Status.SUCCESS
    assert output(behaviour) == goal
    assert "goal unchanged" in behaviour.feedback_message


# ----------------------------------------------------------------------------- waypoints
def offices() -> OccupancyGrid2D:
    """20 x 16 m: two rooms with doors off a corridor, a desk block and a blind alcove."""
    values = cells(20.0, 16.0)
    for wall in ((0, 0, 20, 0.1), (0, 15.9, 20, 16), (0, 0, 0.1, 16), (19.9, 0, 20, 16),
                 (0, 8.0, 8.0, 8.2), (9.2, 8.0, 20, 8.2),       # corridor wall, door 8 .. 9.2
                 (10.0, 8.2, 10.2, 12.0), (10.0, 13.0, 10.2, 16),  # room partition, door 12 .. 13
                 (4.0, 3.0, 6.0, 4.0),                          # a desk block
                 (14.0, 2.0, 14.2, 6.0), (14.0, 6.0, 16.0, 6.2)):  # an alcove's walls
        fill(values, *wall)
    return OccupancyGrid2D.from_message(grid_message(values))


def free_cells_within(grid: OccupancyGrid2D, near: Any, reach: float) -> np.ndarray:
    """(n, 2) centres of the free cells within ``reach`` of ``near(xs, ys) -> distance``."""
    window = grid.window(0.0, 0.0, grid.width * grid.resolution, grid.height * grid.resolution)
    xs, ys = np.meshgrid(window.xs, window.ys)
    free = grid.passable(0.0) & (near(xs, ys) <= reach)
    return np.column_stack([xs[free], ys[free]])


def farthest_from_waypoints(points: np.ndarray, waypoints: list[Pose2D]) -> float:
    spots = np.array([(w.x, w.y) for w in waypoints])
    gaps = np.hypot(points[:, None, 0] - spots[None, :, 0], points[:, None, 1] - spots[None, :, 1])
    return float(gaps.min(axis=1).max())


@pytest.mark.parametrize("box", [Box(5.0, 9.0, 8.0, 12.0), Box(13.0, 3.0, 16.0, 4.5),
                                 Box(1.0, 1.0, 2.8, 2.5)])
def test_exploration_waypoints_cover_the_box_and_6_m_around_it(box: Box) -> None:
    grid, robot = offices(), Pose2D(9.0, 6.0)
    behaviour = run(ExplorationWaypoints(), box=box, occupancy=grid, robot_pose=robot)
    waypoints = output(behaviour)
    assert behaviour.status == Status.SUCCESS
    assert behaviour.feedback_message == f"{len(waypoints)} exploration waypoints"
    for waypoint in waypoints:
        assert_good_goal(grid, robot, waypoint)

    def to_box(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        return np.hypot(np.maximum(np.maximum(box.min_x - xs, xs - box.max_x), 0),
                        np.maximum(np.maximum(box.min_y - ys, ys - box.max_y), 0))

    assert farthest_from_waypoints(free_cells_within(grid, to_box, 6.0), waypoints) <= 2.0
    covers_box = [bool(to_box(np.array(w.x), np.array(w.y)) <= 1.8) for w in waypoints]
    assert covers_box[0] and covers_box == sorted(covers_box, reverse=True)  # box first
    bands = [int(max(float(to_box(np.array(w.x), np.array(w.y))) - 1.8, 0.0) // 2.0)
             + (float(to_box(np.array(w.x), np.array(w.y))) > 1.8) for w in waypoints]
    assert bands == sorted(bands)  # then outward, the nearest band first
    legs = [math.dist((a.x, a.y), (b.x, b.y)) for a, b in itertools.pairwise(waypoints)]
    assert min(legs) >= 0.2  # no waypoint twice
    area = (box.max_x - box.min_x + 12.0) * (box.max_y - box.min_y + 12.0)
    assert len(waypoints) <= 2.0 * area / 2.4**2  # no swarm of waypoints along the walls


def test_guest_search_goes_back_along_the_trail_then_the_last_seen_spot_then_rings() -> None:
    grid, robot, last_seen = open_room(16.0), Pose2D(2.0, 8.0), Pose2D(8.0, 8.0, 1.0)
    behaviour = run(GuestSearchWaypoints(), guest_last_seen=last_seen, occupancy=grid,
                    robot_pose=robot)
    waypoints = output(behaviour)
    assert behaviour.status == Status.SUCCESS
    behind = (8.0 - TRAIL * math.cos(1.0), 8.0 - TRAIL * math.sin(1.0))
    assert math.dist((waypoints[0].x, waypoints[0].y), behind) < 0.15
    assert (waypoints[1].x, waypoints[1].y) == (8.0, 8.0)
    for waypoint in waypoints:
        assert_good_goal(grid, robot, waypoint)
    spots = [(w.x, w.y) for w in waypoints]
    assert min(math.dist(a, b) for i, a in enumerate(spots) for b in spots[i + 1:]) >= (
        TRAIL - 0.15)
    around = free_cells_within(grid, lambda xs, ys: np.hypot(xs - 8.0, ys - 8.0), 5.5)
    assert farthest_from_waypoints(around, waypoints) <= 2.0
    assert math.dist(spots[2], (robot.x, robot.y)) < math.dist(spots[2], (14.0, 8.0))


def test_guest_search_snaps_to_reachable_cells_near_walls() -> None:
    grid, robot = offices(), Pose2D(3.0, 6.0)
    waypoints = output(run(GuestSearchWaypoints(), guest_last_seen=Pose2D(8.6, 7.9),
                           occupancy=grid, robot_pose=robot))
    assert min(math.dist((w.x, w.y), (8.6, 7.9)) for w in waypoints[:2]) <= 1.0
    for waypoint in waypoints:
        assert_good_goal(grid, robot, waypoint)


def test_next_waypoint_iterates_fails_when_exhausted_and_restarts_on_a_new_list() -> None:
    first = [Pose2D(1.0, 1.0), Pose2D(2.0, 2.0)]
    behaviour = run(NextWaypoint(), waypoints=first)
    assert (behaviour.status, output(behaviour)) == (Status.SUCCESS, first[0])
    assert behaviour.feedback_message == "waypoint 1/2 (1.00, 1.00, yaw 0.00)"
    behaviour.tick_once()
    assert (behaviour.status, output(behaviour)) == (Status.SUCCESS, first[1])
    behaviour.tick_once()
    assert behaviour.status == Status.FAILURE
    assert behaviour.feedback_message == "all 2 waypoints visited"
    Blackboard.set("/waypoints", list(first))  # equal, but a new list: start again
    behaviour.tick_once()
    assert (behaviour.status, output(behaviour)) == (Status.SUCCESS, first[0])
    second = [Pose2D(5.0, 5.0)]
    Blackboard.set("/waypoints", second)
    behaviour.tick_once()
    assert output(behaviour) == second[0]
    behaviour.tick_once()
    assert behaviour.status == Status.FAILURE


# ----------------------------------------------------------------------------- missing inputs
FULL_INPUTS = {
    "box": Box(6.0, 6.0, 8.0, 8.0), "robot_pose": Pose2D(2.0, 2.0),
    "start_pose": Pose2D(2.0, 2.0), "goal": Pose2D(3.0, 3.0),
    "guest_last_seen": Pose2D(5.0, 5.0), "waypoints": [Pose2D(1.0, 1.0)],
}
BEHAVIOURS = [PickupGoal, DropOffGoal, DropOffRepositionGoal, ReturnGoal, JitterGoal,
              ExplorationWaypoints, GuestSearchWaypoints, NextWaypoint]


@pytest.mark.parametrize("kind", BEHAVIOURS)
def test_every_missing_input_fails_with_a_message_naming_it(kind: type) -> None:
    grid = open_room()
    everything = {**FULL_INPUTS, "occupancy": grid}
    required = [port for port, information in kind.input_ports().items()
                if information.required]
    complete = run(kind(), **{port: everything[port] for port in required})
    assert complete.status == Status.SUCCESS, complete.feedback_message
    for missing in required:
        Blackboard.clear()
        inputs = {port: everything[port] for port in required if port != missing}
        behaviour = run(kind(), **inputs)
        assert behaviour.status == Status.FAILURE
        assert missing in behaviour.feedback_message
        assert not Blackboard.exists(f"/{next(iter(kind.output_ports()))}")


def test_empty_box_and_wrong_type_fail_with_a_message() -> None:
    grid = open_room()
    empty = run(PickupGoal(), box=Box(1.0, 1.0, 1.0, 1.0), occupancy=grid,
                robot_pose=Pose2D(2.0, 2.0))
    assert empty.status == Status.FAILURE
    assert "is empty" in empty.feedback_message
    Blackboard.clear()
    wrong = run(DropOffGoal(), box=Box(6.0, 6.0, 8.0, 8.0), occupancy=object(),
                robot_pose=Pose2D(2.0, 2.0))
    assert wrong.status == Status.FAILURE
    assert wrong.feedback_message.startswith("occupancy is not a")


# ----------------------------------------------------------------------------- the tree file
GOAL_TAGS = {cls.__name__: cls for cls in BEHAVIOURS}


def test_the_mission_tree_wires_exactly_the_declared_ports() -> None:
    seen = set()
    for element in ElementTree.parse(TREE).getroot().iter():
        kind = GOAL_TAGS.get(element.tag)
        if kind is None:
            continue
        seen.add(element.tag)
        wired = set(element.attrib) - {"name"}
        assert wired == set(kind.input_ports()) | set(kind.output_ports()), element.tag
    assert seen == set(GOAL_TAGS)


def test_goal_behaviours_build_and_run_from_xml(tmp_path: Path) -> None:
    xml_file = tmp_path / "goals.xml"
    xml_file.write_text("""
<root main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="plan" memory="true">
      <PickupGoal name="pickup" box="{box}" occupancy="{occupancy}" robot_pose="{pose}"
                  goal="{pickup_goal}"/>
      <JitterGoal name="jitter" goal="{pickup_goal}" occupancy="{occupancy}"
                  jittered="{jittered}" seed="42"/>
      <ExplorationWaypoints name="explore" box="{box}" occupancy="{occupancy}"
                            robot_pose="{pose}" waypoints="{waypoints}"/>
      <NextWaypoint name="next" waypoints="{waypoints}" goal="{waypoint}"/>
    </Sequence>
  </BehaviorTree>
</root>
""")
    root = parse_behaviour_tree_xml(str(xml_file), node_registry="auto")
    jitter = next(node for node in root.iterate() if isinstance(node, JitterGoal))
    assert jitter.seed == 42
    grid, box = open_room(), centred_box(3.0, 3.0)
    Blackboard.set("/box", box)
    Blackboard.set("/occupancy", grid)
    Blackboard.set("/pose", Pose2D(2.0, 2.0))
    tree = py_trees.trees.BehaviourTree(root)
    tree.tick()
    assert root.status == Status.SUCCESS
    assert Blackboard.get("/waypoint") == Blackboard.get("/waypoints")[0]
    assert depth(box, Blackboard.get("/pickup_goal").x, Blackboard.get("/pickup_goal").y) >= 0.3


# ------------------------------------------------------------------------------ giving way
def test_give_way_spot_keeps_clear_of_the_people_on_the_costmap_but_not_of_the_guest() -> None:
    """In the corridor of tests/planning/test_give_way.py: a walker ahead holds the robot up,
    its guest stands on its trail behind it."""
    grid, history = office(), RfidHistory()
    drive(history, [(20.0, 4.8), (ROBOT.x, ROBOT.y)], guest=(40.0, 40.0))
    walker, guest = (8.9, 4.8), (11.2, 4.8)
    spot = output(run(GiveWaySpot(), robot_pose=ROBOT, occupancy=grid, rfid_history=history,
                      guest_follows=True, costmap=costmap_of(grid, [walker, guest])))
    assert spot is not None and math.dist((spot.x, spot.y), walker) > 1.5
    Blackboard.clear()
    behaviour = run(GiveWaySpot(), robot_pose=ROBOT, occupancy=grid, rfid_history=history,
                    guest_follows=True, costmap=costmap_of(grid, [walker, guest]))
    assert behaviour.feedback_message.endswith("(1 people near: (8.9, 4.8))")
    Blackboard.clear()
    unseen = run(GiveWaySpot(), robot_pose=ROBOT, occupancy=grid, rfid_history=history,
                 guest_follows=True)
    assert unseen.status == Status.SUCCESS
    assert unseen.feedback_message.endswith("(no costmap)")


# ------------------------------------------------------------------------------ coming near
def test_nearest_reachable_spot_hears_a_room_shut_by_someone_in_its_door_from_the_corridor(
) -> None:
    """In the office of tests/planning/test_give_way.py: a walker stands in the room's door."""
    grid, robot, waypoint = office(), Pose2D(14.0, 4.8, math.pi), Pose2D(11.0, 7.0)
    behaviour = run(NearestReachableSpot(), target=waypoint, robot_pose=robot, occupancy=grid,
                    costmap=costmap_of(grid, [(10.0, 5.7)]))
    spot = output(behaviour)
    assert behaviour.status == Status.SUCCESS, behaviour.feedback_message
    assert spot.y < 5.6 and math.dist((spot.x, spot.y), (waypoint.x, waypoint.y)) <= 2.0
    assert behaviour.feedback_message.endswith("(1 people near: (10.0, 5.7))")
    Blackboard.clear()
    unseen = run(NearestReachableSpot(), target=waypoint, robot_pose=robot, occupancy=grid)
    assert math.dist((output(unseen).x, output(unseen).y), (waypoint.x, waypoint.y)) < 0.05
    Blackboard.clear()
    too_deep = run(NearestReachableSpot(), target=Pose2D(11.0, 8.5), robot_pose=robot,
                   occupancy=grid, costmap=costmap_of(grid, [(10.0, 5.7)]))
    assert too_deep.status == Status.FAILURE
    assert too_deep.feedback_message.startswith("nothing reachable near (11.00, 8.50")


def test_give_way_spot_looks_only_within_its_route() -> None:
    """In the office of tests/planning/test_give_way.py, someone a metre from the robot."""
    grid, history = office(), RfidHistory()
    drive(history, [(20.0, 4.8), (ROBOT.x, ROBOT.y)], guest=(40.0, 40.0))
    costmap = costmap_of(grid, [(9.0, 4.8)])
    near = run(GiveWaySpot(max_route=5.0), robot_pose=ROBOT, occupancy=grid,
               rfid_history=history, costmap=costmap)
    assert near.status == Status.SUCCESS, near.feedback_message
    assert math.dist((output(near).x, output(near).y), (ROBOT.x, ROBOT.y)) <= 5.0
    Blackboard.clear()
    too_short = run(GiveWaySpot(max_route=1.0), robot_pose=ROBOT, occupancy=grid,
                    rfid_history=history, costmap=costmap)
    assert too_short.status == Status.FAILURE
    assert too_short.feedback_message.startswith("no spot to give way at")
