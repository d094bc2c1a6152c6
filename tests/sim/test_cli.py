"""``python -m servicesim_sim``: bad arguments and broken world files are one line, exit 2."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SIM = [sys.executable, "-m", "servicesim_sim"]


def simulator(*arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*SIM, *arguments], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        (["--speed", "-2"], "--speed"),
        (["--speed", "fast"], "--speed"),
        (["--seed", "-1"], "--seed"),
        (["--difficulty", "brutal"], "--difficulty"),
        (["--rfid-dropout", "1.5"], "--rfid-dropout"),
        (["--nav-abort-probability", "-0.1"], "--nav-abort-probability"),
        (["--camera-rate", "100"], "--camera-rate"),
        (["--world", "no/such/world.yaml"], "no/such/world.yaml"),
        (["--teleport"], "--teleport"),
        (["--guest-path", "zigzag"], "--guest-path"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(arguments: list[str], named: str) -> None:
    result = simulator(*arguments)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and named in lines[0], result.stderr
    assert result.stdout == ""


def test_a_broken_world_file_is_named_in_one_line(tmp_path: Path) -> None:
    world = tmp_path / "world.yaml"
    world.write_text("name: broken\nmap: missing_map.yaml\n")
    result = simulator("--world", str(world))
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "world.yaml" in lines[0] and "missing_map.yaml" in lines[0]


@pytest.mark.parametrize("stops", [[signal.SIGHUP], [signal.SIGTERM] * 4, [signal.SIGINT]])
def test_stop_signals_end_the_simulator_cleanly_even_when_repeated(
        tmp_path: Path, stops: list[signal.Signals]) -> None:
    """A stop signal ends it with 128 + its number, as any command; the ones after it (a dying
    run sends one per thread) do not cut its shut-down short."""
    log = tmp_path / "sim.log"
    with log.open("wb") as stream:
        process = subprocess.Popen([sys.executable, "-m", "servicesim_sim", "--speed", "1"],
                                   stdout=stream, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 60
        while b"world " not in log.read_bytes():
            assert time.monotonic() < deadline and process.poll() is None, log.read_text()
            time.sleep(0.1)
        for stop in stops:
            process.send_signal(stop)
        assert process.wait(timeout=30) == 128 + stops[0], log.read_text()[-2000:]
        assert "Traceback" not in log.read_text()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


STOPPED_AT = {
    "loading the world": "servicesim_sim.settings.playable_engine",
    "joining ROS": "rclpy.init",
}
"""Moments of the start-up before the simulator's own stop handlers are in place, and what the
test makes send the signal there (as Ctrl-C would at that instant)."""


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=lambda stop: stop.name)
@pytest.mark.parametrize("moment", sorted(STOPPED_AT))
def test_a_stop_signal_while_starting_is_one_line_and_128_plus_the_signal(
        moment: str, stop: signal.Signals) -> None:
    module, _, name = STOPPED_AT[moment].rpartition(".")
    script = (
        "import importlib, os, sys\n"
        f"owner = importlib.import_module({module!r})\n"
        f"original = getattr(owner, {name!r})\n"
        "def stopping(*args, **kwargs):\n"
        f"    os.kill(os.getpid(), {int(stop)})\n"
        "    return original(*args, **kwargs)\n"
        f"setattr(owner, {name!r}, stopping)\n"
        "from servicesim_sim.__main__ import main\n"
        "sys.exit(main(['--speed', '0']))\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 128 + stop, result.stderr[-2000:]
    assert result.stderr.strip().splitlines() == [
        f"python -m servicesim_sim: stopped by {stop.name} while starting"]


def test_a_stop_that_pybind11_turned_into_a_type_error_ends_the_simulator_cleanly() -> None:
    """A stop signal that lands inside a pybind11 call returning a value (rclpy's
    process_cancel_request) comes out of it as ``TypeError: Unable to convert function return
    value to a Python type!``: it is the stop, not a crash."""
    script = (
        "import os, signal, sys\n"
        "from servicesim_sim.ros import node\n"
        "def run(self, executor):\n"
        "    try:\n"
        "        os.kill(os.getpid(), signal.SIGTERM)\n"
        "        while True:\n"
        "            pass\n"
        "    except KeyboardInterrupt:\n"
        "        raise TypeError('Unable to convert function return value to a Python type!')\n"
        "node.SimulatorNode.run = run\n"
        "from servicesim_sim.__main__ import main\n"
        "sys.exit(main(['--speed', '0']))\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 128 + signal.SIGTERM, result.stderr[-2000:]
    assert "Traceback" not in result.stderr and "TypeError" not in result.stderr


def test_guest_path_straight_reaches_the_guest_and_trail_is_the_default() -> None:
    from servicesim_sim.__main__ import build_parser
    from servicesim_sim.settings import difficulty_from

    parser = build_parser()
    assert difficulty_from(parser.parse_args([])).guest_path == "trail"
    straight = difficulty_from(parser.parse_args(["--guest-path", "straight",
                                                  "--difficulty", "hard"]))
    assert (straight.guest_path, straight.drift_scale) == ("straight", 0.25)


def test_a_stop_signal_the_simulator_was_started_with_ignored_stays_ignored(
        tmp_path: Path) -> None:
    """``nohup python -m servicesim_sim`` outlives its terminal: SIGHUP, ignored from the
    start, leaves it running; Ctrl-C still stops it."""
    def as_nohup_starts_it() -> None:
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        signal.signal(signal.SIGINT, signal.SIG_DFL)

    log = tmp_path / "sim.log"
    with log.open("wb") as stream:
        process = subprocess.Popen([*SIM, "--speed", "1"], stdout=stream,
                                   stderr=subprocess.STDOUT, preexec_fn=as_nohup_starts_it)
    try:
        deadline = time.monotonic() + 60
        while b"world " not in log.read_bytes():
            assert time.monotonic() < deadline and process.poll() is None, log.read_text()
            time.sleep(0.1)
        process.send_signal(signal.SIGHUP)
        time.sleep(1.0)
        assert process.poll() is None, log.read_text()[-2000:]
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=30) == 128 + signal.SIGINT, log.read_text()[-2000:]
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


@pytest.mark.parametrize("arguments", [
    ["--seed", "x"],  # refused by the parser
    ["--speed=-5"],  # refused by the settings
    ["--world", "WORLD"],  # a world file that is no world
])
def test_input_the_simulator_refuses_is_refused_before_it_loads_scipy(
        arguments: list[str], tmp_path: Path) -> None:
    """What only playing needs (scipy among it) is not loaded to refuse a command line."""
    world = tmp_path / "world.yaml"
    world.write_text("name: no map\n")
    program = ("import sys\nfrom servicesim_sim.__main__ import main\n"
               "try:\n    code = main(sys.argv[1:])\nexcept SystemExit as stop:\n"
               "    code = stop.code\n"
               "print(code, sorted(n for n in sys.modules if n.split('.')[0] == 'scipy'))")
    given = [str(world) if argument == "WORLD" else argument for argument in arguments]
    result = subprocess.run([sys.executable, "-c", program, *given], capture_output=True,
                            text=True, timeout=60, check=False)
    assert result.stdout.strip() == "2 []", result.stdout + result.stderr
