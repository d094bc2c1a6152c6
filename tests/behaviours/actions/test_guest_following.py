"""GuestFollowing: the guest remembered while in RFID range, lost after a grace period.

The executive's node runs on sim time; the test publishes /clock and jumps it, so the grace
period is checked in sim seconds without waiting for it in wall time.
"""

from __future__ import annotations

import py_trees
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.actions.guest_following import GuestFollowing
from bt_servicesim.planning.geometry import Pose2D
from tests.fakes.graphs import SensorWorld
from tests.fakes.guest import GUEST
from tests.fakes.leaves import ready

Status = py_trees.common.Status


def test_guest_following_remembers_and_then_loses_the_guest(world: SensorWorld) -> None:
    world.jump_to(100.0)
    monitor = ready(GuestFollowing(name="following", grace=3.0), world.node,
                    guest_name="/guest", actors_in_range="/actors", robot_pose="/pose",
                    guest_last_seen="/last_seen")
    Blackboard.set("/guest", GUEST)
    Blackboard.set("/actors", [GUEST])
    Blackboard.set("/pose", Pose2D(1.0, 1.0))
    monitor.tick_once()
    assert monitor.status == Status.RUNNING
    assert Blackboard.get("/last_seen") == Pose2D(1.0, 1.0)

    Blackboard.set("/actors", [])
    Blackboard.set("/pose", Pose2D(4.0, 1.0))
    world.jump_to(102.0)
    monitor.tick_once()
    assert monitor.status == Status.RUNNING
    assert "out of range for 2.0/3.0" in monitor.feedback_message
    assert Blackboard.get("/last_seen") == Pose2D(1.0, 1.0)

    world.jump_to(103.5)
    monitor.tick_once()
    assert monitor.status == Status.FAILURE
    assert monitor.feedback_message == "guest lost: not in RFID range for 3.5 s"


def test_guest_following_is_reset_by_each_sighting(world: SensorWorld) -> None:
    world.jump_to(100.0)
    monitor = ready(GuestFollowing(name="following", grace=3.0), world.node,
                    guest_name="/guest", actors_in_range="/actors")
    Blackboard.set("/guest", GUEST)
    Blackboard.set("/actors", [])
    monitor.tick_once()
    world.jump_to(102.5)
    Blackboard.set("/actors", [GUEST])
    monitor.tick_once()  # seen again: the grace period restarts
    Blackboard.set("/actors", [])
    world.jump_to(105.0)
    monitor.tick_once()
    assert monitor.status == Status.RUNNING
    world.jump_to(105.6)
    monitor.tick_once()
    assert monitor.status == Status.FAILURE
