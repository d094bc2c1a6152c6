"""A real evaluation, run and simulator included, stopped by SIGTERM half-way through an episode.

The fake episodes of ``test_evaluate.py`` check the evaluation's bookkeeping quickly; this one
checks that the real processes take the same way out, on a warm pair (the default) and cold: the
run stops its simulator and writes its own report, nothing of the evaluation is left running,
and nothing writes after it exited.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bt_servicesim.evaluation.episodes import descendants, start_time


@pytest.mark.long
@pytest.mark.parametrize("mode", ["warm", "cold"])
def test_sigterm_stops_a_real_evaluation_and_its_episode_cleanly(tmp_path: Path,
                                                                 mode: str) -> None:
    out = tmp_path / "evaluation"
    cold = ["--cold"] if mode == "cold" else []
    process = subprocess.Popen(
        [sys.executable, "-m", "bt_servicesim.evaluate", "--episodes", "2", "--scenarios",
         "random", "--executive", "bt", "--jobs", "1", "--speed", "5", "--out", str(out),
         *cold],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    episode = out / "bt" / "random" / "0"
    sim_log = episode / "sim.log" if cold else out / "warm-pairs" / "pair-1" / "sim.log"
    family = wait_for_the_simulator(process, sim_log, episode / "report.json", limit_s=90.0)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 143, stderr
    assert "Traceback" not in stderr
    left = {pid: name for pid, (name, started) in family.items() if start_time(pid) == started}
    assert not left, f"still running after the evaluation exited: {left}"
    report = json.loads((episode / "report.json").read_text())
    (row,) = json.loads((out / "summary.json").read_text())["bt"]["rows"]
    assert report["status"] == "interrupted" and report["run_id"] == row["run_id"]
    assert row["not_run"] and row["ros_domain_id"] == report["ros_domain_id"]
    assert isinstance(row["ros_domain_id"], int) and 1 <= row["ros_domain_id"] <= 101
    written = {path: path.stat().st_mtime_ns for path in out.rglob("*") if path.is_file()}
    time.sleep(3.0)
    assert written == {path: path.stat().st_mtime_ns for path in out.rglob("*")
                       if path.is_file()}, "nothing writes into --out after the exit"


def wait_for_the_simulator(process: subprocess.Popen[str], sim_log: Path, report: Path,
                           limit_s: float) -> dict[int, tuple[str, int | None]]:
    """Once the episode's simulator plays seed 0 (its log says so) and its run has begun its
    report: every process of the evaluation, by pid, with its command and start time."""
    deadline = time.monotonic() + limit_s
    while not (sim_log.is_file() and "seed 0," in sim_log.read_text(errors="replace")
               and report.is_file()):
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"the simulator did not come up: {process.communicate()}")
        time.sleep(0.1)
    family = {}
    for pid in (process.pid, *descendants(process.pid)):
        try:
            command = Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ")
        except OSError:
            continue
        family[pid] = (command[:80], start_time(pid))
    assert any("servicesim_sim" in command for command, _ in family.values()), family
    return family
