"""GuestInRange: a condition on the RFID list, through its ports on the blackboard."""

from __future__ import annotations

import py_trees
import pytest
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.conditions.guest_in_range import GuestInRange
from bt_servicesim.behaviours.node import ConditionNode, kind_of
from tests.fakes.guest import GUEST
from tests.fakes.leaves import ready

Status = py_trees.common.Status


def test_guest_in_range() -> None:
    condition = ready(GuestInRange(name="in_range"), guest_name="/guest",
                      actors_in_range="/actors")
    Blackboard.set("/guest", GUEST)
    Blackboard.set("/actors", ["human_11111", GUEST])
    condition.tick_once()
    assert condition.status == Status.SUCCESS
    assert condition.feedback_message == f"{GUEST} in RFID range"
    Blackboard.set("/actors", ["human_11111"])
    condition.tick_once()
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == f"{GUEST} not in RFID range"


@pytest.mark.parametrize(("inputs", "expected"), [
    ({"/guest": GUEST, "/actors": [GUEST]}, Status.SUCCESS),
    ({"/guest": GUEST, "/actors": []}, Status.FAILURE),
    ({"/guest": GUEST}, Status.FAILURE),
    ({"/actors": [GUEST]}, Status.FAILURE),
    ({}, Status.FAILURE),
])
def test_guest_in_range_is_a_condition_answering_at_once(
        inputs: dict[str, object], expected: Status) -> None:
    assert issubclass(GuestInRange, ConditionNode)
    assert kind_of(GuestInRange) == "Condition"
    condition = ready(GuestInRange(name="in_range"), guest_name="/guest",
                      actors_in_range="/actors")
    for key, value in inputs.items():
        Blackboard.set(key, value)
    for _ in range(3):  # never RUNNING, however often it is asked
        condition.tick_once()
        assert condition.status == expected
    if len(inputs) < 2:
        assert condition.feedback_message.startswith("cannot check the guest")
