"""The robot's per-period topics: ``/clock``, odometry, ground truth, ``/tf``, AMCL's pose, the
lidar and the RFID reader, as the original robot's plugins publish them.

Design intent: these go out every I/O period (0.1 sim s) and only a few numbers in them
change, so the high-rate ones are serialised by hand
(:mod:`servicesim_sim.wire.pose_messages`); the lidar is built only while someone listens.
"""

from __future__ import annotations

import array
import math

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from servicesim_competition.msg import ActorNames
from tf2_msgs.msg import TFMessage

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.localisation import Pose
from servicesim_sim.model.scan import LIDAR_HEIGHT_M, LIDAR_OFFSET
from servicesim_sim.ros.publishing import LATCHED, Publishing, stamp, stamp_ns
from servicesim_sim.wire.pose_messages import (
    ClockBytes,
    Link,
    OdometryBytes,
    PoseWithCovarianceBytes,
    TransformsBytes,
)

MAP_FRAME, ODOM_FRAME, BASE_FRAME = "map", "odom", "base_footprint"  # as the original's AMCL
BASE_LINK_HEIGHT_M = 0.749  # servicebot.urdf: base_footprint -> base_link
LIDAR_FRAME = "lidar_frame"
GROUND_TRUTH_TOPIC = "/servicesim/ground_truth/odom"
"""The robot's true pose in map, as Gazebo's model state would give it: for records and
tests, never for an executive (a real robot has no such topic)."""


class RobotTopics:
    """Publishes what the robot's sensors and localisation say, once per I/O period."""

    def __init__(self, *, engine: SimEngine, publishing: Publishing) -> None:
        self.engine = engine
        self._send = publishing.send
        publisher = publishing.publisher
        self._clock = publisher(Clock, "/clock", 10)
        self._odom = publisher(Odometry, "/servicebot/odom", 10)
        self._truth = publisher(Odometry, GROUND_TRUTH_TOPIC, 10)
        self._amcl_pose = publisher(PoseWithCovarianceStamped, "/servicebot/amcl_pose", LATCHED)
        self._tf = publisher(TFMessage, "/tf", 100)
        self._tf_static = publisher(TFMessage, "/tf_static", LATCHED)
        self._scan = publisher(LaserScan, "/servicebot/scan", 2)
        self._rfid = publisher(ActorNames, "/servicebot/rfid", 10)
        self._clock_bytes = ClockBytes()
        self._clock_message = self._clock_bytes.encode(stamp_ns=0)  # the last one sent
        self._odom_bytes = OdometryBytes(frame_id=ODOM_FRAME, child_frame_id=BASE_FRAME)
        self._truth_bytes = OdometryBytes(frame_id=MAP_FRAME, child_frame_id=BASE_FRAME)
        self._amcl_pose_bytes = PoseWithCovarianceBytes(frame_id=MAP_FRAME)
        odom_link = Link(parent=ODOM_FRAME, child=BASE_FRAME)
        self._tf_unlocalised = TransformsBytes([odom_link])
        self._tf_localised = TransformsBytes([odom_link, Link(parent=MAP_FRAME,
                                                              child=ODOM_FRAME)])
        self._scan_next = 0.0

    def send_static_transforms(self) -> None:
        """The robot's fixed frames on ``/tf_static`` (latched): base, body, lidar."""
        self._send(self._tf_static, TFMessage(transforms=[
            transform(BASE_FRAME, "base_link", (0.0, 0.0, 0.0), z=BASE_LINK_HEIGHT_M),
            transform("base_link", LIDAR_FRAME, LIDAR_OFFSET,
                      z=LIDAR_HEIGHT_M - BASE_LINK_HEIGHT_M)]))

    def publish(self) -> None:
        """The period's clock, odometry, transforms, scan and RFID reading."""
        self._clock_message = self._clock_bytes.encode(stamp_ns=stamp_ns(self.engine.sim_time))
        self._send(self._clock, self._clock_message)
        self._publish_odom()
        self._publish_localisation()
        self._publish_scan()
        names = self.engine.rfid_names()
        if names is not None:  # silent when nobody is near, or when a reading is dropped
            self._send(self._rfid, ActorNames(actor_names=names))

    def repeat_clock(self) -> None:
        """The last clock message, again (for subscribers that came late)."""
        self._send(self._clock, self._clock_message)

    def _publish_odom(self) -> None:
        """Odometry (in ``odom``, zero at spawn) and the ground truth (in ``map``)."""
        now = stamp_ns(self.engine.sim_time)
        twist = self.engine.robot_velocity()
        self._send(self._odom, self._odom_bytes.encode(
            stamp_ns=now, pose=self.engine.odometry_pose(), twist=twist))
        self._send(self._truth, self._truth_bytes.encode(
            stamp_ns=now, pose=self.engine.robot_pose(), twist=twist))

    def _publish_localisation(self) -> None:
        """/tf every period (odom -> base as the diff drive does, map -> odom once AMCL is
        running), and ``amcl_pose`` when the filter updated."""
        now = stamp_ns(self.engine.sim_time)
        if self.engine.localisation.localised:
            transforms = self._tf_localised.encode(
                stamp_ns=now, poses=(self.engine.odometry_pose(), self.engine.map_to_odom()))
        else:
            transforms = self._tf_unlocalised.encode(stamp_ns=now,
                                                     poses=(self.engine.odometry_pose(),))
        self._send(self._tf, transforms)
        estimate = self.engine.new_estimate()
        if estimate is not None:
            self._send(self._amcl_pose, self._amcl_pose_bytes.encode(
                stamp_ns=now, pose=estimate.pose, std_m=estimate.std_m,
                std_rad=estimate.std_rad))

    def _publish_scan(self) -> None:
        """A sweep every 0.1 sim s (the original's 10 Hz), only while someone listens."""
        spec = self.engine.scanner.spec
        if self.engine.sim_time < self._scan_next - 1e-9:
            return
        self._scan_next = self.engine.sim_time + 1.0 / spec.rate_hz
        if self._scan.get_subscription_count() == 0:
            return
        scan = LaserScan(angle_min=spec.angle_min, angle_max=spec.angle_max,
                         angle_increment=spec.angle_increment, time_increment=0.0,
                         scan_time=1.0 / spec.rate_hz, range_min=spec.range_min,
                         range_max=spec.range_max)
        scan.header.stamp = stamp(self.engine.sim_time)
        scan.header.frame_id = LIDAR_FRAME
        scan.ranges = array.array("f", self.engine.scan_ranges().tobytes())
        self._send(self._scan, scan)


def transform(parent: str, child: str, pose: Pose, now: Time | None = None, *,
              z: float = 0.0) -> TransformStamped:
    """The planar transform parent -> child (``pose``: the child's origin in the parent)."""
    message = TransformStamped()
    if now is not None:
        message.header.stamp = now
    message.header.frame_id, message.child_frame_id = parent, child
    translation, rotation = message.transform.translation, message.transform.rotation
    translation.x, translation.y, translation.z = float(pose[0]), float(pose[1]), z
    rotation.z, rotation.w = math.sin(pose[2] / 2.0), math.cos(pose[2] / 2.0)
    return message
