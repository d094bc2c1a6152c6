"""Nav2's ``NavigateToPose`` action as its clients hold it: the names of their types.

The tree's :class:`~bt_servicesim.behaviours.actions.navigate_to_pose.NavigateToPose` and the
baseline executive (:mod:`bt_servicesim.evaluation.baseline`) both send it goals; rclpy's
generic client, goal handle and result are spelled out here once, over the action's goal,
result and feedback messages.
"""

from __future__ import annotations

from typing import TypeAlias

from nav2_msgs.action import NavigateToPose
from rclpy.action.client import ActionClient, ClientGoalHandle
from rclpy.type_support import GetResultServiceResponse

__all__ = ["NavigateToPose", "NavigationClient", "NavigationGoalHandle", "NavigationResult"]

NavigationClient: TypeAlias = ActionClient[
    NavigateToPose.Goal, NavigateToPose.Result, NavigateToPose.Feedback]
NavigationGoalHandle: TypeAlias = ClientGoalHandle[
    NavigateToPose.Goal, NavigateToPose.Result, NavigateToPose.Feedback]
NavigationResult: TypeAlias = GetResultServiceResponse[NavigateToPose.Result]
"""What the result request answers: the goal's status and the action's result."""
