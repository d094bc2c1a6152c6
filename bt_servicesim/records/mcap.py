"""Record a run's ROS traffic as MCAP (``run.mcap``), readable by Foxglove and rosbag2 tools.

:class:`McapRecorder` subscribes to the run's topics on the executive's node and writes every
message as it arrived, serialised (CDR, exactly the bytes DDS delivered; nothing is decoded and
encoded again), with the log time and publish time set to the node's clock — *sim* time in a
run. The file follows MCAP's ``ros2`` profile the way rosbag2's MCAP storage writes it:

* one schema per message type, encoding ``ros2msg``, named ``pkg/msg/Type``; its data is the
  type's ``.msg`` text followed by every type it uses, each after a line of 80 ``=`` and a
  ``MSG: pkg/msg/Type`` line. The text comes from the interface packages' installed share
  directories (``AMENT_PREFIX_PATH`` and the venv), the servicesim_competition ones included;
* channels in ``cdr`` encoding, each with the ``offered_qos_profiles`` metadata rosbag2 reads
  back (in rosbag2's current YAML form) so a latched topic is replayed latched.

Besides the simulator's topics the run publishes two of its own, both ``std_msgs/String`` JSON:
``/bt_servicesim/task`` (latched; the task as the referee's ``task_info`` service states it,
published by :class:`TaskTopic` once the referee reports a running task) and
``/bt_servicesim/tree`` (:class:`TreeTopic`; a self-contained tree snapshot on every change the
snapshot log records: tick, sim time, root status, tip, and the status and feedback of every node
that is not INVALID).

The competition's ``/servicesim/score`` (``Score``, 50 Hz) is not recorded: the referee's state
(``/servicesim/referee``, recorded) carries the same score twice a sim second and on every
change, and taking the 50 Hz stream was half of the messages the executive's process received.
Nothing subscribing, the simulator does not publish it (it still does for any other reader).
"""

from __future__ import annotations

import json
import os
import re
import sys
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import yaml
from geometry_msgs.msg import PoseWithCovarianceStamped
from mcap.writer import CompressionType, Writer
from nav_msgs.msg import OccupancyGrid, Odometry
from py_trees.common import Status
from rclpy.client import Client
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rclpy.task import Future
from servicesim_competition.msg import ActorNames, ActorStates, RefereeState
from servicesim_competition.srv import TaskInfo
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from bt_servicesim.records.tree_log import TickRecord, TreeState
from bt_servicesim.ros.messages import pose_from_msg
from bt_servicesim.ros.shared_subscription import Reader, shared_subscription
from bt_servicesim.ros.sim_clock import clock_now_ns
from bt_servicesim.tree.shape import NodeState

MCAP_NAME = "run.mcap"
TASK_TOPIC = "/bt_servicesim/task"
TREE_TOPIC = "/bt_servicesim/tree"
GROUND_TRUTH_TOPIC = "/servicesim/ground_truth/odom"
"""The simulator's true robot pose (``nav_msgs/Odometry`` in ``map``): records may draw from it,
the executive never reads it (a real robot has no such topic)."""
PENALTY_CAUSES_TOPIC = "/servicesim/referee/penalty_causes"
"""The simulator's running sums of penalty points by cause (``std_msgs/String`` JSON, latched;
:mod:`bt_servicesim.records.profile_inputs` reads it): a record, never read by the mission."""
MARKERS_TOPIC, AREA_MARKERS_TOPIC = "/servicesim/markers", "/servicesim/markers/areas"
"""The simulator's ``visualization_msgs/MarkerArray`` in ``map``: people, guest and plan; the
target areas (latched), for a 3D viewer such as Foxglove's."""
RECORDING_DEPTH = 100
"""The history depth the recorder subscribes with: as deep as tf2's listener asks for /tf, so
that the tree's readers, which ask no deeper, share the recording's subscription of a topic
(:mod:`bt_servicesim.ros.shared_subscription`) rather than each having the topic sent again."""
SNAPSHOT_PERIOD_S = 0.5  # sim s between tree snapshots while the tip stays put
DEFINITION_SEPARATOR = "=" * 80
PRIMITIVE_TYPES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring",
})
_ARRAY_OR_BOUND = re.compile(r"(\[[^\]]*\]|<=\d+)")


class MessageDefinitionError(LookupError):
    """An interface's ``.msg`` file could not be found; names the type and where it looked."""


@dataclass(frozen=True)
class RecordedTopic:
    """A topic the recorder subscribes to, and how it is published.

    ``sensor``: a robot's driver may publish it best effort (``qos_profile_sensor_data``), as
    the tree reads it. The recorder then reads it best effort too: a best-effort reader hears
    reliable and best-effort publishers alike, while a reliable one hears no best-effort
    publisher at all (DDS matches reliability "at least": the offer must be as strong as the
    request). rosbag2 adapts to the offered QoS for the same reason. Our simulator publishes
    these reliably; in lockstep the run makes every subscription reliable
    (:func:`~bt_servicesim.ros.node.reliable`), so there nothing is lost.
    """

    name: str
    message_type: type
    latched: bool = False
    sensor: bool = False

    @property
    def qos(self) -> QoSProfile:
        if self.latched:
            return QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                              durability=DurabilityPolicy.TRANSIENT_LOCAL)
        reliability = ReliabilityPolicy.BEST_EFFORT if self.sensor else ReliabilityPolicy.RELIABLE
        return QoSProfile(depth=RECORDING_DEPTH, reliability=reliability)

    @property
    def playback_qos(self) -> QoSProfile:
        """What the channel's metadata offers a player: reliable, which readers of either
        reliability match, however the recorder read it."""
        if self.latched:
            return self.qos
        return QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)


RECORDED_TOPICS = (
    RecordedTopic("/servicebot/odom", Odometry, sensor=True),
    RecordedTopic(GROUND_TRUTH_TOPIC, Odometry),
    RecordedTopic("/servicebot/amcl_pose", PoseWithCovarianceStamped, latched=True),
    RecordedTopic("/tf", TFMessage),
    RecordedTopic("/tf_static", TFMessage, latched=True),
    RecordedTopic("/servicebot/rfid", ActorNames, sensor=True),
    RecordedTopic("/servicesim/referee", RefereeState, latched=True),
    RecordedTopic(PENALTY_CAUSES_TOPIC, String, latched=True),
    RecordedTopic("/servicesim/actors", ActorStates),
    RecordedTopic("/servicebot/map", OccupancyGrid, latched=True),
    RecordedTopic(MARKERS_TOPIC, MarkerArray),
    RecordedTopic(AREA_MARKERS_TOPIC, MarkerArray, latched=True),
    RecordedTopic(TASK_TOPIC, String, latched=True),
    RecordedTopic(TREE_TOPIC, String),
)


# ------------------------------------------------------------------------ message definitions
def type_name(message_type: type) -> str:
    """``nav_msgs/msg/Odometry`` for the generated Python class of that message."""
    package = message_type.__module__.split(".")[0]
    return f"{package}/msg/{message_type.__name__}"


def share_directories() -> list[Path]:
    """Where installed interface packages keep their ``.msg`` files."""
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    return [Path(prefix) / "share" for prefix in [*prefixes, sys.prefix]]


def msg_text(name: str, *, search: Iterable[Path] | None = None) -> str:
    """The ``.msg`` text of ``pkg/msg/Type``."""
    package, _, message = name.split("/")
    places = list(search if search is not None else share_directories())
    for share in places:
        candidate = share / package / "msg" / f"{message}.msg"
        if candidate.is_file():
            return candidate.read_text(encoding="utf-8")
    raise MessageDefinitionError(
        f"no definition for {name}: {package}/msg/{message}.msg is in none of "
        f"{', '.join(str(place) for place in places)}")


def field_types(text: str, *, package: str) -> list[str]:
    """The message types (``pkg/msg/Type``) that the fields of a ``.msg`` text use, in order."""
    used: list[str] = []
    for line in text.splitlines():
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        base = _ARRAY_OR_BOUND.sub("", words[0])
        if base in PRIMITIVE_TYPES:
            continue
        parts = base.split("/")
        name = f"{parts[0]}/msg/{parts[-1]}" if len(parts) > 1 else f"{package}/msg/{base}"
        if name not in used:
            used.append(name)
    return used


def complete_definition(name: str, *, search: Iterable[Path] | None = None) -> str:
    """``name``'s ``.msg`` text with every type it uses after it, as rosbag2 stores them."""
    places = list(search if search is not None else share_directories())
    texts = {name: msg_text(name, search=places)}
    order = [name]
    pending = [name]
    while pending:
        current = pending.pop(0)
        for used in field_types(texts[current], package=current.split("/")[0]):
            if used not in texts:
                texts[used] = msg_text(used, search=places)
                order.append(used)
                pending.append(used)
    parts = [texts[name].rstrip("\n")]
    parts += [f"{DEFINITION_SEPARATOR}\nMSG: {used}\n{texts[used].rstrip(chr(10))}"
              for used in order[1:]]
    return "\n".join(parts) + "\n"


def offered_qos_yaml(qos: QoSProfile) -> str:
    """The channel metadata rosbag2 reads to re-create a topic's publisher on playback."""
    def unspecified() -> dict[str, int]:  # a fresh dict each time: YAML without anchors
        return {"sec": 0, "nsec": 0}

    profile = {
        "history": "keep_all" if qos.history == HistoryPolicy.KEEP_ALL else "keep_last",
        "depth": int(qos.depth),
        "reliability": "reliable" if qos.reliability == ReliabilityPolicy.RELIABLE
        else "best_effort",
        "durability": "transient_local" if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
        else "volatile",
        "deadline": unspecified(), "lifespan": unspecified(), "liveliness": "automatic",
        "liveliness_lease_duration": unspecified(), "avoid_ros_namespace_conventions": False,
    }
    return yaml.safe_dump([profile], sort_keys=False)


# ----------------------------------------------------------------------------------- recorder
class McapRecorder:
    """Writes every message on ``topics`` to an MCAP file until :meth:`close`.

    Args:
        node: the node to subscribe on; its clock stamps the messages (sim time in a run)
        path: the MCAP file to write (truncated)
        topics: what to record
        own_topics: those of ``topics`` this process publishes itself: recorded through
            :meth:`record` as they are published, not by a subscription (which would wake the
            process once more for each of its own messages)
    """

    def __init__(self, *, node: Node, path: Path,
                 topics: Iterable[RecordedTopic] = RECORDED_TOPICS,
                 own_topics: Collection[str] = ()) -> None:
        self.node = node
        self.path = path
        self.counts: dict[str, int] = {}
        self._own: dict[str, Callable[[bytes], None]] = {}
        self._stream: BinaryIO | None = path.open("wb")
        self._writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library="bt_servicesim")
        schemas: dict[str, int] = {}
        self._readers: list[Reader] = []
        for topic in topics:
            name = type_name(topic.message_type)
            if name not in schemas:
                schemas[name] = self._writer.register_schema(
                    name=name, encoding="ros2msg", data=complete_definition(name).encode())
            channel = self._writer.register_channel(
                topic=topic.name, message_encoding="cdr", schema_id=schemas[name],
                metadata={"offered_qos_profiles": offered_qos_yaml(topic.playback_qos)})
            self.counts[topic.name] = 0
            write = self._writes_to(topic.name, channel)
            if topic.name in own_topics:
                self._own[topic.name] = write
                continue
            self._readers.append(shared_subscription(
                node, topic.message_type, topic.name, write, topic.qos, raw=True))

    def records_own(self, topic: str) -> bool:
        """Whether ``topic`` is recorded through :meth:`record` (one of ``own_topics``)."""
        return topic in self._own

    def record(self, topic: str, message: Any) -> None:
        """Write a message this process publishes on one of its ``own_topics``."""
        write = self._own.get(topic)
        if write is None:
            raise ValueError(f"{topic} is not recorded as one of this process's own topics")
        write(serialize_message(message))

    def _writes_to(self, topic: str, channel: int) -> Callable[[bytes], None]:
        """The callback for one topic: writes the message.

        The topic is read through the node's shared subscription
        (:mod:`bt_servicesim.ros.shared_subscription`), which takes a burst of messages (the 50 Hz
        score arrives five at a time) in one wake-up.
        """
        def write(data: bytes) -> None:
            if self._stream is None:
                return
            now = clock_now_ns(self.node.get_clock())
            self._writer.add_message(channel_id=channel, log_time=now, publish_time=now,
                                     data=data, sequence=self.counts[topic])
            self.counts[topic] += 1

        return write

    def close(self) -> None:
        """Stop recording and finish the file (summary and index); idempotent."""
        if self._stream is None:
            return
        for reader in self._readers:
            reader.cancel()
        self._readers.clear()
        self._writer.finish()
        self._stream.close()
        self._stream = None


# ------------------------------------------------------------------------ the run's own topics
class TaskTopic:
    """Publishes the task (``task_info``) on ``/bt_servicesim/task`` once a task is running."""

    def __init__(self, *, node: Node, recorder: McapRecorder | None = None) -> None:
        """Reads the referee's state through the node's shared subscription, and writes the
        task to ``recorder`` when it records the task topic as its own."""
        self.node = node
        self.task: dict[str, Any] | None = None
        self.recorder = recorder
        latched = RecordedTopic(TASK_TOPIC, String, latched=True).qos
        self.publisher = node.create_publisher(String, TASK_TOPIC, latched)
        self.client: Client[TaskInfo.Request, TaskInfo.Response] = node.create_client(
            TaskInfo, "/servicesim/task_info")
        self._pending: Future[TaskInfo.Response] | None = None
        self._referee = shared_subscription(
            node, RefereeState, "/servicesim/referee", self._on_referee,
            RecordedTopic("/servicesim/referee", RefereeState, latched=True).qos)

    def _on_referee(self, state: RefereeState) -> None:
        if self.task is not None or self._pending is not None or not state.task_running:
            return
        if self.client.service_is_ready():
            self._pending = self.client.call_async(TaskInfo.Request())
            self._pending.add_done_callback(self._on_task)

    def _on_task(self, future: Future[TaskInfo.Response]) -> None:
        self._pending = None
        response = future.result()
        if response is None or not response.guest_name:
            return  # refused: asked again on the referee's next state
        start = pose_from_msg(response.robot_start_pose)
        self.task = {
            "pick_up_location": response.pick_up_location,
            "drop_off_location": response.drop_off_location,
            "guest_name": response.guest_name,
            "robot_start_pose": {"x": start.x, "y": start.y, "yaw": start.yaw},
        }
        message = String(data=json.dumps(self.task))
        self.publisher.publish(message)
        if self.recorder is not None and self.recorder.records_own(TASK_TOPIC):
            self.recorder.record(TASK_TOPIC, message)


class TreeTopic:
    """Publishes a self-contained tree snapshot on ``/bt_servicesim/tree`` as the tree runs.

    Register :meth:`publish` as a :class:`~bt_servicesim.records.tree_log.TreeLog` listener. A
    snapshot goes out when the tip or the root's status changes, else at most every ``period_s`` sim
    seconds: a viewer needs no more, and encoding the whole tree as JSON every tick is work the
    executive does between ticks (``tree_log.jsonl`` keeps every tick). :meth:`flush` sends
    the latest state if it has not gone out.
    """

    def __init__(self, *, node: Node, recorder: McapRecorder | None = None,
                 period_s: float = SNAPSHOT_PERIOD_S,
                 phase: Callable[[], str] | None = None) -> None:
        """Writes each snapshot to ``recorder`` too, when given (see its ``own_topics``); each
        snapshot names the mission's phase as ``phase`` (the executive's) says."""
        self.phase = phase
        self.publisher = node.create_publisher(
            String, TREE_TOPIC, RecordedTopic(TREE_TOPIC, String).qos)
        self.recorder = recorder
        self.period_s = period_s
        self._state = TreeState()  # the latest, advanced in place by each record
        self._nodes = SnapshotNodes()  # its nodes as JSON, node by node
        self._sent_at: float | None = None  # the sim time of the last snapshot sent
        self._unsent = False  # whether the latest state is not sent yet

    def publish(self, record: TickRecord) -> None:
        moved = (record.tip, record.root) != (self._state.tip, self._state.root)
        self._state.advance(record)
        self._nodes.update(record.nodes)
        self._unsent = True
        if (self._sent_at is None or moved
                or record.sim_time_s >= self._sent_at + self.period_s):
            self._send()

    def flush(self) -> None:
        if self._unsent:
            self._send()

    def _send(self) -> None:
        message = String(data=snapshot_text(
            self._state, self._nodes, phase=None if self.phase is None else self.phase()))
        self.publisher.publish(message)
        if self.recorder is not None and self.recorder.records_own(TREE_TOPIC):
            self.recorder.record(TREE_TOPIC, message)
        self._sent_at, self._unsent = self._state.sim_time_s, False


def snapshot_json(state: TreeState) -> dict[str, Any]:
    """The tree at one tick: every node that is not INVALID, with its status and feedback."""
    return {
        "tick": state.tick, "sim_time_s": round(state.sim_time_s, 3), "root": state.root.name,
        "tip": state.tip,
        "nodes": {key: {"status": status.name, "feedback": feedback}
                  for key, (status, feedback) in state.nodes.items()
                  if status != Status.INVALID},
    }


class SnapshotNodes:
    """The ``nodes`` of :func:`snapshot_json` as JSON text, kept up to date node by node.

    A tick changes a few of the tree's nodes, and a snapshot holds all of them: each node's
    text is encoded when its state changes, and a snapshot joins the texts of the nodes that
    are not INVALID, in the order the nodes were first seen (the order of the state's dict).
    """

    def __init__(self) -> None:
        self._texts: dict[str, str | None] = {}
        """Per node, in first-seen order: its ``"key": {...}`` text, None while INVALID."""

    def update(self, nodes: dict[str, NodeState]) -> None:
        texts, dumps = self._texts, json.dumps
        for key, (status, feedback) in nodes.items():
            texts[key] = None if status is Status.INVALID else (
                f'{dumps(key)}: {{"status": {dumps(status.name)}, "feedback": {dumps(feedback)}}}')

    def text(self) -> str:
        return "{" + ", ".join(text for text in self._texts.values() if text is not None) + "}"


def snapshot_text(state: TreeState, nodes: SnapshotNodes, *, phase: str | None = None) -> str:
    """``json.dumps`` of :func:`snapshot_json` of ``state`` (with ``phase`` when given), from
    ``nodes`` kept up to date with ``state``: the same text, without a dict of every node."""
    dumps = json.dumps
    text = (f'{{"tick": {dumps(state.tick)}, "sim_time_s": {dumps(round(state.sim_time_s, 3))}, '
            f'"root": {dumps(state.root.name)}, "tip": {dumps(state.tip)}, '
            f'"nodes": {nodes.text()}')
    return text + ("}" if phase is None else f', "phase": {dumps(phase)}}}')
