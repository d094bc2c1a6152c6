"""Warm episodes: one simulator and one executive process play episode after episode, sparing
an evaluation a process pair's start-up for each.

Nothing leaks from one episode into the next: two different seeds played one after the other
on one warm pair give, each, the report the same seed gives played cold (a process pair of its
own), in what lockstep makes replayable (completion, checkpoint times, penalties, score); so
do the hard set's knobs followed by the shipped task with none. A
pair whose worker is killed mid-episode is replaced: its episode is failed with the reason and
the next episode is played on a new pair. Missions are short (flat out, 35 sim s): far enough
for the first two checkpoints of the tasks played (random seeds 5 and 6 pick their guest up by
29 sim s, the shipped task by 22). So the shipped task, played after the hard set's, has used
all that a knob left set would change (navigation goals: aborts; RFID: dropouts, the guest
beyond its range; the pick-up service: latency) but the drifts, which no mission of 35 or
60 sim s reaches: the shipped task's first comes at 487 sim s, 122 with the hard set's scale.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from bt_servicesim.evaluation.episodes import (
    WARM_PAIRS_DIRECTORY,
    Episode,
    descendants,
    plan_episodes,
    run_command,
    run_episodes,
)
from bt_servicesim.evaluation.settings import EvaluationSettings
from bt_servicesim.mission.report import read_report

WALL_LIMIT_S = 300.0  # a generous bound per episode on a loaded machine; not a benchmark
TIME_LIMIT_S = 35.0  # sim seconds a mission plays (see above)


def settings(out: Path, *, seed: int, episodes: int = 2,
             scenarios: tuple[str, ...] = ("random",)) -> EvaluationSettings:
    return EvaluationSettings(
        episodes=episodes, scenarios=scenarios, executives=("bt",), jobs=1, seed=seed,
        out=out, speed=0.0, episode_timeout_s=WALL_LIMIT_S, time_limit_s=TIME_LIMIT_S, docs=None,
        command_line="(test)")


def played_cold(settings: EvaluationSettings) -> list[dict[str, Any]]:
    """The rows of the episodes played cold, each a process pair of its own, as an evaluation
    plays them but for the picture of the mission, which these tests never look at (drawing it
    costs a run more CPU than its 35 sim s)."""
    return run_episodes(settings, plan_episodes(settings), command=without_picture)


def without_picture(episode: Episode, settings: EvaluationSettings) -> list[str]:
    """The episode's run command with ``--trajectory never``."""
    command = run_command(episode, settings)
    command[command.index("--trajectory") + 1] = "never"
    return command


def replayed(row: dict[str, Any]) -> tuple[Any, ...]:
    """What must replay: completion, checkpoint times, penalties, score."""
    return (row["completed"], [(c["done"], c["sim_time_s"]) for c in row["checkpoints"]],
            row["penalties"], row["score"])


@pytest.mark.long
def test_two_seeds_on_one_warm_pair_report_as_each_seed_played_cold(tmp_path: Path) -> None:
    chosen = settings(tmp_path / "warm", seed=5)
    warm = run_episodes(chosen, plan_episodes(chosen), warm=True)
    cold = played_cold(settings(tmp_path / "cold", seed=5))
    assert [row["episode_seed"] for row in warm] == [row["episode_seed"] for row in cold] == [5, 6]
    pairs = sorted(path.name for path in (chosen.out / WARM_PAIRS_DIRECTORY).iterdir())
    assert pairs == ["pair-1"], "both episodes on one pair"
    for warm_row, cold_row in zip(warm, cold, strict=True):
        assert warm_row["timing"] == cold_row["timing"] == "lockstep"
        assert warm_row["lockstep_stalls"] == 0, warm_row.get("failure")
        checkpoints = [c["done"] for c in warm_row["checkpoints"]]
        assert checkpoints[:2] == [True, True], warm_row.get("failure")
        assert replayed(warm_row) == replayed(cold_row)
        assert (Path(warm_row["out"]) / "tree_log.jsonl").is_file()
        assert (Path(warm_row["out"]) / "run.mcap").is_file()
        # an evaluation draws the picture of a mission that did not complete (35 sim s)
        assert not warm_row["completed"]
        assert (Path(warm_row["out"]) / "trajectory.png").is_file()
    assert replayed(warm[0]) != replayed(warm[1]), "two seeds, two missions"


@pytest.mark.long
def test_the_hard_knobs_do_not_outlive_their_episode(tmp_path: Path) -> None:
    """The hard set's knobs, then the shipped task with none, on one pair: as each played cold."""
    chosen = settings(tmp_path / "warm", seed=7, episodes=1, scenarios=("hard", "default"))
    warm = run_episodes(chosen, plan_episodes(chosen), warm=True)
    cold = played_cold(settings(tmp_path / "cold", seed=7, episodes=1,
                                scenarios=("hard", "default")))
    assert [row["scenario"] for row in warm] == ["hard", "default"]
    assert [row["episode_seed"] for row in warm] == [7, None]
    for warm_row, cold_row in zip(warm, cold, strict=True):
        assert warm_row["timing"] == cold_row["timing"] == "lockstep"
        assert replayed(warm_row) == replayed(cold_row)
    shipped = [c["done"] for c in warm[1]["checkpoints"]]
    assert shipped[:2] == [True, True], "the shipped task got past its pick-up (slow services)"
    pairs = sorted(path.name for path in (chosen.out / WARM_PAIRS_DIRECTORY).iterdir())
    assert pairs == ["pair-1"]


@pytest.mark.long
def test_a_worker_killed_mid_episode_fails_that_episode_and_is_replaced(tmp_path: Path) -> None:
    chosen = settings(tmp_path / "warm", seed=3)
    first = chosen.out / "bt" / "random" / "0"
    killed: list[int] = []
    killer = threading.Thread(target=kill_the_worker_once_under_way, args=(first, killed))
    killer.start()
    rows = run_episodes(chosen, plan_episodes(chosen), warm=True)
    killer.join()
    assert killed, "the worker was found and killed"
    assert not rows[0]["completed"] and not rows[0]["not_run"]
    assert "killed by SIGKILL" in rows[0]["failure"], rows[0]["failure"]
    assert "replaced" in rows[0]["failure"]
    assert "pair" not in (rows[1]["failure"] or ""), rows[1]["failure"]
    report = read_report(Path(rows[1]["out"]) / "report.json")
    assert report is not None and report["status"] in ("completed", "failed")
    assert report["timing"] == "lockstep"
    pairs = sorted(path.name for path in (chosen.out / WARM_PAIRS_DIRECTORY).iterdir())
    assert pairs == ["pair-1", "pair-2"]
    gone = time.monotonic() + 30.0
    while any(Path(f"/proc/{pid}").exists() for pid in killed[1:]) and time.monotonic() < gone:
        time.sleep(0.1)
    assert not [pid for pid in killed[1:] if _alive(pid)], "the dead worker's simulator stops"


def kill_the_worker_once_under_way(episode: Path, killed: list[int]) -> None:
    """SIGKILL the warm worker once the episode's tree ticks; note its pid and its children."""
    deadline = time.monotonic() + WALL_LIMIT_S
    while time.monotonic() < deadline:
        log = episode / "tree_log.jsonl"
        if log.is_file() and log.stat().st_size > 0:
            break
        time.sleep(0.05)
    for pid in descendants(os.getpid()):
        if "bt_servicesim.warm_worker" in _command(pid):
            killed += [pid, *descendants(pid)]
            os.kill(pid, signal.SIGKILL)
            return


def _command(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")
