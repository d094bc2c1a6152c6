"""Test-wide fixtures: ROS 2 isolation, a clean blackboard, sim-time graphs.

Every test process talks DDS on loopback only, in a ROS domain of its own, claimed as a run
claims one: parallel workers, two test runs at the same time and the runs the tests start never
see each other's nodes. This runs at import, before any test
calls ``rclpy.init``, and subprocesses started by tests (the simulator) inherit it.

The tests stop the processes they start with SIGINT, as a user's Ctrl-C would. A suite started
with the stop signals ignored (a shell's background job ignores SIGINT, ``nohup`` SIGHUP) would
hand that on to every child, which then keeps it ignored as Unix programs do: the stop would
never arrive and a simulator at full speed would outlive its test. So each test process puts the
stop signals back at their defaults first, as the run does for the simulator it starts.

Every test starts and ends with an empty py_trees blackboard. The fakes these fixtures build are
in the ``fakes`` package. Tests marked ``long`` are collected first.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from typing import TYPE_CHECKING

import pytest
from py_trees.blackboard import Blackboard

from bt_servicesim.ros.domain import DomainClaim, claim_domain
from bt_servicesim.ros.environment import apply_localhost_defaults, delete_participant

if TYPE_CHECKING:
    from tests.fakes.graphs import SensorWorld, SimTimeGraph

def _claim_test_domain() -> DomainClaim:
    """A domain for this test process, claimed as a run claims one (``ros/domain.py``), so that
    runs the tests start, and other test processes, never take it; held until the process ends.
    The pytest-xdist worker and the run's id pick where to start looking."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    index = int(worker[2:]) if worker[2:].isdigit() else 0
    run = int(os.environ.get("PYTEST_XDIST_TESTRUNUID", "0")[:8] or "0", 16) or os.getpid()
    return claim_domain(start=run + index * 37)


def _restore_stop_signals() -> None:
    """SIGINT back to Python's KeyboardInterrupt, SIGTERM and SIGHUP to their defaults, where the
    suite was started with them ignored; the children the tests start inherit the defaults."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    for number in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(number) is signal.SIG_IGN:
            signal.signal(number, signal.SIG_DFL)


_restore_stop_signals()
apply_localhost_defaults()
TEST_DOMAIN = _claim_test_domain()
os.environ["ROS_DOMAIN_ID"] = str(TEST_DOMAIN.domain_id)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Tests marked ``long`` (tens of seconds of real processes each) start first, in their
    order: pytest-xdist hands tests out in this order, so the workers end together rather than
    one playing a long test alone at the end. Only the order changes; every test runs."""
    items.sort(key=lambda item: item.get_closest_marker("long") is None)


@pytest.fixture
def ros_context() -> Iterator[object]:
    """A fresh rclpy context for one test, shut down afterwards and its participant deleted:
    a participant left to the garbage collector stays in the test process's domain, with the
    action servers of the test's simulator, for the tests after it to find."""
    import rclpy
    from rclpy.context import Context

    context = Context()
    rclpy.init(context=context)
    try:
        yield context
    finally:
        delete_participant(context)


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    """An empty blackboard before and after every test."""
    Blackboard.clear()
    yield
    Blackboard.clear()


@pytest.fixture
def sim_clock(ros_context: object) -> Iterator[SimTimeGraph]:
    """A node on sim time ("executive") and a simulator publishing /clock, spun by the test."""
    from tests.fakes.graphs import SimTimeGraph

    graph = SimTimeGraph(ros_context)
    yield graph
    graph.shutdown()


@pytest.fixture
def world(ros_context: object) -> Iterator[SensorWorld]:
    """:func:`sim_clock` whose simulator also publishes the robot's RFID and odometry."""
    from tests.fakes.graphs import SensorWorld

    graph = SensorWorld(ros_context)
    yield graph
    graph.shutdown()
