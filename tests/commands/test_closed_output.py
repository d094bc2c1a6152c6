"""A command whose reader goes away (``| head``) ends as a Unix tool that SIGPIPE ends: with
128 + SIGPIPE and no traceback. ``run`` takes it as a stop: the simulator stopped, the records
closed, the report saying so. Before, the run's next progress line raised ``BrokenPipeError``:
the mission "failed", and the last line's print printed a traceback."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from bt_servicesim.cli import EXIT_OUTPUT_CLOSED, interruptible
from tests.commands.test_run_reliability import WALL_LIMIT_S, alive, children, start_run

SIGPIPE_STATUS = 128 + signal.SIGPIPE


def test_the_exit_status_of_a_closed_output_is_sigpipes() -> None:
    assert EXIT_OUTPUT_CLOSED == SIGPIPE_STATUS


@pytest.mark.long
def test_a_run_whose_output_is_closed_stops_and_says_so(tmp_path: Path) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "report.json").write_text('{"status": "failed"}')  # an earlier run, overwritten
    (out / "traceback.txt").write_text("the earlier run's traceback\n")
    process = start_run(out, "--seed", "3", "--speed", "0", "--overwrite",
                        "--trajectory", "failed")
    assert process.stdout is not None
    simulators: list[int] = []
    try:
        for _ in range(2):  # as `| head -2` reads: the start line and a progress line
            assert process.stdout.readline()
            simulators = simulators or children(process.pid)
        process.stdout.close()
        stderr = process.stderr.read() if process.stderr is not None else ""
        process.wait(timeout=WALL_LIMIT_S)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == SIGPIPE_STATUS, stderr[-2000:]
    assert "Traceback" not in stderr
    assert simulators and not any(alive(pid) for pid in simulators)
    report = json.loads((out / "report.json").read_text())
    assert (report["status"], report["failure"]) == ("interrupted", "interrupted (SIGPIPE)")
    assert report["exit_code"] == SIGPIPE_STATUS
    assert not (out / "traceback.txt").exists(), "the earlier run's is not this run's"
    assert (out / "trajectory.png").is_file() and (out / "run.mcap").is_file()


def test_a_command_that_only_prints_ends_quietly_when_its_reader_goes(tmp_path: Path) -> None:
    script = ("import sys\n"
              "from bt_servicesim.cli import interruptible\n"
              "def main():\n"
              "    for number in range(100_000):\n"
              "        print('line', number)\n"
              "    return 0\n"
              "sys.exit(interruptible('printer', main))\n")
    command = f"{sys.executable} -c \"{script}\" | head -1"
    done = subprocess.run(["bash", "-c", f"{command}; echo ${{PIPESTATUS[0]}} >&2"],
                          capture_output=True, text=True, timeout=120, check=True,
                          cwd=Path(__file__).resolve().parents[2])
    assert done.stdout == "line 0\n"
    assert done.stderr == f"{SIGPIPE_STATUS}\n"  # no traceback, no message


def test_interruptible_passes_the_commands_own_status_through() -> None:
    assert interruptible("quiet", lambda: 3) == 3
