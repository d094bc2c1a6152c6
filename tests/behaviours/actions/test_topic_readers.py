"""The topic readers, with real publishers over DDS and a /clock of our own.

The executive's node runs on sim time; the test publishes /clock and jumps it, so staleness is
checked in sim seconds without waiting for it in wall time.
"""

from __future__ import annotations

import math
from pathlib import Path

import py_trees
import pytest
from nav_msgs.msg import OccupancyGrid
from py_trees.blackboard import Blackboard
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml
from servicesim_competition.msg import ActorNames

from bt_servicesim.behaviours.actions.topic_readers import (
    MAP_QOS,
    CostmapToBlackboard,
    MapToBlackboard,
    RfidToBlackboard,
)
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import Costmap2D
from tests.fakes.graphs import SensorWorld
from tests.fakes.guest import GUEST
from tests.fakes.leaves import ready

Status = py_trees.common.Status


def rfid_reader(world: SensorWorld) -> RfidToBlackboard:
    return ready(RfidToBlackboard(name="rfid"), world.node,
                 actors_in_range="/actors", rfid_age="/rfid_age")


def test_rfid_before_any_message_is_nobody_in_range(world: SensorWorld) -> None:
    world.jump_to(5.0)
    rfid = rfid_reader(world)
    rfid.tick_once()
    assert rfid.status == Status.SUCCESS
    assert Blackboard.get("/actors") == []
    assert Blackboard.get("/rfid_age") == math.inf
    assert rfid.feedback_message == "no RFID message yet: nobody in range"


def test_rfid_list_goes_stale_when_the_sensor_falls_silent(world: SensorWorld) -> None:
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


def test_map_reaches_a_late_joining_reader(world: SensorWorld) -> None:
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
    occupancy = Blackboard.get("/occupancy")
    assert isinstance(occupancy, OccupancyGrid2D)
    assert (occupancy.width, occupancy.height) == (4, 3)
    assert occupancy.values[2, 3] == 100  # the last cell, row 2 from the origin


def costmap_message(width: int, height: int, values: list[int], *, sec: int) -> OccupancyGrid:
    message = OccupancyGrid()
    message.header.frame_id = "map"
    message.header.stamp.sec = sec
    message.info.resolution, message.info.width, message.info.height = 0.1, width, height
    message.info.origin.position.x, message.info.origin.position.y = -3.0, 2.0
    message.data = values
    return message


def test_the_costmap_is_optional_and_written_as_each_one_arrives(world: SensorWorld) -> None:
    publisher = world.simulator.create_publisher(
        OccupancyGrid, "/servicebot/global_costmap/costmap", MAP_QOS)
    reader = ready(CostmapToBlackboard(name="costmap"), world.node, costmap="/costmap")
    reader.tick_once()
    assert reader.status == Status.SUCCESS  # the tree does not wait for it
    assert not Blackboard.exists("/costmap")
    publisher.publish(costmap_message(3, 2, [0, 0, 100, 0, 99, 0], sec=7))
    world.spin_until(lambda: reader._message is not None)
    reader.tick_once()
    costmap = Blackboard.get("/costmap")
    assert isinstance(costmap, Costmap2D) and reader.status == Status.SUCCESS
    assert costmap.values.tolist() == [[0, 0, 100], [0, 99, 0]]
    assert (costmap.origin_x, costmap.origin_y, costmap.stamp_s) == (-3.0, 2.0, 7.0)
    reader._on_message(costmap_message(4, 2, [0] * 6, sec=8))  # 4 x 2 cells, 6 values
    local = costmap_message(3, 2, [0] * 6, sec=9)
    local.header.frame_id = "odom"  # a local costmap: its cells are not where the map's are
    reader._on_message(local)
    reader.tick_once()
    assert Blackboard.get("/costmap") is costmap  # both were left out


XML = """
<root main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="executive" memory="false">
      <Sequence name="topics2bb" memory="false">
        <RfidToBlackboard name="rfid" actors_in_range="{actors}" stale_after="1.5"/>
        <LocalisedPoseToBlackboard name="pose" robot_pose="{pose}"/>
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


def test_robot_state_and_navigation_tags_build_from_xml(world: SensorWorld, tmp_path: Path) -> None:
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
    tree.tick()  # not localised yet: the topics2bb sequence waits
    assert nodes["RfidToBlackboard"].status == Status.SUCCESS
    assert nodes["LocalisedPoseToBlackboard"].status == Status.RUNNING
    assert Blackboard.get("/actors") == []
