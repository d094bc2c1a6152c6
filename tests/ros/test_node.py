"""The executive's node: sim time, no parameter services, no default QoS-event handlers, and
one client per service or action however many behaviours call it."""

from __future__ import annotations

from typing import Any

from nav2_msgs.action import NavigateToPose
from rclpy.event_handler import SubscriptionEventCallbacks
from servicesim_competition.srv import PickUpGuest, RoomInfo
from std_msgs.msg import String

from bt_servicesim.ros.node import ExecutiveNode, shared_action_client, shared_client


def test_the_node_runs_on_sim_time_without_parameter_services(ros_context: Any) -> None:
    node = ExecutiveNode("executive_under_test", context=ros_context)
    try:
        assert node.get_parameter("use_sim_time").value is True
        assert not [service for service in node.services
                    if "parameter" in service.srv_name or "type_description" in
                    service.srv_name]
    finally:
        node.destroy_node()


def test_subscriptions_and_publishers_add_no_event_handlers_unless_asked(
        ros_context: Any) -> None:
    node = ExecutiveNode("executive_under_test", context=ros_context)
    try:
        before = len(list(node.waitables))
        node.create_subscription(String, "/quiet", lambda _: None, 10)
        node.create_publisher(String, "/quiet", 10)
        assert len(list(node.waitables)) == before
        asked = SubscriptionEventCallbacks(message_lost=lambda _: None,
                                           use_default_callbacks=False)
        node.create_subscription(String, "/loud", lambda _: None, 10, event_callbacks=asked)
        assert len(list(node.waitables)) == before + 1
    finally:
        node.destroy_node()


def test_behaviours_share_one_client_per_service_and_action(ros_context: Any) -> None:
    node = ExecutiveNode("executive_under_test", context=ros_context)
    try:
        room = shared_client(node, RoomInfo, "/servicesim/room_info")
        assert shared_client(node, RoomInfo, "/servicesim/room_info") is room
        assert shared_client(node, PickUpGuest, "/servicesim/pickup_guest") is not room
        assert shared_client(node, RoomInfo, "/other/room_info") is not room
        action = shared_action_client(node, NavigateToPose, "/servicebot/navigate_to_pose")
        assert shared_action_client(node, NavigateToPose,
                                    "/servicebot/navigate_to_pose") is action
        assert len(list(node.clients)) == 3
    finally:
        node.destroy_node()


def test_clients_are_not_shared_between_nodes(ros_context: Any) -> None:
    first = ExecutiveNode("first_executive", context=ros_context)
    second = ExecutiveNode("second_executive", context=ros_context)
    try:
        assert (shared_client(first, RoomInfo, "/servicesim/room_info")
                is not shared_client(second, RoomInfo, "/servicesim/room_info"))
    finally:
        first.destroy_node()
        second.destroy_node()
