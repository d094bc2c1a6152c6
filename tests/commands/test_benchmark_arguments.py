"""``benchmarks/sim_rtf.py``, ``startup.py``, ``service_burst.py``, ``tick_cost.py``,
``killed_simulator.py``, ``lockstep_cost.py`` and ``timed_run.py``: bad arguments are one line
on stderr and exit status 2, before any process starts; ``lockstep_cost.py``, which starts no
ROS, also runs briefly."""

from __future__ import annotations

import importlib.util
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from bt_servicesim.evaluation.episodes import descendants

SIM_RTF = Path(__file__).resolve().parents[2] / "benchmarks" / "sim_rtf.py"
STARTUP = SIM_RTF.with_name("startup.py")


@pytest.mark.parametrize(("arguments", "named"), [
    (["--free-running-code", "/nowhere"], "/nowhere: not a checkout of this repository"),
    (["--free-running-code", str(SIM_RTF.parent)], "not a checkout of this repository"),
    (["--seeds", "3-x"], "'3-x': not seeds like 0,1,2 or 0-4"),
    (["--speed", "-1"], "--speed -1.0: must be 0 or more"),
])
def test_a_bad_argument_is_one_line_and_status_2(arguments: list[str], named: str) -> None:
    refused_in_one_line(SIM_RTF, arguments, named)


def refused_in_one_line(script: Path, arguments: list[str], named: str) -> None:
    """``script`` refuses ``arguments`` with one line naming the problem and exit status 2."""
    done = subprocess.run([sys.executable, str(script), *arguments], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"benchmarks/{script.name}: error: "), lines
    assert named in lines[0]


@pytest.mark.parametrize(("arguments", "named"), [
    (["--runs", "0"], "--runs must be at least 1, not 0"),
    (["--runs", "x"], "argument --runs: invalid int value: 'x'"),
    (["--seed", "1.5"], "argument --seed: invalid int value: '1.5'"),
])
def test_the_startup_benchmark_refuses_bad_arguments_in_one_line(arguments: list[str],
                                                                 named: str) -> None:
    refused_in_one_line(STARTUP, arguments, named)


@pytest.mark.parametrize(("arguments", "named"), [
    (["--bursts", "1000,x"], "--bursts 1000,x: not a comma list of whole numbers"),
    (["--bursts", "0"], "--bursts 0: every burst must be 1 request or more"),
    (["--rounds", "0"], "--rounds 0: must be 1 or more"),
    (["--wait", "nan"], "--wait nan: must be more than 0"),
])
def test_the_service_burst_benchmark_refuses_bad_arguments_in_one_line(arguments: list[str],
                                                                       named: str) -> None:
    refused_in_one_line(SIM_RTF.with_name("service_burst.py"), arguments, named)


@pytest.mark.parametrize(("arguments", "named"), [
    ([".", "/nowhere"], "argument OTHER: /nowhere: not a checkout of this repository"),
    (["/nowhere", "."], "argument THIS: /nowhere: not a checkout of this repository"),
    ([".", ".", "--rounds", "0"], "--rounds 0: must be 1 or more"),
    ([".", ".", "--seeds", "5,x"], "'5,x': not seeds like 0,1,2 or 0-4"),
    ([".", ".", "--hard-seeds", "-3"], "'-3': not seeds like 0,1,2 or 0-4"),
    (["."], "the following arguments are required: OTHER"),
])
def test_the_cpu_per_sim_second_benchmark_refuses_bad_arguments_in_one_line(
        arguments: list[str], named: str) -> None:
    refused_in_one_line(SIM_RTF.with_name("cpu_per_sim_second.py"),
                        [str(SIM_RTF.parents[1]) if argument == "." else argument
                         for argument in arguments], named)


@pytest.mark.parametrize(("arguments", "named"), [
    (["--parts", "scripted,nothing"], "--parts: unknown part nothing"),
    (["--seeds", "5,x"], "--seeds 5,x: not a comma list of integers"),
    (["--rounds", "0"], "--idle-ticks and --rounds 1 or more"),
    (["--reference-code", "/nowhere"], "--reference-code /nowhere: not a checkout"),
])
def test_the_tick_cost_benchmark_refuses_bad_arguments_in_one_line(arguments: list[str],
                                                                   named: str) -> None:
    refused_in_one_line(SIM_RTF.with_name("tick_cost.py"), arguments, named)


def test_the_timed_run_harness_without_its_arguments_is_one_line_and_status_2() -> None:
    refused_in_one_line(SIM_RTF.with_name("timed_run.py"), [], "FIGURES.json RUN_ARGUMENTS")


@pytest.mark.parametrize(("arguments", "named"), [
    (["--runs", "0"], "--runs 0: give at least one run"),
    (["--hogs", "-1"], "--hogs -1: give zero or more hogs"),
    (["--jobs", "two"], "--jobs two: give a number of workers or 'auto'"),
])
def test_the_suite_under_load_benchmark_refuses_bad_arguments_in_one_line(
        arguments: list[str], named: str) -> None:
    refused_in_one_line(SIM_RTF.with_name("suite_under_load.py"), arguments, named)



@pytest.mark.parametrize(("arguments", "named"), [
    (["--runs", "0"], "--runs 0: give at least one run"),
    (["--jobs", "0"], "--jobs 0: give at least one loop"),
    (["--hogs", "-1"], "--hogs -1: give zero or more hogs"),
    (["--speed", "0"], "--speed 0: must be more than 0"),
    (["--speed", "nan"], "--speed nan: must be more than 0"),
])
def test_the_killed_simulator_benchmark_refuses_bad_arguments_in_one_line(
        arguments: list[str], named: str) -> None:
    refused_in_one_line(SIM_RTF.with_name("killed_simulator.py"), arguments, named)

def suite_under_load() -> Any:
    spec = importlib.util.spec_from_file_location(
        "suite_under_load", SIM_RTF.with_name("suite_under_load.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # a dataclass looks its module up there
    spec.loader.exec_module(module)
    return module


def test_the_suite_benchmarks_run_as_many_workers_as_make_test(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Their default is the Makefile's ``JOBS``, read from make: what ``make test`` runs, as
    its dry run prints it, and what a user sets for it."""
    module = suite_under_load()
    monkeypatch.delenv("JOBS", raising=False)
    dry_run = subprocess.run(["make", "-n", "--no-print-directory", "-C",
                              str(SIM_RTF.parents[1]), "test"],
                             capture_output=True, text=True, timeout=60, check=True)
    pytest_line = dry_run.stdout.strip().splitlines()[-1]
    assert f" -m pytest -n {module.arguments([])[2]} --dist loadgroup " in pytest_line
    monkeypatch.setenv("JOBS", "7")
    assert module.arguments([])[2] == "7"
    assert module.arguments(["--jobs", "2"])[2] == "2"


def test_the_suite_under_load_benchmark_names_each_failing_test_and_the_counts() -> None:
    module = suite_under_load()
    output = "\n".join([
        "........F.", "=========================== short test summary info ============",
        "FAILED tests/sim/test_x.py::test_y[1] - AssertionError: 998 of 1000",
        "ERROR tests/commands/test_z.py::test_w - TimeoutError",
        "============ 1 failed, 2074 passed, 1 error in 361.27s (0:06:01) ============",
    ])
    run = module.parse_output(number=3, wall_s=370.0, exit_code=1, output=output)
    assert run.failing == ["tests/sim/test_x.py::test_y[1]", "tests/commands/test_z.py::test_w"]
    assert run.counts == {"failed": 1, "passed": 2074, "error": 1}
    assert run.pytest_s == 361.27
    assert "failing: tests/sim/test_x.py::test_y[1]; tests/commands/test_z.py::test_w" in run.line()


SLEEPING_TEST = """
import pathlib, time

def test_sleeps():  # runs until it is stopped
    pathlib.Path(__file__).with_suffix(".started").write_text("up")
    time.sleep(120)
"""


def test_sigterm_stops_the_suite_under_load_benchmark_its_run_and_its_hogs(
        tmp_path: Path) -> None:
    test_file = tmp_path / "test_sleeping.py"
    test_file.write_text(SLEEPING_TEST)
    code, stdout, stderr, started = stopped_by_sigterm(
        [sys.executable, str(SIM_RTF.with_name("suite_under_load.py")), "--runs", "2", "--jobs",
         "1", "--log-dir", str(tmp_path / "logs"), "--", str(test_file), "-p", "no:randomly"],
        started_file=test_file.with_suffix(".started"))
    assert len(started) >= 3  # the hog, pytest and its worker
    assert code == 130, stderr
    assert "interrupted: the run under way is stopped" in stderr
    assert "0 run(s) of the suite" in stdout
    assert all_gone(started), "the run and the hog are gone"


def stopped_by_sigterm(command: list[str], *, started_file: Path,
                       ) -> tuple[int, str, str, list[int]]:
    """``command`` stopped by SIGTERM once ``started_file`` exists (a test it runs wrote it):
    its exit status, stdout, stderr, and the processes it had started by then. Whatever it
    leaves running is killed afterwards, so a failing check leaves nothing behind."""
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, start_new_session=True)
    started: list[int] = []
    try:
        deadline = time.monotonic() + 60.0
        while not started_file.exists():
            assert process.poll() is None and time.monotonic() < deadline, process.communicate()
            time.sleep(0.1)
        started = descendants(process.pid)
        process.send_signal(signal.SIGTERM)
        stdout, stderr = process.communicate(timeout=60)
    finally:
        for pid in [process.pid, *started]:  # whatever the command left, this test ends
            if alive(pid):
                os.kill(pid, signal.SIGKILL)
        process.wait()
    return process.returncode, stdout, stderr, started


def all_gone(pids: list[int], *, limit_s: float = 30.0) -> bool:
    """Whether every one of ``pids`` has ended (or is a zombie) within ``limit_s``."""
    deadline = time.monotonic() + limit_s
    while any(alive(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    return not any(alive(pid) for pid in pids)


def alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize(("arguments", "named"), [
    (["--periods", "0"], "--periods and --rounds: at least 1"),
    (["--rounds", "-1"], "--periods and --rounds: at least 1"),
    (["--reference-code", "/nowhere"], "/nowhere: not a checkout of this repository"),
])
def test_the_lockstep_cost_benchmark_refuses_bad_arguments_in_one_line(
        arguments: list[str], named: str) -> None:
    refused_in_one_line(SIM_RTF.with_name("lockstep_cost.py"), arguments, named)


def test_the_lockstep_cost_benchmark_prints_each_checkouts_cpu_a_period() -> None:
    checkout = str(SIM_RTF.parents[1])
    out = subprocess.run([sys.executable, str(SIM_RTF.with_name("lockstep_cost.py")),
                          "--periods", "200", "--rounds", "1", "--reference-code", checkout],
                         capture_output=True, text=True, timeout=120, check=True).stdout
    figures = re.findall(r"\((.+)\): median ([0-9.]+) µs of CPU a period", out)
    assert [where for where, _ in figures] == [checkout, checkout]
    assert all(float(figure) > 0.0 for _, figure in figures)
