"""Warm pairs that misbehave are replaced: a worker that answers garbage, answers for
another run, hangs past the episode's wall-time limit or dies is stopped with its process tree
and never used again; its episode is failed with the reason and the next one plays on a new
pair. The worker here is a stand-in without ROS (``fake_warm_worker.py``), chosen by seed; the
real worker's crash is ``test_warm_episodes.py``'s.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from bt_servicesim.evaluation import warm_pairs
from bt_servicesim.evaluation.episodes import WARM_PAIRS_DIRECTORY, plan_episodes, run_episodes
from bt_servicesim.evaluation.settings import EvaluationSettings

TIMEOUT_S = 5.0


def test_misbehaving_pairs_fail_their_episode_and_are_replaced(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(warm_pairs, "WORKER_MODULE", "tests.evaluation.fake_warm_worker")
    chosen = EvaluationSettings(
        episodes=6, scenarios=("random",), executives=("bt",), jobs=1, seed=0,
        out=tmp_path / "evaluation", speed=0.0, episode_timeout_s=TIMEOUT_S,
        time_limit_s=900.0, docs=None, command_line="(test)")
    rows = run_episodes(chosen, plan_episodes(chosen), warm=True)
    by_seed = {row["episode_seed"]: row for row in rows}
    assert by_seed[0]["completed"] and by_seed[3]["completed"]
    assert by_seed[0]["failure"] is None and by_seed[3]["failure"] is None
    failures = {seed: by_seed[seed]["failure"] for seed in (1, 2, 4, 5)}
    assert "answered garbage while playing the episode" in failures[1]
    assert "this is not JSON" in failures[1]
    assert failures[2].startswith(f"episode wall-time limit of {TIMEOUT_S:g} s exceeded; stopped")
    assert "someone-else" in failures[4]
    assert "killed by SIGABRT" in failures[5]
    for seed in (1, 2, 4, 5):
        assert failures[seed].endswith("the pair was replaced"), failures[seed]
    for seed in (1, 2, 4, 5):
        assert not by_seed[seed]["completed"] and not by_seed[seed]["not_run"]
    pairs = sorted(path.name for path in (chosen.out / WARM_PAIRS_DIRECTORY).iterdir())
    # seeds 0, 1 on the first pair; 2 on the second; 3, 4 on the third; 5 on the fourth
    assert pairs == ["pair-1", "pair-2", "pair-3", "pair-4"]
