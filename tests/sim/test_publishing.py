"""The simulator's publishers keep what reliable delivery needs to repair a loss."""

from __future__ import annotations

from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)

from servicesim_sim.model.scenario import Difficulty
from servicesim_sim.ros.node import SimulatorNode
from servicesim_sim.ros.publishing import LATCHED, REPAIR_DEPTH, repairable
from servicesim_sim.settings import SimSettings
from servicesim_sim.world.files import DEFAULT_WORLD, load_world


def test_a_reliable_writer_keeps_enough_to_send_a_lost_message_again() -> None:
    deeper = repairable(LATCHED)
    assert isinstance(deeper, QoSProfile)
    assert deeper.depth == REPAIR_DEPTH
    assert (deeper.reliability, deeper.durability) == (ReliabilityPolicy.RELIABLE,
                                                       DurabilityPolicy.TRANSIENT_LOCAL)
    assert LATCHED.depth == 1, "the profile asked for is left as it is"
    assert repairable(2) == REPAIR_DEPTH
    assert repairable(100) == 100


def test_best_effort_and_keep_all_writers_are_left_as_they_are() -> None:
    assert repairable(qos_profile_sensor_data) is qos_profile_sensor_data
    keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1)
    assert repairable(keep_all) is keep_all


def test_every_reliable_publisher_of_the_simulator_keeps_two_periods_of_messages(
        ros_context: Context) -> None:
    settings = SimSettings(world=load_world(DEFAULT_WORLD), seed=None, speed=0.0,
                           difficulty=Difficulty.default(), camera_rate_hz=24.0)
    node = Node("servicesim", context=ros_context)
    try:
        SimulatorNode(settings, node=node)
        reliable = {publisher.topic_name: publisher.qos_profile.depth
                    for publisher in node.publishers
                    if publisher.qos_profile.reliability == ReliabilityPolicy.RELIABLE
                    and publisher.qos_profile.history == HistoryPolicy.KEEP_LAST
                    and not publisher.topic_name.startswith("/servicesim/lockstep/")}
        assert "/servicesim/referee/penalty_causes" in reliable
        assert "/servicebot/camera_front/image_raw" in reliable
        shallow = {topic: depth for topic, depth in reliable.items() if depth < REPAIR_DEPTH}
        assert not shallow, f"writers that lose a message for good: {shallow}"
    finally:
        node.destroy_node()
