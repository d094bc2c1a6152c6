"""CPU per simulated second of whole missions, two checkouts side by side, and whether they
played the same missions.

``python benchmarks/cpu_per_sim_second.py THIS OTHER [--seeds 5,8,13] [--hard-seeds 3,20]
[--rounds R]`` plays, for each round and each seed, ``python -m bt_servicesim.run --seed S
--speed 0 --headless`` with each checkout's code (on this Python environment), one run after
the other, interleaved (``THIS`` then ``OTHER``), then the same seed cut at 1 sim s
(``--time-limit 1``) with each. A run's CPU is the user and system time of the run and of the
simulator it reaps (``RUSAGE_CHILDREN``: the runs go one at a time); the cut run's CPU is the
start-up and the end of a run, so the difference over the difference in sim seconds is what a
simulated second of the mission costs the pair, executive and simulator together. It prints
for each seed and checkout:

* CPU ms per sim second, and ``THIS / OTHER``;
* the simulator's process alone, the same way (its CPU from ``/proc`` every 0.1 s of wall
  time while it runs: the executive's share is the rest);
* the simulator's own figures, where its checkout logs them
  (:mod:`servicesim_sim.process.period_costs`): CPU of its loop thread per 0.1 s period of the
  task, in the physics steps, in publishing, and over the whole period;
* whether the two checkouts played the same mission: ``report.json`` (but for its run id, ROS
  domain and wall-clock timings), ``tree_log.jsonl`` and every message of ``run.mcap``, each
  checkout's own directory written as ``<checkout>``. Recorded messages are compared from the
  executive's join to its leaving: before the join (sim time 0.1 s) what reaches the recorder
  depends on when DDS matched it, and after the leaving the simulator runs on while the run
  closes the recording. Two checkouts that differ in what they compute may rightly differ.

Then, for the pair and for the simulator, the medians over the seeds of each seed's median
over the rounds. Wall-clock-free as far as a busy machine allows: CPU time
moves little with the load, but say how loaded the machine was (the load averages are
printed at the start and the end). Nothing is asserted. Bad arguments give one line and exit
status 2.
"""

from __future__ import annotations

import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from sim_rtf import ProcessCpu, checkout, code_path, commit_of, seed_list

from bt_servicesim.cli import OneLineArgumentParser

CUT_SIM_S = 1.0
WALL_CLOCK_KEYS = frozenset({"run_id", "ros_domain_id", "wall_time_s", "task_timing"})
"""What ``report.json`` says of the wall clock or of the run's identity, not of the mission."""
JOIN_NS = 100_000_000  # the first period's sim time, where the executive joins the lockstep
PERIOD_COSTS = re.compile(r"step ([0-9.]+) ms, publishing ([0-9.]+) ms, whole period ([0-9.]+) ms")
RUN_WALL_LIMIT_S = 1800.0
SAMPLE_S = 0.1  # wall seconds between looks at the simulator's CPU


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(
        prog="benchmarks/cpu_per_sim_second.py",
        description="CPU per simulated second of whole missions, two checkouts interleaved.")
    parser.add_argument("this", type=checkout, metavar="THIS",
                        help="a checkout of this repository (e.g. .)")
    parser.add_argument("other", type=checkout, metavar="OTHER",
                        help="another checkout to compare with (e.g. a git worktree of an "
                             "older commit)")
    parser.add_argument("--seeds", type=seed_list, default=[5, 8, 13],
                        help="random task seeds (default 5,8,13)")
    parser.add_argument("--hard-seeds", type=seed_list, default=[], metavar="SEEDS",
                        help="seeds played with --difficulty hard too (default none)")
    parser.add_argument("--rounds", type=int, default=1,
                        help="times each seed is played with each checkout (default 1)")
    return parser


@dataclass
class Run:
    """One run's figures."""

    cpu_s: float
    simulator_cpu_s: float
    sim_s: float
    period_costs: tuple[float, float, float] | None  # step, publishing, whole period (ms)
    records: Path


@dataclass
class Seed:
    """A seed's runs with one checkout: full missions and cuts, round by round."""

    full: list[Run] = field(default_factory=list)
    cut: list[Run] = field(default_factory=list)

    def ms_per_sim_s(self, *, simulator: bool = False, rounds: slice = slice(None)) -> float:
        """The median over ``rounds`` of (full - cut CPU) / (full - cut sim seconds): of the
        run and its simulator, or of the simulator alone."""
        return statistics.median(
            1e3 * ((full.simulator_cpu_s - cut.simulator_cpu_s) if simulator
                   else (full.cpu_s - cut.cpu_s)) / max(full.sim_s - cut.sim_s, 1e-9)
            for full, cut in zip(self.full[rounds], self.cut[rounds], strict=True))


def play(code: Path, seed: int, *, hard: bool, cut: bool, out: Path) -> Run:
    """``run --seed seed --speed 0 --headless`` with ``code``'s checkout, to ``out``."""
    command = [sys.executable, "-m", "bt_servicesim.run", "--seed", str(seed), "--speed", "0",
               "--headless", "--out", str(out)]
    if hard:
        command += ["--sim-arg=--difficulty", "--sim-arg=hard"]
    if cut:
        command += ["--time-limit", repr(CUT_SIM_S)]
    environment = os.environ.copy()
    environment["PYTHONPATH"] = code_path(code)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with (out.parent / f"{out.name}.stderr").open("w") as errors:
        run = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=errors,
                               env=environment, cwd=code)  # -m looks in cwd first
    simulator = simulator_cpu(run)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    try:
        report = json.loads((out / "report.json").read_text())
    except (OSError, ValueError):
        raise SystemExit(f"{code}: seed {seed}: the run wrote no report "
                         f"(see {out.parent / out.name}.stderr)") from None
    return Run(cpu_s=cpu, simulator_cpu_s=simulator,
               sim_s=float(report.get("sim_time_s") or 0.0),
               period_costs=period_costs(out / "sim.log"), records=out)


def simulator_cpu(run: subprocess.Popen[bytes]) -> float:
    """Wait for ``run``; the CPU seconds its children (the simulator) had spent at the last
    look, every :data:`SAMPLE_S` (what a simulator spends in its last moments is lost, in a
    full run and in a cut one alike)."""
    processes = ProcessCpu(run.pid)
    deadline = time.monotonic() + RUN_WALL_LIMIT_S
    while True:
        processes.sample()
        try:
            run.wait(timeout=SAMPLE_S)
        except subprocess.TimeoutExpired:
            if time.monotonic() > deadline:
                run.kill()
                run.wait()
                raise SystemExit(f"a run took over {RUN_WALL_LIMIT_S:.0f} s") from None
            continue
        return sum(processes.latest[pid] for pid in processes.children())


def period_costs(sim_log: Path) -> tuple[float, float, float] | None:
    """The simulator's own CPU per period of the task, if its checkout logs it."""
    found = PERIOD_COSTS.search(sim_log.read_text(errors="replace")) if sim_log.is_file() else None
    if found is None:
        return None
    step, publishing, period = (float(value) for value in found.groups())
    return step, publishing, period


def record_differences(first: Run, second: Run, codes: tuple[Path, Path]) -> list[str]:
    """What differs between two runs' records (see the module docstring); empty: nothing."""
    texts = [{name: (run.records / name).read_text().replace(str(code), "<checkout>")
              for name in ("report.json", "tree_log.jsonl")}
             for run, code in zip((first, second), codes, strict=True)]
    reports = [json.loads(text["report.json"]) for text in texts]
    differences = [f"report.json {key}" for key in sorted(set(reports[0]) | set(reports[1]))
                   if key not in WALL_CLOCK_KEYS and reports[0].get(key) != reports[1].get(key)]
    if texts[0]["tree_log.jsonl"] != texts[1]["tree_log.jsonl"]:
        differences.append("tree_log.jsonl")
    messages = [recorded(run.records / "run.mcap", code)
                for run, code in zip((first, second), codes, strict=True)]
    differences += [f"run.mcap {topic}" for topic in sorted(set(messages[0]) | set(messages[1]))
                    if messages[0].get(topic) != messages[1].get(topic)]
    return differences


def recorded(path: Path, code: Path) -> dict[str, list[bytes]]:
    """Each topic's messages in the recording, from the executive's join to its leaving."""
    from mcap.reader import make_reader

    topics: dict[str, list[tuple[int, bytes]]] = {}
    with path.open("rb") as stream:
        for _schema, channel, message in make_reader(stream).iter_messages():
            topics.setdefault(channel.topic, []).append((message.log_time, message.data))
    last = max((log_time for messages in topics.values() for log_time, _ in messages), default=0)
    own = str(code).encode()
    return {topic: [data.replace(own, b"<checkout>") for log_time, data in messages
                    if JOIN_NS < log_time < last]
            for topic, messages in topics.items()}


def figures(run: Run) -> str:
    if run.period_costs is None:
        return "the simulator logs no period costs"
    step, publishing, period = run.period_costs
    return (f"simulator per period: step {step:.3f} ms, publishing {publishing:.3f} ms, "
            f"whole {period:.3f} ms")


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.rounds < 1:
        build_parser().error(f"--rounds {args.rounds}: must be 1 or more")
    codes: tuple[Path, Path] = (args.this, args.other)
    print(f"THIS {codes[0]} ({commit_of(codes[0])}), OTHER {codes[1]} ({commit_of(codes[1])}); "
          f"load average {load()} on {os.cpu_count()} CPUs", flush=True)
    played = [(seed, False) for seed in args.seeds] + [(seed, True) for seed in args.hard_seeds]
    results: dict[tuple[int, bool], tuple[Seed, Seed]] = {key: (Seed(), Seed()) for key in played}
    identical = 0
    with tempfile.TemporaryDirectory(prefix="cpu-per-sim-second-") as scratch:
        for round_number in range(args.rounds):
            for seed, hard in played:
                identical += measure_seed(seed, hard, codes, results[seed, hard],
                                          Path(scratch) / f"r{round_number}")
    summary(results, identical=identical, rounds=args.rounds)
    return 0


def measure_seed(seed: int, hard: bool, codes: tuple[Path, Path], seeds: tuple[Seed, Seed],
                 root: Path) -> bool:
    """Play one seed with both checkouts, full then cut; print its line; whether the two full
    missions' records are the same."""
    name = f"{'hard ' if hard else ''}seed {seed}"
    for cut in (False, True):
        for index, (code, results) in enumerate(zip(codes, seeds, strict=True)):
            out = root / f"{'hard' if hard else 'random'}{seed}-{'cut' if cut else 'full'}-{index}"
            out.parent.mkdir(parents=True, exist_ok=True)
            (results.cut if cut else results.full).append(
                play(code, seed, hard=hard, cut=cut, out=out))
    fulls = [results.full[-1] for results in seeds]
    differences = record_differences(fulls[0], fulls[1], codes)
    last = slice(-1, None)  # this round's figures
    this, other = (results.ms_per_sim_s(rounds=last) for results in seeds)
    print(f"{name}: {fulls[0].sim_s:.1f} / {fulls[1].sim_s:.1f} sim s; CPU per sim s THIS "
          f"{this:.1f} ms, OTHER {other:.1f} ms, THIS/OTHER {this / other:.2f}; records "
          + ("identical" if not differences else "differ: " + ", ".join(differences)),
          flush=True)
    for label, run, results in zip(("THIS", "OTHER"), fulls, seeds, strict=True):
        simulator = results.ms_per_sim_s(simulator=True, rounds=last)
        print(f"  {label}: the simulator {simulator:.1f} ms per sim s; {figures(run)}",
              flush=True)
    return not differences


def summary(results: dict[tuple[int, bool], tuple[Seed, Seed]], *, identical: int,
            rounds: int) -> None:
    for what, simulator in (("the pair", False), ("the simulator", True)):
        this = [seeds[0].ms_per_sim_s(simulator=simulator) for seeds in results.values()]
        other = [seeds[1].ms_per_sim_s(simulator=simulator) for seeds in results.values()]
        print(f"median CPU per sim s of {what} over {len(results)} seeds: THIS "
              f"{statistics.median(this):.1f} ms ({min(this):.1f}-{max(this):.1f}), OTHER "
              f"{statistics.median(other):.1f} ms ({min(other):.1f}-{max(other):.1f}), "
              f"THIS/OTHER {statistics.median(this) / statistics.median(other):.2f}")
    print(f"records identical in {identical} of {len(results) * rounds} pairs; load average "
          f"{load()}")


def load() -> str:
    return " ".join(f"{value:.2f}" for value in os.getloadavg())


if __name__ == "__main__":
    sys.exit(main())
