"""The sim-time ticker: a call per period of /clock on either executor, periods missed are not
made up, stamps a hair short of the grid still count, and a cancelled ticker stays quiet."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import pytest
from rclpy.context import Context
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from bt_servicesim.ros.sim_ticker import SimTicker
from tests.fakes.spinning import clock_message, spin_until, wait_for_subscription


class SimClockGraph:
    """A node on sim time, spun by ``executor``, and a /clock publisher the test drives."""

    def __init__(self, context: Context, executor: Executor) -> None:
        self.node = Node("ticker_under_test", context=context, parameter_overrides=[
            Parameter("use_sim_time", Parameter.Type.BOOL, True)])
        self.clock_node = Node("ticker_clock", context=context)
        self.publisher = self.clock_node.create_publisher(Clock, "/clock", 10)
        self.executor = executor
        executor.add_node(self.node)
        self.calls: list[float] = []
        wait_for_subscription(self.publisher)

    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds / 1e9

    def record(self) -> None:
        self.calls.append(round(self.now(), 3))

    def publish(self, seconds: float, *, nanoseconds_short: int = 0) -> None:
        """Publish one /clock stamp and spin until the node's clock has it."""
        message = clock_message(seconds, nanoseconds_short=nanoseconds_short)
        self.publisher.publish(message)
        total = message.clock.sec * 10**9 + message.clock.nanosec
        spin_until(self.executor, lambda: self.node.get_clock().now().nanoseconds == total,
                   f"the clock at {seconds}", limit_s=5.0)
        for _ in range(3):  # the scheduled tick, if any
            self.executor.spin_once(timeout_sec=0.01)


EXECUTORS: dict[str, Callable[[Context], Executor]] = {
    "events": lambda context: EventsExecutor(context=context),
    "single-threaded": lambda context: SingleThreadedExecutor(context=context),
}


@pytest.fixture(params=sorted(EXECUTORS))
def graph(request: pytest.FixtureRequest, ros_context: Context) -> Iterator[SimClockGraph]:
    executor = EXECUTORS[request.param](ros_context)
    made = SimClockGraph(ros_context, executor)
    made.publish(10.0)
    yield made
    executor.shutdown()
    made.node.destroy_node()
    made.clock_node.destroy_node()


def test_one_call_per_period_even_with_stamps_a_hair_short(graph: SimClockGraph) -> None:
    SimTicker(graph.node, 0.1, graph.record)
    for step in range(1, 6):
        graph.publish(10.0 + 0.1 * step, nanoseconds_short=1)  # float stamps, rounded down
    assert graph.calls == [10.1, 10.2, 10.3, 10.4, 10.5]


def test_updates_faster_than_the_period_call_once_per_period(graph: SimClockGraph) -> None:
    SimTicker(graph.node, 0.1, graph.record)
    for step in range(1, 9):
        graph.publish(10.0 + 0.05 * step)
    assert graph.calls == [10.1, 10.2, 10.3, 10.4]


def test_missed_periods_are_skipped_not_made_up(graph: SimClockGraph) -> None:
    SimTicker(graph.node, 0.1, graph.record)
    graph.publish(10.1)
    graph.publish(10.65)  # five periods in one update
    graph.publish(10.7)
    graph.publish(10.8)
    assert graph.calls == [10.1, 10.65, 10.7, 10.8]


def test_a_cancelled_ticker_calls_no_more(graph: SimClockGraph) -> None:
    ticker = SimTicker(graph.node, 0.1, graph.record)
    graph.publish(10.1)
    ticker.cancel()
    ticker.cancel()  # idempotent
    graph.publish(10.2)
    graph.publish(10.3)
    assert graph.calls == [10.1]


def test_without_sim_time_it_ticks_on_a_timer(ros_context: Context) -> None:
    node = Node("ticker_wall_time", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    calls: list[float] = []
    SimTicker(node, 0.01, lambda: calls.append(time.monotonic()))
    deadline = time.monotonic() + 0.3
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.01)
    executor.shutdown()
    node.destroy_node()
    assert len(calls) >= 5


def test_a_period_that_is_not_positive_is_refused(graph: SimClockGraph) -> None:
    with pytest.raises(ValueError, match=r"tick period 0\.0: must be more than 0"):
        SimTicker(graph.node, 0.0, graph.record)


def test_a_node_on_sim_time_without_an_executor_is_refused(ros_context: Context) -> None:
    node = Node("ticker_alone", context=ros_context, parameter_overrides=[
        Parameter("use_sim_time", Parameter.Type.BOOL, True)])
    with pytest.raises(RuntimeError, match="add the node to an executor"):
        SimTicker(node, 0.1, lambda: None)
    node.destroy_node()
