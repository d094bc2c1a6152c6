"""How long a run takes around its mission: from the command to the task's start, and from the
task's end to the process's exit.

``python benchmarks/startup.py [--runs N] [--seed S] [--fast-dds-defaults]`` plays the same
mission ``N`` times with ``python -m bt_servicesim.run --headless --speed 0 --trajectory
failed`` (the shipped task, or seed ``S``), one run at a time, and prints, from each run's
``report.json`` (``task_timing``, ``time.monotonic()``, the same clock as this process's):

* *start*: from starting the command to the run's first referee state of the task (imports,
  the simulator's start, DDS discovery, waiting for servers, the lockstep join);
* *mission*: the task, first to last referee state;
* *end*: from the last referee state to the process's exit (records, the simulator's stop).

With ``--fast-dds-defaults`` every other run gets Fast DDS's own periods instead of the
project's profile (``bt_servicesim/ros/fastdds_profile.xml``: announcements and heartbeats every
0.5 s rather than 3 s), so the two are measured in one sitting, interleaved. Wall-clock
figures follow the machine's load (it prints the load average); nothing is asserted. Bad
arguments give one line and exit status 2.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from bt_servicesim.cli import EXIT_OK, OneLineArgumentParser
from bt_servicesim.mission.settings import REPORT_NAME
from bt_servicesim.ros.environment import PROFILE_VARIABLE, apply_localhost_defaults

PROJECT_PROFILE = "project's profile"
FAST_DDS_DEFAULTS = "Fast DDS's periods"
EMPTY_PROFILE = '<?xml version="1.0"?>\n<profiles xmlns="http://www.eprosima.com"/>\n'


def timed_run(*, out: Path, seed: int | None, profile: str | None) -> tuple[float, ...]:
    """One run: (start, mission, end) in wall seconds; exits if the run left no timing."""
    environment = dict(os.environ)
    if profile is not None:
        environment[PROFILE_VARIABLE] = profile
    command = [sys.executable, "-m", "bt_servicesim.run", "--headless", "--speed", "0",
               "--trajectory", "failed", "--out", str(out), "--overwrite"]
    if seed is not None:
        command += ["--seed", str(seed)]
    started = time.monotonic()
    subprocess.run(command, env=environment, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, check=False)
    ended = time.monotonic()
    try:
        timing = json.loads((out / REPORT_NAME).read_text())["task_timing"]
        first, last = timing["first"]["monotonic_s"], timing["last"]["monotonic_s"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise SystemExit(f"benchmarks/startup.py: the run in {out} left no task timing "
                         f"({error})") from error
    return first - started, last - first, ended - last


def describe(name: str, rows: list[tuple[float, ...]]) -> str:
    starts = sorted(row[0] for row in rows)
    p90 = starts[min(len(starts) - 1, round(0.9 * (len(starts) - 1)))]
    slow = sum(start > starts[0] + 1.0 for start in starts)
    return (f"{name}: {len(rows)} runs; start median {statistics.median(starts):.2f} s, "
            f"p90 {p90:.2f}, max {starts[-1]:.2f} ({slow} more than 1 s over the fastest); "
            f"mission median {statistics.median(row[1] for row in rows):.2f} s; "
            f"end median {statistics.median(row[2] for row in rows):.2f} s")


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog="benchmarks/startup.py", description=__doc__)
    parser.add_argument("--runs", type=int, default=10, help="runs per variant (default 10)")
    parser.add_argument("--seed", type=int, default=None,
                        help="the mission's seed (default: the shipped task)")
    parser.add_argument("--fast-dds-defaults", action="store_true",
                        help="interleave runs with Fast DDS's own periods")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs must be at least 1, not {args.runs}")
    apply_localhost_defaults()
    variants: dict[str, str | None] = {PROJECT_PROFILE: None}
    with tempfile.TemporaryDirectory(prefix="startup-") as scratch:
        if args.fast_dds_defaults:
            empty = Path(scratch) / "fast_dds_defaults.xml"
            empty.write_text(EMPTY_PROFILE)
            variants[FAST_DDS_DEFAULTS] = str(empty)
        print(f"{args.runs} runs per variant, one at a time; Fast DDS profile "
              f"{os.environ.get(PROFILE_VARIABLE, 'none')}; load average "
              f"{os.getloadavg()[0]:.2f} at the start", flush=True)
        rows: dict[str, list[tuple[float, ...]]] = {name: [] for name in variants}
        for number in range(args.runs):
            for name, profile in variants.items():
                row = timed_run(out=Path(scratch) / f"run-{number}", seed=args.seed,
                                profile=profile)
                rows[name].append(row)
                print(f"  {name}, run {number + 1}: start {row[0]:.2f} s, mission "
                      f"{row[1]:.2f} s, end {row[2]:.2f} s", flush=True)
    for name, measured in rows.items():
        print(describe(name, measured))
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
