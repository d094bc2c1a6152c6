"""Does a seed replay? Pairs of identical runs, two at once, compared report by report.

``python benchmarks/reproducibility.py [--pairs N] [--sets default,random,hard] [--speeds 0,20]
[--executive bt|baseline] [--first-seed S] [--time-limit T] [--free-running] [--json FILE]``
runs, for each
scenario set and speed, ``N`` pairs: the two runs of a pair are the same command (the shipped
task for ``default``, seed ``S + i`` for the seeded sets, ``--difficulty hard`` for ``hard``),
started together so that they share the 2-core machine and load each other. It prints, per set
and speed, the share of pairs whose ``report.json`` agree on what an episode is judged by --
completed, each checkpoint's time, the penalties, the score -- and the commands of the pairs
that differ, which ``run`` replays; a pair that differs or has a run that stalled is kept for
a look (both runs' directories and stderr, copied to ``reproducibility-kept-…`` in the working
directory). ``--free-running`` measures the same without lockstep.
``--json FILE`` also writes the figures there, rewritten after each set and speed (so a run cut
short keeps what it measured), for ``evaluate --reproducibility FILE`` to state in
``results.md``.

Wall-clock figures vary with the machine's load; nothing here is asserted. Bad arguments give
one line and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bt_servicesim.cli import OneLineArgumentParser
from bt_servicesim.evaluation.figures_file import checkout_commit, write_figures
from bt_servicesim.mission.report import left_lockstep

SETS = {"default": (False, ()), "random": (True, ()), "hard": (True, ("--difficulty", "hard"))}
WALL_LIMIT_S = 1800.0


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/reproducibility.py",
                                   description="Share of identical report pairs.")
    parser.add_argument("--pairs", type=int, default=20, help="pairs per set and speed (20)")
    parser.add_argument("--sets", default="default,random,hard",
                        help="comma list of scenario sets: default, random, hard")
    parser.add_argument("--speeds", default="0,20", help="comma list of speed factors (0,20)")
    parser.add_argument("--executive", choices=("bt", "baseline"), default="bt")
    parser.add_argument("--first-seed", type=int, default=1,
                        help="the seeded sets use seeds S, S+1, ... (default 1)")
    parser.add_argument("--time-limit", type=float, default=900.0,
                        help="mission time limit in sim seconds (default 900)")
    parser.add_argument("--free-running", action="store_true",
                        help="run without lockstep, for comparison")
    parser.add_argument("--json", type=Path, default=None, metavar="FILE",
                        help="also write the figures to FILE as JSON")
    return parser


def judged(report: dict[str, Any]) -> tuple[Any, ...]:
    """What an episode is judged by, and what must replay."""
    return (report.get("completed"),
            [(c.get("done"), c.get("sim_time_s")) for c in report.get("checkpoints", [])],
            report.get("penalties"), report.get("score"))


def command_for(args: argparse.Namespace, scenario: str, speed: float, index: int) -> list[str]:
    seeded, sim_args = SETS[scenario]
    command = [sys.executable, "-m", "bt_servicesim.run", "--headless", "--speed", repr(speed),
               "--executive", args.executive, "--time-limit", repr(args.time_limit)]
    if seeded:
        command += ["--seed", str(args.first_seed + index)]
    command += [f"--sim-arg={argument}" for argument in sim_args]
    if args.free_running:
        command.append("--free-running")
    return command


def run_pair(command: list[str], root: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """Both runs of a pair, started together; their reports."""
    outs = [root / "a", root / "b"]
    logs = [(root / f"{out.name}.stderr").open("w") for out in outs]
    runs = [subprocess.Popen([*command, "--out", str(out)], stdout=subprocess.DEVNULL,
                             stderr=log) for out, log in zip(outs, logs, strict=True)]
    for log in logs:
        log.close()  # the runs hold their own copies
    for run in runs:
        run.wait(timeout=WALL_LIMIT_S)
    reports = []
    for out in outs:
        try:
            reports.append(json.loads((out / "report.json").read_text()))
        except (OSError, ValueError):
            reports.append({"failure": "no report"})
    return reports[0], reports[1]


def keep_if_odd(root: Path, first: dict[str, Any], second: dict[str, Any],
                name: str) -> Path | None:
    """A pair whose reports differ, or a run that stalled, is evidence: both runs' directories
    and what they said on stderr are copied out of the temporary directory (into the working
    directory); where to, or ``None`` for a pair like any other."""
    odd = (judged(first) != judged(second) or "no report" in (first.get("failure"),
                                                              second.get("failure"))
           or any(left_lockstep(report) for report in (first, second)))
    if not odd:
        return None
    kept = Path(tempfile.mkdtemp(prefix=f"reproducibility-kept-{name}-", dir=Path.cwd()))
    shutil.copytree(root, kept, dirs_exist_ok=True)
    return kept


def measure(args: argparse.Namespace, scenario: str, speed: float) -> dict[str, Any]:
    """Run the pairs of one set and speed; print and return the figures."""
    identical, differing, started = 0, [], time.monotonic()
    stalled = completed = 0
    for index in range(args.pairs):
        command = command_for(args, scenario, speed, index)
        with tempfile.TemporaryDirectory(prefix="reproducibility-") as root:
            first, second = run_pair(command, Path(root))
            kept = keep_if_odd(Path(root), first, second, f"{scenario}-speed{speed:g}-{index}")
        if kept is not None:
            print(f"  kept for a look: {kept}", flush=True)
        stalled += sum(left_lockstep(report) for report in (first, second))
        completed += sum(bool(report.get("completed")) for report in (first, second))
        if judged(first) == judged(second) and first.get("failure") != "no report":
            identical += 1
        else:
            differing.append({"command": shlex.join(["python", *command[1:]]),
                              "scores": [first.get("score"), second.get("score")]})
    wall_s = time.monotonic() - started
    print(f"{scenario:8s} speed {speed:g}: {identical}/{args.pairs} pairs identical "
          f"({100.0 * identical / args.pairs:.0f}%), {wall_s:.0f} s wall; {completed} of "
          f"{2 * args.pairs} runs completed, {stalled} left lockstep's guarantee "
          "(ticked a period without every message, or dropped by the simulator)", flush=True)
    for pair in differing:
        print(f"  differs ({pair['scores'][0]} vs {pair['scores'][1]}): {pair['command']}",
              flush=True)
    return {"set": scenario, "speed": speed, "pairs": args.pairs, "identical": identical,
            "completed_runs": completed, "runs": 2 * args.pairs, "stalled_runs": stalled,
            "wall_s": round(wall_s, 1), "differing": differing}


def write_json(path: Path, args: argparse.Namespace, argv: Sequence[str],
               results: list[dict[str, Any]]) -> None:
    """The figures so far, written whole (a temporary file renamed over ``path``)."""
    document = {
        "command": shlex.join(["python", "benchmarks/reproducibility.py", *argv]),
        "executive": args.executive,
        "timing": timing_of(args),
        "commit": checkout_commit(),
        "load_average": [round(value, 2) for value in os.getloadavg()],
        "results": results,
    }
    write_figures(path, document)


def timing_of(args: argparse.Namespace) -> str:
    return "free running" if args.free_running else "lockstep"


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    sets = [name.strip() for name in args.sets.split(",") if name.strip()]
    unknown = [name for name in sets if name not in SETS]
    if unknown:
        build_parser().error(f"--sets: unknown set {unknown[0]!r} (default, random, hard)")
    try:
        speeds = [float(value) for value in args.speeds.split(",")]
    except ValueError:
        build_parser().error(f"--speeds {args.speeds}: must be numbers")
    if args.pairs < 1 or any(not speed >= 0.0 for speed in speeds):
        build_parser().error("--pairs must be 1 or more and every speed 0 or more")
    print(f"{args.executive} executive, {timing_of(args)}, {args.pairs} pairs per set and speed, "
          "the two runs of a pair at once", flush=True)
    argv = sys.argv[1:] if argv is None else list(argv)
    results: list[dict[str, Any]] = []
    for speed in speeds:
        for scenario in sets:
            results.append(measure(args, scenario, speed))
            if args.json is not None:
                write_json(args.json, args, argv, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
