"""results.md states the share of seeds that replay, from the reproducibility benchmark's JSON.

The figures are written the way ``benchmarks/reproducibility.py --json`` writes them (its own
``write_json``, on results its ``measure`` would return); bad files are refused in one line
before an evaluation starts.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from typing import Any

import pytest

from bt_servicesim.evaluation.reproducibility import (
    load_reproducibility,
    reproducibility_section,
)
from tests.evaluation.report_sections import report_section
from tests.evaluation.test_evaluate import evaluate_command

REPO = Path(__file__).resolve().parents[2]


def benchmark() -> Any:
    """benchmarks/reproducibility.py as a module (it is a script, not a package)."""
    spec = importlib.util.spec_from_file_location(
        "reproducibility_benchmark", REPO / "benchmarks" / "reproducibility.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def figures(tmp_path: Path, *, differing: bool = False) -> Path:
    script = benchmark()
    args = script.build_parser().parse_args(["--pairs", "20"])
    results = [
        {"set": "default", "speed": 0.0, "pairs": 20, "identical": 20, "completed_runs": 40,
         "runs": 40, "stalled_runs": 0, "wall_s": 600.0, "differing": []},
        {"set": "hard", "speed": 20.0, "pairs": 20, "identical": 19 if differing else 20,
         "completed_runs": 39, "runs": 40, "stalled_runs": 0, "wall_s": 900.0,
         "differing": [{"command": "python -m bt_servicesim.run --seed 7", "scores": [1, 2]}]
         if differing else []},
    ]
    path = tmp_path / "reproducibility.json"
    script.write_json(path, args, ["--pairs", "20", "--json", str(path)], results)
    return path


def test_the_benchmarks_figures_are_read_back_as_written(tmp_path: Path) -> None:
    measured = load_reproducibility(figures(tmp_path, differing=True))
    assert measured.command.startswith("python benchmarks/reproducibility.py --pairs 20")
    assert measured.timing == "lockstep"
    assert [(f.scenario, f.speed, f.identical, f.pairs) for f in measured.figures] == [
        ("default", 0.0, 20, 20), ("hard", 20.0, 19, 20)]
    assert measured.figures[1].differing == ("python -m bt_servicesim.run --seed 7",)
    assert len(measured.load_average) == 3


def test_the_report_states_the_share_and_the_pairs_that_differed(tmp_path: Path) -> None:
    measured = load_reproducibility(figures(tmp_path, differing=True))
    rows = [{"timing": "lockstep"}, {"timing": "lockstep"}, {"timing": "free running"}, {}]
    lines = "\n".join(reproducibility_section(rows, measured))
    assert "2 of 3 episodes that say how they were timed ran in lockstep throughout" in lines
    assert "left its guarantee" not in lines
    assert "| default | 0 | 20/20 | 100% | 40/40 |" in lines
    assert "| hard | 20 | 19/20 | 95% | 39/40 |" in lines
    assert "- `python -m bt_servicesim.run --seed 7`" in lines


def test_episodes_that_left_lockstep_on_the_way_are_counted_out_and_named() -> None:
    rows = [{"timing": "lockstep", "lockstep_stalls": 0, "lockstep_dropped": None},
            {"timing": "lockstep", "lockstep_stalls": 2, "executive": "bt",
             "scenario": "default", "seed": None},
            {"timing": "lockstep", "lockstep_stalls": 1, "executive": "bt",
             "scenario": "random", "seed": 4},
            {"timing": "lockstep", "lockstep_stalls": 0, "executive": "baseline",
             "scenario": "hard", "seed": 9,
             "lockstep_dropped": {"period": 8, "sim_time_s": 0.8}}]
    lines = "\n".join(reproducibility_section(rows, None))
    assert "1 of 4 episodes that say how they were timed ran in lockstep throughout" in lines
    assert "3 joined lockstep but left its guarantee" in lines
    assert "(bt default the shipped task, bt random seed 4, baseline hard seed 9)" in lines


def test_without_figures_the_report_says_the_share_was_not_measured() -> None:
    lines = "\n".join(reproducibility_section([{"timing": "lockstep"}], None))
    assert "1 of 1 episodes" in lines
    assert "was not measured for this report" in lines


def test_results_md_has_the_section(tmp_path: Path) -> None:
    section = report_section(tmp_path, heading="Reproducibility",
                             reproducibility=load_reproducibility(figures(tmp_path)))
    assert "| default | 0 | 20/20 | 100% | 40/40 |" in section


@pytest.mark.parametrize(
    ("content", "named"),
    [
        (None, "cannot be read"),
        ("{not json", "not JSON"),
        ('{"results": []}', "not the figures"),
        ('{"command": "c", "timing": "lockstep", "results": [{"set": "random"}]}',
         "not the figures"),
        ('{"command": "c", "timing": "lockstep", "results": []}', "holds no figures"),
        (json.dumps({"command": "c", "timing": "lockstep", "results": [
            {"set": "random", "speed": 0, "pairs": 2, "identical": 3, "completed_runs": 4,
             "runs": 4, "differing": []}]}), "3 identical of 2 pairs"),
    ],
)
def test_a_bad_figures_file_is_refused_in_one_line(tmp_path: Path, content: str | None,
                                                   named: str) -> None:
    path = tmp_path / "figures.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ValueError, match=named) as raised:
        load_reproducibility(path)
    assert "\n" not in str(raised.value)


def test_evaluate_refuses_a_bad_figures_file_before_starting(tmp_path: Path) -> None:
    (tmp_path / "figures.json").write_text("{not json")
    result = evaluate_command(tmp_path, "--out", "evaluation", "--reproducibility",
                              "figures.json")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--reproducibility figures.json: not JSON" in lines[0]
    assert not (tmp_path / "evaluation").exists()


def test_a_pair_that_differs_or_stalled_is_kept_for_a_look(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    script = benchmark()
    root = tmp_path / "pair"
    (root / "a").mkdir(parents=True)
    (root / "a.stderr").write_text("lockstep: joined without a writer for /odom")
    monkeypatch.chdir(tmp_path)
    same = {"completed": True, "checkpoints": [], "penalties": {}, "score": 1.0}
    assert script.keep_if_odd(root, same, dict(same), "random-speed0-0") is None
    kept = script.keep_if_odd(root, same, {**same, "lockstep_stalls": 1}, "random-speed20-3")
    assert kept is not None and kept.parent == tmp_path
    assert kept.name.startswith("reproducibility-kept-random-speed20-3-")
    assert (kept / "a.stderr").read_text().startswith("lockstep: joined without")
    assert script.keep_if_odd(root, same, {**same, "score": 2.0}, "x") is not None
