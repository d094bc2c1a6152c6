"""What the robot is told on topics: AMCL's initial pose and the base's velocity command.

Design intent: both are subscriptions the original robot had (``amcl``'s ``initialpose``,
``gazebo_ros_diff_drive``'s ``cmd_vel``), handed to the engine as they come; lockstep counts
and orders them like requests, so a command sent in tick *k* acts at the same sim time in
every run.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from rclpy.node import Node

from servicesim_sim.lockstep.server import LockstepServer
from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.localisation import initial_pose_problem
from servicesim_sim.ros.publishing import LATCHED, NO_SUBSCRIPTION_EVENTS
from servicesim_sim.ros.robot_topics import MAP_FRAME

INITIAL_POSE_TOPIC = "/servicebot/initialpose"
CMD_VEL_TOPIC = "/servicebot/cmd_vel"


class RobotInputs:
    """The initial pose and ``cmd_vel`` subscriptions on ``node``, applied to ``engine``."""

    def __init__(self, *, node: Node, engine: SimEngine, lockstep: LockstepServer) -> None:
        self.node = node
        self.engine = engine
        node.create_subscription(PoseWithCovarianceStamped, INITIAL_POSE_TOPIC,
                                 lockstep.gated_message(INITIAL_POSE_TOPIC,
                                                        self.on_initial_pose),
                                 LATCHED, event_callbacks=NO_SUBSCRIPTION_EVENTS,
                                 callback_group=lockstep.callback_group)
        node.create_subscription(Twist, CMD_VEL_TOPIC,
                                 lockstep.gated_message(CMD_VEL_TOPIC, self.on_cmd_vel),
                                 10, event_callbacks=NO_SUBSCRIPTION_EVENTS,
                                 callback_group=lockstep.callback_group)

    def on_initial_pose(self, message: PoseWithCovarianceStamped) -> None:
        """AMCL's initialpose: taken in the global frame only and with finite numbers, as AMCL
        takes it (an empty frame is taken as the global one, with a warning, as ROS 1 AMCL does);
        any other is ignored with a warning."""
        if not message.header.frame_id:
            self.node.get_logger().warning(
                f"initial pose with an empty frame_id taken as {MAP_FRAME!r}")
        pose = message.pose.pose
        position, turn = pose.position, pose.orientation
        orientation = (turn.x, turn.y, turn.z, turn.w)
        problem = initial_pose_problem(
            frame_id=message.header.frame_id, global_frame=MAP_FRAME, orientation=orientation,
            numbers=(position.x, position.y, position.z, *orientation, *message.pose.covariance))
        if problem is not None:
            self.node.get_logger().warning(f"initial pose ignored: {problem}")
            return
        yaw = 2.0 * math.atan2(pose.orientation.z, pose.orientation.w)
        self.engine.set_initial_pose(pose.position.x, pose.position.y, yaw)

    def on_cmd_vel(self, message: Twist) -> None:
        self.engine.command_velocity(message.linear.x, message.angular.z)
