"""LookForGuest against a scripted robot: its camera renders what a robot turned by the
behaviour's own ``cmd_vel`` would see, on sim time the test advances a period at a time.

The pictures come from the simulator's camera module (a test may import it; the executive
does not). Each test checks that the camera is read only while the behaviour looks: the fake
camera, like the simulator's, sends a picture only while someone subscribes.
"""

from __future__ import annotations

import math

import numpy as np
import py_trees
import pytest
from geometry_msgs.msg import Twist
from py_trees.blackboard import Blackboard
from sensor_msgs.msg import Image

from bt_servicesim.behaviours.actions.look_for_guest import LookForGuest, image_pixels
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from servicesim_sim.model.camera import render_front_camera
from servicesim_sim.world.files import OccupancyMap
from tests.fakes.graphs import SensorWorld
from tests.fakes.leaves import wire
from tests.fakes.maps import costmap_of

Status = py_trees.common.Status
GUEST = "human_20843"
PERIOD = 0.1
CELLS = np.zeros((440, 440), dtype=np.int8)  # a 20 x 20 m hall from (-1, -1)
CELLS[:20, :] = CELLS[-20:, :] = CELLS[:, :20] = CELLS[:, -20:] = 100
HALL = OccupancyMap(grid=CELLS, resolution=0.05, origin_x=-1.0, origin_y=-1.0)
GRID = OccupancyGrid2D(values=CELLS, resolution=0.05, origin_x=-1.0, origin_y=-1.0)


class TurningRobot:
    """A robot that turns as the last ``cmd_vel`` says, and a camera that shows what it sees
    while somebody subscribes."""

    def __init__(self, world: SensorWorld, pose: Pose2D,
                 people: list[tuple[str, str, float, float]], *, camera_on: bool = True) -> None:
        self.world, self.pose, self.people, self.camera_on = world, pose, people, camera_on
        self.turn_rate = 0.0
        self.commands: list[float] = []
        self.pictures = 0
        self.camera = world.simulator.create_publisher(
            Image, "/servicebot/camera_front/image_raw", 10)
        world.simulator.create_subscription(Twist, "/servicebot/cmd_vel", self._on_command, 10)
        self.time = 100.0
        world.jump_to(self.time)
        Blackboard.set("/robot_pose", pose)

    def _on_command(self, message: Twist) -> None:
        self.turn_rate = message.angular.z
        self.commands.append(message.angular.z)

    def period(self) -> None:
        """One period: time moves on, the robot turns, the camera sends a picture."""
        self.time = round(self.time + PERIOD, 6)
        self.world.jump_to(self.time)
        yaw = self.pose.yaw + self.turn_rate * PERIOD
        self.pose = Pose2D(self.pose.x, self.pose.y, math.atan2(math.sin(yaw), math.cos(yaw)))
        Blackboard.set("/robot_pose", self.pose)
        if self.camera_on and self.camera.get_subscription_count() > 0:
            self.camera.publish(self.picture())
            self.pictures += 1

    def picture(self) -> Image:
        pixels = render_front_camera(robot=(self.pose.x, self.pose.y, self.pose.yaw),
                                     people=self.people, guest_name=GUEST, occupancy_map=HALL)
        image = Image(height=480, width=640, encoding="rgb8", step=640 * 3)
        image.header.stamp.sec = int(self.time)
        image.header.stamp.nanosec = round((self.time - int(self.time)) * 1e9)
        image.data = pixels.tobytes()
        return image

    def run(self, behaviour: LookForGuest, *, most_periods: int = 600) -> Status:
        behaviour.tick_once()
        for _ in range(most_periods):
            if behaviour.status != Status.RUNNING:
                break
            self.period()
            behaviour.tick_once()
        return behaviour.status

    def wait_for_subscribers(self, count: int) -> None:
        self.world.spin_until(lambda: self.camera.get_subscription_count() == count,
                              f"{count} camera subscribers")


def look(world: SensorWorld, last_seen: Pose2D | None = None,
         people_marked: list[tuple[float, float]] | None = None) -> LookForGuest:
    inputs: dict[str, object] = {"occupancy": GRID}
    if people_marked is not None:
        inputs["costmap"] = costmap_of(GRID, people_marked)
    if last_seen is not None:
        inputs["guest_last_seen"] = last_seen
    behaviour = LookForGuest(name="look")
    wire(behaviour, world.node, **inputs)
    return behaviour


def test_a_guest_behind_the_robot_is_found_by_turning_towards_where_they_were(
        world: SensorWorld) -> None:
    robot = TurningRobot(world, Pose2D(10.0, 10.0, 0.0),
                         [(GUEST, "guest", 4.0, 10.5), ("human_11111", "idler", 12.0, 13.0)])
    behaviour = look(world, last_seen=Pose2D(8.0, 10.2))
    robot.wait_for_subscribers(0)
    assert robot.run(behaviour) == Status.SUCCESS, behaviour.feedback_message
    assert behaviour.feedback_message.startswith("guest seen at (4.")
    goal = Blackboard.get("/goal")
    assert math.hypot(goal.x - 4.0, goal.y - 10.5) == pytest.approx(1.6, abs=0.3)
    assert abs(math.atan2(10.5 - goal.y, 4.0 - goal.x) - goal.yaw) < 0.05  # facing them
    assert robot.commands[0] > 0.0 and robot.commands[-1] == 0.0  # turned left, then stopped
    assert abs(robot.pose.yaw) > 2.5  # one turn, about half round, to face them
    robot.wait_for_subscribers(0)  # the camera is left when the look ends


def test_a_guest_beside_others_is_approached_clear_of_them(world: SensorWorld) -> None:
    """The guest stands between two idlers; the costmap marks all three. The goal 1.6 m short
    of the guest on the line of sight would be 0.7 m from one idler: it moves clear of both."""
    guest, left, right = (15.0, 10.0), (13.4, 10.7), (15.0, 11.0)
    robot = TurningRobot(world, Pose2D(10.0, 10.0, 0.0),
                         [(GUEST, "guest", *guest), ("human_11111", "idler", *left),
                          ("human_22222", "idler", *right)])
    behaviour = look(world, people_marked=[guest, left, right])
    assert robot.run(behaviour) == Status.SUCCESS, behaviour.feedback_message
    goal = Blackboard.get("/goal")
    assert math.dist((goal.x, goal.y), guest) < 2.0  # within the referee's pick-up reach
    assert min(math.dist((goal.x, goal.y), other) for other in (left, right)) >= 1.0


def test_a_full_turn_without_the_guest_fails_and_leaves_the_robot_stopped(
        world: SensorWorld) -> None:
    robot = TurningRobot(world, Pose2D(10.0, 10.0, 0.0),
                         [(f"human_{n:05d}", "idler", 10.0 + 3 * math.cos(n), 10.0
                           + 3 * math.sin(n)) for n in range(6)])
    behaviour = look(world)
    assert robot.run(behaviour) == Status.FAILURE
    assert behaviour.feedback_message == "guest not in sight after 7 looks round"
    assert sum(1 for rate in robot.commands if rate == 0.0) >= 7
    assert robot.commands[-1] == 0.0
    turned = 0.9 * 6
    assert robot.pose.yaw == pytest.approx(math.atan2(math.sin(turned), math.cos(turned)),
                                           abs=0.2)
    robot.wait_for_subscribers(0)


def test_a_look_interrupted_mid_turn_stops_the_robot_and_leaves_the_camera(
        world: SensorWorld) -> None:
    robot = TurningRobot(world, Pose2D(10.0, 10.0, 0.0), [])
    behaviour = look(world, last_seen=Pose2D(10.0, 5.0))
    behaviour.tick_once()
    robot.wait_for_subscribers(1)  # subscribed while looking, not before
    for _ in range(5):
        robot.period()
        behaviour.tick_once()
    assert robot.commands[-1] < 0.0  # turning right, towards the guest's last place
    behaviour.stop(Status.INVALID)
    world.spin_until(lambda: robot.commands[-1] == 0.0, "the stop")
    assert behaviour.feedback_message == "look interrupted"
    robot.wait_for_subscribers(0)


def test_a_silent_camera_fails_the_look_in_bounded_time(world: SensorWorld) -> None:
    robot = TurningRobot(world, Pose2D(10.0, 10.0, 0.0), [(GUEST, "guest", 14.0, 10.0)],
                         camera_on=False)
    behaviour = look(world)
    assert robot.run(behaviour, most_periods=100) == Status.FAILURE
    assert behaviour.feedback_message.startswith("no picture on /servicebot/camera_front")
    assert robot.time - 100.0 < 5.0


def test_a_robot_beside_a_wall_does_not_turn_in_place(world: SensorWorld) -> None:
    # the hall's west wall ends at x = 0: the box's corners, 0.32 m from its centre, would
    # sweep into it; the guest stands in plain sight, and still the robot does not turn
    robot = TurningRobot(world, Pose2D(0.25, 10.0, 0.0), [(GUEST, "guest", 4.0, 10.0)])
    behaviour = look(world, last_seen=Pose2D(4.0, 10.0))
    assert robot.run(behaviour) == Status.FAILURE
    assert behaviour.feedback_message.startswith("too near a wall to turn in place")
    assert all(rate == 0.0 for rate in robot.commands)
    assert robot.pictures == 0 and robot.pose.yaw == 0.0


def test_a_robot_beside_someone_does_not_turn_in_place(world: SensorWorld) -> None:
    # an idler 0.54 m from the robot's centre: the box's corners (0.32 m out) would sweep into
    # their body (hard seed 48 booked 1.9 million contact points turning so); one 0.7 m away
    # leaves the corners room
    for idler, turns in ((10.54, False), (10.7, True)):
        robot = TurningRobot(world, Pose2D(10.0, 10.0, 3.14),
                             [(GUEST, "guest", 10.0, 14.0), ("human_11111", "idler", idler, 10.0)])
        behaviour = look(world, last_seen=Pose2D(10.0, 14.0), people_marked=[(idler, 10.0)])
        status = robot.run(behaviour)
        if turns:
            assert status == Status.SUCCESS and any(rate != 0.0 for rate in robot.commands)
        else:
            assert status == Status.FAILURE
            assert behaviour.feedback_message == (
                "too near someone to turn in place: a person 0.54 m away, "
                "the box's corners need 0.60 m")
            assert all(rate == 0.0 for rate in robot.commands) and robot.pictures == 0


def test_a_robot_without_a_pose_cannot_look() -> None:
    behaviour = LookForGuest(name="look")
    with pytest.raises(RuntimeError, match="setup"):
        behaviour.tick_once()


def test_pictures_in_bgr_are_read_as_rgb_and_other_encodings_are_named() -> None:
    image = Image(height=1, width=2, encoding="bgr8", step=8)
    image.data = bytes([1, 2, 3, 4, 5, 6, 0, 0])
    assert image_pixels(image).tolist() == [[[3, 2, 1], [6, 5, 4]]]
    image.encoding = "mono8"
    with pytest.raises(ValueError, match="'mono8'"):
        image_pixels(image)
    image.encoding, image.step = "rgb8", 2
    with pytest.raises(ValueError, match="step 2"):
        image_pixels(image)
