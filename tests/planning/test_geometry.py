"""Planar transforms: composing map -> odom with odom -> base, as tf2 does for a robot."""

from __future__ import annotations

import math

import pytest

from bt_servicesim.planning.geometry import Pose2D, compose


def test_composing_with_the_identity_changes_nothing() -> None:
    pose = Pose2D(1.5, -2.0, 0.3)
    assert compose(Pose2D(0.0, 0.0, 0.0), pose) == pytest.approx(pose)


def test_odometry_from_a_turned_start_far_from_the_origin_lands_in_map() -> None:
    # the shipped spawn pose: odom's origin in map, facing west
    map_to_odom = Pose2D(10.975, 3.75, math.pi)
    ahead = compose(map_to_odom, Pose2D(1.0, 0.5, math.pi / 2))
    assert (ahead.x, ahead.y) == pytest.approx((9.975, 3.25))
    assert math.remainder(ahead.yaw - 3.0 * math.pi / 2, math.tau) == pytest.approx(0.0)


def test_the_yaw_stays_within_minus_pi_and_pi() -> None:
    turned = compose(Pose2D(0.0, 0.0, 3.0), Pose2D(0.0, 0.0, 3.0))
    assert -math.pi <= turned.yaw <= math.pi
    assert turned.yaw == pytest.approx(6.0 - math.tau)
