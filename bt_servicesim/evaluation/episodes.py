"""The episodes of an evaluation: each one what ``python -m bt_servicesim.run --headless`` does.

Every episode has a run directory of its own, several run at once, and each is played either on
a warm pair (``warm``: a simulator and an executive process kept alive from one episode to the
next, :mod:`bt_servicesim.evaluation.warm_pairs`) or, cold, in a ``run`` subprocess of its own
with its own simulator. Each run or pair claims a ROS domain of its own
(:mod:`bt_servicesim.ros.domain`), so episodes running at once never hear each other, and the
report says which. An episode that hangs past
its wall-time limit, or every running one when the evaluation is stopped, is stopped with its
whole process tree. Each finished episode leaves its row (``episode.json``) beside its report, so
``--resume`` keeps what was done.

A report counts only if it is the episode's own: every episode is started with a run id of its
own (``--run-id``), and a ``report.json`` with another run id (an earlier run's, or one that a
run left behind by an earlier evaluation wrote late) is never read as the episode's. A report
that still says ``"status": "running"`` is a run that was killed before it finished: a failed
episode, with that reason.

Episodes are planned lazily and only ``jobs`` of them are under way at a time, so a batch of a
million episodes starts its first as promptly as a batch of ten, and stopping it costs only the
episodes under way.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from queue import Empty, LifoQueue, Queue
from typing import Any

from bt_servicesim.evaluation.process_tree import descendants as descendants
from bt_servicesim.evaluation.process_tree import start_time as start_time
from bt_servicesim.evaluation.process_tree import stop_process_tree
from bt_servicesim.evaluation.progress import Progress
from bt_servicesim.evaluation.report import source_revision
from bt_servicesim.evaluation.scenarios import SCENARIO_SETS
from bt_servicesim.evaluation.settings import (
    EPISODE_NAME,
    INTERRUPTED,
    EvaluationSettings,
    executive_kind,
    tree_digest,
)
from bt_servicesim.evaluation.warm_pairs import WarmPair
from bt_servicesim.mission.report import read_report
from bt_servicesim.mission.settings import REPORT_NAME
from bt_servicesim.mission.stopping import (
    StopSignals,
    Terminated,
    parent_death_signal,
)
from bt_servicesim.ros.environment import apply_localhost_defaults
from bt_servicesim.tree.files import SERVICEBOT

FINAL_STATUSES = ("completed", "failed", "interrupted")  # what a finished run's report says
POLL_S = 0.1  # wall seconds between looks at the episodes under way
WARM_PAIRS_DIRECTORY = "warm-pairs"  # in the evaluation directory: each pair's own output


@dataclass(frozen=True)
class Episode:
    """One mission: an executive on one scenario of one set, and the run id its report carries."""

    executive: str
    scenario: str
    index: int
    seed: int | None
    out: Path
    run_id: str = ""

    @property
    def label(self) -> str:
        seed = "shipped task" if self.seed is None else f"seed {self.seed}"
        return f"{self.executive} {self.scenario} #{self.index} ({seed})"


EpisodeCommand = Callable[[Episode, EvaluationSettings], list[str]]


def plan_episodes(settings: EvaluationSettings) -> Iterator[Episode]:
    """Episode n of every set, for every executive, before episode n+1: partial runs compare.

    Lazily: a plan of millions costs nothing until its episodes are reached. Run ids are
    ``<token>-<executive>-<set>-<n>``, the token drawn once per evaluation.
    """
    token = uuid.uuid4().hex[:12]
    for index in range(settings.episodes):
        for scenario in settings.scenarios:
            for executive in settings.executives:
                yield Episode(executive=executive, scenario=scenario, index=index,
                              seed=settings.seed + index if SCENARIO_SETS[scenario].seeded
                              else None,
                              out=settings.out / executive / scenario / str(index),
                              run_id=f"{token}-{executive}-{scenario}-{index}")


def planned_count(settings: EvaluationSettings) -> int:
    """How many episodes :func:`plan_episodes` plans."""
    return settings.episodes * len(settings.scenarios) * len(settings.executives)


def warm_line(episode: Episode, settings: EvaluationSettings) -> str:
    """The episode as a warm pair's worker takes it: what :func:`run_command` says, as JSON."""
    fields = {"out": str(episode.out), "run_id": episode.run_id,
              "executive": executive_kind(episode.executive), "seed": episode.seed,
              "speed": settings.speed, "time_limit_s": settings.time_limit_s,
              "sim_args": list(SCENARIO_SETS[episode.scenario].sim_args),
              "trajectory": settings.trajectory}
    tree = settings.tree_of(episode.executive)
    if tree is not None:  # else the worker's own shipped tree
        fields["tree"] = str(tree)
    fields["nav_params"] = str(settings.nav_params_of(episode.executive) or SERVICEBOT)
    return json.dumps(fields) + "\n"


def run_command(episode: Episode, settings: EvaluationSettings) -> list[str]:
    """The run command for one episode.

    ``--overwrite``: the episode's directory is the evaluation's own and is cleared before the
    episode starts; should a run of an earlier evaluation still write into it, the new run must
    not refuse the directory (its run id tells the reports apart).
    """
    command = [sys.executable, "-m", "bt_servicesim.run", "--headless",
               "--out", str(episode.out), "--overwrite", "--run-id", episode.run_id,
               "--executive", executive_kind(episode.executive),
               "--speed", repr(settings.speed), "--time-limit", repr(settings.time_limit_s),
               "--trajectory", settings.trajectory]
    tree = settings.tree_of(episode.executive)
    if tree is not None:  # else the run's own shipped tree
        command += ["--tree", str(tree)]
    command += ["--nav-params", str(settings.nav_params_of(episode.executive) or SERVICEBOT)]
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
    """Runs episodes within a wall-time limit, each as a subprocess of its own (``command``) or,
    ``warm``, on warm pairs kept from one episode to the next; stops them all on request."""

    def __init__(self, settings: EvaluationSettings, command: EpisodeCommand, *,
                 warm: bool = False) -> None:
        self.settings = settings
        self.command = command
        self.warm = warm
        self.stopping = threading.Event()
        self.finished: Queue[tuple[int, dict[str, Any] | None]] = Queue()
        """Each episode's plan number and row (None: not started), as they finish."""
        self.revision = source_revision()
        self._tree_digests = {executive: tree_digest(tree) for executive in settings.executives
                              if (tree := settings.played_tree(executive)) is not None}
        self._nav_params_digests = {
            executive: tree_digest(nav_params) for executive in settings.executives
            if (nav_params := settings.nav_params_of(executive)) is not None}
        self._die_with_us = parent_death_signal(os.getpid())
        self._idle_pairs: LifoQueue[WarmPair] = LifoQueue()
        self._pairs_started = itertools.count(1)

    def run(self, episode: Episode) -> dict[str, Any] | None:
        """Run the episode; its row for the summary, or None if the evaluation was stopped
        before the episode started."""
        if self.settings.resume and (kept := self.finished_row(episode)) is not None:
            return kept
        if self.stopping.is_set():
            return None
        if episode.out.exists():
            shutil.rmtree(episode.out)  # whatever an earlier run left is not this episode's
        episode.out.mkdir(parents=True)
        outcome = self._run_process(episode)
        row = episode_row(episode, outcome)
        row.update(revision=self.revision, episode_key=self.key(episode))
        if outcome.stopped != INTERRUPTED:
            (episode.out / EPISODE_NAME).write_text(json.dumps(row, indent=1) + "\n")
        return row

    def run_numbered(self, number: int, episode: Episode) -> None:
        """Run episode ``number`` of the plan and put its row in :attr:`finished`."""
        try:
            row = self.run(episode)
        except Exception as error:  # one episode's trouble must not end the batch
            row = episode_row(episode, EpisodeOutcome(None, 0.0, (
                f"the evaluation could not run it: {type(error).__name__}: {error}")))
        self.finished.put((number, row))

    def key(self, episode: Episode) -> dict[str, Any]:
        """What makes two runs of an episode the same episode."""
        key = {"executive": episode.executive, "scenario": episode.scenario,
               "seed": episode.seed, "sim_args": list(SCENARIO_SETS[episode.scenario].sim_args),
               "speed": self.settings.speed, "time_limit_s": self.settings.time_limit_s}
        if episode.executive in self._tree_digests:  # the baseline plays no tree
            key["tree_sha256"] = self._tree_digests[episode.executive]
        if episode.executive in self._nav_params_digests:  # else the servicebot's
            key["nav_params_sha256"] = self._nav_params_digests[episode.executive]
        return key

    def finished_row(self, episode: Episode) -> dict[str, Any] | None:
        """The row an earlier evaluation kept for this very episode, if any."""
        try:
            row = json.loads((episode.out / EPISODE_NAME).read_text())
        except (OSError, ValueError):
            return None
        if not isinstance(row, dict) or row.get("episode_key") != self.key(episode):
            return None
        return dict(row, resumed=True)

    def _run_process(self, episode: Episode) -> EpisodeOutcome:
        if self.warm:
            return self._run_warm(episode)
        environment = dict(os.environ)
        apply_localhost_defaults(environment)
        started = time.monotonic()
        with (episode.out / "run.log").open("wb") as log:
            process = subprocess.Popen(
                self.command(episode, self.settings), stdout=log, stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL, env=environment, start_new_session=True,
                preexec_fn=self._die_with_us)
            stopped = self._wait(process, started + self.settings.episode_timeout_s)
        return EpisodeOutcome(process.returncode, time.monotonic() - started, stopped)

    def _run_warm(self, episode: Episode) -> EpisodeOutcome:
        """Play the episode on an idle warm pair, or a new one; a pair that failed is gone."""
        pair = self._idle_pair()
        if pair is None:
            pair = WarmPair(log_dir=self.settings.out / WARM_PAIRS_DIRECTORY
                            / f"pair-{next(self._pairs_started)}",
                            die_with_us=self._die_with_us)
        started = time.monotonic()
        outcome = pair.play(warm_line(episode, self.settings), run_id=episode.run_id,
                            timeout_s=self.settings.episode_timeout_s,
                            stopping=self.stopping.is_set)
        if pair.worn_out:
            pair.close()
        elif not pair.broken:
            self._idle_pairs.put(pair)
        return EpisodeOutcome(outcome.returncode, time.monotonic() - started, outcome.failure)

    def _idle_pair(self) -> WarmPair | None:
        """An idle pair whose worker still runs; one that ended meanwhile is let go."""
        while True:
            try:
                pair = self._idle_pairs.get_nowait()
            except Empty:
                return None
            if pair.alive:
                return pair
            pair.kill()

    def close(self) -> None:
        """Let every idle warm pair go: each stops its simulator and exits."""
        while True:
            try:
                self._idle_pairs.get_nowait().close()
            except Empty:
                return

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




def episode_row(episode: Episode, outcome: EpisodeOutcome) -> dict[str, Any]:
    """The run's own report.json (or a failed stand-in), with where it belongs in the evaluation.

    Only a report with the episode's run id is read; one that still says ``running`` is a run
    that never finished (killed, or stopped before it could write its end).
    """
    report = read_report(episode.out / REPORT_NAME)
    own = report is not None and report.get("run_id") == episode.run_id
    if own and report is not None and report.get("status") in FINAL_STATUSES \
            and "completed" in report:
        row = dict(report)
    elif own and report is not None:
        row = {**_stand_in(episode, outcome), **report, "completed": False, "score": None,
               "failure": (f"the run {_ended(outcome)} before it finished (its report still "
                           f"says {report.get('status')!r}): "
                           f"{_last_line(episode.out / 'run.log')}")}
    else:
        row = _stand_in(episode, outcome)
        foreign = "" if report is None else (
            f" (the {REPORT_NAME} there is another run's, run id {report.get('run_id')!r})")
        row["failure"] = (f"the run {_ended(outcome)} and no report of its own{foreign}: "
                          f"{_last_line(episode.out / 'run.log')}")
    if outcome.stopped is not None:
        row["completed"] = False
        row["failure"] = outcome.stopped
    # the evaluation was stopped while it ran: no verdict on the executive, and no statistic
    row["not_run"] = outcome.stopped == INTERRUPTED
    row.setdefault("ros_domain_id", None)  # the domain the run claimed, as its report says
    row.update(executive=episode.executive,  # a tree's name (bt:NAME), where the report says bt
               run_id=episode.run_id, scenario=episode.scenario, episode=episode.index,
               episode_seed=episode.seed, returncode=outcome.returncode,
               episode_wall_time_s=round(outcome.wall_time_s, 3), out=str(episode.out))
    return row


def _stand_in(episode: Episode, outcome: EpisodeOutcome) -> dict[str, Any]:
    return {
        "completed": False, "score": None, "sim_time_s": None, "checkpoints": [],
        "penalties": {}, "wall_time_s": round(outcome.wall_time_s, 3), "seed": episode.seed,
        "world": "default", "executive": episode.executive, "exit_code": outcome.returncode,
        "failure": outcome.stopped,
    }


def _ended(outcome: EpisodeOutcome) -> str:
    """How the run's process ended, as words."""
    code = outcome.returncode
    if code is None:
        return "never started"
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"was killed by {signal.Signals(-code).name}"
        return f"was killed by signal {-code}"
    return f"exited with code {code}"


def _last_line(path: Path) -> str:
    try:
        lines = path.read_text(errors="replace").strip().splitlines()
    except OSError:
        return "no output"
    return lines[-1].strip()[:200] if lines else "no output"


def run_episodes(settings: EvaluationSettings, episodes: Iterable[Episode],
                 command: EpisodeCommand = run_command, progress: Progress | None = None,
                 stops: StopSignals | None = None, *, warm: bool = False
                 ) -> list[dict[str, Any]]:
    """Run every episode, ``settings.jobs`` at once; the rows, in plan order.

    ``warm``: on ``settings.jobs`` warm pairs (:mod:`bt_servicesim.evaluation.warm_pairs`)
    instead of a ``command`` process per episode; a pair that failed is replaced.

    A stop signal (see :class:`StopSignals`) cuts the batch short: the episodes under way are
    stopped (SIGINT, so that each writes its report, then SIGKILL) and get a row saying so
    (``not_run``), the rest are not started and get no row. Whatever happened, this returns
    only once no episode process is left, with ``stops`` held (a stop signal is then only
    noted): the caller writes the results undisturbed.
    """
    runner = EpisodeRunner(settings, command, warm=warm)
    finished = runner.finished
    rows: list[tuple[int, dict[str, Any]]] = []

    def collect() -> None:
        while True:
            try:
                number, row = finished.get_nowait()
            except Empty:
                return
            if row is not None:
                rows.append((number, row))
                if progress is not None:
                    progress.advance(row)

    with contextlib.ExitStack() as stack:
        if stops is None:
            stops = stack.enter_context(StopSignals())
        _run_all(settings, episodes, runner, collect, stops)
    return [row for _, row in sorted(rows, key=lambda pair: pair[0])]


def _poll(under_way: set[Future[None]], collect: Callable[[], None],
          stops: StopSignals) -> set[Future[None]]:
    """Wait a poll, raise a stop that came meanwhile, and collect: the episodes still under way."""
    time.sleep(POLL_S)
    stops.raise_deferred()
    still = {future for future in under_way if not future.done()}
    collect()
    return still


def _run_all(settings: EvaluationSettings, episodes: Iterable[Episode], runner: EpisodeRunner,
             collect: Callable[[], None], stops: StopSignals) -> None:
    """Keep ``settings.jobs`` episodes under way until the plan is done or a stop signal comes;
    return once every episode process has ended, with ``stops`` held."""
    pool = ThreadPoolExecutor(max_workers=settings.jobs, thread_name_prefix="episode")
    # A stop is raised between polls, never inside a lock: raised while the main thread held a
    # future's lock (in done()), it left the lock taken, and the pool's shutdown waited for
    # ever on the worker that set that future's result.
    stops.defer()
    try:
        under_way: set[Future[None]] = set()
        for number, episode in enumerate(episodes):
            while len(under_way) >= settings.jobs:
                under_way = _poll(under_way, collect, stops)
            if settings.resume and (kept := runner.finished_row(episode)) is not None:
                runner.finished.put((number, kept))  # no need of a worker to read a file
            else:
                under_way.add(pool.submit(runner.run_numbered, number, episode))
            collect()
            stops.raise_deferred()
        while under_way:
            under_way = _poll(under_way, collect, stops)
        stops.hold()
    except (KeyboardInterrupt, Terminated) as stop:
        stops.hold(stop)
        runner.stopping.set()
    except BaseException:
        stops.hold()
        runner.stopping.set()
        raise
    finally:
        runner.close()  # before the pool's threads end: a pair dies with the thread that made it
        pool.shutdown(wait=True, cancel_futures=True)  # the episodes under way stop themselves
        runner.close()  # the pairs of the episodes that were under way
        collect()
