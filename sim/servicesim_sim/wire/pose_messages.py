"""The simulator's high-rate pose messages, serialised by hand: every I/O period's clock,
odometry, ground truth and /tf, and AMCL's pose.

Design intent: these messages are sent every 0.1 sim s and only a few numbers in them change.
Building them as rclpy messages cost the loop twice: setting each field runs rclpy's checks,
and ``Publisher.publish`` converts the whole message, both 36-number covariances of an
odometry included, into C before it serialises it (about 20 µs an odometry message, 50 µs
for a ``TFMessage`` built anew). Their CDR encoding has a fixed layout once the frame names
are fixed, so each kind here is a template of bytes, written once with the constant parts
(encapsulation, frame names, zero covariances, alignment) and copied per message with the
numbers packed into their places by :mod:`struct`. The node hands the bytes to
``Publisher.publish``, which sends serialised messages as they are (as it does the costmap:
:mod:`servicesim_sim.wire.costmap_message`). Readers cannot tell the difference:
``tests/sim/test_pose_messages.py`` reads each back with rclpy and compares it, field for field
and in length, with rclpy's own serialisation of the same message.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass

from servicesim_sim.wire.cdr import STAMP, CdrTemplate

__all__ = ["ClockBytes", "Link", "OdometryBytes", "PoseWithCovarianceBytes", "TransformsBytes",
           "split_stamp"]

_POSE = struct.Struct("<7d")  # position x y z, orientation x y z w
_TWIST = struct.Struct("<6d")  # linear x y z, angular x y z
_TRANSFORM = struct.Struct("<7d")  # translation x y z, rotation x y z w
_COVARIANCE = struct.Struct("<36d")

Pose = tuple[float, float, float]


def split_stamp(stamp_ns: int) -> tuple[int, int]:
    """A stamp in nanoseconds as ``builtin_interfaces/Time``'s (sec, nanosec)."""
    return divmod(stamp_ns, 1_000_000_000)


def _planar_pose(pose: Pose, *, z: float = 0.0) -> tuple[float, ...]:
    """Position and orientation numbers of a pose in the plane (yaw about z)."""
    return (float(pose[0]), float(pose[1]), z, 0.0, 0.0,
            math.sin(pose[2] / 2.0), math.cos(pose[2] / 2.0))


class ClockBytes:
    """``rosgraph_msgs/Clock``."""

    def __init__(self) -> None:
        template = CdrTemplate()
        self._stamp = template.slot(STAMP, alignment=4)
        self._template = template.done()

    def encode(self, *, stamp_ns: int) -> bytes:
        out = bytearray(self._template)
        STAMP.pack_into(out, self._stamp, *split_stamp(stamp_ns))
        return bytes(out)


class OdometryBytes:
    """``nav_msgs/Odometry`` in ``frame_id`` of ``child_frame_id`` moving in the plane: the
    pose's x, y and yaw, the forward and turning speeds; covariances zero."""

    def __init__(self, *, frame_id: str, child_frame_id: str) -> None:
        template = CdrTemplate()
        self._stamp = template.header(frame_id)
        template.string(child_frame_id)
        self._pose = template.slot(_POSE, alignment=8)
        template.slot(_COVARIANCE, alignment=8)
        self._twist = template.slot(_TWIST, alignment=8)
        template.slot(_COVARIANCE, alignment=8)
        self._template = template.done()

    def encode(self, *, stamp_ns: int, pose: Pose, twist: tuple[float, float]) -> bytes:
        out = bytearray(self._template)
        STAMP.pack_into(out, self._stamp, *split_stamp(stamp_ns))
        _POSE.pack_into(out, self._pose, *_planar_pose(pose))
        _TWIST.pack_into(out, self._twist, float(twist[0]), 0.0, 0.0, 0.0, 0.0, float(twist[1]))
        return bytes(out)


@dataclass(frozen=True)
class Link:
    """One planar transform ``parent`` -> ``child`` at height ``z``."""

    parent: str
    child: str
    z: float = 0.0


class TransformsBytes:
    """``tf2_msgs/TFMessage`` of one planar transform per link, all stamped alike."""

    def __init__(self, links: Sequence[Link]) -> None:
        template = CdrTemplate()
        template.count(len(links))
        self._links = tuple(links)
        self._slots: list[tuple[int, int]] = []
        for link in self._links:
            stamp = template.header(link.parent)
            template.string(link.child)
            self._slots.append((stamp, template.slot(_TRANSFORM, alignment=8)))
        self._template = template.done()

    def encode(self, *, stamp_ns: int, poses: Sequence[Pose]) -> bytes:
        """``poses``: each link's child origin in its parent, in the links' order."""
        out = bytearray(self._template)
        sec, nanosec = split_stamp(stamp_ns)
        for (stamp, transform), link, pose in zip(self._slots, self._links, poses, strict=True):
            STAMP.pack_into(out, stamp, sec, nanosec)
            _TRANSFORM.pack_into(out, transform, *_planar_pose(pose, z=link.z))
        return bytes(out)


class PoseWithCovarianceBytes:
    """``geometry_msgs/PoseWithCovarianceStamped`` in ``frame_id``: a planar pose with a
    diagonal covariance (x and y alike, yaw), as AMCL publishes its estimate."""

    def __init__(self, *, frame_id: str) -> None:
        template = CdrTemplate()
        self._stamp = template.header(frame_id)
        self._pose = template.slot(_POSE, alignment=8)
        self._covariance = template.slot(_COVARIANCE, alignment=8)
        self._template = template.done()

    def encode(self, *, stamp_ns: int, pose: Pose, std_m: float, std_rad: float) -> bytes:
        out = bytearray(self._template)
        STAMP.pack_into(out, self._stamp, *split_stamp(stamp_ns))
        _POSE.pack_into(out, self._pose, *_planar_pose(pose))
        covariance = [0.0] * 36
        covariance[0] = covariance[7] = std_m ** 2
        covariance[35] = std_rad ** 2
        _COVARIANCE.pack_into(out, self._covariance, *covariance)
        return bytes(out)
