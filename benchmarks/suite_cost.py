"""Where the test suite's CPU goes: every test's CPU, its own and its processes', by file.

``python benchmarks/suite_cost.py [--jobs J] [--top N] [--json FILE] [-- PYTEST_ARGS...]`` runs
``make test``'s pytest command (``pytest -n J --dist loadgroup tests``, ``J`` the Makefile's
``JOBS`` unless given; ``--jobs 0`` runs without pytest-xdist) with this file as a pytest
plugin, and prints:

* the whole run: wall time, and the CPU (user + system) of pytest and of every process it
  reaped, which on a CPU-bound suite is what sets the wall time on two cores;
* how much of that the tests account for, in the test processes themselves and in the
  processes they started (simulators, runs, evaluations), and the rest (starting the workers,
  collecting the tests);
* the ``N`` test files and the ``N`` tests that cost the most CPU, each with its wall time.

pytest's own output goes to stderr, the report to stdout.

A test's CPU is read from ``getrusage`` around its set-up, call and tear-down: its test
process's own time (``RUSAGE_SELF``) and the time of the child processes reaped meanwhile
(``RUSAGE_CHILDREN``, which includes what those reaped of theirs). A process a fixture started
for many tests counts for the test whose tear-down reaps it. ``--json FILE`` writes every test's
figures there, whole or not at all. Figures are this machine's; nothing is asserted. Ctrl-C (or
SIGTERM, or SIGHUP) stops the suite and exits with status 130; bad arguments give one line and
exit status 2; otherwise the exit status is pytest's.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Generator, Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import pytest
from suite_under_load import REPO, make_test_jobs, wait_for_suite

PLUGIN = Path(__file__).stem
OUT_VARIABLE = "BT_SERVICESIM_SUITE_COST_OUT"
"""Where the plugin, loaded in each test process, appends one JSON line per test."""


# ----------------------------------------------------------------------------- the plugin
def _cpu_s(who: int) -> float:
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None,
                            ) -> Generator[None, object, object]:
    """Around each test's set-up, call and tear-down: its CPU and wall time, one line."""
    out = os.environ.get(OUT_VARIABLE)
    own, children, started = (_cpu_s(resource.RUSAGE_SELF), _cpu_s(resource.RUSAGE_CHILDREN),
                              time.monotonic())
    outcome = yield
    if out is None:
        return outcome
    line = json.dumps({"test": item.nodeid,
                       "own_s": round(_cpu_s(resource.RUSAGE_SELF) - own, 4),
                       "children_s": round(_cpu_s(resource.RUSAGE_CHILDREN) - children, 4),
                       "wall_s": round(time.monotonic() - started, 4)})
    with open(out, "a", encoding="utf-8") as lines:  # a line per write: appends stay whole
        lines.write(line + "\n")
    return outcome


# ---------------------------------------------------------------------------- the command
@dataclass(frozen=True)
class TestCost:
    """One test's figures, as the plugin wrote them."""

    test: str
    own_s: float
    children_s: float
    wall_s: float

    @property
    def cpu_s(self) -> float:
        return self.own_s + self.children_s

    @property
    def file(self) -> str:
        return self.test.split("::", 1)[0]


@dataclass(frozen=True)
class SuiteCost:
    """The whole run: pytest's exit status, wall time and CPU, and every test's figures."""

    exit_code: int
    wall_s: float
    cpu_s: float
    tests: list[TestCost]


def run_suite(*, jobs: str, pytest_args: Sequence[str]) -> SuiteCost:
    """The suite with the plugin; Ctrl-C stops it (its whole process group) and is raised."""
    with tempfile.TemporaryDirectory(prefix="suite-cost-") as folder:
        lines = Path(folder) / "tests.jsonl"
        parallel = [] if jobs == "0" else ["-n", jobs, "--dist", "loadgroup"]
        command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", PLUGIN,
                   *parallel, *pytest_args]
        path = os.pathsep.join(filter(None, [str(REPO / "benchmarks"),
                                             os.environ.get("PYTHONPATH", "")]))
        environment = {**os.environ, OUT_VARIABLE: str(lines), "PYTHONPATH": path,
                       "PYTHONDONTWRITEBYTECODE": ""}  # bytecode written, as make test
        before, started = _cpu_s(resource.RUSAGE_CHILDREN), time.monotonic()
        suite = subprocess.Popen(command, cwd=REPO, env=environment, start_new_session=True,
                                 stdout=sys.stderr)  # pytest's own lines; the report on stdout
        exit_code = wait_for_suite(suite)
        wall_s, cpu_s = time.monotonic() - started, _cpu_s(resource.RUSAGE_CHILDREN) - before
        tests = read_tests(lines.read_text(encoding="utf-8") if lines.exists() else "")
    return SuiteCost(exit_code=exit_code, wall_s=wall_s, cpu_s=cpu_s, tests=tests)


def read_tests(text: str) -> list[TestCost]:
    """The plugin's lines; a line cut short (a worker killed mid-write) is left out."""
    tests = []
    for line in text.splitlines():
        try:
            tests.append(TestCost(**json.loads(line)))
        except (ValueError, TypeError):
            continue
    return tests


def by_file(tests: Iterable[TestCost]) -> list[tuple[str, float, float, int]]:
    """Per test file: CPU, wall, number of tests; most CPU first."""
    totals: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0.0])
    for test in tests:
        total = totals[test.file]
        total[0] += test.cpu_s
        total[1] += test.wall_s
        total[2] += 1
    return sorted(((name, cpu, wall, int(count)) for name, (cpu, wall, count) in totals.items()),
                  key=lambda row: -row[1])


def report(cost: SuiteCost, *, top: int) -> str:
    own = sum(test.own_s for test in cost.tests)
    children = sum(test.children_s for test in cost.tests)
    lines = [
        f"{len(cost.tests)} tests, pytest exit {cost.exit_code}: {cost.wall_s:.1f} s wall, "
        f"{cost.cpu_s:.1f} s CPU (pytest and every process it reaped)",
        f"  in the tests: {own + children:.1f} s ({own:.1f} s in the test processes, "
        f"{children:.1f} s in the processes they started); the rest "
        f"{cost.cpu_s - own - children:.1f} s (workers starting, collecting)",
        f"the {top} test files that cost the most CPU (CPU s, wall s, tests):",
    ]
    lines += [f"  {cpu:7.1f} {wall:7.1f} {count:5d}  {name}"
              for name, cpu, wall, count in by_file(cost.tests)[:top]]
    lines.append(f"the {top} tests that cost the most CPU (CPU s, of it in processes, wall s):")
    lines += [f"  {test.cpu_s:7.2f} {test.children_s:7.2f} {test.wall_s:7.2f}  {test.test}"
              for test in sorted(cost.tests, key=lambda test: -test.cpu_s)[:top]]
    return "\n".join(lines)


def write_json(path: Path, cost: SuiteCost) -> None:
    """Every figure, written whole or not at all."""
    figures: dict[str, Any] = {"exit_code": cost.exit_code, "wall_s": round(cost.wall_s, 3),
                               "cpu_s": round(cost.cpu_s, 3),
                               "tests": [asdict(test) for test in cost.tests]}
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(figures, indent=1) + "\n", encoding="utf-8")
    partial.replace(path)


def arguments(argv: Sequence[str]) -> tuple[str, int, Path | None, list[str]]:
    from bt_servicesim.cli import OneLineArgumentParser

    parser = OneLineArgumentParser(prog="benchmarks/suite_cost.py",
                                   description=__doc__.split("\n")[0])
    parser.add_argument("--jobs", help="pytest-xdist workers (default: make test's, the "
                        "Makefile's JOBS; 0: no pytest-xdist)")
    parser.add_argument("--top", type=int, default=15, help="files and tests listed (15)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="every test's figures")
    parser.add_argument("pytest_args", nargs="*", help="after --: pytest's arguments (tests)")
    args = parser.parse_args(argv)
    if not (args.jobs is None or args.jobs == "auto" or args.jobs.isdigit()):
        parser.error(f"--jobs {args.jobs}: give a number of workers or 'auto'")
    if args.top < 1:
        parser.error(f"--top {args.top}: give at least 1")
    if args.json is not None and not args.json.parent.is_dir():
        parser.error(f"--json {args.json}: its folder does not exist")
    jobs = make_test_jobs() if args.jobs is None else args.jobs
    return jobs, args.top, args.json, args.pytest_args or ["tests"]


def main(argv: Sequence[str] | None = None) -> int:
    jobs, top, json_path, pytest_args = arguments(sys.argv[1:] if argv is None else argv)
    for stop_signal in (signal.SIGTERM, signal.SIGHUP):  # a stop as Ctrl-C: the suite ends
        signal.signal(stop_signal, signal.default_int_handler)
    try:
        cost = run_suite(jobs=jobs, pytest_args=pytest_args)
    except KeyboardInterrupt:
        print("interrupted: the suite is stopped", file=sys.stderr)
        return 130
    print(report(cost, top=top))
    if json_path is not None:
        write_json(json_path, cost)
    return cost.exit_code


if __name__ == "__main__":
    sys.exit(main())
