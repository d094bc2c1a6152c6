"""Lockstep on a live graph: a client that dies does not hang the simulator.

The simulator runs in its own process, held at its first period for a client to join; the
client, in a process of its own, joins and is then killed with SIGKILL before it says it is
done. The simulator must drop it after its bound of wall time, say so naming it, and go on.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from servicesim_competition.msg import LockstepPeriod

from servicesim_sim.lockstep.server import JOIN_SERVICE, PERIOD_TOPIC
from tests.fakes.commands import stop_child

JOINING_CLIENT = textwrap.dedent(f"""
    import rclpy, time
    from servicesim_competition.srv import LockstepJoin
    rclpy.init()
    node = rclpy.create_node("doomed_client")
    client = node.create_client(LockstepJoin, "{JOIN_SERVICE}")
    client.wait_for_service(timeout_sec=60.0)
    future = client.call_async(LockstepJoin.Request(name="doomed"))
    rclpy.spin_until_future_complete(node, future, timeout_sec=60.0)
    print("joined at", future.result().joined_at.period, flush=True)
    time.sleep(600)
""")


def wait_for_line(path: Path, text: str, limit_s: float) -> str | None:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        for line in path.read_text().splitlines():
            if text in line:
                return line
        time.sleep(0.2)
    return None


@pytest.mark.long
def test_a_killed_lockstep_client_is_dropped_and_the_simulator_goes_on(
        tmp_path: Path, ros_context: Any) -> None:
    sim_log, client_log = tmp_path / "sim.log", tmp_path / "client.log"
    with sim_log.open("w") as sim_out, client_log.open("w") as client_out:
        simulator = subprocess.Popen(
            [sys.executable, "-m", "servicesim_sim", "--speed", "0", "--await-lockstep", "60"],
            stdout=sim_out, stderr=subprocess.STDOUT)
        client = subprocess.Popen([sys.executable, "-c", JOINING_CLIENT], stdout=client_out,
                                  stderr=subprocess.STDOUT)
        try:
            assert wait_for_line(client_log, "joined at", 90.0), client_log.read_text()
            client.send_signal(signal.SIGKILL)
            client.wait(timeout=10)
            dropped = wait_for_line(sim_log, "dropped client 'doomed'", 60.0)
            assert dropped is not None, sim_log.read_text()[-2000:]
            assert "at period 1 " in dropped
            assert periods_seen_beyond(1, context=ros_context, limit_s=30.0), \
                "the simulator did not go on"
        finally:
            for process in (client, simulator):
                stop_child(process)


def periods_seen_beyond(period: int, *, context: Any, limit_s: float) -> bool:
    """Whether the simulator announces a period past ``period`` within ``limit_s``."""
    node = Node("lockstep_probe", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    seen: list[int] = []
    node.create_subscription(LockstepPeriod, PERIOD_TOPIC, lambda m: seen.append(m.period),
                             QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    try:
        deadline = time.monotonic() + limit_s
        while time.monotonic() < deadline and not any(p > period + 10 for p in seen):
            executor.spin_once(timeout_sec=0.1)
        return any(p > period + 10 for p in seen)
    finally:
        executor.shutdown()
        node.destroy_node()


def test_the_simulator_runs_one_period_ahead_unless_told_to_take_turns(
        monkeypatch: Any) -> None:
    from servicesim_sim.lockstep.server import LAG_VARIABLE, pipeline_lag

    monkeypatch.delenv(LAG_VARIABLE, raising=False)
    assert pipeline_lag() == 1
    monkeypatch.setenv(LAG_VARIABLE, "0")
    assert pipeline_lag() == 0
    monkeypatch.setenv(LAG_VARIABLE, "2")
    with pytest.raises(SystemExit, match=f"{LAG_VARIABLE}='2': must be 0 or 1"):
        pipeline_lag()


def test_a_join_is_answered_once_every_reader_acknowledged_what_was_published(
        ros_context: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """What the simulator sent before a join must be in the client's readers before the answer
    (docs/reference/simulator.md, "Joining"): every publisher is waited on, within one deadline; a
    reader that does not acknowledge in time does not keep the client out."""
    from rclpy.publisher import Publisher
    from servicesim_competition.srv import LockstepJoin
    from std_msgs.msg import String

    from servicesim_sim.lockstep import server as lockstep
    from servicesim_sim.lockstep.joining import JOIN_ACK_WAIT_S

    node = Node("acknowledged_join", context=ros_context)
    asked: list[tuple[str, float]] = []

    def wait_for_all_acked(publisher: Publisher, timeout: Any) -> bool:
        asked.append((publisher.topic_name, timeout.nanoseconds / 1e9))
        return publisher.topic_name != "/stuck"

    monkeypatch.setattr(Publisher, "wait_for_all_acked", wait_for_all_acked)
    try:
        server = lockstep.LockstepServer(node)
        node.create_publisher(String, "/first", 10)
        answer = server.joining.answer(LockstepJoin.Request(name="a"), LockstepJoin.Response())
        assert sorted(topic for topic, _ in asked) == sorted(
            publisher.topic_name for publisher in node.publishers)
        assert all(0.0 < timeout <= JOIN_ACK_WAIT_S for _, timeout in asked)
        assert answer.client == 1
        asked.clear()
        node.create_publisher(String, "/stuck", 10)
        answer = server.joining.answer(LockstepJoin.Request(name="b"), LockstepJoin.Response())
        assert ("/stuck" in {topic for topic, _ in asked}) and answer.client == 2
    finally:
        node.destroy_node()
