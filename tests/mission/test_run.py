"""The run's start-up gate: the tree starts once every server its executive calls is there; its
sim-time backstop counts from the mission's start."""

from __future__ import annotations

import dataclasses
import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from servicesim_competition.msg import RefereeState
from std_srvs.srv import Empty

from bt_servicesim.mission import run as mission_run
from bt_servicesim.mission.referee_monitor import RefereeMonitor
from bt_servicesim.mission.run import SIM_TIME_BACKSTOP_S, MissionRun, outlived_time_limit
from bt_servicesim.mission.settings import RunSettings
from bt_servicesim.tree.files import DEFAULT_NAV_PARAMS
from bt_servicesim.tree.loading import DEFAULT_TREE


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


SECOND_NS = 10**9


@pytest.mark.parametrize(("since_start_s", "outlived"), [
    (0.0, False),
    (30.0 + SIM_TIME_BACKSTOP_S, False),  # the limit and the backstop's grace, to the second
    (30.0 + SIM_TIME_BACKSTOP_S + 0.001, True),
])
def test_the_backstop_counts_from_the_missions_start_not_the_clocks_zero(
        since_start_s: float, outlived: bool) -> None:
    """A backend whose clock already reads 5000 s (Gazebo running since its launch) gives a
    30 s mission 30 s and the backstop's grace, not nothing."""
    started_ns = 5000 * SECOND_NS
    now_ns = started_ns + round(since_start_s * SECOND_NS)
    assert outlived_time_limit(started_ns=started_ns, now_ns=now_ns,
                               time_limit_s=30.0) is outlived


def test_a_backend_without_referee_state_leaves_the_referees_books_unknown(
        ros_context: Any) -> None:
    node = Node("no_referee", context=ros_context)
    try:
        monitor = RefereeMonitor(node)
        assert monitor.report_fields()["referee_heard"] is False
        assert "what the referee counted is unknown" in monitor.unheard()
        assert "/servicesim/referee" in monitor.unheard()
        monitor.latest = RefereeState(checkpoint_names=["a"], checkpoint_done=[True],
                                      checkpoint_sim_time=[1.0])
        assert monitor.unheard() == "" and monitor.report_fields()["referee_heard"] is True
    finally:
        node.destroy_node()


def test_the_report_says_when_the_run_saw_the_task_start_and_end(ros_context: Any) -> None:
    """``task_timing``, for benchmarks: the first and the latest state of the task the monitor
    took, with the monotonic clock; nothing before the task, nothing once frozen."""
    node = Node("task_timing", context=ros_context)
    try:
        monitor = RefereeMonitor(node)
        monitor._on_state(RefereeState(task_running=False))
        assert monitor.task_timing() is None
        before = time.monotonic()
        monitor._on_state(RefereeState(task_running=True, task_sim_time=0.5))
        monitor._on_state(RefereeState(task_running=True, task_sim_time=40.0))
        monitor._on_state(RefereeState(task_running=False, completed=True, task_sim_time=80.0))
        after = time.monotonic()
        monitor.freeze()
        monitor._on_state(RefereeState(completed=True, task_sim_time=99.0))
        timing = monitor.task_timing()
        assert timing is not None
        assert [timing[end]["task_sim_time_s"] for end in ("first", "last")] == [0.5, 80.0]
        first, last = timing["first"]["monotonic_s"], timing["last"]["monotonic_s"]
        assert before - 1e-3 <= first <= last <= after + 1e-3
    finally:
        node.destroy_node()


@pytest.mark.parametrize(("attach", "free_running", "reliable"), [
    (False, False, True), (False, True, False), (True, False, False)],
    ids=["own simulator", "free running", "attached"])
def test_subscriptions_are_reliable_from_the_start_only_with_our_simulator_in_lockstep(
        tmp_path: Path, attach: bool, free_running: bool, reliable: bool) -> None:
    """The records subscribe before the lockstep offer; with our simulator the run knows the
    answer already. Attached to another backend it cannot: a reliable reader would hear
    nothing of a driver publishing best effort."""
    settings = RunSettings(world=None, seed=None, speed=0.0, tree=DEFAULT_TREE, out=tmp_path,
                           time_limit_s=900.0, headless=True, executive="bt", attach=attach,
                           free_running=free_running)
    run = MissionRun(settings=settings, make_executive=lambda node: None)  # type: ignore[arg-type]
    assert run.reliable_from_the_start() is reliable
    assert run._header("running")["timing"] is None  # not known before the offer


@pytest.mark.parametrize("code", [0, 1])
def test_a_stop_signal_during_the_clean_up_still_makes_the_exit_status_say_so(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, code: int) -> None:
    """The mission ended (completed or failed) and the run was cleaning up when Ctrl-C came:
    the signal is only noted then, but the run must still exit 130, as ``run`` promises."""
    settings = RunSettings(world=None, seed=None, speed=0.0, tree=DEFAULT_TREE, out=tmp_path,
                           time_limit_s=900.0, headless=True, executive="bt")

    def ended_then_interrupted(_run: MissionRun, _node: Any, stops: Any) -> int:
        stops.hold()
        os.kill(os.getpid(), signal.SIGINT)
        return code

    monkeypatch.setattr(mission_run.rclpy, "init", lambda **_: None)
    monkeypatch.setattr(mission_run.rclpy, "try_shutdown", lambda: None)
    monkeypatch.setattr(MissionRun, "_node", lambda _run: None)
    monkeypatch.setattr(MissionRun, "_execute_on", ended_then_interrupted)
    run = MissionRun(settings=settings, make_executive=lambda node: None)  # type: ignore[arg-type]
    before = signal.getsignal(signal.SIGINT)
    assert run.execute() == 130
    assert signal.getsignal(signal.SIGINT) is before


def test_the_last_line_says_when_a_lockstep_run_may_not_replay() -> None:
    in_step = {"timing": "lockstep", "lockstep_stalls": 0, "lockstep_dropped": None}
    assert mission_run._replay_warning(in_step) == ""
    free = {"timing": "free running", "lockstep_stalls": None}
    assert mission_run._replay_warning(free) == ""  # it said so at start-up
    assert "2 lockstep period(s)" in mission_run._replay_warning(
        {**in_step, "lockstep_stalls": 2})
    dropped = mission_run._replay_warning(
        {**in_step, "lockstep_dropped": {"period": 1388, "sim_time_s": 138.8}})
    assert dropped == (" (may not replay: the simulator dropped the run from lockstep at "
                       "138.8 s sim, and it ran free from there)")


def test_the_run_keeps_a_copy_of_its_navigation_parameters_and_names_their_digest(
        tmp_path: Path) -> None:
    params = tmp_path / "mine.yaml"
    params.write_text("controller_server:\n  ros__parameters: {}\n")
    out = tmp_path / "run"
    out.mkdir()
    (out / "nav_params.yaml").write_text("an earlier run's")
    settings = RunSettings(world=None, seed=3, speed=0.0, tree=DEFAULT_TREE, out=out,
                           time_limit_s=900.0, headless=True, executive="bt", attach=True,
                           nav_params=params)
    run = MissionRun(settings=settings, make_executive=lambda node: None)  # type: ignore[arg-type]
    run._clear_what_an_earlier_run_left()
    run._keep_the_nav_params()
    assert (out / "nav_params.yaml").read_text() == params.read_text()
    record = run._header("running")["nav_params"]
    assert record == {"file": str(params),
                      "sha256": hashlib.sha256(params.read_bytes()).hexdigest()}
    assert f"--nav-params {params}" in run._header("running")["reproduce"]
    default = MissionRun(settings=dataclasses.replace(settings, nav_params=None),
                         make_executive=lambda node: None)  # type: ignore[arg-type]
    default._clear_what_an_earlier_run_left()
    default._keep_the_nav_params()
    assert not (out / "nav_params.yaml").exists(), "an earlier run's copy is not this run's"
    assert default._header("running")["nav_params"] is None
    assert "--nav-params" not in default._header("running")["reproduce"]


def test_the_reproduce_command_names_the_checkout_s_own_files_from_the_repository_root(
        tmp_path: Path) -> None:
    settings = RunSettings(world=None, seed=3, speed=0.0, tree=DEFAULT_TREE, out=tmp_path / "run",
                           time_limit_s=900.0, headless=True, executive="bt", attach=True,
                           nav_params=DEFAULT_NAV_PARAMS)
    words = mission_run.reproduce_command(settings, ()).split()
    assert words[words.index("--tree") + 1] == "trees/servicesim_mission.xml"
    assert words[words.index("--nav-params") + 1] == "trees/servicesim_nav2_params.yaml"
    elsewhere = tmp_path / "mine.xml"
    words = mission_run.reproduce_command(dataclasses.replace(settings, tree=elsewhere),
                                          ()).split()
    assert words[words.index("--tree") + 1] == str(elsewhere)


def test_a_run_loads_the_monitors_libraries_only_when_it_serves_them() -> None:
    """Groot2's server (ZeroMQ) and the Foxglove bridge (the Foxglove SDK) come with ``--groot``
    and ``--foxglove``: a run that serves neither does not load them."""
    program = ("import sys, bt_servicesim.run, bt_servicesim.mission.run, "
               "bt_servicesim.mission.run_records; print(sorted({name.split('.')[0] for name "
               "in sys.modules} & {'foxglove', 'zmq'}))")
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.strip() == "[]"
