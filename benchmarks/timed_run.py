"""``python -m bt_servicesim.run`` with the tree's tick timed: a harness for benchmarks.

``python benchmarks/timed_run.py FIGURES.json RUN_ARGUMENTS...`` runs the run command's
``main`` in this process, on whatever ``bt_servicesim`` the interpreter imports (this checkout,
or another one first on ``PYTHONPATH``, for an A/B of two versions of the code), and writes to
``FIGURES.json`` per tick of the mission tree:

* ``wall_us``, ``cpu_us``: the tick itself (``MissionExecutive.tick``: the tree, its visitors
  and post-tick handlers) plus, in lockstep, what the tick left for after its done
  (``LockstepClient._run_after_done``: the tree log and the tree topic), in wall time and in
  the CPU time of the thread that ticks (DDS's own threads, which take messages meanwhile,
  left out);
* ``process_cpu_s``, ``ticks``: the process's CPU time (every thread: rclpy's and Fast DDS's
  included) from its first tick to its last, and how many ticks that took (0.1 sim s each).

The timing reads the clocks only into these figures, never into the mission. Only the
benchmarks use it; its exit status is the run's.
"""

from __future__ import annotations

import atexit
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


class TickTimes:
    """Wall and CPU time of each tick with its records, and the process's CPU over the ticks."""

    def __init__(self) -> None:
        self.wall_ns: list[int] = []
        self.cpu_ns: list[int] = []
        self.first_cpu_ns: int | None = None
        self.last_cpu_ns = 0
        self._open: tuple[int, int] | None = None

    def begin(self) -> None:
        self._open = (time.perf_counter_ns(), time.thread_time_ns())
        if self.first_cpu_ns is None:
            self.first_cpu_ns = time.process_time_ns()

    def add_to_last(self, wall_ns: int, cpu_ns: int) -> None:
        if self.wall_ns:
            self.wall_ns[-1] += wall_ns
            self.cpu_ns[-1] += cpu_ns

    def end(self) -> None:
        if self._open is None:
            return
        wall, cpu = time.perf_counter_ns(), time.thread_time_ns()
        self.wall_ns.append(wall - self._open[0])
        self.cpu_ns.append(cpu - self._open[1])
        self.last_cpu_ns = time.process_time_ns()
        self._open = None

    def figures(self) -> dict[str, Any]:
        return {"wall_us": [ns / 1e3 for ns in self.wall_ns],
                "cpu_us": [ns / 1e3 for ns in self.cpu_ns],
                "ticks": len(self.wall_ns),
                "process_cpu_s": (self.last_cpu_ns - (self.first_cpu_ns or 0)) / 1e9}


def timed(times: TickTimes, method: Callable[..., Any]) -> Callable[..., Any]:
    def tick(self: object) -> None:
        times.begin()
        try:
            method(self)
        finally:
            times.end()
    return tick


def timed_after_done(times: TickTimes, method: Callable[..., Any]) -> Callable[..., Any]:
    def after_done(self: object) -> None:
        wall, cpu = time.perf_counter_ns(), time.thread_time_ns()
        try:
            method(self)
        finally:
            times.add_to_last(time.perf_counter_ns() - wall, time.thread_time_ns() - cpu)
            times.last_cpu_ns = time.process_time_ns()
    return after_done


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print("benchmarks/timed_run.py: error: usage: python benchmarks/timed_run.py "
              "FIGURES.json RUN_ARGUMENTS...", file=sys.stderr)
        return 2
    figures = Path(argv[0])
    from bt_servicesim import run
    from bt_servicesim.ros import lockstep
    from bt_servicesim.tree import executive

    times = TickTimes()
    mission, client = executive.MissionExecutive, lockstep.LockstepClient
    setattr(mission, "tick", timed(times, mission.tick))  # noqa: B010 (a method replaced)
    setattr(client, "_run_after_done", timed_after_done(times, client._run_after_done))  # noqa: B010
    atexit.register(lambda: figures.write_text(json.dumps(times.figures())))
    return run.main(argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
