"""The episode reset, which warm pairs play on: a running simulator starts a new episode as a
start would, and refuses a bad request with the command's own one-line error, playing on with
what it had.

Over real DDS against ``python -m servicesim_sim`` in a subprocess: the task the simulator
plays is read back through the competition's own services (``new_task``, ``task_info``) and
compared with the task the world and seed draw without ROS.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from servicesim_competition.srv import NewTask, ResetEpisode, TaskInfo

from servicesim_sim.model.scenario import Difficulty, make_scenario
from servicesim_sim.world.files import DEFAULT_WORLD, load_world

ANSWER_WAIT_S = 60.0  # a generous bound on an answer on a loaded machine; not a benchmark


class Probe:
    """A node calling the simulator's services and reading its clock."""

    def __init__(self, context: Context) -> None:
        self.node = Node("reset_probe", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.clock_s: float | None = None
        self.node.create_subscription(Clock, "/clock", self._on_clock, 10)

    def _on_clock(self, message: Clock) -> None:
        self.clock_s = message.clock.sec + message.clock.nanosec * 1e-9

    def call(self, kind: Any, name: str, request: Any) -> Any:
        client = self.node.create_client(kind, name)
        try:
            assert client.wait_for_service(timeout_sec=ANSWER_WAIT_S), f"no {name}"
            future = client.call_async(request)
            deadline = time.monotonic() + ANSWER_WAIT_S
            while not future.done() and time.monotonic() < deadline:
                self.executor.spin_once(timeout_sec=0.05)
            assert future.done(), f"{name}: no answer within {ANSWER_WAIT_S:.0f} s"
            return future.result()
        finally:
            self.node.destroy_client(client)

    def reset(self, *arguments: str) -> ResetEpisode.Response:
        return self.call(ResetEpisode, "/servicesim/reset",
                         ResetEpisode.Request(arguments=list(arguments)))

    def task(self, service: str = "/servicesim/new_task") -> tuple[str, str, str]:
        kind = NewTask if service.endswith("new_task") else TaskInfo
        answer = self.call(kind, service, kind.Request())
        return answer.pick_up_location, answer.drop_off_location, answer.guest_name

    def clock_restarted(self) -> bool:
        """Whether a /clock below 1 s arrives: the old episode's clock was past that (the
        simulator runs flat out once a task started), the new one is paced at real time
        until its task starts."""
        self.clock_s = None
        deadline = time.monotonic() + ANSWER_WAIT_S
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
            if self.clock_s is not None and self.clock_s < 1.0:
                return True
        return False


def drawn_task(seed: int | None) -> tuple[str, str, str]:
    task = make_scenario(load_world(DEFAULT_WORLD), seed=seed,
                         difficulty=Difficulty.default()).task
    return task.pick_up, task.drop_off, task.guest_name


@pytest.fixture
def simulator(tmp_path: Path) -> Iterator[subprocess.Popen[bytes]]:
    with (tmp_path / "sim.log").open("wb") as log:
        process = subprocess.Popen([sys.executable, "-m", "servicesim_sim", "--speed", "0"],
                                   stdout=log, stderr=subprocess.STDOUT)
    try:
        yield process
    finally:
        process.terminate()
        process.wait(timeout=30)


def test_a_reset_plays_the_new_seed_from_the_start_and_a_bad_one_changes_nothing(
        simulator: subprocess.Popen[bytes], ros_context: Context) -> None:
    probe = Probe(ros_context)
    assert drawn_task(5) != drawn_task(7) != drawn_task(None)
    assert probe.task() == drawn_task(None)  # started with the shipped task

    assert probe.reset("--seed", "5", "--speed", "0").accepted
    assert probe.clock_restarted(), "the clock starts again at 0"
    assert probe.task("/servicesim/task_info") == ("", "", ""), "no task started yet"
    assert probe.task() == drawn_task(5)

    for arguments, named in ((["--seed", "-1"], "--seed -1: must be 0 or more"),
                             (["--no-such-knob"], "unrecognized arguments: --no-such-knob"),
                             (["--world", "/nowhere/office.world"], "/nowhere/office.world"),
                             (["--rfid-dropout", "2"], "--rfid-dropout 2.0: must be within"),
                             (["--seed", "five"], "invalid int value: 'five'"),
                             (["--help"], "--help")):
        answer = probe.reset(*arguments)
        assert not answer.accepted
        assert named in answer.error and "\n" not in answer.error, answer.error
    assert probe.task("/servicesim/task_info") == drawn_task(5), "the episode plays on"
    assert simulator.poll() is None

    assert probe.reset("--seed", "7", "--speed", "0").accepted
    assert probe.clock_restarted()
    assert probe.task() == drawn_task(7)
    assert simulator.poll() is None
