"""Navigation as a behaviour: one NavigateToPose goal per round of activity, never blocking.

:class:`NavigateToPose` is an action-client leaf in the style of py_trees_ros's action
clients. ``initialise`` sends the goal (or starts waiting, RUNNING, for a server that is not up
yet); ``update`` only polls the goal-handle and result futures and copies the latest feedback
to the output ports; ``terminate`` cancels a goal that is still active, without waiting for the
server's reply, whether the behaviour was interrupted by a higher priority or gave up itself.

Only ``STATUS_SUCCEEDED`` is success. A rejected, aborted or cancelled goal is a FAILURE that
carries Nav2's ``error_code`` and ``error_msg``. Because a navigation server can die mid-goal
(and an rclpy future then simply never completes), the behaviour watches the server too: if
nothing (acceptance, feedback, result) has arrived for :data:`SERVER_CHECK_AFTER_S` and
``server_is_ready()`` is false, or nothing has arrived for ``silence_timeout`` sim seconds, it
fails with "navigation server lost". All times are sim time;
the silence allowed is generous because an executive that falls behind a fast simulator
sees sim time jump before it has read the feedback that came with it.
"""

from typing import Any

from action_msgs.msg import GoalStatus
from nav2_msgs.action import NavigateToPose as NavigateToPoseAction
from py_trees.ports import NoDataAvailable, PortInformation
from rclpy.node import Node
from rclpy.task import Future

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.messages import pose_to_msg
from bt_servicesim.ros.navigate_to_pose import (
    NavigationClient,
    NavigationGoalHandle,
    NavigationResult,
)
from bt_servicesim.ros.node import shared_action_client
from bt_servicesim.ros.sim_clock import SimStopwatch, node_from_setup_kwargs

__all__ = ["SERVER_CHECK_AFTER_S", "NavigateToPose"]

SERVER_CHECK_AFTER_S = 1.0
"""Sim seconds without word from the server (acceptance, feedback, result) after which a tick
looks whether it is still on the ROS graph. While feedback comes (Nav2's and the simulator's
several times a sim second) the server plainly is, and looking at the graph costs tens of
microseconds, too much for every tick."""

_STATUS_NAMES = {
    GoalStatus.STATUS_ABORTED: "aborted",
    GoalStatus.STATUS_CANCELED: "canceled",
    GoalStatus.STATUS_UNKNOWN: "unknown",
}



class NavigateToPose(ActionNode):
    """Drive to the pose on the ``goal`` port (map frame) with a NavigateToPose action.

    Args:
        name: the behaviour's name
        action: the action name
        server_timeout: sim seconds to wait for the server to appear
        silence_timeout: sim seconds of silence (no acceptance, feedback or result) tolerated
            from the server mid-goal
        timeout: sim seconds the whole navigation may take; 0 means no limit
        frame_id: the frame of the goal pose
    """

    INPUT_PORTS: Ports = {"goal": PortInformation(data_type=Pose2D, required=True)}
    OUTPUT_PORTS: Ports = {
        "distance_remaining": PortInformation(data_type=float, required=False),
        "error_code": PortInformation(data_type=int, required=False),
        "error_msg": PortInformation(data_type=str, required=False),
    }

    def __init__(
        self,
        name: str,
        action: str = "/servicebot/navigate_to_pose",
        server_timeout: float = 5.0,
        silence_timeout: float = 30.0,
        timeout: float = 0.0,
        frame_id: str = "map",
        **kwargs: Any,
    ) -> None:
        super().__init__(name=name, **kwargs)
        self.action = action
        self.server_timeout = float(server_timeout)
        self.silence_timeout = float(silence_timeout)
        self.timeout = float(timeout)
        self.frame_id = frame_id
        self.node: Node | None = None
        self.client: NavigationClient | None = None
        self._goal: Pose2D | None = None
        self._error: str | None = None
        self._goal_future: Future[NavigationGoalHandle] | None = None
        self._result_future: Future[NavigationResult] | None = None
        self._goal_handle: NavigationGoalHandle | None = None
        self._feedback: Any = None
        self._generation = 0
        self._overall: SimStopwatch | None = None
        self._silence: SimStopwatch | None = None

    # ---------------------------------------------------------------- lifecycle
    def setup(self, **kwargs: Any) -> None:
        """Create the action client on ``kwargs["node"]``."""
        self.node = node_from_setup_kwargs(self.name, kwargs)
        self.client = shared_action_client(self.node, NavigateToPoseAction, self.action)
        self._overall = SimStopwatch(self.node.get_clock())
        self._silence = SimStopwatch(self.node.get_clock())

    def initialise(self) -> None:
        """Read the goal and send it, if the server is ready."""
        client = self._require_setup()
        self._reset()
        assert self._overall is not None and self._silence is not None
        self._overall.restart()
        self._silence.restart()
        try:
            self._goal = self.get_input("goal")
        except NoDataAvailable as error:
            self._error = f"no goal to navigate to: {error}"
            self.feedback_message = self._error
            return
        if client.server_is_ready():
            self._send()
        else:
            self.feedback_message = f"waiting for navigation server {self.action}"

    def update(self) -> Status:
        """Poll the server, the goal handle and the result."""
        if self._error is not None:
            self.feedback_message = self._error
            return Status.FAILURE
        if self._goal_future is None:
            return self._wait_for_server()
        self._write_feedback()
        assert self._overall is not None
        if self.timeout > 0.0 and self._overall.elapsed() > self.timeout:
            self.feedback_message = f"navigation timed out after {self.timeout:.1f} sim s"
            return Status.FAILURE
        if self._result_future is not None and self._result_future.done():
            return self._judge_result(self._result_future)
        if self._goal_handle is None and self._goal_future.done():
            status = self._take_goal_handle(self._goal_future)
            if status is not None:
                return status
        return self._check_server()

    def terminate(self, new_status: Status) -> None:
        """Cancel a goal that is still active; do not wait for the server's reply."""
        if self._goal_future is not None and self._goal_active():
            if self._goal_handle is not None:
                self._goal_handle.cancel_goal_async()
            else:
                self._goal_future.add_done_callback(_cancel_when_accepted)
            if new_status == Status.INVALID:
                self.feedback_message = "navigation interrupted: goal cancelled"
        elif new_status == Status.INVALID:
            self.feedback_message = "navigation interrupted"
        self._reset()

    # ---------------------------------------------------------------- helpers
    def _require_setup(self) -> NavigationClient:
        if self.client is None or self.node is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self.client

    def _reset(self) -> None:
        self._goal_future, self._result_future, self._goal_handle = None, None, None
        self._feedback, self._error = None, None

    def _goal_active(self) -> bool:
        return self._result_future is None or not self._result_future.done()

    def _send(self) -> None:
        client = self._require_setup()
        assert self._goal is not None and self.node is not None and self._silence is not None
        message = NavigateToPoseAction.Goal()
        message.pose.header.frame_id = self.frame_id
        message.pose.header.stamp = self.node.get_clock().now().to_msg()
        message.pose.pose = pose_to_msg(self._goal)
        self._silence.restart()
        self._generation += 1
        generation = self._generation

        def on_feedback(feedback_message: Any) -> None:
            self._on_feedback(generation, feedback_message)

        self._goal_future = client.send_goal_async(message, feedback_callback=on_feedback)
        self.feedback_message = (
            f"sent goal ({self._goal.x:.2f}, {self._goal.y:.2f}, {self._goal.yaw:.2f})"
        )

    def _on_feedback(self, generation: int, message: Any) -> None:
        # Runs in the executor; keep only the latest of the current goal, the tick copies it
        # to the ports. Feedback from a goal sent in an earlier round is ignored.
        if generation != self._generation or self._goal_future is None:
            return
        self._feedback = message.feedback
        if self._silence is not None:
            self._silence.restart()

    def _write_feedback(self) -> None:
        feedback = self._feedback
        if feedback is not None:
            self._set_output("distance_remaining", float(feedback.distance_remaining))

    def _wait_for_server(self) -> Status:
        client = self._require_setup()
        if client.server_is_ready():
            self._send()
            return Status.RUNNING
        assert self._overall is not None
        if self._overall.elapsed() >= self.server_timeout:
            self.feedback_message = (
                f"navigation server missing: {self.action} not available after "
                f"{self.server_timeout:.1f} sim s"
            )
            return Status.FAILURE
        self.feedback_message = f"waiting for navigation server {self.action}"
        return Status.RUNNING

    def _take_goal_handle(self, future: Future[NavigationGoalHandle]) -> Status | None:
        handle = None if future.exception() is not None else future.result()
        if handle is None or not handle.accepted:
            self._record_error(-1, "goal rejected by the navigation server")
            self.feedback_message = "navigation failed: goal rejected"
            return Status.FAILURE
        assert self._silence is not None
        self._goal_handle = handle
        self._silence.restart()
        self._result_future = handle.get_result_async()
        self.feedback_message = "goal accepted, navigating"
        return None

    def _check_server(self) -> Status:
        client = self._require_setup()
        assert self._silence is not None
        silence = self._silence.elapsed()
        if silence > self.silence_timeout or (silence > SERVER_CHECK_AFTER_S
                                              and not client.server_is_ready()):
            self.feedback_message = (
                f"navigation server lost: no feedback or result for {silence:.1f} sim s"
                if silence > self.silence_timeout
                else "navigation server lost: server no longer available"
            )
            return Status.FAILURE
        if self._goal_handle is None:
            self.feedback_message = "waiting for the goal to be accepted"
        elif self._feedback is not None:
            remaining = self._feedback.distance_remaining
            self.feedback_message = f"navigating: {remaining:.2f} m remaining"
        return Status.RUNNING

    def _judge_result(self, future: Future[NavigationResult]) -> Status:
        wrapped = None if future.exception() is not None else future.result()
        if wrapped is None:
            self._record_error(-1, "no result from the navigation server")
            self.feedback_message = "navigation failed: no result"
            return Status.FAILURE
        code, text = int(wrapped.result.error_code), str(wrapped.result.error_msg)
        self._record_error(code, text)
        if wrapped.status == GoalStatus.STATUS_SUCCEEDED:
            self.feedback_message = "navigation succeeded"
            self._set_output("distance_remaining", 0.0)
            return Status.SUCCESS
        outcome = _STATUS_NAMES.get(wrapped.status, f"status {wrapped.status}")
        self.feedback_message = f"navigation {outcome}: error {code} '{text}'"
        return Status.FAILURE

    def _record_error(self, code: int, text: str) -> None:
        self._set_output("error_code", code)
        self._set_output("error_msg", text)


def _cancel_when_accepted(future: Future[NavigationGoalHandle]) -> None:
    """Cancel a goal whose acceptance arrives after the behaviour was stopped."""
    if future.cancelled() or future.exception() is not None:
        return
    handle = future.result()
    if handle is not None and handle.accepted:
        handle.cancel_goal_async()
