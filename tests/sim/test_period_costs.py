"""The loop's tally of what its periods cost, and the line a benchmark reads."""

from __future__ import annotations

import re

from servicesim_sim.process.period_costs import SUMMARY_PREFIX, PeriodCosts


def test_the_summary_gives_the_mean_of_each_stage_per_period() -> None:
    costs = PeriodCosts()
    costs.add(started=1.0, stepped=1.002, published=1.003, ended=1.004)
    costs.add(started=2.0, stepped=2.004, published=2.005, ended=2.008)
    line = costs.summary()
    assert line.startswith(SUMMARY_PREFIX)
    figures = dict(re.findall(r"(step|publishing|whole period) ([0-9.]+) ms", line))
    assert figures == {"step": "3.000", "publishing": "1.000", "whole period": "6.000"}
    assert "2 periods" in line


def test_no_period_of_a_task_says_so_rather_than_divide_by_zero() -> None:
    assert PeriodCosts().summary() == f"{SUMMARY_PREFIX}: no period of a running task"


def test_the_clock_is_the_threads_cpu_and_moves_with_work() -> None:
    before = PeriodCosts.now()
    sum(i * i for i in range(200_000))
    assert PeriodCosts.now() > before
