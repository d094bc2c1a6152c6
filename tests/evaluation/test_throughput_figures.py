"""results.md states episodes per hour, warm and cold, from the throughput benchmark's JSON.

The figures are written the way ``benchmarks/throughput.py --json`` writes them (its own
``figures``, on rows like those its episodes return, and ``write_figures``); bad files are
refused in one line before an evaluation starts.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from typing import Any

import pytest

from bt_servicesim.evaluation.figures_file import write_figures
from bt_servicesim.evaluation.report import revision_note
from bt_servicesim.evaluation.throughput import load_throughput, throughput_section
from tests.commands.test_benchmark_arguments import refused_in_one_line
from tests.evaluation.report_sections import report_section
from tests.evaluation.test_evaluate import evaluate_command

REPO = Path(__file__).resolve().parents[2]
BENCHMARK = REPO / "benchmarks" / "throughput.py"


def benchmark() -> Any:
    """benchmarks/throughput.py as a module (it is a script, not a package)."""
    spec = importlib.util.spec_from_file_location("throughput_benchmark", BENCHMARK)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def row(seed: int, *, completed: bool = True, score: float = 100.0) -> dict[str, Any]:
    return {"episode_seed": seed, "completed": completed, "score": score, "penalties": {},
            "checkpoints": [{"done": completed, "sim_time_s": 10.0}]}


def figures(tmp_path: Path, *, warm_differs: bool = False) -> Path:
    script = benchmark()
    argv = ["--episodes", "4", "--json", "figures.json"]
    args = script.build_parser().parse_args(argv)
    cold = [row(0), row(1), row(2, completed=False), row(3)]
    warm = [row(0), row(1, score=101.0 if warm_differs else 100.0), row(2, completed=False),
            row(3)]
    document = script.figures(args, argv, load_start=1.5,
                              modes={"cold": (cold, 36.0), "warm": (warm, 18.0)})
    path = tmp_path / "figures.json"
    write_figures(path, document)
    return path


def test_the_benchmarks_figures_are_read_back_as_written(tmp_path: Path) -> None:
    measured = load_throughput(figures(tmp_path, warm_differs=True))
    assert measured.command == "python benchmarks/throughput.py --episodes 4 --json figures.json"
    assert (measured.scenario, measured.executive, measured.jobs, measured.speed) == (
        "random", "bt", 2, 0.0)
    assert measured.load_average[0] == 1.5
    cold, warm = measured.mode("cold"), measured.mode("warm")
    assert (cold.episodes, cold.completed, cold.wall_s) == (4, 3, 36.0)
    assert cold.episodes_per_hour == pytest.approx(400.0)
    assert warm.episodes_per_hour == pytest.approx(800.0)
    assert measured.agreeing == 3
    assert [entry.name for entry in tmp_path.iterdir()] == ["figures.json"]  # no temporary


def test_the_section_states_both_modes_their_ratio_and_the_load(tmp_path: Path) -> None:
    lines = "\n".join(throughput_section(load_throughput(figures(tmp_path))))
    assert "| cold | 4 | 36.0 | 400 | 3/4 |" in lines
    assert "| warm | 4 | 18.0 | 800 | 3/4 |" in lines
    assert "2.00 times as many episodes an hour" in lines
    assert "agree on 4 of 4 episodes" in lines
    assert "load average was 1.5 at its start" in lines


def test_without_figures_the_section_says_they_were_not_measured() -> None:
    assert "were not measured for this report" in "\n".join(throughput_section(None))


def test_results_md_has_the_section(tmp_path: Path) -> None:
    section = report_section(tmp_path, heading="Episodes per hour",
                             throughput=load_throughput(figures(tmp_path)))
    assert "| warm | 4 | 18.0 | 800 | 3/4 |" in section


def good() -> dict[str, Any]:
    return {"command": "c", "commit": None, "scenario": "random", "executive": "bt", "jobs": 2,
            "cores": 2, "speed": 0, "load_average": [1, 2], "agreeing": 2,
            "cold": {"episodes": 2, "completed": 2, "wall_s": 10.0},
            "warm": {"episodes": 2, "completed": 2, "wall_s": 5.0}}


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"warm": None}, "not the figures"),
        ({"cold": {"episodes": 2}}, "not the figures"),
        ({"load_average": [1]}, "not the figures"),
        ({"warm": {"episodes": 3, "completed": 2, "wall_s": 5.0}}, "different numbers"),
        ({"cold": {"episodes": 2, "completed": 3, "wall_s": 5.0}}, "3 completed of 2"),
        ({"warm": {"episodes": 2, "completed": 2, "wall_s": 0.0}}, "wall time 0.0 s"),
        ({"agreeing": 5}, "5 agreeing reports of 2"),
    ],
)
def test_a_bad_figures_file_is_refused_in_one_line(tmp_path: Path, change: dict[str, Any],
                                                   named: str) -> None:
    path = tmp_path / "figures.json"
    path.write_text(json.dumps({**good(), **change}))
    with pytest.raises(ValueError, match=named) as raised:
        load_throughput(path)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize(("content", "named"), [(None, "cannot be read"),
                                                ("{not json", "not JSON"),
                                                ("[]", "not the figures")])
def test_an_unreadable_figures_file_is_refused_in_one_line(tmp_path: Path, content: str | None,
                                                           named: str) -> None:
    path = tmp_path / "figures.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ValueError, match=named):
        load_throughput(path)


def test_evaluate_refuses_a_bad_figures_file_before_starting(tmp_path: Path) -> None:
    (tmp_path / "figures.json").write_text("{not json")
    result = evaluate_command(tmp_path, "--out", "evaluation", "--throughput", "figures.json")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--throughput figures.json: not JSON" in lines[0]
    assert not (tmp_path / "evaluation").exists()


@pytest.mark.parametrize(("arguments", "named"), [
    (["--json", "/nowhere/figures.json"], "--json /nowhere/figures.json: its directory does not"),
    (["--json", "/tmp"], "--json /tmp: is a directory"),
    (["--episodes", "0"], "--episodes must be 1 or more"),
])
def test_the_benchmark_refuses_bad_arguments_in_one_line(arguments: list[str],
                                                         named: str) -> None:
    refused_in_one_line(BENCHMARK, arguments, named)



def test_results_md_names_the_checkout_the_episodes_were_played_on() -> None:
    """The report is written at the end; a checkout changed meanwhile is not the one that played
    the episodes, and results.md says which did."""
    rows = [{"executive": "bt", "revision": "commit `aaa`"},
            {"executive": "baseline", "revision": "commit `aaa`"}]
    assert revision_note(rows, "commit `bbb`") == (
        " (the episodes were played on another checkout: baseline episodes on commit `aaa`: 1, "
        "bt episodes on commit `aaa`: 1)")
    assert revision_note(rows, "commit `aaa`") == ""
    resumed = [{**rows[0], "resumed": True}, {**rows[1], "revision": "commit `bbb`"}]
    assert revision_note(resumed, "commit `bbb`").startswith(
        " (1 episodes kept from an earlier run with --resume; baseline episodes on commit `bbb`")


def test_episodes_whose_reports_disagree_are_kept_for_a_look(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A seed that did not replay is evidence: copied out of the benchmark's temporary
    directory (or named where --out keeps it)."""
    script = benchmark()
    rows = []
    for mode in ("cold", "warm"):
        (tmp_path / mode).mkdir()
        (tmp_path / mode / "report.json").write_text(f'{{"mode": "{mode}"}}')
        rows.append({"out": str(tmp_path / mode), "episode_seed": 13})
    monkeypatch.chdir(tmp_path)
    said = script.keep(*rows, script.build_parser().parse_args([]))
    kept = Path(said.removeprefix("both kept in "))
    assert kept.parent == tmp_path and kept.name.startswith("throughput-disagreed-seed13-")
    assert (kept / "warm" / "report.json").read_text() == '{"mode": "warm"}'
    assert (kept / "cold" / "report.json").read_text() == '{"mode": "cold"}'
    named = script.keep(*rows, script.build_parser().parse_args(["--out", "somewhere"]))
    assert named == f"kept in {tmp_path / 'cold'} and {tmp_path / 'warm'}"
