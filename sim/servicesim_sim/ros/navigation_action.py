"""The NavigateToPose action server: one goal at a time, as Nav2's bt_navigator runs them.

Design intent: a new goal preempts the running one, which ends ABORTED with a result; a goal
that cannot be executed (its frame, its numbers, off the map:
:mod:`servicesim_sim.navigation.goals`) is aborted with NavigateToPose's error code and a
sentence, never executed as something else. The engine's navigator drives; the loop calls
:meth:`NavigationAction.advance` once per I/O period for feedback and results, so a goal's
coroutine only waits for its result instead of waking every period. The goal, cancel and
result requests are counted and gated by lockstep
(:class:`~servicesim_sim.lockstep.server.CountingActionServer`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, TypeAlias

from geometry_msgs.msg import PoseStamped
from nav2_msgs.action import NavigateToPose
from rclpy.action import CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.node import Node
from rclpy.task import Future

from servicesim_sim.lockstep.server import CountingActionServer, LockstepServer
from servicesim_sim.model.engine import NavigationState, SimEngine
from servicesim_sim.navigation.goals import GoalPose, GoalRefusal, goal_in_map
from servicesim_sim.ros.publishing import EVERY_REQUEST, duration, stamp
from servicesim_sim.world.files import World

NavigationGoal: TypeAlias = ServerGoalHandle[
    NavigateToPose.Goal, NavigateToPose.Result, NavigateToPose.Feedback]
"""A NavigateToPose goal as the action server holds it."""

NAVIGATION_ACTION = "/servicebot/navigate_to_pose"
FEEDBACK_PERIOD_S = 0.5  # navigation feedback at 2 Hz sim, as often as anyone reads it


class NavigationAction:
    """The action server on ``node``, its goals followed by ``engine``'s navigator."""

    def __init__(self, *, node: Node, engine: SimEngine, world: World,
                 lockstep: LockstepServer, io_period_s: float) -> None:
        self.node = node
        self.engine = engine
        self.world = world
        self.lockstep = lockstep
        self.io_period_s = io_period_s
        self._active_goal: NavigationGoal | None = None
        self._navigations: list[_Navigation] = []
        self._server = CountingActionServer(
            node, NavigateToPose, NAVIGATION_ACTION, lockstep=lockstep,
            execute_callback=self._navigate, goal_callback=lambda _: GoalResponse.ACCEPT,
            handle_accepted_callback=self._on_goal_accepted,  # served through the gate
            cancel_callback=lambda _: CancelResponse.ACCEPT,
            goal_service_qos_profile=EVERY_REQUEST, result_service_qos_profile=EVERY_REQUEST,
            cancel_service_qos_profile=EVERY_REQUEST, callback_group=lockstep.callback_group,
        )

    def close(self) -> None:
        """Forget the goals (their coroutines are dropped with the node) and destroy the
        server (a waitable the node's destruction leaves alive)."""
        self._navigations = []
        self._server.destroy()

    def _on_goal_accepted(self, goal_handle: NavigationGoal) -> None:
        """One goal at a time, as Nav2: the new goal preempts whatever runs, at once."""
        self._active_goal = goal_handle
        for navigation in self._navigations:
            navigation.end(self._preempted(navigation))
        self._navigations.clear()
        goal_handle.execute()

    async def _navigate(self, goal_handle: NavigationGoal) -> NavigateToPose.Result:
        """Start the goal and wait for its result, which :meth:`advance` sets.

        A goal already preempted (a burst accepts several before any runs) or refused ends
        here.
        """
        if goal_handle is not self._active_goal:
            goal_handle.abort()
            return _preemption_result()
        goal = self._goal_in_map(goal_handle.request.pose)
        if isinstance(goal, GoalRefusal):
            self.node.get_logger().warning(f"navigate_to_pose: goal aborted: {goal.error_msg}")
            goal_handle.abort()
            return NavigateToPose.Result(error_code=goal.error_code, error_msg=goal.error_msg)
        navigation = _Navigation(
            handle=goal_handle, ticket=self.engine.navigate(*goal),
            started=self.engine.sim_time, feedback_due=self.engine.sim_time + self.io_period_s)
        self._navigations.append(navigation)
        return await navigation.result

    def _goal_in_map(self, stamped: Any) -> tuple[float, float, float] | GoalRefusal:
        """The goal message's pose in ``map`` (through the engine's map -> odom), or why not."""
        position, orientation = stamped.pose.position, stamped.pose.orientation
        goal = GoalPose(frame_id=stamped.header.frame_id,
                        position=(position.x, position.y, position.z),
                        orientation=(orientation.x, orientation.y, orientation.z, orientation.w))
        return goal_in_map(goal, map_extent=self.world.map.extent,
                           map_to_odom=self.engine.map_to_odom())

    def advance(self) -> bool:
        """Once per I/O period: feedback, and the result of every goal that ended; whether
        any ended."""
        ended = False
        for navigation in list(self._navigations):
            result = self._outcome(navigation)
            if result is not None:
                self._navigations.remove(navigation)
                navigation.end(result)
                ended = True
        return ended

    def _outcome(self, navigation: _Navigation) -> NavigateToPose.Result | None:
        """The goal's result if it ended (preempted, canceled, reached, failed), else None."""
        handle = navigation.handle
        if handle is not self._active_goal:
            return self._preempted(navigation)
        if handle.is_cancel_requested:
            self.engine.cancel_navigation(navigation.ticket)
            handle.canceled()
            return NavigateToPose.Result(error_msg="canceled")
        state = self.engine.navigation_state(navigation.ticket)
        if self.engine.sim_time >= navigation.feedback_due - 1e-9:
            navigation.feedback_due = self.engine.sim_time + FEEDBACK_PERIOD_S
            handle.publish_feedback(self.feedback(state, navigation.started))
            self.lockstep.answered(f"{NAVIGATION_ACTION}:feedback")
        if state.status == "succeeded":
            handle.succeed()
            return NavigateToPose.Result(error_code=NavigateToPose.Result.NONE)
        if state.status != "running":
            handle.abort()
            return NavigateToPose.Result(error_code=state.error_code, error_msg=state.error_msg)
        return None

    def _preempted(self, navigation: _Navigation) -> NavigateToPose.Result:
        """Stop the goal's navigation and abort it: a newer goal has taken over."""
        self.engine.cancel_navigation(navigation.ticket)
        navigation.handle.abort()
        return _preemption_result()

    def feedback(self, state: NavigationState, started: float) -> NavigateToPose.Feedback:
        feedback = NavigateToPose.Feedback()
        feedback.current_pose = self._pose_stamped()
        feedback.navigation_time = duration(self.engine.sim_time - started)
        feedback.estimated_time_remaining = duration(state.distance_remaining / 0.5)
        feedback.number_of_recoveries = int(state.recoveries)
        feedback.distance_remaining = float(state.distance_remaining)
        return feedback

    def _pose_stamped(self) -> PoseStamped:
        """The robot's pose as Nav2's feedback gives it: the localisation's map pose."""
        x, y, yaw = self.engine.estimated_pose() or self.engine.robot_pose()
        message = PoseStamped()
        message.header.stamp = stamp(self.engine.sim_time)
        message.header.frame_id = "map"
        message.pose.position.x, message.pose.position.y = x, y
        message.pose.orientation.z, message.pose.orientation.w = (
            math.sin(yaw / 2.0), math.cos(yaw / 2.0))
        return message


def _preemption_result() -> NavigateToPose.Result:
    return NavigateToPose.Result(error_code=NavigateToPose.Result.UNKNOWN,
                                 error_msg="preempted by a newer goal")


@dataclass
class _Navigation:
    """A NavigateToPose goal the loop follows; ``result`` completes the goal's coroutine."""

    handle: NavigationGoal
    ticket: int
    started: float
    feedback_due: float
    result: Future[NavigateToPose.Result] = field(default_factory=Future)

    def end(self, result: NavigateToPose.Result) -> None:
        """Complete the goal's coroutine with its result (its terminal state is already set)."""
        self.result.set_result(result)
