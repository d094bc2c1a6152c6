"""NavigateToPose against a real in-process action server over DDS.

The server spins in a thread of its own, as a navigation stack would; the behaviour's node is
spun from the test thread between ticks, as the executive does. Each test uses its own action
name, so a server of an earlier test that DDS still remembers cannot answer.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import py_trees
import pytest
from nav2_msgs.action import NavigateToPose as NavigateToPoseAction
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.actions.navigate_to_pose import NavigateToPose
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.messages import pose_from_msg
from tests.fakes.graphs import ExecutiveGraph
from tests.fakes.leaves import ready
from tests.fakes.navigator import FakeNavigator
from tests.fakes.servers import ServerThread
from tests.fakes.spinning import unique_name

Status = py_trees.common.Status
Result = NavigateToPoseAction.Result


class Client(ExecutiveGraph):
    """The behaviour's node and the executor the test spins between ticks."""

    def navigate(self, action: str, **kwargs: Any) -> NavigateToPose:
        Blackboard.set("/goal", Pose2D(3.0, -1.0, 1.57))
        return ready(NavigateToPose(name="navigate", action=action, **kwargs), self.node,
                     goal="/goal", distance_remaining="/remaining",
                     error_code="/error_code", error_msg="/error_msg")


@pytest.fixture
def client(ros_context: object) -> Iterator[Client]:
    client = Client(ros_context, unique_name("executive"))
    yield client
    client.shutdown()


@pytest.fixture
def action() -> str:
    return f"/{unique_name('test')}/navigate_to_pose"


@pytest.fixture
def navigator(ros_context: object, action: str) -> Iterator[FakeNavigator]:
    navigator = FakeNavigator(ros_context, action)
    server = ServerThread(ros_context, navigator, threads=3)
    yield navigator
    server.shutdown()


def test_goal_succeeds_with_feedback_on_the_outputs(
    client: Client, navigator: FakeNavigator, action: str
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
    client: Client, navigator: FakeNavigator, action: str
) -> None:
    navigator.outcome = "abort"
    navigate = client.navigate(action)
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert Blackboard.get("/error_code") == Result.TIMEOUT
    assert Blackboard.get("/error_msg") == "planner timed out"
    assert navigate.feedback_message == (
        f"navigation aborted: error {Result.TIMEOUT} 'planner timed out'"
    )


def test_rejected_goal_fails(client: Client, navigator: FakeNavigator, action: str) -> None:
    navigator.accept = False
    navigate = client.navigate(action)
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message == "navigation failed: goal rejected"


def test_interrupting_cancels_the_goal(
    client: Client, navigator: FakeNavigator, action: str
) -> None:
    navigator.steps, navigator.step_s = 1000, 0.01
    navigate = client.navigate(action)
    client.tick_until(navigate, lambda: Blackboard.exists("/remaining"))
    assert navigate.status == Status.RUNNING
    navigate.stop(Status.INVALID)
    assert navigate.feedback_message == "navigation interrupted: goal cancelled"
    client.spin_until(lambda: navigator.cancel_requests > 0, "a cancel request at the server")


def test_the_next_round_sends_a_new_goal(
    client: Client, navigator: FakeNavigator, action: str
) -> None:
    navigate = client.navigate(action)
    assert client.tick_until_done(navigate) == Status.SUCCESS
    assert client.tick_until_done(navigate) == Status.SUCCESS
    assert len(navigator.goals) == 2


def test_overall_timeout_fails_and_cancels(
    client: Client, navigator: FakeNavigator, action: str
) -> None:
    navigator.steps, navigator.step_s = 1000, 0.01
    navigate = client.navigate(action, timeout=0.3)
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message == "navigation timed out after 0.3 sim s"
    client.spin_until(lambda: navigator.cancel_requests > 0, "a cancel request at the server")


def test_missing_server_fails_after_server_timeout(client: Client, action: str) -> None:
    navigate = client.navigate(action, server_timeout=0.3)
    navigate.tick_once()
    assert navigate.status == Status.RUNNING
    assert navigate.feedback_message == f"waiting for navigation server {action}"
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message.startswith("navigation server missing")


def test_a_silent_server_counts_as_lost(
    client: Client, navigator: FakeNavigator, action: str
) -> None:
    navigator.outcome, navigator.steps, navigator.step_s = "silent", 1000, 0.01
    navigate = client.navigate(action, silence_timeout=0.5)
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message.startswith("navigation server lost: no feedback")


def test_a_server_that_disappears_mid_goal_counts_as_lost(
    client: Client, ros_context: object, action: str
) -> None:
    navigator = FakeNavigator(ros_context, action)
    server = ServerThread(ros_context, navigator, threads=3)
    navigator.steps, navigator.step_s = 1000, 0.01
    navigate = client.navigate(action, silence_timeout=2.0)
    client.tick_until(navigate, lambda: Blackboard.exists("/remaining"))
    server.between_turns(navigator.vanish)
    try:
        assert client.tick_until_done(navigate, limit_s=15.0) == Status.FAILURE
        assert navigate.feedback_message.startswith("navigation server lost")
    finally:
        server.shutdown()


def test_missing_goal_fails_clearly(client: Client, navigator: FakeNavigator, action: str) -> None:
    navigate = client.navigate(action)
    Blackboard.unset("/goal")
    assert client.tick_until_done(navigate) == Status.FAILURE
    assert navigate.feedback_message.startswith("no goal to navigate to")

