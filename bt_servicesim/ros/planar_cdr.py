"""The planar poses in odometry and transform messages, read straight from their CDR bytes.

The tree needs two things every period from the two busiest topics: the robot's pose in the
odometry frame (``nav_msgs/Odometry``) and the map -> odom transform (``tf2_msgs/TFMessage``).
rclpy turns a message's bytes into Python objects field by field, each nested message built
through its generated constructor (an ``Odometry`` has two 36-number covariances), a sizeable
share of what the executive spends on a period, spent on fields nobody reads; ``rosbags``'
deserialiser builds the whole message too. These readers take the frame names and the seven
numbers of a pose at their offsets in the serialised message, tens of times faster.

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

from bt_servicesim.planning.geometry import Pose2D, yaw_of

__all__ = ["PLAIN_CDR_LE", "StampedTransform", "odometry_pose", "transforms"]

PLAIN_CDR_LE = b"\x00\x01"
"""The encapsulation identifier of little-endian plain CDR, the first two bytes."""
_HEADER = 4
_U32 = struct.Struct("<I")
_POSE = struct.Struct("<7d")  # position x, y, z; orientation x, y, z, w
_STAMP = 8  # builtin_interfaces/Time: int32 sec, uint32 nanosec
_TRANSFORM = 7 * 8  # geometry_msgs/Transform: translation (3 doubles), rotation (4)

StampedTransform = tuple[str, str, Pose2D]
"""A transform's parent frame, child frame and the child's planar pose in the parent."""


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
