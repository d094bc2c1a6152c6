"""SimWait and SimTimeout measure SIM time: the test publishes /clock itself and jumps it."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import py_trees
import pytest
from builtin_interfaces.msg import Time
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from bt_servicesim.behaviours.actions.sim_wait import SimWait
from bt_servicesim.behaviours.decorators.sim_timeout import SimTimeout
from bt_servicesim.ros.sim_clock import SimStopwatch

Status = py_trees.common.Status


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


class SimClock:
    """A /clock publisher and a use_sim_time node that follows it."""

    def __init__(self, context: object) -> None:
        self.node = Node(
            "sim_time_user", context=context,
            parameter_overrides=[Parameter("use_sim_time", value=True)],
        )
        self.simulator = Node("sim_time_clock", context=context)
        self.publisher = self.simulator.create_publisher(Clock, "/clock", 10)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.simulator)

    def jump_to(self, seconds: float, limit_s: float = 10.0) -> None:
        """Publish /clock = ``seconds`` until the node's clock reads it."""
        target = round(seconds * 1e9)
        message = Clock(clock=Time(sec=target // 10**9, nanosec=target % 10**9))
        deadline = time.monotonic() + limit_s
        while self.node.get_clock().now().nanoseconds != target:
            assert time.monotonic() < deadline, "/clock did not arrive"
            self.publisher.publish(message)
            self.executor.spin_once(timeout_sec=0.01)

    def spin_until(self, done: Callable[[], bool], limit_s: float = 5.0) -> None:
        deadline = time.monotonic() + limit_s
        while not done():
            assert time.monotonic() < deadline, "condition not reached"
            self.executor.spin_once(timeout_sec=0.01)

    def shutdown(self) -> None:
        self.executor.shutdown()


@pytest.fixture
def sim_clock(ros_context: object) -> Iterator[SimClock]:
    clock = SimClock(ros_context)
    yield clock
    clock.shutdown()


def test_sim_wait_counts_sim_seconds_not_wall_seconds(sim_clock: SimClock) -> None:
    sim_clock.jump_to(100.0)
    wait = SimWait(name="wait", seconds=3.0)
    wait.setup(node=sim_clock.node)
    started = time.monotonic()
    wait.tick_once()
    assert wait.status == Status.RUNNING
    sim_clock.jump_to(101.0)
    wait.tick_once()
    assert wait.status == Status.RUNNING
    assert "1.0/3.0" in wait.feedback_message
    sim_clock.jump_to(105.0)
    wait.tick_once()
    assert wait.status == Status.SUCCESS
    assert time.monotonic() - started < 3.0, "SimWait waited in wall time"
    assert "waited 5.0 sim s" in wait.feedback_message


def test_sim_wait_does_not_advance_before_the_clock_runs(sim_clock: SimClock) -> None:
    wait = SimWait(name="wait", seconds=0.05)
    wait.setup(node=sim_clock.node)
    deadline = time.monotonic() + 0.3
    while time.monotonic() < deadline:
        wait.tick_once()
        assert wait.status == Status.RUNNING
        sim_clock.executor.spin_once(timeout_sec=0.01)
    sim_clock.jump_to(50.0)  # the clock starts: counting starts here
    wait.tick_once()
    assert wait.status == Status.RUNNING
    sim_clock.jump_to(50.1)
    wait.tick_once()
    assert wait.status == Status.SUCCESS


def test_stopwatch_restarts_when_the_clock_jumps_back(sim_clock: SimClock) -> None:
    sim_clock.jump_to(20.0)
    stopwatch = SimStopwatch(sim_clock.node.get_clock())
    stopwatch.restart()
    sim_clock.jump_to(25.0)
    assert stopwatch.elapsed() == pytest.approx(5.0)
    sim_clock.jump_to(3.0)  # the simulator restarted
    assert stopwatch.elapsed() == 0.0
    sim_clock.jump_to(4.0)
    assert stopwatch.elapsed() == pytest.approx(1.0)


def test_sim_timeout_fails_and_stops_a_long_running_child(sim_clock: SimClock) -> None:
    sim_clock.jump_to(10.0)
    child = py_trees.behaviours.Running(name="long")
    timeout = SimTimeout(name="limit", child=child, seconds=2.0)
    timeout.setup(node=sim_clock.node)
    timeout.tick_once()
    assert (timeout.status, child.status) == (Status.RUNNING, Status.RUNNING)
    sim_clock.jump_to(11.9)
    timeout.tick_once()
    assert timeout.status == Status.RUNNING
    sim_clock.jump_to(12.5)
    timeout.tick_once()
    assert timeout.status == Status.FAILURE
    assert child.status == Status.INVALID
    assert "timed out" in timeout.feedback_message and "long" in timeout.feedback_message


def test_sim_timeout_passes_a_finished_child_through(sim_clock: SimClock) -> None:
    sim_clock.jump_to(10.0)
    for child, expected in (
        (py_trees.behaviours.Success(name="ok"), Status.SUCCESS),
        (py_trees.behaviours.Failure(name="no"), Status.FAILURE),
    ):
        timeout = SimTimeout(name=f"limit_{child.name}", child=child, seconds=2.0)
        timeout.setup(node=sim_clock.node)
        timeout.tick_once()
        assert timeout.status == expected
        assert "child finished" in timeout.feedback_message


def test_sim_timeout_interrupted_stops_its_child(sim_clock: SimClock) -> None:
    sim_clock.jump_to(10.0)
    child = py_trees.behaviours.Running(name="long")
    timeout = SimTimeout(name="limit", child=child, seconds=2.0)
    timeout.setup(node=sim_clock.node)
    timeout.tick_once()
    timeout.stop(Status.INVALID)
    assert (timeout.status, child.status) == (Status.INVALID, Status.INVALID)
    assert timeout.feedback_message == "time limit interrupted"


def test_setup_without_a_node_is_a_clear_error() -> None:
    wait = SimWait(name="wait", seconds=1.0)
    with pytest.raises(KeyError, match="needs the rclpy node"):
        wait.setup()
