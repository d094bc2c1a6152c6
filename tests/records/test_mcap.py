"""The MCAP recording: messages published over real DDS come back out of the file, field for field.

A test node publishes one message on every recorded topic (and plays the referee's task_info
service); the recorder runs on a second node with ``use_sim_time`` while the test drives
``/clock``. The file is read back with the mcap library and mcap-ros2-support's decoder, which
builds its decoders from nothing but the schemas in the file, as Foxglove does.
"""

from __future__ import annotations

import array
import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseWithCovarianceStamped, TransformStamped
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import OccupancyGrid, Odometry
from py_trees.common import Status
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from servicesim_competition.msg import ActorNames, ActorStates, RefereeState
from servicesim_competition.srv import TaskInfo
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from bt_servicesim.behaviours.actions.localised_pose import LocalisedPoseToBlackboard
from bt_servicesim.behaviours.actions.topic_readers import RfidToBlackboard
from bt_servicesim.records.mcap import (
    PENALTY_CAUSES_TOPIC,
    RECORDED_TOPICS,
    TASK_TOPIC,
    TREE_TOPIC,
    McapRecorder,
    SnapshotNodes,
    TaskTopic,
    TreeTopic,
    complete_definition,
    field_types,
    snapshot_json,
    snapshot_text,
)
from bt_servicesim.records.tree_log import TickRecord, TreeState
from bt_servicesim.ros.node import ExecutiveNode
from bt_servicesim.ros.shared_subscription import shared_subscription
from tests.fakes.graphs import SimTimeGraph

SIM_NS = 42_500_000_000


def odometry_at(x: float) -> Odometry:
    odom = Odometry()
    odom.header.frame_id, odom.pose.pose.position.x = "odom", x
    return odom


def sample_messages() -> dict[str, Any]:
    odom = Odometry()
    odom.header.stamp = Time(sec=42, nanosec=500_000_000)
    odom.header.frame_id, odom.child_frame_id = "odom", "base_footprint"
    odom.pose.pose.position.x, odom.pose.pose.position.y = 1.25, -3.5
    odom.pose.pose.orientation.z, odom.pose.pose.orientation.w = 0.6, 0.8
    odom.pose.covariance[0] = 0.01
    odom.twist.twist.linear.x = 0.5
    grid = OccupancyGrid()
    grid.header.frame_id = "map"
    grid.info.resolution, grid.info.width, grid.info.height = 0.0625, 4, 3  # float32-exact
    grid.info.origin.position.x = -30.0
    grid.data = array.array("b", [0, 100, -1, 0] * 3)
    referee = RefereeState(
        task_running=True, score=12.5, task_sim_time=30.0,
        checkpoint_names=["go_to_pick_up", "pick_up_guest", "drop_off_guest", "return_to_start"],
        checkpoint_done=[True, False, False, False], checkpoint_sim_time=[10.0, 0.0, 0.0, 0.0],
        failed_pickups=1, drifts=2, contact=0.25)
    actors = ActorStates(names=["human_20843", "human_00001"], roles=["guest", "walker"],
                         positions=[Point(x=1.0, y=2.0), Point(x=-4.0, y=0.5)],
                         guest_state="following")
    transform = TransformStamped(child_frame_id="odom")
    transform.header.frame_id = "map"
    transform.transform.translation.x, transform.transform.rotation.z = 10.975, 1.0
    estimate = PoseWithCovarianceStamped()
    estimate.header.frame_id = "map"
    estimate.pose.pose.position.x, estimate.pose.covariance[35] = 9.5, 0.0025
    name = Marker(ns="area_names", id=3, type=Marker.TEXT_VIEW_FACING, text="PublicCafe")
    name.header.frame_id, name.scale.z, name.color.a = "map", 0.25, 1.0
    plan = Marker(ns="plan", id=0, type=Marker.LINE_STRIP,
                  points=[Point(x=1.0, y=2.0), Point(x=1.5, y=2.5, z=0.125)])
    return {
        "/servicebot/odom": odom,
        "/servicesim/markers": MarkerArray(markers=[
            Marker(ns="people", action=Marker.DELETEALL), name, plan]),
        "/tf": TFMessage(transforms=[transform]),
        "/servicebot/amcl_pose": estimate,
        "/servicebot/rfid": ActorNames(actor_names=["human_20843"]),
        "/servicesim/referee": referee,
        "/servicesim/actors": actors,
        "/servicebot/map": grid,
        PENALTY_CAUSES_TOPIC: String(data='{"sim_time_s": 30.0, "sums": '
                                          '{"approximation/walker/human_00001": 2.5}}'),
    }


class Graph(SimTimeGraph):
    """A publishing node and a recording node (sim time) on one executor."""

    def __init__(self, context: Any, tmp_path: Path) -> None:
        super().__init__(context, node_name="test_recorder", simulator_name="test_world")
        self.recorder_node, self.publisher_node = self.node, self.simulator
        self.path = tmp_path / "run.mcap"
        self.publishers = {
            topic.name: self.publisher_node.create_publisher(topic.message_type, topic.name,
                                                             topic.qos)
            for topic in RECORDED_TOPICS if topic.name not in (TASK_TOPIC, TREE_TOPIC)
        }

    def start_sim_clock(self) -> None:
        self.jump_to(SIM_NS / 1e9)


@pytest.fixture
def graph(ros_context: Any, tmp_path: Path) -> Iterator[Graph]:
    built = Graph(ros_context, tmp_path)
    yield built
    built.shutdown()


def read_back(path: Path) -> list[tuple[str, str, int, Any]]:
    """(topic, schema name, log time, decoded message) for every message in the file."""
    with path.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [(channel.topic, schema.name, message.log_time, decoded)
                for schema, channel, message, decoded in reader.iter_decoded_messages()]


def assert_same_fields(published: Any, decoded: Any, where: str) -> None:
    """Every field of an rclpy message equals the decoded one, recursively."""
    if hasattr(published, "get_fields_and_field_types"):
        for field in published.get_fields_and_field_types():
            assert_same_fields(getattr(published, field), getattr(decoded, field),
                               f"{where}.{field}")
    elif isinstance(published, (list, tuple, array.array)) or hasattr(published, "tolist"):
        values = published.tolist() if hasattr(published, "tolist") else list(published)
        assert len(values) == len(decoded), where
        for index, (mine, theirs) in enumerate(zip(values, decoded, strict=True)):
            assert_same_fields(mine, theirs, f"{where}[{index}]")
    else:
        assert published == decoded, where


def test_every_recorded_message_decodes_to_what_was_published_at_sim_time(
        graph: Graph) -> None:
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path)
    graph.start_sim_clock()
    messages = sample_messages()
    graph.spin_until(lambda: all(p.get_subscription_count() > 0
                                 for p in graph.publishers.values()), "the recorder to match")
    for topic, message in messages.items():
        graph.publishers[topic].publish(message)
    graph.spin_until(lambda: all(recorder.counts[topic] == 1 for topic in messages),
                     "every message to arrive")
    recorder.close()
    recorded = read_back(graph.path)
    assert sorted(topic for topic, *_ in recorded) == sorted(messages)
    for topic, schema_name, log_time, decoded in recorded:
        published = messages[topic]
        assert schema_name == f"{type(published).__module__.split('.')[0]}/msg/" \
                              f"{type(published).__name__}"
        assert log_time == SIM_NS, topic
        assert_same_fields(published, decoded, topic)


def test_a_burst_of_messages_is_recorded_whole_and_in_order_in_one_callback(
        graph: Graph) -> None:
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path)
    graph.start_sim_clock()
    odom = graph.publishers["/servicebot/odom"]
    graph.spin_until(lambda: odom.get_subscription_count() > 0, "the recorder to match")
    for value in range(8):  # within the subscription's queue depth (50)
        odom.publish(odometry_at(float(value)))
    time.sleep(0.5)  # let DDS deliver the whole burst before anything is taken
    graph.spin_until(lambda: recorder.counts["/servicebot/odom"] > 0, "the first odometry")
    assert recorder.counts["/servicebot/odom"] == 8, "the first callback takes the queue"
    recorder.close()
    xs = [decoded.pose.pose.position.x for topic, _, _, decoded in read_back(graph.path)
          if topic == "/servicebot/odom"]
    assert xs == [float(value) for value in range(8)]


def test_a_reader_of_a_recorded_topic_shares_the_recorders_subscription(graph: Graph) -> None:
    """The tree reads odometry as sensor data (best effort, 5 deep), as the recorder does."""
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path)
    heard: list[float] = []
    subscriptions = len(list(graph.recorder_node.subscriptions))
    shared_subscription(graph.recorder_node, Odometry, "/servicebot/odom",
                        lambda message: heard.append(message.pose.pose.position.x),
                        qos_profile_sensor_data)
    assert len(list(graph.recorder_node.subscriptions)) == subscriptions
    graph.start_sim_clock()
    odom = graph.publishers["/servicebot/odom"]
    graph.spin_until(lambda: odom.get_subscription_count() > 0, "the recorder to match")
    for value in range(3):
        odom.publish(odometry_at(float(value)))
    graph.spin_until(lambda: recorder.counts["/servicebot/odom"] == 3, "three odometries")
    recorder.close()
    assert heard == [0.0, 1.0, 2.0]


@pytest.mark.parametrize("lockstep", [False, True], ids=["free running", "lockstep"])
def test_the_trees_readers_of_recorded_topics_add_no_subscription(
        ros_context: Any, tmp_path: Path, lockstep: bool) -> None:
    """Odometry, transforms and RFID each come once a period: a second subscription would
    have the backend send each to the executive twice. In lockstep every subscription is
    reliable, the recorder's too (the run decides that before it records)."""
    node = ExecutiveNode("recording_executive", context=ros_context)
    node.reliable_subscriptions = lockstep
    recorder = McapRecorder(node=node, path=tmp_path / "run.mcap")
    recording = len(list(node.subscriptions))
    LocalisedPoseToBlackboard(name="pose").setup(node=node)
    RfidToBlackboard(name="rfid").setup(node=node)
    assert len(list(node.subscriptions)) == recording
    recorder.close()
    node.destroy_node()


@pytest.mark.parametrize("offered", [ReliabilityPolicy.BEST_EFFORT, ReliabilityPolicy.RELIABLE],
                         ids=["best-effort", "reliable"])
def test_sensor_topics_are_recorded_whether_published_best_effort_or_reliably(
        graph: Graph, offered: ReliabilityPolicy) -> None:
    """A robot's drivers often publish odometry and sensors best effort, which a reliable
    reader would never hear; our simulator publishes them reliably. Both must be recorded."""
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path)
    graph.start_sim_clock()
    sensors = {"/servicebot/odom": odometry_at(2.5),
               "/servicebot/rfid": ActorNames(actor_names=["human_20843"])}
    publishers = {topic: graph.publisher_node.create_publisher(
        type(message), topic, QoSProfile(depth=5, reliability=offered))
        for topic, message in sensors.items()}
    graph.spin_until(lambda: all(p.get_subscription_count() > 0 for p in publishers.values()),
                     "the recorder to match the sensors' publishers")
    for topic, message in sensors.items():
        publishers[topic].publish(message)
    graph.spin_until(lambda: all(recorder.counts[topic] == 1 for topic in sensors),
                     "both sensor messages to be recorded")
    recorder.close()
    recorded = {topic: decoded for topic, _, _, decoded in read_back(graph.path)}
    assert recorded["/servicebot/odom"].pose.pose.position.x == 2.5
    assert list(recorded["/servicebot/rfid"].actor_names) == ["human_20843"]


def test_the_file_follows_the_ros2_profile_with_qos_metadata(graph: Graph) -> None:
    McapRecorder(node=graph.recorder_node, path=graph.path).close()
    with graph.path.open("rb") as stream:
        reader = make_reader(stream)
        header = reader.get_header()
        summary = reader.get_summary()
    assert header.profile == "ros2"
    assert summary is not None
    channels = {channel.topic: channel for channel in summary.channels.values()}
    assert set(channels) == {topic.name for topic in RECORDED_TOPICS}
    for topic in RECORDED_TOPICS:
        channel = channels[topic.name]
        schema = summary.schemas[channel.schema_id]
        assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
        (profile,) = yaml.safe_load(channel.metadata["offered_qos_profiles"])
        assert profile["reliability"] == "reliable"
        assert profile["durability"] == ("transient_local" if topic.latched else "volatile")


def test_the_task_is_asked_for_once_a_task_runs_and_recorded(graph: Graph) -> None:
    asked: list[int] = []

    def task_info(_request: Any, response: Any) -> Any:
        asked.append(1)
        response.pick_up_location, response.drop_off_location = "FrontElevator", "PrivateCafe"
        response.guest_name = "human_20843"
        response.robot_start_pose.position.x, response.robot_start_pose.position.y = 10.975, 3.75
        response.robot_start_pose.orientation.w = 1.0
        return response

    graph.publisher_node.create_service(TaskInfo, "/servicesim/task_info", task_info)
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path)
    task_topic = TaskTopic(node=graph.recorder_node)
    graph.start_sim_clock()
    referee = graph.publishers["/servicesim/referee"]
    graph.spin_until(lambda: task_topic.client.service_is_ready(), "the task_info service")
    referee.publish(RefereeState(task_running=False))
    graph.spin_until(lambda: recorder.counts["/servicesim/referee"] == 1, "the first state")
    assert task_topic.task is None and not asked  # no task yet: nothing asked
    referee.publish(RefereeState(task_running=True))
    graph.spin_until(lambda: recorder.counts[TASK_TOPIC] == 1, "the task to be recorded")
    referee.publish(RefereeState(task_running=True))
    graph.spin_until(lambda: recorder.counts["/servicesim/referee"] == 3, "a later state")
    recorder.close()
    (task,) = [decoded for topic, _, _, decoded in read_back(graph.path) if topic == TASK_TOPIC]
    assert json.loads(task.data) == {
        "pick_up_location": "FrontElevator", "drop_off_location": "PrivateCafe",
        "guest_name": "human_20843", "robot_start_pose": {"x": 10.975, "y": 3.75, "yaw": 0.0}}
    assert len(asked) == 1


def test_tree_snapshots_are_published_whole_and_recorded(graph: Graph) -> None:
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path)
    tree_topic = TreeTopic(node=graph.recorder_node)
    graph.start_sim_clock()
    graph.spin_until(lambda: tree_topic.publisher.get_subscription_count() > 0, "a match")
    tree_topic.publish(TickRecord(
        tick=1, sim_time_s=42.5, root=Status.RUNNING, tip="Main.Go",
        nodes={"Main": (Status.RUNNING, ""), "Main.Go": (Status.RUNNING, "3.0 m to go"),
               "Main.Then": (Status.INVALID, "")}, blackboard={}))
    tree_topic.publish(TickRecord(
        tick=2, sim_time_s=42.6, root=Status.RUNNING, tip="Main.Then",
        nodes={"Main.Go": (Status.SUCCESS, "arrived"), "Main.Then": (Status.RUNNING, "")},
        blackboard={}))
    graph.spin_until(lambda: recorder.counts[TREE_TOPIC] == 2, "both snapshots")
    recorder.close()
    snapshots = [json.loads(decoded.data) for topic, _, _, decoded in read_back(graph.path)
                 if topic == TREE_TOPIC]
    assert snapshots[0]["nodes"] == {
        "Main": {"status": "RUNNING", "feedback": ""},
        "Main.Go": {"status": "RUNNING", "feedback": "3.0 m to go"}}
    assert snapshots[1] == {
        "tick": 2, "sim_time_s": 42.6, "root": "RUNNING", "tip": "Main.Then",
        "nodes": {"Main": {"status": "RUNNING", "feedback": ""},
                  "Main.Go": {"status": "SUCCESS", "feedback": "arrived"},
                  "Main.Then": {"status": "RUNNING", "feedback": ""}}}


def test_own_topics_are_recorded_as_published_without_a_subscription(graph: Graph) -> None:
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path, own_topics=(TREE_TOPIC,))
    subscribed = {subscription.topic_name for subscription in graph.recorder_node.subscriptions}
    assert TREE_TOPIC not in subscribed and "/servicebot/odom" in subscribed
    assert recorder.records_own(TREE_TOPIC) and not recorder.records_own(TASK_TOPIC)
    with pytest.raises(ValueError, match="own topics"):
        recorder.record(TASK_TOPIC, String(data="{}"))
    tree_topic = TreeTopic(node=graph.recorder_node, recorder=recorder)
    graph.start_sim_clock()
    tree_topic.publish(TickRecord(tick=1, sim_time_s=1.5, root=Status.RUNNING, tip="Main",
                                  nodes={"Main": (Status.RUNNING, "")}, blackboard={}))
    assert recorder.counts[TREE_TOPIC] == 1  # written at once, no spinning
    recorder.close()
    (snapshot,) = [json.loads(decoded.data) for topic, _, _, decoded in read_back(graph.path)
                   if topic == TREE_TOPIC]
    assert snapshot["tick"] == 1 and snapshot["tip"] == "Main"


def test_snapshots_go_out_on_a_new_tip_or_after_the_period_and_on_flush(graph: Graph) -> None:
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path, own_topics=(TREE_TOPIC,))
    tree_topic = TreeTopic(node=graph.recorder_node, recorder=recorder, period_s=0.5)
    graph.start_sim_clock()

    def tick(number: int, at: float, tip: str, feedback: str) -> None:
        tree_topic.publish(TickRecord(tick=number, sim_time_s=at, root=Status.RUNNING, tip=tip,
                                      nodes={tip: (Status.RUNNING, feedback)}, blackboard={}))

    tick(1, 1.0, "Main.Go", "3.0 m to go")  # the first: sent
    tick(2, 1.1, "Main.Go", "2.9 m to go")  # same tip, within the period: held back
    tick(3, 1.2, "Main.Then", "")  # a new tip: sent
    tick(4, 1.3, "Main.Then", "waiting")  # held back
    tick(5, 1.7, "Main.Then", "still waiting")  # the period passed: sent
    tick(6, 1.8, "Main.Then", "done waiting")  # held back, until the flush
    tree_topic.flush()
    tree_topic.flush()  # nothing new: nothing sent
    recorder.close()
    snapshots = [json.loads(decoded.data) for topic, _, _, decoded in read_back(graph.path)
                 if topic == TREE_TOPIC]
    assert [snapshot["tick"] for snapshot in snapshots] == [1, 3, 5, 6]
    assert snapshots[-1]["nodes"]["Main.Then"]["feedback"] == "done waiting"


def test_schemas_hold_every_type_a_message_uses_once_each() -> None:
    definition = complete_definition("nav_msgs/msg/Odometry")
    included = [line[5:] for line in definition.splitlines() if line.startswith("MSG: ")]
    assert sorted(included) == sorted({
        "std_msgs/msg/Header", "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/PoseWithCovariance", "geometry_msgs/msg/Pose",
        "geometry_msgs/msg/Point", "geometry_msgs/msg/Quaternion",
        "geometry_msgs/msg/TwistWithCovariance", "geometry_msgs/msg/Twist",
        "geometry_msgs/msg/Vector3"})
    assert definition.count("=" * 80 + "\nMSG: ") == len(included)


def test_field_types_reads_arrays_bounds_constants_and_comments() -> None:
    text = ("# a comment line\nuint8 KIND=1  # constant\nstring<=8 short\n"
            "Point[] points  # same package\ngeometry_msgs/Pose[<=3] poses\n"
            "builtin_interfaces/Time stamp\nfloat64[36] covariance\n")
    assert field_types(text, package="geometry_msgs") == [
        "geometry_msgs/msg/Point", "geometry_msgs/msg/Pose", "builtin_interfaces/msg/Time"]


def test_snapshots_carry_the_executives_phase(
        graph: Graph) -> None:
    recorder = McapRecorder(node=graph.recorder_node, path=graph.path, own_topics=(TREE_TOPIC,))
    phases = iter(["BeginTask", "Pickup"])
    tree_topic = TreeTopic(node=graph.recorder_node, recorder=recorder,
                           phase=lambda: next(phases))
    graph.start_sim_clock()
    for number, tip in ((1, "Main.Go"), (2, "Main.Then")):  # a new tip each: both sent
        tree_topic.publish(TickRecord(tick=number, sim_time_s=number / 10, root=Status.RUNNING,
                                      tip=tip, nodes={tip: (Status.RUNNING, "")}, blackboard={}))
    recorder.close()
    snapshots = [json.loads(decoded.data) for topic, _, _, decoded in read_back(graph.path)
                 if topic == TREE_TOPIC]
    assert [snapshot["phase"] for snapshot in snapshots] == ["BeginTask", "Pickup"]


def test_a_snapshot_kept_node_by_node_is_the_text_json_writes_of_the_whole_state() -> None:
    """The tree topic joins per-node texts; each snapshot is what json writes of the state."""
    state, nodes = TreeState(), SnapshotNodes()
    records = [
        TickRecord(tick=1, sim_time_s=0.1, root=Status.RUNNING, tip="Main.Go",
                   nodes={"Main": (Status.RUNNING, ""), "Main.Go": (Status.RUNNING, "3 m → go"),
                          'Main."Then"': (Status.INVALID, "")}, blackboard={}),
        TickRecord(tick=2, sim_time_s=0.2 + 1e-9, root=Status.RUNNING, tip='Main."Then"',
                   nodes={"Main.Go": (Status.SUCCESS, "arrived"),
                          'Main."Then"': (Status.RUNNING, "waiting\n")}, blackboard={}),
        TickRecord(tick=3, sim_time_s=0.3, root=Status.FAILURE, tip=None,
                   nodes={"Main.Go": (Status.INVALID, "arrived"),
                          'Main."Then"': (Status.FAILURE, "gave up")}, blackboard={}),
    ]
    for record, phase in zip(records, ("BeginTask", None, "Pickup"), strict=True):
        state.advance(record)
        nodes.update(record.nodes)
        whole = snapshot_json(state)
        assert snapshot_text(state, nodes) == json.dumps(whole)
        if phase is not None:
            assert snapshot_text(state, nodes, phase=phase) == json.dumps(
                {**whole, "phase": phase})
