"""The run's start-up gate: the tree starts once every server its executive calls is there."""

from __future__ import annotations

import time
from typing import Any

import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_srvs.srv import Empty

from bt_servicesim.mission import run as mission_run
from bt_servicesim.mission.run import MissionRun


def test_the_run_waits_until_every_client_has_its_server(ros_context: Any) -> None:
    executive = Node("gate_executive", context=ros_context)
    simulator = Node("gate_simulator", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(executive)
    executor.add_node(simulator)
    try:
        first = executive.create_client(Empty, "/gate/first")
        second = executive.create_client(Empty, "/gate/second")
        simulator.create_service(Empty, "/gate/first", lambda _, response: response)
        simulator.create_service(Empty, "/gate/second", lambda _, response: response)
        MissionRun._wait_for_servers(executive, executor)
        assert first.service_is_ready() and second.service_is_ready()
    finally:
        executive.destroy_node()
        simulator.destroy_node()


def test_a_server_that_never_comes_holds_the_run_only_until_the_limit(
        ros_context: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mission_run, "SERVER_WAIT_LIMIT_S", 0.5)
    executive = Node("gate_executive", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(executive)
    try:
        missing = executive.create_client(Empty, "/gate/nobody")
        started = time.monotonic()
        MissionRun._wait_for_servers(executive, executor)
        assert 0.5 <= time.monotonic() - started < 5.0
        assert not missing.service_is_ready()
    finally:
        executive.destroy_node()
