"""The monitor never slows the tick: with ``btview echo`` polling at 50 Hz the ticking thread
does no more work than with no monitor at all, within a margin a loaded machine cannot breach.

The figure compared is the ticking thread's own CPU time (``time.thread_time``), which neither
the machine's load nor the server thread's work counts into; ``benchmarks/tick_cost.py`` prints
the wall-clock figures. The blocks of ticks alternate between the settings so that whatever
else happens on the machine falls on all of them alike."""

from __future__ import annotations

import signal
import subprocess
import time

import py_trees
import pytest

from bt_servicesim.monitor.groot2_server import Groot2Server
from bt_servicesim.tree.lean_tree import LeanBehaviourTree
from tests.monitor.test_btview import BTVIEW, wait_for_requests

BLOCKS = 3
TICKS_PER_BLOCK = 400
MARGIN = 1.5
"""A tick with the monitor polled may cost at most this many times one without a monitor."""


def wide_tree() -> py_trees.trees.BehaviourTree:
    """161 behaviours, every one ticked on every tick (the mission tree has 133, fewer of
    them ticked), in the executive's kind of tree."""
    behaviours = py_trees.behaviours
    root = py_trees.composites.Sequence(name="Root", memory=False, children=[
        py_trees.composites.Selector(name=f"Choice{index}", memory=False, children=[
            behaviours.Failure(name=f"No{index}"), behaviours.Failure(name=f"Nor{index}"),
            behaviours.Success(name=f"Yes{index}")])
        for index in range(40)])
    return LeanBehaviourTree(root)


def tick_cpu_s(tree: py_trees.trees.BehaviourTree, ticks: int) -> float:
    started = time.thread_time()
    for _ in range(ticks):
        tree.tick()
    return time.thread_time() - started


@pytest.fixture
def polled() -> tuple[Groot2Server, py_trees.trees.BehaviourTree, subprocess.Popen[bytes]]:
    with Groot2Server(port=0) as server:
        tree = wide_tree()
        server.watch(tree)
        client = subprocess.Popen([str(BTVIEW), "echo", "--poll-hz", "50", "-p",
                                   str(server.port)], stdout=subprocess.DEVNULL)
        try:
            wait_for_requests(server, 3)
            yield server, tree, client
        finally:
            client.kill()
            client.wait()


@pytest.mark.long
def test_a_client_polling_at_50_hz_costs_the_tick_nothing_measurable(
        polled: tuple[Groot2Server, py_trees.trees.BehaviourTree, subprocess.Popen[bytes]]
) -> None:
    server, watched, client = polled
    unwatched = wide_tree()
    without, with_client, requests = 0.0, 0.0, 0
    for _ in range(BLOCKS):
        client.send_signal(signal.SIGSTOP)
        without += tick_cpu_s(unwatched, TICKS_PER_BLOCK)
        client.send_signal(signal.SIGCONT)
        before = server.requests
        with_client += tick_cpu_s(watched, TICKS_PER_BLOCK)
        requests += server.requests - before
    assert requests >= BLOCKS, "the client did not poll while the tree ticked"
    assert with_client <= MARGIN * without, (
        f"{with_client / without:.2f} times the tick's CPU with a polling client")
