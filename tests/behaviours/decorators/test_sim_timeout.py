"""SimTimeout: a time limit in sim seconds on its child, with a /clock the test publishes."""

from __future__ import annotations

import py_trees

from bt_servicesim.behaviours.decorators.sim_timeout import SimTimeout
from tests.fakes.graphs import SimTimeGraph

Status = py_trees.common.Status


def test_sim_timeout_fails_and_stops_a_long_running_child(sim_clock: SimTimeGraph) -> None:
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


def test_sim_timeout_passes_a_finished_child_through(sim_clock: SimTimeGraph) -> None:
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


def test_sim_timeout_interrupted_stops_its_child(sim_clock: SimTimeGraph) -> None:
    sim_clock.jump_to(10.0)
    child = py_trees.behaviours.Running(name="long")
    timeout = SimTimeout(name="limit", child=child, seconds=2.0)
    timeout.setup(node=sim_clock.node)
    timeout.tick_once()
    timeout.stop(Status.INVALID)
    assert (timeout.status, child.status) == (Status.INVALID, Status.INVALID)
    assert timeout.feedback_message == "time limit interrupted"
