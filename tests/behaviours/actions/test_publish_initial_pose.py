"""PublishInitialPose: a latched pose in the map frame that a late-joining simulator receives."""

from __future__ import annotations

import py_trees
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from py_trees.blackboard import Blackboard
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from bt_servicesim.behaviours.actions.publish_initial_pose import PublishInitialPose
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.initial_pose import INITIAL_POSE_QOS
from bt_servicesim.ros.messages import pose_from_msg
from tests.fakes.leaves import ready
from tests.fakes.spinning import spin_until

Status = py_trees.common.Status


def publisher(node: Node) -> PublishInitialPose:
    return ready(PublishInitialPose(name="initial_pose"), node, pose="/start_pose")


def test_late_joining_subscriber_gets_the_pose(ros_context: object) -> None:
    executive = Node("executive", context=ros_context)
    behaviour = publisher(executive)
    Blackboard.set("/start_pose", Pose2D(10.975, 3.75, 3.14))
    behaviour.tick_once()
    assert behaviour.status == Status.SUCCESS
    assert behaviour.feedback_message.startswith("initial pose (10.97, 3.75, 3.14) published")

    simulator = Node("simulator", context=ros_context)  # joins after the publication
    received: list[PoseWithCovarianceStamped] = []
    simulator.create_subscription(
        PoseWithCovarianceStamped, "/servicebot/initialpose", received.append, INITIAL_POSE_QOS
    )
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(executive)
    executor.add_node(simulator)
    spin_until(executor, lambda: bool(received), "the latched initial pose", limit_s=10.0,
               step_s=0.05)
    message = received[0]
    assert message.header.frame_id == "map"
    pose = pose_from_msg(message.pose.pose)
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((10.975, 3.75, 3.14))
    covariance = list(message.pose.covariance)
    assert covariance[0] == covariance[7] == pytest.approx(0.0625)
    assert 0.0 < covariance[35] < 0.1
    assert sum(covariance) == pytest.approx(covariance[0] + covariance[7] + covariance[35])
    executor.shutdown()


def test_without_a_pose_it_fails_clearly(ros_context: object) -> None:
    behaviour = publisher(Node("executive", context=ros_context))
    behaviour.tick_once()
    assert behaviour.status == Status.FAILURE
    assert behaviour.feedback_message.startswith("no initial pose to publish")


def test_setup_needs_the_node() -> None:
    with pytest.raises(KeyError, match="needs the rclpy node"):
        PublishInitialPose(name="initial_pose").setup()
