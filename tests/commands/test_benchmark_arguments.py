"""``benchmarks/sim_rtf.py``, ``startup.py`` and ``service_burst.py``: bad arguments are one
line on stderr and exit status 2, before any process starts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

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
