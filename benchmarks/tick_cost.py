"""What one tick of the real mission tree costs, in microseconds.

``python benchmarks/tick_cost.py [--tree FILE] [--drive-ticks N] [--idle-ticks N]`` prints

* scripted: the tree file parsed with scripted leaves (``tests/mission_script.py``: the same
  ports, outcomes from a script, the real sim-time decorators on a manual clock), ticked through a
  whole mission in which every navigation leaf stays RUNNING for ``--drive-ticks`` ticks before
  it succeeds: the composites, decorators and blackboard ports at work, leaves almost free;
* idle: the same file with the real leaves, set up on an rclpy node whose sim-time clock never
  runs and with no simulator, ticked ``--idle-ticks`` times: the mission waits in BeginTask while
  the topic readers run, so this is the real leaves' cost of a tick in which nothing happens;
* Groot2 monitor: the scripted mission ticked ``--monitor-rounds`` times each without a monitor,
  with ``run --groot``'s server watching and no client, and with ``btview echo`` polling it at
  50 Hz (rounds interleaved, so load on the machine falls on all three alike); wall time and the
  ticking thread's CPU time per tick, and the requests the server answered;
* missions: ``python -m bt_servicesim.run --headless --speed 0`` on each of ``--seeds``,
  ``--rounds`` times, through ``benchmarks/timed_run.py``: every tick of the real mission timed
  with what it records (the tree log and the tree topic, written after the lockstep done),
  wall and the process's CPU time, the executive's CPU (every thread) per sim second from
  its first tick to its last, and the leaves whose updates cost the most per sim second;
  with ``--reference-code DIR`` the same missions are played on another checkout too (``git
  worktree add DIR COMMIT``), interleaved seed by seed, so that both meet the same load.

``--parts`` picks the parts to run (default all four).

Figures are wall-clock on this machine and vary with its load; nothing here is asserted. Bad
arguments or a broken tree file give one line and exit status 2.
"""

from __future__ import annotations

import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib.metadata import version
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from ros_harness import REPO, isolate
from sim_rtf import code_path

from bt_servicesim.cli import OneLineArgumentParser

if TYPE_CHECKING:  # imported where they are used: the tree and the monitor cost their import
    from bt_servicesim.monitor.groot2_server import Groot2Server
    from bt_servicesim.tree.lean_tree import LeanBehaviourTree
    from tests.mission_script import ManualClock, Script

sys.path.insert(0, str(REPO))  # tests.mission_script, the scripted leaves the tree tests use

NAVIGATION_TAG = "NavigateToPose"
#: Conditions that would otherwise end a drive at once fail (as in the tree tests).
STILL_DRIVING = ("RobotInPickUpArea",)


def build_parser() -> OneLineArgumentParser:
    from bt_servicesim.tree.files import DEFAULT_TREE

    parser = OneLineArgumentParser(prog="benchmarks/tick_cost.py",
                                   description="Tick cost of the mission tree.")
    parser.add_argument("--tree", type=Path, default=DEFAULT_TREE, help="mission tree XML")
    parser.add_argument("--drive-ticks", type=int, default=300,
                        help="ticks every scripted navigation stays RUNNING (default 300)")
    parser.add_argument("--idle-ticks", type=int, default=3000,
                        help="ticks of the idle real tree (default 3000)")
    parser.add_argument("--monitor-rounds", type=int, default=5,
                        help="scripted missions per Groot2 monitor setting (default 5; 0: none)")
    parser.add_argument("--seeds", default="5,8,13",
                        help="comma list of task seeds for the missions (default 5,8,13)")
    parser.add_argument("--rounds", type=int, default=1,
                        help="missions per seed and checkout (default 1)")
    parser.add_argument("--reference-code", type=Path, metavar="DIR",
                        help="a checkout whose missions are played interleaved with these")
    parser.add_argument("--parts", default=",".join(PARTS),
                        help=f"comma list of {', '.join(PARTS)} (default all)")
    return parser


PARTS = ("scripted", "idle", "monitor", "missions")


def microseconds(seconds: Sequence[float]) -> str:
    us = np.asarray(seconds) * 1e6
    return (f"mean {us.mean():7.1f} µs  median {np.median(us):7.1f} µs  "
            f"p99 {np.percentile(us, 99):7.1f} µs  (n={len(us)})")


def timed_ticks(tree: LeanBehaviourTree, ticks: int | None,
                after_tick: Callable[[], None] | None = None) -> list[float]:
    """Tick until the root finishes (or ``ticks`` times); the wall time of each tick."""
    import py_trees

    finished = (py_trees.common.Status.SUCCESS, py_trees.common.Status.FAILURE)
    durations: list[float] = []
    while ticks is None or len(durations) < ticks:
        started = time.perf_counter()
        tree.tick()
        durations.append(time.perf_counter() - started)
        if after_tick is not None:
            after_tick()
        if ticks is None and tree.root.status in finished:
            break
    return durations


def navigation_leaves(tree_file: Path) -> list[str]:
    root = ElementTree.parse(tree_file).getroot()
    return sorted({element.get("name", "") for element in root.iter(NAVIGATION_TAG)})


def scripted_mission(tree_file: Path,
                     drive_ticks: int) -> tuple[LeanBehaviourTree, ManualClock, Script]:
    """The tree file with scripted leaves, set up on a manual clock: (tree, clock, script)."""
    import py_trees
    from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

    from bt_servicesim.tree.lean_tree import LeanBehaviourTree
    from tests.mission_script import ManualClock, Script, scripted_registry

    py_trees.blackboard.Blackboard.clear()
    drive = (py_trees.common.Status.SUCCESS, drive_ticks)
    outcomes: dict[str, list[Any]] = {name: [drive] * 1000
                                      for name in navigation_leaves(tree_file)}
    outcomes.update({name: [py_trees.common.Status.FAILURE] * 100_000 for name in STILL_DRIVING})
    script = Script(outcomes)
    root = parse_behaviour_tree_xml(str(tree_file),
                                    node_registry=scripted_registry(tree_file, script))
    tree = LeanBehaviourTree(root)
    clock = ManualClock()
    tree.setup(node=clock)
    return tree, clock, script


def scripted(tree_file: Path, drive_ticks: int) -> None:
    tree, clock, script = scripted_mission(tree_file, drive_ticks)
    durations = timed_ticks(tree, None, lambda: clock.advance(0.1))
    size = len(list(tree.root.iterate()))
    print(f"scripted mission ({size} behaviours, ended {tree.root.status.name} after "
          f"{len(durations)} ticks, {len(script.calls)} leaf activations):")
    print(f"  {microseconds(durations)}")


MONITOR_SETTINGS = ("no monitor", "Groot2 monitor, no client",
                    "Groot2 monitor, btview echo polling at 50 Hz")


@dataclass
class MonitorFigures:
    """One setting's ticks, pooled over the rounds."""

    wall: list[float] = field(default_factory=list)
    cpu_s: float = 0.0
    requests: int = 0
    seconds: float = 0.0


def monitored(tree_file: Path, drive_ticks: int, rounds: int) -> None:
    """The scripted mission's ticks under each of :data:`MONITOR_SETTINGS`, interleaved."""
    from bt_servicesim.monitor.groot2_server import Groot2Server

    figures = {setting: MonitorFigures() for setting in MONITOR_SETTINGS}
    with Groot2Server(port=0) as server:
        server.watch(scripted_mission(tree_file, drive_ticks)[0])  # btview quits on no tree
        client = subprocess.Popen(
            [str(Path(sys.executable).with_name("btview")), "echo", "--poll-hz", "50",
             "-p", str(server.port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            wait_for_client(server, client)
            for _ in range(rounds):
                for setting in MONITOR_SETTINGS:
                    quiet = setting == MONITOR_SETTINGS[1]
                    client.send_signal(signal.SIGSTOP if quiet else signal.SIGCONT)
                    monitor = None if setting == MONITOR_SETTINGS[0] else server
                    monitored_round(tree_file, drive_ticks, monitor, figures[setting])
        finally:
            client.kill()
            client.wait()
    print(f"scripted mission, {rounds} rounds per setting (Groot2 monitor, run --groot):")
    for setting, figure in figures.items():
        print(f"  {setting}:\n    wall {microseconds(figure.wall)}\n"
              f"    ticking thread's CPU {figure.cpu_s / len(figure.wall) * 1e6:7.1f} µs a tick;"
              f" {figure.requests / figure.seconds:5.1f} requests answered a second")


def wait_for_client(server: Groot2Server, client: subprocess.Popen[bytes]) -> None:
    """Until the client polls (its tree request and two status polls), or exit if it quit."""
    while server.requests < 3:
        if client.poll() is not None:
            sys.exit(f"benchmarks/tick_cost.py: error: btview echo exited ({client.returncode})")
        time.sleep(0.05)


def monitored_round(tree_file: Path, drive_ticks: int, server: Groot2Server | None,
                    figures: MonitorFigures) -> None:
    """One scripted mission, watched by ``server`` unless it is ``None``."""
    tree, clock, _ = scripted_mission(tree_file, drive_ticks)
    if server is not None:
        server.watch(tree)
    requests = 0 if server is None else server.requests
    started, cpu_started = time.perf_counter(), time.thread_time()
    figures.wall += timed_ticks(tree, None, lambda: clock.advance(0.1))
    figures.cpu_s += time.thread_time() - cpu_started
    figures.seconds += time.perf_counter() - started
    figures.requests += 0 if server is None else server.requests - requests


def idle(tree_file: Path, ticks: int) -> None:
    import py_trees
    import rclpy
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from bt_servicesim.tree.lean_tree import LeanBehaviourTree
    from bt_servicesim.tree.loading import load_mission_tree

    py_trees.blackboard.Blackboard.clear()
    root = load_mission_tree(tree_file)
    rclpy.init()
    node = Node("benchmark_tick_cost",
                parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)])
    try:
        tree = LeanBehaviourTree(root)
        tree.setup(timeout=15.0, node=node)
        durations = timed_ticks(tree, ticks)
        tip = tree.root.tip()
        print(f"idle real tree (no simulator, waiting in {tip.name if tip else '-'}):")
        print(f"  {microseconds(durations)}")
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


@dataclass
class MissionFigures:
    """One checkout's missions: every tick's wall and CPU time; per mission, its seed and the
    CPU per sim second of the executive, of its ticking thread and of each part of the period."""

    wall_us: list[float] = field(default_factory=list)
    cpu_us: list[float] = field(default_factory=list)
    per_sim_s: list[tuple[int, dict[str, float]]] = field(default_factory=list)
    sim_s: float = 0.0
    leaf_cpu_s: dict[str, float] = field(default_factory=dict)
    leaf_calls: dict[str, int] = field(default_factory=dict)

    def add(self, seed: int, result: dict[str, Any]) -> None:
        self.wall_us += result["wall_us"]
        self.cpu_us += result["cpu_us"]
        sim_s = result["ticks"] * 0.1
        self.sim_s += sim_s
        for kind, (cpu_s, calls) in result.get("leaves", {}).items():
            self.leaf_cpu_s[kind] = self.leaf_cpu_s.get(kind, 0.0) + cpu_s
            self.leaf_calls[kind] = self.leaf_calls.get(kind, 0) + int(calls)
        shares = {"the executive (every thread)": result["process_cpu_s"],
                  "its ticking thread": result["thread_cpu_s"], **result["parts_cpu_s"]}
        self.per_sim_s.append((seed, {what: cpu_s * 1e3 / sim_s
                                      for what, cpu_s in shares.items()}))


def timed_mission(code: Path, seed: int, out: Path) -> dict[str, Any]:
    """One mission of ``code`` (a checkout) through ``timed_run.py``: its figures."""
    figures = out.with_suffix(".json")
    environment = {**os.environ, "PYTHONPATH": code_path(code)}
    command = [sys.executable, str(Path(__file__).with_name("timed_run.py")), str(figures),
               "--seed", str(seed), "--speed", "0", "--headless", "--out", str(out),
               "--trajectory", "failed"]
    done = subprocess.run(command, env=environment, cwd=code, capture_output=True, text=True)
    if not figures.exists():
        sys.exit(f"benchmarks/tick_cost.py: error: seed {seed} on {code} wrote no figures "
                 f"(exit {done.returncode}): {done.stderr.strip().splitlines()[-1:]}")
    result: dict[str, Any] = json.loads(figures.read_text())
    return result


def missions(seeds: Sequence[int], rounds: int, reference: Path | None) -> None:
    codes = {"this checkout": REPO} | ({} if reference is None else {"reference": reference})
    figures = {label: MissionFigures() for label in codes}
    with tempfile.TemporaryDirectory(prefix="tick_cost-") as scratch:
        for round_number in range(rounds):
            for seed in seeds:
                for label, code in codes.items():
                    out = Path(scratch) / f"{label}-{seed}-{round_number}"
                    figures[label].add(seed, timed_mission(code, seed, out))
    print(f"missions (seeds {', '.join(map(str, seeds))}, {rounds} round(s), interleaved), "
          "each tick with its records:")
    for label, code in codes.items():
        figure = figures[label]
        wall, cpu = ([us / 1e6 for us in figure.wall_us], [us / 1e6 for us in figure.cpu_us])
        print(f"  {label} ({commit_of(code)}):\n    wall {microseconds(wall)}\n"
              f"    CPU of the ticking thread {microseconds(cpu)}\n"
              "    CPU per sim second, median of the missions:")
        for what in figure.per_sim_s[0][1]:
            values = [shares[what] for _, shares in figure.per_sim_s]
            print(f"      {what:34} {statistics.median(values):6.2f} ms")
        for seed in seeds:
            values = [shares["the executive (every thread)"]
                      for played, shares in figure.per_sim_s if played == seed]
            print(f"      the executive, seed {seed:<20} {statistics.median(values):6.2f} ms")
        print_leaves(figure)


def print_leaves(figure: MissionFigures, shown: int = 8) -> None:
    """The leaves whose updates took the most CPU over all the missions, per sim second, and
    their updates' share of the tick (the rest is py_trees' composites, decorators and the
    leaves' lifecycle)."""
    if not figure.leaf_cpu_s or figure.sim_s <= 0.0:
        return
    total = sum(figure.leaf_cpu_s.values())
    print(f"    the leaves' updates, over all missions: {total * 1e3 / figure.sim_s:.2f} ms "
          "per sim s; the most costly:")
    for kind in sorted(figure.leaf_cpu_s, key=figure.leaf_cpu_s.__getitem__, reverse=True)[:shown]:
        cpu_s, calls = figure.leaf_cpu_s[kind], figure.leaf_calls[kind]
        each_us = cpu_s * 1e6 / max(calls, 1)
        print(f"      {kind:34} {cpu_s * 1e3 / figure.sim_s:6.2f} ms "
              f"({calls / figure.sim_s:5.1f} updates a sim s, {each_us:8.1f} µs each)")


def commit_of(code: Path) -> str:
    done = subprocess.run(["git", "-C", str(code), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True)
    return done.stdout.strip() or "not a git checkout"


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.drive_ticks < 0 or args.idle_ticks < 1 or args.monitor_rounds < 0 or args.rounds < 1:
        build_parser().error("--drive-ticks and --monitor-rounds must be 0 or more and "
                             "--idle-ticks and --rounds 1 or more")
    parts = [part for part in args.parts.split(",") if part]
    if unknown := [part for part in parts if part not in PARTS]:
        build_parser().error(f"--parts: unknown part {unknown[0]} (choose from {', '.join(PARTS)})")
    try:
        seeds = [int(seed) for seed in args.seeds.split(",")]
    except ValueError:
        build_parser().error(f"--seeds {args.seeds}: not a comma list of integers")
    if args.reference_code is not None and not (args.reference_code / "bt_servicesim").is_dir():
        build_parser().error(f"--reference-code {args.reference_code}: not a checkout of this "
                             "repository")
    domain = isolate()
    from bt_servicesim.tree.loading import MissionTreeError, load_mission_tree

    try:
        load_mission_tree(args.tree)
    except MissionTreeError as error:
        build_parser().error(str(error))
    print(f"py_trees {version('py_trees')}, ROS domain {domain}, "
          f"discovery {os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}")
    if "scripted" in parts:
        scripted(args.tree, args.drive_ticks)
    if "idle" in parts:
        idle(args.tree, args.idle_ticks)
    if "monitor" in parts and args.monitor_rounds:
        monitored(args.tree, args.drive_ticks, args.monitor_rounds)
    if "missions" in parts:
        missions(seeds, args.rounds, args.reference_code)
    return 0


if __name__ == "__main__":
    sys.exit(main())
