"""The evaluation's failure table names how ``run`` plays each failed episode again."""

from __future__ import annotations

from typing import Any

from bt_servicesim.evaluation.report import failure_table


def row(scenario: str, seed: int | None, *, completed: bool = False) -> dict[str, Any]:
    return {"executive": "bt", "scenario": scenario, "episode_seed": seed,
            "completed": completed, "failure": "the mission tree ended with FAILURE",
            "checkpoints": [{"done": True}, {"done": False}]}


def test_failed_episodes_name_their_seeds_and_the_sets_knobs() -> None:
    table = failure_table([row("hard", 41), row("hard", 23), row("hard", 7, completed=True),
                           row("default", None)])
    hard = next(line for line in table if "| hard |" in line)
    assert "| 2 |" in hard
    assert ("`--executive bt` `--seed 23`, `--seed 41` `--sim-arg=--difficulty` "
            "`--sim-arg=hard` |") in hard
    assert "--seed 7" not in hard  # it completed
    default = next(line for line in table if "| default |" in line)
    assert default.endswith("| `--executive bt` the shipped task |")


def test_a_seed_whose_episode_left_lockstep_says_its_replay_may_differ() -> None:
    dropped = {**row("random", 5), "timing": "lockstep", "lockstep_stalls": 0,
               "lockstep_dropped": {"period": 8, "sim_time_s": 0.8}}
    in_step = {**row("random", 6), "timing": "lockstep", "lockstep_stalls": 0,
               "lockstep_dropped": None}
    free = {**row("random", 7), "timing": "free running"}
    line = next(line for line in failure_table([dropped, in_step, free])
                if "| random |" in line)
    assert ("`--seed 5` (left lockstep on the way: may differ), `--seed 6`, "
            "`--seed 7` (ran free: may differ) |") in line
