"""The episodes of an evaluation: each one a ``python -m bt_servicesim.run --headless`` process.

Every episode runs in a subprocess of its own with its own simulator, run directory and ROS
domain, several at once; an episode that hangs past its wall-time limit, or the whole batch
when it is interrupted, is stopped with its whole process tree. Each finished episode leaves
its row (``episode.json``) beside its report, so ``--resume`` keeps what was done.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from queue import Queue
from typing import Any, TextIO

from bt_servicesim.evaluation.report import source_revision
from bt_servicesim.evaluation.scenarios import SCENARIO_SETS
from bt_servicesim.evaluation.settings import (
    DOMAIN_SPAN,
    EPISODE_NAME,
    INTERRUPTED,
    STOP_GRACE_S,
    EvaluationSettings,
)
from bt_servicesim.mission.settings import REPORT_NAME
from bt_servicesim.ros.environment import apply_localhost_defaults

PARENT_FIELD, START_TIME_FIELD = 4, 22  # of /proc/<pid>/stat


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
                f"episodes, {self.failed} failed, {as_minutes(elapsed)} elapsed, "
                f"~{as_minutes(left)} left")


def _row_line(row: dict[str, Any]) -> str:
    seed = "shipped" if row["episode_seed"] is None else f"seed {row['episode_seed']}"
    verdict = (f"completed, score {row['score']:.1f}" if row["completed"]
               else f"failed: {row['failure']}")
    return f"{row['executive']} {row['scenario']} #{row['episode']} ({seed}): {verdict}"


def as_minutes(seconds: float) -> str:
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
