"""The foundation: built interfaces work over real DDS, and the ROS defaults are in force."""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import pytest
import rclpy
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from servicesim_competition.action import NavigateToPose
from servicesim_competition.srv import PickUpGuest, RoomInfo

from bt_servicesim.ros.environment import apply_localhost_defaults


def spin_until(executor: Executor, done: Callable[[], bool], limit_s: float = 10.0) -> None:
    deadline = time.monotonic() + limit_s
    while not done():
        assert time.monotonic() < deadline, "ROS round trip did not complete"
        executor.spin_once(timeout_sec=0.05)


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
    server = Node("pickup_server", context=ros_context)
    client_node = Node("pickup_client", context=ros_context)
    received: list[tuple[str, str]] = []

    def handle(
        request: PickUpGuest.Request, response: PickUpGuest.Response
    ) -> PickUpGuest.Response:
        received.append((request.guest_name, request.robot_name))
        response.success = request.robot_name == "servicebot"
        return response

    server.create_service(PickUpGuest, "/servicesim/pickup_guest", handle)
    client = client_node.create_client(PickUpGuest, "/servicesim/pickup_guest")
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(server)
    executor.add_node(client_node)
    assert client.wait_for_service(timeout_sec=10.0)

    request = PickUpGuest.Request(guest_name="human_20843", robot_name="servicebot")
    future = client.call_async(request)
    spin_until(executor, future.done)
    assert received == [("human_20843", "servicebot")]
    assert future.result().success is True

    future = client.call_async(PickUpGuest.Request(guest_name="human_20843", robot_name="intruder"))
    spin_until(executor, future.done)
    assert future.result().success is False
    executor.shutdown()


def test_room_info_geometry_fields_survive_the_wire(ros_context: object) -> None:
    server = Node("room_server", context=ros_context)
    client_node = Node("room_client", context=ros_context)

    def handle(request: RoomInfo.Request, response: RoomInfo.Response) -> RoomInfo.Response:
        if request.name == "FrontElevator":
            response.min.x, response.min.y, response.max.x, response.max.y = -1.5, 0.0, 1.5, 2.7
        return response

    server.create_service(RoomInfo, "/servicesim/room_info", handle)
    client = client_node.create_client(RoomInfo, "/servicesim/room_info")
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(server)
    executor.add_node(client_node)
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(RoomInfo.Request(name="FrontElevator"))
    spin_until(executor, future.done)
    box = future.result()
    assert (box.min.x, box.min.y, box.max.x, box.max.y) == (-1.5, 0.0, 1.5, 2.7)
    executor.shutdown()


class _CountingNavigator:
    """A NavigateToPose server that gives feedback for ``steps`` executions, then succeeds."""

    def __init__(self, node: Node, steps: int) -> None:
        self.steps = steps
        self.server = ActionServer(
            node, NavigateToPose, "/servicebot/navigate_to_pose",
            execute_callback=self.execute,
            goal_callback=lambda goal: GoalResponse.ACCEPT,
            cancel_callback=lambda handle: CancelResponse.ACCEPT,
        )

    def execute(self, handle):
        goal = handle.request
        for remaining in range(self.steps, 0, -1):
            if handle.is_cancel_requested:
                handle.canceled()
                return NavigateToPose.Result(error_msg="canceled")
            feedback = NavigateToPose.Feedback(distance_remaining=float(remaining))
            feedback.current_pose.pose.position.x = goal.pose.pose.position.x - remaining
            handle.publish_feedback(feedback)
            time.sleep(0.02)
        handle.succeed()
        return NavigateToPose.Result(error_code=NavigateToPose.Result.NONE, error_msg="")


@pytest.fixture
def navigation(ros_context: object):
    from rclpy.executors import MultiThreadedExecutor

    server_node = Node("navigator", context=ros_context)
    client_node = Node("navigation_client", context=ros_context)
    navigator = _CountingNavigator(server_node, steps=5)
    executor = MultiThreadedExecutor(num_threads=2, context=ros_context)
    executor.add_node(server_node)
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


def test_action_goal_is_accepted_gives_feedback_and_succeeds(navigation) -> None:
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


def test_action_goal_can_be_cancelled(navigation) -> None:
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
