"""``evaluate --cluster``: the episodes on a Dask cluster of two workers the test starts.

The cluster is the real thing, on loopback only: ``dask scheduler`` and two ``dask worker``
processes of one thread each, bound to 127.0.0.1, no dashboard. Real episodes (short missions of
the bt executive, in lockstep, so a seed replays) run once on the cluster and once in the local
pool, and must give the same rows and summary; fake episodes (those of ``test_evaluate.py``)
check what only timing can show: a stop reaching every episode under way on any worker, and a
worker that dies mid-episode.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from bt_servicesim.evaluation.cluster import cluster_address
from bt_servicesim.cli import UsageError
from tests.evaluation.test_evaluate import alive, files_under, start_evaluation, wait_for

CLUSTER_UP_S = 60.0


class Cluster:
    """A scheduler and two single-threaded workers on 127.0.0.1, stopped by their pids."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.scheduler_file = directory / "scheduler.json"
        self.processes: list[subprocess.Popen[bytes]] = []

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
        for process in reversed(self.processes):
            if process.poll() is None:
                process.terminate()
        for process in self.processes:
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()

    def _dask(self, *arguments: str) -> subprocess.Popen[bytes]:
        log = (self.directory / f"{arguments[0]}-{len(self.processes)}.log").open("wb")
        return subprocess.Popen([sys.executable, "-m", "dask", *arguments], stdout=log,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)

    def _wait_for_workers(self, count: int) -> None:
        deadline = time.monotonic() + CLUSTER_UP_S
        while not self.scheduler_file.exists():
            assert time.monotonic() < deadline, "the scheduler did not come up"
            time.sleep(0.1)
        from distributed import Client

        with Client(self.address, timeout=CLUSTER_UP_S, set_as_default=False) as client:
            client.wait_for_workers(count, timeout=CLUSTER_UP_S)


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[Cluster]:
    started = Cluster(tmp_path / "cluster")
    started.directory.mkdir()
    try:
        yield started.start()
    finally:
        started.stop()


def evaluation(out: Path, *arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bt_servicesim.evaluate", "--out", str(out), *arguments],
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


def test_a_cluster_of_two_workers_gives_the_local_pools_results(
        tmp_path: Path, cluster: Cluster) -> None:
    common = ("--episodes", "2", "--scenarios", "random", "--executive", "bt", "--seed", "3",
              "--speed", "0", "--time-limit", "40")
    local = evaluation(tmp_path / "local", *common, "--jobs", "2")
    assert local.returncode == 0, local.stderr
    remote = evaluation(tmp_path / "remote", *common, "--cluster", cluster.address)
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
    assert "2/2 episodes" in remote.stderr and "results:" in remote.stderr
