"""Does a seed replay? The figures of ``benchmarks/reproducibility.py``, read for the report.

The benchmark plays each seed twice at once and compares the two ``report.json`` by what an
episode is judged by; with ``--json FILE`` it writes its figures there. ``evaluate
--reproducibility FILE`` reads that file (:func:`load_reproducibility`, which names what is
wrong with a bad one in one line) so that ``results.md`` states the share of identical pairs
next to the results it qualifies (:func:`reproducibility_section`), together with how many of
the evaluation's own episodes ran in lockstep.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bt_servicesim.evaluation.figures_file import read_figures
from bt_servicesim.mission.report import left_lockstep

__all__ = ["PairFigures", "Reproducibility", "load_reproducibility", "reproducibility_section"]


@dataclass(frozen=True)
class PairFigures:
    """One scenario set at one speed: how many pairs of runs agreed."""

    scenario: str
    speed: float
    pairs: int
    identical: int
    completed_runs: int
    runs: int
    differing: tuple[str, ...]
    """The ``run`` commands of the pairs that differed."""


@dataclass(frozen=True)
class Reproducibility:
    command: str
    timing: str
    commit: str | None
    load_average: tuple[float, ...]
    figures: tuple[PairFigures, ...]


def load_reproducibility(path: Path) -> Reproducibility:
    """The benchmark's figures in ``path``; ``ValueError`` with one line naming the problem."""
    document = read_figures(path)
    try:
        figures = tuple(_pair_figures(entry) for entry in document["results"])
        result = Reproducibility(
            command=str(document["command"]), timing=str(document["timing"]),
            commit=None if document.get("commit") is None else str(document["commit"]),
            load_average=tuple(float(value) for value in document.get("load_average", ())),
            figures=figures)
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{path}: not the figures of benchmarks/reproducibility.py --json "
                         f"({type(error).__name__}: {error})") from error
    if not figures:
        raise ValueError(f"{path}: holds no figures (the benchmark measured nothing)")
    return result


def _pair_figures(entry: dict[str, Any]) -> PairFigures:
    figures = PairFigures(
        scenario=str(entry["set"]), speed=float(entry["speed"]), pairs=int(entry["pairs"]),
        identical=int(entry["identical"]), completed_runs=int(entry["completed_runs"]),
        runs=int(entry["runs"]),
        differing=tuple(str(pair["command"]) for pair in entry["differing"]))
    if not 0 <= figures.identical <= figures.pairs or figures.pairs < 1:
        raise ValueError(f"{figures.identical} identical of {figures.pairs} pairs")
    return figures


def reproducibility_section(rows: list[dict[str, Any]],
                            measured: Reproducibility | None) -> list[str]:
    """The report's lines: the episodes' timing, then the benchmark's figures if given."""
    timed = [row for row in rows if row.get("timing")]
    lockstep = [row for row in timed if row["timing"] == "lockstep"]
    left = [row for row in lockstep if left_lockstep(row)]
    lines = [f"{len(lockstep) - len(left)} of {len(timed)} episodes that say how they were "
             "timed ran in lockstep throughout, where the same world, seed, knobs, tree and "
             "code play the same mission at any speed and load.", ""]
    if left:
        named = ", ".join(f"{row.get('executive')} {row.get('scenario')} "
                          + ("the shipped task" if row.get("seed") is None
                             else f"seed {row.get('seed')}") for row in left)
        lines += [f"{len(left)} joined lockstep but left its guarantee on the way (a period "
                  "ticked without every message after 10 s of wall time, or the simulator "
                  f"went on without the run and it ran free): they may not replay ({named}).",
                  ""]
    if measured is None:
        return [*lines, "The share of seeds that replay was not measured for this report "
                "(`evaluate --reproducibility FILE` states the figures of "
                "`benchmarks/reproducibility.py --json FILE`)."]
    load = ", ".join(f"{value:g}" for value in measured.load_average) or "not recorded"
    commit = f"commit `{measured.commit}`" if measured.commit else "an unknown commit"
    lines += [f"`{measured.command}` on {commit} ({measured.timing}; load average at its end "
              f"{load}) played every seed twice at once and compared the two reports by "
              "what an episode is judged by (completed, checkpoint times, penalties, score):",
              "", "| set | speed | identical pairs | share | runs completed |",
              "|---|---|---|---|---|"]
    for figures in measured.figures:
        lines.append(f"| {figures.scenario} | {figures.speed:g} | {figures.identical}/"
                     f"{figures.pairs} | {figures.identical / figures.pairs:.0%} | "
                     f"{figures.completed_runs}/{figures.runs} |")
    differing = [command for figures in measured.figures for command in figures.differing]
    if differing:
        lines += ["", "Pairs that differed (each command played twice):", "",
                  *(f"- `{command}`" for command in differing)]
    return lines
