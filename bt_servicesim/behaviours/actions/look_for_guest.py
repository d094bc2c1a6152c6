"""Look round for a lost guest with the front camera, as OSRF's 0.3 example did.

RFID hears the guest only within 2.0 m; a guest who drifted a few metres off, out of that range
but in plain sight, is seen by the camera: a blue shirt over red trousers
(:mod:`bt_servicesim.planning.guest_camera`). :class:`LookForGuest` turns the robot in place in
bounded steps, first towards where the guest was last in range, then on round a full turn,
and stops to judge one picture after each step. When the guest is in it, it writes a goal
:data:`~bt_servicesim.planning.guest_camera.STAND_OFF` short of them and succeeds; after a
full turn without them, or its time limit, it fails.

The camera is the costliest sensor to serve (a simulator renders a frame in milliseconds), so
the behaviour subscribes only while it looks: the subscription is made in ``initialise`` and
destroyed in ``terminate``, and nobody reads the camera otherwise.

Seeds replay: everything is judged in sim time. Each step's schedule is fixed when the step
starts (turn for angle / speed, stop, settle), so the picture judged is the first whose stamp
is at or after the settled time, whenever it arrives; it is judged at a tick a fixed
``frame_lag`` later, or, if it has not come by then, at the tick it comes (RUNNING meanwhile).
The behaviour knows nothing of lockstep: with a simulator in lockstep the run's node counts the
new subscription from a period it names (:mod:`bt_servicesim.ros.lockstep`), so every frame
reaches the tick of its own period, and a camera that just streams (a robot's) works the same.
A new subscription takes a moment to be matched, so the first look comes no sooner than
``warm_up`` sim seconds after the start.

The turn is sent on ``cmd_vel`` every tick while turning (a navigation goal that ends meanwhile
sends its own stop), and a stop is sent when the turn is over and in ``terminate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from geometry_msgs.msg import Twist
from py_trees.ports import NoDataAvailable, PortInformation
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Image

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.behaviours.ports import GOAL_OUT, OCCUPANCY, ROBOT_POSE
from bt_servicesim.planning.geometry import Point, Pose2D
from bt_servicesim.planning.goals import ROBOT_CLEARANCE
from bt_servicesim.planning.guest_camera import (
    CameraModel,
    camera_goal,
    find_guest,
    guest_position,
    look_turns,
)
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import Costmap2D, people_on_costmap
from bt_servicesim.planning.rules import PERSON_BODY_RADIUS
from bt_servicesim.ros.shared_subscription import Reader, shared_subscription
from bt_servicesim.ros.sim_clock import node_from_setup_kwargs, sim_now_s

__all__ = ["LookForGuest", "image_pixels"]

BYSTANDER_REACH = 3.0
"""Metres round the guest (in x and in y) in which the costmap's people are bystanders."""
GUEST_MARK = 0.8
"""Metres from where the camera puts the guest within which a costmap disc is the guest's."""


@dataclass
class _Step:
    """One turn and the look after it, in sim seconds."""

    turn: float
    """Radians to turn, positive to the left."""
    turn_until: float
    """When the turn command ends."""
    look_at: float
    """The stamp from which a picture shows the robot settled."""


class LookForGuest(ActionNode):
    """Turn in place in steps until the camera shows the guest; write a goal short of them.

    SUCCESS with ``goal`` when the guest is seen; FAILURE after a full turn without them, when
    no picture comes, when no reachable spot lies near the guest, or after ``timeout``.

    Args:
        name: the behaviour's name
        camera_topic: the front camera's image topic (sensor_msgs/Image, rgb8 or bgr8)
        cmd_vel_topic: the base's velocity command
        hfov: the camera's horizontal field of view, radians
        turn_step: radians between looks after the first (less than ``hfov``: pictures overlap)
        turn_speed: rad/s while turning
        settle: sim seconds from the end of a turn until a picture counts
        frame_lag: sim seconds after the settled stamp at which the picture is judged
        warm_up: sim seconds from the start before the first picture counts
        frame_wait: sim seconds a picture may be late before the camera counts as silent
        timeout: sim seconds the whole look may take
    """

    INPUT_PORTS: Ports = {
        "robot_pose": ROBOT_POSE,
        "occupancy": OCCUPANCY,
        "guest_last_seen": PortInformation(
            data_type=Pose2D, required=False,
            description="where the robot last had the guest in range: looked towards first"),
        "costmap": PortInformation(
            data_type=Costmap2D, required=False,
            description="navigation's costmap: the goal keeps clear of others near the guest"),
    }
    OUTPUT_PORTS: Ports = {"goal": GOAL_OUT}

    def __init__(self, name: str = "LookForGuest",
                 camera_topic: str = "/servicebot/camera_front/image_raw",
                 cmd_vel_topic: str = "/servicebot/cmd_vel", hfov: float = 1.0629,
                 turn_step: float = 0.9, turn_speed: float = 0.8, settle: float = 0.4,
                 frame_lag: float = 0.2, warm_up: float = 1.5, frame_wait: float = 3.0,
                 timeout: float = 40.0, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.camera_topic, self.cmd_vel_topic, self.hfov = camera_topic, cmd_vel_topic, float(hfov)
        self.turn_step, self.turn_speed = float(turn_step), float(turn_speed)
        self.settle, self.frame_lag, self.warm_up = float(settle), float(frame_lag), float(warm_up)
        self.frame_wait, self.timeout = float(frame_wait), float(timeout)
        self.node: Node | None = None
        self.publisher: Publisher[Twist] | None = None
        self.reader: Reader | None = None
        self._turns: list[float] = []
        self._step: _Step | None = None
        self._frame: Image | None = None
        self._started = 0.0
        self._looks = 0
        self._moving = False

    # ---------------------------------------------------------------- lifecycle
    def setup(self, **kwargs: Any) -> None:
        """Create the velocity publisher on ``kwargs["node"]``; the camera waits for a look."""
        self.node = node_from_setup_kwargs(self.name, kwargs)
        self.publisher = self.node.create_publisher(Twist, self.cmd_vel_topic, 10)

    def initialise(self) -> None:
        """Subscribe to the camera and plan the turns: first towards the guest's last place."""
        node = self._require_setup()
        self._drop_camera()
        self._started, self._looks, self._frame, self._step = self._now(), 0, None, None
        self._turns = []
        try:
            robot, grid = self.get_input("robot_pose"), self.get_input("occupancy")
        except NoDataAvailable as missing:
            self.feedback_message = f"cannot look round: {missing}"
            return
        refusal = self._no_room_to_turn(robot, grid)
        if refusal is not None:
            self.feedback_message = refusal
            return
        self._turns = look_turns(robot, towards=self._last_seen(), step=self.turn_step)
        self.reader = shared_subscription(node, Image, self.camera_topic, self._on_image,
                                          qos_profile_sensor_data)
        self._begin_step(earliest_look=self._started + self.warm_up)
        self.feedback_message = f"looking round for the guest: {len(self._turns)} looks"

    def update(self) -> Status:
        """Turn, settle, judge the picture; then the next step, until seen or round."""
        step, now = self._step, self._now()
        if step is None:
            return Status.FAILURE
        if now - self._started > self.timeout:
            self.feedback_message = f"guest not seen in {self.timeout:.0f} sim s of looking"
            return Status.FAILURE
        if now < step.turn_until:
            self._command(turn=math.copysign(self.turn_speed, step.turn))
            self.feedback_message = f"turning {step.turn:+.2f} rad for look {self._looks + 1}"
            return Status.RUNNING
        self._command(turn=0.0)
        if now < step.look_at + self.frame_lag:
            self.feedback_message = f"settling for look {self._looks + 1}"
            return Status.RUNNING
        if self._frame is None:
            return self._wait_for_picture(now - step.look_at)
        return self._judge(self._frame)

    def terminate(self, new_status: Status) -> None:
        """Stop the robot if it was told to turn, and leave the camera."""
        if self._moving:
            self._command(turn=0.0)
        self._drop_camera()
        if new_status == Status.INVALID and self._step is not None:
            self.feedback_message = "look interrupted"
        self._step = None

    # ---------------------------------------------------------------- steps
    def _begin_step(self, *, earliest_look: float = 0.0) -> None:
        turn = self._turns[self._looks]
        turn_until = self._now() + abs(turn) / self.turn_speed
        self._frame = None
        self._step = _Step(turn=turn, turn_until=turn_until,
                           look_at=max(turn_until + self.settle, earliest_look))

    def _judge(self, frame: Image) -> Status:
        self._looks += 1
        try:
            pixels = image_pixels(frame)
            robot, grid = self.get_input("robot_pose"), self.get_input("occupancy")
        except (ValueError, NoDataAvailable) as error:
            self.feedback_message = f"cannot judge the picture: {error}"
            return Status.FAILURE
        camera = CameraModel(width=pixels.shape[1], height=pixels.shape[0], hfov=self.hfov)
        sighting = find_guest(pixels, camera)
        if sighting is None:
            return self._next_step()
        x, y = guest_position(robot, sighting)
        where = (f"guest seen at ({x:.2f}, {y:.2f}), {sighting.distance:.1f} m "
                 f"at {sighting.bearing:+.2f} rad")
        goal = camera_goal(robot, sighting, grid, bystanders=self._bystanders(grid, (x, y)))
        if goal is None:
            self.feedback_message = f"{where}: no reachable spot near them"
            return Status.FAILURE
        self._set_output("goal", goal)
        self.feedback_message = f"{where}: approach ({goal.x:.2f}, {goal.y:.2f})"
        return Status.SUCCESS

    def _next_step(self) -> Status:
        if self._looks >= len(self._turns):
            self.feedback_message = f"guest not in sight after {self._looks} looks round"
            return Status.FAILURE
        self._begin_step()
        self.feedback_message = f"guest not in look {self._looks}: turning on"
        return Status.RUNNING

    def _wait_for_picture(self, late: float) -> Status:
        allowed = self.frame_wait if self._looks == 0 else self.frame_wait / 2.0
        if late > allowed:
            self.feedback_message = f"no picture on {self.camera_topic} for {late:.1f} sim s"
            return Status.FAILURE
        self.feedback_message = f"waiting for a picture from {self.camera_topic}"
        return Status.RUNNING

    # ---------------------------------------------------------------- ROS
    def _on_image(self, message: Image) -> None:
        step = self._step
        if step is None or self._frame is not None:
            return
        if message.header.stamp.sec + message.header.stamp.nanosec * 1e-9 >= step.look_at - 1e-6:
            self._frame = message

    def _command(self, *, turn: float) -> None:
        if self.publisher is None:
            return
        message = Twist()
        message.angular.z = float(turn)
        self.publisher.publish(message)
        self._moving = turn != 0.0

    def _drop_camera(self) -> None:
        if self.reader is not None:
            self.reader.cancel()
            self.reader = None

    def _no_room_to_turn(self, robot: Pose2D, grid: OccupancyGrid2D) -> str | None:
        """Why the robot cannot turn in place here, or None. A turn in place sweeps the box's
        corners round: the navigation checks its footprint, a bare cmd_vel turn does not, so
        turn only where the map has room, and nobody the costmap shows stands within the
        corners' reach (their body's radius beyond it)."""
        room = grid.clearance(robot.x, robot.y)
        if room < ROBOT_CLEARANCE:
            return (f"too near a wall to turn in place: {room:.2f} m of room, "
                    f"the box's corners need {ROBOT_CLEARANCE:.2f} m")
        try:
            costmap = self.get_input("costmap")
        except NoDataAvailable:
            return None
        if not isinstance(costmap, Costmap2D):
            return None
        reach = ROBOT_CLEARANCE + PERSON_BODY_RADIUS
        # a wider window than the reach, so that a disc it would cut is located whole
        near = people_on_costmap(costmap, grid, x=robot.x, y=robot.y, reach=2.0 * reach)
        gaps = [math.dist((robot.x, robot.y), (float(px), float(py))) for px, py in near]
        if gaps and min(gaps) < reach:
            return (f"too near someone to turn in place: a person {min(gaps):.2f} m away, "
                    f"the box's corners need {reach:.2f} m")
        return None

    def _bystanders(self, grid: OccupancyGrid2D, guest: Point) -> list[Point]:
        """Others the costmap shows near the guest: every disc but the one nearest the guest,
        if it lies within :data:`GUEST_MARK` of where the camera puts them."""
        try:
            costmap = self.get_input("costmap")
        except NoDataAvailable:
            return []
        if not isinstance(costmap, Costmap2D):
            return []
        people = [(float(px), float(py)) for px, py in people_on_costmap(
            costmap, grid, x=guest[0], y=guest[1], reach=BYSTANDER_REACH)]
        people.sort(key=lambda person: math.dist(person, guest))
        if people and math.dist(people[0], guest) <= GUEST_MARK:
            people = people[1:]
        return people

    def _last_seen(self) -> Pose2D | None:
        try:
            seen = self.get_input("guest_last_seen")
        except NoDataAvailable:
            return None
        return seen if isinstance(seen, Pose2D) else None

    def _now(self) -> float:
        return sim_now_s(self._require_setup().get_clock())

    def _require_setup(self) -> Node:
        if self.node is None or self.publisher is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self.node


def image_pixels(message: Image) -> np.ndarray:
    """An rgb8 or bgr8 ``sensor_msgs/Image`` as an RGB array (height, width, 3) of uint8."""
    if message.encoding not in ("rgb8", "bgr8"):
        raise ValueError(f"image encoding {message.encoding!r}, not rgb8 or bgr8")
    height, width, step = int(message.height), int(message.width), int(message.step)
    data = np.frombuffer(bytes(message.data), dtype=np.uint8)
    if height <= 0 or width <= 0 or step < width * 3 or data.size < height * step:
        raise ValueError(f"image of {width}x{height} with step {step} and {data.size} bytes")
    pixels = data[:height * step].reshape(height, step)[:, :width * 3].reshape(height, width, 3)
    return pixels[..., ::-1] if message.encoding == "bgr8" else pixels
