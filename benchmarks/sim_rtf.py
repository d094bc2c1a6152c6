"""The simulator's real-time factor: alone, and with one executive driving a full mission.

``python benchmarks/sim_rtf.py [--seconds S] [--speed X] [--executive bt|baseline]
[--missions N | --seeds 0-4] [--timing lockstep|free|both|all] [--free-running-code DIR]``
prints

* alone: the simulator as fast as it can run (speed 0) with its task started (before
  ``new_task`` it never runs faster than real time) but nobody driving the robot and nobody
  but this script listening to ``/clock``, over ``S`` wall seconds after a warm-up;
* driven: ``python -m bt_servicesim.run --headless`` on the default (shipped) task at speed
  ``X`` (default 50, the target; 0 asks for as fast as the pair can go), ``N`` times one after
  another (then the median, least and greatest factor too), measured from the referee's own
  stamps between the task's start and its end, which is the part of a run an evaluation pays
  for: the run's report says when it took the task's first and latest referee state
  (``task_timing``: task sim time and ``time.monotonic()``); a checkout whose report does not
  say (``--free-running-code`` from before it did) is measured by this script's own reader of
  the referee, which can join after the task started; the run's report (completed, sim and
  wall time); and how often the tree ticked per sim
  second over the task, from its tree log: 10 when the executive keeps up with the simulator,
  fewer when it falls behind (it ticks at most once per /clock message it gets to). A factor
  of 50 with the tree ticking 10 times a sim second is the target met; flat out the pair goes
  faster, but the tree falls behind;
* with ``--timing both`` (the default) each mission is run twice, in lockstep with the
  simulator (the run's default) and free running (``run --free-running``, as on Gazebo), one
  after the other, so that the two are measured on the same machine at the same time; in
  lockstep the tree ticks exactly 10 times a sim second by construction, and the factor says
  what that costs; ``--timing all`` adds lockstep *taking turns* (the simulator waits for each
  tick before it steps on, as before the pipeline), to show what the pipeline gains;
* with ``--seeds``, one mission per task seed (``run --seed``) instead of ``N`` of the shipped
  task, each played every way in turn: a mission's cost per sim second depends on what happens
  in it (a robot held up by people replans all the while), and free running, whose timing
  changes the mission, plays a different one from lockstep even on the same task, so one task
  compares the timings on the content of one or two missions only. The summary gives each
  timing's factor pooled over its missions (all sim seconds over all wall seconds) and
  lockstep against the others mission by mission;
* with ``--free-running-code DIR``, the free-running missions run the code of another checkout
  of this repository (``DIR``, e.g. ``git worktree add /tmp/free 5094628^``, a commit from before
  lockstep) on this checkout's Python environment, interleaved
  with this checkout's lockstep missions: lockstep now against free running as it was, on the
  same machine at the same time;
* the CPU time the executive's and the simulator's processes spent over the task (from
  ``/proc``), as milliseconds per sim second: a process needing more than 1000/X ms per sim
  second cannot keep X times real time even with a core of its own, so these say which of
  the two limits the pair.

Real-time factor = sim seconds per wall second. Figures are wall-clock on this machine and vary
with its load; nothing here is asserted. Bad arguments give one line and exit status 2.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ros_harness import Simulator, isolate, spin_until, start_task

from bt_servicesim.cli import OneLineArgumentParser

if TYPE_CHECKING:  # rclpy is imported once the domain is set
    from builtin_interfaces.msg import Time
    from rclpy.executors import Executor
    from rclpy.node import Node

LAG_VARIABLE = "SERVICESIM_LOCKSTEP_LAG"
"""Read by the simulator (``servicesim_sim/lockstep/server.py``): 0 waits for each tick."""
TIMINGS = {"lockstep": ("lockstep",), "free": ("free running",),
           "both": ("lockstep", "free running"),
           "all": ("lockstep", "lockstep, taking turns", "free running")}


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/sim_rtf.py",
                                   description="The simulator's real-time factor.")
    parser.add_argument("--seconds", type=float, default=20.0,
                        help="wall seconds to measure the simulator alone (default 20)")
    parser.add_argument("--speed", type=float, default=50.0,
                        help="speed factor of the driven missions (default 50, the target; "
                             "0: as fast as the pair can go)")
    parser.add_argument("--executive", choices=("bt", "baseline"), default="bt",
                        help="the executive driving the mission (default bt)")
    parser.add_argument("--timing", choices=tuple(TIMINGS), default="both",
                        help="run the missions in lockstep, free running, each both ways, or "
                             "all three ways (also lockstep taking turns, without the pipeline) "
                             "(default both)")
    parser.add_argument("--missions", type=int, default=5,
                        help="driven missions to run one after another (default 5): a "
                             "mission's cost per sim second depends on what happens in it")
    parser.add_argument("--seeds", type=seed_list, default=None,
                        help="comma-separated task seeds (run --seed) to drive instead of the "
                             "shipped task, one mission each, every timing on each seed: "
                             "compares the timings over several missions' content; overrides "
                             "--missions")
    parser.add_argument("--free-running-code", type=checkout, default=None, metavar="DIR",
                        help="run the free-running missions with the code of this other "
                             "checkout of the repository (e.g. from before lockstep)")
    return parser


def checkout(text: str) -> Path:
    """A directory holding a checkout of this repository (its executive and its simulator)."""
    path = Path(text).resolve()
    for part in ("bt_servicesim/run.py", "sim/servicesim_sim/__main__.py"):
        if not (path / part).is_file():
            raise argparse.ArgumentTypeError(f"{text}: not a checkout of this repository "
                                             f"(no {part})")
    return path


def code_path(code: Path) -> str:
    """``PYTHONPATH`` for a process on ``code``'s checkout: its executive and simulator first,
    then whatever this environment's own ``PYTHONPATH`` adds (an interface package built
    outside the virtual environment, say), so that ``code`` wins over any other checkout."""
    inherited = [entry for entry in os.environ.get("PYTHONPATH", "").split(os.pathsep) if entry]
    return os.pathsep.join([str(code), str(code / "sim"), *inherited])


def seed_list(text: str) -> list[int]:
    """``0,1,2`` or a range ``0-4`` (both ends included) as seeds."""
    try:
        if "-" in text.strip("-") and "," not in text:
            first, last = (int(part) for part in text.split("-", 1))
            seeds = list(range(first, last + 1))
        else:
            seeds = [int(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: not seeds like 0,1,2 or 0-4") from None
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: not seeds like 0,1,2 or 0-4")
    return seeds


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


def seconds_of(stamp: Time) -> float:
    """A ``builtin_interfaces/Time`` in seconds."""
    seconds: float = stamp.sec + stamp.nanosec * 1e-9
    return seconds


def measure_alone(node: Node, executor: Executor, *, speed: float, seconds: float) -> None:
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


class ProcessCpu:
    """CPU seconds (user + system) of a process and its children, read from ``/proc``."""

    TICKS = os.sysconf("SC_CLK_TCK")

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.latest: dict[int, float] = {}  # pid to CPU seconds, at the last sample
        self.marks: list[dict[int, float]] = []
        self.timeline: list[tuple[float, dict[int, float]]] = []  # (monotonic, totals)

    def sample(self) -> None:
        for pid in (self.pid, *self._children()):
            seconds = self._cpu_of(pid)
            if seconds is not None:
                self.latest[pid] = seconds
        self.timeline.append((time.monotonic(), dict(self.latest)))

    def mark_at(self, moments: Sequence[float]) -> None:
        """Take as the marks the samples nearest each of ``moments`` (``time.monotonic()``)."""
        self.marks = [min(self.timeline, key=lambda sample: abs(sample[0] - moment))[1]
                      for moment in moments]

    def mark(self) -> None:
        """Remember the totals now (the task's start and its end)."""
        self.sample()
        self.marks.append(dict(self.latest))

    def spent(self, pid: int) -> float:
        first, last = self.marks[0], self.marks[-1]
        return last.get(pid, 0.0) - first.get(pid, 0.0)

    def children(self) -> list[int]:
        return [pid for pid in self.latest if pid != self.pid]

    def _children(self) -> list[int]:
        try:
            text = Path(f"/proc/{self.pid}/task/{self.pid}/children").read_text()
        except OSError:
            return []
        return [int(pid) for pid in text.split()]

    def _cpu_of(self, pid: int) -> float | None:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            return None
        return (int(fields[11]) + int(fields[12])) / self.TICKS


def measure_mission(*, speed: float, executive: str, free_running: bool = False,
                    taking_turns: bool = False, seed: int | None = None,
                    code: Path | None = None) -> tuple[float, float]:
    """Run one mission, print its figures; the sim and wall seconds of its task.

    The run claims a ROS domain of its own and names it in the report it writes as it starts;
    the benchmark reads the referee there, on a context of that domain. With ``code``, the run
    is that checkout's (a checkout from before lockstep runs free without being asked).
    """
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    with tempfile.TemporaryDirectory(prefix="benchmark-run-") as out:
        asks_free = free_running and (code is None or knows_lockstep(code))
        command = [sys.executable, "-m", "bt_servicesim.run", "--headless", "--speed",
                   repr(speed), "--executive", executive, "--out", out,
                   *(["--free-running"] if asks_free else []),
                   *(["--seed", str(seed)] if seed is not None else [])]
        started = time.monotonic()
        errors = (Path(out) / "run.err").open("w")  # a pipe nobody reads would block the run
        environment = os.environ.copy()
        if code is not None:
            environment["PYTHONPATH"] = code_path(code)
        if taking_turns:  # the simulator (started by the run) waits for each tick
            environment[LAG_VARIABLE] = "0"
        run = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=errors,
                               env=environment, cwd=code)  # ``-m`` looks in cwd first
        errors.close()
        domain = run_domain(Path(out), run)
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        node = Node("benchmark_sim_rtf_driven", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        try:
            task, cpu = watch_mission(node, executor, run)
        finally:
            executor.shutdown()
            node.destroy_node()
            context.try_shutdown()
        wall = time.monotonic() - started
        report = json.loads((Path(out) / "report.json").read_text())
        ticks = tick_times(Path(out) / "tree_log.jsonl")
        sim_log = Path(out) / "sim.log"
        said = (Path(out) / "run.err").read_text() + (
            sim_log.read_text() if sim_log.is_file() else "")
        warnings = [line for line in said.splitlines()
                    if "lockstep: dropped" in line or "ticked without" in line
                    or "Traceback" in line]
    timing_seen = report.get("task_timing")
    if timing_seen:  # the run's own account of when it saw the task: never late
        task = Stamps()
        for end in (timing_seen["first"], timing_seen["last"]):
            task.pairs.append((end["monotonic_s"], end["task_sim_time_s"]))
        cpu.mark_at([wall for wall, _ in task.pairs])
    if len(task.pairs) < 2:
        raise SystemExit(f"the referee reported no running task ({report.get('failure')})")
    sim_s, wall_s, factor = task.factor()
    verdict = "completed" if report["completed"] else f"failed ({report['failure']})"
    timing = "free running" if free_running else report.get("timing", "?")
    if code is not None:
        timing += f", the code of {code}"
    if taking_turns:
        timing += ", taking turns"
    shown = f"seed {seed}, " if seed is not None else ""
    print(f"driven by {executive} ({shown}{timing}, speed {speed:g}): {sim_s:7.1f} sim s of task "
          f"in {wall_s:5.1f} wall s  real-time factor {factor:6.1f}")
    print(f"  the run: {verdict}, task {report['sim_time_s']:.1f} sim s, whole run {wall:.1f} "
          f"wall s (start-up and shut-down included)")
    if sim_s < 0.95 * float(report["sim_time_s"]):
        print(f"  (measured over the last {sim_s:.1f} sim s only: this benchmark's reader "
              "found the referee late, after the task had started)")
    print_ticks(ticks, start=task.pairs[0][1], end=task.pairs[-1][1])
    if report.get("lockstep_stalls"):
        print(f"  lockstep: {report['lockstep_stalls']} period(s) ticked without every message")
    if report.get("lockstep_dropped"):
        dropped = report["lockstep_dropped"]
        print(f"  lockstep: the simulator dropped the run at period {dropped['period']} "
              f"({dropped['sim_time_s']:.1f} sim s); it ran free from there")
    for line in warnings[:3]:
        print(f"  the run said: {line.strip()[:200]}")
    if len(cpu.marks) == 2:
        processes = [("executive", cpu.pid)] + [("simulator", pid) for pid in cpu.children()]
        print("  CPU over the task: " + ", ".join(
            f"{name} {cpu.spent(pid):.2f} s ({1000.0 * cpu.spent(pid) / sim_s:.1f} ms "
            f"per sim s)" for name, pid in processes))
    return sim_s, wall_s


def commit_of(code: Path) -> str:
    """The checkout's commit, as git names it (or why not)."""
    found = subprocess.run(["git", "-C", str(code), "describe", "--always", "--dirty"],
                           capture_output=True, text=True, check=False)
    return found.stdout.strip() or "not a git checkout"


def knows_lockstep(code: Path) -> bool:
    """Whether the checkout's ``run`` has ``--free-running`` (code from before lockstep
    runs free and would refuse the flag)."""
    return "--free-running" in (code / "bt_servicesim" / "run.py").read_text()


def run_domain(out: Path, run: subprocess.Popen[bytes]) -> int:
    """The ROS domain the run claimed, from the report it writes as it starts."""
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline and run.poll() is None:
        try:
            return int(json.loads((out / "report.json").read_text())["ros_domain_id"])
        except (OSError, ValueError, KeyError):
            time.sleep(0.05)
    raise SystemExit("the run wrote no report naming its ROS domain")


def watch_mission(node: Node, executor: Executor,
                  run: subprocess.Popen[bytes]) -> tuple[Stamps, ProcessCpu]:
    """The referee's stamps over the task and the processes' CPU, until the run ends."""
    from servicesim_competition.msg import RefereeState

    from bt_servicesim.mission.referee_monitor import LATCHED, REFEREE_TOPIC

    task = Stamps()
    ended: list[bool] = []
    cpu = ProcessCpu(run.pid)

    def on_state(state: RefereeState) -> None:
        if (state.task_running or state.completed) and not ended:
            if not task.pairs:
                cpu.mark()
            task.add(seconds_of(state.stamp))
        if state.completed and not ended:
            ended.append(True)  # the referee keeps publishing the finished state
            cpu.mark()

    node.create_subscription(RefereeState, REFEREE_TOPIC, on_state, LATCHED)

    def run_over() -> bool:
        cpu.sample()
        return run.poll() is not None

    spin_until(executor, run_over, 1800.0, "the mission")
    return task, cpu


def tick_times(tree_log: Path) -> list[float]:
    """The sim times of the tree's ticks, from the run's tree log (none for the baseline)."""
    if not tree_log.is_file():
        return []
    times = []
    for line in tree_log.read_text().splitlines():
        record = json.loads(line)
        if record.get("kind") == "tick":
            times.append(float(record["sim_time_s"]))
    return times


def print_ticks(ticks: list[float], *, start: float, end: float) -> None:
    """How often the tree ticked over the task (10 a sim second when it keeps up)."""
    during = [t for t in ticks if start <= t <= end]
    if len(during) < 2:
        return
    gaps = [b - a for a, b in itertools.pairwise(during)]
    print(f"  the tree ticked {len(during) / (end - start):.1f} times a sim second over the "
          f"task (longest gap {max(gaps):.1f} sim s)")



def summarise(executive: str, tasks: dict[str, list[tuple[float, float]]]) -> None:
    """Each timing's factor over its missions (median, least, greatest, and pooled: all sim
    seconds over all wall seconds), and each timing against lockstep mission by mission."""
    for name, missions in tasks.items():
        if len(missions) < 2:
            continue
        factors = [sim_s / wall_s for sim_s, wall_s in missions]
        pooled = sum(sim_s for sim_s, _ in missions) / sum(wall_s for _, wall_s in missions)
        print(f"driven by {executive}, {name}, {len(missions)} missions: real-time factor "
              f"median {statistics.median(factors):.1f}, min {min(factors):.1f}, "
              f"max {max(factors):.1f}, pooled {pooled:.1f}")
    lockstep = tasks.get("lockstep")
    for name, missions in tasks.items():
        if name == "lockstep" or not lockstep:
            continue
        pairs = list(zip(lockstep, missions, strict=True))
        ratios = [(ls / lw) / (s / w) for (ls, lw), (s, w) in pairs]
        print(f"lockstep against {name}, mission by mission: "
              + ", ".join(f"{ratio:.2f}" for ratio in ratios)
              + f" (median {statistics.median(ratios):.2f})")
        print(f"  the task's wall seconds, {name} over lockstep (a timing that loses ticks can "
              "play a longer mission): "
              + ", ".join(f"{w / lw:.2f}" for (_, lw), (_, w) in pairs)
              + f" (median {statistics.median(w / lw for (_, lw), (_, w) in pairs):.2f})")


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if not args.seconds > 0.0:
        build_parser().error(f"--seconds {args.seconds}: must be more than 0")
    if not args.speed >= 0.0:
        build_parser().error(f"--speed {args.speed}: must be 0 or more")
    if args.missions < 1:
        build_parser().error(f"--missions {args.missions}: must be 1 or more")
    domain = isolate()
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    print(f"ROS domain {domain}, discovery {os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}, "
          f"{os.cpu_count()} CPUs")
    if args.free_running_code is not None:
        print(f"free running runs the code of {args.free_running_code} "
              f"({commit_of(args.free_running_code)}); lockstep runs this checkout's")
    rclpy.init()
    node = Node("benchmark_sim_rtf")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        measure_alone(node, executor, speed=0.0, seconds=args.seconds)
        seeds = args.seeds or [None] * args.missions
        tasks: dict[str, list[tuple[float, float]]] = {name: [] for name in TIMINGS[args.timing]}
        for seed in seeds:
            for name in tasks:
                tasks[name].append(measure_mission(
                    speed=args.speed, executive=args.executive,
                    free_running=name == "free running",
                    taking_turns=name == "lockstep, taking turns", seed=seed,
                    code=args.free_running_code if name == "free running" else None))
        summarise(args.executive, tasks)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
