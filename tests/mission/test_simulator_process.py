"""Stopping the simulator's process: asked first, waited for later, signalled once."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from bt_servicesim.mission.simulator_process import SimulatorProcess

# A stand-in that counts its SIGINTs: it takes half a second to shut down after the first, as
# the simulator takes a moment, and says how many came before it exits.
COUNTING = """
import signal, sys, time
count = 0
def note(number, frame):
    global count
    count += 1
signal.signal(signal.SIGINT, note)
print("ready", flush=True)
while count == 0:
    time.sleep(0.01)
print("stopping", flush=True)
time.sleep(0.5)
print(f"SIGINTs: {count}", flush=True)
"""


def counting_process(tmp_path: Path) -> SimulatorProcess:
    process = SimulatorProcess(world=None, seed=None, speed=0.0, log_path=tmp_path / "sim.log")
    process.command = [sys.executable, "-c", COUNTING]
    process.start()
    wait_for_line(process, "ready")
    return process


def wait_for_line(process: SimulatorProcess, line: str) -> None:
    deadline = time.monotonic() + 30.0
    while line not in process.log_path.read_text().split() and time.monotonic() < deadline:
        time.sleep(0.01)


def test_a_process_asked_to_stop_shuts_down_meanwhile_and_is_signalled_once(
        tmp_path: Path) -> None:
    process = counting_process(tmp_path)
    process.ask_to_stop()
    wait_for_line(process, "stopping")
    assert process.exit_code() is None  # not waited for: the caller works on meanwhile
    process.stop()
    assert process.exit_code() == 0
    assert process.last_error() == "SIGINTs: 1"


def test_a_process_stopped_without_asking_is_signalled_and_waited_for(tmp_path: Path) -> None:
    process = counting_process(tmp_path)
    process.stop()
    assert process.exit_code() == 0
    assert process.last_error() == "SIGINTs: 1"
