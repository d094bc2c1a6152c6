"""``benchmarks/suite_cost.py``: every test's CPU, its own and its processes', is put down to
that test and its file; bad arguments are one line and exit status 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.commands.test_benchmark_arguments import (
    SLEEPING_TEST,
    all_gone,
    refused_in_one_line,
    stopped_by_sigterm,
)

SUITE_COST = Path(__file__).resolve().parents[2] / "benchmarks" / "suite_cost.py"
TINY_SUITE = '''
import subprocess, sys, time

def burn(seconds):
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass

def test_in_a_process_of_its_own():
    subprocess.run([sys.executable, "-c",
                    "import time\\nend = time.process_time() + 0.4\\n"
                    "while time.process_time() < end: pass"], check=True)

def test_in_the_test_process():
    burn(0.3)

def test_that_fails():
    assert False
'''


@pytest.mark.parametrize(("arguments", "named"), [
    (["--jobs", "x"], "--jobs x: give a number of workers or 'auto'"),
    (["--top", "0"], "--top 0: give at least 1"),
    (["--json", "/nowhere/figures.json"], "--json /nowhere/figures.json: its folder does not"),
])
def test_bad_arguments_are_one_line_and_status_2(arguments: list[str], named: str) -> None:
    refused_in_one_line(SUITE_COST, arguments, named)


def test_each_tests_cpu_is_put_down_to_it_in_its_process_or_in_the_ones_it_started(
        tmp_path: Path) -> None:
    (tmp_path / "test_tiny.py").write_text(TINY_SUITE)
    figures = tmp_path / "figures.json"
    done = subprocess.run(
        [sys.executable, str(SUITE_COST), "--jobs", "0", "--top", "2", "--json", str(figures),
         "--", str(tmp_path / "test_tiny.py"), "--rootdir", str(tmp_path)],
        capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, done.stderr  # pytest's: a test failed
    tests = {test["test"].rsplit("::", 1)[-1]: test
             for test in json.loads(figures.read_text())["tests"]}
    assert set(tests) == {"test_in_a_process_of_its_own", "test_in_the_test_process",
                          "test_that_fails"}
    assert tests["test_in_a_process_of_its_own"]["children_s"] >= 0.35
    assert tests["test_in_the_test_process"]["own_s"] >= 0.28
    assert tests["test_in_the_test_process"]["children_s"] < 0.05
    lines = done.stdout.splitlines()
    assert lines[0].startswith("3 tests, pytest exit 1: ")
    ranked = lines[lines.index(next(line for line in lines if line.startswith("the 2 tests"))) + 1:]
    assert ranked[0].endswith("test_in_a_process_of_its_own")
    assert ranked[1].endswith("test_in_the_test_process")


def test_sigterm_stops_the_suite_and_leaves_no_process(tmp_path: Path) -> None:
    test_file = tmp_path / "test_sleeping.py"
    test_file.write_text(SLEEPING_TEST)
    code, stdout, stderr, started = stopped_by_sigterm(
        [sys.executable, str(SUITE_COST), "--jobs", "1", "--", str(test_file),
         "--rootdir", str(tmp_path)],
        started_file=test_file.with_suffix(".started"))
    assert len(started) >= 2  # pytest and its worker
    assert code == 130, stderr
    assert "interrupted: the suite is stopped" in stderr
    assert stdout == ""
    assert all_gone(started), "pytest and its worker are gone"
