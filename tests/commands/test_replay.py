"""Seeing the tree over time: ``python -m bt_servicesim.replay`` and the live view of a run.

The run is the errand tree of ``tests.fakes.recorded_run.RecordedRun``; what replay prints is
compared with the live tree drawn at the same tick. The live view draws to a stream that says it
is a terminal.
"""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from py_trees.common import Status

from bt_servicesim import replay
from bt_servicesim.mission.live_view import HOME, LiveTreeView
from bt_servicesim.mission.progress import ProgressView
from bt_servicesim.tree.shape import plain, walk
from tests.fakes.recorded_run import RecordedRun


def replay_output(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = replay.main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def tree_part(output: str) -> str:
    heading, _, tree = output.partition("\n")
    assert heading.startswith("tick ")
    return tree


def test_replay_at_a_tick_prints_the_tree_as_it_was_then(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = RecordedRun(tmp_path)
    for tick in (1, 4, 5, len(run.text)):
        code, out, _ = replay_output(capsys, str(tmp_path), "--tick", str(tick))
        assert code == 0
        assert tree_part(out) == run.text[tick], f"tick {tick}"
        assert out.startswith(f"tick {tick}  ")


def test_replay_by_default_shows_the_end_of_the_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = RecordedRun(tmp_path)
    code, out, _ = replay_output(capsys, str(tmp_path / "tree_log.jsonl"))
    assert code == 0
    assert tree_part(out) == run.text[max(run.text)]
    assert "root SUCCESS" in out.splitlines()[0]


def test_replay_at_a_sim_time_picks_the_last_change_before_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = RecordedRun(tmp_path)  # tick N ran at 100.0 + 0.1 (N - 1) s
    code, out, _ = replay_output(capsys, str(tmp_path), "--time", "100.45")
    assert code == 0
    assert out.startswith("tick 5  sim time 100.4 s")
    assert tree_part(out) == run.text[5]
    assert "Detour [*] -- step 2 of 3" in out


def test_stepping_walks_forwards_and_back_through_the_changes(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    run = RecordedRun(tmp_path)
    monkeypatch.setattr("sys.stdin", io.StringIO("\n\nb\nq\n"))
    code, out, _ = replay_output(capsys, str(tmp_path), "--tick", "2", "--step")
    assert code == 0
    headings = [line.split("  ")[0] for line in out.splitlines() if line.startswith("tick ")]
    assert headings == ["tick 2", "tick 3", "tick 4", "tick 3"]
    assert run.text[4] in out


def test_stepping_ends_at_the_end_of_input(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    run = RecordedRun(tmp_path)
    monkeypatch.setattr("sys.stdin", io.StringIO("\n" * 100))
    code, out, _ = replay_output(capsys, str(tmp_path), "--tick", "1", "--step")
    assert code == 0
    assert out.count("tick ") == run.log.records
    assert "[end of run]" in out


def test_running_only_collapses_branches_that_are_not_running(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    RecordedRun(tmp_path)
    code, out, _ = replay_output(capsys, str(tmp_path), "--tick", "5", "--running-only")
    assert code == 0
    assert "Detour [*]" in out
    assert "Check" not in out  # under a decorator that has not run yet: collapsed
    assert "..." in out


@pytest.mark.parametrize(("argv", "problem"), [
    (["--tick", "0"], "nothing logged at tick 0"),
    (["--time", "1.0"], "nothing logged at sim time 1 s"),
    (["--tick", "-3"], "--tick -3: must be 0 or more"),
    (["--time", "99999"], "nothing logged at sim time 99999 s: the run's last record is tick"),
    (["--tick", "99999"], "nothing logged at tick 99999: the run's last record is tick"),
])
def test_a_moment_outside_the_run_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str],
        problem: str) -> None:
    RecordedRun(tmp_path)
    code, out, err = replay_output(capsys, str(tmp_path), *argv)
    assert code == 2 and out == ""
    assert problem in err and err.count("\n") == 1


def test_a_directory_without_a_log_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = replay_output(capsys, str(tmp_path))
    assert code == 2
    assert "no tree_log.jsonl" in err and err.count("\n") == 1


class Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


def test_the_live_view_redraws_when_the_tree_changes_and_only_then(tmp_path: Path) -> None:
    run = RecordedRun(tmp_path)  # finished; its tree is drawn as it ended
    terminal = Terminal()
    view = LiveTreeView(root=run.tree.root, stream=terminal, redraw_period_s=0.0)
    assert view.draw(status_line="status A")
    assert not view.draw(status_line="status A")  # nothing changed
    assert view.draw(status_line="status B")
    run.tree.root.children[-1].feedback_message = "lingering on"
    assert view.draw(status_line="status B")
    assert view.redraws == 3
    frames = terminal.getvalue().split(HOME)[1:]
    assert "Errand" in plain(frames[0]) and "status A" in frames[0]
    assert "lingering on" in plain(frames[2])


def test_the_live_view_waits_its_redraw_period(tmp_path: Path) -> None:
    run = RecordedRun(tmp_path)
    view = LiveTreeView(root=run.tree.root, stream=Terminal(), redraw_period_s=3600.0)
    assert view.draw(status_line="first")
    assert not view.draw(status_line="second")  # changed, but not due for an hour
    view.close(status_line="final")  # the last frame is always drawn
    assert view.redraws == 2


def test_the_live_view_fits_the_terminal(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    run = RecordedRun(tmp_path)
    for behaviour in walk(run.tree.root):
        behaviour.status = Status.RUNNING  # everything expanded
        behaviour.feedback_message = "a long feedback message " * 4
    monkeypatch.setattr("shutil.get_terminal_size", lambda: os.terminal_size((40, 6)))
    lines = LiveTreeView(root=run.tree.root, stream=Terminal()).screen("status")
    assert len(lines) == 5 and lines[-1] == "status"
    assert lines[-2].startswith("... (") and "more lines" in lines[-2]
    assert all(len(plain(line)) <= 40 for line in lines)


def test_progress_shows_the_live_tree_on_a_terminal_but_not_headless(tmp_path: Path) -> None:
    run = RecordedRun(tmp_path)
    assert ProgressView(headless=False, stream=Terminal(), tree_root=run.tree.root).tree_view
    assert ProgressView(headless=True, stream=Terminal(), tree_root=run.tree.root).tree_view \
        is None
    assert ProgressView(headless=False, stream=io.StringIO(), tree_root=run.tree.root) \
        .tree_view is None  # a pipe gets plain lines


def test_ctrl_c_while_stepping_is_one_line_and_exit_130(tmp_path: Path) -> None:
    """The stepper waits for a key; Ctrl-C there quits as a command interrupted, not with a
    traceback."""
    RecordedRun(tmp_path)
    process = subprocess.Popen(
        [sys.executable, "-m", "bt_servicesim.replay", str(tmp_path), "--step"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None
        while "quit" not in process.stdout.readline():  # the first screen's prompt: waiting
            assert process.poll() is None
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 130
    assert stderr == "python -m bt_servicesim.replay: stopped by SIGINT\n"


@pytest.mark.parametrize(("fields", "shown"), [
    ({"timing": "lockstep", "lockstep_stalls": 0, "lockstep_dropped": None}, "python -m x"),
    ({"timing": "free running"}, "python -m x (ran free: may differ)"),
    ({"timing": "lockstep", "lockstep_stalls": 3},
     "python -m x (3 lockstep period(s) went on without every message: may differ)"),
    ({"timing": "lockstep", "lockstep_stalls": 0,
      "lockstep_dropped": {"period": 8, "sim_time_s": 0.8}},
     "python -m x (the simulator dropped the run from lockstep at 0.8 s sim, and it ran free "
     "from there: may differ)"),
], ids=["lockstep throughout", "free running", "stalled", "dropped"])
def test_the_command_that_plays_a_mission_again_says_when_it_may_differ(
        tmp_path: Path, fields: dict[str, object], shown: str) -> None:
    (tmp_path / "report.json").write_text(json.dumps({"reproduce": "python -m x", **fields}))
    assert replay.reproduce_command(tmp_path) == shown
