"""What the ROS benchmarks share: a private ROS domain on loopback, the simulator, statistics.

Every benchmark calls :func:`isolate` before it imports rclpy: DDS discovery stays on this
machine unless the user set ``ROS_AUTOMATIC_DISCOVERY_RANGE``, and the benchmark gets a ROS
domain of its own (``ROS_DOMAIN_ID`` if set, else one it claims as a run claims one,
``bt_servicesim/ros/domain.py``), so a test run, a run or an evaluation on the same machine
cannot answer its requests. The simulator is started exactly as
the run command starts it (``python -m servicesim_sim``), with its output in a temporary file;
:func:`start_task` starts its task, since before one it never runs faster than real time.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bt_servicesim.mission.stopping import parent_death_signal
from bt_servicesim.ros.domain import DomainClaim, claim_domain
from bt_servicesim.ros.spinning import Spinner

if TYPE_CHECKING:  # rclpy is imported once the domain is set
    from rclpy.client import Client
    from rclpy.node import Node
    from servicesim_competition.srv import NewTask

REPO = Path(__file__).resolve().parents[1]
_claims: list[DomainClaim] = []  # held until the process ends


def isolate() -> int:
    """Loopback discovery and a ROS domain for this benchmark; returns the domain."""
    if not os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE"):
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    if not os.environ.get("ROS_DOMAIN_ID", "").isdigit():
        _claims.append(claim_domain())
        os.environ["ROS_DOMAIN_ID"] = str(_claims[-1].domain_id)
    return int(os.environ["ROS_DOMAIN_ID"])


class Simulator:
    """``python -m servicesim_sim`` as a child process, stopped with SIGINT (then SIGKILL)."""

    def __init__(self, *, speed: float, arguments: Sequence[str] = ()) -> None:
        self.log = Path(tempfile.gettempdir()) / f"benchmark-sim-{os.getpid()}.log"
        with self.log.open("wb") as log:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "servicesim_sim", "--speed", repr(speed), *arguments],
                stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                start_new_session=True,  # stopped with SIGINT, which it must not ignore:
                preexec_fn=parent_death_signal(os.getpid()))  # defaults, and dies with us

    def check_running(self) -> None:
        if self.process.poll() is not None:
            raise SystemExit(f"the simulator exited: {self.last_line()}")

    def last_line(self) -> str:
        lines = self.log.read_text(errors="replace").strip().splitlines()
        return lines[-1] if lines else "no output"

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.unlink(missing_ok=True)


def spin_until(executor: Spinner, done: Callable[[], bool], limit_s: float,
               what: str, simulator: Simulator | None = None) -> None:
    """Spin until ``done()``; exit with a message naming ``what`` after ``limit_s`` wall s."""
    deadline = time.monotonic() + limit_s
    while not done():
        if simulator is not None:
            simulator.check_running()
        if time.monotonic() > deadline:
            raise SystemExit(f"gave up waiting for {what} after {limit_s:.0f} s")
        executor.spin_once(timeout_sec=0.05)


def start_task(node: Node, executor: Spinner, simulator: Simulator) -> None:
    """Call ``new_task``: until a task starts the simulator runs at most at real time."""
    from servicesim_competition.srv import NewTask

    client: Client[NewTask.Request, NewTask.Response] = node.create_client(
        NewTask, "/servicesim/new_task")
    spin_until(executor, client.service_is_ready, 60.0, "/servicesim/new_task", simulator)
    answer = client.call_async(NewTask.Request())
    spin_until(executor, answer.done, 30.0, "the new_task answer", simulator)
    started = answer.result()
    if started is None or not started.pick_up_location:
        raise SystemExit("the simulator refused new_task")
    node.destroy_client(client)


def milliseconds(seconds: Sequence[float]) -> str:
    """Median and p99 (and the count) of wall durations, in milliseconds."""
    ms = np.asarray(seconds) * 1e3
    return (f"median {np.median(ms):7.3f} ms  p99 {np.percentile(ms, 99):7.3f} ms  "
            f"(n={len(ms)})")
