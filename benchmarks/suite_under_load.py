"""The whole test suite, run after run, with a CPU hog on one core beside it.

``python benchmarks/suite_under_load.py [--runs N] [--hogs H] [--jobs J] [--log-dir DIR]
[-- PYTEST_ARGS...]`` runs ``make test``'s pytest command (``pytest -n J --dist loadgroup
tests``, ``J`` the Makefile's ``JOBS`` unless given) ``N`` times one after the other
(default 10) while ``H`` busy-loop processes (default one: a CPU hog on one core, as a shared
machine or a CI runner has) spin beside it, and prints,
for each run, its wall time, how many tests passed and failed, and the failing tests by name;
then the failures over all runs, test by test. Each run's whole output is kept in ``--log-dir``
(a new temporary folder by default) so that a failure can be read afterwards.

This is how a flaky test is found: one that fails even once in the runs waits on wall time
somewhere, or the code it tests has a race. Figures are wall-clock on this machine; nothing is
asserted. Ctrl-C (or SIGTERM, or SIGHUP) stops the run under way and the hogs, still prints
the table of the runs that finished and exits with status 130. Bad arguments give one line and
exit status 2.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from bt_servicesim.cli import OneLineArgumentParser

REPO = Path(__file__).resolve().parents[1]
HOG = "while True:\n    pass\n"
SUMMARY = re.compile(r"=+ (?P<text>.*\bin (?P<seconds>[0-9.]+)s\b.*) =+$")
COUNT = re.compile(r"(?P<count>\d+) (?P<what>passed|failed|errors?|skipped|xfailed|xpassed)")
FAILED = re.compile(r"^(?:FAILED|ERROR) (?P<test>\S+)")


@dataclass
class SuiteRun:
    """What one run of the suite gave."""

    number: int
    wall_s: float
    exit_code: int
    counts: dict[str, int] = field(default_factory=dict)
    failing: list[str] = field(default_factory=list)
    pytest_s: float | None = None

    def line(self) -> str:
        counts = ", ".join(f"{n} {what}" for what, n in sorted(self.counts.items())) or "no summary"
        named = "; ".join(self.failing) if self.failing else "-"
        pytest = f"{self.pytest_s:.1f}" if self.pytest_s is not None else "?"
        return (f"run {self.number:>2}: {self.wall_s:7.1f} s wall (pytest {pytest} s), "
                f"exit {self.exit_code}, {counts}; failing: {named}")


def parse_output(*, number: int, wall_s: float, exit_code: int, output: str) -> SuiteRun:
    """Read pytest's short summary and its last line into a :class:`SuiteRun`."""
    run = SuiteRun(number=number, wall_s=wall_s, exit_code=exit_code)
    for line in output.splitlines():
        failed = FAILED.match(line)
        if failed:
            run.failing.append(failed["test"])
        summary = SUMMARY.search(line.strip())
        if summary:
            run.pytest_s = float(summary["seconds"])
            run.counts = {m["what"]: int(m["count"]) for m in COUNT.finditer(summary["text"])}
    return run


def start_hogs(count: int) -> list[subprocess.Popen[bytes]]:
    """``count`` processes that each keep one core busy until they are stopped."""
    return [subprocess.Popen([sys.executable, "-c", HOG], stdin=subprocess.DEVNULL)
            for _ in range(count)]


def stop(processes: Sequence[subprocess.Popen[bytes]]) -> None:
    """End the processes this benchmark started, by their PID, and reap them."""
    for process in processes:
        if process.poll() is None:
            process.terminate()
    for process in processes:
        process.wait()


def run_suite(*, number: int, jobs: str, pytest_args: Sequence[str], log: Path) -> SuiteRun:
    """One run of the suite; its output goes to ``log`` and is parsed afterwards."""
    command = [sys.executable, "-m", "pytest", "-n", jobs, "--dist", "loadgroup", "-rfE",
               "-p", "no:cacheprovider", *pytest_args]
    start = time.monotonic()
    with log.open("w") as out:
        suite = subprocess.Popen(command, cwd=REPO, stdout=out, stderr=subprocess.STDOUT,
                                 start_new_session=True,  # bytecode written, as make test
                                 env={**os.environ, "PYTHONDONTWRITEBYTECODE": ""})
        exit_code = wait_for_suite(suite)
    return parse_output(number=number, wall_s=time.monotonic() - start, exit_code=exit_code,
                        output=log.read_text(errors="replace"))


def make_test_jobs() -> str:
    """``make test``'s pytest-xdist workers: the Makefile's ``JOBS``, their one source."""
    try:
        done = subprocess.run(["make", "-s", "--no-print-directory", "-C", str(REPO), "--eval",
                               "print-test-jobs: ; @echo $(JOBS)", "print-test-jobs"],
                              capture_output=True, text=True, timeout=60, check=False)
    except OSError as error:
        raise SystemExit(f"the Makefile's JOBS: make did not start ({error})") from error
    jobs = done.stdout.strip()
    if done.returncode != 0 or not jobs.isdigit():
        raise SystemExit(f"the Makefile's JOBS: make printed {jobs!r} "
                         f"({done.stderr.strip() or f'exit {done.returncode}'})")
    return jobs


def wait_for_suite(suite: subprocess.Popen[bytes]) -> int:
    """The exit status of a pytest run started in a session of its own; Ctrl-C stops it (its
    whole process group, workers and what they started) and is raised again."""
    try:
        return suite.wait()
    except KeyboardInterrupt:
        os.killpg(suite.pid, signal.SIGINT)
        suite.wait()
        raise


def report(runs: Sequence[SuiteRun], *, hogs: int) -> None:
    print(f"\n{len(runs)} run(s) of the suite with {hogs} CPU hog(s) beside it:")
    for run in runs:
        print(run.line())
    failures = Counter(test for run in runs for test in run.failing)
    if not runs:
        return
    walls = sorted(run.wall_s for run in runs)
    print(f"wall time: {walls[0]:.1f}-{walls[-1]:.1f} s; runs with a failure: "
          f"{sum(1 for run in runs if run.exit_code != 0)} of {len(runs)}")
    for test, times in failures.most_common():
        print(f"  failed {times}x: {test}")


def arguments(argv: Sequence[str]) -> tuple[int, int, str, Path | None, list[str]]:
    parser = OneLineArgumentParser(prog="benchmarks/suite_under_load.py",
                                   description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=10, help="runs of the suite (10)")
    parser.add_argument("--hogs", type=int, default=1, help="busy-loop processes beside it (1)")
    parser.add_argument("--jobs", help="pytest-xdist workers (default: make test's, the "
                        "Makefile's JOBS)")
    parser.add_argument("--log-dir", type=Path, help="keep each run's output here")
    parser.add_argument("pytest_args", nargs="*", help="after --: pytest's arguments (tests)")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs {args.runs}: give at least one run")
    if args.hogs < 0:
        parser.error(f"--hogs {args.hogs}: give zero or more hogs")
    if not (args.jobs is None or args.jobs == "auto" or args.jobs.isdigit()):
        parser.error(f"--jobs {args.jobs}: give a number of workers or 'auto'")
    jobs = make_test_jobs() if args.jobs is None else args.jobs
    return args.runs, args.hogs, jobs, args.log_dir, args.pytest_args or ["tests"]


def main(argv: Sequence[str] | None = None) -> int:
    runs, hogs, jobs, log_dir, pytest_args = arguments(sys.argv[1:] if argv is None else argv)
    folder = log_dir or Path(tempfile.mkdtemp(prefix="suite-under-load-"))
    folder.mkdir(parents=True, exist_ok=True)
    print(f"logs in {folder}", flush=True)
    done: list[SuiteRun] = []
    interrupted = False
    for stop_signal in (signal.SIGTERM, signal.SIGHUP):  # a stop as Ctrl-C: run and hogs end
        signal.signal(stop_signal, signal.default_int_handler)
    hog_processes = start_hogs(hogs)
    try:
        for number in range(1, runs + 1):
            run = run_suite(number=number, jobs=jobs, pytest_args=pytest_args,
                            log=folder / f"run-{number:02d}.log")
            done.append(run)
            print(run.line(), flush=True)
    except KeyboardInterrupt:
        print("interrupted: the run under way is stopped", file=sys.stderr)
        interrupted = True
    finally:
        stop(hog_processes)
    report(done, hogs=hogs)
    if interrupted:
        return 130
    return 0 if done and all(run.exit_code == 0 for run in done) else 1


if __name__ == "__main__":
    sys.exit(main())
