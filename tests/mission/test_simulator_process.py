"""Stopping the simulator's process: asked first, waited for later, signalled once."""

from __future__ import annotations

import os
import signal
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


CHECKING = """
import os, sys, time
fd = int(sys.argv[sys.argv.index("--checked-fd") + 1])
if "--world" in sys.argv:
    print("python -m servicesim_sim: error: --world x.yaml: no such map", flush=True)
    sys.exit(2)
os.write(fd, b"checked\\n")
os.close(fd)
time.sleep(30)
"""


def checking_process(tmp_path: Path, *, refuses: bool) -> SimulatorProcess:
    process = SimulatorProcess(world=None, seed=None, speed=0.0, log_path=tmp_path / "sim.log")
    process.command = [sys.executable, "-c", CHECKING, *(["--world"] if refuses else [])]
    process.start(announce_checks=True)
    return process


def test_a_simulator_that_refuses_its_input_says_so_through_its_exit(tmp_path: Path) -> None:
    process = checking_process(tmp_path, refuses=True)
    refusal = process.input_refusal(timeout_s=30.0)
    assert process.exit_code() == 2
    assert refusal == ("the simulator exited with code 2: python -m servicesim_sim: error: "
                       "--world x.yaml: no such map")


def test_a_simulator_that_checked_its_input_is_waited_for_no_longer(tmp_path: Path) -> None:
    process = checking_process(tmp_path, refuses=False)
    try:
        assert process.input_refusal(timeout_s=30.0) is None
        assert process.exit_code() is None
    finally:
        process.stop()


def test_a_simulator_stopped_by_a_signal_it_caught_is_said_to_be(tmp_path: Path) -> None:
    process = SimulatorProcess(world=None, seed=None, speed=0.0, log_path=tmp_path / "sim.log")
    process.command = [sys.executable, "-c", "print('an unrelated line'); raise SystemExit(143)"]
    process.start()
    deadline = time.monotonic() + 30.0
    while process.exit_code() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert process.describe_exit() == "the simulator was stopped by SIGTERM (exit status 143)"


def test_the_navigation_parameters_reach_the_simulator_cold_and_on_every_warm_reset(
        tmp_path: Path) -> None:
    import json

    from bt_servicesim.mission.settings import RunSettings
    from bt_servicesim.tree.files import DEFAULT_TREE
    from bt_servicesim.warm_worker import WarmEpisode

    params = tmp_path / "mine.yaml"
    settings = RunSettings(world=None, seed=4, speed=0.0, tree=DEFAULT_TREE, out=tmp_path,
                           time_limit_s=900.0, headless=True, executive="baseline",
                           nav_params=params)
    cold = SimulatorProcess.for_run(settings, ("--difficulty", "hard")).command
    assert cold[cold.index("--nav-params") + 1] == str(params)
    assert cold[-2:] == ["--difficulty", "hard"]
    episode = WarmEpisode.from_line(json.dumps({
        "out": str(tmp_path), "run_id": "r", "executive": "baseline", "seed": 4, "speed": 0.0,
        "nav_params": str(params)}))
    reset = episode.reset_arguments()
    assert reset[reset.index("--nav-params") + 1] == str(params)
    without = WarmEpisode.from_line(json.dumps({
        "out": str(tmp_path), "run_id": "r", "executive": "baseline", "speed": 0.0}))
    assert "--nav-params" not in without.reset_arguments(), "the simulator's default"


def test_only_a_simulator_killed_by_a_signal_it_did_not_handle_counts_as_killed(
        tmp_path: Path) -> None:
    """Killed, it ended without deleting its DDS participant; stopped, or exiting with a code
    (a caught signal's 128 + N included), it did not."""
    (tmp_path / "stopped").mkdir()
    stopped = counting_process(tmp_path / "stopped")
    assert not stopped.killed()  # still running
    stopped.stop()
    assert stopped.exit_code() == 0 and not stopped.killed()
    killed = counting_process(tmp_path)
    assert killed.pid is not None
    os.kill(killed.pid, signal.SIGKILL)
    deadline = time.monotonic() + 30.0
    while killed.exit_code() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert killed.killed()
    assert killed.describe_exit() == "the simulator was killed by SIGKILL"
