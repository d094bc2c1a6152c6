"""One mission on a live ROS graph: the simulator process, the executive node, the report.

Split from :mod:`bt_servicesim.run` so the command checks its input before rclpy is imported.
The run waits (in wall time, bounded) for the simulator's clock and referee, ticks the tree on
sim time until it ends, then waits briefly for the referee's last word and writes the report.

Beside the report, :class:`RunRecords` keeps the run's records in the run directory: the tree's
snapshot log (``tree_log.jsonl``) and its final tick (``final_tree.txt``) when the executive is
a behaviour tree, the trajectory picture (``trajectory.png``) and the ROS traffic (``run.mcap``).
They are written on every way out, Ctrl-C included; a record that cannot be written costs a
warning line, never the report.

The executive's node is spun by rclpy's experimental C++ ``EventsExecutor``. It takes a message
for about a quarter of the CPU rclpy's ``SingleThreadedExecutor`` needs (49 against 207 µs,
measured on this project's machine with the simulator's burst of five scores and an odometry
message every 2 ms), and at 50 times real time the executive's share of the machine was
mostly that per-message work. Two things it does differently are handled here: it runs no
timers on ROS time (Kilted), so the executives tick from the clock itself
(:mod:`bt_servicesim.ros.sim_ticker`); and it catches SIGINT and SIGTERM itself to shut the
context down, so the run puts Python's handlers back: Ctrl-C must reach the run as
``KeyboardInterrupt``, which stops the tree and cancels what is in flight first.
"""

from __future__ import annotations

import json
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import py_trees
import rclpy
from rclpy.action import ActionClient
from rclpy.executors import Executor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from servicesim_competition.srv import NewTask

from bt_servicesim.cli import EXIT_BAD_INPUT, EXIT_COMPLETED, EXIT_FAILED, EXIT_INTERRUPTED
from bt_servicesim.mission.progress import ProgressView
from bt_servicesim.mission.referee_monitor import RefereeMonitor
from bt_servicesim.mission.settings import REPORT_NAME, STARTUP_LIMIT_S, RunSettings
from bt_servicesim.mission.simulator_process import SimulatorProcess
from bt_servicesim.records.mcap import (
    MCAP_NAME,
    TASK_TOPIC,
    TREE_TOPIC,
    McapRecorder,
    TaskTopic,
    TreeTopic,
)
from bt_servicesim.records.trajectory import (
    TRAJECTORY_NAME,
    boxes_from_blackboard,
    render_trajectory,
    trace_from_recording,
)
from bt_servicesim.records.tree_log import LOG_NAME, TreeLog, behaviour_tree_of
from bt_servicesim.ros.node import ExecutiveNode
from bt_servicesim.tree.executive import Executive
from bt_servicesim.tree.shape import ShadowTree

FINAL_TREE_NAME = "final_tree.txt"

DISCOVERY_SETTLE_S = 2.0  # wall seconds for the simulator to discover the clients set up
SERVER_WAIT_LIMIT_S = 30.0  # wall seconds the run waits for every server its executive calls
FINAL_STATE_WAIT_S = 3.0  # wall seconds to wait for the referee's last state
SIM_TIME_BACKSTOP_S = 60.0  # sim seconds past the time limit before the run gives up itself
SIMULATOR_CHECK_PERIOD_S = 0.1  # wall seconds between looks at whether the simulator exited


class MissionRun:
    """Everything one ``python -m bt_servicesim.run`` does once its input is good."""

    def __init__(
        self,
        *,
        settings: RunSettings,
        make_executive: Callable[[Node], Executive],
        extra_sim_args: tuple[str, ...] = (),
    ) -> None:
        self.settings = settings
        self.make_executive = make_executive
        self.simulator = SimulatorProcess(
            world=settings.world, seed=settings.seed, speed=settings.speed,
            log_path=settings.out / "sim.log", extra_args=extra_sim_args,
        )
        self.started_wall = time.monotonic()
        self.failure: str | None = None

    def execute(self) -> int:
        self.simulator.start()
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        node = ExecutiveNode("bt_servicesim_executive")
        executor = events_executor()
        executor.add_node(node)
        monitor = RefereeMonitor(node)
        executive = self.make_executive(node)
        records = RunRecords(node=node, executive=executive, out=self.settings.out,
                             tree_file=self.settings.tree)
        try:
            code = self._run(node, executor, monitor, executive, records)
        except KeyboardInterrupt:
            executive.interrupt()
            self._spin_for(executor, 0.5)
            self.failure = "interrupted (Ctrl-C)"
            code = EXIT_INTERRUPTED
        finally:
            self.simulator.stop()
        records.finish(title=self._title(monitor))
        self._finish(monitor, code, executive)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
        return code

    def _run(self, node: Node, executor: Executor, monitor: RefereeMonitor,
             executive: Executive, records: RunRecords) -> int:
        refused = self._wait_for_simulator(node, executor)
        if refused is not None:
            return refused
        executive.setup()
        self._wait_for_servers(node, executor)
        self._spin_for(executor, DISCOVERY_SETTLE_S)
        executive.start()
        view = ProgressView(headless=self.settings.headless,
                            tree_root=records.tree.root if records.tree else None)
        limit_ns = int((self.settings.time_limit_s + SIM_TIME_BACKSTOP_S) * 1e9)
        next_exit_check = time.monotonic()
        while not executive.finished:
            executor.spin_once(timeout_sec=0.05)
            now_ns = node.get_clock().now().nanoseconds
            records.note_phase(executive.phase())
            view.update(executive=executive, monitor=monitor, sim_time_s=now_ns / 1e9)
            if time.monotonic() >= next_exit_check:  # a system call: ten times a wall second
                next_exit_check = time.monotonic() + SIMULATOR_CHECK_PERIOD_S
                if self.simulator.exit_code() is not None:
                    self.failure = f"the simulator exited: {self.simulator.last_error()}"
                    executive.interrupt()
                    return EXIT_FAILED
            if now_ns > limit_ns:
                self.failure = "the mission tree outlived its time limit"
                executive.interrupt()
                return EXIT_FAILED
        self._spin_until(executor, lambda: monitor.completed, FINAL_STATE_WAIT_S)
        view.close(executive=executive, monitor=monitor, sim_time_s=_sim_seconds(node))
        if not monitor.completed:
            self.failure = f"the mission tree ended with {executive.outcome.name}" if (
                executive.outcome) else "the mission did not end"
        return EXIT_COMPLETED if monitor.completed else EXIT_FAILED

    def _wait_for_simulator(self, node: Node, executor: Executor) -> int | None:
        """Until /clock runs and the referee answers; an exit code if the simulator refused."""
        client = node.create_client(NewTask, "/servicesim/new_task")
        deadline = time.monotonic() + STARTUP_LIMIT_S
        while not (client.service_is_ready() and node.get_clock().now().nanoseconds > 0):
            code = self.simulator.exit_code()
            if code is not None:
                self.failure = f"simulator: {self.simulator.last_error()}"
                print(f"python -m bt_servicesim.run: error: {self.failure}", file=sys.stderr)
                return EXIT_BAD_INPUT if code == EXIT_BAD_INPUT else EXIT_FAILED
            if time.monotonic() > deadline:
                self.failure = f"the simulator did not come up within {STARTUP_LIMIT_S:.0f} s"
                return EXIT_FAILED
            executor.spin_once(timeout_sec=0.1)
        node.destroy_client(client)
        return None

    @staticmethod
    def _wait_for_servers(node: Node, executor: Executor) -> None:
        """Until every service and action the executive set up a client for has a server.

        A client is "ready" once its requests reach the server; the server's answers reach
        the client only once the server has discovered the client's reader in turn, which on a
        busy machine can take seconds. An answer sent before that is lost (a drop-off the
        referee granted looked like a timeout), so the tree starts only when every client is
        ready, and DISCOVERY_SETTLE_S later. Bounded: a server that never comes is the
        tree's to wait for and report.
        """
        def every_server_ready() -> bool:
            actions = [w for w in node.waitables if isinstance(w, ActionClient)]
            return (all(client.service_is_ready() for client in node.clients)
                    and all(action.server_is_ready() for action in actions))

        MissionRun._spin_until(executor, every_server_ready, SERVER_WAIT_LIMIT_S)

    def _title(self, monitor: RefereeMonitor) -> str:
        fields = monitor.report_fields()
        world = self.settings.world.stem if self.settings.world else "ServiceSim office"
        seed = "shipped task" if self.settings.seed is None else f"seed {self.settings.seed}"
        outcome = "completed" if fields["completed"] else "not completed"
        done = sum(1 for checkpoint in fields["checkpoints"] if checkpoint["done"])
        return (f"{world}, {seed}, {self.settings.executive} executive: {outcome}, "
                f"{done}/4 checkpoints, score {fields['score']:.1f}, "
                f"{fields['sim_time_s']:.0f} s sim")

    def _finish(self, monitor: RefereeMonitor, code: int, executive: Executive) -> None:
        report: dict[str, Any] = {
            **monitor.report_fields(),
            "wall_time_s": round(time.monotonic() - self.started_wall, 3),
            "seed": self.settings.seed,
            "world": str(self.settings.world) if self.settings.world else "default",
            "executive": self.settings.executive,
            "exit_code": code,
            "failure": self.failure,
            # where a failed run stood: the phase and the running behaviour with its feedback
            "last_activity": (f"{executive.phase()}: {executive.activity()}"
                              if self.failure else None),
        }
        (self.settings.out / REPORT_NAME).write_text(json.dumps(report, indent=2) + "\n")
        verdict = "completed" if report["completed"] else f"failed ({self.failure})"
        print(f"mission {verdict}: score {report['score']:.1f}, "
              f"{report['sim_time_s']:.1f} s sim, {report['wall_time_s']:.1f} s wall; "
              f"report: {self.settings.out / REPORT_NAME}")

    @staticmethod
    def _spin_for(executor: Executor, seconds: float) -> None:
        MissionRun._spin_until(executor, lambda: False, seconds)

    @staticmethod
    def _spin_until(executor: Executor, done: Any, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while not done() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)


def events_executor() -> Executor:
    """rclpy's ``EventsExecutor``, leaving the process's signal handlers as they were."""
    handlers = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    executor = EventsExecutor()
    for number, handler in handlers.items():
        signal.signal(number, handler)
    return executor


def _sim_seconds(node: Node) -> float:
    return node.get_clock().now().nanoseconds / 1e9


class RunRecords:
    """The run's records in its directory (see the module docstring), made on ``node``."""

    def __init__(self, *, node: Node, executive: Executive, out: Path, tree_file: Path) -> None:
        self.out = out
        self.tree = behaviour_tree_of(executive)
        self.mcap = McapRecorder(node=node, path=out / MCAP_NAME,
                                 own_topics=(TASK_TOPIC, TREE_TOPIC))
        self.task = TaskTopic(node=node, recorder=self.mcap)
        # the picture is drawn from the recording after the run: decoding the people's
        # positions as they come would cost the executive a tenth of its time
        self.phases: list[tuple[float, str]] = []
        self._node = node
        self.tree_log: TreeLog | None = None
        self.tree_topic: TreeTopic | None = None
        if self.tree is not None:
            self.tree_log = TreeLog(tree=self.tree, path=out / LOG_NAME,
                                    sim_time_s=lambda: _sim_seconds(node),
                                    tree_file=str(tree_file))
            self.tree_topic = TreeTopic(node=node, recorder=self.mcap, phase=executive.phase)
            self.tree_log.listeners.append(self.tree_topic.publish)
            self.tree.add_post_tick_handler(self.tree_log)

    def note_phase(self, phase: str) -> None:
        """The mission's phase now (the executive's ``phase()``), kept for the picture."""
        if not self.phases or self.phases[-1][1] != phase:
            self.phases.append((_sim_seconds(self._node), phase))

    def finish(self, *, title: str) -> None:
        """Write what is written at the end and close the rest; a failure is a warning."""
        steps: list[tuple[str, Callable[[], None]]] = [
            (MCAP_NAME, self._close_recording),  # the picture is drawn from the finished recording
            (TRAJECTORY_NAME, lambda: self._render_trajectory(title)),
        ]
        if self.tree_log is not None:
            steps += [(LOG_NAME, self.tree_log.close), (FINAL_TREE_NAME, self._write_final_tree)]
        for name, step in steps:
            try:
                step()
            except Exception as error:  # a record is not worth losing the report for
                print(f"warning: could not write {self.out / name}: {error}", file=sys.stderr)

    def _close_recording(self) -> None:
        if self.tree_topic is not None:
            self.tree_topic.flush()  # the last state, if the period held it back
        self.mcap.close()

    def _render_trajectory(self, title: str) -> None:
        boxes = boxes_from_blackboard(py_trees.blackboard.Blackboard.storage)
        trace = trace_from_recording(self.out / MCAP_NAME, phases=self.phases)
        render_trajectory(trace, path=self.out / TRAJECTORY_NAME, boxes=boxes,
                          title=title)

    def _write_final_tree(self) -> None:
        """The last *ticked* state: after Ctrl-C the live tree has been stopped (all INVALID)."""
        assert self.tree_log is not None
        shadow = ShadowTree(self.tree_log.shape)
        nodes, tip = self.tree_log.latest
        shadow.show(nodes, tip=tip)
        (self.out / FINAL_TREE_NAME).write_text(shadow.text(), encoding="utf-8")
