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
* ``process_cpu_s``, ``thread_cpu_s``, ``ticks``: the CPU time of the process (every thread:
  rclpy's and Fast DDS's included) and of the thread that ticks, from the first tick to the
  last, and how many ticks that took (0.1 sim s each);
* ``parts_cpu_s``: the ticking thread's CPU in the parts of lockstep's periods (:data:`PARTS`):
  the whole period (handing on its messages, the tick, the done, the records) and each of
  them, and outside
  the periods taking the announcements; what the thread spent besides is rclpy's executor
  and the arrivals it holds;
* ``leaves``: per kind of leaf (its class), the CPU its ``update`` took over the mission and
  how many updates that was (:class:`LeafTimes`): which leaves the tick's time goes to, and
  how much of it is py_trees' own machinery (the tick less its leaves' updates).

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
    """Wall and CPU time of each tick with its records; the thread's CPU in each part of the
    period; the process's and the ticking thread's CPU from the first tick to the last."""

    def __init__(self) -> None:
        self.wall_ns: list[int] = []
        self.cpu_ns: list[int] = []
        self.parts_ns: dict[str, int] = dict.fromkeys([*PARTS.values(), TICK], 0)
        self.first: tuple[int, int] | None = None
        self.last = (0, 0)
        self._open: tuple[int, int] | None = None

    def begin(self) -> None:
        self._open = (time.perf_counter_ns(), time.thread_time_ns())
        if self.first is None:
            self.first = (time.process_time_ns(), self._open[1])

    def add_to_last(self, wall_ns: int, cpu_ns: int) -> None:
        if self.wall_ns:
            self.wall_ns[-1] += wall_ns
            self.cpu_ns[-1] += cpu_ns
            self.last = (time.process_time_ns(), time.thread_time_ns())

    def end(self) -> None:
        if self._open is None:
            return
        wall, cpu = time.perf_counter_ns(), time.thread_time_ns()
        self.wall_ns.append(wall - self._open[0])
        self.cpu_ns.append(cpu - self._open[1])
        self.parts_ns[TICK] += cpu - self._open[1]
        self.last = (time.process_time_ns(), cpu)
        self._open = None

    def figures(self) -> dict[str, Any]:
        first = self.first or self.last
        return {"wall_us": [ns / 1e3 for ns in self.wall_ns],
                "cpu_us": [ns / 1e3 for ns in self.cpu_ns],
                "ticks": len(self.wall_ns),
                "process_cpu_s": (self.last[0] - first[0]) / 1e9,
                "thread_cpu_s": (self.last[1] - first[1]) / 1e9,
                "parts_cpu_s": {part: ns / 1e9 for part, ns in self.parts_ns.items()}}


class LeafTimes:
    """The thread CPU of every leaf's ``update``, summed by the leaf's class."""

    def __init__(self) -> None:
        self.cpu_ns: dict[str, int] = {}
        self.calls: dict[str, int] = {}

    def watch(self, root: Any) -> None:
        """Time the ``update`` of every leaf under ``root`` from now on."""
        for behaviour in root.iterate():
            if not behaviour.children:
                behaviour.update = self._timed(type(behaviour).__name__, behaviour.update)

    def _timed(self, kind: str, update: Callable[[], Any]) -> Callable[[], Any]:
        self.cpu_ns.setdefault(kind, 0)
        self.calls.setdefault(kind, 0)

        def timed_update() -> Any:
            cpu = time.thread_time_ns()
            try:
                return update()
            finally:
                self.cpu_ns[kind] += time.thread_time_ns() - cpu
                self.calls[kind] += 1
        return timed_update

    def figures(self) -> dict[str, list[float]]:
        return {kind: [ns / 1e9, self.calls[kind]] for kind, ns in self.cpu_ns.items()}


PARTS = {"_run_period": "the period", "_release": "handing on the period's messages",
         "_run_after_done": "records after the done", "_publish_done": "the done",
         "_on_period": "taking an announcement"}
"""The lockstep client's methods whose thread CPU is summed, and what each is."""
TICK = "the tick (records not counted)"


def timed(times: TickTimes, method: Callable[..., Any]) -> Callable[..., Any]:
    def tick(self: object) -> None:
        times.begin()
        try:
            method(self)
        finally:
            times.end()
    return tick


def summed(times: TickTimes, part: str, method: Callable[..., Any]) -> Callable[..., Any]:
    def run(self: object, *args: Any) -> Any:
        wall, cpu = time.perf_counter_ns(), time.thread_time_ns()
        try:
            return method(self, *args)
        finally:
            spent = time.thread_time_ns() - cpu
            times.parts_ns[part] += spent
            if part == PARTS["_run_after_done"]:
                times.add_to_last(time.perf_counter_ns() - wall, spent)
    return run


def watched(leaves: LeafTimes, method: Callable[..., Any]) -> Callable[..., Any]:
    """``MissionExecutive.setup``, then every leaf of its tree timed by ``leaves``."""
    def setup(self: Any, **kwargs: Any) -> None:
        method(self, **kwargs)
        leaves.watch(self.tree.root)
    return setup


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print("benchmarks/timed_run.py: error: usage: python benchmarks/timed_run.py "
              "FIGURES.json RUN_ARGUMENTS...", file=sys.stderr)
        return 2
    figures = Path(argv[0])
    from bt_servicesim import run
    from bt_servicesim.ros import lockstep
    from bt_servicesim.tree import executive

    times, leaves = TickTimes(), LeafTimes()
    mission, client = executive.MissionExecutive, lockstep.LockstepClient
    setattr(mission, "tick", timed(times, mission.tick))  # noqa: B010 (a method replaced)
    setattr(mission, "setup", watched(leaves, mission.setup))  # noqa: B010
    for name, part in PARTS.items():
        setattr(client, name, summed(times, part, getattr(client, name)))
    atexit.register(lambda: figures.write_text(json.dumps(
        {**times.figures(), "leaves": leaves.figures()})))
    return run.main(argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
