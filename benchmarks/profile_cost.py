"""What the mission profile costs: on the tick, after the run, and over whole episodes.

``python benchmarks/profile_cost.py [--episodes N] [--seeds 7,11] [--rounds R]`` prints

* tick: the shipped tree with scripted leaves (``benchmarks/tick_cost.py``'s scripted mission),
  ticked through a whole mission with the run's snapshot log, without and with its tick
  counter (:class:`~bt_servicesim.records.tree_log.TickCounter`, the only part of the profile
  on the tick's path), ``--rounds`` rounds interleaved: wall time per tick;
* build: ``profile.json`` built again from the first episode's records
  (:func:`~bt_servicesim.records.profile_inputs.profile_of_run`), wall and CPU time;
* episodes: ``python -m bt_servicesim.run --headless --speed 0`` on each seed, ``--episodes``
  times each, alternately with ``--no-profile`` (no counter, no profile.json) and with the
  profile (the default): each episode's wall time and the CPU time of the run's process tree
  (executive and simulator), and the paired differences (the same seed and round, with and
  without) as shares of the episode without the profile.

Figures are this machine's, under its load; nothing here is asserted. Bad arguments give one
line and exit status 2.
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from functools import partial
from pathlib import Path
from typing import Any

from ros_harness import REPO, isolate
from tick_cost import microseconds, scripted_mission

from bt_servicesim.cli import OneLineArgumentParser

sys.path.insert(0, str(REPO))


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog="python benchmarks/profile_cost.py",
                                   description="What the mission profile costs.")
    parser.add_argument("--episodes", type=int, default=2,
                        help="episodes per seed and setting (default 2)")
    parser.add_argument("--seeds", default="7,11", help="comma list of seeds (default 7,11)")
    parser.add_argument("--rounds", type=int, default=5,
                        help="interleaved rounds of the scripted mission (default 5)")
    return parser


def tick_cost(rounds: int) -> None:
    from bt_servicesim.records.tree_log import TreeLog
    from bt_servicesim.tree.files import DEFAULT_TREE

    durations: dict[bool, list[float]] = {False: [], True: []}
    with tempfile.TemporaryDirectory() as scratch:
        for _ in range(rounds):
            for count in (False, True):
                tree, clock, _script = scripted_mission(DEFAULT_TREE, 300)
                log = TreeLog(tree=tree, path=Path(scratch) / "tree_log.jsonl",
                              sim_time_s=partial(_seconds, clock),
                              count=count)
                tree.add_post_tick_handler(log)
                durations[count] += _ticks(tree, clock)
                log.close()
    print("tick, scripted shipped mission with its snapshot log:")
    for count, label in ((False, "without the tick counter"), (True, "with the tick counter")):
        print(f"  {label:26} {microseconds(durations[count])}")


def _seconds(clock: Any) -> float:
    return float(clock.nanoseconds) / 1e9


def _ticks(tree: Any, clock: Any) -> list[float]:
    import py_trees

    finished = (py_trees.common.Status.SUCCESS, py_trees.common.Status.FAILURE)
    times = []
    while tree.root.status not in finished:
        started = time.perf_counter()
        tree.tick()
        times.append(time.perf_counter() - started)
        clock.advance(0.1)
    return times


def build_cost(run: Path) -> None:
    from bt_servicesim.records.profile_inputs import profile_of_run

    cpu, wall = time.process_time(), time.perf_counter()
    profile = profile_of_run(run)
    print(f"build: profile.json of a {profile['sim_time_s']:.0f} sim s episode "
          f"({profile['ticks']} ticks) in {time.perf_counter() - wall:.3f} s wall, "
          f"{time.process_time() - cpu:.3f} s CPU")


def episode(seed: int, out: Path, *, profile: bool) -> tuple[float, float]:
    """(wall s, CPU s of the run's process tree) of one episode."""
    command = [sys.executable, "-m", "bt_servicesim.run", "--headless", "--speed", "0",
               "--seed", str(seed), "--out", str(out), "--overwrite", "--trajectory", "failed"]
    if not profile:
        command.append("--no-profile")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def episodes(seeds: Sequence[int], count: int, directory: Path) -> Path:
    figures: dict[bool, list[tuple[float, float]]] = {False: [], True: []}
    for round_number in range(count):
        for seed in seeds:
            for profile in (False, True):
                out = directory / f"{seed}-{'profile' if profile else 'plain'}-{round_number}"
                figures[profile].append(episode(seed, out, profile=profile))
    print(f"episodes: seeds {', '.join(map(str, seeds))}, {count} each per setting, alternated:")
    for profile, label in ((False, "--no-profile"), (True, "with the profile")):
        walls = [wall for wall, _ in figures[profile]]
        cpus = [cpu for _, cpu in figures[profile]]
        print(f"  {label:17} wall median {statistics.median(walls):6.2f} s "
              f"(mean {statistics.fmean(walls):6.2f}), CPU median {statistics.median(cpus):6.2f} s "
              f"(mean {statistics.fmean(cpus):6.2f})")
    for index, measure in ((0, "wall"), (1, "CPU")):
        shares = [(with_profile[index] - plain[index]) / plain[index]
                  for plain, with_profile in zip(figures[False], figures[True], strict=True)]
        print(f"  {measure} with the profile over the same seed without it, paired: median "
              f"{statistics.median(shares):+.1%}, mean {statistics.fmean(shares):+.1%} "
              f"(n={len(shares)})")
    return directory / f"{seeds[0]}-profile-0"


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        seeds = [int(seed) for seed in args.seeds.split(",")]
    except ValueError:
        print(f"python benchmarks/profile_cost.py: error: --seeds {args.seeds}: not a comma "
              "list of integers", file=sys.stderr)
        return 2
    if args.episodes < 1 or args.rounds < 1:
        print("python benchmarks/profile_cost.py: error: --episodes and --rounds must be 1 or "
              "more", file=sys.stderr)
        return 2
    isolate()
    tick_cost(args.rounds)
    with tempfile.TemporaryDirectory(prefix="profile_cost-") as scratch:
        first = episodes(seeds, args.episodes, Path(scratch))
        build_cost(first)
    return 0


if __name__ == "__main__":
    sys.exit(main())
