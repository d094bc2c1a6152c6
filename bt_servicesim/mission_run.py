"""One mission on a live ROS graph: the simulator process, the executive node, the report.

Split from :mod:`bt_servicesim.run` so the command checks its input before rclpy is imported.
The run waits (in wall time, bounded) for the simulator's clock and referee, ticks the tree on
sim time until it ends, then waits briefly for the referee's last word and writes the report.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from servicesim_competition.srv import NewTask

from bt_servicesim.executive import Executive
from bt_servicesim.progress import ProgressView
from bt_servicesim.referee_monitor import RefereeMonitor
from bt_servicesim.run import (
    EXIT_BAD_INPUT,
    EXIT_COMPLETED,
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    REPORT_NAME,
    STARTUP_LIMIT_S,
    RunSettings,
    write_report,
)
from bt_servicesim.simulator_process import SimulatorProcess

FINAL_STATE_WAIT_S = 3.0  # wall seconds to wait for the referee's last state
SIM_TIME_BACKSTOP_S = 60.0  # sim seconds past the time limit before the run gives up itself


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
        node = Node("bt_servicesim_executive",
                    parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)])
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        monitor = RefereeMonitor(node)
        executive = self.make_executive(node)
        try:
            code = self._run(node, executor, monitor, executive)
        except KeyboardInterrupt:
            executive.interrupt()
            self._spin_for(executor, 0.5)
            self.failure = "interrupted (Ctrl-C)"
            code = EXIT_INTERRUPTED
        finally:
            self.simulator.stop()
        self._finish(monitor, code)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
        return code

    def _run(self, node: Node, executor: SingleThreadedExecutor, monitor: RefereeMonitor,
             executive: Executive) -> int:
        refused = self._wait_for_simulator(node, executor)
        if refused is not None:
            return refused
        executive.setup()
        executive.start()
        view = ProgressView(headless=self.settings.headless)
        limit_ns = int((self.settings.time_limit_s + SIM_TIME_BACKSTOP_S) * 1e9)
        while not executive.finished:
            executor.spin_once(timeout_sec=0.05)
            view.update(executive=executive, monitor=monitor, sim_time_s=_sim_seconds(node))
            if self.simulator.exit_code() is not None:
                self.failure = f"the simulator exited: {self.simulator.last_error()}"
                executive.interrupt()
                return EXIT_FAILED
            if node.get_clock().now().nanoseconds > limit_ns:
                self.failure = "the mission tree outlived its time limit"
                executive.interrupt()
                return EXIT_FAILED
        self._spin_until(executor, lambda: monitor.completed, FINAL_STATE_WAIT_S)
        view.close(executive=executive, monitor=monitor, sim_time_s=_sim_seconds(node))
        if not monitor.completed:
            self.failure = f"the mission tree ended with {executive.outcome.name}" if (
                executive.outcome) else "the mission did not end"
        return EXIT_COMPLETED if monitor.completed else EXIT_FAILED

    def _wait_for_simulator(self, node: Node, executor: SingleThreadedExecutor) -> int | None:
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

    def _finish(self, monitor: RefereeMonitor, code: int) -> None:
        report: dict[str, Any] = {
            **monitor.report_fields(),
            "wall_time_s": round(time.monotonic() - self.started_wall, 3),
            "seed": self.settings.seed,
            "world": str(self.settings.world) if self.settings.world else "default",
            "executive": self.settings.executive,
            "exit_code": code,
            "failure": self.failure,
        }
        write_report(self.settings.out / REPORT_NAME, report)
        verdict = "completed" if report["completed"] else f"failed ({self.failure})"
        print(f"mission {verdict}: score {report['score']:.1f}, "
              f"{report['sim_time_s']:.1f} s sim, {report['wall_time_s']:.1f} s wall; "
              f"report: {self.settings.out / REPORT_NAME}")

    @staticmethod
    def _spin_for(executor: SingleThreadedExecutor, seconds: float) -> None:
        MissionRun._spin_until(executor, lambda: False, seconds)

    @staticmethod
    def _spin_until(executor: SingleThreadedExecutor, done: Any, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while not done() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)


def _sim_seconds(node: Node) -> float:
    return node.get_clock().now().nanoseconds / 1e9
