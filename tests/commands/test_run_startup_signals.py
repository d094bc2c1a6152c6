"""A stop signal at the moments of a run's start-up when neither the command's handlers nor the
run's own used to be in place: while the command makes the run (and hands it the simulator the
head start began), and between the command and the run's handlers. Each still ends the run in
one line with 128 + the signal, and leaves no simulator running.

The moments are hit exactly, by a run whose hand-over or whose start sends the signal to its
own process (as Ctrl-C would at that instant): found at random by Ctrl-C a second or two after
the start, which printed a traceback and left no report."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.commands.test_run_reliability import WALL_LIMIT_S, alive, report_of, start_run, wait_for

STOPPING_RUN = """
import os, sys
from pathlib import Path
from bt_servicesim.mission.head_start import HeadStart
from bt_servicesim.mission.run import MissionRun
from bt_servicesim.run import main

moment, number, pid_file = sys.argv[1], int(sys.argv[2]), Path(sys.argv[3])
hand_over, execute = HeadStart.hand_over, MissionRun.execute

def handing_over(self):
    pid_file.write_text(str(self.simulator.pid))
    if moment == "making the run":
        os.kill(os.getpid(), number)
    return hand_over(self)

def executing(self, **kwargs):
    if moment == "starting the run":
        os.kill(os.getpid(), number)
    return execute(self, **kwargs)

HeadStart.hand_over, MissionRun.execute = handing_over, executing
sys.exit(main(sys.argv[4:]))
"""


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=lambda stop: stop.name)
@pytest.mark.parametrize("moment", ["making the run", "starting the run"])
def test_a_stop_signal_during_the_start_up_ends_the_run_in_one_line(
        tmp_path: Path, moment: str, stop: signal.Signals) -> None:
    out, pid_file = tmp_path / "run", tmp_path / "simulator.pid"
    command = [sys.executable, "-c", STOPPING_RUN, moment, str(int(stop)), str(pid_file),
               "--headless"]
    process = start_run(out, "--speed", "0", command=command)
    try:
        _, stderr = process.communicate(timeout=WALL_LIMIT_S)
    except subprocess.TimeoutExpired:
        process.kill()
        raise
    assert process.returncode == 128 + stop, stderr[-2000:]
    assert "Traceback" not in stderr
    simulator = int(pid_file.read_text())
    wait_for(lambda: not alive(simulator), "the simulator to end", 10.0)
    if moment == "making the run":  # taken back whole, as any refusal while starting
        assert stderr.strip().splitlines()[-1] == (
            f"python -m bt_servicesim.run: stopped by {stop.name} while starting")
        assert not out.exists()
    else:  # the run's own way: its report says so
        report = report_of(out)
        assert report["status"] == "interrupted"
        assert report["failure"] == f"stopped by {stop.name} while starting"
