"""The simulator's real-time factor: alone, and with one executive driving a full mission.

``python benchmarks/sim_rtf.py [--seconds S] [--speed X] [--executive bt|baseline]`` prints

* alone: the simulator at ``--speed`` (default 0, as fast as it can) with its task started
  (before ``new_task`` it never runs faster than real time) but nobody driving the robot and
  nobody but this script listening to ``/clock``, over ``S`` wall seconds after a warm-up;
* driven: ``python -m bt_servicesim.run --headless`` on the default (shipped) task, same speed,
  measured from the referee's own stamps between the task's start and its end, which is the
  part of a run an evaluation pays for; and the run's report (completed, sim and wall time).

Real-time factor = sim seconds per wall second. Figures are wall-clock on this machine and vary
with its load; nothing here is asserted. Bad arguments give one line and exit status 2.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ros_harness import OneLineArgumentParser, Simulator, isolate, spin_until, start_task


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/sim_rtf.py",
                                   description="The simulator's real-time factor.")
    parser.add_argument("--seconds", type=float, default=20.0,
                        help="wall seconds to measure the simulator alone (default 20)")
    parser.add_argument("--speed", type=float, default=0.0,
                        help="sim speed factor (default 0: as fast as possible)")
    parser.add_argument("--executive", choices=("bt", "baseline"), default="bt",
                        help="the executive driving the mission (default bt)")
    return parser


class Stamps:
    """(wall, sim) pairs from a topic's stamps."""

    def __init__(self) -> None:
        self.pairs: list[tuple[float, float]] = []

    def add(self, sim_s: float) -> None:
        self.pairs.append((time.monotonic(), sim_s))

    def factor(self) -> tuple[float, float, float]:
        """Sim seconds, wall seconds and their ratio, first pair to last."""
        (wall0, sim0), (wall1, sim1) = self.pairs[0], self.pairs[-1]
        return sim1 - sim0, wall1 - wall0, (sim1 - sim0) / max(wall1 - wall0, 1e-9)


def seconds_of(stamp: Any) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def measure_alone(node: Any, executor: Any, *, speed: float, seconds: float) -> None:
    from rosgraph_msgs.msg import Clock

    stamps = Stamps()
    simulator = Simulator(speed=speed)
    try:
        subscription = node.create_subscription(
            Clock, "/clock", lambda message: stamps.add(seconds_of(message.clock)), 10)
        spin_until(executor, lambda: bool(stamps.pairs), 60.0, "/clock", simulator)
        start_task(node, executor, simulator)
        warm_up = time.monotonic() + 2.0
        spin_until(executor, lambda: time.monotonic() > warm_up, 10.0, "warm-up", simulator)
        stamps.pairs.clear()
        finish = time.monotonic() + seconds
        spin_until(executor, lambda: time.monotonic() > finish, seconds + 10.0, "", simulator)
        node.destroy_subscription(subscription)
    finally:
        simulator.stop()
    sim_s, wall_s, factor = stamps.factor()
    print(f"alone (speed {speed:g}):  {sim_s:7.1f} sim s in {wall_s:5.1f} wall s  "
          f"real-time factor {factor:6.1f}")


def measure_mission(node: Any, executor: Any, *, speed: float, executive: str) -> None:
    from servicesim_competition.msg import RefereeState

    from bt_servicesim.referee_monitor import LATCHED, REFEREE_TOPIC

    task = Stamps()
    ended: list[bool] = []

    def on_state(state: RefereeState) -> None:
        if (state.task_running or state.completed) and not ended:
            task.add(seconds_of(state.stamp))
        if state.completed:
            ended.append(True)  # the referee keeps publishing the finished state

    node.create_subscription(RefereeState, REFEREE_TOPIC, on_state, LATCHED)
    with tempfile.TemporaryDirectory(prefix="benchmark-run-") as out:
        command = [sys.executable, "-m", "bt_servicesim.run", "--headless", "--speed",
                   repr(speed), "--executive", executive, "--out", out]
        started = time.monotonic()
        run = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               env=os.environ.copy())
        spin_until(executor, lambda: run.poll() is not None, 1800.0, "the mission")
        wall = time.monotonic() - started
        report = json.loads((Path(out) / "report.json").read_text())
    if len(task.pairs) < 2:
        raise SystemExit(f"the referee reported no running task ({report.get('failure')})")
    sim_s, wall_s, factor = task.factor()
    verdict = "completed" if report["completed"] else f"failed ({report['failure']})"
    print(f"driven by {executive} (speed {speed:g}): {sim_s:7.1f} sim s of task in {wall_s:5.1f} "
          f"wall s  real-time factor {factor:6.1f}")
    print(f"  the run: {verdict}, task {report['sim_time_s']:.1f} sim s, whole run {wall:.1f} "
          f"wall s (start-up and shut-down included)")


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if not args.seconds > 0.0:
        build_parser().error(f"--seconds {args.seconds}: must be more than 0")
    if not args.speed >= 0.0:
        build_parser().error(f"--speed {args.speed}: must be 0 or more")
    domain = isolate()
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    print(f"ROS domain {domain}, discovery {os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}, "
          f"{os.cpu_count()} CPUs")
    rclpy.init()
    node = Node("benchmark_sim_rtf")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        measure_alone(node, executor, speed=args.speed, seconds=args.seconds)
        measure_mission(node, executor, speed=args.speed, executive=args.executive)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
