"""The robot's map pose from localisation's map -> odom on /tf and odometry, over real DDS.

Odometry alone is never a map pose: until map -> odom arrives the reader waits, however much
odometry comes in; afterwards the pose is map -> odom composed with the newest odometry.
"""

from __future__ import annotations

import math

import py_trees
import pytest
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from py_trees.blackboard import Blackboard
from tf2_msgs.msg import TFMessage

from bt_servicesim.behaviours.actions.localised_pose import LocalisedPoseToBlackboard
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.messages import pose_to_msg
from tests.fakes.graphs import SensorWorld
from tests.fakes.leaves import ready

Status = py_trees.common.Status
SPAWN = Pose2D(10.975, 3.75, math.pi)  # the shipped start pose: far from the origin, facing west


def odometry(pose: Pose2D, frame: str = "odom") -> Odometry:
    message = Odometry()
    message.header.frame_id, message.child_frame_id = frame, "base_footprint"
    message.pose.pose = pose_to_msg(pose)
    return message


def transforms(*edges: tuple[str, str, Pose2D]) -> TFMessage:
    message = TFMessage()
    for parent, child, pose in edges:
        stamped = TransformStamped()
        stamped.header.frame_id, stamped.child_frame_id = parent, child
        stamped.transform.translation.x, stamped.transform.translation.y = pose.x, pose.y
        stamped.transform.rotation.z = math.sin(pose.yaw / 2.0)
        stamped.transform.rotation.w = math.cos(pose.yaw / 2.0)
        message.transforms.append(stamped)
    return message


def reader(world: SensorWorld, **settings: str) -> LocalisedPoseToBlackboard:
    return ready(LocalisedPoseToBlackboard(name="pose", **settings), world.node,
                 robot_pose="/pose")


def test_odometry_alone_is_not_a_map_pose(world: SensorWorld) -> None:
    pose = reader(world)
    world.spin_until(lambda: pose._odometry is not None,
                     before=lambda: world.odom.publish(odometry(Pose2D(1.0, 0.0, 0.0))))
    pose.tick_once()
    assert pose.status == Status.RUNNING
    assert "waiting for localisation: no map -> odom on /tf" in pose.feedback_message
    assert not Blackboard.exists("/pose")


def test_the_map_pose_is_map_to_odom_composed_with_odometry(world: SensorWorld) -> None:
    pose = reader(world)
    # another broadcaster's transforms come first in the message: only map -> odom counts
    tf = transforms(("base_footprint", "lidar_frame", Pose2D(0.05, 0.0, 0.0)),
                    ("map", "odom", SPAWN))
    world.spin_until(lambda: pose._map_to_odom is not None and pose._odometry is not None,
                     before=lambda: (world.tf.publish(tf),
                                     world.odom.publish(odometry(Pose2D(1.0, 0.5, 0.0)))))
    pose.tick_once()
    assert pose.status == Status.SUCCESS
    robot = Blackboard.get("/pose")
    assert (robot.x, robot.y) == pytest.approx((SPAWN.x - 1.0, SPAWN.y - 0.5))
    assert math.cos(robot.yaw) == pytest.approx(-1.0)


def test_odometry_in_another_frame_is_named_and_not_used(world: SensorWorld) -> None:
    pose = reader(world)
    world.spin_until(lambda: bool(pose._wrong_frame),
                     before=lambda: world.odom.publish(odometry(SPAWN, frame="map")))
    world.spin_until(lambda: pose._map_to_odom is not None,
                     before=lambda: world.tf.publish(transforms(("map", "odom", SPAWN))))
    pose.tick_once()
    assert pose.status == Status.RUNNING
    assert "in frame 'map', expected 'odom'" in pose.feedback_message


def test_the_frames_are_settings(world: SensorWorld) -> None:
    pose = reader(world, global_frame="world", odom_frame="wheels")
    origin = Pose2D(0.0, 0.0)
    world.spin_until(lambda: pose._odometry is not None,
                     before=lambda: (world.tf.publish(transforms(("map", "odom", origin))),
                                     world.odom.publish(odometry(origin, frame="wheels"))))
    assert pose._map_to_odom is None  # map -> odom is not world -> wheels
    world.spin_until(lambda: False if pose._map_to_odom is None else pose._map_to_odom == SPAWN,
                     before=lambda: world.tf.publish(transforms(("world", "wheels", SPAWN))))
    pose.tick_once()
    robot = Blackboard.get("/pose")
    assert (robot.x, robot.y, robot.yaw) == pytest.approx((SPAWN.x, SPAWN.y, SPAWN.yaw))
