"""The trajectory picture: paths and events collected from the run's topics, drawn over the map.

A test node plays a small story over real DDS: a map, the robot driving east, the
guest waiting then following, a drift and a re-acquire, the referee's checkpoints. The recorder
collects it; the PNG must show the map, the robot's path in its colour and the target areas.
"""

from __future__ import annotations

import array
import math
import subprocess
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import pytest
from geometry_msgs.msg import Point
from nav_msgs.msg import OccupancyGrid, Odometry
from PIL import Image
from servicesim_competition.msg import ActorStates, RefereeState

from bt_servicesim import trajectory
from bt_servicesim.planning.geometry import Box
from bt_servicesim.records.mcap import (
    GROUND_TRUTH_TOPIC,
    RECORDED_TOPICS,
    TREE_TOPIC,
    McapRecorder,
    TreeTopic,
)
from bt_servicesim.records.profile_inputs import profile_inputs_of, read_profile_inputs
from bt_servicesim.records.recording import recorded_messages
from bt_servicesim.records.trajectory import (
    LATCHED,
    ROBOT_COLOUR,
    MapImage,
    TrajectoryRecorder,
    boxes_from_blackboard,
    boxes_from_tree_log,
    render_trajectory,
    trace_from_recording,
    trace_of,
)
from bt_servicesim.records.tree_log import TickRecord, TreeLog
from tests.fakes.graphs import SimTimeGraph

CHECKPOINTS = ["go_to_pick_up", "pick_up_guest", "drop_off_guest", "return_to_start"]


def office_map() -> OccupancyGrid:
    """20 x 10 m, walls around, unknown beyond a 1 m border."""
    grid = OccupancyGrid()
    grid.info.resolution, grid.info.width, grid.info.height = 0.25, 88, 48
    grid.info.origin.position.x, grid.info.origin.position.y = -1.0, -1.0
    cells = np.full((48, 88), -1, dtype=np.int8)
    cells[4:44, 4:84] = 100
    cells[5:43, 5:83] = 0
    grid.data = array.array("b", cells.ravel().tobytes())
    return grid


def odom_at(x: float, y: float) -> Odometry:
    message = Odometry()
    message.pose.pose.position.x, message.pose.pose.position.y = x, y
    message.pose.pose.orientation.w = 1.0
    return message


def actors_at(guest: tuple[float, float], state: str, walker_x: float) -> ActorStates:
    return ActorStates(names=["human_20843", "human_00001", "human_00002"],
                       roles=["guest", "walker", "idler"],
                       positions=[Point(x=guest[0], y=guest[1]), Point(x=walker_x, y=8.0),
                                  Point(x=15.0, y=2.0)],
                       guest_state=state)


def referee(done: list[bool], drifts: int = 0) -> RefereeState:
    return RefereeState(task_running=True, checkpoint_names=CHECKPOINTS, checkpoint_done=done,
                        checkpoint_sim_time=[0.0] * 4, drifts=drifts)


class Story(SimTimeGraph):
    """The test's world node, the recorder's node (sim time) and one executor."""

    def __init__(self, context: Any) -> None:
        super().__init__(context, node_name="test_executive", simulator_name="test_world")
        self.map = self.simulator.create_publisher(OccupancyGrid, "/servicebot/map", LATCHED)
        self.odom = self.simulator.create_publisher(Odometry, GROUND_TRUTH_TOPIC, 50)
        self.actors = self.simulator.create_publisher(ActorStates, "/servicesim/actors", 10)
        self.referee = self.simulator.create_publisher(RefereeState, "/servicesim/referee",
                                                       LATCHED)
        self.sim_s = 0.0

    def at(self, sim_s: float) -> None:
        """Advance the sim clock and wait until the recorder's node reads it."""
        self.sim_s = sim_s
        self.jump_to(sim_s)

    def deliver(self, publisher: Any, message: Any, *received: Mapping[str, int]) -> None:
        """Publish and wait until every counter of received messages has counted it."""
        topic = publisher.topic_name
        before = [counts.get(topic, 0) for counts in received]
        publisher.publish(message)
        self.spin_until(lambda: all(counts.get(topic, 0) > count
                                    for counts, count in zip(received, before, strict=True)),
                        f"a message on {topic}")


@pytest.fixture
def story(ros_context: Any) -> Iterator[Story]:
    built = Story(ros_context)
    yield built
    built.shutdown()


def play(story: Story, recorder: TrajectoryRecorder,
         *also: Mapping[str, int]) -> None:
    """The story; each message is waited for by the recorder (and the ``also`` counters)."""
    counters = (recorder.received, *also)
    story.at(1.0)
    story.spin_until(lambda: all(p.get_subscription_count() > 0 for p in (
        story.map, story.odom, story.actors, story.referee)), "the recorder's subscriptions")
    story.deliver(story.map, office_map(), *counters)
    recorder.note_phase("BeginTask")
    story.deliver(story.referee, referee([False] * 4), *counters)
    for step in range(40):  # the robot drives east along y = 2, 0.25 m per 0.5 s
        x, y = 2.0 + 0.25 * step, 2.0
        story.at(1.0 + 0.5 * step)
        story.deliver(story.odom, odom_at(x, y), *counters)
        if step == 10:
            recorder.note_phase("Pickup")
        if step == 12:
            story.deliver(story.referee, referee([True, False, False, False]), *counters)
        if step == 16:
            story.deliver(story.referee, referee([True, True, False, False]), *counters)
            recorder.note_phase("DropOff")
        guest = (5.0, 2.5) if step < 16 else (x - 1.2, 2.5)
        state = "waiting" if step < 16 else "drifted" if 24 <= step < 28 else "following"
        story.deliver(story.actors, actors_at(guest, state, walker_x=3.0 + 0.3 * step), *counters)
        if step == 24:
            story.deliver(story.referee, referee([True, True, False, False], drifts=1), *counters)
    story.deliver(story.referee, referee([True, False, False, False], drifts=1), *counters)
    story.deliver(story.referee, referee([True, True, True, False], drifts=1), *counters)


def test_the_recorder_collects_paths_and_marks_what_happened_where(story: Story) -> None:
    recorder = TrajectoryRecorder(node=story.node)
    play(story, recorder)
    trace = recorder.trace
    assert trace.robot[0] == (2.0, 2.0) and trace.robot[-1] == pytest.approx((11.75, 2.0))
    assert trace.start == (2.0, 2.0)
    assert trace.guest[0] == (5.0, 2.5)
    assert set(trace.people) == {"human_00001", "human_00002"}
    assert len(trace.people["human_00001"]) == 40 and len(trace.people["human_00002"]) == 1
    events = [(event.kind, event.label) for event in trace.events]
    assert events == [
        ("phase", "BeginTask"), ("phase", "Pickup"), ("checkpoint", "at pick-up"),
        ("checkpoint", "pick-up"), ("phase", "DropOff"), ("drift", "drift"),
        ("re-acquired", "re-acquired"), ("back to pick-up", "back to pick-up"),
        ("checkpoint", "pick-up"), ("checkpoint", "drop-off")]
    pick_up = trace.events[3]
    assert (pick_up.x, pick_up.y) == (6.0, 2.0)  # where the robot was at step 16
    assert pick_up.sim_time_s == pytest.approx(9.0)
    begin = trace.events[0]  # before any odometry: placed where the robot first was
    assert (begin.x, begin.y, begin.sim_time_s) == (2.0, 2.0, pytest.approx(1.0))
    re_acquired = trace.events[6]
    assert (re_acquired.x, re_acquired.y) == pytest.approx((2.0 + 0.25 * 28 - 1.2, 2.5))
    recorder.close()


def test_the_picture_shows_the_map_the_areas_and_the_robots_path(
        story: Story, tmp_path: Path) -> None:
    recorder = TrajectoryRecorder(node=story.node)
    play(story, recorder)
    boxes = boxes_from_blackboard({"/pick_up_box": Box(4.0, 1.0, 7.0, 4.0),
                                   "/drop_off_box": Box(10.0, 1.0, 13.0, 3.0),
                                   "/robot_pose": (1.0, 2.0)})
    assert set(boxes) == {"pick_up_box", "drop_off_box"}
    path = tmp_path / "trajectory.png"
    render_trajectory(recorder.trace, path=path, boxes=boxes, title="test run")
    with Image.open(path) as image:
        assert image.format == "PNG"
        pixels = np.asarray(image.convert("RGB")).astype(int)
    height, width, _ = pixels.shape
    assert width >= 1000 and height >= 500
    robot = np.array([int(ROBOT_COLOUR[i:i + 2], 16) for i in (1, 3, 5)])
    robot_pixels = np.sum(np.abs(pixels - robot).sum(axis=2) < 30)
    assert robot_pixels > 300  # the path is drawn, not just the legend's swatch
    assert np.sum(pixels.sum(axis=2) < 60) > 2000  # the map's walls
    green = np.sum((pixels[..., 1] > pixels[..., 0] + 20) & (pixels[..., 1] > pixels[..., 2] + 20))
    assert green > 1000  # the pick-up area's fill


def test_an_empty_trace_still_renders_a_picture(tmp_path: Path) -> None:
    from bt_servicesim.records.trajectory import RunTrace

    path = tmp_path / "trajectory.png"
    render_trajectory(RunTrace(), path=path)
    with Image.open(path) as image:
        assert image.size[0] > 100


def test_boxes_the_referee_refused_are_not_drawn() -> None:
    assert boxes_from_blackboard({"/pick_up_box": Box(0.0, 0.0, 0.0, 0.0),
                                  "/Pickup/drop_off_box": Box(0.0, 0.0, 1.0, math.pi)}) == {
        "drop_off_box": Box(0.0, 0.0, 1.0, math.pi)}


def test_a_recorded_run_is_drawn_again_from_its_mcap(story: Story, tmp_path: Path) -> None:
    recording = McapRecorder(node=story.node, path=tmp_path / "run.mcap")
    recorder = TrajectoryRecorder(node=story.node)
    play(story, recorder, recording.counts)
    recording.close()
    live, rebuilt = recorder.trace, trace_from_recording(tmp_path / "run.mcap")
    assert rebuilt.robot == live.robot and rebuilt.start == live.start
    assert rebuilt.guest == live.guest and rebuilt.people == live.people
    assert rebuilt.events == [event for event in live.events if event.kind != "phase"]
    assert rebuilt.map_image is not None and live.map_image is not None
    assert np.array_equal(rebuilt.map_image.cells, live.map_image.cells)
    write_tree_log(tmp_path, {"/pick_up_box": Box(4.0, 1.0, 7.0, 4.0), "/other": 3})
    assert boxes_from_tree_log(tmp_path / "tree_log.jsonl") == {
        "pick_up_box": Box(4.0, 1.0, 7.0, 4.0)}
    assert trajectory.main([str(tmp_path), "--out", str(tmp_path / "again.png")]) == 0
    with Image.open(tmp_path / "again.png") as image:
        assert image.format == "PNG" and image.size[0] >= 1000


def test_one_reading_of_every_topic_gives_the_trace_and_the_profile_inputs_each_reads_alone(
        story: Story, tmp_path: Path) -> None:
    recording = McapRecorder(node=story.node, path=tmp_path / "run.mcap")
    recorder = TrajectoryRecorder(node=story.node)
    play(story, recorder, recording.counts)
    recording.close()
    every = [(channel.topic, message) for channel, message in recorded_messages(
        tmp_path / "run.mcap", topics=[topic.name for topic in RECORDED_TOPICS])]
    alone, shared = trace_from_recording(tmp_path / "run.mcap"), trace_of(every)
    assert (shared.robot, shared.guest, shared.people, shared.events, shared.start) == (
        alone.robot, alone.guest, alone.people, alone.events, alone.start)
    assert shared.robot and shared.people and shared.events
    assert profile_inputs_of(every) == read_profile_inputs(tmp_path / "run.mcap")
    recorder.close()


def test_phases_noted_during_a_run_are_marked_where_the_live_recorder_marked_them(
        story: Story, tmp_path: Path) -> None:
    recording = McapRecorder(node=story.node, path=tmp_path / "run.mcap")
    recorder = TrajectoryRecorder(node=story.node)
    noted: list[tuple[float, str]] = []
    live_note = recorder.note_phase

    def note(phase: str) -> None:
        noted.append((story.node.get_clock().now().nanoseconds / 1e9, phase))
        live_note(phase)

    recorder.note_phase = note  # type: ignore[method-assign]
    play(story, recorder, recording.counts)
    recording.close()
    rebuilt = trace_from_recording(tmp_path / "run.mcap", phases=noted)
    assert [event.kind for event in rebuilt.events].count("phase") == 3
    assert rebuilt.events == recorder.trace.events
    recorder.close()


def write_tree_log(directory: Path, blackboard: dict[str, Any]) -> None:
    """A one-node tree ticked once, with ``blackboard`` as the blackboard's contents."""
    tree = py_trees.trees.BehaviourTree(py_trees.behaviours.Success(name="Done"))
    log = TreeLog(tree=tree, path=directory / "tree_log.jsonl", sim_time_s=lambda: 1.0,
                  blackboard=lambda: blackboard)
    tree.add_post_tick_handler(log)
    tree.tick()
    log.close()


def test_redrawing_a_directory_without_a_recording_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert trajectory.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "no run.mcap here" in err and err.count("\n") == 1


def test_phases_in_the_recorded_tree_snapshots_are_marked_when_drawn_again(
        story: Story, tmp_path: Path) -> None:
    recording = McapRecorder(node=story.node, path=tmp_path / "run.mcap",
                             own_topics=(TREE_TOPIC,))
    recorder = TrajectoryRecorder(node=story.node)
    current = ["-"]
    tree_topic = TreeTopic(node=story.node, recorder=recording, phase=lambda: current[0])
    live_note = recorder.note_phase

    def note(phase: str) -> None:  # the executive's phase, as the run's tree snapshots carry it
        current[0] = phase
        tree_topic.publish(TickRecord(
            tick=len(phase), sim_time_s=story.node.get_clock().now().nanoseconds / 1e9,
            root=py_trees.common.Status.RUNNING, tip=f"Main.{phase}", nodes={},
            blackboard={}))
        live_note(phase)

    recorder.note_phase = note  # type: ignore[method-assign]
    play(story, recorder, recording.counts)
    recording.close()
    rebuilt = trace_from_recording(tmp_path / "run.mcap")
    assert [event.label for event in rebuilt.events if event.kind == "phase"] == [
        "BeginTask", "Pickup", "DropOff"]
    assert rebuilt.events == recorder.trace.events
    recorder.close()


def test_a_run_loads_matplotlib_only_to_draw() -> None:
    """Importing the run's machinery cost every run 0.6 s of start-up for matplotlib, which a
    completed mission (evaluations draw only failed ones) never used."""
    program = ("import sys, bt_servicesim.mission.run; "
               "print(sorted(name for name in sys.modules if name.startswith('matplotlib')))")
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.strip() == "[]"


def test_the_map_is_cut_to_its_known_cells_and_the_frames_margin() -> None:
    """The picture draws only the part of the map it can show: the known cells, the frame's
    margin around them (still the map's own cells), nothing beyond the map's edge."""
    cells = np.full((40, 60), -1, dtype=np.int8)
    cells[10:20, 30:59] = 0
    cells[12, 40] = 100
    whole = MapImage(cells=cells, origin=(-5.0, -2.0), resolution=0.5)
    part = whole.known_part(margin_m=1.0)  # 1 m = 2 cells, and one more
    assert part.cells.shape == (10 + 2 * 3, 60 - 27)  # cut at the map's right edge
    assert part.origin == (-5.0 + 27 * 0.5, -2.0 + 7 * 0.5)
    assert np.array_equal(part.cells, cells[7:23, 27:60])
    assert part.known_bounds() == whole.known_bounds()
    pixels = part.grey_pixels()
    assert pixels.dtype == np.uint8 and pixels.shape == (*part.cells.shape, 3)
    assert pixels[12 - 7, 40 - 27].tolist() == [0, 0, 0]
    assert pixels[15 - 7, 35 - 27].tolist() == [255, 255, 255]
    assert pixels[0, 0].tolist() == [217, 217, 217]  # unknown: light grey (0.85)
    unknown = MapImage(cells=np.full((4, 4), -1, dtype=np.int8), origin=(0.0, 0.0),
                       resolution=1.0)
    assert unknown.known_part(margin_m=1.0) is unknown


def small_chunked_recording(path: Path, poses: int) -> None:
    """A run.mcap of the map and ``poses`` ground-truth poses, in chunks of a few messages, so
    that cutting its end off leaves whole chunks before the cut."""
    from mcap.writer import Writer
    from rclpy.serialization import serialize_message

    from bt_servicesim.records.mcap import complete_definition, type_name

    with path.open("wb") as stream:
        writer = Writer(stream, chunk_size=512)
        writer.start(profile="ros2", library="test")
        channels = {}
        for topic, message_type in (("/servicebot/map", OccupancyGrid),
                                    (GROUND_TRUTH_TOPIC, Odometry)):
            name = type_name(message_type)
            schema = writer.register_schema(name=name, encoding="ros2msg",
                                            data=complete_definition(name).encode())
            channels[topic] = writer.register_channel(topic=topic, message_encoding="cdr",
                                                      schema_id=schema)
        messages = [("/servicebot/map", office_map())]
        messages += [(GROUND_TRUTH_TOPIC, odom_at(1.0 + 0.5 * step, 2.0)) for step in range(poses)]
        for when, (topic, message) in enumerate(messages, start=1):
            writer.add_message(channel_id=channels[topic], log_time=when * 10**8,
                               publish_time=when * 10**8, data=serialize_message(message))
        writer.finish()


def test_a_recording_cut_short_is_drawn_up_to_the_cut_with_a_warning(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    recording = tmp_path / "run.mcap"
    small_chunked_recording(recording, poses=40)
    whole = trace_from_recording(recording)
    assert whole.cut_short is None and len(whole.robot) == 40
    recording.write_bytes(recording.read_bytes()[:recording.stat().st_size // 4])
    cut = trace_from_recording(recording)
    assert cut.cut_short is not None and "cut short" in cut.cut_short
    assert cut.map_image is not None and 0 < len(cut.robot) < 40
    assert cut.robot == whole.robot[:len(cut.robot)]
    assert trajectory.main([str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "warning" in err and f"{recording} is cut short" in err
    assert (tmp_path / "trajectory.png").is_file()


@pytest.mark.parametrize(("content", "out", "problem"), [
    pytest.param(b"", None, "run.mcap is empty", id="empty"),
    pytest.param(b"PK\x03\x04 a zip file", None, "not an MCAP recording", id="not-mcap"),
    pytest.param(b"\x89MCAP0\r\n\x01\x02", None, "cut short", id="cut-before-any-message"),
    pytest.param(None, ".", "--out", id="out-is-a-directory"),
    pytest.param(None, "no/such/dir/picture.png", "--out", id="out-in-no-directory"),
])
def test_a_recording_or_out_that_cannot_be_drawn_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], content: bytes | None,
        out: str | None, problem: str) -> None:
    recording = tmp_path / "run.mcap"
    if content is None:
        small_chunked_recording(recording, poses=3)
    else:
        recording.write_bytes(content)
    arguments = [str(tmp_path)] + ([] if out is None else ["--out", str(tmp_path / out)])
    assert trajectory.main(arguments) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error: " in err and problem in err
    assert not (tmp_path / "trajectory.png").exists()
