"""The pose messages, serialised by hand: what rclpy would send, field for field and in length.

Not byte for byte: Fast CDR leaves alignment padding as it found the buffer (see
test_costmap_message). Each message is built here as the node built it with rclpy, for
varied numbers and frame names of varied lengths (which move the alignment of what follows).
"""

from __future__ import annotations

import math
from typing import Any

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage

from servicesim_sim.wire.pose_messages import (
    ClockBytes,
    Link,
    OdometryBytes,
    PoseWithCovarianceBytes,
    TransformsBytes,
    split_stamp,
)

STAMPS_NS = [0, 1, 999_999_999, 1_000_000_000, 233_960_000_000, 2**31 * 1_000_000_000 - 1]
POSES = [(0.0, 0.0, 0.0), (20.3, 13.1, 1.9102876514490017), (-16.5, 10.025, -2.159542248896137),
         (1e-12, -1e6, math.pi), (-0.1, 0.2, -math.pi)]
FRAMES = ["odom", "map", "", "a", "abc", "base_footprint", "a_frame_of_seven_ch"]


def same(ours: bytes, theirs: bytes, kind: type) -> Any:
    """Both decode to equal messages of the same length; ours decoded."""
    assert len(ours) == len(theirs)
    read = deserialize_message(ours, kind)
    assert read == deserialize_message(theirs, kind)
    return read


def time_of(stamp_ns: int) -> Any:
    from builtin_interfaces.msg import Time

    sec, nanosec = split_stamp(stamp_ns)
    return Time(sec=sec, nanosec=nanosec)


def set_planar(position: Any, orientation: Any, pose: tuple[float, float, float]) -> None:
    position.x, position.y = pose[0], pose[1]
    orientation.z, orientation.w = math.sin(pose[2] / 2.0), math.cos(pose[2] / 2.0)


@pytest.mark.parametrize("stamp_ns", STAMPS_NS)
def test_clock(stamp_ns: int) -> None:
    read = same(ClockBytes().encode(stamp_ns=stamp_ns),
                serialize_message(Clock(clock=time_of(stamp_ns))), Clock)
    assert (read.clock.sec, read.clock.nanosec) == split_stamp(stamp_ns)


@pytest.mark.parametrize("frames", [("odom", "base_footprint"), ("map", "base_footprint"),
                                    ("", "a"), ("abc", ""), ("a_frame_of_seven_ch", "ab")])
@pytest.mark.parametrize("stamp_ns", STAMPS_NS[:4])
@pytest.mark.parametrize("pose", POSES)
def test_odometry(frames: tuple[str, str], stamp_ns: int,
                  pose: tuple[float, float, float]) -> None:
    twist = (pose[0] / 7.0, -pose[2])
    message = Odometry()
    message.header.stamp = time_of(stamp_ns)
    message.header.frame_id, message.child_frame_id = frames
    set_planar(message.pose.pose.position, message.pose.pose.orientation, pose)
    message.twist.twist.linear.x, message.twist.twist.angular.z = twist
    ours = OdometryBytes(frame_id=frames[0], child_frame_id=frames[1]).encode(
        stamp_ns=stamp_ns, pose=pose, twist=twist)
    read = same(ours, serialize_message(message), Odometry)
    assert (read.pose.pose.position.x, read.twist.twist.angular.z) == (pose[0], twist[1])


def rclpy_transform(link: Link, pose: tuple[float, float, float],
                    stamp_ns: int) -> TransformStamped:
    message = TransformStamped()
    message.header.stamp = time_of(stamp_ns)
    message.header.frame_id, message.child_frame_id = link.parent, link.child
    message.transform.translation.z = link.z
    set_planar(message.transform.translation, message.transform.rotation, pose)
    return message


@pytest.mark.parametrize("count", [0, 1, 2, 3])
@pytest.mark.parametrize("stamp_ns", STAMPS_NS)
@pytest.mark.parametrize("first_frame", FRAMES)
def test_transforms(count: int, stamp_ns: int, first_frame: str) -> None:
    links = [Link(parent=first_frame, child=FRAMES[(i + 2) % len(FRAMES)], z=0.1 * i)
             for i in range(count)]
    poses = POSES[:count]
    theirs = TFMessage(transforms=[rclpy_transform(link, pose, stamp_ns)
                                   for link, pose in zip(links, poses, strict=True)])
    ours = TransformsBytes(links).encode(stamp_ns=stamp_ns, poses=poses)
    read = same(ours, serialize_message(theirs), TFMessage)
    assert [t.child_frame_id for t in read.transforms] == [link.child for link in links]


def test_transforms_need_a_pose_per_link() -> None:
    with pytest.raises(ValueError):
        TransformsBytes([Link(parent="map", child="odom")]).encode(stamp_ns=0, poses=[])


@pytest.mark.parametrize("frame_id", FRAMES)
@pytest.mark.parametrize("pose", POSES)
@pytest.mark.parametrize("stds", [(0.0, 0.0), (0.05, 0.02), (1.5, math.pi)])
def test_pose_with_covariance(frame_id: str, pose: tuple[float, float, float],
                              stds: tuple[float, float]) -> None:
    message = PoseWithCovarianceStamped()
    message.header.stamp, message.header.frame_id = time_of(123_456_789_012), frame_id
    set_planar(message.pose.pose.position, message.pose.pose.orientation, pose)
    covariance = [0.0] * 36
    covariance[0] = covariance[7] = stds[0] ** 2
    covariance[35] = stds[1] ** 2
    message.pose.covariance = covariance
    ours = PoseWithCovarianceBytes(frame_id=frame_id).encode(
        stamp_ns=123_456_789_012, pose=pose, std_m=stds[0], std_rad=stds[1])
    read = same(ours, serialize_message(message), PoseWithCovarianceStamped)
    assert read.pose.covariance[35] == stds[1] ** 2
