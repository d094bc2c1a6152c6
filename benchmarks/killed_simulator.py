"""Runs whose simulator is killed outright: does every one end as it should?

``python benchmarks/killed_simulator.py [--runs N] [--jobs J] [--hogs H] [--speed S]`` plays
``J`` loops at once (default 3, as ``make test`` has workers), each of ``N`` runs (default 100):
``python -m bt_servicesim.run --headless --trajectory never --speed S`` (default 2, a long
mission), and once its tree ticks, SIGKILL to its simulator. Every run must then end with exit
status 1 and a report that says ``the simulator was killed by SIGKILL`` (docs/reference/cli.md,
"What every way out leaves"); ``H`` busy-loop processes (default one: a CPU hog on one core)
run beside the loops, as on a shared machine.

Printed: each run that ended otherwise (its status, its report's failure, the last lines of its
stderr, and its kept directory), then how many runs ended with each exit status. A crash of the
run's own shut-down after its report (Fast DDS's, with its peer killed mid-write: see
docs/reference/evaluation.md, "Leaks") shows as exit status -11. Exit status 0 when every run
ended as it should, 1 otherwise; bad arguments give one line and exit status 2; Ctrl-C (or
SIGTERM, or SIGHUP) stops the runs under way and the hogs, and prints what was played.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from suite_under_load import REPO, start_hogs, stop

from bt_servicesim.cli import OneLineArgumentParser

EXPECTED_STATUS = 1
EXPECTED_FAILURE = "the simulator was killed by SIGKILL"
START_LIMIT_S = 120.0
"""Wall seconds a run may take to tick its tree, or to end once its simulator was killed."""


@dataclass(frozen=True)
class Outcome:
    """How one run ended once its simulator was killed."""

    status: int | None
    failure: str | None
    stderr_tail: str
    out: Path

    @property
    def as_it_should(self) -> bool:
        return self.status == EXPECTED_STATUS and self.failure == EXPECTED_FAILURE


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/killed_simulator.py",
                                   description="Runs whose simulator is killed: all end well?")
    parser.add_argument("--runs", type=int, default=100, help="runs in each loop (100)")
    parser.add_argument("--jobs", type=int, default=3, help="loops at once (3)")
    parser.add_argument("--hogs", type=int, default=1, help="busy-loop processes beside (1)")
    parser.add_argument("--speed", type=float, default=2.0,
                        help="the runs' speed factor (2: the mission outlasts the kill)")
    return parser


def arguments(argv: Sequence[str]) -> tuple[int, int, int, float]:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs {args.runs}: give at least one run")
    if args.jobs < 1:
        parser.error(f"--jobs {args.jobs}: give at least one loop")
    if args.hogs < 0:
        parser.error(f"--hogs {args.hogs}: give zero or more hogs")
    if not args.speed > 0:
        parser.error(f"--speed {args.speed:g}: must be more than 0 (the kill lands mid-mission)")
    return args.runs, args.jobs, args.hogs, args.speed


class Runs:
    """The runs under way, so that a stop reaches each of them, however late it started."""

    def __init__(self) -> None:
        self.stopping = threading.Event()
        self._lock = threading.Lock()
        self._running: set[subprocess.Popen[str]] = set()

    def start(self, command: list[str]) -> subprocess.Popen[str]:
        with self._lock:
            process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL,
                                       stderr=subprocess.PIPE, text=True)
            self._running.add(process)
            if self.stopping.is_set():
                process.send_signal(signal.SIGTERM)
        return process

    def done(self, process: subprocess.Popen[str]) -> None:
        with self._lock:
            self._running.discard(process)

    def stop(self) -> None:
        """SIGTERM to every run under way (a run stopped so stops its simulator) and to every
        run started from now on."""
        with self._lock:
            self.stopping.set()
            for process in self._running:
                process.send_signal(signal.SIGTERM)


def play_one(out: Path, *, speed: float, runs: Runs) -> Outcome:
    """Start a run, kill its simulator once the tree ticks, and wait for the run's end."""
    process = runs.start([sys.executable, "-m", "bt_servicesim.run", "--headless",
                          "--trajectory", "never", "--speed", repr(speed), "--out", str(out)])
    try:
        if _ticked(out, process, runs.stopping):
            for child in _children(process.pid):
                os.kill(child, signal.SIGKILL)
        try:
            _, stderr = process.communicate(timeout=START_LIMIT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            _, stderr = process.communicate()
    finally:
        runs.done(process)
    return Outcome(status=process.returncode, failure=_failure(out),
                   stderr_tail="\n".join(stderr.strip().splitlines()[-3:]), out=out)


def _ticked(out: Path, process: subprocess.Popen[str], stopping: threading.Event) -> bool:
    log, deadline = out / "tree_log.jsonl", time.monotonic() + START_LIMIT_S
    while time.monotonic() < deadline and process.poll() is None and not stopping.is_set():
        if log.is_file() and '"kind": "tick"' in log.read_text(errors="replace"):
            return True
        time.sleep(0.1)
    return False


def _children(pid: int) -> list[int]:
    try:
        return [int(child) for child in
                Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def _failure(out: Path) -> str | None:
    try:
        failure = json.loads((out / "report.json").read_text()).get("failure")
    except (OSError, ValueError):
        return "no readable report.json"
    return failure if isinstance(failure, str) else None


def loop(number: int, *, count: int, speed: float, folder: Path, outcomes: list[Outcome],
         runs: Runs) -> None:
    for index in range(count):
        if runs.stopping.is_set():
            return
        outcome = play_one(folder / f"loop{number}-run{index}", speed=speed, runs=runs)
        outcomes.append(outcome)
        if outcome.as_it_should:
            shutil.rmtree(outcome.out, ignore_errors=True)
        elif not runs.stopping.is_set():
            print(f"run {outcome.out.name}: exit status {outcome.status}, failure "
                  f"{outcome.failure!r}; kept in {outcome.out}\n  {outcome.stderr_tail}",
                  flush=True)


def report(outcomes: Sequence[Outcome]) -> None:
    statuses = Counter(outcome.status for outcome in outcomes)
    good = sum(outcome.as_it_should for outcome in outcomes)
    print(f"\n{len(outcomes)} run(s) played: {good} ended with status "
          f"{EXPECTED_STATUS} and '{EXPECTED_FAILURE}' in the report")
    for status, count in sorted(statuses.items(), key=lambda item: str(item[0])):
        print(f"  exit status {status}: {count}")


def _wait_for(threads: Sequence[threading.Thread]) -> None:
    """Until every thread has ended. A bare sleep, not ``join``: a signal that interrupts
    ``join`` can leave a thread that still runs looking ended."""
    while any(thread.is_alive() for thread in threads):
        time.sleep(0.2)


def main(argv: Sequence[str] | None = None) -> int:
    count, jobs, hogs, speed = arguments(sys.argv[1:] if argv is None else argv)
    folder = Path(tempfile.mkdtemp(prefix="killed-simulator-"))
    print(f"runs in {folder} (those that end as they should are removed)", flush=True)
    for stop_signal in (signal.SIGTERM, signal.SIGHUP):  # a stop as Ctrl-C
        signal.signal(stop_signal, signal.default_int_handler)
    outcomes: list[Outcome] = []
    runs = Runs()
    loops = [threading.Thread(target=loop, args=(number,), daemon=True, kwargs={
        "count": count, "speed": speed, "folder": folder, "outcomes": outcomes, "runs": runs})
        for number in range(jobs)]
    hog_processes = start_hogs(hogs)
    interrupted = False
    try:
        for thread in loops:
            thread.start()
        _wait_for(loops)
    except KeyboardInterrupt:
        print("interrupted: the runs under way are stopped", file=sys.stderr)
        interrupted = True
        runs.stop()
        _wait_for(loops)
    finally:
        stop(hog_processes)
    report(outcomes)
    if interrupted:
        return 130
    return 0 if outcomes and all(outcome.as_it_should for outcome in outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
