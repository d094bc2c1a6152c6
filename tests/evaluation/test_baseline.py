"""The seed's state machine against fake referee and navigation servers over DDS.

The fake simulator serves the competition's services and a NavigateToPose action from a thread
of its own; the test publishes ``/clock`` and spins the baseline's node between clock steps, so
the baseline runs on sim time exactly as in a run. Each test prefixes every name with a
namespace of its own, so that servers of earlier tests that DDS still remembers cannot answer.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import py_trees
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from bt_servicesim.evaluation.baseline import CLEAR_SERVER_WAIT_S, SEED_STATES, SeedStateMachine
from bt_servicesim.mission.settings import RunSettings
from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.run import executive_factory
from bt_servicesim.tree.loading import MissionTreeError
from tests.fakes.referee import Task
from tests.fakes.simulator import FakeSimulator
from tests.fakes.spinning import clock_message, unique_name

Status = py_trees.common.Status

ROOMS = {"PickUp": Box(-1.5, 0.0, 1.5, 3.0),  # centre (0.0, 1.5)
         "DropOff": Box(4.0, 10.0, 6.0, 11.0)}  # centre (5.0, 10.5)
START = (10.975, 3.75, math.pi)
TASK = Task(pick_up="PickUp", drop_off="DropOff", start=Pose2D(*START))


class Driver:
    """The baseline on a sim-time node; the test steps the clock and spins between steps."""

    STEP_S = 0.05
    HOLD_LIMIT_S = 10.0

    def __init__(self, context: object, namespace: str, **kwargs: Any) -> None:
        self.node = Node(unique_name("baseline"), context=context, parameter_overrides=[
            Parameter("use_sim_time", Parameter.Type.BOOL, True)])
        self.clock = self.node.create_publisher(Clock, "/clock", 10)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.machine = SeedStateMachine(node=self.node, seed=7, namespace=namespace, **kwargs)
        self.machine.setup()
        self.sim_time = 1.0

    def step(self, simulator: FakeSimulator) -> None:
        """One clock step. The clock stays until the baseline has seen it and what the baseline
        asked has been answered (up to :data:`HOLD_LIMIT_S` wall seconds), so that the fake
        simulator logs a request at the sim time it was sent however late a loaded machine
        delivers either."""
        self.sim_time += self.STEP_S
        simulator.log.sim_time = self.sim_time
        self.clock.publish(clock_message(self.sim_time))
        deadline = time.monotonic() + self.HOLD_LIMIT_S
        now_ns = round(self.sim_time * 1e9)
        while (self.node.get_clock().now().nanoseconds < now_ns
               and time.monotonic() < deadline):
            self.executor.spin_once(timeout_sec=0.01)
        for _ in range(3):
            self.executor.spin_once(timeout_sec=0.002)
        while self.asking() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    def asking(self) -> bool:
        """Whether a request of the baseline's (a service call, a goal, a cancel) is unanswered.
        rclpy keeps them in its clients' private tables; a goal's result, pending for as long as
        the goal runs, does not count."""
        services = any(client._pending_requests for client in self.node.clients)
        goals = any(getattr(waitable, "_pending_goal_requests", None)
                    or getattr(waitable, "_pending_cancel_requests", None)
                    for waitable in self.node.waitables)
        return services or goals

    def run_until(self, simulator: FakeSimulator, done: Callable[[], bool],
                  sim_limit_s: float = 120.0) -> None:
        while self.sim_time < 1.5:  # let the clock arrive before the machine starts
            self.step(simulator)
        self.machine.start()
        while not done():
            assert self.sim_time < sim_limit_s, f"stuck in {self.machine.phase()}: " \
                                                f"{self.machine.activity()}"
            self.step(simulator)

    def step_until(self, simulator: FakeSimulator, done: Callable[[], bool]) -> None:
        """Keep stepping for up to 5 wall seconds, for an answer that is on its way."""
        deadline = time.monotonic() + 5.0
        while not done() and time.monotonic() < deadline:
            self.step(simulator)

    def shutdown(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()


@pytest.fixture
def namespace() -> str:
    return f"/{unique_name('baseline_test')}"


@pytest.fixture
def simulator(ros_context: object, namespace: str) -> Iterator[FakeSimulator]:
    simulator = FakeSimulator(ros_context, namespace, task=TASK, rooms=ROOMS)
    simulator.referee.pickup_ok = simulator.referee.dropoff_ok = False  # the seed moves on
    yield simulator
    simulator.shutdown()


@pytest.fixture
def driver(ros_context: object, namespace: str) -> Iterator[Driver]:
    driver = Driver(ros_context, namespace)
    yield driver
    driver.shutdown()


def finished(driver: Driver) -> Callable[[], bool]:
    return lambda: driver.machine.finished


def assert_seed_goal(goal: Pose2D, x: float, y: float) -> None:
    """Centre (or start) shifted −1 m in x, within the ±0.1 m jitter, facing −x."""
    assert goal.x == pytest.approx(x - 1.0, abs=0.1)
    assert goal.y == pytest.approx(y, abs=0.1)
    assert abs(math.cos(goal.yaw) + 1.0) < 1e-6


def test_four_states_in_order_with_failed_pickup_and_dropoff_moving_on(
    driver: Driver, simulator: FakeSimulator
) -> None:
    driver.run_until(simulator, finished(driver))
    machine = driver.machine
    assert machine.outcome == Status.SUCCESS
    assert machine.states_entered == list(SEED_STATES)
    assert [event.what for event in simulator.events if event.what != "cancel"] == [
        "new_task",
        "room_info", "clear_costmaps", "goal", "pickup_guest",
        "room_info", "clear_costmaps", "goal", "dropoff_guest",
        "clear_costmaps", "goal",
    ]
    assert simulator.named("pickup_guest")[0].detail == ("human_20843", "servicebot")
    assert machine.ignored_answers == [("pickup_guest", False), ("dropoff_guest", False)]


def test_goals_are_centre_and_start_minus_one_metre(
    driver: Driver, simulator: FakeSimulator
) -> None:
    driver.run_until(simulator, finished(driver))
    pick_up, drop_off, start = (event.detail for event in simulator.named("goal"))
    assert_seed_goal(pick_up, 0.0, 1.5)
    assert_seed_goal(drop_off, 5.0, 10.5)
    assert_seed_goal(start, START[0], START[1])
    assert (pick_up.x, pick_up.y) != (-1.0, 1.5), "the goal is jittered"


def test_each_attempt_clears_costmaps_then_waits_half_a_second(
    driver: Driver, simulator: FakeSimulator
) -> None:
    simulator.navigator.outcomes = ["abort", "abort", "succeed"]
    driver.run_until(simulator, lambda: len(simulator.named("pickup_guest")) == 1)
    clears, goals = simulator.named("clear_costmaps"), simulator.named("goal")
    assert len(goals) == 3 and len(clears) == 3
    for clear, goal in zip(clears, goals, strict=True):
        assert goal.sim_time - clear.sim_time >= 0.5 - 1e-6
    gaps = [later.sim_time - earlier.sim_time for earlier, later in itertools.pairwise(clears)]
    # a request reaches the fake simulator in the step it was sent, or the next (Driver.step)
    jitter = Driver.STEP_S + 1e-6
    assert all(gap >= 1.0 - jitter for gap in gaps), f"attempts faster than 1 Hz: {gaps}"


def test_without_move_bases_clearing_service_goals_are_still_sent(
    ros_context: object, namespace: str
) -> None:
    """A Nav2 robot has no move_base clear_costmaps: the first attempt waits for it a bounded
    time, then sends its goal; later attempts do not wait for it again."""
    simulator = FakeSimulator(ros_context, namespace, task=TASK, rooms=ROOMS,
                              move_base_clearing=False)
    simulator.navigator.outcomes = ["abort", "succeed"]
    driver = Driver(ros_context, namespace)
    try:
        driver.run_until(simulator, lambda: len(simulator.named("pickup_guest")) == 1)
        first, second = simulator.named("goal")[:2]
        asked_for_the_room = simulator.named("room_info")[0].sim_time
        assert not simulator.named("clear_costmaps")
        assert first.sim_time - asked_for_the_room >= CLEAR_SERVER_WAIT_S
        assert second.sim_time - first.sim_time < CLEAR_SERVER_WAIT_S
    finally:
        driver.shutdown()
        simulator.shutdown()


def test_a_goal_without_result_is_cancelled_and_resent_after_ten_seconds(
    driver: Driver, simulator: FakeSimulator
) -> None:
    simulator.navigator.outcomes = ["hang", "succeed"]
    driver.run_until(simulator, lambda: len(simulator.named("pickup_guest")) == 1)
    first, second = simulator.named("goal")[:2]
    sent = simulator.named("clear_costmaps")[0].sim_time + 0.5  # the server logs goals late
    assert second.sim_time - first.sim_time >= 10.0
    cancels = simulator.named("cancel")
    assert cancels and sent + 10.0 <= cancels[0].sim_time <= second.sim_time


def test_interrupt_cancels_the_goal_in_flight(driver: Driver, simulator: FakeSimulator) -> None:
    simulator.navigator.outcomes = ["hang"]
    driver.run_until(simulator, lambda: len(simulator.named("goal")) == 1)
    driver.machine.interrupt()
    driver.step_until(simulator, lambda: bool(simulator.named("cancel")))
    assert len(simulator.named("cancel")) == 1
    assert driver.machine.phase() == "Pickup"
    assert not simulator.named("pickup_guest")


def test_refused_task_fails(driver: Driver, simulator: FakeSimulator) -> None:
    simulator.referee.task_running = True  # the error answer
    driver.run_until(simulator, finished(driver))
    assert driver.machine.outcome == Status.FAILURE
    assert driver.machine.states_entered == ["BeginTask"]
    assert "new_task" in driver.machine.activity()


def test_time_limit_ends_the_run_with_failure(ros_context: object, namespace: str,
                                              simulator: FakeSimulator) -> None:
    simulator.navigator.outcomes = ["hang"] * 10
    driver = Driver(ros_context, namespace, time_limit_s=15.0)
    try:
        driver.run_until(simulator, finished(driver))
        assert driver.machine.outcome == Status.FAILURE
        assert "time limit" in driver.machine.activity()
        assert 15.0 < driver.sim_time - 1.5 < 16.0
        driver.step_until(simulator, lambda: bool(simulator.named("cancel")))
        assert simulator.named("cancel"), "the goal in flight is cancelled"
    finally:
        driver.shutdown()



def test_the_run_command_makes_the_baseline_without_a_tree_file(ros_context: object,
                                                                tmp_path: Path) -> None:
    settings = RunSettings(world=None, seed=3, speed=0.0, tree=tmp_path / "no_such_tree.xml",
                           out=tmp_path, time_limit_s=123.0, headless=True,
                           executive="baseline")
    node = Node(unique_name("factory"), context=ros_context)
    try:
        machine = executive_factory(settings)(node)
        assert isinstance(machine, SeedStateMachine)
        assert machine.time_limit_s == 123.0 and machine.node is node
    finally:
        node.destroy_node()


def test_the_run_command_still_checks_the_tree_file_of_the_tree(tmp_path: Path) -> None:
    settings = RunSettings(world=None, seed=None, speed=0.0, tree=tmp_path / "missing.xml",
                           out=tmp_path, time_limit_s=900.0, headless=True, executive="bt")
    with pytest.raises(MissionTreeError, match=r"missing\.xml"):
        executive_factory(settings)
