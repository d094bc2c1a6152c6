"""A scripted ``NavigateToPose`` action server: :class:`FakeNavigator`."""

from __future__ import annotations

import time
from typing import Any

from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionServer, CancelResponse, GoalResponse

from bt_servicesim.ros.messages import pose_from_msg
from tests.fakes.referee import Result
from tests.fakes.servers import EventLog, FakeServer
from tests.fakes.spinning import unique_name


class FakeNavigator(FakeServer):
    """A scripted NavigateToPose server at ``action``.

    Each goal (accepted while ``accept``) takes the next of ``outcomes``, or ``outcome`` once
    they are used up: ``steps`` feedbacks ``step_s`` apart (none when ``silent``), then
    ``succeed``, ``abort`` (a planner timeout), or ``hang`` until cancelled. A cancel request is
    granted. Goals are kept in ``goals``; each goal executed and each cancel request is logged.
    """

    def __init__(self, context: object, action: str, node_name: str | None = None, *,
                 log: EventLog | None = None) -> None:
        super().__init__(context, node_name or unique_name("navigator"), log)
        self.steps = 3
        self.step_s = 0.02
        self.outcome = "succeed"
        self.outcomes: list[str] = []
        self.accept = True
        self.goals: list[Any] = []
        self.cancel_requests = 0
        self.server = ActionServer(
            self.node, NavigateToPose, action,
            execute_callback=self.execute,
            goal_callback=self.on_goal,
            cancel_callback=self.on_cancel,
        )

    def on_goal(self, goal: Any) -> GoalResponse:
        self.goals.append(goal)
        return GoalResponse.ACCEPT if self.accept else GoalResponse.REJECT

    def on_cancel(self, handle: Any) -> CancelResponse:
        self.cancel_requests += 1
        self.log.add("cancel")
        return CancelResponse.ACCEPT

    def execute(self, handle: Any) -> Any:
        goal = handle.request.pose.pose
        self.log.add("goal", pose_from_msg(goal))
        outcome = self.outcomes.pop(0) if self.outcomes else self.outcome
        for remaining in range(self.steps, 0, -1):
            if self.stopping:
                return Result(error_msg="server shut down")
            if handle.is_cancel_requested:
                handle.canceled()
                return Result(error_msg="canceled")
            if outcome != "silent":
                feedback = NavigateToPose.Feedback(distance_remaining=float(remaining))
                feedback.current_pose.pose.position.x = goal.position.x - remaining
                handle.publish_feedback(feedback)
            time.sleep(self.step_s)
        while outcome == "hang" and not handle.is_cancel_requested and not self.stopping:
            time.sleep(0.005)
        if handle.is_cancel_requested:
            handle.canceled()
            return Result(error_msg="canceled")
        if outcome == "abort":
            handle.abort()
            return Result(error_code=Result.TIMEOUT, error_msg="planner timed out")
        handle.succeed()
        return Result(error_code=Result.NONE)

    def vanish(self) -> None:
        """The navigation stack dies mid-goal: its server goes without a last word."""
        self.server.destroy()
        self.stopping = True
