"""RecordRfidReadings: each RFID message once into the history, where the robot heard it."""

from __future__ import annotations

import py_trees
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.actions.record_rfid_readings import RecordRfidReadings
from bt_servicesim.planning.geometry import Pose2D
from tests.fakes.guest import GUEST
from tests.fakes.leaves import wire
from tests.mission_script import ManualClock

Status = py_trees.common.Status


def test_each_rfid_message_is_recorded_once_and_silence_as_nobody_in_range() -> None:
    clock = ManualClock()
    recorder = wire(RecordRfidReadings(), clock, actors_in_range=[GUEST], rfid_age=0.02,
                    robot_pose=Pose2D(1.0, 2.0))
    recorder.tick_once()
    clock.advance(0.05)
    Blackboard.set("/rfid_age", 0.07)  # the same message, a tick later
    recorder.tick_once()
    history = Blackboard.get("/rfid_history")
    assert [reading.names for reading in history] == [frozenset({GUEST})]
    assert (history.latest.x, history.latest.y) == (1.0, 2.0)

    clock.advance(0.05)
    Blackboard.set("/rfid_age", 0.0)  # a new message
    recorder.tick_once()
    assert len(history) == 2
    for _ in range(5):  # the sensor falls silent; the list on the blackboard is stale
        clock.advance(0.1)
        Blackboard.set("/rfid_age", Blackboard.get("/rfid_age") + 0.1)
        recorder.tick_once()
    assert [reading.names for reading in history][-2:] == [frozenset(), frozenset()]
    assert recorder.status == Status.SUCCESS
    assert Blackboard.get("/rfid_history") is history


def test_the_recorder_waits_quietly_for_odometry() -> None:
    recorder = wire(RecordRfidReadings(), ManualClock(), actors_in_range=[], rfid_age=0.0)
    recorder.tick_once()
    assert recorder.status == Status.SUCCESS
    assert len(Blackboard.get("/rfid_history")) == 0
