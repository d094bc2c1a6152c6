"""SimStopwatch: elapsed sim time on a node's clock, restarted when the simulator restarts."""

from __future__ import annotations

import pytest

from bt_servicesim.ros.sim_clock import SimStopwatch
from tests.fakes.graphs import SimTimeGraph


def test_stopwatch_restarts_when_the_clock_jumps_back(sim_clock: SimTimeGraph) -> None:
    sim_clock.jump_to(20.0)
    stopwatch = SimStopwatch(sim_clock.node.get_clock())
    stopwatch.restart()
    sim_clock.jump_to(25.0)
    assert stopwatch.elapsed() == pytest.approx(5.0)
    sim_clock.jump_to(3.0)  # the simulator restarted
    assert stopwatch.elapsed() == 0.0
    sim_clock.jump_to(4.0)
    assert stopwatch.elapsed() == pytest.approx(1.0)
