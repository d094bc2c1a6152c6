"""Did the last navigation fail because the way was blocked? A condition on Nav2's error code.

Nav2 says why a ``NavigateToPose`` goal failed in its result's ``error_code``: the planner's
``NO_VALID_PATH`` (208) when no path to the goal exists and ``GOAL_OCCUPIED`` (206) when
something stands on the goal, the controller's ``FAILED_TO_MAKE_PROGRESS`` (105) when the robot
stood still. Around the office's people all three can mean the same thing: someone stands in the
way and waits for the robot, as a walker does for anyone in its lane. The mission's navigation
recovery then gives way instead of trying the same way again at once
(:class:`~bt_servicesim.behaviours.actions.goals.GiveWaySpot`). Other failures (a goal
rejected, the server lost, a random abort) are not a blocked way.
"""

from __future__ import annotations

from typing import Any

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ConditionNode, Ports

__all__ = ["BLOCKED_ERROR_CODES", "NavigationBlocked"]

GOAL_OCCUPIED = 206
"""``nav2_msgs/action/ComputePathToPose`` result: the goal is in an obstacle."""
NO_VALID_PATH = 208
"""``nav2_msgs/action/ComputePathToPose`` result: no path to the goal."""
FAILED_TO_MAKE_PROGRESS = 105
"""``nav2_msgs/action/FollowPath`` result: the robot made no progress."""
BLOCKED_ERROR_CODES = frozenset({GOAL_OCCUPIED, NO_VALID_PATH, FAILED_TO_MAKE_PROGRESS})


class NavigationBlocked(ConditionNode):
    """SUCCESS when ``error_code`` (a NavigateToPose's last error) says the way was blocked."""

    INPUT_PORTS: Ports = {
        "error_code": PortInformation(data_type=int, required=True,
                                      description="the last navigation's Nav2 error code"),
    }
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str = "NavigationBlocked", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def check(self) -> bool:
        """Look the code up."""
        try:
            code = int(self.get_input("error_code"))
        except NoDataAvailable:
            self.feedback_message = "no navigation error on the blackboard"
            return False
        blocked = code in BLOCKED_ERROR_CODES
        self.feedback_message = f"navigation error {code}: {'blocked' if blocked else 'other'}"
        return blocked
