"""``python -m bt_servicesim.run`` under stress: signals, crashes, neighbours, bad input.

Every way a run can end leaves a readable record and no simulator behind; a run only ever talks
to the simulator it started; bad input is one line on stderr and exit 2. Each case starts real
processes (the run, its simulator), so each is a few seconds of wall time.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from tests.fakes.commands import run_module
from tests.raising_leaf import MESSAGE

REPO = Path(__file__).resolve().parents[2]
#: No picture: these tests judge the run's process and report, and the drawing is a CPU second.
RUN_ARGUMENTS = ["--headless", "--trajectory", "never"]
RUN = [sys.executable, "-m", "bt_servicesim.run", *RUN_ARGUMENTS]
WALL_LIMIT_S = 300.0


def start_run(out: Path, *arguments: str, command: list[str] | None = None,
              env: dict[str, str] | None = None) -> subprocess.Popen[str]:
    return subprocess.Popen([*(command or RUN), "--out", str(out), *arguments], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env)


def wait_for(condition: Callable[[], bool], what: str, timeout_s: float = 120.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.1)


def children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(child) for child in text.split()]


def alive(pid: int) -> bool:
    """Running (a zombie waiting to be reaped has ended)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return False
    return fields[0] != "Z"


def report_of(out: Path) -> dict[str, Any]:
    return json.loads((out / "report.json").read_text())


def mission_started(out: Path) -> Callable[[], bool]:
    """The tree has ticked: the run is past start-up, with its simulator up."""
    log = out / "tree_log.jsonl"
    return lambda: log.is_file() and '"kind": "tick"' in log.read_text()


@pytest.fixture
def running(tmp_path: Path) -> Iterator[tuple[subprocess.Popen[str], int, Path]]:
    """A run at speed 2 (a long mission), its tree ticking; the simulator's pid."""
    out = tmp_path / "run"
    process = start_run(out, "--speed", "2")
    try:
        wait_for(mission_started(out), "the mission to start")
        (simulator,) = children(process.pid)
        yield process, simulator, out
    finally:
        if process.poll() is None:
            process.kill()
        process.communicate()


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_stop_signal_ends_the_run_with_its_report_and_no_simulator_left(
        running: tuple[subprocess.Popen[str], int, Path], stop: signal.Signals) -> None:
    process, simulator, out = running
    process.send_signal(stop)
    process.wait(timeout=60)
    assert process.returncode == 128 + stop
    report = report_of(out)
    assert report["status"] == "interrupted"
    assert report["failure"] == f"interrupted ({stop.name})"
    wait_for(lambda: not alive(simulator), "the simulator to end", 10.0)
    with (out / "run.mcap").open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics.message_count > 0


@pytest.mark.long
def test_a_run_started_as_nohup_starts_it_outlives_its_terminal(tmp_path: Path) -> None:
    """SIGHUP ignored at the start (``nohup``) stays ignored: the terminal closing does not
    stop the run, Ctrl-C still does."""
    out = tmp_path / "run"
    process = subprocess.Popen(
        [*RUN, "--out", str(out), "--speed", "2"], cwd=REPO, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    try:
        wait_for(mission_started(out), "the mission to start")
        (simulator,) = children(process.pid)
        ticks = (out / "tree_log.jsonl").read_text().count('"kind": "tick"')
        process.send_signal(signal.SIGHUP)
        wait_for(lambda: process.poll() is not None or (
            out / "tree_log.jsonl").read_text().count('"kind": "tick"') > ticks,
            "the tree to tick on after SIGHUP")
        assert process.poll() is None and alive(simulator), process.returncode
        process.send_signal(signal.SIGINT)
        process.wait(timeout=60)
        assert process.returncode == 130
        assert report_of(out)["failure"] == "interrupted (SIGINT)"
        wait_for(lambda: not alive(simulator), "the simulator to end", 10.0)
    finally:
        if process.poll() is None:
            process.kill()
        process.communicate()


def test_a_killed_run_takes_its_simulator_with_it_and_leaves_a_record(
        running: tuple[subprocess.Popen[str], int, Path]) -> None:
    process, simulator, out = running
    process.kill()
    process.wait(timeout=10)
    wait_for(lambda: not alive(simulator), "the simulator to end", 10.0)
    report = report_of(out)
    assert report["status"] == "running" and report["run_id"]


def test_a_killed_simulator_fails_the_run_and_says_so(
        running: tuple[subprocess.Popen[str], int, Path]) -> None:
    process, simulator, out = running
    os.kill(simulator, signal.SIGKILL)
    process.wait(timeout=60)
    assert process.returncode == 1
    report = report_of(out)
    assert report["status"] == "failed"
    assert report["failure"] == "the simulator was killed by SIGKILL"


@pytest.mark.long
def test_an_exception_in_a_tick_fails_the_mission_with_its_reason(tmp_path: Path) -> None:
    tree = tmp_path / "raising.xml"
    tree.write_text('<root BTCPP_format="4" main_tree_to_execute="Main">'
                    '<BehaviorTree ID="Main"><RaiseOnTick name="Buggy"/></BehaviorTree></root>')
    command = [sys.executable, "-c", "import sys, tests.raising_leaf\n"
               "from bt_servicesim.run import main\nsys.exit(main(sys.argv[1:]))", "--headless"]
    process = start_run(tmp_path / "run", "--speed", "20", "--tree", str(tree), command=command)
    _, stderr = process.communicate(timeout=WALL_LIMIT_S)
    assert process.returncode == 1, stderr[-2000:]
    report = report_of(tmp_path / "run")
    assert report["status"] == "failed"
    assert report["failure"] == f"the mission tree raised RuntimeError in Buggy: {MESSAGE}"
    assert "raise RuntimeError(MESSAGE)" in (tmp_path / "run" / report["traceback"]).read_text()


@pytest.mark.long
def test_a_run_whose_shutdown_hangs_ends_at_its_limit_with_the_missions_status(
        tmp_path: Path) -> None:
    """A deadlock after the report (here an exit handler that never returns, where rclpy or
    Fast DDS would hang) cannot hold the run's caller: the process ends at its limit, its report
    complete, its simulator gone, the stacks in its output for a bug report. The limit is
    generous: on a machine a CPU hog shares, the run's own work after its report (closing its
    records, stopping its simulator) can take more than a second, and a limit that fell before
    the hang would show that work's stacks instead."""
    command = [sys.executable, "-c", "import atexit, sys, threading\n"
               "atexit.register(threading.Event().wait)\n"
               "from bt_servicesim.run import main\n"
               "sys.exit(main(sys.argv[1:], shutdown_limit_s=10.0))", *RUN_ARGUMENTS]
    process = start_run(tmp_path / "run", "--speed", "0", "--seed", "3",
                        "--time-limit", SHORT_MISSION_S, command=command)
    _, stderr = process.communicate(timeout=WALL_LIMIT_S)
    assert process.returncode == 1, stderr[-2000:]
    assert "did not end within 10 s of its report: ending the process with exit status 1" \
        in stderr
    assert re.search(r'threading\.py", line \d+ in wait\n', stderr), "the stack of the hang"
    assert_played_to_its_time_limit(report_of(tmp_path / "run"))


@pytest.mark.long
def test_two_runs_in_one_shell_each_talk_only_to_their_own_simulator(tmp_path: Path) -> None:
    shell = os.environ["ROS_DOMAIN_ID"]
    runs = [start_run(tmp_path / name, "--speed", "0", "--seed", seed,  # lockstep: flat out
                      "--time-limit", SHORT_MISSION_S)
            for name, seed in (("first", "3"), ("second", "5"))]
    for name, process in zip(("first", "second"), runs, strict=True):
        _, stderr = process.communicate(timeout=WALL_LIMIT_S)
        assert process.returncode == 1, stderr[-2000:]
        assert_played_to_its_time_limit(report_of(tmp_path / name))
    domains = {report_of(tmp_path / name)["ros_domain_id"] for name in ("first", "second")}
    assert len(domains) == 2 and int(shell) not in domains


#: A mission time limit for tests about something else than the mission's end (sim seconds).
SHORT_MISSION_S = "20"


def assert_played_to_its_time_limit(report: dict[str, Any]) -> None:
    """The run played its mission, with its simulator, until the short time limit ended it."""
    assert report["status"] == "failed", report.get("failure")
    assert "MissionTimeLimit: timed out" in report["last_activity"], report["last_activity"]
    assert float(SHORT_MISSION_S) - 1.0 <= report["sim_time_s"] <= float(SHORT_MISSION_S) + 2.0


@pytest.fixture
def standalone_simulator(tmp_path: Path) -> Iterator[subprocess.Popen[bytes]]:
    """A simulator started alone, on the shell's (this test process's) domain."""
    with (tmp_path / "standalone.log").open("wb") as log:
        process = subprocess.Popen([sys.executable, "-m", "servicesim_sim", "--speed", "10"],
                                   stdout=log, stderr=subprocess.STDOUT)
    try:
        yield process
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


@pytest.mark.long
def test_a_run_beside_a_standalone_simulator_uses_its_own(
        tmp_path: Path, standalone_simulator: subprocess.Popen[bytes]) -> None:
    result = run_module("bt_servicesim.run", *RUN_ARGUMENTS, "--speed", "10", "--time-limit",
                        SHORT_MISSION_S, "--out", str(tmp_path / "run"), timeout=WALL_LIMIT_S)
    assert result.returncode == 1, result.stderr[-2000:]
    assert_played_to_its_time_limit(report_of(tmp_path / "run"))
    assert report_of(tmp_path / "run")["ros_domain_id"] != int(os.environ["ROS_DOMAIN_ID"])
    assert standalone_simulator.poll() is None


@pytest.mark.long
def test_attach_runs_against_the_backend_already_on_the_shells_domain(
        tmp_path: Path, standalone_simulator: subprocess.Popen[bytes]) -> None:
    result = run_module("bt_servicesim.run", *RUN_ARGUMENTS, "--attach", "--out",
                        str(tmp_path / "run"), timeout=WALL_LIMIT_S)
    assert result.returncode == 0, result.stderr[-2000:]
    report = report_of(tmp_path / "run")
    assert report["completed"] and report["attached"]
    assert report["timing"] == "lockstep" and "lockstep with the simulator" in result.stdout
    assert report["ros_domain_id"] == int(os.environ["ROS_DOMAIN_ID"])
    assert not (tmp_path / "run" / "sim.log").exists()


@pytest.mark.long
def test_attach_on_the_system_clock_runs_without_sim_time(
        tmp_path: Path, standalone_simulator: subprocess.Popen[bytes]) -> None:
    """As on a real robot, which publishes no /clock: the tree ticks on the system clock, and
    its own time limit (8 s of it here) ends the mission."""
    result = run_module("bt_servicesim.run", *RUN_ARGUMENTS, "--attach", "--clock", "system",
                        "--time-limit", "8", "--out", str(tmp_path / "run"), timeout=WALL_LIMIT_S)
    report = report_of(tmp_path / "run")
    assert result.returncode == 1, result.stderr[-2000:]
    assert "free running: the run keeps the system clock" in result.stdout
    assert (report["clock"], report["timing"]) == ("system", "free running")
    assert report["ticks"] >= 40  # 10 a second for 8 s, allowing for a busy machine
    assert "MissionTimeLimit: timed out" in report["last_activity"]
    assert "--clock system" in report["reproduce"]


def bad_trees(directory: Path) -> dict[str, Path]:
    trees = {
        "retry": '<Retry name="R" num_failures="abc"><Fallback name="f"/></Retry>',
        "port": '<GuestInRange name="G" guest_name="{g}"/>',
    }
    paths = {}
    for name, body in trees.items():
        paths[name] = directory / f"{name}.xml"
        paths[name].write_text(f'<root BTCPP_format="4" main_tree_to_execute="M">'
                               f'<BehaviorTree ID="M">{body}</BehaviorTree></root>')
    return paths


BAD_INPUT = [
    ("bt_servicesim.run", ["--time-limit", "inf"], "--time-limit inf: must be"),
    ("bt_servicesim.run", ["--time-limit", "1e308"], "--time-limit 1e+308: must be"),
    ("bt_servicesim.run", ["--time-limit", "nan"], "--time-limit nan: must be"),
    ("bt_servicesim.run", ["--speed", "inf"], "--speed inf: must be"),
    ("bt_servicesim.run", ["--speed", "-1"], "--speed -1.0: must be"),
    ("bt_servicesim.run", ["--out", ""], "--out: an empty path"),
    ("bt_servicesim.run", ["--sim-arg=--speed=0.001"], "--sim-arg --speed=0.001: the run sets"),
    ("bt_servicesim.run", ["--attach", "--seed", "3"], "--attach starts no simulator: --seed"),
    ("bt_servicesim.run", ["--clock", "system"], "--clock system: only with --attach"),
    ("bt_servicesim.run", ["--tree", "{retry}"], 'num_failures="abc" is not an int'),
    ("bt_servicesim.run", ["--executive", "baseline", "--tree", "{retry}"],
     "only the bt executive plays a tree"),
    ("bt_servicesim.run", ["--tree", "{port}"], "the required input port actors_in_range"),
    ("bt_servicesim.dump", ["--tree", "{retry}"], 'num_failures="abc" is not an int'),
    ("bt_servicesim.dump", ["--format", "svg", "--out", "{tmp}/x.png"], "a .png name for"),
]


@pytest.mark.parametrize(("module", "arguments", "expected"), BAD_INPUT)
def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, module: str, arguments: list[str],
                                          expected: str) -> None:
    values = {name: str(path) for name, path in bad_trees(tmp_path).items()}
    values["tmp"] = str(tmp_path)
    argv = [argument.format(**values) for argument in arguments]
    result = run_module(module, *argv, timeout=60)
    assert result.returncode == 2, result.stderr
    assert expected in result.stderr
    assert result.stderr.count("\n") == 1, result.stderr


def test_replay_refuses_a_time_that_is_not_finite(tmp_path: Path) -> None:
    (tmp_path / "tree_log.jsonl").write_text("")
    for value in ("nan", "inf"):
        result = run_module("bt_servicesim.replay", str(tmp_path), "--time", value, timeout=60)
        assert result.returncode == 2
        assert f"--time {value}: must be a finite number" in result.stderr


def test_an_earlier_runs_directory_is_kept_unless_overwrite(tmp_path: Path) -> None:
    (tmp_path / "report.json").write_text('{"status": "completed"}')
    result = run_module("bt_servicesim.run", "--out", str(tmp_path), timeout=60)
    assert result.returncode == 2
    assert "holds an earlier run" in result.stderr and result.stderr.count("\n") == 1
    assert json.loads((tmp_path / "report.json").read_text()) == {"status": "completed"}
