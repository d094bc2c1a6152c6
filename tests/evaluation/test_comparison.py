"""Two evaluations against each other: rows paired by set and seed, whatever each evaluation's
``--seed``, and bad directories refused in one line. Summaries are written by hand as an
evaluation writes them (``summary.json``: each executive's figures and rows)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

from bt_servicesim.evaluation.comparison import comparison_lines, paired_rows

PROG = "python -m bt_servicesim.evaluation.comparison"


def row(scenario: str, seed: int, score: float, *, completed: bool = True,
        not_run: bool = False, episode: int = 0) -> dict[str, Any]:
    checkpoints = [{"name": name, "done": completed, "sim_time_s": 10.0 * (index + 1)}
                   for index, name in enumerate(("go_to_pick_up", "pick_up_guest",
                                                 "drop_off_guest", "return_to_start"))]
    return {"executive": "bt", "scenario": scenario, "episode": episode, "episode_seed": seed,
            "seed": seed, "completed": completed, "score": score, "checkpoints": checkpoints,
            "not_run": not_run, "revision": "commit `abc1234`"}


def evaluation(directory: Path, rows: list[dict[str, Any]],
               nav_params: dict[str, str] | None = None) -> Path:
    directory.mkdir(parents=True)
    entry = {"episodes": len(rows), "rows": rows, "nav_params": nav_params}
    (directory / "summary.json").write_text(json.dumps({"bt": entry, "baseline": entry}))
    return directory


def compare(*arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "bt_servicesim.evaluation.comparison",
                           *arguments], capture_output=True, text=True, timeout=60)


def test_episodes_pair_by_set_and_seed_not_by_their_place_in_each_evaluation() -> None:
    # one evaluation from --seed 0, the other from --seed 1: seed 1 is episode 1, then 0
    before = [row("random", 0, 100.0, episode=0), row("random", 1, 200.0, episode=1),
              row("hard", 1, 900.0, episode=1)]
    after = [row("random", 1, 150.0, episode=0), row("random", 2, 50.0, episode=1),
             row("hard", 1, 800.0, episode=0)]
    rows, scenarios, only_one = paired_rows(before, after)
    assert scenarios == ["random", "hard"]
    assert only_one == 2  # random 0 (before only) and random 2 (after only)
    pairs = {(r["executive"], r["scenario"], r["episode"]): r["score"] for r in rows}
    assert pairs == {("before", "random", 1): 200.0, ("after", "random", 1): 150.0,
                     ("before", "hard", 1): 900.0, ("after", "hard", 1): 800.0}


def test_the_table_counts_who_did_better_with_its_p_value(tmp_path: Path) -> None:
    seeds = range(6)
    before = evaluation(tmp_path / "before", [row("random", s, 100.0 + s) for s in seeds],
                        nav_params={"file": "trees/servicesim_nav2_params.yaml",
                                    "sha256": "552a3877dab6d16b" + "0" * 48})
    after = evaluation(tmp_path / "after",
                       [row("random", s, 50.0 + s, completed=s != 5) for s in seeds]
                       + [row("random", 9, 1.0, not_run=True)])
    lines = comparison_lines(before, after)
    text = "\n".join(lines)
    assert "navigation `trees/servicesim_nav2_params.yaml` (SHA-256 552a3877dab6d16b)" in text
    assert "the servicebot's navigation" in text  # the after evaluation named none
    assert "Paired over 6 missions" in text
    (random,) = [line for line in lines if line.startswith("| random |")]
    cells = [cell.strip() for cell in random.strip("|").split("|")]
    assert cells[1] == "1 / 0 (p 1)"  # seed 5 completed before only
    assert cells[2] == "5"  # both completed seeds 0-4
    assert (cells[3], cells[4]) == ("102.0", "52.0")
    assert cells[5] == "0/5 (p 0.062)"  # before lower on none of the five


def test_a_directory_without_a_summary_or_the_executive_is_one_line_exit_2(
        tmp_path: Path) -> None:
    good = evaluation(tmp_path / "good", [row("random", 0, 1.0)])
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "summary.json").write_text("{not json")
    (tmp_path / "odd").mkdir()
    (tmp_path / "odd" / "summary.json").write_text('{"bt": {"rows": [{"seed": 3}]}}')
    for arguments, named in (
            ([str(tmp_path / "missing"), str(good)], "missing/summary.json: cannot read it"),
            ([str(good), str(tmp_path / "broken")], "broken/summary.json: not JSON"),
            ([str(tmp_path / "odd"), str(good)],
             "odd/summary.json: bt's rows are not as an evaluation writes them (no scenario)"),
            ([str(good), str(good), "--executive", "bt:mine"],
             "no rows of the 'bt:mine' executive (it has: baseline, bt)"),
            ([str(good)], "the following arguments are required: after")):
        result = compare(*arguments)
        lines = result.stderr.strip().splitlines()
        assert result.returncode == 2 and len(lines) == 1, result.stderr
        assert lines[0].startswith(f"{PROG}: error: ") and named in lines[0], lines[0]
        assert result.stdout == ""


def test_two_evaluations_of_other_seeds_have_nothing_to_compare(tmp_path: Path) -> None:
    before = evaluation(tmp_path / "before", [row("random", 0, 1.0)])
    after = evaluation(tmp_path / "after", [row("random", 7, 1.0), row("hard", 0, 1.0)])
    result = compare(str(before), str(after))
    assert result.returncode == 2
    assert "have no mission in common" in result.stderr and result.stderr.count("\n") == 1
    assert sorted(p.name for p in before.iterdir()) == ["summary.json"]  # nothing written
