"""Where everyone went: the run's trajectory picture, ``trajectory.png``.

:class:`TrajectoryRecorder` listens, during a run, to the map (``/servicebot/map``), the
robot's and the people's ground truth (``/servicesim/ground_truth/odom``,
``/servicesim/actors``) and the referee's state
(``/servicesim/referee``). These are records, never inputs to the mission: the executive
decides from its own sensors. From them it keeps the robot's path, the guest's path, every
other person's path, and the moments worth marking, each where it happened:

* the referee's checkpoints as they are reached (pick-up and drop-off among them), and the
  task being sent back from drop-off to pick-up (the guest drifted or fell behind);
* drifts, from the referee's drift counter, at the guest's position;
* re-acquiring the guest: the guest following again after being lost or drifting;
* the mission tree's phase changes (BeginTask, Pickup, DropOff, ReturnToStart), at the robot.

:func:`render_trajectory` draws it all over the map with matplotlib (no display needed), with
the target areas the executive looked up: every box on the blackboard, labelled with its key
(:func:`boxes_from_blackboard`), so a tree that names its keys otherwise is drawn the same.

A recorded run can be drawn again later: ``python -m bt_servicesim.trajectory DIR`` rebuilds the
trace from ``DIR/run.mcap`` (the same messages, in the order they arrived; the phases from the
tree snapshots, which carry the executive's phase) and the areas from the last blackboard in
``DIR/tree_log.jsonl``.
"""

from __future__ import annotations

import json
import math
import re
from collections import Counter, deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from mcap.records import Message
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from servicesim_competition.msg import ActorStates, RefereeState
from std_msgs.msg import String

from bt_servicesim.planning.geometry import Box
from bt_servicesim.records.mcap import GROUND_TRUTH_TOPIC, RECORDED_TOPICS, TREE_TOPIC
from bt_servicesim.records.recording import (
    RecordingCutShortError,
    recorded_messages,
    recorded_people,
)
from bt_servicesim.records.tree_log import read_tree_log
from bt_servicesim.ros.planar_cdr import PeopleStates, odometry_pose

if TYPE_CHECKING:  # matplotlib is imported when a picture is drawn
    from matplotlib.axes import Axes

TRAJECTORY_NAME = "trajectory.png"
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
ROBOT_COLOUR, GUEST_COLOUR, PEOPLE_COLOUR = "#d62728", "#1f77b4", "#9a9a9a"
BOX_COLOURS = ("#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#bcbd22")
"""Target areas' colours, in the order the executive first wrote them (pick-up first)."""
EVENT_STYLE = {  # kind: (marker, colour)
    "checkpoint": ("*", "#ff7f0e"),
    "back to pick-up": ("X", "#000000"),
    "drift": ("v", "#8c564b"),
    "re-acquired": ("P", "#17becf"),
    "phase": ("o", ROBOT_COLOUR),
}
CHECKPOINT_LABELS = {"go_to_pick_up": "at pick-up", "pick_up_guest": "pick-up",
                     "drop_off_guest": "drop-off", "return_to_start": "back at start"}
Point2D = tuple[float, float]
MAX_LISTED_EVENTS = 30
FRAME_MARGIN_M = 1.0
"""How far the picture reaches beyond the known map, the paths and the boxes."""


@dataclass(frozen=True)
class RunEvent:
    """Something worth marking on the picture: what, when (sim s) and where (map frame)."""

    kind: str
    label: str
    sim_time_s: float
    x: float
    y: float


@dataclass
class MapImage:
    """An occupancy grid as an image: cells row 0 at the bottom, and where it lies."""

    cells: np.ndarray
    origin: Point2D
    resolution: float

    @classmethod
    def from_message(cls, message: OccupancyGrid) -> MapImage:
        info = message.info
        cells = np.asarray(message.data, dtype=np.int8).reshape(info.height, info.width)
        return cls(cells=cells, resolution=float(info.resolution),
                   origin=(float(info.origin.position.x), float(info.origin.position.y)))

    @property
    def extent(self) -> tuple[float, float, float, float]:
        height, width = self.cells.shape
        x0, y0 = self.origin
        return (x0, x0 + width * self.resolution, y0, y0 + height * self.resolution)

    def known_bounds(self) -> tuple[float, float, float, float] | None:
        """(min x, max x, min y, max y) of the cells that are not unknown."""
        rows, columns = np.nonzero(self.cells >= 0)
        if rows.size == 0:
            return None
        x0, y0 = self.origin
        return (x0 + columns.min() * self.resolution, x0 + (columns.max() + 1) * self.resolution,
                y0 + rows.min() * self.resolution, y0 + (rows.max() + 1) * self.resolution)

    def shades(self) -> np.ndarray:
        """Grey levels: free white, occupied black, unknown light grey."""
        shade = np.full(self.cells.shape, 0.85)
        shade[(self.cells >= 0) & (self.cells < 50)] = 1.0
        shade[self.cells >= 50] = 0.0
        return shade

    def known_part(self, *, margin_m: float) -> MapImage:
        """The part of the map that holds every known cell and ``margin_m`` around them (the
        whole map when no cell is known): the picture is zoomed to that, so the cells beyond
        are never seen, and drawing them cost as much as the rest of the picture."""
        rows, columns = np.nonzero(self.cells >= 0)
        if rows.size == 0:
            return self
        margin = math.ceil(margin_m / self.resolution) + 1
        bottom, left = max(rows.min() - margin, 0), max(columns.min() - margin, 0)
        top, right = rows.max() + 1 + margin, columns.max() + 1 + margin
        x0, y0 = self.origin
        return MapImage(cells=self.cells[bottom:top, left:right], resolution=self.resolution,
                        origin=(x0 + left * self.resolution, y0 + bottom * self.resolution))

    def grey_pixels(self) -> np.ndarray:
        """:meth:`shades` as 8-bit RGB, which matplotlib draws without a colour map: mapping
        the office's 1.4 million cells through one was most of the picture's drawing time."""
        level = np.rint(self.shades() * 255).astype(np.uint8)
        return np.repeat(level[..., np.newaxis], 3, axis=2)


@dataclass
class RunTrace:
    """Everything the picture shows, collected during the run."""

    map_image: MapImage | None = None
    robot: list[Point2D] = field(default_factory=list)
    guest: list[Point2D] = field(default_factory=list)
    people: dict[str, list[Point2D]] = field(default_factory=dict)
    events: list[RunEvent] = field(default_factory=list)
    start: Point2D | None = None
    cut_short: str | None = None
    """Why the trace ends early, when it was read from a recording cut short."""


class TraceBuilder:
    """Builds a :class:`RunTrace` from the run's messages, handed to its ``on_*`` methods.

    Args:
        now_s: the sim time now, in seconds (stamps the events)
        min_step_m: a path point closer than this to the previous one is left out
    """

    def __init__(self, *, now_s: Callable[[], float], min_step_m: float = 0.05) -> None:
        self.trace = RunTrace()
        self.received: Counter[str] = Counter()  # messages per topic
        self.min_step_m = min_step_m
        self._now_s = now_s
        self._phase = "-"
        self._unplaced: list[tuple[str, str, float]] = []  # events before the robot's position
        self._referee: RefereeState | None = None
        self._guest_state = ""

    def on_map(self, message: OccupancyGrid) -> None:
        self.received["/servicebot/map"] += 1
        self.trace.map_image = MapImage.from_message(message)

    def on_robot(self, message: Odometry) -> None:
        """The robot's true pose in map (the simulator's ground truth, not its odometry)."""
        position = message.pose.pose.position
        self.on_robot_at((position.x, position.y))

    def on_robot_at(self, point: Point2D) -> None:
        """:meth:`on_robot` for a position already read from the message."""
        self.received[GROUND_TRUTH_TOPIC] += 1
        _append_moved(self.trace.robot, point, self.min_step_m)
        if self.trace.start is None:
            self.trace.start = point
            for kind, label, sim_time_s in self._unplaced:
                self.trace.events.append(RunEvent(kind=kind, label=label, sim_time_s=sim_time_s,
                                                  x=point[0], y=point[1]))
            self._unplaced.clear()

    def on_actors(self, message: ActorStates) -> None:
        self.on_people(PeopleStates(
            names=list(message.names), roles=list(message.roles),
            positions=[(position.x, position.y) for position in message.positions],
            guest_state=message.guest_state))

    def on_people(self, message: PeopleStates) -> None:
        """:meth:`on_actors` for the people already read from the message."""
        self.received["/servicesim/actors"] += 1
        guest: Point2D | None = None
        for name, role, point in zip(message.names, message.roles, message.positions,
                                     strict=False):
            if role == "guest":
                guest = point
                _append_moved(self.trace.guest, point, self.min_step_m)
            else:
                _append_moved(self.trace.people.setdefault(name, []), point, self.min_step_m)
        self._note_guest_state(message.guest_state, guest)

    def _note_guest_state(self, state: str, guest: Point2D | None) -> None:
        was, self._guest_state = self._guest_state, state
        if state == "following" and was in ("lost", "drifted") and guest is not None:
            self._mark("re-acquired", "re-acquired", guest)

    def on_referee(self, state: RefereeState) -> None:
        self.received["/servicesim/referee"] += 1
        last, self._referee = self._referee, state
        before = list(last.checkpoint_done) if last is not None else []
        for index, (name, done) in enumerate(zip(state.checkpoint_names, state.checkpoint_done,
                                                 strict=False)):
            was = index < len(before) and before[index]
            if done and not was:
                where = self._guest_or_robot() if name == "drop_off_guest" else self._robot()
                self._mark("checkpoint", CHECKPOINT_LABELS.get(name, name), where)
            elif was and not done and name == "pick_up_guest":
                self._mark("back to pick-up", "back to pick-up", self._guest_or_robot())
        drifts_before = last.drifts if last is not None else 0
        for _ in range(max(0, state.drifts - drifts_before)):
            self._mark("drift", "drift", self._guest_or_robot())

    def note_phase(self, phase: str) -> None:
        """The mission's phase now (the executive's ``phase()``); marks each change."""
        if phase != self._phase and phase != "-":
            self._mark("phase", phase, self._robot())
        self._phase = phase

    def _robot(self) -> Point2D | None:
        return self.trace.robot[-1] if self.trace.robot else None

    def _guest_or_robot(self) -> Point2D | None:
        return self.trace.guest[-1] if self.trace.guest else self._robot()

    def _mark(self, kind: str, label: str, where: Point2D | None) -> None:
        """Note an event; one before the robot's first position is placed at that position."""
        if where is None:
            self._unplaced.append((kind, label, self._now_s()))
            return
        self.trace.events.append(RunEvent(kind=kind, label=label, sim_time_s=self._now_s(),
                                          x=where[0], y=where[1]))



class TrajectoryRecorder(TraceBuilder):
    """A :class:`TraceBuilder` fed by subscriptions on ``node``, stamped by its (sim) clock."""

    def __init__(self, *, node: Node, min_step_m: float = 0.05) -> None:
        super().__init__(now_s=lambda: node.get_clock().now().nanoseconds / 1e9,
                         min_step_m=min_step_m)
        self.node = node
        self._subscriptions = [
            node.create_subscription(OccupancyGrid, "/servicebot/map", self.on_map, LATCHED),
            node.create_subscription(Odometry, GROUND_TRUTH_TOPIC, self.on_robot, 50),
            node.create_subscription(ActorStates, "/servicesim/actors", self.on_actors, 10),
            node.create_subscription(RefereeState, "/servicesim/referee", self.on_referee,
                                     LATCHED),
        ]

    def close(self) -> None:
        for subscription in self._subscriptions:
            self.node.destroy_subscription(subscription)
        self._subscriptions.clear()


def _append_moved(path: list[Point2D], point: Point2D, min_step_m: float) -> None:
    """Append ``point`` unless it is within ``min_step_m`` of the last one (keeps paths small)."""
    if not path or math.hypot(point[0] - path[-1][0], point[1] - path[-1][1]) >= min_step_m:
        path.append(point)


# --------------------------------------------------------------------------------- rendering
def boxes_from_blackboard(storage: Mapping[str, Any]) -> dict[str, Box]:
    """Every target area on the blackboard, by the last part of its key, in the order written.

    A box kept under two keys (a subtree's remapped copy) is drawn once, under its first key.
    """
    boxes: dict[str, Box] = {}
    for key, value in storage.items():
        if isinstance(value, Box) and not value.is_empty and value not in boxes.values():
            boxes.setdefault(key.rsplit("/", 1)[-1], value)
    return boxes


def render_trajectory(trace: RunTrace, *, path: Path, boxes: Mapping[str, Box] | None = None,
                      title: str = "") -> None:
    """Draw ``trace`` (and the target ``boxes``) to a PNG at ``path``, written whole: drawn
    beside it and moved into place, so that an interrupted drawing leaves no half a picture."""
    # matplotlib only when a picture is drawn: a run that completes draws none by default, and
    # importing it cost every run 0.6 s of start-up
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(14, 7.5), dpi=100)
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    if trace.map_image is not None:
        known = trace.map_image.known_part(margin_m=FRAME_MARGIN_M)
        axes.imshow(known.grey_pixels(), origin="lower", extent=known.extent,
                    interpolation="nearest")
    _draw_boxes(axes, boxes or {})
    _draw_paths(axes, trace)
    _draw_events(axes, trace.events)
    _frame(axes, trace, boxes or {})
    axes.set_title(title or "Run trajectory")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    if axes.get_legend_handles_labels()[0]:
        axes.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=9, frameon=False)
    figure.tight_layout()
    # the layout is set: with no engine left, savefig draws once instead of twice
    figure.set_layout_engine(None)
    partial = path.with_name(f".{path.name}.partial")
    try:
        figure.savefig(partial, format="png")
        partial.replace(path)
    finally:
        partial.unlink(missing_ok=True)


def _draw_boxes(axes: Axes, boxes: Mapping[str, Box]) -> None:
    from matplotlib.patches import Rectangle

    for index, (name, box) in enumerate(boxes.items()):
        colour = BOX_COLOURS[index % len(BOX_COLOURS)]
        axes.add_patch(Rectangle((box.min_x, box.min_y), box.max_x - box.min_x,
                                 box.max_y - box.min_y, facecolor=colour, alpha=0.25,
                                 edgecolor=colour, linewidth=1.5,
                                 label=name.replace("_box", "").replace("_", "-") + " area"))


def _draw_paths(axes: Axes, trace: RunTrace) -> None:
    for index, points in enumerate(trace.people.values()):
        if len(points) > 1:
            xs, ys = zip(*points, strict=True)
            axes.plot(xs, ys, color=PEOPLE_COLOUR, linewidth=0.6, alpha=0.6,
                      label="other people" if index == 0 else None)
        if points:
            axes.plot(*points[-1], "o", color=PEOPLE_COLOUR, markersize=3)
    # the guest follows the robot's trail: drawn on top, dashed, so both stay visible
    for points, colour, label, style in ((trace.robot, ROBOT_COLOUR, "robot", "-"),
                                         (trace.guest, GUEST_COLOUR, "guest", "--")):
        if points:
            xs, ys = zip(*points, strict=True)
            axes.plot(xs, ys, style, color=colour, linewidth=2.2 if style == "-" else 1.4,
                      label=label)
    if trace.start is not None:
        axes.plot(*trace.start, "s", color=ROBOT_COLOUR, markersize=8, label="robot start")


def _draw_events(axes: Axes, events: list[RunEvent]) -> None:
    """A numbered marker per event, and the numbered list beside the legend."""
    labelled: set[str] = set()
    lines = []
    for number, event in enumerate(events, start=1):
        marker, colour = EVENT_STYLE.get(event.kind, ("o", "#000000"))
        legend = None if event.kind in labelled else event.kind
        labelled.add(event.kind)
        axes.plot(event.x, event.y, marker, color=colour, markersize=11 if marker == "*" else 8,
                  markeredgecolor="black", markeredgewidth=0.6, label=legend)
        axes.annotate(str(number), (event.x, event.y), xytext=(4, 4),
                      textcoords="offset points", fontsize=7, fontweight="bold")
        lines.append(f"{number:>2} {event.sim_time_s:6.1f} s  {event.label}")
    if len(lines) > MAX_LISTED_EVENTS:
        lines = [*lines[:MAX_LISTED_EVENTS - 1], f"... {len(lines) - MAX_LISTED_EVENTS + 1} more"]
    if lines:
        axes.text(1.02, 0.52, "\n".join(["   sim time  event", *lines]), transform=axes.transAxes,
                  va="top", ha="left", family="monospace", fontsize=7.5)


def _frame(axes: Axes, trace: RunTrace, boxes: Mapping[str, Box]) -> None:
    """Zoom to the known map, the paths and the boxes, with a margin."""
    xs: list[float] = [x for points in (trace.robot, trace.guest) for x, _ in points]
    ys: list[float] = [y for points in (trace.robot, trace.guest) for _, y in points]
    for box in boxes.values():
        xs += [box.min_x, box.max_x]
        ys += [box.min_y, box.max_y]
    bounds = trace.map_image.known_bounds() if trace.map_image is not None else None
    if bounds is not None:
        xs += [bounds[0], bounds[1]]
        ys += [bounds[2], bounds[3]]
    if xs and ys:
        axes.set_xlim(min(xs) - FRAME_MARGIN_M, max(xs) + FRAME_MARGIN_M)
        axes.set_ylim(min(ys) - FRAME_MARGIN_M, max(ys) + FRAME_MARGIN_M)
    axes.set_aspect("equal")


# ---------------------------------------------------------------------- from a recorded run
TRACE_TOPICS = ("/servicebot/map", GROUND_TRUTH_TOPIC, "/servicesim/actors", "/servicesim/referee")
"""The recorded topics a trace is drawn from (and the tree's, for the phases, when the run did
not note them)."""
_NUMBER = r"(-?[0-9.]+(?:e[-+]?[0-9]+)?)"
_BOX_REPR = re.compile(
    rf"Box\(min_x={_NUMBER}, min_y={_NUMBER}, max_x={_NUMBER}, max_y={_NUMBER}\)")


def trace_from_recording(mcap_path: Path,
                         phases: Sequence[tuple[float, str]] | None = None) -> RunTrace:
    """The trace rebuilt from a run's ``run.mcap``, messages in the order they arrived.

    The mission's phases come from ``phases`` ((sim time, phase) in time order, as the run
    noted them) when given, else from the recorded tree snapshots. A recording cut short gives
    the trace up to the cut, with :attr:`RunTrace.cut_short` saying so; one that cannot be read
    at all raises :class:`~bt_servicesim.records.recording.RecordingError`.
    """
    topics = [*TRACE_TOPICS, *([TREE_TOPIC] if phases is None else [])]
    return trace_of(((channel.topic, message)
                     for channel, message in recorded_messages(mcap_path, topics=topics)),
                    phases=phases)


def trace_of(messages: Iterable[tuple[str, Message]],
             phases: Sequence[tuple[float, str]] | None = None) -> RunTrace:
    """:func:`trace_from_recording` of recorded ``messages`` (topic, message) in the order
    written; topics the trace is not drawn from are passed over."""
    types = {topic.name: topic.message_type for topic in RECORDED_TOPICS}
    now_ns = [0]
    builder = TraceBuilder(now_s=lambda: now_ns[0] / 1e9)
    noted = deque(phases or ())
    handlers: dict[str, Callable[[Any], None]] = {  # the ground truth and the people: below
        "/servicebot/map": builder.on_map, "/servicesim/referee": builder.on_referee}
    try:  # in the order written, which is the order of arrival
        for topic, message in messages:
            while noted and noted[0][0] * 1e9 < message.log_time:  # ties: message first
                when, phase = noted.popleft()
                now_ns[0] = round(when * 1e9)
                builder.note_phase(phase)
            now_ns[0] = message.log_time
            if topic == GROUND_TRUTH_TOPIC:
                _read_robot(builder, message.data)
            elif topic == "/servicesim/actors":
                builder.on_people(recorded_people(message.data))
            elif topic in handlers:
                handlers[topic](deserialize_message(message.data, types[topic]))
            elif topic == TREE_TOPIC and phases is None:
                snapshot = json.loads(deserialize_message(message.data, String).data)
                builder.note_phase(str(snapshot.get("phase", "-")))
    except RecordingCutShortError as error:  # what was read before the cut is drawn
        builder.trace.cut_short = str(error)
    for when, phase in noted:  # noted after the last message
        now_ns[0] = round(when * 1e9)
        builder.note_phase(phase)
    return builder.trace


def _read_robot(builder: TraceBuilder, data: bytes) -> None:
    """A recorded ground truth, read at its pose's offset (a run records one every period,
    and rclpy's deserialisation of each was most of the time it took to read a run back)."""
    read = odometry_pose(data)
    if read is None:  # not little-endian plain CDR
        builder.on_robot(deserialize_message(data, Odometry))
    else:
        builder.on_robot_at((read[1].x, read[1].y))


def boxes_from_tree_log(path: Path) -> dict[str, Box]:
    """The target areas as the snapshot log last saw them on the blackboard."""
    history = read_tree_log(path)
    values = history.states[-1].blackboard if history.states else {}
    boxes = {}
    for key, text in values.items():
        found = _BOX_REPR.fullmatch(text)
        if found is not None:
            boxes[key] = Box(*(float(number) for number in found.groups()))
    return boxes_from_blackboard(boxes)
