"""NavigateToPose against a real in-process action server over DDS.

The server spins in a thread of its own, as a navigation stack would; the behaviour's node is
spun from the test thread between ticks, as the executive does. Each test uses its own action
name, so a server of an earlier test that DDS still remembers cannot answer.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import py_trees
import pytest
from py_trees.blackboard import Blackboard
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from servicesim_competition.action import NavigateToPose as NavigateToPoseAction

from bt_servicesim.behaviours.actions.navigate_to_pose import NavigateToPose
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.messages import pose_from_msg

Status = py_trees.common.Status
Result = NavigateToPoseAction.Result
_names = itertools.count()


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    Blackboard.clear()
    yield
    Blackboard.clear()


class Navigator:
    """A scripted NavigateToPose server: ``steps`` feedbacks, then the scripted outcome."""

    def __init__(self, context: object, action: str) -> None:
        self.node = Node(f"navigator_{next(_names)}", context=context)
        self.steps = 3
        self.step_s = 0.02
        self.outcome = "succeed"  # or "abort", "silent"
        self.accept = True
        self.goals: list[Any] = []
        self.cancel_requests = 0
        self.stopping = False
        self.server = ActionServer(
            self.node, NavigateToPoseAction, action,
            execute_callback=self.execute,
            goal_callback=self.on_goal,
            cancel_callback=self.on_cancel,
        )
        self.executor = MultiThreadedExecutor(num_threads=3, context=context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def on_goal(self, goal: Any) -> GoalResponse:
        self.goals.append(goal)
        return GoalResponse.ACCEPT if self.accept else GoalResponse.REJECT

    def on_cancel(self, handle: Any) -> CancelResponse:
        self.cancel_requests += 1
        return CancelResponse.ACCEPT

    def execute(self, handle: Any) -> Any:
        for remaining in range(self.steps, 0, -1):
            if self.stopping:
                return Result(error_msg="server shut down")
            if handle.is_cancel_requested:
                handle.canceled()
                return Result(error_msg="canceled")
            if self.outcome != "silent":
                handle.publish_feedback(NavigateToPoseAction.Feedback(
                    distance_remaining=float(remaining)
                ))
            time.sleep(self.step_s)
        if self.outcome == "abort":
            handle.abort()
            return Result(error_code=Result.TIMEOUT, error_msg="planner timed out")
        handle.succeed()
        return Result(error_code=Result.NONE)

    def vanish(self) -> None:
        """The navigation stack dies mid-goal: its server goes without a last word."""
        self.server.destroy()
        self.stopping = True

    def shutdown(self) -> None:
        self.stopping = True
        self.executor.shutdown()
        self.thread.join(timeout=5.0)
        self.node.destroy_node()


class Client:
    """The behaviour's node and the executor the test spins between ticks."""

    def __init__(self, context: object) -> None:
        self.node = Node(f"executive_{next(_names)}", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)

    def navigate(self, action: str, **kwargs: Any) -> NavigateToPose:
        Blackboard.set("/goal", Pose2D(3.0, -1.0, 1.57))
        behaviour = NavigateToPose(name="navigate", action=action, **kwargs)
        behaviour.setup_ports(port_remappings={
            "goal": "/goal", "distance_remaining": "/remaining",
            "error_code": "/error_code", "error_msg": "/error_msg",
        })
        behaviour.setup(node=self.node)
        return behaviour

    def tick_until(
        self, behaviour: NavigateToPose, done: Callable[[], bool], limit_s: float = 10.0
    ) -> None:
        deadline = time.monotonic() + limit_s
        while True:
            behaviour.tick_once()
            if done():
                return
            assert time.monotonic() < deadline, f"stuck: {behaviour.feedback_message}"
            self.executor.spin_once(timeout_sec=0.01)

    def tick_until_done(self, behaviour: NavigateToPose, limit_s: float = 10.0) -> Status:
        self.tick_until(behaviour, lambda: behaviour.status != Status.RUNNING, limit_s)
        return behaviour.status


@pytest.fixture
def client(ros_context: object) -> Iterator[Client]:
    client = Client(ros_context)
    yield client
    client.executor.shutdown()
    client.node.destroy_node()


@pytest.fixture
def action() -> str:
    return f"/test_{next(_names)}/navigate_to_pose"


@pytest.fixture
def navigator(ros_context: object, action: str) -> Iterator[Navigator]:
    navigator = Navigator(ros_context, action)
    yield navigator
    navigator.shutdown()


def test_goal_succeeds_with_feedback_on_the_outputs(
    client: Client, navigator: Navigator, action: str
) -> None:
    navigator.steps, navigator.step_s = 20, 0.05  # feedback may race topic discovery at first
    navigate = client.navigate(action)
    seen: list[float] = []

    def record() -> bool:
        if Blackboard.exists("/remaining"):
            seen.append(Blackboard.get("/remaining"))
        return navigate.status != Status.RUNNING

    client.tick_until(navigate, record)
    assert navigate.status == Status.SUCCESS
    assert navigate.feedback_message == "navigation succeeded"
    assert Blackboard.get("/error_code") == 0
    assert any(distance > 0.0 for distance in seen)
    assert Blackboard.get("/remaining") == 0.0
    goal = navigator.goals[0].pose
    assert goal.header.frame_id == "map"
    sent = pose_from_msg(goal.pose)
    assert (sent.x, sent.y, sent.yaw) == pytest.approx((3.0, -1.0, 1.57))


def test_aborted_goal_fails_with_code_and_message(
    client: Client, navigator: Navigator, action: str
) -> None:
    navigator.outcome = "abort"
    navigate = client.navigate(action)
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert Blackboard.get("/error_code") == Result.TIMEOUT
    assert Blackboard.get("/error_msg") == "planner timed out"
    assert navigate.feedback_message == (
        f"navigation aborted: error {Result.TIMEOUT} 'planner timed out'"
    )


def test_rejected_goal_fails(client: Client, navigator: Navigator, action: str) -> None:
    navigator.accept = False
    navigate = client.navigate(action)
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message == "navigation failed: goal rejected"


def test_interrupting_cancels_the_goal(client: Client, navigator: Navigator, action: str) -> None:
    navigator.steps, navigator.step_s = 1000, 0.01
    navigate = client.navigate(action)
    client.tick_until(navigate, lambda: Blackboard.exists("/remaining"))
    assert navigate.status == Status.RUNNING
    navigate.stop(Status.INVALID)
    assert navigate.feedback_message == "navigation interrupted: goal cancelled"
    deadline = time.monotonic() + 10.0
    while navigator.cancel_requests == 0:
        assert time.monotonic() < deadline, "the server never saw a cancel request"
        client.executor.spin_once(timeout_sec=0.01)


def test_the_next_round_sends_a_new_goal(
    client: Client, navigator: Navigator, action: str
) -> None:
    navigate = client.navigate(action)
    assert client.tick_until_done(navigate) == Status.SUCCESS
    assert client.tick_until_done(navigate) == Status.SUCCESS
    assert len(navigator.goals) == 2


def test_overall_timeout_fails_and_cancels(
    client: Client, navigator: Navigator, action: str
) -> None:
    navigator.steps, navigator.step_s = 1000, 0.01
    navigate = client.navigate(action, timeout=0.3)
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message == "navigation timed out after 0.3 sim s"
    deadline = time.monotonic() + 10.0
    while navigator.cancel_requests == 0:
        assert time.monotonic() < deadline, "the server never saw a cancel request"
        client.executor.spin_once(timeout_sec=0.01)


def test_missing_server_fails_after_server_timeout(client: Client, action: str) -> None:
    navigate = client.navigate(action, server_timeout=0.3)
    navigate.tick_once()
    assert navigate.status == Status.RUNNING
    assert navigate.feedback_message == f"waiting for navigation server {action}"
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message.startswith("navigation server missing")


def test_a_silent_server_counts_as_lost(
    client: Client, navigator: Navigator, action: str
) -> None:
    navigator.outcome, navigator.steps, navigator.step_s = "silent", 1000, 0.01
    navigate = client.navigate(action, silence_timeout=0.5)
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message.startswith("navigation server lost: no feedback")


def test_a_server_that_disappears_mid_goal_counts_as_lost(
    client: Client, ros_context: object, action: str
) -> None:
    navigator = Navigator(ros_context, action)
    navigator.steps, navigator.step_s = 1000, 0.01
    navigate = client.navigate(action, silence_timeout=2.0)
    client.tick_until(navigate, lambda: Blackboard.exists("/remaining"))
    navigator.vanish()
    try:
        assert client.tick_until_done(navigate, limit_s=15.0) == Status.FAILURE
        assert navigate.feedback_message.startswith("navigation server lost")
    finally:
        navigator.shutdown()


def test_missing_goal_fails_clearly(client: Client, navigator: Navigator, action: str) -> None:
    navigate = client.navigate(action)
    Blackboard.unset("/goal")
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message.startswith("no goal to navigate to")

