"""The planar CDR readers against rclpy's own serialisation of the same messages."""

from __future__ import annotations

import math
import random
import struct

import pytest
from geometry_msgs.msg import Point, TransformStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from servicesim_competition.msg import ActorStates
from tf2_msgs.msg import TFMessage

from bt_servicesim.behaviours.actions.localised_pose import LocalisedPoseToBlackboard
from bt_servicesim.planning.geometry import Pose2D, yaw_of
from bt_servicesim.ros.planar_cdr import odometry_pose, people_states, transforms

# frame names of every length mod 4 and mod 8, so that every alignment after them is met
FRAMES = ["", "m", "od", "map", "odom", "base_footprint", "a/b/c", "ünïcode_frame"]


def quaternion(rng: random.Random) -> tuple[float, float, float, float]:
    values = [rng.uniform(-1.0, 1.0) for _ in range(4)]
    norm = math.sqrt(sum(v * v for v in values))
    return tuple(v / norm for v in values)  # type: ignore[return-value]


def odometry(rng: random.Random, frame: str, child: str) -> Odometry:
    message = Odometry()
    message.header.stamp.sec, message.header.stamp.nanosec = rng.randrange(2**31), 999
    message.header.frame_id, message.child_frame_id = frame, child
    pose = message.pose.pose
    pose.position.x, pose.position.y, pose.position.z = (rng.uniform(-1e3, 1e3) for _ in "xyz")
    q = quaternion(rng)
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = q
    message.pose.covariance = [rng.random() for _ in range(36)]
    message.twist.twist.linear.x = rng.random()
    return message


def stamped(rng: random.Random, parent: str, child: str) -> TransformStamped:
    transform = TransformStamped()
    transform.header.stamp.sec = rng.randrange(2**31)
    transform.header.frame_id, transform.child_frame_id = parent, child
    t = transform.transform
    t.translation.x, t.translation.y, t.translation.z = (rng.uniform(-50, 50) for _ in "xyz")
    t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w = quaternion(rng)
    return transform


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("child", FRAMES)
def test_odometry_reads_the_frame_and_the_planar_pose_rclpy_wrote(frame: str, child: str) -> None:
    rng = random.Random(f"{frame}/{child}")
    message = odometry(rng, frame, child)
    read = odometry_pose(serialize_message(message))
    assert read is not None
    pose, q = message.pose.pose, message.pose.pose.orientation
    assert read[0] == frame
    assert (read[1].x, read[1].y) == (pose.position.x, pose.position.y)
    assert read[1].yaw == yaw_of(q.x, q.y, q.z, q.w)


@pytest.mark.parametrize("count", [0, 1, 2, 5])
def test_transforms_reads_every_transform_in_order(count: int) -> None:
    rng = random.Random(count)
    sent = [stamped(rng, rng.choice(FRAMES), rng.choice(FRAMES)) for _ in range(count)]
    read = transforms(serialize_message(TFMessage(transforms=sent)))
    assert read is not None and len(read) == count
    for (parent, child, pose), transform in zip(read, sent, strict=True):
        t, q = transform.transform, transform.transform.rotation
        assert (parent, child) == (transform.header.frame_id, transform.child_frame_id)
        assert (pose.x, pose.y) == (t.translation.x, t.translation.y)
        assert pose.yaw == yaw_of(q.x, q.y, q.z, q.w)


def test_another_encapsulation_is_left_to_rclpy() -> None:
    data = bytearray(serialize_message(odometry(random.Random(1), "odom", "base")))
    data[1] = 0x00  # big-endian plain CDR
    assert odometry_pose(bytes(data)) is None
    assert transforms(bytes(data)) is None


def test_bytes_that_end_early_are_refused_with_where() -> None:
    data = serialize_message(odometry(random.Random(2), "odom", "base_footprint"))
    for cut in (6, 14, 40, 60):
        with pytest.raises(ValueError, match="message"):
            odometry_pose(data[:cut])
    tf = serialize_message(TFMessage(transforms=[stamped(random.Random(3), "map", "odom")]))
    with pytest.raises(ValueError, match="message"):
        transforms(tf[:-8])


def big_endian_odometry(frame: str, child: str, x: float, y: float,
                        q: tuple[float, float, float, float]) -> bytes:
    """An ``Odometry`` in big-endian plain CDR, as no ROS 2 middleware writes by default."""
    out = bytearray(b"\x00\x00\x00\x00") + struct.pack(">iI", 7, 8)
    for name in (frame, child):
        out += b"\x00" * (-(len(out) - 4) % 4)
        encoded = name.encode() + b"\x00"
        out += struct.pack(">I", len(encoded)) + encoded
    out += b"\x00" * (-(len(out) - 4) % 8)
    out += struct.pack(">7d", x, y, 0.0, *q) + struct.pack(">36d", *([0.0] * 36))
    out += struct.pack(">6d", *([0.0] * 6)) + struct.pack(">36d", *([0.0] * 36))
    return bytes(out)


def test_the_pose_reader_falls_back_to_rclpy_for_big_endian_odometry() -> None:
    q = (0.0, 0.0, math.sin(0.35), math.cos(0.35))
    data = big_endian_odometry("odom", "base_footprint", 1.5, -2.25, q)
    assert odometry_pose(data) is None
    reader = LocalisedPoseToBlackboard(name="pose")
    reader._on_odometry(data)  # the subscription's callback, given the bytes DDS delivered
    reader._on_transforms(serialize_message(TFMessage(transforms=[
        stamped(random.Random(4), "map", "odom")])))
    assert reader._odometry == Pose2D(x=1.5, y=-2.25, yaw=pytest.approx(0.7))
    assert reader._map_to_odom is not None


def actor_states(rng: random.Random, count: int) -> ActorStates:
    message = ActorStates(names=[rng.choice(FRAMES) + str(index) for index in range(count)],
                          roles=[rng.choice(FRAMES) for _ in range(count)],
                          guest_state=rng.choice(FRAMES))
    message.stamp.sec, message.stamp.nanosec = rng.randrange(2**31), rng.randrange(10**9)
    message.positions = [Point(x=rng.uniform(-1e3, 1e3), y=rng.uniform(-1e3, 1e3),
                               z=rng.uniform(-1.0, 1.0)) for _ in range(count)]
    return message


@pytest.mark.parametrize("count", [0, 1, 2, 3, 5, 41])
@pytest.mark.parametrize("seed", range(4))
def test_people_states_reads_what_rclpy_wrote(count: int, seed: int) -> None:
    message = actor_states(random.Random(f"{count}/{seed}"), count)
    read = people_states(serialize_message(message))
    assert read is not None
    assert (read.names, read.roles, read.guest_state) == (
        list(message.names), list(message.roles), message.guest_state)
    assert read.positions == [(point.x, point.y) for point in message.positions]


def test_people_states_refuses_bytes_that_end_early_and_leaves_big_endian_to_rclpy() -> None:
    data = serialize_message(actor_states(random.Random(5), 3))
    for cut in (10, len(data) - 30, len(data) - 2):
        with pytest.raises(ValueError, match="message"):
            people_states(data[:cut])
    assert people_states(b"\x00\x00" + data[2:]) is None
