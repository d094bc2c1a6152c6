"""SimWait: sim seconds on a use_sim_time node, with a /clock the test publishes and jumps."""

from __future__ import annotations

import time

import py_trees
import pytest

from bt_servicesim.behaviours.actions.sim_wait import SimWait
from tests.fakes.graphs import SimTimeGraph

Status = py_trees.common.Status


def test_sim_wait_counts_sim_seconds_not_wall_seconds(sim_clock: SimTimeGraph) -> None:
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


def test_sim_wait_does_not_advance_before_the_clock_runs(sim_clock: SimTimeGraph) -> None:
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


def test_setup_without_a_node_is_a_clear_error() -> None:
    wait = SimWait(name="wait", seconds=1.0)
    with pytest.raises(KeyError, match="needs the rclpy node"):
        wait.setup()
