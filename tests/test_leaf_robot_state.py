"""Topic readers and guest conditions, with real publishers over DDS and a /clock of our own.

The executive's node runs on sim time; the test publishes /clock and jumps it, so staleness
and grace periods are checked in sim seconds without waiting for them in wall time.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import py_trees
import pytest
from builtin_interfaces.msg import Time
from nav_msgs.msg import OccupancyGrid, Odometry
from py_trees.blackboard import Blackboard
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from servicesim_competition.msg import ActorNames

import bt_servicesim.behaviours.actions.navigate_to_pose  # noqa: F401  (registers NavigateToPose for the XML test)
from bt_servicesim.behaviours.actions.guest_following import GuestFollowing
from bt_servicesim.behaviours.actions.topic_readers import (
    MAP_QOS,
    MapToBlackboard,
    OdomToBlackboard,
    RfidToBlackboard,
)
from bt_servicesim.behaviours.conditions.guest_in_range import GuestInRange
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.messages import pose_to_msg

Status = py_trees.common.Status
GUEST = "human_20843"


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    Blackboard.clear()
    yield
    Blackboard.clear()


class World:
    """The executive's sim-time node, and a simulator node publishing /clock and sensors."""

    def __init__(self, context: object) -> None:
        self.node = Node(
            "executive", context=context,
            parameter_overrides=[Parameter("use_sim_time", value=True)],
        )
        self.simulator = Node("simulator", context=context)
        self.clock = self.simulator.create_publisher(Clock, "/clock", 10)
        self.rfid = self.simulator.create_publisher(ActorNames, "/servicebot/rfid", 10)
        self.odom = self.simulator.create_publisher(Odometry, "/servicebot/odom", 10)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.simulator)

    def jump_to(self, seconds: float) -> None:
        target = round(seconds * 1e9)
        message = Clock(clock=Time(sec=target // 10**9, nanosec=target % 10**9))
        self.spin_until(lambda: self.node.get_clock().now().nanoseconds == target,
                        before=lambda: self.clock.publish(message))

    def spin_until(
        self, done: Callable[[], bool], before: Callable[[], Any] = lambda: None,
        limit_s: float = 10.0,
    ) -> None:
        deadline = time.monotonic() + limit_s
        while not done():
            assert time.monotonic() < deadline, "condition not reached"
            before()
            self.executor.spin_once(timeout_sec=0.01)

    def shutdown(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.simulator.destroy_node()


@pytest.fixture
def world(ros_context: object) -> Iterator[World]:
    world = World(ros_context)
    yield world
    world.shutdown()


def ready(behaviour: Any, node: Node | None = None, **remappings: str) -> Any:
    behaviour.setup_ports(port_remappings=remappings)
    if node is not None:
        behaviour.setup(node=node)
    return behaviour


def rfid_reader(world: World) -> RfidToBlackboard:
    return ready(RfidToBlackboard(name="rfid"), world.node,
                 actors_in_range="/actors", rfid_age="/rfid_age")


def test_rfid_before_any_message_is_nobody_in_range(world: World) -> None:
    world.jump_to(5.0)
    rfid = rfid_reader(world)
    rfid.tick_once()
    assert rfid.status == Status.SUCCESS
    assert Blackboard.get("/actors") == []
    assert Blackboard.get("/rfid_age") == math.inf
    assert rfid.feedback_message == "no RFID message yet: nobody in range"


def test_rfid_list_goes_stale_when_the_sensor_falls_silent(world: World) -> None:
    world.jump_to(10.0)
    rfid = rfid_reader(world)
    message = ActorNames(actor_names=[GUEST, "human_11111"])
    world.spin_until(lambda: rfid._message is not None, before=lambda: world.rfid.publish(message))
    rfid.tick_once()
    assert rfid.status == Status.SUCCESS
    assert Blackboard.get("/actors") == [GUEST, "human_11111"]
    assert Blackboard.get("/rfid_age") == 0.0
    world.jump_to(11.5)  # silent, but within stale_after
    rfid.tick_once()
    assert Blackboard.get("/actors") == [GUEST, "human_11111"]
    assert Blackboard.get("/rfid_age") == pytest.approx(1.5)
    world.jump_to(12.5)  # silent for longer than 2 s: nobody is in range
    rfid.tick_once()
    assert rfid.status == Status.SUCCESS
    assert Blackboard.get("/actors") == []
    assert Blackboard.get("/rfid_age") == pytest.approx(2.5)
    assert "silent for 2.5 sim s" in rfid.feedback_message


def test_odom_waits_for_the_first_message(world: World) -> None:
    odom = ready(OdomToBlackboard(name="odom"), world.node, robot_pose="/pose")
    odom.tick_once()
    assert odom.status == Status.RUNNING
    assert "waiting for the first message" in odom.feedback_message
    message = Odometry()
    message.pose.pose = pose_to_msg(Pose2D(1.0, 2.0, 0.5))
    world.spin_until(lambda: odom._message is not None, before=lambda: world.odom.publish(message))
    odom.tick_once()
    assert odom.status == Status.SUCCESS
    pose = Blackboard.get("/pose")
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((1.0, 2.0, 0.5))


def test_map_reaches_a_late_joining_reader(world: World) -> None:
    latched = world.simulator.create_publisher(OccupancyGrid, "/servicebot/map", MAP_QOS)
    grid = OccupancyGrid()
    grid.header.frame_id = "map"
    grid.info.resolution, grid.info.width, grid.info.height = 0.05, 4, 3
    grid.info.origin.position.x = -30.0
    grid.data = [0] * 11 + [100]
    latched.publish(grid)  # published once, before the reader exists
    reader = ready(MapToBlackboard(name="map"), world.node, occupancy="/occupancy")
    reader.tick_once()
    assert reader.status == Status.RUNNING
    world.spin_until(lambda: reader._message is not None)
    reader.tick_once()
    assert reader.status == Status.SUCCESS
    assert Blackboard.exists("/occupancy")
    # OccupancyGrid2D once bt_servicesim.planning.occupancy exists; the message itself until then
    assert type(Blackboard.get("/occupancy")).__name__ in {"OccupancyGrid2D", "OccupancyGrid"}


def test_guest_in_range() -> None:
    condition = ready(GuestInRange(name="in_range"), guest_name="/guest",
                      actors_in_range="/actors")
    Blackboard.set("/guest", GUEST)
    Blackboard.set("/actors", ["human_11111", GUEST])
    condition.tick_once()
    assert condition.status == Status.SUCCESS
    assert condition.feedback_message == f"{GUEST} in RFID range"
    Blackboard.set("/actors", ["human_11111"])
    condition.tick_once()
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == f"{GUEST} not in RFID range"


def test_guest_following_remembers_and_then_loses_the_guest(world: World) -> None:
    world.jump_to(100.0)
    monitor = ready(GuestFollowing(name="following", grace=3.0), world.node,
                    guest_name="/guest", actors_in_range="/actors", robot_pose="/pose",
                    guest_last_seen="/last_seen")
    Blackboard.set("/guest", GUEST)
    Blackboard.set("/actors", [GUEST])
    Blackboard.set("/pose", Pose2D(1.0, 1.0))
    monitor.tick_once()
    assert monitor.status == Status.RUNNING
    assert Blackboard.get("/last_seen") == Pose2D(1.0, 1.0)

    Blackboard.set("/actors", [])
    Blackboard.set("/pose", Pose2D(4.0, 1.0))
    world.jump_to(102.0)
    monitor.tick_once()
    assert monitor.status == Status.RUNNING
    assert "out of range for 2.0/3.0" in monitor.feedback_message
    assert Blackboard.get("/last_seen") == Pose2D(1.0, 1.0)

    world.jump_to(103.5)
    monitor.tick_once()
    assert monitor.status == Status.FAILURE
    assert monitor.feedback_message == "guest lost: not in RFID range for 3.5 s"


def test_guest_following_is_reset_by_each_sighting(world: World) -> None:
    world.jump_to(100.0)
    monitor = ready(GuestFollowing(name="following", grace=3.0), world.node,
                    guest_name="/guest", actors_in_range="/actors")
    Blackboard.set("/guest", GUEST)
    Blackboard.set("/actors", [])
    monitor.tick_once()
    world.jump_to(102.5)
    Blackboard.set("/actors", [GUEST])
    monitor.tick_once()  # seen again: the grace period restarts
    Blackboard.set("/actors", [])
    world.jump_to(105.0)
    monitor.tick_once()
    assert monitor.status == Status.RUNNING
    world.jump_to(105.6)
    monitor.tick_once()
    assert monitor.status == Status.FAILURE


XML = """
<root main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="executive" memory="false">
      <Sequence name="topics2bb" memory="false">
        <RfidToBlackboard name="rfid" actors_in_range="{actors}" stale_after="1.5"/>
        <OdomToBlackboard name="odom" robot_pose="{pose}"/>
        <MapToBlackboard name="map" occupancy="{occupancy}"/>
      </Sequence>
      <PublishInitialPose name="initial_pose" pose="{start}"/>
      <GuestInRange name="in_range" guest_name="{guest}" actors_in_range="{actors}"/>
      <Parallel name="guide" policy="success_on_one">
        <NavigateToPose name="navigate" goal="{goal}" action="/xml/navigate_to_pose"
                        server_timeout="2.5" timeout="60.0"/>
        <GuestFollowing name="following" guest_name="{guest}" actors_in_range="{actors}"
                        robot_pose="{pose}" guest_last_seen="{last_seen}" grace="4.0"/>
      </Parallel>
    </Sequence>
  </BehaviorTree>
</root>
"""


def test_robot_state_and_navigation_tags_build_from_xml(world: World, tmp_path: Path) -> None:
    xml_file = tmp_path / "guide.xml"
    xml_file.write_text(XML)
    root = parse_behaviour_tree_xml(str(xml_file), node_registry="auto")
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(node=world.node, timeout=5.0)
    nodes = {type(node).__name__: node for node in root.iterate()}
    assert nodes["RfidToBlackboard"].stale_after == 1.5
    assert nodes["GuestFollowing"].grace == 4.0
    navigate = nodes["NavigateToPose"]
    assert (navigate.action, navigate.server_timeout, navigate.timeout) == (
        "/xml/navigate_to_pose", 2.5, 60.0,
    )
    tree.tick()  # no odometry yet: the topics2bb sequence waits
    assert nodes["RfidToBlackboard"].status == Status.SUCCESS
    assert nodes["OdomToBlackboard"].status == Status.RUNNING
    assert Blackboard.get("/actors") == []
