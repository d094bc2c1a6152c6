"""Batch evaluation with fake episodes: the summary's shape, stopped and crashed episodes, input.

A fake episode is a small Python process standing in for ``python -m bt_servicesim.run``: like
the run it claims a ROS domain of its own and writes report.json with its run id, "running" at
the start and its outcome (which depends on the executive and the seed) at the end; it records
the ROS environment it was given, and can be told to hang (and write "interrupted" on SIGINT,
beside an orphan child that writes a report of its own later), to crash, to be killed, or to
crash after another run's report appeared in its directory. ``DRIVER`` runs the command itself,
``python -m bt_servicesim.evaluate``, on fake episodes, for the tests that signal it.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from bt_servicesim.evaluate import evaluate
from bt_servicesim.evaluation.episodes import (
    Episode,
    EpisodeCommand,
    EpisodeOutcome,
    episode_row,
    plan_episodes,
    run_command,
    start_time,
)
from bt_servicesim.evaluation.report import PLOTS, markdown_report
from bt_servicesim.evaluation.settings import (
    EPISODE_NAME,
    INTERRUPTED,
    PENALTY_KEYS,
    EvaluationSettings,
)
from bt_servicesim.evaluation.summary import summarise, summary_of
from bt_servicesim.tree.files import DEFAULT_NAV_PARAMS, SERVICEBOT
from tests.evaluation.bound_fakes import FAKE_BOUND_COMMAND
from tests.fakes.commands import run_module

FAKE_EPISODE = r"""
import json, os, signal, subprocess, sys, time
from bt_servicesim.ros.domain import claim_domain
out, executive, seed, scenario, mode, run_id = sys.argv[1:7]
started = time.time()
users = os.environ.get("ROS_DOMAIN_ID", "")
claim = claim_domain(avoid=int(users) if users.isdigit() else None)  # as the run does
number = 0 if seed == "None" else int(seed)
header = {"run_id": run_id, "ros_domain_id": claim.domain_id, "executive": executive,
          "seed": None if seed == "None" else number, "world": "default"}

def write(report):
    path = os.path.join(out, "report.json")
    with open(path + ".tmp", "w") as f:
        json.dump(report, f)
    os.replace(path + ".tmp", path)

write({**header, "status": "running"})
if mode == "hang":
    try:  # from the moment it is seen to run (its orphan up), Ctrl-C is handled, as the run's
        orphan = subprocess.Popen([sys.executable, "-c", ORPHAN, out], start_new_session=True)
        with open(os.path.join(out, "pids"), "w") as f:
            f.write(f"{os.getpid()} {orphan.pid}")
        time.sleep(120)
    except KeyboardInterrupt:  # as the run: stop, write the report, exit 130
        write({**header, "status": "interrupted", "completed": False, "score": 0.0,
               "sim_time_s": 1.0, "checkpoints": [], "penalties": {}, "wall_time_s": 1.0,
               "exit_code": 130, "failure": "interrupted (SIGINT)"})
        sys.exit(130)
if mode == "crash":
    print("Traceback: something broke", file=sys.stderr)
    sys.exit(3)
if mode == "killed":
    os.kill(os.getpid(), signal.SIGKILL)
if mode == "foreign":  # what an orphan of an earlier evaluation wrote, then this run crashed
    write({"run_id": "an-earlier-evaluation", "status": "completed", "completed": True,
           "score": 4252.7, "sim_time_s": 900.0, "checkpoints": [], "penalties": {},
           "executive": executive})
    print("Traceback: crashed at start", file=sys.stderr)
    sys.exit(3)
time.sleep(0.3)
completed = executive == "bt" or number % 2 == 0
score = (100.0 if executive == "bt" else 200.0) + number
first = 10.0 if executive == "bt" else 20.0
checkpoints = [{"name": name, "done": completed or index < 3, "sim_time_s": first + 10.0 * index}
               for index, name in enumerate(("go_to_pick_up", "pick_up_guest",
                                              "drop_off_guest", "return_to_start"))]
write({
    **header, "status": "completed" if completed else "failed",
    "completed": completed, "score": score, "sim_time_s": score / 2,
    "checkpoints": checkpoints, "wall_time_s": 0.3, "exit_code": 0 if completed else 1,
    "failure": None if completed else "the mission tree ended with SUCCESS",
    "penalties": {"failed_pickup": 1 if executive == "baseline" else 0, "failed_dropoff": 0,
                  "too_fast": 0, "drifts": 0, "contact": 0.0, "approximation": 2.0},
    "environment": {key: os.environ.get(key) for key in
                    ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")},
    "interval": [started, time.time()],
})
"""

ORPHAN_DELAY_S = 5.0
"""When the hanging fake's orphan writes a report of its own into the episode's directory."""

ORPHAN = f"""
import json, os, signal, sys, time
signal.signal(signal.SIGINT, signal.SIG_IGN)
time.sleep({ORPHAN_DELAY_S})
with open(os.path.join(sys.argv[1], "report.json"), "w") as f:
    json.dump({{"run_id": "orphan", "status": "completed", "completed": True, "score": 1.0}}, f)
"""

DRIVER = r"""
import os, sys
from bt_servicesim.evaluate import main
from bt_servicesim.evaluation import kinematic_bound
kinematic_bound.BOUND_COMMAND = (sys.executable, "-c", FAKE_BOUND_COMMAND, os.devnull)
fake, mode = sys.argv[1:3]
code = open(fake).read()
def command(episode, settings):
    return [sys.executable, "-c", code, str(episode.out), episode.executive, str(episode.seed),
            episode.scenario, mode, episode.run_id]
sys.exit(main(sys.argv[3:], command=command))
""".replace("FAKE_BOUND_COMMAND", repr(FAKE_BOUND_COMMAND), 1)
"""``python -m bt_servicesim.evaluate`` with the fake episodes: ``DRIVER fake.py mode args``.
Its kinematic bounds come from the stand-in, as in-process evaluations' do (``conftest.py``):
the real bound command would spend seconds of CPU on tasks the fakes never played."""

SUMMARY_KEYS = {"episodes", "success_rate", "success_interval", "mean_score", "median_score",
                "mean_sim_time_s",
                "penalties", "wall_time_s", "not_run", "rows", "time_over_bound", "nav_params"}


def settings(tmp_path: Path, **changes: Any) -> EvaluationSettings:
    values: dict[str, Any] = dict(
        episodes=2, scenarios=("default", "random"), executives=("bt", "baseline"), jobs=2,
        seed=0, out=tmp_path / "evaluation", speed=0.0, episode_timeout_s=60.0,
        time_limit_s=900.0, docs=None, command_line="python -m bt_servicesim.evaluate (test)")
    values.update(changes)
    return EvaluationSettings(**values)


def fake_code() -> str:
    return FAKE_EPISODE.replace("ORPHAN", repr(ORPHAN), 1)


def fake(mode_for: dict[tuple[str, int | None], str] | None = None) -> EpisodeCommand:
    """The fake episode; ``mode_for[(executive, seed)]`` makes that one hang, crash, be killed
    or leave another run's report."""
    code = fake_code()

    def command(episode: Episode, _: EvaluationSettings) -> list[str]:
        mode = (mode_for or {}).get((episode.executive, episode.seed), "report")
        return [sys.executable, "-c", code, str(episode.out), episode.executive,
                str(episode.seed), episode.scenario, mode, episode.run_id]
    return command


def quietly(tmp_path: Path, chosen: EvaluationSettings,
            command: EpisodeCommand) -> list[dict[str, Any]]:
    with (tmp_path / "progress.log").open("w") as stream:
        rows, stopped_by = evaluate(chosen, command=command, stream=stream)
    assert stopped_by is None
    return rows


@pytest.mark.long
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
        report = json.loads((Path(row["out"]) / "report.json").read_text())
        assert report["run_id"] == row["run_id"] and report["status"] in ("completed", "failed")
        assert row["environment"]["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert len({row["run_id"] for row in rows}) == len(rows), "every episode has its own run id"


def test_episodes_running_at_once_have_distinct_ros_domains_as_their_reports_say(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", "0")
    rows = quietly(tmp_path, settings(tmp_path), fake())
    for row in rows:
        report = json.loads((Path(row["out"]) / "report.json").read_text())
        assert row["ros_domain_id"] == report["ros_domain_id"]
        assert 1 <= row["ros_domain_id"] <= 101
        # the evaluation leaves the domain to the run: the environment is passed on as it is
        assert row["environment"]["ROS_DOMAIN_ID"] == "0"
    overlapping = [(a, b) for a in rows for b in rows if a is not b
                   and a["interval"][0] < b["interval"][1] and b["interval"][0] < a["interval"][1]]
    assert overlapping, "two jobs ran at once"
    for a, b in overlapping:
        assert a["ros_domain_id"] != b["ros_domain_id"]


@pytest.mark.long
def test_table_plots_and_docs_are_written(tmp_path: Path) -> None:
    chosen = settings(tmp_path, docs=tmp_path / "docs")
    quietly(tmp_path, chosen, fake())
    results = (chosen.out / "results.md").read_text()
    assert chosen.command_line in results
    assert "| bt | random | 2 | 100% (34%–100%) |" in results  # Wilson, 95 %
    assert "| baseline | random | 2 | 50% (9%–91%) |" in results
    # random: bt alone completed episode 1; both completed episode 0 (100 vs 200); both
    # dropped off in 0 and 1 (60 vs 90 s); exact two-sided p-values of 1/0, 1/0 and 2/0 splits
    assert ("| random | 1 / 0 (p 1) | 1 | 100.0 | 200.0 | 1/1 (p 1) | 2 | 60.0 | 90.0 | "
            "2/2 (p 0.5) |") in results
    # default: both episodes of each executive play the shipped task, one mission; both
    # completed it, so no one completed it alone (no p-value for nothing to compare)
    assert "| default | 0 / 0 | 1 | 100.0 | 200.0 | 1/1 (p 1) | 1 | 60.0 | 90.0 | 1/1 (p 1) |" \
        in results
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


def test_a_report_of_another_run_is_never_counted(tmp_path: Path) -> None:
    """The measured bug: an orphan of an earlier evaluation wrote a completed report into the
    directory of an episode that then crashed, and the crash counted as completed."""
    chosen = settings(tmp_path, episodes=1, scenarios=("random",), executives=("bt",))
    rows = quietly(tmp_path, chosen, fake({("bt", 0): "foreign"}))
    row = rows[0]
    assert not row["completed"] and row["score"] is None
    assert "another run's, run id 'an-earlier-evaluation'" in row["failure"]
    assert "exited with code 3" in row["failure"] and "crashed at start" in row["failure"]
    assert row["ros_domain_id"] is None, "nothing of the other run's report is taken"
    summary = json.loads((chosen.out / "summary.json").read_text())
    assert summary["bt"]["success_rate"] == 0.0 and summary["bt"]["mean_score"] is None


def test_a_report_that_still_says_running_is_a_failed_episode(tmp_path: Path) -> None:
    chosen = settings(tmp_path, episodes=1, scenarios=("random",), executives=("bt",))
    rows = quietly(tmp_path, chosen, fake({("bt", 0): "killed"}))
    row = rows[0]
    assert not row["completed"] and not row["not_run"]
    assert row["failure"] == ("the run was killed by SIGKILL before it finished (its report "
                              "still says 'running'): no output")
    assert row["returncode"] == -9 and 1 <= row["ros_domain_id"] <= 101
    assert "| bt | random | 1 | 0% (0%–79%) |" in (chosen.out / "results.md").read_text()


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


def test_the_original_guest_set_plays_the_random_sets_tasks_with_the_straight_guest(
        tmp_path: Path) -> None:
    chosen = settings(tmp_path, scenarios=("random", "original-guest"))
    plan = list(plan_episodes(chosen))
    for index in range(2):
        random, original = (run_command(next(e for e in plan if e.scenario == name
                                             and e.index == index), chosen)
                            for name in ("random", "original-guest"))
        assert random[random.index("--seed") + 1] == original[original.index("--seed") + 1]
        assert original[-2:] == ["--sim-arg=--guest-path", "--sim-arg=straight"]
        assert "--sim-arg=--guest-path" not in random


def test_run_command_for_each_scenario_set(tmp_path: Path) -> None:
    chosen = settings(tmp_path, scenarios=("default", "hard"), speed=2.0)
    plan = list(plan_episodes(chosen))
    default = run_command(next(e for e in plan if e.scenario == "default"), chosen)
    hard = run_command(next(e for e in plan if e.scenario == "hard" and e.index == 1), chosen)
    assert "--seed" not in default and "--sim-arg=--difficulty" not in default
    assert hard[hard.index("--seed") + 1] == "1"
    assert hard[-2:] == ["--sim-arg=--difficulty", "--sim-arg=hard"]
    assert hard[hard.index("--speed") + 1] == "2.0"
    assert hard[hard.index("--executive") + 1] in ("bt", "baseline")
    for episode in plan:
        command = run_command(episode, chosen)
        assert command[command.index("--run-id") + 1] == episode.run_id
        assert "--overwrite" in command, "a rerun's directory is the evaluation's own"
        assert "ROS_DOMAIN_ID" not in " ".join(command)
    assert len({episode.run_id for episode in plan}) == len(plan)
    assert not {e.run_id for e in plan} & {e.run_id for e in plan_episodes(chosen)}, \
        "each evaluation draws new run ids"


def test_the_time_limit_bound_is_the_runs() -> None:
    from bt_servicesim.evaluation.settings import MAX_TIME_LIMIT_S
    from bt_servicesim.run import MAX_TIME_LIMIT_S as RUN_MAX_TIME_LIMIT_S

    assert MAX_TIME_LIMIT_S == RUN_MAX_TIME_LIMIT_S


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
        (["--episodes", "-3"], "--episodes"),
        (["--episodes", "many"], "--episodes"),
        (["--episodes", "inf"], "--episodes"),
        (["--episodes", "nan"], "--episodes"),
        (["--scenarios", "easy"], "easy"),
        (["--scenarios", "random,random"], "repeated"),
        (["--executive", "bt,magic"], "magic"),
        (["--jobs", "0"], "--jobs"),
        (["--jobs", "-1"], "--jobs"),
        (["--jobs", "101"], "--jobs"),
        (["--jobs", "nan"], "--jobs"),
        (["--jobs", "inf"], "--jobs"),
        (["--seed", "-1"], "--seed"),
        (["--seed", "nan"], "--seed"),
        (["--seed", "inf"], "--seed"),
        (["--speed", "-2"], "--speed"),
        (["--speed", "nan"], "--speed"),
        (["--speed", "inf"], "--speed"),
        (["--speed", "-inf"], "--speed"),
        (["--episode-timeout", "0"], "--episode-timeout"),
        (["--episode-timeout", "-1"], "--episode-timeout"),
        (["--episode-timeout", "nan"], "--episode-timeout"),
        (["--episode-timeout", "inf"], "--episode-timeout"),
        (["--episode-timeout", "1e7"], "--episode-timeout"),
        (["--time-limit", "-5"], "--time-limit"),
        (["--time-limit", "0"], "--time-limit"),
        (["--time-limit", "nan"], "--time-limit"),
        (["--time-limit", "inf"], "--time-limit"),
        (["--time-limit", "1e7"], "--time-limit"),
        (["--frobnicate"], "--frobnicate"),
        (["--docs", "/proc/no-such-place"], "--docs /proc/no-such-place: cannot make it"),
        (["--trajectory", "always"], "--trajectory"),
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
    chosen = settings(tmp_path, episodes=4, scenarios=("random",), executives=("bt",))
    episodes = list(plan_episodes(chosen))
    for episode in episodes:
        episode.out.mkdir(parents=True)
    played_ok = dict(episode_row(episodes[0], EpisodeOutcome(0, 1.0)),
                     completed=True, score=10.0, sim_time_s=5.0)
    failed = episode_row(episodes[1], EpisodeOutcome(1, 1.0))
    stopped = episode_row(episodes[2], EpisodeOutcome(130, 1.0, INTERRUPTED))
    # episode 3 was never started: it has no row
    assert stopped["not_run"] and not failed["not_run"]
    rows = [played_ok, failed, stopped]
    summary = summarise(rows)
    assert (summary["episodes"], summary["success_rate"], summary["not_run"]) == (2, 0.5, 1)
    assert len(summary["rows"]) == 3, "the stopped episode's row is kept, not dropped"
    assert summary_of(chosen, rows)["bt"]["not_run"] == 2, "stopped, and never started"
    report = markdown_report(chosen, rows, ".")
    assert "not played and are left out of the statistics (bt random: 2)" in report
    assert INTERRUPTED not in report.split("## Why episodes failed")[1]


def test_settings_that_overload_the_machine_are_warned_about() -> None:
    from bt_servicesim.evaluation.settings import load_warning

    assert load_warning(jobs=2, speed=20.0, cores=2) is None
    warning = load_warning(jobs=3, speed=20.0, cores=2)
    assert warning is not None and "2.9 cores" in warning and "this machine has 2" in warning
    assert "slower than --speed asks" in warning
    # flat out asks for nothing but the cores there are: more episodes only share them
    assert load_warning(jobs=1, speed=0.0, cores=2) is None
    assert load_warning(jobs=3, speed=0.0, cores=2) is None


STARTED: list[subprocess.Popen[str]] = []
"""The evaluations ``start_evaluation`` started, for ``no_evaluation_outlives_its_test``."""


@pytest.fixture(autouse=True)
def no_evaluation_outlives_its_test() -> Iterator[None]:
    """An evaluation a test left running (its assertion failed, or ``communicate`` timed out) is
    killed when the test ends: its episodes then get their parent-death signal."""
    yield
    while STARTED:
        process = STARTED.pop()
        if process.poll() is None:
            process.kill()
        process.communicate()


def start_evaluation(tmp_path: Path, mode: str, *arguments: str) -> subprocess.Popen[str]:
    """``python -m bt_servicesim.evaluate`` on fake episodes, all in ``mode``, out in
    ``tmp_path / "evaluation"``."""
    fake_file = tmp_path / "fake_episode.py"
    fake_file.write_text(fake_code())
    process = subprocess.Popen(
        [sys.executable, "-c", DRIVER, str(fake_file), mode, "--out",
         str(tmp_path / "evaluation"), *arguments],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    STARTED.append(process)
    return process


def wait_for(paths: list[Path], process: subprocess.Popen[str], limit_s: float) -> None:
    deadline = time.monotonic() + limit_s
    while not all(path.is_file() and path.stat().st_size for path in paths):
        assert process.poll() is None, process.communicate()
        if time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"none of {paths} within {limit_s} s: {process.communicate()}")
        time.sleep(0.05)


def files_under(directory: Path) -> dict[str, tuple[int, int]]:
    return {str(path): (path.stat().st_size, path.stat().st_mtime_ns)
            for path in directory.rglob("*") if path.is_file()}


@pytest.mark.long
@pytest.mark.parametrize(("stop", "code"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129),
                                            (signal.SIGINT, 130)])
def test_a_stop_signal_stops_every_episode_and_nothing_writes_after_the_exit(
        tmp_path: Path, stop: signal.Signals, code: int) -> None:
    process = start_evaluation(tmp_path, "hang", "--episodes", "3", "--scenarios", "random",
                               "--jobs", "2", "--speed", "1")
    out = tmp_path / "evaluation"
    pid_files = [out / executive / "random" / "0" / "pids" for executive in ("bt", "baseline")]
    wait_for(pid_files, process, 30.0)
    pids = [int(pid) for path in pid_files for pid in path.read_text().split()]
    process.send_signal(stop)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == code, stderr
    assert "Traceback" not in stderr
    assert all(not alive(pid) for pid in pids), "every episode and its orphan are gone"
    written = files_under(out)
    time.sleep(ORPHAN_DELAY_S + 1.0)  # the orphans would have written their reports by now
    assert files_under(out) == written, "nothing writes into --out after the evaluation exited"
    summary = json.loads((out / "summary.json").read_text())
    for executive in ("bt", "baseline"):
        (row,) = summary[executive]["rows"]
        assert row["not_run"] and row["failure"] == "evaluation interrupted"
        report = json.loads((Path(row["out"]) / "report.json").read_text())
        assert (report["run_id"], report["status"]) == (row["run_id"], "interrupted")
        assert summary[executive]["not_run"] == 3 and summary[executive]["episodes"] == 0
    assert f"(stopped by {stop.name})" in stderr


@pytest.mark.long
def test_a_million_episodes_start_at_once_and_ctrl_c_ends_them_cleanly(tmp_path: Path) -> None:
    process = start_evaluation(tmp_path, "report", "--episodes", "1000000", "--jobs", "2",
                               "--speed", "1")
    out = tmp_path / "evaluation"
    first = out / "bt" / "default" / "0"
    wait_for([first / "report.json"], process, 10.0)
    wait_for([first / EPISODE_NAME], process, 60.0)  # the first episode's row: it was played
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["bt"]["episodes"] >= 1 and summary["bt"]["not_run"] > 2_990_000
    assert "were not played" in (out / "results.md").read_text()


def test_ctrl_c_while_the_first_episodes_start_prints_no_traceback(tmp_path: Path) -> None:
    process = start_evaluation(tmp_path, "hang", "--episodes", "2", "--jobs", "2", "--speed", "1")
    wait_for([tmp_path / "evaluation" / "bt" / "default" / "0" / "report.json"], process, 10.0)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130 and "Traceback" not in stderr, stderr


def test_episodes_die_with_an_evaluation_killed_outright(tmp_path: Path) -> None:
    """SIGKILL cannot be caught: the episodes then get SIGTERM from the kernel (their parent-death
    signal), which stops a run as Ctrl-C does, instead of running on as orphans."""
    process = start_evaluation(tmp_path, "hang", "--episodes", "1", "--scenarios", "random",
                               "--executive", "bt", "--jobs", "1", "--speed", "1")
    pid_file = tmp_path / "evaluation" / "bt" / "random" / "0" / "pids"
    wait_for([pid_file], process, 30.0)
    episode, orphan = (int(pid) for pid in pid_file.read_text().split())
    try:
        process.kill()
        process.communicate(timeout=30)
        assert not alive(episode), "the episode went with the evaluation"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(orphan, signal.SIGKILL)  # the fake's own child has no such signal


# ------------------------------------------------------------------ a tree of the user's own
def own_tree(tmp_path: Path, comment: str = "mine") -> Path:
    """The shipped tree, copied as a user's own (a comment makes its content differ)."""
    from bt_servicesim.tree.files import DEFAULT_TREE

    path = tmp_path / "my_tree.xml"
    path.write_text(DEFAULT_TREE.read_text().replace("<root", f"<!-- {comment} -->\n<root", 1))
    return path


def test_the_bt_executive_plays_the_tree_given_cold_or_warm(tmp_path: Path) -> None:
    from bt_servicesim.evaluation.episodes import warm_line
    from bt_servicesim.warm_worker import WarmEpisode

    tree = own_tree(tmp_path)
    chosen = settings(tmp_path, tree=tree)
    for episode in plan_episodes(chosen):
        command, line = run_command(episode, chosen), json.loads(warm_line(episode, chosen))
        if episode.executive == "bt":
            assert command[command.index("--tree") + 1] == str(tree)
            assert WarmEpisode.from_line(json.dumps(line)).run_settings().tree == tree
        else:
            assert "--tree" not in command and "tree" not in line  # the baseline has none
    shipped = settings(tmp_path)  # the shipped tree: each run (on a cluster worker, too) its own
    for episode in plan_episodes(shipped):
        assert "--tree" not in run_command(episode, shipped)
        assert "tree" not in json.loads(warm_line(episode, shipped))


def test_results_name_the_tree_and_replay_its_failures_with_it(tmp_path: Path) -> None:
    tree = own_tree(tmp_path)
    chosen = settings(tmp_path, episodes=1, scenarios=("random",), executives=("bt",),
                      tree=tree)
    quietly(tmp_path, chosen, fake({("bt", 0): "crash"}))
    results = (chosen.out / "results.md").read_text()
    assert f"the bt executive plays `{tree}` (SHA-256 " in results
    assert f"`--executive bt` `--tree {tree}` `--seed 0`" in results
    shipped = settings(tmp_path, episodes=1, scenarios=("random",), executives=("bt",),
                       out=tmp_path / "shipped")
    quietly(tmp_path, shipped, fake({("bt", 0): "crash"}))
    assert "plays `" not in (shipped.out / "results.md").read_text()  # the shipped tree: as ever


@pytest.mark.parametrize("shipped", [False, True], ids=["own-tree", "shipped-tree"])
def test_resume_reruns_the_trees_episodes_when_the_tree_changed(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, shipped: bool) -> None:
    tree = own_tree(tmp_path)
    if shipped:  # the copy stands in for trees/servicesim_mission.xml
        monkeypatch.setattr("bt_servicesim.evaluation.settings.DEFAULT_TREE", tree)
    first = settings(tmp_path, episodes=1, scenarios=("random",), tree=tree)
    assert first.own_tree is not shipped
    quietly(tmp_path, first, fake())
    same = settings(tmp_path, episodes=1, scenarios=("random",), tree=tree, resume=True)
    assert all(row.get("resumed") for row in quietly(tmp_path, same, fake()))
    own_tree(tmp_path, comment="edited since")
    rows = quietly(tmp_path, same, fake())
    resumed = {row["executive"]: bool(row.get("resumed")) for row in rows}
    assert resumed == {"bt": False, "baseline": True}, "only the tree's episodes play again"


def test_a_tree_that_cannot_play_is_one_line_before_anything_starts(tmp_path: Path) -> None:
    (tmp_path / "broken.xml").write_text("<root BTCPP_format='4'><BehaviorTree ID='x'>")
    for arguments, named in ((["--tree", "missing.xml"], "missing.xml: no such tree file"),
                             (["--tree", "broken.xml"], "broken.xml"),
                             (["--tree", str(own_tree(tmp_path)), "--executive", "baseline"],
                              "only the bt executive plays a tree")):
        result = evaluate_command(tmp_path, "--out", "evaluation", *arguments)
        lines = result.stderr.strip().splitlines()
        assert result.returncode == 2 and len(lines) == 1, result.stderr
        assert named in lines[0] and lines[0].count("--tree") == 1
        assert not (tmp_path / "evaluation").exists(), "nothing is started or written"


def test_a_stop_before_any_episode_started_is_one_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    def interrupted(*_: object) -> None:
        raise KeyboardInterrupt

    from bt_servicesim.evaluate import main

    monkeypatch.setattr("bt_servicesim.evaluate.settings_from", interrupted)
    assert main(["--episodes", "1", "--out", str(tmp_path)]) == 130
    assert capsys.readouterr().err == (
        "python -m bt_servicesim.evaluate: stopped by SIGINT while starting\n")


# ------------------------------------------------------------ the robot's navigation parameters
def nav_params(tmp_path: Path, tolerance: str = "0.3") -> Path:
    path = tmp_path / "nav2_params.yaml"
    path.write_text("controller_server:\n  ros__parameters:\n    general_goal_checker:\n"
                    f"      xy_goal_tolerance: {tolerance}\n")
    return path


def test_every_executives_episodes_get_the_navigation_parameters_cold_or_warm(
        tmp_path: Path) -> None:
    from bt_servicesim.evaluation.episodes import warm_line
    from bt_servicesim.warm_worker import WarmEpisode

    params = nav_params(tmp_path)
    chosen = settings(tmp_path, executives=("bt", "bt:mine", "baseline"),
                      trees={"bt:mine": own_tree(tmp_path)}, nav_params=str(params))
    for episode in plan_episodes(chosen):
        command, line = run_command(episode, chosen), warm_line(episode, chosen)
        assert command[command.index("--nav-params") + 1] == str(params)
        assert WarmEpisode.from_line(line).run_settings().nav_params == params
    default = settings(tmp_path, executives=("bt", "bt:mine", "baseline"),
                       trees={"bt:mine": own_tree(tmp_path)})
    for episode in plan_episodes(default):
        command, line = run_command(episode, default), warm_line(episode, default)
        own = DEFAULT_NAV_PARAMS if episode.executive.startswith("bt") else None
        assert command[command.index("--nav-params") + 1] == str(own or SERVICEBOT)
        assert WarmEpisode.from_line(line).run_settings().nav_params == own


@pytest.mark.parametrize("trajectory", ["failed", "never"])
def test_every_episode_draws_its_picture_as_the_evaluation_says_cold_or_warm(
        tmp_path: Path, trajectory: str) -> None:
    from bt_servicesim.evaluation.episodes import warm_line
    from bt_servicesim.warm_worker import WarmEpisode

    chosen = settings(tmp_path, executives=("bt", "baseline"), trajectory=trajectory)
    for episode in plan_episodes(chosen):
        command, line = run_command(episode, chosen), warm_line(episode, chosen)
        assert command[command.index("--trajectory") + 1] == trajectory
        assert WarmEpisode.from_line(line).run_settings().trajectory == trajectory


def test_a_warm_episode_with_an_unknown_picture_policy_is_refused_in_one_line() -> None:
    from bt_servicesim.warm_worker import WarmEpisode

    line = json.dumps({"out": "/tmp/e", "run_id": "r", "executive": "bt", "seed": 1,
                       "speed": 0.0, "trajectory": "sometimes"})
    with pytest.raises(ValueError, match="trajectory 'sometimes': one of always, failed, never"):
        WarmEpisode.from_line(line)


def test_the_summary_and_results_name_the_navigation_parameters_and_their_digest(
        tmp_path: Path) -> None:
    import hashlib

    params = nav_params(tmp_path)
    chosen = settings(tmp_path, episodes=1, scenarios=("random",), nav_params=str(params))
    quietly(tmp_path, chosen, fake())
    digest = hashlib.sha256(params.read_bytes()).hexdigest()
    summary = json.loads((chosen.out / "summary.json").read_text())
    for executive in ("bt", "baseline"):
        assert summary[executive]["nav_params"] == {"file": str(params), "sha256": digest}
    assert f"navigates with `{params}` (SHA-256 {digest[:16]})" in (
        chosen.out / "results.md").read_text()
    default = settings(tmp_path, episodes=1, scenarios=("random",), out=tmp_path / "default")
    quietly(tmp_path, default, fake())
    summary = json.loads((default.out / "summary.json").read_text())
    assert summary["bt"]["nav_params"]["file"] == str(DEFAULT_NAV_PARAMS)
    assert summary["baseline"]["nav_params"] is None
    assert "baseline's robot navigates with the servicebot's configuration" in (
        default.out / "results.md").read_text()


def test_resume_reruns_every_episode_when_the_navigation_parameters_changed(
        tmp_path: Path) -> None:
    params = nav_params(tmp_path)
    first = settings(tmp_path, episodes=1, scenarios=("random",), nav_params=str(params))
    quietly(tmp_path, first, fake())
    same = settings(tmp_path, episodes=1, scenarios=("random",), nav_params=str(params),
                    resume=True)
    assert all(row.get("resumed") for row in quietly(tmp_path, same, fake()))
    nav_params(tmp_path, tolerance="0.2")
    assert not any(row.get("resumed") for row in quietly(tmp_path, same, fake()))


def test_navigation_parameters_the_simulator_would_refuse_are_one_line_before_anything_starts(
        tmp_path: Path) -> None:
    (tmp_path / "integer.yaml").write_text(
        "controller_server:\n  ros__parameters:\n    general_goal_checker:\n"
        "      xy_goal_tolerance: 1\n")
    for arguments, named in ((["--nav-params", "missing.yaml"], "missing.yaml: no such file"),
                             (["--nav-params", "integer.yaml"],
                              "integer.yaml: controller_server.ros__parameters."
                              "general_goal_checker.xy_goal_tolerance: must be a double")):
        result = evaluate_command(tmp_path, "--out", "evaluation", *arguments)
        lines = result.stderr.strip().splitlines()
        assert result.returncode == 2 and len(lines) == 1, result.stderr
        assert named in lines[0] and lines[0].count("--nav-params") == 1, lines[0]
        assert not (tmp_path / "evaluation").exists(), "nothing is started or written"
