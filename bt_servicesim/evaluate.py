"""``python -m bt_servicesim.evaluate``: many seeded missions per executive, side by side.

The claim of this project is that the behaviour tree completes missions the seed's state machine
does not, faster and with a lower score. Evaluation checks that claim with numbers: for every
scenario set and episode number it runs *each* executive on the *same* seed, each episode a
``python -m bt_servicesim.run --headless`` subprocess (its own simulator, its own run directory)
with a ROS domain of its own, several at once. It writes

* ``summary.json``: per executive, ``episodes``, ``success_rate``, ``mean_score``,
  ``median_score``, ``mean_sim_time_s``, ``penalties``, ``wall_time_s`` and ``rows`` (every
  episode's ``report.json``, with its scenario set and episode number added);
* ``results.md``: the tables (per executive and set; paired: scores where both completed,
  times to the drop-off where both got there; failure reasons), the plots and the exact
  command; ``results_*.png``: the plots.

An episode is never dropped: one that outlives its wall-time limit is stopped (SIGINT, so the
run stops its simulator and writes its report, then SIGKILL for whatever is left) and recorded
as failed with the reason; one that crashes is recorded with its exit code and last error line.
Statistics are defined in ``docs/evaluation.md``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from queue import Queue
from typing import Any, NoReturn, TextIO

from bt_servicesim.ros_environment import apply_localhost_defaults

PROG = "python -m bt_servicesim.evaluate"
EXIT_OK, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 2, 130
EXECUTIVES = ("bt", "baseline")
#: Episodes run at 20x real time by default, not flat out: at speed 0 the simulator runs as
#: fast as its core allows and never waits for the executive, which needs about as much CPU
#: per sim second; with a few episodes at once on a small machine the executive then falls
#: sim seconds behind (a guest "out of range for 20 s" at the first look), and the evaluation
#: measures the machine's load instead of the mission logic.
DEFAULT_SPEED = 20.0
DOMAIN_SPAN = 101  # ROS_DOMAIN_ID 1..101; 0 is left to the user's own graph
STOP_GRACE_S = 10.0  # wall seconds a stopped episode gets to write its report
REPORT_NAME = "report.json"
EPISODE_CPU_S_PER_SIM_S = 0.027
"""CPU seconds an episode spends per sim second, simulator and executive together (measured
with ``benchmarks/sim_rtf.py`` at speed 50: about 13 ms each)."""
EPISODE_NAME = "episode.json"  # the episode's row, kept for --resume
INTERRUPTED = "evaluation interrupted"
PARENT_FIELD, START_TIME_FIELD = 4, 22  # of /proc/<pid>/stat
PENALTY_KEYS = ("failed_pickup", "failed_dropoff", "too_fast", "drifts", "contact",
                "approximation")


# ============================================================================ scenario sets
@dataclass(frozen=True)
class ScenarioSet:
    """How the episodes of one set are run: seeded or the shipped task, extra simulator args."""

    name: str
    seeded: bool
    sim_args: tuple[str, ...] = ()
    description: str = ""


SCENARIO_SETS = {
    scenario.name: scenario for scenario in (
        ScenarioSet("default", seeded=False, description="the shipped task"),
        ScenarioSet("random", seeded=True, description="seeded random tasks"),
        ScenarioSet("hard", seeded=True, sim_args=("--difficulty", "hard"),
                    description="seeded random tasks, every difficulty knob turned up"),
    )
}


# ============================================================================ settings
class UsageError(ValueError):
    """Bad command-line input; the message is the one line the user sees."""


class OneLineArgumentParser(argparse.ArgumentParser):
    """argparse, but errors are a single line and exit 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


@dataclass(frozen=True)
class EvaluationSettings:
    episodes: int
    scenarios: tuple[str, ...]
    executives: tuple[str, ...]
    jobs: int
    seed: int
    out: Path
    speed: float
    episode_timeout_s: float
    time_limit_s: float
    docs: Path | None
    command_line: str
    resume: bool = False


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description=(
        "Run seeded missions for each executive on the same seeds and compare them."))
    parser.add_argument("--episodes", type=int, default=10, help="episodes per scenario set")
    parser.add_argument("--scenarios", default="default,random,hard",
                        help="comma list of scenario sets: default, random, hard")
    parser.add_argument("--executive", default="bt,baseline",
                        help="comma list of executives: bt, baseline")
    parser.add_argument("--jobs", type=int, default=2, help="episodes run at once")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the first episode; episode n plays seed+n")
    parser.add_argument("--out", type=Path, required=True, help="evaluation directory")
    parser.add_argument("--speed", type=float, default=DEFAULT_SPEED,
                        help=f"sim speed of every episode (default {DEFAULT_SPEED:g}; 0: as fast "
                             "as possible, which lets a busy executive fall behind)")
    parser.add_argument("--episode-timeout", type=float, default=600.0,
                        help="wall seconds before an episode is stopped and failed (default 600)")
    parser.add_argument("--time-limit", type=float, default=900.0,
                        help="mission time limit in sim seconds (default 900)")
    parser.add_argument("--docs", type=Path,
                        help="also write results.md here, with the plots in <docs>/images/")
    parser.add_argument("--resume", action="store_true",
                        help="keep the episodes an earlier evaluation in --out finished with "
                             "the same executive, scenario, seed, speed and time limit; run "
                             "only the rest")
    return parser


def settings_from(args: argparse.Namespace, argv: Sequence[str]) -> EvaluationSettings:
    """Check every argument before anything starts."""
    scenarios = _names(args.scenarios, "--scenarios", SCENARIO_SETS)
    executives = _names(args.executive, "--executive", EXECUTIVES)
    _check(args.episodes >= 1, f"--episodes {args.episodes}: must be 1 or more")
    _check(1 <= args.jobs <= DOMAIN_SPAN, f"--jobs {args.jobs}: must be within 1..{DOMAIN_SPAN}")
    _check(args.seed >= 0, f"--seed {args.seed}: must be 0 or more")
    _check(args.speed >= 0.0, f"--speed {args.speed}: must be 0 or more")
    _check(args.episode_timeout > 0.0,
           f"--episode-timeout {args.episode_timeout}: must be more than 0")
    _check(args.time_limit > 0.0, f"--time-limit {args.time_limit}: must be more than 0")
    for flag, path in (("--out", args.out), ("--docs", args.docs)):
        _check(path is None or not path.exists() or path.is_dir(),
               f"{flag} {path}: exists and is not a directory")
    return EvaluationSettings(
        episodes=args.episodes, scenarios=scenarios, executives=executives, jobs=args.jobs,
        seed=args.seed, out=args.out, speed=args.speed, episode_timeout_s=args.episode_timeout,
        time_limit_s=args.time_limit, docs=args.docs,
        command_line=" ".join([PROG, *(shlex.quote(arg) for arg in argv)]),
        resume=args.resume,
    )


def load_warning(*, jobs: int, speed: float, cores: int) -> str | None:
    """Why these settings will overload the machine, or None.

    An episode at speed X needs about X times :data:`EPISODE_CPU_S_PER_SIM_S` of CPU per wall
    second (simulator and executive together); past the machine's cores the executives fall
    behind the worlds they steer (they tick late, then seconds apart), and the results measure
    the machine rather than the mission logic.
    """
    if speed <= 0.0:  # each simulator runs flat out on a core, its executive beside it
        if 2 * jobs <= cores:
            return None
        need_text = f"--jobs {jobs} at --speed 0 keeps {2 * jobs} processes busy"
    else:
        needed = jobs * speed * EPISODE_CPU_S_PER_SIM_S
        if needed <= cores:
            return None
        need_text = f"--jobs {jobs} at --speed {speed:g} needs about {needed:.1f} cores"
    return (f"{need_text}; this machine has {cores}: the executives will lag behind their "
            f"simulators (use fewer --jobs or a lower --speed)")


def _names(value: str, flag: str, known: Iterable[str]) -> tuple[str, ...]:
    names = tuple(name.strip() for name in value.split(","))
    for name in names:
        _check(name in known, f"{flag} {value}: unknown name {name!r} "
                              f"(choose from {', '.join(known)})")
    _check(len(set(names)) == len(names), f"{flag} {value}: a name is repeated")
    return names


def _check(condition: bool, message: str) -> None:
    if not condition:
        raise UsageError(message)


# ============================================================================ episodes
@dataclass(frozen=True)
class Episode:
    """One mission: an executive on one scenario of one set."""

    executive: str
    scenario: str
    index: int
    seed: int | None
    out: Path

    @property
    def label(self) -> str:
        seed = "shipped task" if self.seed is None else f"seed {self.seed}"
        return f"{self.executive} {self.scenario} #{self.index} ({seed})"


EpisodeCommand = Callable[[Episode, EvaluationSettings], list[str]]


def plan_episodes(settings: EvaluationSettings) -> list[Episode]:
    """Episode n of every set, for every executive, before episode n+1: partial runs compare."""
    return [
        Episode(executive=executive, scenario=scenario, index=index,
                seed=settings.seed + index if SCENARIO_SETS[scenario].seeded else None,
                out=settings.out / executive / scenario / str(index))
        for index in range(settings.episodes)
        for scenario in settings.scenarios
        for executive in settings.executives
    ]


def run_command(episode: Episode, settings: EvaluationSettings) -> list[str]:
    """The run command for one episode."""
    command = [sys.executable, "-m", "bt_servicesim.run", "--headless",
               "--out", str(episode.out), "--executive", episode.executive,
               "--speed", repr(settings.speed), "--time-limit", repr(settings.time_limit_s)]
    if episode.seed is not None:
        command += ["--seed", str(episode.seed)]
    for argument in SCENARIO_SETS[episode.scenario].sim_args:
        command.append(f"--sim-arg={argument}")
    return command


@dataclass
class EpisodeOutcome:
    """What happened to the episode's process."""

    returncode: int | None
    wall_time_s: float
    stopped: str | None = None  # why the evaluation stopped it, if it did


class EpisodeRunner:
    """Runs episodes as subprocesses within a wall-time limit; stops them all on request."""

    def __init__(self, settings: EvaluationSettings, command: EpisodeCommand) -> None:
        self.settings = settings
        self.command = command
        self.stopping = threading.Event()
        self.revision = source_revision()

    def run(self, episode: Episode, domain_id: int) -> dict[str, Any]:
        """Run the episode in ROS domain ``domain_id``; its row for the summary."""
        if self.settings.resume and (kept := self.finished_row(episode)) is not None:
            return kept
        if episode.out.exists():
            shutil.rmtree(episode.out)  # a stale report must never pass for this episode's
        episode.out.mkdir(parents=True)
        if self.stopping.is_set():
            return episode_row(episode, EpisodeOutcome(None, 0.0, INTERRUPTED), domain_id)
        outcome = self._run_process(episode, domain_id)
        row = episode_row(episode, outcome, domain_id)
        row.update(revision=self.revision, episode_key=self.key(episode))
        if outcome.stopped != INTERRUPTED:
            (episode.out / EPISODE_NAME).write_text(json.dumps(row, indent=1) + "\n")
        return row

    def key(self, episode: Episode) -> dict[str, Any]:
        """What makes two runs of an episode the same episode."""
        return {"executive": episode.executive, "scenario": episode.scenario,
                "seed": episode.seed, "sim_args": list(SCENARIO_SETS[episode.scenario].sim_args),
                "speed": self.settings.speed, "time_limit_s": self.settings.time_limit_s}

    def finished_row(self, episode: Episode) -> dict[str, Any] | None:
        """The row an earlier evaluation kept for this very episode, if any."""
        try:
            row = json.loads((episode.out / EPISODE_NAME).read_text())
        except (OSError, ValueError):
            return None
        if not isinstance(row, dict) or row.get("episode_key") != self.key(episode):
            return None
        return dict(row, resumed=True)

    def _run_process(self, episode: Episode, domain_id: int) -> EpisodeOutcome:
        environment = dict(os.environ, ROS_DOMAIN_ID=str(domain_id))
        apply_localhost_defaults(environment)
        started = time.monotonic()
        with (episode.out / "run.log").open("wb") as log:
            process = subprocess.Popen(
                self.command(episode, self.settings), stdout=log, stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL, env=environment, start_new_session=True)
            stopped = self._wait(process, started + self.settings.episode_timeout_s)
        return EpisodeOutcome(process.returncode, time.monotonic() - started, stopped)

    def _wait(self, process: subprocess.Popen[bytes], deadline: float) -> str | None:
        while True:
            try:
                process.wait(timeout=0.25)
                return None
            except subprocess.TimeoutExpired:
                pass
            if self.stopping.is_set():
                stop_process_tree(process)
                return INTERRUPTED
            if time.monotonic() > deadline:
                stop_process_tree(process)
                return (f"episode wall-time limit of {self.settings.episode_timeout_s:g} s "
                        "exceeded; stopped")


def stop_process_tree(process: subprocess.Popen[bytes]) -> None:
    """SIGINT the episode (it then stops its simulator), then SIGKILL whatever is left.

    The run starts its simulator in a session of its own, so the tree is collected from
    ``/proc`` before anything is signalled; a process is only killed if it is still the one
    that was collected (same pid and start time).
    """
    family = [process.pid, *descendants(process.pid)]
    identities = {pid: start_time(pid) for pid in family}
    _signal(process.pid, signal.SIGINT)
    with contextlib.suppress(subprocess.TimeoutExpired):
        process.wait(timeout=STOP_GRACE_S)
    for pid in family:
        if identities[pid] is not None and start_time(pid) == identities[pid]:
            _signal(pid, signal.SIGKILL)
    process.wait()


def descendants(pid: int) -> list[int]:
    """Every process below ``pid``, found through ``/proc/<pid>/stat`` parent ids."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            parent = _stat_field(int(entry.name), PARENT_FIELD)
            if parent is not None:
                children.setdefault(parent, []).append(int(entry.name))
    found, frontier = [], [pid]
    while frontier:
        below = children.get(frontier.pop(), [])
        found += below
        frontier += below
    return found


def start_time(pid: int) -> int | None:
    """The process's start time in clock ticks since boot; None if it is gone."""
    return _stat_field(pid, START_TIME_FIELD)


def _stat_field(pid: int, number: int) -> int | None:
    """Field ``number`` (1-based, as proc(5) counts) of ``/proc/<pid>/stat``."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    after_name = text[text.rfind(")") + 2:].split()  # the name (field 2) may hold spaces
    return int(after_name[number - 3])


def _signal(pid: int, signal_number: int) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal_number)


def episode_row(episode: Episode, outcome: EpisodeOutcome, domain_id: int) -> dict[str, Any]:
    """The run's report.json (or a failed stand-in), with where it belongs in the evaluation."""
    report = _read_report(episode.out / REPORT_NAME)
    row = report if report is not None else _missing_report(episode, outcome)
    if outcome.stopped is not None:
        row["completed"] = False
        row["failure"] = outcome.stopped
    # Ctrl-C stopped it or it never started: no verdict on the executive, and no statistic
    row["not_run"] = outcome.stopped == INTERRUPTED
    row.update(scenario=episode.scenario, episode=episode.index, episode_seed=episode.seed,
               ros_domain_id=domain_id, returncode=outcome.returncode,
               episode_wall_time_s=round(outcome.wall_time_s, 3), out=str(episode.out))
    return row


def _read_report(path: Path) -> dict[str, Any] | None:
    try:
        report = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return report if isinstance(report, dict) and "completed" in report else None


def _missing_report(episode: Episode, outcome: EpisodeOutcome) -> dict[str, Any]:
    return {
        "completed": False, "score": None, "sim_time_s": None, "checkpoints": [],
        "penalties": {}, "wall_time_s": round(outcome.wall_time_s, 3), "seed": episode.seed,
        "world": "default", "executive": episode.executive, "exit_code": outcome.returncode,
        "failure": outcome.stopped or (f"the run exited with code {outcome.returncode} and "
                                       f"no report: {_last_line(episode.out / 'run.log')}"),
    }


def _last_line(path: Path) -> str:
    try:
        lines = path.read_text(errors="replace").strip().splitlines()
    except OSError:
        return "no output"
    return lines[-1].strip()[:200] if lines else "no output"


# ============================================================================ the batch
class ProgressBar:
    """One redrawn line on a terminal; one line per finished episode otherwise (logs, CI)."""

    WIDTH = 30

    def __init__(self, total: int, stream: TextIO | None = None) -> None:
        self.total, self.done, self.failed = total, 0, 0
        self.stream = stream or sys.stderr
        self.live = self.stream.isatty()
        self.started = time.monotonic()

    def advance(self, row: dict[str, Any]) -> None:
        self.done += 1
        self.failed += not row["completed"]
        if self.live:
            self.stream.write("\r\x1b[2K" + self._bar())
        else:
            self.stream.write(f"{self._bar()}  {_row_line(row)}\n")
        self.stream.flush()

    def close(self) -> None:
        if self.live:
            self.stream.write("\n")
            self.stream.flush()

    def _bar(self) -> str:
        filled = round(self.WIDTH * self.done / self.total)
        elapsed = time.monotonic() - self.started
        left = elapsed / self.done * (self.total - self.done) if self.done else 0.0
        return (f"[{'#' * filled}{'.' * (self.WIDTH - filled)}] {self.done}/{self.total} "
                f"episodes, {self.failed} failed, {_minutes(elapsed)} elapsed, "
                f"~{_minutes(left)} left")


def _row_line(row: dict[str, Any]) -> str:
    seed = "shipped" if row["episode_seed"] is None else f"seed {row['episode_seed']}"
    verdict = (f"completed, score {row['score']:.1f}" if row["completed"]
               else f"failed: {row['failure']}")
    return f"{row['executive']} {row['scenario']} #{row['episode']} ({seed}): {verdict}"


def _minutes(seconds: float) -> str:
    return f"{int(seconds // 60)}m{int(seconds % 60):02d}s"


def domain_ids(jobs: int, base: int | None = None) -> list[int]:
    """Distinct ROS domains 1..101, one per parallel job, starting from ``ROS_DOMAIN_ID``.

    Without one set, the start depends on this process's id, so two evaluations at once are
    unlikely to share domains.
    """
    if base is None:
        given = os.environ.get("ROS_DOMAIN_ID", "")
        base = int(given) if given.isdigit() else os.getpid()
    return [1 + (base + job) % DOMAIN_SPAN for job in range(jobs)]


def run_episodes(settings: EvaluationSettings, episodes: list[Episode],
                 command: EpisodeCommand = run_command,
                 progress: ProgressBar | None = None) -> tuple[list[dict[str, Any]], bool]:
    """Run every episode, ``settings.jobs`` at once: a row for each, in plan order, and
    whether Ctrl-C cut the batch short (running episodes are then stopped, the rest not
    started, and every one of them still gets a row saying so).
    """
    runner = EpisodeRunner(settings, command)
    free: Queue[int] = Queue()
    for domain in domain_ids(settings.jobs):
        free.put(domain)

    def in_a_domain(episode: Episode) -> dict[str, Any]:
        domain = free.get()
        try:
            return runner.run(episode, domain)
        finally:
            free.put(domain)

    with ThreadPoolExecutor(max_workers=settings.jobs) as pool:
        futures = [pool.submit(in_a_domain, episode) for episode in episodes]
        try:
            _report_progress(futures, progress)
        except KeyboardInterrupt:
            runner.stopping.set()
    return [future.result() for future in futures], runner.stopping.is_set()


def _report_progress(futures: list[Future[dict[str, Any]]], progress: ProgressBar | None) -> None:
    reported: set[int] = set()
    while len(reported) < len(futures):
        for number, future in enumerate(futures):
            if number not in reported and future.done():
                reported.add(number)
                if progress is not None:
                    progress.advance(future.result())
        time.sleep(0.2)


# ============================================================================ statistics
def played(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows of episodes that ran to an outcome: not those a Ctrl-C stopped or never ran."""
    return [row for row in rows if not row.get("not_run")]


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The summary of one executive's rows (see ``docs/evaluation.md`` for the definitions).

    Episodes an interrupted evaluation did not play to an outcome are counted as ``not_run``
    and left out of every statistic; their rows are kept.
    """
    every = rows
    rows = played(every)
    completed = [row for row in rows if row["completed"]]
    scores = [float(row["score"]) for row in completed]
    return {
        "episodes": len(rows),
        "success_rate": len(completed) / len(rows) if rows else 0.0,
        "mean_score": _mean(scores),
        "median_score": statistics.median(scores) if scores else None,
        "mean_sim_time_s": _mean([float(row["sim_time_s"]) for row in completed]),
        "penalties": mean_penalties(rows),
        "wall_time_s": round(sum(_episode_wall(row) for row in rows), 3),
        "not_run": len(every) - len(rows),
        "rows": every,
    }


def mean_penalties(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Each penalty kind per episode, over the episodes the referee reported on."""
    refereed = [row["penalties"] for row in rows if row.get("penalties")]
    return {key: (sum(float(p.get(key, 0.0)) for p in refereed) / len(refereed)
                  if refereed else 0.0) for key in PENALTY_KEYS}


def summary_of(settings: EvaluationSettings, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """``summary.json``: each executive's name to its summary."""
    return {executive: summarise([row for row in rows if row["executive"] == executive])
            for executive in settings.executives}


def paired_scores(rows: list[dict[str, Any]], scenario: str, first: str,
                  second: str) -> tuple[list[float], list[float]]:
    """Scores of ``first`` and ``second`` on the episodes of a set that both completed."""
    return paired_values(rows, scenario, first, second,
                         reached=lambda row: bool(row["completed"]),
                         value=lambda row: float(row["score"]))


def paired_drop_off_times(rows: list[dict[str, Any]], scenario: str, first: str,
                          second: str) -> tuple[list[float], list[float]]:
    """Task sim time to the drop-off (checkpoints 1–3) on the episodes both got that far."""
    return paired_values(rows, scenario, first, second, reached=_dropped_off,
                         value=lambda row: sum(float(checkpoint["sim_time_s"])
                                               for checkpoint in row["checkpoints"][:3]))


def paired_values(rows: list[dict[str, Any]], scenario: str, first: str, second: str, *,
                  reached: Callable[[dict[str, Any]], bool],
                  value: Callable[[dict[str, Any]], float]) -> tuple[list[float], list[float]]:
    """``value`` of ``first``'s and ``second``'s rows, episode by episode, on the episodes of
    a set where both rows satisfy ``reached``."""
    by_key = {(row["executive"], row["episode"]): row for row in rows
              if row["scenario"] == scenario and reached(row)}
    both = sorted({episode for (_, episode) in by_key
                   if (first, episode) in by_key and (second, episode) in by_key})
    return ([value(by_key[(first, n)]) for n in both],
            [value(by_key[(second, n)]) for n in both])


def _dropped_off(row: dict[str, Any]) -> bool:
    checkpoints = row.get("checkpoints") or []
    return len(checkpoints) >= 3 and all(bool(c.get("done")) for c in checkpoints[:3])


def _mean(values: list[float]) -> float | None:
    return statistics.fmean(values) if values else None


def _episode_wall(row: dict[str, Any]) -> float:
    return float(row.get("episode_wall_time_s") or row.get("wall_time_s") or 0.0)


# ============================================================================ the report
def markdown_report(settings: EvaluationSettings, rows: list[dict[str, Any]],
                    image_dir: str, *, revision: str | None = None) -> str:
    """``results.md``: the command, the tables and the plots; ``revision`` names the checkout
    (default: as it is now)."""
    lines = ["# Evaluation results", "",
             f"Generated by `{settings.command_line}` on {revision or source_revision()}"
             f"{_resumed_note(rows)}: "
             f"{settings.episodes} episodes per scenario set, every executive on the same "
             f"seeds, {settings.jobs} at once; speed {settings.speed:g}, mission time limit "
             f"{settings.time_limit_s:g} sim s, episode wall-time limit "
             f"{settings.episode_timeout_s:g} s. Definitions: "
             "[evaluation.md](evaluation.md).", "",
             "## Per executive and scenario set", "", *_not_run_note(rows),
             *results_table(settings, rows), ""]
    if set(EXECUTIVES) <= set(settings.executives):
        lines += ["## Paired: the same episodes, both executives", "",
                  "Scores where both completed the mission; the task sim time to the drop-off "
                  "(checkpoints 1–3) where both got the guest there.", "",
                  *paired_table(settings, rows), ""]
    lines += ["## Why episodes failed", "", *failure_table(rows), "", "## Plots", ""]
    lines += [f"![{title}]({image_dir}/results_{name}.png)" for name, title in PLOTS]
    return "\n".join(lines) + "\n"


def _not_run_note(rows: list[dict[str, Any]]) -> list[str]:
    """A line saying how many episodes an interrupted evaluation left unplayed, if any."""
    counts = Counter((row["executive"], row["scenario"]) for row in rows if row.get("not_run"))
    if not counts:
        return []
    parts = ", ".join(f"{executive} {scenario}: {count}"
                      for (executive, scenario), count in sorted(counts.items()))
    return [f"The evaluation was stopped before every episode had run; these episodes were not "
            f"played and are left out of the statistics ({parts}). `episodes` counts the "
            "episodes played.", ""]


def _resumed_note(rows: list[dict[str, Any]]) -> str:
    """Where ``--resume`` kept episodes of earlier runs: which revisions ran how many."""
    resumed = [row for row in rows if row.get("resumed")]
    if not resumed:
        return ""
    ran: dict[tuple[str, str], int] = {}
    for row in rows:
        key = (str(row.get("executive")), str(row.get("revision", "an unknown revision")))
        ran[key] = ran.get(key, 0) + 1
    parts = ", ".join(f"{executive} episodes on {revision}: {count}"
                      for (executive, revision), count in sorted(ran.items()))
    return f" ({len(resumed)} episodes kept from an earlier run with --resume; {parts})"


def source_revision() -> str:
    """The git commit the episodes ran (the checkout this package was imported from)."""
    here = Path(__file__).resolve().parent
    try:
        commit = subprocess.run(["git", "-C", str(here), "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True, timeout=10, check=True)
        changes = subprocess.run(["git", "-C", str(here), "status", "--porcelain",
                                  "--untracked-files=no"],
                                 capture_output=True, text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return "an unknown revision (not a git checkout)"
    dirty = " with uncommitted changes" if changes.stdout.strip() else ""
    return f"commit `{commit.stdout.strip()}`{dirty}"


def results_table(settings: EvaluationSettings, rows: list[dict[str, Any]]) -> list[str]:
    lines = ["| executive | set | episodes | success | mean score | median score | "
             "mean sim time (s) | mean wall time (s) | failed pick-ups | failed drop-offs | "
             "too fast | approximation | contact |", "|" + "---|" * 13]
    for scenario in settings.scenarios:
        for executive in settings.executives:
            group = [row for row in rows
                     if row["executive"] == executive and row["scenario"] == scenario]
            summary, walls = summarise(group), [_episode_wall(row) for row in played(group)]
            penalties = summary["penalties"]
            lines.append(
                f"| {executive} | {scenario} | {summary['episodes']} | "
                f"{summary['success_rate']:.0%} | {_number(summary['mean_score'])} | "
                f"{_number(summary['median_score'])} | {_number(summary['mean_sim_time_s'])} | "
                f"{_number(_mean(walls))} | {penalties['failed_pickup']:.2f} | "
                f"{penalties['failed_dropoff']:.2f} | {penalties['too_fast']:.2f} | "
                f"{penalties['approximation']:.1f} | {penalties['contact']:.1f} |")
    return lines


def paired_table(settings: EvaluationSettings, rows: list[dict[str, Any]]) -> list[str]:
    """Each set, paired: scores where both completed, drop-off times where both dropped off."""
    lines = ["| set | both completed | bt mean score | baseline mean score | bt lower on | "
             "both dropped off | bt mean time to drop-off (s) | baseline mean time to "
             "drop-off (s) | bt faster on |", "|" + "---|" * 9]
    for scenario in settings.scenarios:
        tree, seed = paired_scores(rows, scenario, "bt", "baseline")
        tree_time, seed_time = paired_drop_off_times(rows, scenario, "bt", "baseline")
        lines.append(f"| {scenario} | {len(tree)} | {_number(_mean(tree))} | "
                     f"{_number(_mean(seed))} | {_below(tree, seed)} | {len(tree_time)} | "
                     f"{_number(_mean(tree_time))} | {_number(_mean(seed_time))} | "
                     f"{_below(tree_time, seed_time)} |")
    return lines


def _below(first: list[float], second: list[float]) -> str:
    return f"{sum(a < b for a, b in zip(first, second, strict=True))}/{len(first)}"


def failure_table(rows: list[dict[str, Any]]) -> list[str]:
    """Failed episodes by executive, set, how far the referee saw them get, and reason."""
    reasons = Counter((row["executive"], row["scenario"], _checkpoints_done(row),
                       str(row["failure"])) for row in played(rows) if not row["completed"])
    if not reasons:
        return ["No episode failed."]
    lines = ["| executive | set | episodes | checkpoints | reason |", "|---|---|---|---|---|"]
    for (executive, scenario, done, reason), count in sorted(reasons.items()):
        lines.append(f"| {executive} | {scenario} | {count} | {done} | "
                     f"{reason.replace('|', '/')} |")
    return lines


def _checkpoints_done(row: dict[str, Any]) -> str:
    checkpoints = row.get("checkpoints") or []
    if not checkpoints:
        return "–"
    return f"{sum(bool(c.get('done')) for c in checkpoints)}/{len(checkpoints)}"


def _number(value: float | None) -> str:
    return "–" if value is None else f"{value:.1f}"


PLOTS = (("scores", "Score of completed episodes (lower is better)"),
         ("times", "Task sim time of completed episodes"),
         ("success", "Success rate per scenario set"))


def write_plots(settings: EvaluationSettings, rows: list[dict[str, Any]],
                directory: Path) -> list[Path]:
    """The three PNGs of :data:`PLOTS` in ``directory``."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for name, title in PLOTS:
        figure, axes = pyplot.subplots(figsize=(8, 4.5), dpi=110)
        if name == "success":
            _success_bars(axes, settings, rows)
        else:
            _distributions(axes, settings, rows, "score" if name == "scores" else "sim_time_s")
        axes.set_title(title)
        figure.tight_layout()
        path = directory / f"results_{name}.png"
        figure.savefig(path)
        pyplot.close(figure)
        written.append(path)
    return written


def _distributions(axes: Any, settings: EvaluationSettings, rows: list[dict[str, Any]],
                   field: str) -> None:
    groups, labels = [], []
    for scenario in settings.scenarios:
        for executive in settings.executives:
            groups.append([float(row[field]) for row in rows if row["completed"]
                           and row["executive"] == executive and row["scenario"] == scenario])
            labels.append(f"{executive}\n{scenario} (n={len(groups[-1])})")
    boxes = axes.boxplot([group or [float("nan")] for group in groups], patch_artist=True)
    colours = [f"C{number}" for number in range(len(settings.executives))]
    for number, box in enumerate(boxes["boxes"]):
        box.set_facecolor(colours[number % len(colours)])
        box.set_alpha(0.6)
    axes.set_xticks(range(1, len(labels) + 1), labels, fontsize=8)
    axes.set_ylabel("score" if field == "score" else "sim seconds")
    axes.grid(axis="y", alpha=0.3)


def _success_bars(axes: Any, settings: EvaluationSettings, rows: list[dict[str, Any]]) -> None:
    width = 0.8 / len(settings.executives)
    for number, executive in enumerate(settings.executives):
        rates = []
        for scenario in settings.scenarios:
            group = [row for row in rows
                     if row["executive"] == executive and row["scenario"] == scenario]
            rates.append(100.0 * summarise(group)["success_rate"])
        positions = [index + (number - (len(settings.executives) - 1) / 2) * width
                     for index in range(len(settings.scenarios))]
        bars = axes.bar(positions, rates, width=width, label=executive, color=f"C{number}",
                        alpha=0.8)
        axes.bar_label(bars, fmt="%.0f%%", fontsize=8)
    axes.set_xticks(range(len(settings.scenarios)), settings.scenarios)
    axes.set_ylabel("completed (%)")
    axes.set_ylim(0, 110)
    axes.legend()


def write_results(settings: EvaluationSettings, rows: list[dict[str, Any]]) -> None:
    """summary.json, results.md and the plots in ``--out`` (and in ``--docs`` if given).

    The checkout is described before anything is written: ``--docs`` inside it would
    otherwise make every report say "with uncommitted changes".
    """
    revision = source_revision()
    settings.out.mkdir(parents=True, exist_ok=True)
    summary = summary_of(settings, rows)
    (settings.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    write_plots(settings, rows, settings.out)
    (settings.out / "results.md").write_text(
        markdown_report(settings, rows, ".", revision=revision))
    if settings.docs is not None:
        write_plots(settings, rows, settings.docs / "images")
        (settings.docs / "results.md").write_text(
            markdown_report(settings, rows, "images", revision=revision))


# ============================================================================ the command
def evaluate(settings: EvaluationSettings, command: EpisodeCommand = run_command,
             stream: TextIO | None = None) -> tuple[list[dict[str, Any]], bool]:
    """Run the whole evaluation and write its results: the rows, in plan order, and whether
    it was interrupted (the results of an interrupted evaluation are written all the same)."""
    episodes = plan_episodes(settings)
    progress = ProgressBar(len(episodes), stream)
    started = time.monotonic()
    try:
        rows, interrupted = run_episodes(settings, episodes, command, progress)
    finally:
        progress.close()
    write_results(settings, rows)
    out = stream or sys.stderr
    out.write(f"{len(rows)} episodes in {_minutes(time.monotonic() - started)}"
              f"{' (interrupted)' if interrupted else ''}; "
              f"results: {settings.out / 'results.md'}\n")
    return rows, interrupted


def main(argv: Sequence[str] | None = None) -> int:
    arguments = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(arguments)
    try:
        settings = settings_from(args, arguments)
        settings.out.mkdir(parents=True, exist_ok=True)
    except (UsageError, OSError) as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    apply_localhost_defaults()
    warning = load_warning(jobs=settings.jobs, speed=settings.speed, cores=os.cpu_count() or 1)
    if warning is not None:
        print(f"{PROG}: warning: {warning}", file=sys.stderr)
    _, interrupted = evaluate(settings)
    return EXIT_INTERRUPTED if interrupted else EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
