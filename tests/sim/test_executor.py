"""The simulator's executor: waits really wait, requests and shutdown wake them, and what the
loop or a callback makes runnable runs in the same drain."""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator

import pytest
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import Empty

from servicesim_sim.process.executor import DrainingExecutor


class ParkedCoroutine:
    """A coroutine task awaiting a future only the test completes; counts its resumptions."""

    def __init__(self, executor: DrainingExecutor) -> None:
        self.future: Future = Future()
        self.resumed = 0
        self.finished = False
        executor.create_task(self._run)

    async def _run(self) -> None:
        while not self.future.done():
            self.resumed += 1
            await _OneStep()
        self.finished = True


class _OneStep:
    """Yields to the executor once, as awaiting an unfinished rclpy future does each time."""

    def __await__(self) -> Iterator[None]:
        yield


@pytest.fixture
def sim_side(ros_context: Context) -> Iterator[tuple[Node, DrainingExecutor]]:
    node = Node("executor_under_test", context=ros_context)
    executor = DrainingExecutor(context=ros_context)
    executor.add_node(node)
    yield node, executor
    executor.shutdown()
    node.destroy_node()


def test_a_parked_coroutine_does_not_turn_a_wait_into_a_busy_loop(
        sim_side: tuple[Node, DrainingExecutor]) -> None:
    _, executor = sim_side
    coroutine = ParkedCoroutine(executor)
    executor.run_ready()  # the new task's first pass
    resumed_before = coroutine.resumed
    started = time.monotonic()
    executor.wait_and_run(timeout_sec=0.3)
    assert time.monotonic() - started >= 0.25  # it waited for the wall clock ...
    assert coroutine.resumed == resumed_before  # ... without resuming the coroutine


def test_a_completed_future_resumes_its_coroutine_only_when_the_loop_says_so(
        sim_side: tuple[Node, DrainingExecutor]) -> None:
    _, executor = sim_side
    coroutine = ParkedCoroutine(executor)
    executor.run_ready()
    coroutine.future.set_result(True)
    executor.run_ready()
    assert not coroutine.finished  # nothing told the executor: no pass
    executor.note_resumable()
    executor.run_ready()
    assert coroutine.finished


def test_a_task_created_during_a_drain_runs_in_that_drain(
        sim_side: tuple[Node, DrainingExecutor]) -> None:
    _, executor = sim_side
    ran: list[str] = []

    def first() -> None:
        ran.append("first")
        executor.create_task(lambda: ran.append("second"))

    executor.create_task(first)
    executor.run_ready()
    assert ran == ["first", "second"]


def test_a_request_wakes_the_wait_and_is_answered(
        ros_context: Context, sim_side: tuple[Node, DrainingExecutor]) -> None:
    node, executor = sim_side
    calls: list[int] = []

    def answer(request: Empty.Request, response: Empty.Response) -> Empty.Response:
        calls.append(1)
        return response

    node.create_service(Empty, "/executor_test/ping", answer)
    client_node = Node("executor_test_client", context=ros_context)
    client_executor = SingleThreadedExecutor(context=ros_context)
    client_executor.add_node(client_node)
    client = client_node.create_client(Empty, "/executor_test/ping")
    assert client.wait_for_service(timeout_sec=10.0)
    executor.run_ready()  # nothing left from before: the wait below really waits
    waiter = threading.Thread(target=executor.wait_and_run, kwargs={"timeout_sec": 30.0})
    waiter.start()
    future = client.call_async(Empty.Request())
    client_executor.spin_until_future_complete(future, timeout_sec=10.0)
    waiter.join(timeout=10.0)
    assert future.done() and calls == [1]
    assert not waiter.is_alive()  # woken by the request, long before its 30 s
    client_node.destroy_node()


def test_the_context_shutting_down_ends_a_wait(
        ros_context: Context, sim_side: tuple[Node, DrainingExecutor]) -> None:
    _, executor = sim_side
    executor.run_ready()
    returned = threading.Event()

    def wait() -> None:
        # the executor then finds the context shut down and raises: the loop's way out
        with contextlib.suppress(Exception):
            executor.wait_and_run(timeout_sec=30.0)
        returned.set()

    waiter = threading.Thread(target=wait, daemon=True)
    waiter.start()
    time.sleep(0.2)
    ros_context.try_shutdown()
    assert returned.wait(timeout=10.0)
