"""What a viewer gets of a run: ``run --foxglove`` live, and ``run.mcap`` afterwards.

One short run (its time limit ends it) is watched through Foxglove's WebSocket protocol by a
plain ``websockets`` client, which subscribes to the transforms and the markers and decodes the
CDR payloads with mcap-ros2-support's decoders built from the schemas the server advertised.
Its recording is then read by two readers nobody here wrote, mcap-ros2-support and rosbags
(from the schemas embedded in the file: no types registered by hand), which must agree, and
hold the building's areas by name, everyone in it, and map -> odom -> base_footprint where
the ground truth puts the robot.
"""

from __future__ import annotations

import asyncio
import json
import math
import re
import socket
import struct
import subprocess
import sys
import time
from collections import defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
import websockets
from mcap.reader import make_reader
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from servicesim_sim.world.files import DEFAULT_WORLD, load_world
from tests.fakes.commands import run_module

#: One run serves the whole module: its tests go to one pytest-xdist worker (``make test``'s
#: ``--dist loadgroup``), or each worker given some of them would start a run of its own.
pytestmark = pytest.mark.xdist_group("foxglove_run")
LIVE_TOPICS = ("/tf", "/servicesim/markers", "/servicesim/markers/areas")
URL = re.compile(r"ws://127\.0\.0\.1:\d+")
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
BINARY_MESSAGE_DATA = 0x01
WAIT_LIMIT_S = 120.0  # wall seconds any one wait may take on a loaded machine
ADD, DELETE, DELETEALL, TEXT_VIEW_FACING = 0, 2, 3, 9
FULL_PERIOD_NS = 5_000_000_000  # everyone is sent every 5 sim s, those who moved in between
#: The run is paced, for the viewer to subscribe while it goes on: its WebSocket client starts
#: after the run printed the server's URL, and must then see full marker messages (one every
#: FULL_PERIOD_NS). 40 sim s at 5x is 8 wall s, seven full messages after the first.
SPEED, TIME_LIMIT_S = 5, 40


# ------------------------------------------------------------------------------ the run
@dataclass
class WatchedRun:
    out: Path
    code: int
    live: dict[str, list[Any]]  # topic -> messages decoded from the live server, until it closed

    def account(self) -> str:
        """What the viewer got and what the run said: for a failing assertion's message."""
        got = {topic: len(messages) for topic, messages in self.live.items()}
        said = self.out.with_name("stdout.txt").read_text().splitlines()[-8:]
        return f"streamed {got}; the run exited {self.code}, its last lines: {said}"


@pytest.fixture(scope="module")
def watched_run(tmp_path_factory: pytest.TempPathFactory) -> WatchedRun:
    out = tmp_path_factory.mktemp("foxglove") / "run"
    log = out.with_name("stdout.txt")
    with log.open("w") as stdout:
        process = subprocess.Popen(
            [sys.executable, "-m", "bt_servicesim.run", "--headless", "--speed", str(SPEED),
             "--time-limit", str(TIME_LIMIT_S), "--out", str(out), "--foxglove", "0",
             "--trajectory", "never"],
            stdout=stdout, stderr=subprocess.STDOUT, text=True)
    try:
        url = _wait_for_url(log, process)
        live = asyncio.run(asyncio.wait_for(_watch(url), WAIT_LIMIT_S))
        code = process.wait(timeout=WAIT_LIMIT_S)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return WatchedRun(out=out, code=code, live=live)


def _wait_for_url(log: Path, process: subprocess.Popen[str]) -> str:
    deadline = time.monotonic() + WAIT_LIMIT_S
    while time.monotonic() < deadline and process.poll() is None:
        found = URL.search(log.read_text())
        if found:
            return found.group(0)
        time.sleep(0.05)
    raise AssertionError(f"the run printed no server URL:\n{log.read_text()}")


async def _watch(url: str) -> dict[str, list[Any]]:
    """Subscribe to the live topics and decode every message until the server goes away (the
    run stops it as it ends; the fixture's bound fails a server that stays)."""
    decoded: dict[str, list[Any]] = defaultdict(list)
    async with websockets.connect(url, subprotocols=SUBPROTOCOLS, max_size=None) as client:
        subscriptions: dict[int, tuple[str, Any]] = {}
        try:
            async for frame in client:
                if isinstance(frame, str):
                    await _on_advertise(client, json.loads(frame), subscriptions)
                    continue
                opcode, subscription, _log_time = struct.unpack_from("<BIQ", frame)
                assert opcode == BINARY_MESSAGE_DATA
                topic, decode = subscriptions[subscription]
                decoded[topic].append(decode(frame[13:]))
        except websockets.ConnectionClosed:
            pass
    return decoded


async def _on_advertise(client: Any, message: dict[str, Any],
                        subscriptions: dict[int, tuple[str, Any]]) -> None:
    if message.get("op") != "advertise":
        return
    wanted = []
    for channel in message["channels"]:
        if channel["topic"] not in LIVE_TOPICS:
            continue
        assert (channel["encoding"], channel["schemaEncoding"]) == ("cdr", "ros2msg")
        schema = Schema(id=channel["id"], name=channel["schemaName"], encoding="ros2msg",
                        data=channel["schema"].encode())
        decoder = DecoderFactory().decoder_for("cdr", schema)
        subscriptions[channel["id"]] = (channel["topic"], decoder)
        wanted.append({"id": channel["id"], "channelId": channel["id"]})
    if wanted:
        await client.send(json.dumps({"op": "subscribe", "subscriptions": wanted}))


# ------------------------------------------------------------------------------ the readers
def read_with_mcap_ros2(path: Path) -> Iterator[tuple[str, Any]]:
    with path.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, message in reader.iter_decoded_messages(log_time_order=False):
            yield channel.topic, message


def read_with_rosbags(path: Path) -> Iterator[tuple[str, Any]]:
    with AnyReader([path]) as reader:
        for connection, _, data in reader.messages():
            yield connection.topic, reader.deserialize(data, connection.msgtype)


@dataclass
class Scene:
    """What a 3D viewer would show of a recording, as plain values, whichever reader read it."""

    area_names: list[str] = field(default_factory=list)
    people_seen: set[int] = field(default_factory=set)
    guest_labels: set[str] = field(default_factory=set)
    plans: int = 0
    transforms: set[tuple[str, str]] = field(default_factory=set)
    static: set[tuple[str, str]] = field(default_factory=set)
    localised_poses: dict[int, tuple[float, float]] = field(default_factory=dict)
    truth: dict[int, tuple[float, float]] = field(default_factory=dict)
    markers_at: dict[int, list[tuple[float, float]]] = field(default_factory=dict)
    actors_at: dict[int, list[tuple[float, float]]] = field(default_factory=dict)
    task: dict[str, Any] = field(default_factory=dict)
    shown: dict[tuple[str, int], tuple[float, float]] = field(default_factory=dict)


def nanoseconds(stamp: Any) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def yaw_of(rotation: Any) -> float:
    return 2.0 * math.atan2(rotation.z, rotation.w)


def scene_of(messages: Iterable[tuple[str, Any]]) -> Scene:
    scene = Scene()
    for topic, message in messages:
        if topic == "/servicesim/markers/areas":
            scene.area_names = [m.text for m in message.markers if m.type == TEXT_VIEW_FACING
                                and m.action == ADD]
        elif topic == "/servicesim/markers":
            _add_scene_markers(scene, message)
        elif topic in ("/tf", "/tf_static"):
            _add_transforms(scene, message, static=topic == "/tf_static")
        elif topic == "/servicesim/ground_truth/odom":
            position = message.pose.pose.position
            scene.truth[nanoseconds(message.header.stamp)] = (position.x, position.y)
        elif topic == "/servicesim/actors":
            scene.actors_at[nanoseconds(message.stamp)] = sorted(
                (round(p.x, 6), round(p.y, 6)) for p in message.positions)
        elif topic == "/bt_servicesim/task":
            scene.task = json.loads(message.data)
    return scene


def _add_scene_markers(scene: Scene, message: Any) -> None:
    """Apply the markers as a viewer does; note where everyone stands then."""
    for marker in message.markers:
        key = (marker.ns, marker.id)
        if marker.action == DELETEALL:
            scene.shown = {shown: value for shown, value in scene.shown.items()
                           if shown[0] != marker.ns}
        elif marker.action == DELETE:
            scene.shown.pop(key, None)
        elif marker.action == ADD:
            scene.shown[key] = (round(marker.pose.position.x, 6),
                                round(marker.pose.position.y, 6))
            scene.people_seen |= {marker.id} if marker.ns == "people" else set()
            scene.guest_labels |= {marker.text} if marker.ns == "guest_name" else set()
            scene.plans += int(marker.ns == "plan" and len(marker.points) >= 2)
    if message.markers:
        scene.markers_at[nanoseconds(message.markers[0].header.stamp)] = sorted(
            place for (namespace, _), place in scene.shown.items()
            if namespace in ("people", "guest"))


def _add_transforms(scene: Scene, message: Any, *, static: bool) -> None:
    frames = {(t.header.frame_id, t.child_frame_id): t for t in message.transforms}
    (scene.static if static else scene.transforms).update(frames)
    if static or ("map", "odom") not in frames or ("odom", "base_footprint") not in frames:
        return
    parent, child = frames["map", "odom"].transform, frames["odom", "base_footprint"].transform
    yaw = yaw_of(parent.rotation)
    x, y = child.translation.x, child.translation.y
    scene.localised_poses[nanoseconds(frames["map", "odom"].header.stamp)] = (
        parent.translation.x + math.cos(yaw) * x - math.sin(yaw) * y,
        parent.translation.y + math.sin(yaw) * x + math.cos(yaw) * y)


# ------------------------------------------------------------------------------ the tests
def test_both_readers_decode_the_recording_alike(watched_run: WatchedRun) -> None:
    assert watched_run.code == 1, "the time limit ends the mission"
    path = watched_run.out / "run.mcap"
    by_mcap, by_rosbags = (scene_of(read(path)) for read in (read_with_mcap_ros2,
                                                             read_with_rosbags))
    assert by_mcap == by_rosbags
    assert by_mcap.localised_poses and by_mcap.markers_at


def test_the_recording_shows_the_building_by_name_and_who_is_where(
        watched_run: WatchedRun) -> None:
    scene = scene_of(read_with_rosbags(watched_run.out / "run.mcap"))
    world = load_world(DEFAULT_WORLD)
    assert [name.split(" (")[0] for name in scene.area_names] == list(world.areas)
    task = scene.task
    assert f"{task['pick_up_location']} (pick-up)" in scene.area_names
    assert f"{task['drop_off_location']} (drop-off)" in scene.area_names
    assert scene.guest_labels == {f"guest {task['guest_name']}"}
    assert len(scene.people_seen) == world.people.walkers + world.people.idlers
    assert scene.plans >= 1, "the robot's plan was drawn"
    shared = sorted(set(scene.markers_at) & set(scene.actors_at))
    everyone = [stamp for stamp in shared  # the recorder may join after the first full message
                if len(scene.markers_at[stamp]) == len(scene.actors_at[stamp])]
    assert everyone and everyone[0] - min(scene.markers_at) <= FULL_PERIOD_NS
    assert len(shared) - shared.index(everyone[0]) >= 10
    for stamp in shared[shared.index(everyone[0]):]:  # a viewer's markers stand where the
        assert scene.markers_at[stamp] == scene.actors_at[stamp], stamp  # actors are


AMCL_LAUNCH_POSE = (-24.469, 6.278)  # the original's amcl_diff.launch, the office's


def test_the_transforms_chain_map_odom_base_to_where_the_robot_truly_is(
        watched_run: WatchedRun) -> None:
    scene = scene_of(read_with_mcap_ros2(watched_run.out / "run.mcap"))
    assert {("map", "odom"), ("odom", "base_footprint")} <= scene.transforms
    assert {("base_footprint", "base_link"), ("base_link", "lidar_frame")} <= scene.static
    shared = sorted(set(scene.localised_poses) & set(scene.truth))
    # until the tree's initial pose is taken the estimate is AMCL's launch pose, as in the
    # original (docs/fidelity.md); from then on, with exact odometry and no localisation
    # noise, the estimate is the truth
    assert math.dist(scene.localised_poses[shared[0]], AMCL_LAUNCH_POSE) < 1e-3
    taken = next(index for index, stamp in enumerate(shared)
                 if math.dist(scene.localised_poses[stamp], scene.truth[stamp]) < 1e-3)
    assert shared[taken] - shared[0] < 5_000_000_000, "the initial pose is taken at the start"
    assert len(shared) - taken >= 50
    for stamp in shared[taken:]:
        assert math.dist(scene.localised_poses[stamp], scene.truth[stamp]) < 1e-3, stamp


def test_the_live_server_streams_transforms_and_markers_until_the_run_ends(
        watched_run: WatchedRun) -> None:
    live = watched_run.live
    frames = {(t.header.frame_id, t.child_frame_id) for m in live["/tf"] for t in m.transforms}
    assert {("map", "odom"), ("odom", "base_footprint")} <= frames, watched_run.account()
    areas = live["/servicesim/markers/areas"]
    assert areas and any(m.text.startswith("PublicCafe") for m in areas[-1].markers)
    recorded = scene_of(read_with_mcap_ros2(watched_run.out / "run.mcap"))
    streamed = scene_of(("/servicesim/markers", m) for m in live["/servicesim/markers"])
    crowd = len(recorded.people_seen) + 1  # and the guest
    whole = sorted(stamp for stamp, bodies in streamed.markers_at.items() if len(bodies) == crowd)
    assert len(whole) >= 10
    for stamp in whole:  # what was streamed was recorded
        assert recorded.markers_at.get(stamp) == streamed.markers_at[stamp], stamp


# ------------------------------------------------------------------------------ bad input
def test_an_address_in_use_is_one_line_and_exit_2_with_nothing_started(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = run_module("bt_servicesim.run", "--headless", "--foxglove", str(port),
                            cwd=tmp_path)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert f"--foxglove 127.0.0.1:{port}" in lines[0] and "in use" in lines[0]
    assert not (tmp_path / "runs").exists(), "no run started, no simulator"


@pytest.mark.parametrize("value", ["eighty", "70000", ":8765", "host:port"])
def test_a_bad_address_is_one_line_and_exit_2(tmp_path: Path, value: str) -> None:
    result = run_module("bt_servicesim.run", "--headless", f"--foxglove={value}", cwd=tmp_path)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--foxglove" in lines[0], result.stderr
    assert not (tmp_path / "runs").exists()
