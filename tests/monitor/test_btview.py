"""A client nobody here wrote, ``btview`` (PyPI), reads our server: its snapshot and its stream
of transitions show the node names and statuses the terminal view shows."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import py_trees
import pytest

from bt_servicesim.monitor.groot2_server import Groot2Server
from bt_servicesim.tree.shape import ShadowTree, TreeShape, walk
from tests.monitor.scripted_tree import scripted_tree

BTVIEW = Path(sys.executable).with_name("btview")
#: py_trees' unicode status marks, as BehaviorTree.CPP names the statuses
TERMINAL_MARKS = {"✓": "SUCCESS", "✕": "FAILURE", "*": "RUNNING", "-": "IDLE"}
TERMINAL_LINE = re.compile(r"^\s*\S+ (?P<name>.+?) \[(?P<mark>[✓✕*-])\]")
#: a node in ``btview snapshot``: its glyph, name, tag (left out when it is the name), uid (with
#: ``--uid``), then its status, or "was" a status when it is idle after one
SNAPSHOT_LINE = re.compile(
    r"^[\s│├└─]*\S+ (?P<name>\S+)(?: \[[^\]]+\])?(?: #\d+)?\s+\S+ "
    r"(?P<was>was )?(?P<status>RUNNING|SUCCESS|FAILURE|IDLE|SKIPPED)\s*$")
WAIT_LIMIT_S = 30.0


def btview(*arguments: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(BTVIEW), *arguments], capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, "COLUMNS": "200"})


def terminal_view(root: py_trees.behaviour.Behaviour) -> list[tuple[str, str]]:
    """(name, status) of every node as the terminal view draws them (all branches)."""
    shadow = ShadowTree(TreeShape.of(root))
    shadow.copy_from(walk(root))
    rows = [TERMINAL_LINE.match(line) for line in shadow.text(show_status=True).splitlines()]
    return [(row["name"], TERMINAL_MARKS[row["mark"]]) for row in rows if row]


def snapshot_rows(output: str) -> list[tuple[str, str]]:
    rows = [SNAPSHOT_LINE.match(line) for line in output.splitlines()]
    return [(row["name"], "IDLE" if row["was"] else row["status"]) for row in rows if row]


@pytest.fixture
def server() -> Iterator[Groot2Server]:
    with Groot2Server(port=0) as serving:
        yield serving


@pytest.mark.parametrize("ticks", [0, 1, 4])
def test_btview_snapshot_shows_the_terminal_views_names_and_statuses(
        server: Groot2Server, ticks: int) -> None:
    tree = scripted_tree()
    server.watch(tree)
    for _ in range(ticks):
        tree.tick()
    result = btview("snapshot", "--no-color", "--uid", "-p", str(server.port))
    assert result.returncode == 0, result.stderr
    assert len(snapshot_rows(result.stdout)) == 10, result.stdout
    assert snapshot_rows(result.stdout) == terminal_view(tree.root)


def wait_for_requests(server: Groot2Server, count: int) -> None:
    deadline = time.monotonic() + WAIT_LIMIT_S
    while server.requests < count:
        assert time.monotonic() < deadline, f"btview sent {server.requests} requests"
        time.sleep(0.01)


def test_btview_echo_streams_each_ticks_transitions(server: Groot2Server) -> None:
    tree = scripted_tree()
    server.watch(tree)
    echo = subprocess.Popen(
        [str(BTVIEW), "echo", "--json", "--poll-hz", "50", "-p", str(server.port)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_requests(server, 3)  # the tree and two polls: it has seen everything IDLE
        views = []
        while tree.root.status not in (py_trees.common.Status.SUCCESS,):
            tree.tick()
            views.append(terminal_view(tree.root))
            wait_for_requests(server, server.requests + 2)  # a poll after this tick
        echo.send_signal(signal.SIGINT)
        output, errors = echo.communicate(timeout=WAIT_LIMIT_S)
    finally:
        if echo.poll() is None:
            echo.kill()
            echo.wait()
    transitions = [json.loads(line) for line in output.splitlines() if line.startswith("{")]
    assert transitions, errors
    seen = {uid: ("", "IDLE") for uid in range(1, 11)}
    for transition in transitions:
        name = transition["node"].rsplit(" [", 1)[0]
        assert transition["from"] == seen[transition["uid"]][1]
        seen[transition["uid"]] = (name, transition["to"])
    final = dict(views[-1])
    assert {name: status for name, status in seen.values() if name} == {
        name: status for name, status in final.items() if status != "IDLE"}
    work = [t["to"] for t in transitions if t["node"].startswith("Work ")]
    assert work == ["RUNNING", "SUCCESS"]
