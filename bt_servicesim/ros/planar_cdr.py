"""The planar poses in odometry and transform messages, read straight from their CDR bytes.

The tree needs two things every period from the two busiest topics: the robot's pose in the
odometry frame (``nav_msgs/Odometry``) and the map -> odom transform (``tf2_msgs/TFMessage``).
rclpy turns a message's bytes into Python objects field by field, each nested message built
through its generated constructor (an ``Odometry`` has two 36-number covariances), a sizeable
share of what the executive spends on a period, spent on fields nobody reads; ``rosbags``'
deserialiser builds the whole message too. These readers take the frame names and the seven
numbers of a pose at their offsets in the serialised message, tens of times faster. The
people's ground truth (``servicesim_competition/ActorStates``, two a sim second in every run's
recording) is read the same way when a run's records are built from its recording: rclpy builds
a ``geometry_msgs/Point`` object for every person of every message.

The layout is ROS 2's, fixed by the message definitions: XCDR1 ("plain CDR") after a four-byte
encapsulation header, numbers aligned to their size counted from the end of that header,
strings as a 32-bit length (counting the terminating NUL) and the characters. Every ROS 2
middleware writes these two messages so by default. Bytes in any other encapsulation (big
endian, or XCDR2 from a middleware configured for it) are not read here: the readers return
None and the caller deserialises them with rclpy, so a message from any backend is understood.
Bytes that end early raise :class:`ValueError`, as rclpy does for a broken message.
"""

from __future__ import annotations

import struct
from typing import NamedTuple

from bt_servicesim.planning.geometry import Pose2D, yaw_of

__all__ = ["PLAIN_CDR_LE", "PeopleStates", "StampedTransform", "odometry_pose", "people_states",
           "transforms"]

PLAIN_CDR_LE = b"\x00\x01"
"""The encapsulation identifier of little-endian plain CDR, the first two bytes."""
_HEADER = 4
_U32 = struct.Struct("<I")
_POSE = struct.Struct("<7d")  # position x, y, z; orientation x, y, z, w
_STAMP = 8  # builtin_interfaces/Time: int32 sec, uint32 nanosec
_TRANSFORM = 7 * 8  # geometry_msgs/Transform: translation (3 doubles), rotation (4)
_POINT = struct.Struct("<3d")  # geometry_msgs/Point: x, y, z

StampedTransform = tuple[str, str, Pose2D]
"""A transform's parent frame, child frame and the child's planar pose in the parent."""


class PeopleStates(NamedTuple):
    """What a run's records read of an ``ActorStates``: names, roles and (x, y) of every
    person, in the message's order, and the guest's state."""

    names: list[str]
    roles: list[str]
    positions: list[tuple[float, float]]
    guest_state: str


def odometry_pose(data: bytes) -> tuple[str, Pose2D] | None:
    """The header's frame and the planar pose of a serialised ``nav_msgs/Odometry``.

    None when ``data`` is not little-endian plain CDR (deserialise it with rclpy instead).
    """
    if data[:2] != PLAIN_CDR_LE:
        return None
    offset = _STAMP
    frame, offset = _string(data, offset)
    _child, offset = _string(data, offset)
    return frame, _planar(data, _aligned(offset, 8))


def transforms(data: bytes) -> list[StampedTransform] | None:
    """Every transform of a serialised ``tf2_msgs/TFMessage``, in order.

    None when ``data`` is not little-endian plain CDR (deserialise it with rclpy instead).
    """
    if data[:2] != PLAIN_CDR_LE:
        return None
    count = _u32(data, 0)
    offset, found = 4, []
    for _ in range(count):
        offset = _aligned(offset, 4) + _STAMP
        parent, offset = _string(data, offset)
        child, offset = _string(data, offset)
        offset = _aligned(offset, 8)
        found.append((parent, child, _planar(data, offset)))
        offset += _TRANSFORM
    return found


def people_states(data: bytes) -> PeopleStates | None:
    """The names, roles, planar positions and guest state of a serialised ``ActorStates``.

    None when ``data`` is not little-endian plain CDR (deserialise it with rclpy instead).
    """
    if data[:2] != PLAIN_CDR_LE:
        return None
    names, offset = _strings(data, _STAMP)
    roles, offset = _strings(data, offset)
    count = _u32(data, _aligned(offset, 4))
    offset = _aligned(offset, 4) + 4
    if count:
        offset = _aligned(offset, 8)
    end = _HEADER + offset + count * _POINT.size
    if end > len(data):
        raise ValueError(f"the message ends at byte {len(data)}, inside its positions")
    positions = [(x, y) for x, y, _z in _POINT.iter_unpack(data[_HEADER + offset:end])]
    guest_state, _ = _string(data, offset + count * _POINT.size)
    return PeopleStates(names, roles, positions, guest_state)


def _strings(data: bytes, offset: int) -> tuple[list[str], int]:
    """The sequence of strings at ``offset``, and the offset after it."""
    count = _u32(data, _aligned(offset, 4))
    offset = _aligned(offset, 4) + 4
    found = []
    for _ in range(count):
        text, offset = _string(data, offset)
        found.append(text)
    return found, offset


def _aligned(offset: int, size: int) -> int:
    return offset + (-offset % size)


def _u32(data: bytes, offset: int) -> int:
    if _HEADER + offset + 4 > len(data):
        raise ValueError(f"the message ends at byte {len(data)}, inside a length")
    return int(_U32.unpack_from(data, _HEADER + offset)[0])


def _string(data: bytes, offset: int) -> tuple[str, int]:
    """The string at ``offset`` (a CDR string: aligned length, characters, NUL), and the
    offset after it."""
    offset = _aligned(offset, 4)
    length = _u32(data, offset)
    start = _HEADER + offset + 4
    if length == 0:  # writers put the NUL even in an empty string; be lenient all the same
        return "", offset + 4
    if start + length > len(data):
        raise ValueError(f"a string of length {length} at byte {start} does not fit the "
                         f"message's {len(data)} bytes")
    return data[start:start + length - 1].decode("utf-8"), offset + 4 + length


def _planar(data: bytes, offset: int) -> Pose2D:
    if _HEADER + offset + _POSE.size > len(data):
        raise ValueError(f"the message ends at byte {len(data)}, inside a pose")
    x, y, _z, qx, qy, qz, qw = _POSE.unpack_from(data, _HEADER + offset)
    return Pose2D(x=x, y=y, yaw=yaw_of(qx, qy, qz, qw))
