"""``evaluate --cluster``: the episodes on a Dask cluster of two workers the tests start (one
for the tests that leave it whole, one for each test that kills a part of it).

The cluster is the real thing, on loopback only: ``dask scheduler`` and two ``dask worker``
processes of one thread each, bound to 127.0.0.1, no dashboard (nor profiler: ``QUIET``). Real
episodes (short missions of the bt executive, in lockstep, so a seed replays) run once on the
cluster and once in the local pool, and must give the same rows and summary. Fake episodes
(those of ``test_evaluate.py``) check the rest quickly: the rows' order and ``--resume``, a stop
reaching every episode under way on any worker, a worker that dies mid-episode, a lost
scheduler, an evaluation killed outright; and bad addresses are refused before anything starts.
"""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import IO, Any

import pytest

from bt_servicesim.cli import UsageError
from bt_servicesim.evaluate import evaluate
from bt_servicesim.evaluation.cluster import ClusterError, cluster_address, connect
from bt_servicesim.evaluation.episodes import descendants, start_time
from tests.evaluation.bound_fakes import FAKE_BOUND_COMMAND
from tests.evaluation.test_evaluate import (
    alive,
    fake,
    files_under,
    no_evaluation_outlives_its_test,  # noqa: F401 (autouse here as there)
    settings,
    start_evaluation,
)

CLUSTER_UP_S = 60.0

QUIET = {"DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False",
         "DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL": "1s"}
"""Dask's configuration for the cluster's processes: no statistical profiler on the workers (it
samples every thread every 10 ms, for a dashboard there is none of) and the event loop's
watchdog ticking once a second rather than every 20 ms. What the evaluation asks of the cluster
uses neither; idle, the three processes then take a third of the CPU they would."""


class Cluster:
    """A scheduler and two single-threaded workers on 127.0.0.1, stopped by their pids."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.scheduler_file = directory / "scheduler.json"
        self.processes: list[subprocess.Popen[bytes]] = []
        self.logs: list[IO[bytes]] = []

    def start(self) -> Cluster:
        self.processes.append(self._dask("scheduler", "--host", "127.0.0.1", "--port", "0",
                                         "--no-dashboard", "--scheduler-file",
                                         str(self.scheduler_file)))
        for number in range(2):
            self.processes.append(self.start_worker(number))
        self._wait_for_workers(2)
        return self

    @property
    def address(self) -> str:
        return str(json.loads(self.scheduler_file.read_text())["address"])

    def start_worker(self, number: int) -> subprocess.Popen[bytes]:
        return self._dask("worker", "--scheduler-file", str(self.scheduler_file),
                          "--host", "127.0.0.1", "--nthreads", "1", "--no-nanny",
                          "--no-dashboard", "--name", f"worker-{number}",
                          "--local-directory", str(self.directory / f"worker-{number}"))

    def stop(self) -> None:
        """The workers first (they leave the scheduler), then the scheduler."""
        workers, scheduler = self.processes[1:], self.processes[0]
        for group in (workers, [scheduler]):
            for process in group:
                if process.poll() is None:
                    process.terminate()
            for process in group:
                try:
                    process.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()
        for log in self.logs:
            log.close()

    def _dask(self, *arguments: str) -> subprocess.Popen[bytes]:
        log = (self.directory / f"{arguments[0]}-{len(self.processes)}.log").open("wb")
        self.logs.append(log)
        return subprocess.Popen([sys.executable, "-m", "dask", *arguments], stdout=log,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                env={**os.environ, **QUIET})

    def _wait_for_workers(self, count: int) -> None:
        deadline = time.monotonic() + CLUSTER_UP_S
        while not (self.scheduler_file.exists() and self.scheduler_file.stat().st_size
                   and "address" in self.scheduler_file.read_text()):
            assert time.monotonic() < deadline, "the scheduler did not come up"
            time.sleep(0.1)
        from distributed import Client

        with Client(self.address, timeout=CLUSTER_UP_S, set_as_default=False) as client:
            client.wait_for_workers(count, timeout=CLUSTER_UP_S)

    def wait_until_idle(self) -> None:
        """Until both workers are up and neither runs a task (an earlier test's episode)."""
        from distributed import Client

        deadline = time.monotonic() + CLUSTER_UP_S
        with Client(self.address, timeout=CLUSTER_UP_S, set_as_default=False) as client:
            client.wait_for_workers(2, timeout=CLUSTER_UP_S)
            while any(client.run(_executing).values()):
                assert time.monotonic() < deadline, "the cluster's workers stayed busy"
                time.sleep(0.1)


def _executing(dask_worker: Any) -> int:
    return int(dask_worker.state.executing_count)


def started_cluster(directory: Path) -> Iterator[Cluster]:
    started = Cluster(directory)
    started.directory.mkdir()
    try:
        yield started.start()
    finally:
        started.stop()


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[Cluster]:
    """A cluster of the test's own, for a test that kills a part of it."""
    yield from started_cluster(tmp_path / "cluster")


@pytest.fixture(scope="module")
def module_cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    yield from started_cluster(tmp_path_factory.mktemp("shared") / "cluster")


#: The tests that leave the cluster whole share one (``shared_cluster``), on one pytest-xdist
#: worker (``make test`` runs ``--dist loadgroup``): starting a scheduler and two workers is
#: seconds of processes each time.
SHARED_CLUSTER = pytest.mark.xdist_group("dask_cluster")


@pytest.fixture
def shared_cluster(module_cluster: Cluster) -> Cluster:
    """The module's cluster, once no episode of an earlier test is under way on it."""
    module_cluster.wait_until_idle()
    return module_cluster


EVALUATE = r"""
import os, sys
from bt_servicesim.evaluate import main
from bt_servicesim.evaluation import kinematic_bound
kinematic_bound.BOUND_COMMAND = (sys.executable, "-c", FAKE_BOUND_COMMAND, os.devnull)
sys.exit(main(sys.argv[1:]))
""".replace("FAKE_BOUND_COMMAND", repr(FAKE_BOUND_COMMAND), 1)
"""``python -m bt_servicesim.evaluate`` with the stand-in bound command (``conftest.py``): the
bounds are the client's work, the same with a cluster or without, and the real command's
search of the office is seconds of CPU per evaluation."""


def evaluation(out: Path, *arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bt_servicesim.evaluate", "--out", str(out), *arguments],
        capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)


def bounded_evaluation(out: Path, *arguments: str) -> subprocess.CompletedProcess[str]:
    """:func:`evaluation` of real episodes, its bounds from the stand-in."""
    return subprocess.run([sys.executable, "-c", EVALUATE, "--out", str(out), *arguments],
                          capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)


def judged(row: dict[str, Any]) -> tuple[Any, ...]:
    """What an episode is judged by, and what a seed replays."""
    return (row["executive"], row["scenario"], row["episode"], row["episode_seed"],
            row["completed"], [(c["done"], c["sim_time_s"]) for c in row["checkpoints"]],
            row["penalties"], row["score"], row["not_run"])


def statistics(summary: dict[str, Any]) -> dict[str, Any]:
    """The summary less what wall time and the machine decide."""
    return {executive: {key: value for key, value in figures.items()
                        if key not in ("rows", "wall_time_s")}
            for executive, figures in summary.items()}


@pytest.mark.long
@SHARED_CLUSTER
def test_a_cluster_of_two_workers_gives_the_local_pools_results(
        tmp_path: Path, shared_cluster: Cluster) -> None:
    # random seeds 7 and 8: seed 7 has its guest picked up by 17 sim s, seed 8 nothing yet
    # no picture drawn (--trajectory never), though neither mission completes in 25 s
    common = ("--episodes", "2", "--scenarios", "random", "--executive", "bt", "--seed", "7",
              "--speed", "0", "--time-limit", "25", "--trajectory", "never")
    local = bounded_evaluation(tmp_path / "local", *common, "--jobs", "2")
    assert local.returncode == 0, local.stderr
    remote = bounded_evaluation(tmp_path / "remote", *common, "--cluster",
                                shared_cluster.address)
    assert remote.returncode == 0, remote.stderr
    summaries = [json.loads((tmp_path / name / "summary.json").read_text())
                 for name in ("local", "remote")]
    rows = [[judged(row) for row in summary["bt"]["rows"]] for summary in summaries]
    assert rows[0] == rows[1] and len(rows[0]) == 2
    assert any(done for _, _, _, _, _, checkpoints, *_ in rows[0] for done, _ in checkpoints), \
        "the missions got far enough to tell two runs apart"
    assert statistics(summaries[0]) == statistics(summaries[1])
    for row in summaries[1]["bt"]["rows"]:  # the run directories came back under --out
        out = Path(row["out"])
        assert out == tmp_path / "remote" / "bt" / "random" / str(row["episode"])
        assert json.loads((out / "report.json").read_text())["run_id"] == row["run_id"]
        assert json.loads((out / "episode.json").read_text())["out"] == str(out)
        assert (out / "run.log").is_file() and (out / "sim.log").is_file()
    for summary in summaries:
        for row in summary["bt"]["rows"]:
            assert not row["completed"] and not (Path(row["out"]) / "trajectory.png").exists()
    assert "2/2 episodes" in remote.stderr and "results:" in remote.stderr


def episodes_on(workers: list[subprocess.Popen[bytes]], evaluation: subprocess.Popen[str],
                limit_s: float = 60.0) -> dict[int, int]:
    """Once every worker plays a fake episode that has written its first report and started
    its orphan: each of their processes, by pid, with its start time."""
    deadline = time.monotonic() + limit_s
    while True:
        found = {worker.pid: [pid for pid in descendants(worker.pid)
                              if b"report.json" in _command_line(pid)] for worker in workers}
        if all(len(pids) >= 2 for pids in found.values()):
            return {pid: start_time(pid) or 0 for pids in found.values() for pid in pids}
        if evaluation.poll() is not None or time.monotonic() > deadline:
            evaluation.kill()
            pytest.fail(f"no episode on every worker: {evaluation.communicate()}")
        time.sleep(0.1)


def _command_line(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def still_running(processes: dict[int, int]) -> list[int]:
    return [pid for pid, started in processes.items() if start_time(pid) == started
            and alive(pid)]


@pytest.mark.long
@SHARED_CLUSTER
def test_sigterm_stops_the_episodes_under_way_on_every_worker(
        tmp_path: Path, shared_cluster: Cluster) -> None:
    process = start_evaluation(tmp_path, "hang", "--episodes", "3", "--scenarios", "random",
                               "--cluster", shared_cluster.address)
    played = episodes_on(shared_cluster.processes[1:], process)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 143, stderr
    assert "Traceback" not in stderr and "(stopped by SIGTERM)" in stderr
    assert not still_running(played), "every episode and its orphan are gone"
    out = tmp_path / "evaluation"
    summary = json.loads((out / "summary.json").read_text())
    for executive in ("bt", "baseline"):
        (row,) = summary[executive]["rows"]
        assert row["not_run"] and row["failure"] == "evaluation interrupted"
        report = json.loads((Path(row["out"]) / "report.json").read_text())
        assert (report["run_id"], report["status"]) == (row["run_id"], "interrupted")
        assert summary[executive]["not_run"] == 3 and summary[executive]["episodes"] == 0
    written = files_under(out)
    time.sleep(2.0)
    assert files_under(out) == written, "nothing writes into --out after the evaluation exited"


@pytest.mark.long
def test_an_episode_whose_worker_dies_is_played_again_on_another(
        tmp_path: Path, cluster: Cluster) -> None:
    process = start_evaluation(tmp_path, "hang", "--episodes", "1", "--scenarios", "random",
                               "--episode-timeout", "4", "--cluster", cluster.address)
    doomed = cluster.processes[1]
    played = episodes_on(cluster.processes[1:], process)
    on_the_doomed = {pid: started for pid, started in played.items()
                     if pid in descendants(doomed.pid)}
    doomed.send_signal(signal.SIGKILL)
    doomed.wait()
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 0, stderr
    assert not still_running(on_the_doomed), "the dead worker's episode died with it"
    summary = json.loads((tmp_path / "evaluation" / "summary.json").read_text())
    for executive in ("bt", "baseline"):
        (row,) = summary[executive]["rows"]
        assert row["failure"] == "episode wall-time limit of 4 s exceeded; stopped", row
        report = json.loads((Path(row["out"]) / "report.json").read_text())
        assert report["run_id"] == row["run_id"], "played to its end, and shipped back"


@pytest.mark.parametrize("address", ["localhost:8786", "http://127.0.0.1:8786",
                                     "tcp://127.0.0.1", "tcp://127.0.0.1:99999",
                                     "tcp://:8786", "tcp://127.0.0.1:8786/x"])
def test_an_address_that_is_no_scheduler_address_is_refused(address: str) -> None:
    with pytest.raises(UsageError, match="not a scheduler address"):
        cluster_address(address)
    assert cluster_address("tcp://127.0.0.1:8786") == "tcp://127.0.0.1:8786"


@pytest.mark.parametrize(("address", "problem"), [
    ("tcp://127.0.0.1:9", "no Dask scheduler answered: nothing listens there"),
    ("127.0.0.1:9", "not a scheduler address"),
])
def test_a_bad_cluster_gives_one_line_and_starts_nothing(
        tmp_path: Path, address: str, problem: str) -> None:
    out = tmp_path / "evaluation"
    finished = evaluation(out, "--episodes", "1", "--cluster", address)
    assert finished.returncode == 2
    (line,) = finished.stderr.splitlines()
    assert line.startswith("python -m bt_servicesim.evaluate: error: --cluster " + address)
    assert problem in line
    assert not out.exists(), "nothing started"


SILENT = b""
"""A listener that accepts and never answers."""


@pytest.mark.parametrize(("answer", "problem"), [
    pytest.param(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 3,
                 "does not speak Dask's protocol: it announced an answer of", id="http"),
    pytest.param(struct.pack("<Q", 3 * 10**9) + b"x" * 64,
                 "does not speak Dask's protocol: it announced an answer of 3000000000 bytes",
                 id="plausible-length"),
    pytest.param(struct.pack("<Q", 16) + b"\xff" * 16,
                 "does not speak Dask's protocol: its answer is not Dask's framing",
                 id="garbage-frames"),
    pytest.param(b"\x00\x01", "does not speak Dask's protocol: it closed the connection",
                 id="closed"),
    pytest.param(SILENT, "no Dask scheduler answered within 1 s", id="silent"),
])
def test_a_server_that_is_no_dask_scheduler_is_refused_in_one_line(
        monkeypatch: pytest.MonkeyPatch, answer: bytes, problem: str) -> None:
    monkeypatch.setattr("bt_servicesim.evaluation.cluster.CONNECT_TIMEOUT_S", 1.0)
    done = threading.Event()
    with socket.create_server(("127.0.0.1", 0)) as server:
        def answer_once() -> None:
            connection, _ = server.accept()
            with connection:
                connection.recv(4096)
                if answer:
                    connection.sendall(answer)
                    return
                done.wait(timeout=30)  # silent until the client has given up

        threading.Thread(target=answer_once, daemon=True).start()
        address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
        try:
            with pytest.raises(ClusterError, match=re.escape(problem)) as refused:
                connect(address)
        finally:
            done.set()
    assert "\n" not in str(refused.value)


@pytest.mark.long
@SHARED_CLUSTER
def test_the_rows_come_back_in_plan_order_and_resume_keeps_them(
        tmp_path: Path, shared_cluster: Cluster) -> None:
    modes = {("baseline", 1): "crash"}  # one episode with no report of its own
    local = settings(tmp_path, out=tmp_path / "local")
    remote = settings(tmp_path, out=tmp_path / "remote")
    with (tmp_path / "progress.log").open("w") as stream:
        local_rows, _ = evaluate(local, command=fake(modes), stream=stream)
        with connect(shared_cluster.address) as client:
            remote_rows, _ = evaluate(remote, command=fake(modes), stream=stream, cluster=client)
            played = files_under(remote.out)
            again, _ = evaluate(replace(remote, resume=True), command=fake(modes),
                                stream=stream, cluster=client)
    assert [judged(row) for row in remote_rows] == [judged(row) for row in local_rows]
    assert [row["failure"] for row in remote_rows] == [row["failure"] for row in local_rows]
    assert len(remote_rows) == 8 and any(not row["completed"] for row in remote_rows)
    assert [row.get("resumed") for row in again] == [True] * 8, "a crash is an outcome, kept"
    assert [judged(row) for row in again] == [judged(row) for row in remote_rows]
    assert episode_files(remote.out) == episode_files(remote.out, played), \
        "the kept episodes were not played again"


def episode_files(out: Path, files: dict[str, Any] | None = None) -> dict[str, Any]:
    """The episodes' files (not the evaluation's summary and results), as ``files_under``."""
    return {path: stamp for path, stamp in (files or files_under(out)).items()
            if Path(path).parent != out}


@pytest.mark.long
def test_a_lost_scheduler_ends_the_evaluation_with_one_line_and_its_results(
        tmp_path: Path, cluster: Cluster) -> None:
    process = start_evaluation(tmp_path, "hang", "--episodes", "3", "--scenarios", "random",
                               "--cluster", cluster.address)
    played = episodes_on(cluster.processes[1:], process)
    scheduler = cluster.processes[0]
    scheduler.send_signal(signal.SIGKILL)
    scheduler.wait()
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 1, stderr
    assert "Traceback" not in stderr
    assert "error: --cluster tcp://127.0.0.1:" in stderr and "the scheduler was lost" in stderr
    assert not still_running(played), "the workers stopped their episodes"
    summary = json.loads((tmp_path / "evaluation" / "summary.json").read_text())
    for executive in ("bt", "baseline"):
        (row,) = summary[executive]["rows"]
        assert row["not_run"] and row["failure"] == "the cluster's scheduler was lost"
        assert summary[executive]["not_run"] == 3 and summary[executive]["episodes"] == 0


@pytest.mark.long
@SHARED_CLUSTER
def test_an_evaluation_killed_outright_leaves_no_episode_running_on_the_workers(
        tmp_path: Path, shared_cluster: Cluster) -> None:
    process = start_evaluation(tmp_path, "hang", "--episodes", "3", "--scenarios", "random",
                               "--cluster", shared_cluster.address)
    played = episodes_on(shared_cluster.processes[1:], process)
    process.kill()  # SIGKILL: no clean-up of its own; its client just leaves the scheduler
    process.communicate(timeout=30)
    deadline = time.monotonic() + 60.0
    while still_running(played) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not still_running(played), "the workers stopped the episodes nobody would take"
    assert all(worker.poll() is None for worker in shared_cluster.processes), \
        "the cluster lives on"


@pytest.mark.long
def test_an_episode_whose_workers_die_twice_is_failed_not_played_a_third_time(
        tmp_path: Path, cluster: Cluster) -> None:
    process = start_evaluation(tmp_path, "hang", "--episodes", "1", "--scenarios", "random",
                               "--episode-timeout", "4", "--cluster", cluster.address)
    workers = cluster.processes[1:]
    for _ in range(2):  # kill whichever worker plays the bt episode, twice
        playing = playing_worker(workers, process, b"-bt-random-0")
        playing.send_signal(signal.SIGKILL)
        playing.wait()
        workers.remove(playing)
    cluster.processes.append(cluster.start_worker(2))
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 0, stderr
    summary = json.loads((tmp_path / "evaluation" / "summary.json").read_text())
    (bt,) = summary["bt"]["rows"]
    assert bt["failure"] == "the worker playing it died mid-episode, 2 times; not played again"
    assert not bt["completed"] and not bt["not_run"]
    (baseline,) = summary["baseline"]["rows"]
    assert baseline["failure"] == "episode wall-time limit of 4 s exceeded; stopped"


def playing_worker(workers: list[subprocess.Popen[bytes]], evaluation: subprocess.Popen[str],
                   run_id_part: bytes, limit_s: float = 60.0) -> subprocess.Popen[bytes]:
    """The worker whose episode ``run_id_part`` has written its first report (its orphan is
    up)."""
    deadline = time.monotonic() + limit_s
    while True:
        for worker in workers:
            lines = [_command_line(pid) for pid in descendants(worker.pid)]
            if any(run_id_part in line for line in lines) and len(lines) >= 2:
                return worker
        if evaluation.poll() is not None or time.monotonic() > deadline:
            evaluation.kill()
            pytest.fail(f"episode {run_id_part!r} not seen on a worker: "
                        f"{evaluation.communicate()}")
        time.sleep(0.1)
