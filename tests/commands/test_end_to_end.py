"""Whole missions: ``python -m bt_servicesim.run`` with the simulator in its own process, real
DDS between them, the mission tree on sim time, judged by the referee's own report."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from tests.fakes.commands import run_module
from tests.mission_script import matches

if TYPE_CHECKING:
    from tests.commands.conftest import FinishedRun

SHIPPED_TASK_GROUP = "shipped_task_run"
GUEST_OUT_OF_RANGE_GROUP = "guest_out_of_range_run"

#: Flat out: a run joins the simulator's lockstep, so the executive never falls behind sim time
#: and the speed changes nothing but the wall time.
RUN = ["--headless", "--speed", "0"]
WALL_LIMIT_S = 300
#: The shipped tree's navigation parameters: its robot's berth around people, with which the
#: situations below arise (docs/reference/navigation.md).
TREE_NAV_PARAMS = str(Path(__file__).resolve().parents[2] / "trees" / "servicesim_nav2_params.yaml")
EVERY_SECOND_TREE = "navigate_to_pose_w_replanning_and_recovery.xml"
WHEN_INVALID_TREE = "navigate_w_replanning_only_if_path_becomes_invalid.xml"


def planning_again_only_when_blocked(directory: Path) -> str:
    """The shipped tree's navigation parameters with Nav2's navigation tree that plans the path
    again only once people stand on it, instead of every second: the robot with which a seed's
    situation below was found. The situation is the mission tree's to handle whichever way its
    navigation plans; the seed that plays it depends on both."""
    text = Path(TREE_NAV_PARAMS).read_text(encoding="utf-8")
    assert EVERY_SECOND_TREE in text
    params = directory / "nav_params_when_blocked.yaml"
    params.write_text(text.replace(EVERY_SECOND_TREE, WHEN_INVALID_TREE), encoding="utf-8")
    return str(params)


def mission(out: Path, *arguments: str) -> tuple[int, dict[str, Any]]:
    """The run's exit status and report. Its standard error is kept beside its directory
    (``<out>.stderr``) and, when the status is not the one the report gives, shown in the
    test's captured output: a run that failed after its report says why."""
    result = run_module("bt_servicesim.run", *RUN, "--out", str(out), *arguments,
                        timeout=WALL_LIMIT_S)
    out.with_name(f"{out.name}.stderr").write_text(result.stderr, encoding="utf-8")
    report_file = out / "report.json"
    assert report_file.is_file(), result.stderr[-2000:]
    report = json.loads(report_file.read_text())
    if result.returncode != report.get("exit_code"):
        print(f"the run exited with status {result.returncode}, its report says "
              f"{report.get('exit_code')}; its standard error ends:\n{result.stderr[-4000:]}",
              file=sys.stderr)
    return result.returncode, report


def tree_log_statuses(out: Path, key: str) -> list[str]:
    """Every status the tree log recorded for the behaviours ``key`` names (its last part the
    behaviour's own name, the others its ancestors', as in the scripted tree tests)."""
    statuses = []
    for line in (out / "tree_log.jsonl").read_text().splitlines():
        row = json.loads(line)
        if row.get("kind") != "tick":
            continue
        for name, (status, _) in row["nodes"].items():
            if matches(name, key):
                statuses.append(status)
    return statuses


def tree_log_feedback(out: Path, key: str) -> list[str]:
    """Every feedback message the tree log recorded for the behaviours ``key`` names."""
    messages = []
    for line in (out / "tree_log.jsonl").read_text().splitlines():
        row = json.loads(line)
        if row.get("kind") == "tick":
            messages += [feedback for name, (_, feedback) in row["nodes"].items()
                         if matches(name, key)]
    return messages


def assert_completed(code: int, report: dict[str, Any]) -> None:
    assert code == 0, report.get("failure")
    assert report["completed"] is True
    assert [c["done"] for c in report["checkpoints"]] == [True] * 4
    assert report["penalties"]["contact"] == 0.0


@pytest.mark.xdist_group(SHIPPED_TASK_GROUP)
def test_the_default_shipped_task_completes(shipped_task_run: FinishedRun) -> None:
    tmp_path, code, report = shipped_task_run.out, shipped_task_run.code, shipped_task_run.report
    assert_completed(code, report)
    assert (report["seed"], report["world"], report["executive"]) == (None, "default", "bt")
    assert report["penalties"]["failed_pickup"] == 0
    assert report["penalties"]["failed_dropoff"] == 0
    assert 0.0 < report["sim_time_s"] < 900.0
    assert (tmp_path / "trajectory.png").is_file(), "every run draws its picture by default"
    # logged after each period's lockstep done, each tick still under its own number
    ticks = [json.loads(line) for line in (tmp_path / "tree_log.jsonl").read_text().splitlines()]
    numbers = [row["tick"] for row in ticks if row["kind"] == "tick"]
    assert numbers[0] == 1 and numbers[-1] == report["ticks"] and numbers == sorted(set(numbers))
    assert [row for row in ticks if row["kind"] == "tick"][-1]["root"] == "SUCCESS"


@pytest.mark.long
@pytest.mark.xdist_group(GUEST_OUT_OF_RANGE_GROUP)
def test_a_completed_mission_leaves_its_picture_to_be_drawn_later_when_asked_to(
        guest_out_of_range_run: FinishedRun, tmp_path: Path) -> None:
    # what an evaluation asks (--trajectory failed): the picture only of a mission that did not
    # complete
    code, report = guest_out_of_range_run.code, guest_out_of_range_run.report
    assert_completed(code, report)
    assert not (guest_out_of_range_run.out / "trajectory.png").exists()
    out = shutil.copytree(guest_out_of_range_run.out, tmp_path / "run")  # drawn in a copy
    drawn = run_module("bt_servicesim.trajectory", str(out), timeout=WALL_LIMIT_S)
    assert drawn.returncode == 0, drawn.stderr[-2000:]
    assert (out / "trajectory.png").stat().st_size > 0


@pytest.mark.long
@pytest.mark.xdist_group(GUEST_OUT_OF_RANGE_GROUP)
def test_a_guest_beyond_rfid_range_of_the_area_is_explored_for_and_guided(
        guest_out_of_range_run: FinishedRun) -> None:
    out, code, report = (guest_out_of_range_run.out, guest_out_of_range_run.code,
                         guest_out_of_range_run.report)
    assert_completed(code, report)
    assert "SUCCESS" in tree_log_statuses(out, "PlanExploration")
    assert report["seed"] == 3


@pytest.mark.long
def test_a_guest_who_drifts_while_guided_is_reacquired(tmp_path: Path) -> None:
    # drift times are world times, the shipped world file's (487, 654, ... s): at scale 0.15
    # the first is due at 72.6 s, while the shipped task guides the guest from about 30 s to 95 s
    code, report = mission(tmp_path, "--sim-arg=--drift-scale=0.15", "--trajectory", "never")
    assert_completed(code, report)
    assert report["penalties"]["drifts"] >= 1
    # a pick-up that succeeds ends the recovery in the same tick (the RecoveryNode halts it and
    # guides again at once), so the log shows the call's answer, not a SUCCESS status
    picked_up_again = any("answered true" in feedback for feedback in tree_log_feedback(
        tmp_path, "PickUpGuestAgain.CallPickUpGuest"))
    assert picked_up_again or "SUCCESS" in tree_log_statuses(tmp_path, "GuestCaughtUp")


@pytest.mark.long
def test_a_hard_mission_whose_guest_the_camera_finds_replays_in_lockstep(
        tmp_path: Path) -> None:
    """Hard seed 9: the guest drifts twice while led, stops a few metres back in sight, and
    the camera finds them each time (a blue shirt over red trousers), at 99 and 140 sim s. The
    look subscribes to the camera in a tick; its frames come from the period the lockstep
    client names, three of 0.9 MB a period, and nothing of lockstep's guarantee is lost under
    them: played twice to 150 sim s (the whole mission completes at 230 s), the tree logs are
    the same, tick for tick. The robot plans again only when blocked."""
    params = planning_again_only_when_blocked(tmp_path)
    logs = []
    for run in ("a", "b"):
        out = tmp_path / run
        code, report = mission(out, "--seed", "9", "--sim-arg=--difficulty", "--sim-arg=hard",
                               "--nav-params", params, "--trajectory", "never",
                               "--time-limit", "150")
        assert code == 1 and report["checkpoints"][1]["done"], report.get("failure")
        assert (report["lockstep_dropped"], report["lockstep_stalls"]) == (None, 0)
        seen = sorted({message for message in tree_log_feedback(
            out, "LookForLostGuest.LookForGuest") if message.startswith("guest seen at")})
        assert len(seen) >= 2, seen
        logs.append((out / "tree_log.jsonl").read_text())
    assert logs[0] == logs[1]


@pytest.mark.long
def test_a_walker_standoff_is_broken_by_giving_way_where_the_costmap_shows_nobody_near(
        tmp_path: Path) -> None:
    """Random seed 10: leading its guest west along the office's 1.65 m top corridor, the robot
    meets a walker coming east, who waits for it as long as it stays in the walker's lane; the
    guest behind closes the way back. The robot steps into the room beside them, the walker,
    bound for that room, stops in its door for the guest, and the robot gives way again, to
    where the costmap shows nobody near. Before giving way learnt where people stand, nothing
    moved again before the 900 s limit. In lockstep the speed changes nothing: flat out. The
    walkers walk our random loops (the office's own are the original's one-way loops). The robot
    keeps the shipped tree's berth around people, planning again only when blocked."""
    params = planning_again_only_when_blocked(tmp_path)
    code, report = mission(tmp_path / "run", "--seed", "10", "--speed", "0", "--time-limit",
                           "600", "--sim-arg=--walker-routes", "--sim-arg=random",
                           "--nav-params", params, "--trajectory", "never")
    assert_completed(code, report)
    spots = [message for message in tree_log_feedback(tmp_path / "run", "FindGiveWaySpot")
             if message.startswith("give way at")]
    assert len(set(spots)) >= 2, spots  # in the corridor, and again in the room


@pytest.mark.long
def test_a_random_abort_beside_someone_keeps_the_costmaps_and_touches_nobody(
        tmp_path: Path) -> None:
    """Hard seed 14: exploring for the guest at 201 s, navigation aborts at random (error 9000,
    no obstacle) with someone within 1.5 m of the robot, and again a moment later. Cleared, the
    costmaps would forget whoever stands out of the lidar's 240 degrees, and the local
    planner's escape (backing off while no turn keeps the box off the walls) could drive into
    them. The recovery keeps the costmaps after an abort no obstacle caused, steps aside (the
    costmap shows someone near), and the mission completes touching nobody. The robot plans
    again only when blocked."""
    params = planning_again_only_when_blocked(tmp_path)
    out = tmp_path / "run"
    code, report = mission(out, "--seed", "14", "--sim-arg=--difficulty", "--sim-arg=hard",
                           "--nav-params", params, "--trajectory", "never")
    assert_completed(code, report)
    kept = [message for message in tree_log_feedback(out, "WaypointRecovery.WayBlocked")
            if message.startswith("navigation error 9000")]
    assert kept, "the seed still plays a random abort while exploring"
    assert "SUCCESS" not in tree_log_statuses(
        out, "ClearCostmapsForWaypointIfBlocked.ClearCostmaps")


@pytest.mark.long
def test_a_hopeless_mission_ends_at_the_time_limit_with_exit_1(tmp_path: Path) -> None:
    # paced: what the run waits for in wall time after the end shows as sim time
    code, report = mission(tmp_path, "--time-limit", "20", "--trajectory", "failed",
                           "--speed", "10")
    assert code == 1
    assert (tmp_path / "trajectory.png").is_file(), "a mission that failed is drawn"
    assert report["completed"] is False
    assert report["failure"]
    # the report is the referee's books when the mission ended, not after the run's shut-down
    # (at speed 10 the 3 wall seconds the run once waited for the referee were 30 sim s)
    assert report["sim_time_s"] <= 20.0 + 2.0
