"""The foundation: built interfaces work over real DDS, and the ROS defaults are in force."""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionClient
from rclpy.client import Client
from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from servicesim_competition.srv import PickUpGuest, RoomInfo

from bt_servicesim.ros.environment import apply_localhost_defaults, delete_participant
from tests.fakes.navigator import FakeNavigator
from tests.fakes.referee import FakeReferee
from tests.fakes.spinning import spin_until


def referee_and_client(context: object, name: str, kind: Any,
                       service: str) -> tuple[FakeReferee, Client, SingleThreadedExecutor]:
    """A fake referee, a client of one of its services on a node of its own, one executor."""
    referee = FakeReferee(context, f"{name}_server")
    client_node = Node(f"{name}_client", context=context)
    client = client_node.create_client(kind, service)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(referee.node)
    executor.add_node(client_node)
    assert client.wait_for_service(timeout_sec=10.0)
    return referee, client, executor


def test_localhost_discovery_and_private_domain_are_in_force() -> None:
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert 1 <= int(os.environ["ROS_DOMAIN_ID"]) <= 101


def test_user_choice_of_discovery_range_is_kept() -> None:
    environment = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}
    apply_localhost_defaults(environment)
    assert environment["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"
    empty: dict[str, str] = {}
    apply_localhost_defaults(empty)
    assert empty["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"


def test_service_round_trip_carries_request_and_response_fields(ros_context: object) -> None:
    referee, client, executor = referee_and_client(ros_context, "pickup", PickUpGuest,
                                                   "/servicesim/pickup_guest")
    request = PickUpGuest.Request(guest_name="human_20843", robot_name="servicebot")
    future = client.call_async(request)
    spin_until(executor, future.done, "the pick-up round trip")
    received = [event.detail for event in referee.log.named("pickup_guest")]
    assert received == [("human_20843", "servicebot")]
    assert future.result().success is True

    future = client.call_async(PickUpGuest.Request(guest_name="human_20843", robot_name="intruder"))
    spin_until(executor, future.done, "the pick-up round trip")
    assert future.result().success is False
    executor.shutdown()


def test_room_info_geometry_fields_survive_the_wire(ros_context: object) -> None:
    # the fake referee's FrontElevator is (-1.5, 0.0)-(1.5, 2.7)
    _, client, executor = referee_and_client(ros_context, "room", RoomInfo,
                                             "/servicesim/room_info")
    future = client.call_async(RoomInfo.Request(name="FrontElevator"))
    spin_until(executor, future.done, "the room-info round trip")
    box = future.result()
    assert (box.min.x, box.min.y, box.max.x, box.max.y) == (-1.5, 0.0, 1.5, 2.7)
    executor.shutdown()


@pytest.fixture
def navigation(
    ros_context: object,
) -> Iterator[tuple[MultiThreadedExecutor, ActionClient, FakeNavigator]]:
    """A NavigateToPose server giving five feedbacks before it succeeds, and a client of it."""
    navigator = FakeNavigator(ros_context, "/servicebot/navigate_to_pose", "navigator")
    navigator.steps = 5
    client_node = Node("navigation_client", context=ros_context)
    executor = MultiThreadedExecutor(num_threads=2, context=ros_context)
    executor.add_node(navigator.node)
    executor.add_node(client_node)
    client = ActionClient(client_node, NavigateToPose, "/servicebot/navigate_to_pose")
    assert client.wait_for_server(timeout_sec=10.0)
    yield executor, client, navigator
    executor.shutdown()


def _goal(x: float) -> NavigateToPose.Goal:
    goal = NavigateToPose.Goal()
    goal.pose.header.frame_id = "map"
    goal.pose.pose.position.x = x
    return goal


def test_action_goal_is_accepted_gives_feedback_and_succeeds(
    navigation: tuple[MultiThreadedExecutor, ActionClient, FakeNavigator],
) -> None:
    executor, client, _ = navigation
    feedback: list[float] = []
    sent = client.send_goal_async(
        _goal(3.0), feedback_callback=lambda m: feedback.append(m.feedback.distance_remaining)
    )
    spin_until(executor, sent.done)
    handle = sent.result()
    assert handle.accepted
    result = handle.get_result_async()
    spin_until(executor, result.done)
    assert result.result().status == 4  # action_msgs/GoalStatus.STATUS_SUCCEEDED
    assert result.result().result.error_code == NavigateToPose.Result.NONE
    assert feedback and feedback[0] == 5.0 and feedback[-1] == 1.0


def test_action_goal_can_be_cancelled(
    navigation: tuple[MultiThreadedExecutor, ActionClient, FakeNavigator],
) -> None:
    executor, client, navigator = navigation
    navigator.steps = 500
    sent = client.send_goal_async(_goal(1.0))
    spin_until(executor, sent.done)
    handle = sent.result()
    cancel = handle.cancel_goal_async()
    spin_until(executor, cancel.done)
    assert len(cancel.result().goals_canceling) == 1
    result = handle.get_result_async()
    spin_until(executor, result.done)
    assert result.result().status == 5  # action_msgs/GoalStatus.STATUS_CANCELED


def test_rclpy_uses_the_domain_from_the_environment(ros_context: object) -> None:
    assert rclpy.utilities.get_default_context() is not ros_context
    assert ros_context.get_domain_id() == int(os.environ["ROS_DOMAIN_ID"])


def test_a_deleted_participant_leaves_no_action_server_in_the_domain(
        ros_context: Any) -> None:
    """Shutting a context down leaves its nodes' action servers in the domain until the
    garbage goes; ``delete_participant`` takes them out at once."""
    from rclpy.action import ActionServer
    from rclpy.context import Context

    goals = "/foundation_test/navigate_to_pose/_action/send_goal"
    probe = Node("probe", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(probe)
    served = Context()
    rclpy.init(context=served)
    node = Node("served", context=served)
    ActionServer(node, NavigateToPose, "/foundation_test/navigate_to_pose", lambda _: None)
    spin_until(executor, lambda: probe.count_services(goals) == 1, "the server")
    served.try_shutdown()
    executor.spin_once(timeout_sec=1.0)
    assert probe.count_services(goals) == 1, "rclpy's shutdown alone takes the server out now"
    delete_participant(served)
    spin_until(executor, lambda: probe.count_services(goals) == 0, "the server to go")
