"""How far each mission ran from the physical limit: the task's kinematic bound, per episode.

Design intent: the bound of a task (the shortest route the rules allow at the robot's top
speed) needs the world and the scenario, which only the simulator knows; the executive's
package must not import the simulator, nor read what the executive may not know. So the
evaluation asks the simulator's own command, ``python -m servicesim_sim.task_bound``, once per
evaluation for every distinct task (world, seed, simulator arguments) its rows played, and
puts two fields in each row: ``kinematic_bound_s`` (every row whose task has a bound) and
``time_over_bound`` (completed episodes only: the mission time, the referee's task sim time at
the fourth checkpoint, over the bound). The bound is the same for every executive on the same
episode, so a paired comparison needs no more.

A failing bound command (a broken install, a world that moved) costs the report its bound
columns, never the evaluation: the rows keep no bound and :class:`Bounds` says why in a line.

``python -m bt_servicesim.evaluation.kinematic_bound DIR`` does the same for an evaluation
already run (its episodes' ``episode.json``; nothing in ``DIR`` is written) and prints the
median and 90th percentile of time over the bound per executive and set.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bt_servicesim.cli import EXIT_FAILED, EXIT_OK, OneLineArgumentParser, interruptible
from bt_servicesim.evaluation.scenarios import SCENARIO_SETS

BOUND_COMMAND = (sys.executable, "-m", "servicesim_sim.task_bound")
TIMEOUT_S = 3600.0  # wall seconds for all the bounds of an evaluation (about 2 s each)
#: Fewest tasks worth a process of their own: a process's start (its imports, the world, its
#: search lattice) costs about what a bound or two does, so a few tasks share one process.
TASKS_PER_PROCESS = 4
DEFAULT_WORLD = "default"  # what a run's report names the simulator's own office


@dataclass(frozen=True)
class TaskKey:
    """What makes a task: the world, the seed (None: the shipped task) and the sim args."""

    world: str | None
    seed: int | None
    sim_args: tuple[str, ...]

    def as_entry(self) -> dict[str, Any]:
        """The task as an entry of the bound command's ``--episodes`` file."""
        return {"world": self.world, "seed": self.seed, "sim_args": list(self.sim_args)}


@dataclass
class Bounds:
    """The bounds the command gave, by task, and why there are none, if so."""

    by_task: dict[TaskKey, dict[str, Any]] = field(default_factory=dict)
    problem: str | None = None


def task_key(row: dict[str, Any]) -> TaskKey | None:
    """The task an episode row played, or None if the row cannot tell (no set, no seed)."""
    scenario = SCENARIO_SETS.get(str(row.get("scenario")))
    key = row.get("episode_key") or {}
    if "sim_args" in key:
        sim_args = tuple(str(argument) for argument in key["sim_args"])
    elif scenario is not None:
        sim_args = scenario.sim_args
    else:
        return None
    seed = row.get("episode_seed", row.get("seed"))
    world = row.get("world")
    return TaskKey(world=None if world in (None, DEFAULT_WORLD) else str(world),
                   seed=None if seed is None else int(seed), sim_args=sim_args)


def request_bounds(keys: list[TaskKey], *, command: tuple[str, ...] | None = None,
                   timeout_s: float = TIMEOUT_S, jobs: int = 1) -> Bounds:
    """The bounds of ``keys`` from ``command`` (default :data:`BOUND_COMMAND`), run as up to
    ``jobs`` processes at once, each on an equal share of the tasks and none on fewer than
    :data:`TASKS_PER_PROCESS` unless there are fewer (a bound is about a CPU second: the
    evaluation's 600 episodes took 5 minutes on one core)."""
    if not keys:
        return Bounds()
    command = command or BOUND_COMMAND
    processes = max(1, min(jobs, math.ceil(len(keys) / TASKS_PER_PROCESS)))
    shares = [keys[start::processes] for start in range(processes)]
    with tempfile.TemporaryDirectory(prefix="task_bounds_") as directory:
        try:
            answers = _run_shares(command, shares, Path(directory), timeout_s)
        except _BoundCommandError as problem:
            return Bounds(problem=str(problem))
    return Bounds(by_task={key: answer for share, share_answers in zip(shares, answers,
                                                                        strict=True)
                           for key, answer in zip(share, share_answers, strict=True)})


class _BoundCommandError(Exception):
    """Why the bound command gave no bounds, in a line."""


def _run_shares(command: tuple[str, ...], shares: list[list[TaskKey]], directory: Path,
                timeout_s: float) -> list[list[Any]]:
    """Each share's answers, the shares' processes started together and all waited for."""
    processes = []
    try:
        for number, share in enumerate(shares):
            episodes = directory / f"episodes-{number}.json"
            episodes.write_text(json.dumps([key.as_entry() for key in share]))
            processes.append(subprocess.Popen(
                [*command, "--episodes", str(episodes)], stdout=subprocess.PIPE,
                stderr=subprocess.PIPE, text=True))
        outputs = [process.communicate(timeout=timeout_s) for process in processes]
    except (OSError, subprocess.TimeoutExpired) as error:
        raise _BoundCommandError(f"the bound command did not run: {error}") from error
    finally:
        for process in processes:  # none outlives the request, whatever happened
            if process.poll() is None:
                process.kill()
                process.wait()
    return [_answers(process.returncode, stdout, stderr, len(share))
            for process, (stdout, stderr), share in zip(processes, outputs, shares, strict=True)]


def _answers(returncode: int, stdout: str, stderr: str, expected: int) -> list[Any]:
    if returncode != 0:
        lines = stderr.strip().splitlines() or [f"exit status {returncode}"]
        raise _BoundCommandError(f"the bound command failed: {lines[-1]}")
    try:
        answers = json.loads(stdout)
    except json.JSONDecodeError as error:
        raise _BoundCommandError(f"the bound command printed no JSON ({error})") from error
    if not isinstance(answers, list) or len(answers) != expected:
        raise _BoundCommandError("the bound command answered for other episodes than asked")
    return answers


def with_bounds(rows: list[dict[str, Any]], bounds: Bounds) -> list[dict[str, Any]]:
    """Copies of the rows with ``kinematic_bound_s``, ``time_over_bound`` and the bound's legs
    (``kinematic_bound_legs``) where the task has a bound."""
    bounded = []
    for row in rows:
        key = task_key(row)
        answer = bounds.by_task.get(key) if key is not None else None
        row = dict(row)
        if answer is not None and float(answer["bound_s"]) > 0.0:
            bound = float(answer["bound_s"])
            row["kinematic_bound_s"] = bound
            row["kinematic_bound_legs"] = answer.get("legs")
            row["time_over_bound"] = (round(float(row["sim_time_s"]) / bound, 4)
                                      if row.get("completed") and row.get("sim_time_s")
                                      is not None else None)
        bounded.append(row)
    return bounded


def add_kinematic_bounds(rows: list[dict[str, Any]], *,
                         command: tuple[str, ...] | None = None, jobs: int = 1) -> tuple[
                             list[dict[str, Any]], str | None]:
    """The rows with their bounds (each distinct task asked once), and the problem, if any.

    Only played rows are asked for: an evaluation stopped at once writes its results at once."""
    played = [row for row in rows if not row.get("not_run")]
    keys = list(dict.fromkeys(key for key in map(task_key, played) if key is not None))
    bounds = request_bounds(keys, command=command, jobs=jobs)
    return with_bounds(rows, bounds), bounds.problem


# ------------------------------------------------------------------------------ the command
PROG = "python -m bt_servicesim.evaluation.kinematic_bound"


def rows_of(directory: Path) -> list[dict[str, Any]]:
    """The rows an evaluation directory holds: each finished episode's ``episode.json``."""
    rows = []
    for path in sorted(directory.glob("*/*/*/episode.json")):
        try:
            row = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            continue  # an episode still being written, or a broken file: not a finished row
        if isinstance(row, dict) and {"executive", "scenario", "completed"} <= set(row):
            rows.append(row)
    return rows


def bound_lines(rows: list[dict[str, Any]]) -> list[str]:
    """Per executive and set: completed episodes with a bound, median and p90 time over it."""
    from bt_servicesim.evaluation.summary import time_over_bound

    lines = ["executive set completed-with-bound median-bound-s median p90"]
    for executive, scenario in sorted({(row["executive"], row["scenario"]) for row in rows}):
        figures = time_over_bound([row for row in rows if row["executive"] == executive
                                   and row["scenario"] == scenario])
        lines.append(f"{executive} {scenario} {figures['episodes']} {figures['median_bound_s']} "
                     f"{figures['median']} {figures['p90']}")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bt_servicesim.evaluation.kinematic_bound DIR [--rows FILE]``: time over the
    bound of an evaluation's finished episodes, read from ``DIR`` (never written to); ``--rows``
    writes the rows with their bounds as JSON."""
    parser = OneLineArgumentParser(prog=PROG, description=main.__doc__)
    parser.add_argument("directory", type=Path, help="an evaluation's --out directory")
    parser.add_argument("--rows", type=Path, help="write the rows with their bounds here")
    args = parser.parse_args(argv)
    if not args.directory.is_dir():
        parser.error(f"{args.directory}: not a directory")
    rows = rows_of(args.directory)
    if not rows:
        parser.error(f"{args.directory}: no finished episode (no */*/*/episode.json)")
    rows, problem = add_kinematic_bounds(rows, jobs=os.cpu_count() or 1)
    if problem:
        print(f"{PROG}: error: {problem}", file=sys.stderr)
        return EXIT_FAILED
    if args.rows is not None:
        args.rows.write_text(json.dumps(rows, indent=1) + "\n")
    print("\n".join(bound_lines(rows)))
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(interruptible(PROG, main))
