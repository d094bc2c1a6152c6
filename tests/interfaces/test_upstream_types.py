"""The interface types built from upstream definitions are upstream's types: same name, same hash.

``nav2_msgs`` and ``tf2_msgs`` have no PyPI wheels, so ``interfaces/`` builds the types this
project needs from upstream's files, unchanged. A real ``bt_navigator``, costmap server or tf2
listener matches an endpoint only if the type's name and its RIHS01 hash (REP-2011, a digest of the
definition and of everything it refers to) are the ones its own build computed.

Where the expected hashes come from:

* ``tf2_msgs/msg/TFMessage``: ``RIHS01_e369d0f0...`` as ``ros2 topic info --verbose /tf`` reports
  it on a Jazzy robot running Nav2's AMCL, and as projects that speak /tf without ROS pin it
  (the carla-simulator ROS 2 middleware tests list it among the golden hashes read from
  ``/opt/ros/jazzy/share/tf2_msgs/msg/TFMessage.json``).
* ``nav2_msgs/action/NavigateToPose``: no public listing of the action's own hash was found. It
  was derived from upstream's text: ``nav2_msgs/action/NavigateToPose.action`` at
  ros-navigation/navigation2 branch ``kilted`` (commit 71a1d84f49dc48e226c96619188ee12054824ff3)
  built with the Kilted rosidl wheels' ``rosidl_generator_type_description`` (what
  ``interfaces/build.sh`` runs). The same pipeline reproduces the public TFMessage hash above and
  the public hash of the action's feedback topic type,
  ``nav2_msgs/action/NavigateToPose_FeedbackMessage`` = ``RIHS01_9d1f6fa2...``, pinned by a
  public rosbag tool for Nav2's NavigateToPose feedback, which is the only part of the action a
  bag records.
* ``nav2_msgs/srv/ClearEntireCostmap`` (the costmaps' clearing service, upstream's text at the
  same Kilted commit) and its request and response: ``RIHS01_553f54f9...``, ``RIHS01_365687a6...``
  and ``RIHS01_a0aeab7d...`` as another project's own colcon build of Nav2's ``nav2_msgs``
  generated them into ``clear_entire_costmap__description.c`` (public repository
  thomasankara/hive_ws2, commit bb4ae947b7c2b6b0fa86dbb7a934f95b4ef751d8,
  ``build/nav2_msgs/rosidl_generator_c/nav2_msgs/srv/detail/``), whose embedded source text is
  Kilted's file. On the wire a service is two DDS topics, its requests and its replies, and the
  middleware announces the request's and the response's hashes on them.

The tests read the hashes twice: from the type description the build installs and from the
endpoint the middleware announces (what a real peer compares).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest

TF_MESSAGE = "tf2_msgs/msg/TFMessage"
TF_MESSAGE_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"
NAVIGATE_TO_POSE = "nav2_msgs/action/NavigateToPose"
NAVIGATE_TO_POSE_HASH = "RIHS01_a56dba8a3234a1215e610180dc703ae25bbf406dded8b54887891c9732857eab"
FEEDBACK_MESSAGE = "nav2_msgs/action/NavigateToPose_FeedbackMessage"
FEEDBACK_MESSAGE_HASH = "RIHS01_9d1f6fa2eb975ce733b419ac2e97b134d8ff92b6478b6559feed9a50bdfd82b3"
CLEAR_COSTMAP = "nav2_msgs/srv/ClearEntireCostmap"
CLEAR_COSTMAP_HASH = "RIHS01_553f54f9cadab44553fdf5627433fcb6701f71c1fc2eb55a7b4a004fdeeab952"
CLEAR_REQUEST = "nav2_msgs/srv/ClearEntireCostmap_Request"
CLEAR_REQUEST_HASH = "RIHS01_365687a69e15ff9f199447a047ab6fdd264272e6b4d12de0b71bd4a6e4137e99"
CLEAR_RESPONSE = "nav2_msgs/srv/ClearEntireCostmap_Response"
CLEAR_RESPONSE_HASH = "RIHS01_a0aeab7debb4b503bf8d5edcadb896864aa3dda700452d8c9cfa6c4755956665"


def installed_hashes(package: str, relative: str) -> dict[str, str]:
    """Every type name -> RIHS01 hash in the type description the build installed (into the
    virtual environment's prefix, ``interfaces/build.sh``)."""
    path = Path(sys.prefix) / "share" / package / relative
    description = json.loads(path.read_text(encoding="utf-8"))
    return {entry["type_name"]: entry["hash_string"] for entry in description["type_hashes"]}


@pytest.mark.parametrize(("package", "relative", "name", "expected"), [
    ("tf2_msgs", "msg/TFMessage.json", TF_MESSAGE, TF_MESSAGE_HASH),
    ("nav2_msgs", "action/NavigateToPose.json", NAVIGATE_TO_POSE, NAVIGATE_TO_POSE_HASH),
    ("nav2_msgs", "action/NavigateToPose.json", FEEDBACK_MESSAGE, FEEDBACK_MESSAGE_HASH),
    ("nav2_msgs", "srv/ClearEntireCostmap.json", CLEAR_COSTMAP, CLEAR_COSTMAP_HASH),
    ("nav2_msgs", "srv/ClearEntireCostmap.json", CLEAR_REQUEST, CLEAR_REQUEST_HASH),
    ("nav2_msgs", "srv/ClearEntireCostmap.json", CLEAR_RESPONSE, CLEAR_RESPONSE_HASH),
])
def test_the_installed_type_description_has_upstreams_name_and_hash(
        package: str, relative: str, name: str, expected: str) -> None:
    assert installed_hashes(package, relative)[name] == expected


def announced(node: Any, topic: str, *, no_mangle: bool = False) -> list[tuple[str, str]]:
    """(type name, type hash) of every endpoint on ``topic`` as the middleware announces it;
    ``no_mangle`` for the DDS topics under a service (``rq/<service>Request``, ``rr/...Reply``)."""
    endpoints = (node.get_publishers_info_by_topic(topic, no_mangle=no_mangle)
                 + node.get_subscriptions_info_by_topic(topic, no_mangle=no_mangle))
    return [(info.topic_type, str(info.topic_type_hash)) for info in endpoints]


def test_the_endpoints_announce_upstreams_types(ros_context: Any) -> None:
    from nav2_msgs.action import NavigateToPose
    from rclpy.action import ActionClient
    from rclpy.node import Node
    from tf2_msgs.msg import TFMessage

    node = Node("upstream_types", context=ros_context)
    try:
        node.create_publisher(TFMessage, "/tf", 10)
        ActionClient(node, NavigateToPose, "/navigate_to_pose")
        assert announced(node, "/tf") == [(TF_MESSAGE, TF_MESSAGE_HASH)]
        assert announced(node, "/navigate_to_pose/_action/feedback") == [
            (FEEDBACK_MESSAGE, FEEDBACK_MESSAGE_HASH)]
    finally:
        node.destroy_node()


def test_the_costmap_clearing_service_announces_upstreams_types(ros_context: Any) -> None:
    from nav2_msgs.srv import ClearEntireCostmap
    from rclpy.node import Node

    service = "/upstream_types/clear_entirely_global_costmap"
    node = Node("upstream_service_types", context=ros_context)
    try:
        node.create_service(ClearEntireCostmap, service, lambda _request, response: response)
        assert (service, [CLEAR_COSTMAP]) in node.get_service_names_and_types()
        assert set(announced(node, f"rq{service}Request", no_mangle=True)) == {
            ("nav2_msgs::srv::dds_::ClearEntireCostmap_Request_", CLEAR_REQUEST_HASH)}
        assert set(announced(node, f"rr{service}Reply", no_mangle=True)) == {
            ("nav2_msgs::srv::dds_::ClearEntireCostmap_Response_", CLEAR_RESPONSE_HASH)}
    finally:
        node.destroy_node()
