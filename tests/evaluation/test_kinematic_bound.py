"""The evaluation's kinematic bounds: which task each row played, one call of the bound command
for all of them, time over the bound in the rows, summary.json, results.md and the plot.

The bound command is a stand-in here (``bound_fakes.py``); the real one is tested in
``tests/sim/test_task_bound.py``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bt_servicesim.evaluation.kinematic_bound import (
    TaskKey,
    add_kinematic_bounds,
    main,
    task_key,
)
from bt_servicesim.evaluation.report import markdown_report, write_results
from bt_servicesim.evaluation.settings import EvaluationSettings
from bt_servicesim.evaluation.summary import percentile, summary_of, time_over_bound
from tests.evaluation.bound_fakes import fake_bound, fake_bound_command


def row(executive: str, scenario: str, seed: int | None, *, sim_time_s: float | None = 100.0,
        completed: bool = True, **changes: Any) -> dict[str, Any]:
    values: dict[str, Any] = dict(
        executive=executive, scenario=scenario, episode=seed or 0, episode_seed=seed,
        world="default", completed=completed, score=sim_time_s if completed else None,
        sim_time_s=sim_time_s, not_run=False, penalties={}, checkpoints=[], failure=None)
    values.update(changes)
    return values


def settings(tmp_path: Path, **changes: Any) -> EvaluationSettings:
    values: dict[str, Any] = dict(
        episodes=2, scenarios=("default", "random", "hard"), executives=("bt", "baseline"),
        jobs=1, seed=0, out=tmp_path / "evaluation", speed=0.0, episode_timeout_s=60.0,
        time_limit_s=900.0, docs=None, command_line="python -m bt_servicesim.evaluate (test)")
    values.update(changes)
    return EvaluationSettings(**values)


def test_a_row_names_its_task_by_world_seed_and_the_sets_simulator_arguments() -> None:
    assert task_key(row("bt", "default", None)) == TaskKey(None, None, ())
    assert task_key(row("bt", "random", 3)) == TaskKey(None, 3, ())
    assert task_key(row("baseline", "hard", 3)) == TaskKey(None, 3, ("--difficulty", "hard"))
    # the arguments the episode ran with, as its key recorded them, win over the set's now
    recorded = row("bt", "hard", 3, episode_key={"sim_args": ["--rfid-dropout", "0.5"]})
    assert task_key(recorded) == TaskKey(None, 3, ("--rfid-dropout", "0.5"))
    assert task_key(row("bt", "random", 3, world="/w/hall.yaml")).world == "/w/hall.yaml"
    assert task_key(row("bt", "no such set", 3)) is None


def test_each_task_is_asked_once_for_every_executive_and_the_ratio_is_time_over_bound(
        tmp_path: Path) -> None:
    log = tmp_path / "calls.log"
    rows = [row("bt", "random", 1, sim_time_s=90.0), row("baseline", "random", 1),
            row("bt", "hard", 1, sim_time_s=120.0),
            row("baseline", "hard", 1, completed=False, sim_time_s=900.0),
            row("bt", "default", None, sim_time_s=75.0),
            row("bt", "random", 9, not_run=True)]  # a stopped evaluation: not asked for
    bounded, problem = add_kinematic_bounds(rows, command=fake_bound_command(log))
    assert problem is None
    calls = log.read_text().splitlines()
    assert len(calls) == 1, "one call of the bound command for the whole evaluation"
    assert json.loads(calls[0]) == [
        {"world": None, "seed": 1, "sim_args": []},
        {"world": None, "seed": 1, "sim_args": ["--difficulty", "hard"]},
        {"world": None, "seed": None, "sim_args": []}]
    assert [r.get("kinematic_bound_s") for r in bounded] == [60.0, 60.0, 60.0, 60.0, 50.0, None]
    assert [r.get("time_over_bound") for r in bounded] == [
        1.5, pytest.approx(100 / 60, abs=1e-4), 2.0, None, 1.5, None]
    assert bounded[0]["kinematic_bound_legs"][0]["checkpoint"] == "go_to_pick_up"
    assert "kinematic_bound_s" not in rows[0], "the rows given are left as they were"


def test_bounds_asked_of_several_processes_come_back_for_the_tasks_each_was_given(
        tmp_path: Path) -> None:
    log = tmp_path / "calls.log"
    rows = [row("bt", "random", seed, sim_time_s=90.0) for seed in range(5)]
    bounded, problem = add_kinematic_bounds(rows, command=fake_bound_command(log), jobs=2)
    assert problem is None
    shares = [json.loads(line) for line in log.read_text().splitlines()]
    assert len(shares) == 2, "one process per job"
    assert sorted(entry["seed"] for share in shares for entry in share) == list(range(5))
    assert [r["kinematic_bound_s"] for r in bounded] == [fake_bound(seed) for seed in range(5)]


def test_a_few_tasks_share_one_process_whatever_the_jobs(tmp_path: Path) -> None:
    log = tmp_path / "calls.log"
    rows = [row("bt", "random", seed, sim_time_s=90.0) for seed in range(3)]
    bounded, problem = add_kinematic_bounds(rows, command=fake_bound_command(log), jobs=2)
    assert problem is None
    shares = [json.loads(line) for line in log.read_text().splitlines()]
    assert [sorted(entry["seed"] for entry in share) for share in shares] == [[0, 1, 2]]
    assert [r["kinematic_bound_s"] for r in bounded] == [fake_bound(seed) for seed in range(3)]


def test_a_failing_bound_command_costs_the_bounds_not_the_evaluation(tmp_path: Path) -> None:
    failing = (sys.executable, "-c",
               "import sys; sys.stderr.write('traceback...\\nbroken world: no map\\n'); "
               "sys.exit(2)")
    rows = [row("bt", "random", 1)]
    bounded, problem = add_kinematic_bounds(rows, command=failing)
    assert problem == "the bound command failed: broken world: no map"
    assert "kinematic_bound_s" not in bounded[0]
    report = markdown_report(settings(tmp_path), bounded, ".", revision="commit `abc`",
                             bound_problem=problem)
    assert "No kinematic bounds: the bound command failed: broken world: no map." in report
    assert "| bt | random | 0 | – | – | – |" in report


def test_time_over_bound_counts_completed_episodes_that_have_a_bound() -> None:
    ratios = [1.0 + step / 10.0 for step in range(11)]  # 1.0 .. 2.0
    rows = [row("bt", "random", n, time_over_bound=ratio, kinematic_bound_s=50.0 + n)
            for n, ratio in enumerate(ratios)]
    rows += [row("bt", "random", 20, completed=False, time_over_bound=None,
                 kinematic_bound_s=99.0),
             row("bt", "random", 21, time_over_bound=9.0, kinematic_bound_s=99.0,
                 not_run=True),
             row("bt", "random", 22)]  # completed, no bound
    assert time_over_bound(rows) == {"episodes": 11, "median": 1.5, "p90": 1.9,
                                     "median_bound_s": 55.0}
    assert time_over_bound([]) == {"episodes": 0, "median": None, "p90": None,
                                   "median_bound_s": None}


def test_the_percentile_interpolates_as_numpy_does() -> None:
    values = list(np.random.default_rng(5).uniform(1.0, 3.0, size=37))
    for percent in (0.0, 50.0, 90.0, 100.0):
        assert percentile(values, percent) == pytest.approx(np.percentile(values, percent))
    assert percentile([1.3], 90.0) == 1.3


def test_summary_and_results_show_time_over_bound_per_set_and_executive(
        tmp_path: Path) -> None:
    chosen = settings(tmp_path, docs=tmp_path / "docs")
    # fake bounds: 50 s for the shipped task, 50 + 10 x seed otherwise
    rows = [row("bt", "default", None, sim_time_s=60.0), row("bt", "random", 0, sim_time_s=55.0),
            row("bt", "random", 1, sim_time_s=90.0), row("baseline", "random", 0,
                                                          sim_time_s=100.0),
            row("baseline", "random", 1, completed=False), row("bt", "hard", 1,
                                                              sim_time_s=66.0)]
    write_results(chosen, rows)
    summary = json.loads((chosen.out / "summary.json").read_text())
    assert summary["bt"]["time_over_bound"]["random"] == {
        "episodes": 2, "median": pytest.approx((1.1 + 1.5) / 2),
        "p90": pytest.approx(1.1 + 0.9 * 0.4), "median_bound_s": 55.0}
    assert summary["bt"]["time_over_bound"]["default"]["median"] == pytest.approx(1.2)
    assert summary["baseline"]["time_over_bound"]["random"]["episodes"] == 1
    assert summary["baseline"]["time_over_bound"]["hard"]["median"] is None
    bounded = {(r["executive"], r["episode_seed"], r["scenario"]): r
               for r in summary["bt"]["rows"]}
    assert bounded[("bt", 1, "hard")]["kinematic_bound_s"] == fake_bound(1)
    results = (chosen.out / "results.md").read_text()
    assert "## How far from the physical limit" in results
    assert "| bt | random | 2 | 55.0 | 1.30 | 1.46 |" in results
    assert "| baseline | random | 1 | 50.0 | 2.00 | 2.00 |" in results
    assert "| baseline | hard | 0 | – | – | – |" in results
    for directory in (chosen.out, tmp_path / "docs" / "images"):
        assert (directory / "results_bound.png").stat().st_size > 1000
    assert "](images/results_bound.png)" in (tmp_path / "docs" / "results.md").read_text()


def test_summary_of_rows_without_bounds_says_none() -> None:
    rows = [row("bt", "random", 0), row("baseline", "random", 0)]
    summary = summary_of(settings(Path("unused"), scenarios=("random",)), rows)
    assert summary["bt"]["time_over_bound"] == {"random": {
        "episodes": 0, "median": None, "p90": None, "median_bound_s": None}}


def test_the_command_reads_an_evaluation_directory_without_writing_to_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    evaluation = tmp_path / "evaluation"
    for executive, seed, sim_time in (("bt", 0, 55.0), ("bt", 1, 90.0), ("baseline", 0, 75.0)):
        episode = evaluation / executive / "random" / str(seed)
        episode.mkdir(parents=True)
        (episode / "episode.json").write_text(json.dumps(
            row(executive, "random", seed, sim_time_s=sim_time)))
    (evaluation / "bt" / "random" / "2").mkdir()
    (evaluation / "bt" / "random" / "2" / "episode.json").write_text('{"half written')
    before = sorted(path.name for path in evaluation.rglob("*"))
    assert main([str(evaluation), "--rows", str(tmp_path / "rows.json")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1:] == ["baseline random 1 50.0 1.5 1.5", "bt random 2 55.0 1.3 1.46"]
    assert sorted(path.name for path in evaluation.rglob("*")) == before
    rows = json.loads((tmp_path / "rows.json").read_text())
    assert sorted(r["kinematic_bound_s"] for r in rows) == [50.0, 50.0, 60.0]


@pytest.mark.parametrize("make", ["missing", "empty"])
def test_the_command_refuses_a_directory_without_episodes_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], make: str) -> None:
    directory = tmp_path / "evaluation"
    if make == "empty":
        directory.mkdir()
    with pytest.raises(SystemExit) as stop:
        main([str(directory)])
    assert stop.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and str(directory) in lines[0], lines
