"""The episodes of an evaluation on a Dask distributed cluster (``evaluate --cluster ADDRESS``).

The evaluation (the client) plans the episodes as the local pool does and submits each one to
the scheduler; a worker runs it exactly as the local pool would (:class:`EpisodeRunner`: a
``python -m bt_servicesim.run --headless`` process with a ROS domain it claims on the worker's
machine, talking only on that machine's loopback), in a scratch directory of the worker's own,
and sends back the episode's row and its whole run directory as a compressed tar archive. The
client unpacks it under ``--out`` where the local pool would have written it and points the row
(and the kept ``episode.json``) there, so workers need share no filesystem and everything after
the episodes -- resume, the rows' order, the summary, the results -- is the local pool's.

Each worker runs as many episodes at once as it has threads (``dask worker --nthreads N``): the
machine that runs them knows its cores; ``--jobs`` is the local pool's. The client keeps only as
many episodes submitted as the workers have threads, so the plan stays lazy and a stop costs only
the episodes under way.

Stopping: on Ctrl-C, SIGTERM or SIGHUP the client sets a distributed :class:`~distributed.Event`
that every running episode's task watches; each stops its episode as the local pool does
(:func:`~bt_servicesim.evaluation.episodes.stop_process_tree`), episodes not yet started are not
started, and the stopped ones come back as ``not_run`` rows. A task whose client is gone (the
evaluation was killed) stops its episode too. A worker that dies mid-episode: the scheduler
hands the episode to another worker, which plays it again from the start (a retry, once); if
that worker dies too, the episode is failed with the reason. An episode the cluster could not
run (a task error) is failed with the reason; none is dropped. A lost scheduler ends the batch:
the episodes under way come back as ``not_run`` rows (:data:`LOST`), the rest are not started.
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import json
import logging
import shutil
import tarfile
import tempfile
import threading
import time
import uuid
from collections.abc import Iterable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from dask.typing import Key
from distributed import Client, Event, Future, Variable, Worker, get_client, get_worker

from bt_servicesim.cli import UsageError
from bt_servicesim.evaluation.episodes import (
    Episode,
    EpisodeCommand,
    EpisodeOutcome,
    EpisodeRunner,
    episode_row,
    run_command,
)
from bt_servicesim.evaluation.progress import Progress
from bt_servicesim.evaluation.scheduler_probe import ProbeError, server_kind
from bt_servicesim.evaluation.settings import (
    EPISODE_NAME,
    INTERRUPTED,
    STOP_GRACE_S,
    EvaluationSettings,
)
from bt_servicesim.mission.stopping import StopSignals, Terminated

__all__ = ["LOST", "ClusterError", "cluster_address", "connect", "lost", "run_on_cluster"]

CONNECT_TIMEOUT_S = 10.0  # wall seconds to reach the scheduler and find a worker there
POLL_S = 0.2  # wall seconds between the client's looks at the episodes under way
WATCH_S = 0.5  # wall seconds between a task's looks at the stop event
RETRIES = 1  # plays of an episode again after the worker playing it died
STOP_WAIT_S = STOP_GRACE_S + 50.0
"""Wall seconds the client waits, once stopped, for the workers to stop their episodes and send
them back (each episode gets :data:`STOP_GRACE_S` to write its report, then is killed)."""

LOST = "the cluster's scheduler was lost"
"""The failure of an episode under way when the client lost the scheduler (a ``not_run`` row)."""

Row = dict[str, Any]
Played = tuple[Row, bytes] | None
"""What a worker sends back: the row and the run directory packed, or None if stopped first."""


def lost(client: Client) -> bool:
    """Whether the client lost its scheduler (its futures are then cancelled)."""
    return client.status != "running"


class ClusterError(Exception):
    """The cluster cannot be used: the message is the one line the user sees."""


def cluster_address(text: str) -> str:
    """``tcp://host:port``, checked; anything else is a usage error naming the problem."""
    parts = urlsplit(text)
    try:
        port = parts.port
    except ValueError:
        port = None
    if parts.scheme != "tcp" or not parts.hostname or port is None or not 0 < port < 65536 \
            or parts.path not in ("", "/") or parts.query or parts.fragment:
        raise UsageError(f"--cluster {text}: not a scheduler address (tcp://HOST:PORT, as "
                         "`dask scheduler` prints it)")
    return text


def connect(address: str) -> Client:
    """A client of the scheduler at ``address`` with at least one worker, within
    :data:`CONNECT_TIMEOUT_S` each; :class:`ClusterError` otherwise, with nothing started.

    The server is asked who it is before a client is made, bounded in time and size
    (:mod:`~bt_servicesim.evaluation.scheduler_probe`): what answers may be no scheduler (a
    worker, a listener that never replies, no Dask server at all), and a client that fails to
    start leaves noise behind.
    """
    quiet = logging.getLogger("distributed")
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)  # the one line of the ClusterError says it all
    try:
        kind = asyncio.run(server_kind(address, timeout_s=CONNECT_TIMEOUT_S))
        if kind != "Scheduler":
            raise ClusterError(f"--cluster {address}: the server there is a Dask {kind}, not "
                               "a scheduler")
        client = Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except TimeoutError:
        raise ClusterError(f"--cluster {address}: no Dask scheduler answered within "
                           f"{CONNECT_TIMEOUT_S:g} s (something accepted the connection and "
                           "said nothing)") from None
    except OSError as error:
        raise ClusterError(f"--cluster {address}: no Dask scheduler answered: nothing "
                           f"listens there ({error.strerror or error})") from None
    except ProbeError as error:  # another protocol
        raise ClusterError(f"--cluster {address}: what answers there does not speak Dask's "
                           f"protocol: {error}") from None
    finally:
        quiet.setLevel(level)
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
    except TimeoutError:
        client.close()
        raise ClusterError(f"--cluster {address}: the scheduler has no worker (none joined "
                           f"within {CONNECT_TIMEOUT_S:g} s; start one with `dask worker "
                           f"{address}`)") from None
    logging.getLogger("distributed.client").setLevel(logging.CRITICAL)  # a lost scheduler:
    return client  # the evaluation's rows and its one line say so


def run_on_cluster(settings: EvaluationSettings, episodes: Iterable[Episode], client: Client,
                   command: EpisodeCommand = run_command, progress: Progress | None = None,
                   stops: StopSignals | None = None) -> list[Row]:
    """Run every episode on the cluster; the rows, in plan order, as
    :func:`~bt_servicesim.evaluation.episodes.run_episodes` gives them.

    Returns once no episode is under way on any worker (or the workers did not answer within
    :data:`STOP_WAIT_S` of a stop), with ``stops`` held.
    """
    batch = ClusterBatch(settings, client, command, progress)
    with contextlib.ExitStack() as stack:
        if stops is None:
            stops = stack.enter_context(StopSignals())
        batch.run(episodes, stops)
    return [row for _, row in sorted(batch.rows, key=lambda pair: pair[0])]


class ClusterBatch:
    """The episodes submitted and the rows come back, on the client."""

    def __init__(self, settings: EvaluationSettings, client: Client, command: EpisodeCommand,
                 progress: Progress | None) -> None:
        self.settings, self.client, self.command, self.progress = (
            settings, client, command, progress)
        self.local = EpisodeRunner(settings, command)  # what an earlier evaluation kept
        self.token = f"bt_servicesim-{uuid.uuid4().hex[:12]}"
        self.stop = Event(f"{self.token}-stop", client=client)
        self.under_way: dict[Future[Played], tuple[int, Episode]] = {}
        self.rows: list[tuple[int, Row]] = []

    def run(self, episodes: Iterable[Episode], stops: StopSignals) -> None:
        """Keep the workers' threads busy until the plan is done or a stop signal comes."""
        # A stop is raised between polls, never inside a lock: the client's calls wait on the
        # threads of its event loop, as the local pool's futures do (episodes._run_all).
        stops.defer()
        try:
            for number, episode in enumerate(episodes):
                while not lost(self.client) and len(self.under_way) >= self.capacity():
                    self.collect(timeout=POLL_S)
                    stops.raise_deferred()
                if lost(self.client):
                    break  # the rest are not played: not_run in the summary
                self.start(number, episode)
                stops.raise_deferred()
            while self.under_way:
                self.collect(timeout=POLL_S)
                stops.raise_deferred()
            stops.hold()
        except (KeyboardInterrupt, Terminated) as stop:
            stops.hold(stop)
            self.stop_all()
        except BaseException:
            stops.hold()
            self.stop_all()
            raise

    def capacity(self) -> int:
        """Episodes the workers can run at once: their threads, all together (at least one,
        which waits on the scheduler for a worker to join); none if the scheduler cannot say."""
        try:
            threads: dict[str, int] = self.client.nthreads()
            return max(1, sum(threads.values()))
        except Exception:  # the scheduler is being lost: the caller looks again
            return 0

    def start(self, number: int, episode: Episode) -> None:
        if self.settings.resume and (kept := self.local.finished_row(episode)) is not None:
            self.record(number, kept)  # no need of a worker to read a file
            return
        if episode.out.exists():
            shutil.rmtree(episode.out)  # whatever an earlier run left is not this episode's
        Variable(f"{self.token}-{number}", client=self.client).set(0)  # played so far
        future = self.client.submit(
            play_episode, replace(self.settings, resume=False), self.command, episode,
            f"{self.token}-stop", f"{self.token}-{number}", key=f"{self.token}-{number}",
            pure=False)
        self.under_way[future] = (number, episode)

    def collect(self, timeout: float) -> None:
        """Take in the episodes that have come back (waiting up to ``timeout`` for one)."""
        if not self.under_way:
            return
        deadline = time.monotonic() + timeout
        while not (done := [future for future in self.under_way if future.done()]):
            if time.monotonic() >= deadline:
                return
            time.sleep(POLL_S / 4)
        for future in done:
            number, episode = self.under_way[future]
            row = self.take(future, number, episode)
            del self.under_way[future]  # only now: a stop during take() takes it again
            if row is not None:
                self.record(number, row)

    def take(self, future: Future[Played], number: int, episode: Episode) -> Row | None:
        """The episode's row, its run directory unpacked under ``--out``."""
        try:
            played = future.result()
        except Exception as error:  # the cluster could not run it: failed, never dropped
            if future.cancelled():  # the scheduler was lost: no verdict on the executive
                row: Row | None = dict(self.failed(episode, LOST), not_run=True)
            else:
                row = self.failed(episode, f"the cluster could not run it: "
                                           f"{type(error).__name__}: {error}")
        else:
            row = None if played is None else unpack(episode, *played)
        future.release()
        with contextlib.suppress(Exception):  # its count of plays is done with
            Variable(f"{self.token}-{number}", client=self.client).delete()
        return row  # None: the evaluation was stopped before the episode started

    def failed(self, episode: Episode, reason: str) -> Row:
        episode.out.mkdir(parents=True, exist_ok=True)
        row = episode_row(episode, EpisodeOutcome(None, 0.0, reason))
        row.update(revision=self.local.revision, episode_key=self.local.key(episode))
        return row

    def record(self, number: int, row: Row) -> None:
        self.rows.append((number, row))
        if self.progress is not None:
            self.progress.advance(row)

    def stop_all(self) -> None:
        """Stop every episode under way on any worker; take in what they send back."""
        with contextlib.suppress(Exception):  # a lost scheduler: nothing more to take in
            self.stop.set()
        deadline = time.monotonic() + STOP_WAIT_S
        while self.under_way and time.monotonic() < deadline:
            self.collect(timeout=POLL_S)
        for future, (number, episode) in list(self.under_way.items()):
            future.cancel()
            self.record(number, dict(self.failed(episode, (
                f"{INTERRUPTED}; the worker did not answer within {STOP_WAIT_S:g} s")),
                not_run=True))
        self.under_way.clear()


def unpack(episode: Episode, row: Row, archive: bytes) -> Row:
    """Put the worker's run directory where the local pool would have written it."""
    if episode.out.exists():
        shutil.rmtree(episode.out)
    episode.out.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(archive), mode="r:gz") as tar:
        tar.extractall(episode.out, filter="data")
    row = dict(row, out=str(episode.out))
    kept = episode.out / EPISODE_NAME
    if kept.exists():
        kept.write_text(json.dumps(row, indent=1) + "\n")
    return row


def pack(directory: Path) -> bytes:
    """The run directory as a compressed tar archive, its files at the top."""
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        for path in sorted(directory.iterdir()):
            tar.add(path, arcname=path.name)
    return buffer.getvalue()


def play_episode(settings: EvaluationSettings, command: EpisodeCommand, episode: Episode,
                 stop_name: str, attempts_name: str) -> Played:
    """On a worker: play the episode as the local pool does, in a scratch directory; its row
    and run directory, or None if the evaluation was stopped before it started."""
    client = get_client()
    stop = Event(stop_name, client=client)
    if stop.is_set():
        return None
    attempt = _attempt(Variable(attempts_name, client=client))
    scratch = Path(tempfile.mkdtemp(prefix="bt_servicesim-episode-",
                                    dir=get_worker().local_directory))
    here = replace(episode, out=scratch / "run")
    try:
        if attempt > RETRIES + 1:
            here.out.mkdir()
            return _worker_died(here, attempt), pack(here.out)
        runner = EpisodeRunner(settings, command)
        with _watching(stop, runner.stopping):
            row = _played(runner, here)
        return None if row is None else (row, pack(here.out))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _attempt(attempts: Variable) -> int:
    """Which play of the episode this is: the scheduler hands an episode whose worker died to
    another worker, and the count, kept on the scheduler (set to 0 by the client before it
    submits the episode), outlives the worker."""
    try:
        played = int(attempts.get(timeout=CONNECT_TIMEOUT_S))
    except TimeoutError:  # not set: the client is not this module's
        played = 0
    attempts.set(played + 1)
    return played + 1


def _worker_died(here: Episode, attempt: int) -> Row:
    return episode_row(here, EpisodeOutcome(None, 0.0, (
        f"the worker playing it died mid-episode, {attempt - 1} times; not played again")))


def _played(runner: EpisodeRunner, here: Episode) -> Row | None:
    """The episode's row as the local pool makes it, its trouble included."""
    try:
        return runner.run(here)
    except Exception as error:  # one episode's trouble must not end the batch
        here.out.mkdir(parents=True, exist_ok=True)
        return episode_row(here, EpisodeOutcome(None, 0.0, (
            f"the evaluation could not run it: {type(error).__name__}: {error}")))


@contextlib.contextmanager
def _watching(stop: Event, stopping: threading.Event) -> Iterator[None]:
    """While the episode runs: stop it once the evaluation is stopped, or is gone (the
    scheduler lost, or the task released because its client left)."""
    worker = get_worker()
    key = worker.get_current_task()
    done = threading.Event()

    def watch() -> None:
        while not done.is_set():
            if _stop_asked(stop, worker, key):
                stopping.set()
                return

    watcher = threading.Thread(target=watch, name="episode-stop-watch", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        done.set()
        watcher.join()


def _stop_asked(stop: Event, worker: Worker, key: Key) -> bool:
    """Whether the episode must stop: the evaluation set the stop event (waited for on the
    scheduler, :data:`WATCH_S` at most), the scheduler no longer wants the task's result (its
    client is gone), or the scheduler is lost (nobody can take the episode back)."""
    try:
        if stop.wait(timeout=WATCH_S):
            return True
    except Exception:
        return True
    task = worker.state.tasks.get(key)
    return task is None or task.state in ("cancelled", "released", "forgotten")
