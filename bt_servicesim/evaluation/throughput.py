"""Episodes per hour, warm against cold: the figures of ``benchmarks/throughput.py``, read.

The benchmark plays the same seeds twice with the evaluation's own machinery, a process pair
per episode (cold) and on warm pairs kept alive between episodes; with ``--json FILE`` it writes
what it measured there. ``evaluate --throughput FILE`` reads that file (:func:`load_throughput`,
which names what is wrong with a bad one in one line) so that ``results.md`` states how many
episodes an hour the machine played, beside the results those episodes gave
(:func:`throughput_section`). Wall-clock figures depend on the machine's load, so the section
gives the load the benchmark saw with them; the episodes themselves replay at any load.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bt_servicesim.evaluation.figures_file import read_figures

__all__ = ["ModeFigures", "Throughput", "load_throughput", "throughput_section"]

MODES = ("cold", "warm")


@dataclass(frozen=True)
class ModeFigures:
    """The benchmark's episodes played one way (``cold`` or ``warm``)."""

    mode: str
    episodes: int
    completed: int
    wall_s: float

    @property
    def episodes_per_hour(self) -> float:
        return self.episodes / self.wall_s * 3600.0


@dataclass(frozen=True)
class Throughput:
    command: str
    commit: str | None
    scenario: str
    executive: str
    jobs: int
    cores: int
    speed: float
    load_average: tuple[float, float]
    """The one-minute load average when the benchmark started and when it ended."""
    modes: tuple[ModeFigures, ...]
    agreeing: int
    """Episodes whose cold and warm reports agree on what an episode is judged by."""

    def mode(self, name: str) -> ModeFigures:
        return next(figures for figures in self.modes if figures.mode == name)


def load_throughput(path: Path) -> Throughput:
    """The benchmark's figures in ``path``; ``ValueError`` with one line naming the problem."""
    document = read_figures(path)
    try:
        result = _throughput(document)
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise ValueError(f"{path}: not the figures of benchmarks/throughput.py --json "
                         f"({type(error).__name__}: {error})") from error
    return result


def _throughput(document: dict[str, Any]) -> Throughput:
    modes = tuple(_mode(name, document[name]) for name in MODES)
    start, end = (float(value) for value in document["load_average"])
    result = Throughput(
        command=str(document["command"]),
        commit=None if document.get("commit") is None else str(document["commit"]),
        scenario=str(document["scenario"]), executive=str(document["executive"]),
        jobs=int(document["jobs"]), cores=int(document["cores"]),
        speed=float(document["speed"]), load_average=(start, end), modes=modes,
        agreeing=int(document["agreeing"]))
    if len({figures.episodes for figures in modes}) != 1:
        raise ValueError("cold and warm played different numbers of episodes")
    if not 0 <= result.agreeing <= modes[0].episodes:
        raise ValueError(f"{result.agreeing} agreeing reports of {modes[0].episodes} episodes")
    return result


def _mode(name: str, entry: dict[str, Any]) -> ModeFigures:
    figures = ModeFigures(mode=name, episodes=int(entry["episodes"]),
                          completed=int(entry["completed"]), wall_s=float(entry["wall_s"]))
    if figures.episodes < 1 or not 0 <= figures.completed <= figures.episodes:
        raise ValueError(f"{name}: {figures.completed} completed of {figures.episodes} episodes")
    if not figures.wall_s > 0.0:
        raise ValueError(f"{name}: wall time {figures.wall_s} s")
    return figures


def throughput_section(measured: Throughput | None) -> list[str]:
    """The report's lines: the benchmark's figures, or that they were not measured."""
    if measured is None:
        return ["Episodes per hour were not measured for this report (`evaluate --throughput "
                "FILE` states the figures of `benchmarks/throughput.py --json FILE`)."]
    commit = f"commit `{measured.commit}`" if measured.commit else "an unknown commit"
    start, end = measured.load_average
    cold, warm = measured.mode("cold"), measured.mode("warm")
    episodes = cold.episodes
    lines = [f"`{measured.command}` on {commit} played the same {episodes} "
             f"`{measured.scenario}` episodes ({measured.executive}, speed {measured.speed:g}) "
             f"twice, {measured.jobs} at once on {measured.cores} cores: a process pair per "
             "episode (cold), then on warm pairs kept alive between episodes (warm). The load "
             f"average was {start:g} at its start and {end:g} at its end: wall-clock figures "
             "follow the machine's load, where the episodes themselves do not.", "",
             "| episodes played | episodes | wall time (s) | episodes per hour | completed |",
             "|---|---|---|---|---|"]
    for figures in (cold, warm):
        lines.append(f"| {figures.mode} | {figures.episodes} | {figures.wall_s:.1f} | "
                     f"{figures.episodes_per_hour:.0f} | {figures.completed}/{figures.episodes} |")
    lines += ["", f"Warm played {warm.episodes_per_hour / cold.episodes_per_hour:.2f} times as "
              f"many episodes an hour as cold; the cold and warm reports agree on "
              f"{measured.agreeing} of {episodes} episodes (completed, checkpoint times, "
              "penalties, score)."]
    return lines
