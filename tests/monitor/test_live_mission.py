"""A live mission with ``run --groot``: ``btview snapshot`` prints the mission tree with its
statuses while the run goes on, and the server stops with the run.

The statuses btview shows are checked against the run's own record of every tick (the tree
log, from which the terminal view and the replay draw): they are the tree's at one of them."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from py_trees.common import Status

from bt_servicesim.records.tree_log import LOG_NAME, TreeState, read_tree_log
from bt_servicesim.tree.loading import load_mission_tree
from bt_servicesim.tree.shape import short_label, walk
from tests.monitor.groot2_client import free_port
from tests.monitor.test_btview import btview, snapshot_rows

STARTUP_LIMIT_S = 150.0
STOP_LIMIT_S = 60.0
SPEED = "1"
"""Real time: the shipped task's mission (250 sim s) lasts about four wall minutes, so it is
still under way when the snapshot comes however loaded the machine is. At speed 10 it lasted
25 s, and on a loaded CI machine the SIGINT once came only as it ended (exit status 0)."""


def snapshot_while_running(port: int, run: subprocess.Popen[str]) -> list[tuple[str, str]]:
    """The first snapshot in which the mission is RUNNING."""
    deadline = time.monotonic() + STARTUP_LIMIT_S
    while time.monotonic() < deadline and run.poll() is None:
        result = btview("snapshot", "--no-color", "-p", str(port), "--timeout", "2")
        rows = snapshot_rows(result.stdout)
        if rows and rows[0][1] == "RUNNING":
            return rows
        time.sleep(0.5)
    raise AssertionError(f"no running mission to see (run exit code {run.poll()})")


def logged_statuses(out: Path) -> set[tuple[str, ...]]:
    """Every node's status, as btview names them, at every tick the run logged a change."""
    history = read_tree_log(out / LOG_NAME)

    def shown(state: TreeState, key: str) -> str:
        status = state.nodes.get(key, (Status.INVALID, ""))[0]
        return "IDLE" if status == Status.INVALID else status.name

    return {tuple(shown(state, key) for key in history.shape.keys) for state in history.states}


@pytest.mark.long
def test_btview_snapshot_shows_the_live_mission_and_the_server_stops_with_the_run(
        tmp_path: Path) -> None:
    port = free_port()
    started = time.monotonic()
    run = subprocess.Popen(
        [sys.executable, "-m", "bt_servicesim.run", "--headless", "--speed", SPEED,
         "--groot", str(port), "--out", str(tmp_path / "run"), "--trajectory", "never"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        rows = snapshot_while_running(port, run)
        snapshot_after_s = time.monotonic() - started
        run.send_signal(signal.SIGINT)
        _, stderr = run.communicate(timeout=STOP_LIMIT_S)
    finally:
        if run.poll() is None:
            run.kill()
            run.communicate()
    names = [short_label(behaviour.name) for behaviour in walk(load_mission_tree())]
    assert [name for name, _ in rows] == names
    running = [name for name, status in rows if status == "RUNNING"]
    assert running[:2] == ["ServiceSimMission", "Topics2BB-KeepReading"]
    assert run.returncode == 130, (
        f"SIGINT {snapshot_after_s:.1f} s after the start; the run said: {stderr.strip()}")
    assert tuple(status for _, status in rows) in logged_statuses(tmp_path / "run")
    after = btview("snapshot", "--no-color", "-p", str(port), "--timeout", "0.5")
    assert after.returncode != 0, "the server outlived its run"
