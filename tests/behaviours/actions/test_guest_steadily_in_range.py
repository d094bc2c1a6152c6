"""GuestSteadilyInRange: half a second of RFID readings, all naming the guest, on sim time."""

from __future__ import annotations

import py_trees

from bt_servicesim.behaviours.actions.guest_steadily_in_range import GuestSteadilyInRange
from bt_servicesim.planning.guest_localisation import RfidHistory, RfidReading
from tests.fakes.guest import GUEST, RFID_PERIOD
from tests.fakes.leaves import wire
from tests.mission_script import ManualClock

Status = py_trees.common.Status


def steady_check(readings: list[bool], clock: ManualClock) -> Status:
    """Tick GuestSteadilyInRange while readings come every 0.1 s (None: a lost message)."""
    history = RfidHistory()
    check = wire(GuestSteadilyInRange(), clock, guest_name=GUEST, rfid_history=history)
    check.tick_once()
    for heard in readings:
        clock.advance(RFID_PERIOD)
        if heard is not None:
            names = frozenset({GUEST} if heard else set())
            history.add(RfidReading(clock.nanoseconds / 1e9, 0.0, 0.0, names))
        check.tick_once()
        if check.status != Status.RUNNING:
            break
    return check.status


def test_the_pick_up_waits_for_half_a_second_of_readings_all_naming_the_guest() -> None:
    assert steady_check([True] * 3, ManualClock()) == Status.RUNNING
    assert steady_check([True] * 6, ManualClock()) == Status.SUCCESS
    assert steady_check([True, None, True, None, True, True], ManualClock()) == Status.SUCCESS


def test_a_guest_dropping_out_of_range_or_silence_fails_the_check() -> None:
    assert steady_check([True, True, False, True, True, True], ManualClock()) == Status.FAILURE
    assert steady_check([None] * 40, ManualClock()) == Status.FAILURE
