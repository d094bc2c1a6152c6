"""Where the robot thinks it is: wheel odometry and an AMCL-like map pose, with no ROS in it.

The original robot (``servicebot.urdf``) drives with ``gazebo_ros_diff_drive``, ``odometrySource
encoder`` and ``publishTf true``: odometry is in frame ``odom``, zero where the robot spawned,
and the transform odom -> base_footprint goes on ``/tf``. The map pose comes only from AMCL
(``amcl_diff.launch``), started by the initial pose the seed publishes; AMCL broadcasts
map -> odom, so that map -> odom -> base_footprint is the robot's map pose. These classes play
both parts for the simulator's node.

:class:`WheelOdometry` integrates the base's motion (the wheels' speeds: what the robot truly
did, so a robot held by a wall counts nothing) step by step from the spawn pose. With
``drift`` > 0 it is an encoder with a calibration error, drawn once from the seeded generator:
distance travelled scaled by ``1 + drift * N(0, 1)`` and heading change by another such factor,
so odometry wanders off the true pose as the robot drives, as real odometry does.

:class:`AmclModel` is not a particle filter; it models what AMCL does with this robot's lidar on
a known, static map, which is all a client can observe:

* nothing (no estimate, no map -> odom) until an initial pose arrives (the engine gives it the
  world's AMCL launch pose at start, as ROS 1 AMCL starts at its ``initial_pose_*``);
* on an initial pose, the estimate is that pose, published at once;
* the filter updates only when odometry has moved ``update_min_d`` metres or turned
  ``update_min_a`` radians since its last update (Nav2's AMCL defaults, 0.25 m and 0.2 rad);
  between updates map -> odom stays put, so the estimate follows odometry;
* at an update, an estimate that started within :data:`CONVERGENCE_RADIUS_M` and
  :data:`CONVERGENCE_ANGLE_RAD` of the true pose (where AMCL's initial particle cloud, 0.5 m and
  about 0.26 rad standard deviation by default, covers the truth and the lidar pulls it in) is
  the true pose, plus seeded Gaussian noise of ``noise`` metres (and radians) when asked for;
  an initial pose farther off never converges (the cloud does not cover the truth), and the
  estimate keeps following odometry from the wrong start, as a lost AMCL does;
* every update publishes the estimate (``amcl_pose``) and moves map -> odom.

A new initial pose starts over. Poses are (x, y, yaw) tuples: metres and radians. An initial
pose AMCL would ignore is ignored (:func:`initial_pose_problem`): one in a frame other than
``map`` (AMCL takes it in its global frame only), and one with a number that is not finite or
a quaternion of no length (Nav2's AMCL rejects such a message as malformed, with
``nav2_util::validateMsg``), which would otherwise put NaN in every estimate after it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from servicesim_sim.navigation.goals import MIN_QUATERNION_NORM

Pose = tuple[float, float, float]

IDENTITY: Pose = (0.0, 0.0, 0.0)
CONVERGENCE_RADIUS_M = 1.0
CONVERGENCE_ANGLE_RAD = 0.5
UPDATE_MIN_D = 0.25  # Nav2 AMCL's default update_min_d
UPDATE_MIN_A = 0.2  # Nav2 AMCL's default update_min_a
CONVERGED_STD_M = 0.05  # the spread a converged estimate reports, before any noise knob
INITIAL_STD_M, INITIAL_STD_RAD = 0.5, math.pi / 12  # AMCL's default initial_cov_xx / _aa


def wrap(angle: float) -> float:
    """The angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def compose(a: Pose, b: Pose) -> Pose:
    """``b`` (given in ``a``'s frame) in the frame ``a`` is given in: the transform a * b."""
    cos, sin = math.cos(a[2]), math.sin(a[2])
    return (a[0] + cos * b[0] - sin * b[1], a[1] + sin * b[0] + cos * b[1], wrap(a[2] + b[2]))


def inverse(a: Pose) -> Pose:
    """The transform that undoes ``a``."""
    cos, sin = math.cos(a[2]), math.sin(a[2])
    return (-cos * a[0] - sin * a[1], sin * a[0] - cos * a[1], wrap(-a[2]))


def between(a: Pose, b: Pose) -> Pose:
    """``b`` seen from ``a``: the motion that takes pose ``a`` to pose ``b``."""
    return compose(inverse(a), b)


class WheelOdometry:
    """Encoder odometry: the robot's pose in ``odom``, zero at the spawn pose."""

    def __init__(self, *, drift: float, rng: np.random.Generator) -> None:
        if not drift >= 0.0:
            raise ValueError(f"odometry drift {drift}: must be 0 or more")
        self.pose: Pose = IDENTITY
        scale_d, scale_a = rng.standard_normal(2)
        self._scale_d, self._scale_a = 1.0 + drift * scale_d, 1.0 + drift * scale_a

    def update(self, *, v: float, w: float, dt: float) -> None:
        """Count the wheels' turns over ``dt``: the base moved at (v, w) (an arc)."""
        if v == 0.0 and w == 0.0:
            return
        distance, turn = v * dt * self._scale_d, w * dt * self._scale_a
        if abs(turn) > 1e-9:
            radius = distance / turn
            step = (radius * math.sin(turn), radius * (1.0 - math.cos(turn)), turn)
        else:
            step = (distance, 0.0, turn)
        self.pose = compose(self.pose, step)


@dataclass(frozen=True)
class Estimate:
    """An AMCL pose: the map pose and the standard deviations it reports."""

    pose: Pose
    std_m: float
    std_rad: float


class AmclModel:
    """The map pose as AMCL would estimate it; see the module docstring."""

    def __init__(self, *, noise: float, rng: np.random.Generator,
                 update_min_d: float = UPDATE_MIN_D, update_min_a: float = UPDATE_MIN_A) -> None:
        if not noise >= 0.0:
            raise ValueError(f"localisation noise {noise}: must be 0 or more")
        self.noise, self._rng = noise, rng
        self.update_min_d, self.update_min_a = update_min_d, update_min_a
        self.map_to_odom: Pose | None = None
        self.estimate: Estimate | None = None
        self._converges = False
        self._since_update: Pose = inverse(IDENTITY)  # undoes the odometry of the last update

    @property
    def localised(self) -> bool:
        return self.map_to_odom is not None

    def pose(self, odom: Pose) -> Pose | None:
        """The map pose now (map -> odom -> base), None before an initial pose."""
        return None if self.map_to_odom is None else compose(self.map_to_odom, odom)

    def set_initial_pose(self, guess: Pose, *, odom: Pose, truth: Pose) -> None:
        """Start over at ``guess`` (the robot's odometry reads ``odom``, it truly is at
        ``truth``)."""
        off = between(truth, guess)
        self._converges = (math.hypot(off[0], off[1]) <= CONVERGENCE_RADIUS_M
                           and abs(off[2]) <= CONVERGENCE_ANGLE_RAD)
        self._publish(guess, odom, Estimate(guess, INITIAL_STD_M, INITIAL_STD_RAD))

    def update(self, *, odom: Pose, truth: Pose) -> bool:
        """A filter update if odometry moved far enough since the last one; whether it ran."""
        if self.map_to_odom is None:
            return False
        dx, dy, dyaw = compose(self._since_update, odom)  # between(last update's odom, odom)
        if math.hypot(dx, dy) < self.update_min_d and abs(dyaw) < self.update_min_a:
            return False
        if not self._converges:
            pose = compose(self.map_to_odom, odom)
            self._publish(pose, odom, Estimate(pose, INITIAL_STD_M, INITIAL_STD_RAD))
            return True
        pose = truth
        if self.noise > 0.0:
            ex, ey, eyaw = self.noise * self._rng.standard_normal(3)
            pose = (truth[0] + ex, truth[1] + ey, wrap(truth[2] + eyaw))
        spread = CONVERGED_STD_M + self.noise
        self._publish(pose, odom, Estimate(pose, spread, spread))
        return True

    def _publish(self, pose: Pose, odom: Pose, estimate: Estimate) -> None:
        self.map_to_odom = compose(pose, inverse(odom))
        self.estimate = estimate
        self._since_update = inverse(odom)


def initial_pose_problem(*, frame_id: str, global_frame: str,
                         numbers: Sequence[float],
                         orientation: tuple[float, float, float, float]) -> str | None:
    """Why AMCL would ignore this initial pose, or None: a frame that is not ``global_frame``
    (an empty one is taken as the global frame, as ROS 1 AMCL takes it), a number that is not
    finite among ``numbers`` (the position, the orientation and the covariance), an orientation
    of no length."""
    if frame_id and frame_id != global_frame:
        return f"frame {frame_id!r}, must be {global_frame!r}"
    if not all(math.isfinite(number) for number in numbers):
        return "a number in it is not finite"
    if math.hypot(*orientation) < MIN_QUATERNION_NORM:
        return "its orientation is a quaternion of no length"
    return None
