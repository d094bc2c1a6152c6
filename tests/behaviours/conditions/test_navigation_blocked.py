"""NavigationBlocked: did the last navigation fail because someone stood in the way?

Through its port on the blackboard, as the mission tree wires it: ``error_code``, the Nav2 code
a ``NavigateToPose`` leaf wrote when its goal failed.
"""

from __future__ import annotations

import py_trees
import pytest

from bt_servicesim.behaviours.conditions.navigation_blocked import (
    BLOCKED_ERROR_CODES,
    NavigationBlocked,
)
from bt_servicesim.behaviours.node import ConditionNode, kind_of
from tests.fakes.leaves import wire

Status = py_trees.common.Status


def check(**inputs: int) -> NavigationBlocked:
    condition = wire(NavigationBlocked(name="blocked"), **inputs)
    condition.tick_once()
    return condition


@pytest.mark.parametrize("code", [105, 206, 208])
def test_no_progress_a_goal_occupied_or_no_path_is_a_blocked_way(code: int) -> None:
    condition = check(error_code=code)
    assert condition.status == Status.SUCCESS
    assert condition.feedback_message == f"navigation error {code}: blocked"


@pytest.mark.parametrize("code", [0, 9000, 9003, 101, 207])
def test_other_failures_are_not(code: int) -> None:
    condition = check(error_code=code)
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == f"navigation error {code}: other"


def test_no_code_on_the_blackboard_fails_with_a_message() -> None:
    condition = check()
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == "no navigation error on the blackboard"


def test_it_is_a_condition_on_exactly_the_three_codes() -> None:
    assert kind_of(NavigationBlocked) == "Condition"
    assert issubclass(NavigationBlocked, ConditionNode)
    assert frozenset({105, 206, 208}) == BLOCKED_ERROR_CODES
