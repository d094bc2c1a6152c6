"""The evaluation's uncertainty figures: the success rate's Wilson interval and the exact
binomial tests of paired comparisons (sign test, McNemar's), checked against values worked
out by hand and against scipy's ``binomtest`` over every sample of up to 40 episodes."""

from __future__ import annotations

from typing import Any

import pytest

from bt_servicesim.evaluation.summary import (
    completed_by_one,
    distinct_missions,
    exact_binomial_p,
    sign_test,
    success_interval,
    summarise,
)


def test_the_wilson_interval_of_15_of_16_and_of_none_and_all() -> None:
    # p = 15/16, z = 1.96: centre (p + z²/2n) / (1 + z²/n),
    # half-width z·sqrt(p(1-p)/n + z²/4n²) / (1 + z²/n)
    low, high = success_interval(15, 16)
    assert (low, high) == (pytest.approx(0.7167, abs=1e-4), pytest.approx(0.9889, abs=1e-4))
    assert success_interval(0, 16) == (pytest.approx(0.0, abs=1e-12),
                                       pytest.approx(0.1936, abs=1e-4))
    assert success_interval(16, 16)[1] == pytest.approx(1.0)
    assert success_interval(0, 0) is None


def test_the_summary_carries_the_interval_of_the_missions_played() -> None:
    rows = [{"episode_seed": 1, "completed": True, "score": 1.0, "sim_time_s": 2.0,
             "penalties": {}},
            {"episode_seed": 2, "completed": False, "score": 0.0, "sim_time_s": 9.0,
             "penalties": {}},
            {"episode_seed": 3, "completed": False, "not_run": True}]
    assert summarise(rows)["success_interval"] == [pytest.approx(0.0945, abs=1e-4),
                                                   pytest.approx(0.9055, abs=1e-4)]
    assert summarise([])["success_interval"] is None


@pytest.mark.parametrize(("wins", "losses", "p_value"), [
    (4, 0, 0.125),   # 2 · (1/2)^4
    (3, 1, 0.625),   # 2 · (1 + 4) / 16
    (8, 8, 1.0),
    (10, 0, 2 / 1024),
])
def test_the_exact_binomial_test_at_one_half(wins: int, losses: int, p_value: float) -> None:
    assert exact_binomial_p(wins, losses) == pytest.approx(p_value)
    assert exact_binomial_p(losses, wins) == pytest.approx(p_value)  # two-sided


def test_nothing_to_compare_has_no_p_value() -> None:
    assert exact_binomial_p(0, 0) is None
    assert sign_test([], []) is None
    assert sign_test([1.0, 2.0], [1.0, 2.0]) is None  # ties only


def test_the_sign_test_leaves_ties_out() -> None:
    first, second = [1.0, 2.0, 3.0, 4.0, 5.0], [2.0, 3.0, 4.0, 5.0, 5.0]
    assert sign_test(first, second) == pytest.approx(0.125)  # 4 below, 0 above, 1 tie


def row(executive: str, episode: int, completed: bool, **extra: Any) -> dict[str, Any]:
    return {"executive": executive, "episode": episode, "episode_seed": episode,
            "scenario": "random", "completed": completed, **extra}


def test_completed_by_one_counts_only_episodes_both_played() -> None:
    rows = [row("bt", 0, True), row("baseline", 0, False),     # bt only
            row("bt", 1, True), row("baseline", 1, True),      # both
            row("bt", 2, False), row("baseline", 2, True),     # baseline only
            row("bt", 3, True), row("baseline", 3, False),     # bt only
            row("bt", 4, True),                                 # baseline never played it
            row("bt", 5, True), row("baseline", 5, False, not_run=True),  # stopped: not played
            {**row("bt", 6, True), "scenario": "hard"}, row("baseline", 6, False)]
    assert completed_by_one(rows, "random", "bt", "baseline") == (2, 1)
    assert completed_by_one(rows, "random", "baseline", "bt") == (1, 2)


def test_replays_of_one_task_are_one_mission() -> None:
    """Every episode of the default set plays the shipped task (no seed): in lockstep, one
    mission replayed, so one observation, whatever the episode count."""
    shipped = [{"executive": "bt", "scenario": "default", "episode": n, "episode_seed": None,
                "completed": True, "score": 5.0, "sim_time_s": 9.0, "penalties": {}}
               for n in range(16)]
    assert distinct_missions(shipped) == shipped[:1]
    summary = summarise(shipped)
    assert summary["episodes"] == 16 and summary["success_rate"] == 1.0
    assert summary["success_interval"] == [pytest.approx(0.2065, abs=1e-4), 1.0]  # 1 of 1
    other = [{**shipped[0], "executive": "baseline", "completed": False}]
    assert completed_by_one(shipped + other, "default", "bt", "baseline") == (1, 0)


def test_distinct_missions_keeps_the_first_played_row_of_each_seed() -> None:
    rows = [row("bt", 0, False, not_run=True), row("bt", 1, True), row("bt", 2, False),
            {**row("bt", 3, True), "episode_seed": 1}, row("baseline", 1, False)]
    assert distinct_missions(rows) == [rows[1], rows[2], rows[4]]


def test_both_agree_with_scipys_binomial_test_over_every_small_sample() -> None:
    from scipy.stats import binomtest

    for episodes in range(1, 41):
        for successes in range(episodes + 1):
            low, high = binomtest(successes, episodes).proportion_ci(confidence_level=0.95,
                                                                     method="wilson")
            assert success_interval(successes, episodes) == (
                pytest.approx(float(low), abs=1e-12), pytest.approx(float(high), abs=1e-12))
            assert exact_binomial_p(successes, episodes - successes) == pytest.approx(
                float(binomtest(successes, episodes, 0.5).pvalue), rel=1e-12)
