"""Batch evaluation with fake episodes: the summary's shape, stopped and crashed episodes, input.

A fake episode is a small Python process standing in for ``python -m bt_servicesim.run``: it
writes a report.json whose outcome depends on the executive and the seed, records the ROS
environment it was given, and can be told to hang or to crash.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from bt_servicesim.evaluate import evaluate
from bt_servicesim.evaluation.episodes import (
    Episode,
    EpisodeCommand,
    EpisodeOutcome,
    domain_ids,
    episode_row,
    plan_episodes,
    run_command,
    start_time,
)
from bt_servicesim.evaluation.report import PLOTS, markdown_report
from bt_servicesim.evaluation.settings import INTERRUPTED, PENALTY_KEYS, EvaluationSettings
from bt_servicesim.evaluation.summary import summarise
from tests.fakes import run_module

FAKE_EPISODE = r"""
import json, os, signal, subprocess, sys, time
out, executive, seed, scenario, mode = sys.argv[1:6]
started = time.time()
if mode == "hang":
    orphan = subprocess.Popen([sys.executable, "-c",
        "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); time.sleep(120)"],
        start_new_session=True)
    with open(os.path.join(out, "pids"), "w") as f:
        f.write(f"{os.getpid()} {orphan.pid}")
    time.sleep(120)
if mode == "crash":
    print("Traceback: something broke", file=sys.stderr)
    sys.exit(3)
time.sleep(0.3)
number = 0 if seed == "None" else int(seed)
completed = executive == "bt" or number % 2 == 0
score = (100.0 if executive == "bt" else 200.0) + number
first = 10.0 if executive == "bt" else 20.0
checkpoints = [{"name": name, "done": completed or index < 3, "sim_time_s": first + 10.0 * index}
               for index, name in enumerate(("go_to_pick_up", "pick_up_guest",
                                              "drop_off_guest", "return_to_start"))]
report = {
    "completed": completed, "score": score, "sim_time_s": score / 2,
    "checkpoints": checkpoints, "wall_time_s": 0.3, "seed": None if seed == "None" else number,
    "world": "default", "executive": executive, "exit_code": 0 if completed else 1,
    "failure": None if completed else "the mission tree ended with SUCCESS",
    "penalties": {"failed_pickup": 1 if executive == "baseline" else 0, "failed_dropoff": 0,
                  "too_fast": 0, "drifts": 0, "contact": 0.0, "approximation": 2.0},
    "environment": {key: os.environ.get(key) for key in
                    ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")},
    "interval": [started, time.time()],
}
with open(os.path.join(out, "report.json"), "w") as f:
    json.dump(report, f)
"""

SUMMARY_KEYS = {"episodes", "success_rate", "mean_score", "median_score", "mean_sim_time_s",
                "penalties", "wall_time_s", "not_run", "rows"}


def settings(tmp_path: Path, **changes: Any) -> EvaluationSettings:
    values: dict[str, Any] = dict(
        episodes=2, scenarios=("default", "random"), executives=("bt", "baseline"), jobs=2,
        seed=0, out=tmp_path / "evaluation", speed=0.0, episode_timeout_s=60.0,
        time_limit_s=900.0, docs=None, command_line="python -m bt_servicesim.evaluate (test)")
    values.update(changes)
    return EvaluationSettings(**values)


def fake(mode_for: dict[tuple[str, int | None], str] | None = None) -> EpisodeCommand:
    """The fake episode; ``mode_for[(executive, seed)]`` makes that one hang or crash."""
    def command(episode: Episode, _: EvaluationSettings) -> list[str]:
        mode = (mode_for or {}).get((episode.executive, episode.seed), "report")
        return [sys.executable, "-c", FAKE_EPISODE, str(episode.out), episode.executive,
                str(episode.seed), episode.scenario, mode]
    return command


def quietly(tmp_path: Path, chosen: EvaluationSettings,
            command: EpisodeCommand) -> list[dict[str, Any]]:
    with (tmp_path / "progress.log").open("w") as stream:
        rows, interrupted = evaluate(chosen, command=command, stream=stream)
    assert not interrupted
    return rows


def test_summary_maps_each_executive_to_its_statistics_and_rows(tmp_path: Path) -> None:
    chosen = settings(tmp_path, seed=1)
    quietly(tmp_path, chosen, fake())
    summary = json.loads((chosen.out / "summary.json").read_text())
    assert list(summary) == ["bt", "baseline"]
    for executive in ("bt", "baseline"):
        assert set(summary[executive]) == SUMMARY_KEYS
        assert summary[executive]["episodes"] == 4
        assert {row["executive"] for row in summary[executive]["rows"]} == {executive}
    bt, baseline = summary["bt"], summary["baseline"]
    # bt completes all four (default: seed None -> 100; random seeds 1, 2 -> 101, 102)
    assert bt["success_rate"] == 1.0
    assert bt["mean_score"] == pytest.approx((100 + 100 + 101 + 102) / 4)
    assert bt["median_score"] == pytest.approx(100.5)
    assert bt["mean_sim_time_s"] == pytest.approx(bt["mean_score"] / 2)
    # the baseline completes default (seed None counts as 0) twice and random seed 2 once
    assert baseline["success_rate"] == 0.75
    assert baseline["mean_score"] == pytest.approx((200 + 200 + 202) / 3)
    assert baseline["penalties"]["failed_pickup"] == 1.0
    assert baseline["penalties"]["approximation"] == 2.0
    assert set(baseline["penalties"]) == set(PENALTY_KEYS)


def test_rows_are_the_run_reports_with_their_place_in_the_evaluation(tmp_path: Path) -> None:
    chosen = settings(tmp_path, seed=5)
    rows = quietly(tmp_path, chosen, fake())
    assert len(rows) == 8
    random_rows = [row for row in rows if row["scenario"] == "random"]
    by_executive = {executive: sorted(row["episode_seed"] for row in random_rows
                                      if row["executive"] == executive)
                    for executive in ("bt", "baseline")}
    assert by_executive == {"bt": [5, 6], "baseline": [5, 6]}, "same seeds for both"
    assert all(row["episode_seed"] is None for row in rows if row["scenario"] == "default")
    for row in rows:
        assert Path(row["out"]) == chosen.out / row["executive"] / row["scenario"] / str(
            row["episode"])
        assert (Path(row["out"]) / "report.json").is_file()
        assert row["environment"]["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
        assert 1 <= int(row["environment"]["ROS_DOMAIN_ID"]) <= 101


def test_episodes_running_at_once_have_distinct_ros_domains(tmp_path: Path) -> None:
    rows = quietly(tmp_path, settings(tmp_path), fake())
    overlapping = [(a, b) for a in rows for b in rows if a is not b
                   and a["interval"][0] < b["interval"][1] and b["interval"][0] < a["interval"][1]]
    assert overlapping, "two jobs ran at once"
    for a, b in overlapping:
        assert a["environment"]["ROS_DOMAIN_ID"] != b["environment"]["ROS_DOMAIN_ID"]


def test_table_plots_and_docs_are_written(tmp_path: Path) -> None:
    chosen = settings(tmp_path, docs=tmp_path / "docs")
    quietly(tmp_path, chosen, fake())
    results = (chosen.out / "results.md").read_text()
    assert chosen.command_line in results
    assert "| bt | random | 2 | 100% |" in results
    assert "| baseline | random | 2 | 50% |" in results
    # random: both completed episode 0 (100 vs 200); both dropped off in 0 and 1 (60 vs 90 s)
    assert "| random | 1 | 100.0 | 200.0 | 1/1 | 2 | 60.0 | 90.0 | 2/2 |" in results
    assert "| baseline | random | 1 | 3/4 | the mission tree ended with SUCCESS |" in results
    for name, _ in PLOTS:
        assert (chosen.out / f"results_{name}.png").stat().st_size > 1000
        assert (tmp_path / "docs" / "images" / f"results_{name}.png").is_file()
    assert "](images/results_scores.png)" in (tmp_path / "docs" / "results.md").read_text()


def test_a_hung_episode_is_stopped_and_recorded_as_failed(tmp_path: Path) -> None:
    chosen = settings(tmp_path, episodes=1, scenarios=("random",), episode_timeout_s=1.5)
    rows = quietly(tmp_path, chosen, fake({("baseline", 0): "hang"}))
    hung = next(row for row in rows if row["executive"] == "baseline")
    assert not hung["completed"]
    assert "wall-time limit of 1.5 s exceeded" in hung["failure"]
    assert hung["returncode"] is not None
    pids = [int(pid) for pid in (Path(hung["out"]) / "pids").read_text().split()]
    assert pids and all(not alive(pid) for pid in pids), "the episode and its orphan are gone"
    assert next(row for row in rows if row["executive"] == "bt")["completed"]
    summary = json.loads((chosen.out / "summary.json").read_text())
    assert summary["baseline"]["episodes"] == 1 and summary["baseline"]["success_rate"] == 0.0


def test_a_crashed_episode_is_recorded_with_its_exit_code(tmp_path: Path) -> None:
    chosen = settings(tmp_path, episodes=1, scenarios=("random",))
    rows = quietly(tmp_path, chosen, fake({("bt", 0): "crash"}))
    crashed = next(row for row in rows if row["executive"] == "bt")
    assert not crashed["completed"] and crashed["score"] is None
    assert crashed["exit_code"] == 3
    assert "code 3" in crashed["failure"] and "something broke" in crashed["failure"]


def test_a_stale_report_never_passes_for_a_new_episode(tmp_path: Path) -> None:
    chosen = settings(tmp_path, episodes=1, scenarios=("random",), executives=("bt",))
    stale = chosen.out / "bt" / "random" / "0"
    stale.mkdir(parents=True)
    (stale / "report.json").write_text(json.dumps({"completed": True, "score": 1.0}))
    rows = quietly(tmp_path, chosen, fake({("bt", 0): "crash"}))
    assert not rows[0]["completed"]


def test_resume_keeps_finished_episodes_and_runs_the_rest(tmp_path: Path) -> None:
    first = settings(tmp_path, episodes=1, scenarios=("random",), executives=("baseline",))
    kept = quietly(tmp_path, first, fake())[0]
    both = settings(tmp_path, episodes=1, scenarios=("random",), resume=True)
    rows = quietly(tmp_path, both, fake({("baseline", 0): "crash"}))
    baseline = next(row for row in rows if row["executive"] == "baseline")
    assert baseline["resumed"] is True, "the finished baseline episode is not run again"
    assert baseline["interval"] == kept["interval"]
    bt = next(row for row in rows if row["executive"] == "bt")
    assert bt["completed"] and not bt.get("resumed")
    summary = json.loads((both.out / "summary.json").read_text())
    assert summary["baseline"]["episodes"] == 1 and summary["bt"]["episodes"] == 1
    assert "kept from an earlier run with --resume" in (both.out / "results.md").read_text()


def test_resume_reruns_an_episode_played_with_other_settings(tmp_path: Path) -> None:
    quietly(tmp_path, settings(tmp_path, episodes=1, scenarios=("random",),
                               executives=("bt",)), fake())
    longer = settings(tmp_path, episodes=1, scenarios=("random",), executives=("bt",),
                      time_limit_s=300.0, resume=True)
    rows = quietly(tmp_path, longer, fake({("bt", 0): "crash"}))
    assert not rows[0].get("resumed") and rows[0]["exit_code"] == 3


def test_run_command_for_each_scenario_set(tmp_path: Path) -> None:
    chosen = settings(tmp_path, scenarios=("default", "hard"), speed=2.0)
    plan = plan_episodes(chosen)
    default = run_command(next(e for e in plan if e.scenario == "default"), chosen)
    hard = run_command(next(e for e in plan if e.scenario == "hard" and e.index == 1), chosen)
    assert "--seed" not in default and "--sim-arg=--difficulty" not in default
    assert hard[hard.index("--seed") + 1] == "1"
    assert hard[-2:] == ["--sim-arg=--difficulty", "--sim-arg=hard"]
    assert hard[hard.index("--speed") + 1] == "2.0"
    assert hard[hard.index("--executive") + 1] in ("bt", "baseline")


def test_domains_are_distinct_and_in_range() -> None:
    domains = domain_ids(8, base=97)
    assert len(set(domains)) == 8
    assert all(1 <= domain <= 101 for domain in domains)


def alive(pid: int) -> bool:
    deadline = time.monotonic() + 2.0
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        if start_time(pid) is None:
            return False
        status = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        if status == "Z":  # a zombie is dead; its parent has not reaped it yet
            return False
        time.sleep(0.05)
    return True


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        (["--episodes", "0"], "--episodes"),
        (["--episodes", "many"], "--episodes"),
        (["--scenarios", "easy"], "easy"),
        (["--scenarios", "random,random"], "repeated"),
        (["--executive", "bt,magic"], "magic"),
        (["--jobs", "0"], "--jobs"),
        (["--seed", "-1"], "--seed"),
        (["--speed", "-2"], "--speed"),
        (["--episode-timeout", "0"], "--episode-timeout"),
        (["--time-limit", "-5"], "--time-limit"),
        (["--frobnicate"], "--frobnicate"),
    ],
)
def test_bad_arguments_get_one_line_and_exit_2(tmp_path: Path, arguments: list[str],
                                               named: str) -> None:
    result = evaluate_command(tmp_path, "--out", "evaluation", *arguments)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert named in lines[0]
    assert not (tmp_path / "evaluation").exists(), "nothing is started or written"


def test_missing_out_and_out_a_file_are_bad_input(tmp_path: Path) -> None:
    assert evaluate_command(tmp_path).returncode == 2
    (tmp_path / "taken").write_text("")
    result = evaluate_command(tmp_path, "--out", "taken")
    assert result.returncode == 2 and "--out taken" in result.stderr.strip()


def evaluate_command(cwd: Path, *arguments: str) -> subprocess.CompletedProcess[str]:
    return run_module("bt_servicesim.evaluate", *arguments, cwd=cwd, timeout=60)


def test_episodes_an_interrupted_evaluation_did_not_play_are_left_out_of_the_statistics(
        tmp_path: Path) -> None:
    chosen = settings(tmp_path, episodes=3, scenarios=("random",), executives=("bt",))
    episodes = plan_episodes(chosen)
    for episode in episodes:
        episode.out.mkdir(parents=True)
    played_ok = dict(episode_row(episodes[0], EpisodeOutcome(0, 1.0), 7),
                     completed=True, score=10.0, sim_time_s=5.0)
    failed = episode_row(episodes[1], EpisodeOutcome(1, 1.0), 7)
    not_run = episode_row(episodes[2], EpisodeOutcome(None, 0.0, INTERRUPTED), 7)
    assert not_run["not_run"] and not failed["not_run"]
    summary = summarise([played_ok, failed, not_run])
    assert (summary["episodes"], summary["success_rate"], summary["not_run"]) == (2, 0.5, 1)
    assert len(summary["rows"]) == 3, "the unplayed row is kept, not dropped"
    report = markdown_report(chosen, [played_ok, failed, not_run], ".")
    assert "not played and are left out of the statistics (bt random: 1)" in report
    assert INTERRUPTED not in report.split("## Why episodes failed")[1]


def test_settings_that_overload_the_machine_are_warned_about() -> None:
    from bt_servicesim.evaluation.settings import load_warning

    assert load_warning(jobs=3, speed=20.0, cores=2) is None
    warning = load_warning(jobs=4, speed=20.0, cores=2)
    assert warning is not None and "2.2 cores" in warning and "this machine has 2" in warning
    assert load_warning(jobs=1, speed=0.0, cores=2) is None
    assert load_warning(jobs=2, speed=0.0, cores=2) is not None
