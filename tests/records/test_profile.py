"""The mission profile: phases, node figures and points by cause, from a scripted mission's log.

Scripted missions (tests/records/scripted_runs.py) play the real tree file with stand-in leaves;
the test books the referee's points itself, near whom and when it says, and checks where the
profile puts them.
"""

from __future__ import annotations

from pathlib import Path

import py_trees

from bt_servicesim.records.profile import (
    Booking,
    Proximity,
    Segment,
    add_bounds,
    build_profile,
    increments,
    proxemics,
    spread,
)
from bt_servicesim.records.situations import PeopleSample
from bt_servicesim.records.tree_log import read_records
from tests.mission_script import Script, matches
from tests.records.scripted_runs import play

Status = py_trees.common.Status
GUIDE = "GoToDropOffArea.NavigateToGoal"
FOLLOWING = {"WatchGuestFollows": [(Status.FAILURE, 100_000)]}  # the guest follows throughout
GUIDE_KEY = ("ServiceSimMission.MissionTimeLimit.Mission.DropOffPhaseRetry.DropOff.DeliverGuest."
             "DropOffRetry.GuideAndDropOff.GuideRetry.GuideGuest.LeadGuestToDropOff."
             "GuideWhileGuestFollows.GoToDropOffGoal.DropOffGoalRetry.GoWhileDropOffGoalClear."
             "GoToDropOffArea.NavigateWithRecovery.NavigateRecovery."
             "StopStandoff.NavigateToGoal")


def walker_crosses_while_guiding(tip: py_trees.behaviour.Behaviour, _now: float
                                 ) -> dict[str, float]:
    """A walker, human_7, crosses the robot's way while it guides the guest: 2 points a tick."""
    if tip is not None and matches(tip.name, GUIDE):
        return {"approximation/walker/human_7": 2.0}
    if tip is not None and tip.status == Status.RUNNING:  # the mission still under way
        return {"approximation/walls": 0.5}
    return {}


def test_points_booked_near_a_walker_appear_under_its_role_phase_and_the_running_node(
        tmp_path: Path) -> None:
    script = Script({GUIDE: [(Status.SUCCESS, 20)], **FOLLOWING})  # 20 ticks RUNNING, arrived
    run = play(tmp_path, script, book=walker_crosses_while_guiding)
    profile = run.profile()
    walker_points = 2.0 * 20  # from each of the 20 ticks it ended RUNNING to the next
    assert profile["penalties"]["by_role"]["approximation/walker"] == walker_points
    drop_off = next(phase for phase in profile["phases"] if phase["phase"] == "DropOff")
    assert drop_off["penalties_by_role"]["approximation/walker"] == walker_points
    assert drop_off["penalties_by_cause"]["approximation/walker/human_7"] == walker_points
    others = [phase for phase in profile["phases"] if phase["phase"] != "DropOff"]
    assert all("approximation/walker" not in phase["penalties_by_role"] for phase in others)
    guide = profile["nodes"][GUIDE_KEY]
    assert guide["points_tip"] == walker_points
    assert guide["starts"] == 1 and guide["success"] == 1
    assert guide["running_s"] == 2.0 and guide["tip_s"] == 2.0
    mission = profile["nodes"]["ServiceSimMission.MissionTimeLimit.Mission"]
    total = sum(profile["penalties"]["by_cause"].values())
    assert abs(mission["points_under"] - total) < 1e-6


def test_retries_and_failures_are_counted_per_node(tmp_path: Path) -> None:
    script = Script({"GoToPickUpArea.NavigateToGoal": [(Status.FAILURE, 3), (Status.FAILURE, 3)],
                     "RobotInPickUpArea": [Status.FAILURE] * 100_000})
    profile = play(tmp_path, script).profile()
    navigate = next(figures for key, figures in profile["nodes"].items()
                    if matches(key, "GoToPickUpArea.NavigateToGoal"))
    assert navigate["starts"] == 3
    assert navigate["failure"] == 2 and navigate["success"] == 1
    clear = next(figures for key, figures in profile["nodes"].items()
                 if matches(key, "GoToPickUpArea.ClearCostmaps"))
    assert clear["success"] == 2
    recovery = next(figures for key, figures in profile["nodes"].items()
                    if matches(key, "GoToPickUpArea.NavigateRecovery"))
    assert recovery["type"] == "RecoveryNode" and recovery["fired"] == 2
    assert profile["last_failure"]["phase"] == "Pickup"


def test_the_same_script_writes_the_same_log_and_profile(tmp_path: Path) -> None:
    script = {GUIDE: [(Status.FAILURE, 5), (Status.SUCCESS, 8)], **FOLLOWING}
    first = play(tmp_path / "a", Script(script), book=walker_crosses_while_guiding)
    second = play(tmp_path / "b", Script(script), book=walker_crosses_while_guiding)
    assert first.log.read_bytes() == second.log.read_bytes()
    assert "__const" in first.log.read_text()  # the ports' constants are there, UUIDs are not
    assert first.profile() == second.profile()


def test_points_between_two_samples_are_shared_by_time() -> None:
    segments = [Segment(0.0, 1.0, "a", "P"), Segment(1.0, 4.0, "b", "Q")]
    bookings = [Booking(0.0, {}), Booking(2.0, {"contact/idler/x": 4.0})]
    shares = spread(increments(bookings), segments)
    assert [(segment.tip, change) for segment, change in shares if segment] == [
        ("a", {"contact/idler/x": 2.0}), ("b", {"contact/idler/x": 2.0})]


def test_proxemic_zones_keep_the_guest_apart_and_weigh_by_time() -> None:
    samples = [Proximity(0.0, 0.3, 5.0), Proximity(1.0, 1.0, 2.0), Proximity(4.0, None, 0.2)]
    zones = proxemics(samples, end_s=5.0, phase_at=lambda _t: "P")["P"]
    assert zones["guest"]["intimate"] == 0.25 and zones["guest"]["personal"] == 0.75
    assert zones["others"]["public"] == 0.2 and zones["others"]["social"] == 0.6
    assert zones["others"]["intimate"] == 0.2


def test_each_phase_gets_the_bound_of_the_checkpoints_it_booked() -> None:
    profile = {"phases": [
        {"phase": "Pickup", "sim_time_s": 30.0, "checkpoints": [
            {"name": "go_to_pick_up"}, {"name": "pick_up_guest"}]},
        {"phase": "ReturnToStart", "sim_time_s": 120.0,
         "checkpoints": [{"name": "return_to_start"}]},
        {"phase": "BeginTask", "sim_time_s": 1.0, "checkpoints": []}]}
    legs = [{"checkpoint": "go_to_pick_up", "bound_s": 15.0},
            {"checkpoint": "pick_up_guest", "bound_s": 0.0},
            {"checkpoint": "drop_off_guest", "bound_s": 25.0},
            {"checkpoint": "return_to_start", "bound_s": 60.0}]
    phases = {phase["phase"]: phase for phase in add_bounds(profile, legs)["phases"]}
    assert phases["Pickup"]["time_over_bound"] == 2.0 and phases["Pickup"]["bound_share"] == 0.15
    assert phases["ReturnToStart"]["time_over_bound"] == 2.0
    assert phases["BeginTask"]["bound_s"] is None


def test_points_near_a_walker_standing_in_the_robots_way_are_booked_to_that_situation(
        tmp_path: Path) -> None:
    """The walker human_7 walked east until the mission began and stands from then on, the
    robot 1 m ahead of it in its lane: every point booked near it is a walker standing for the
    robot."""
    script = Script({GUIDE: [(Status.SUCCESS, 20)], **FOLLOWING})
    run = play(tmp_path, script, book=walker_crosses_while_guiding)
    header, records = read_records(run.log)
    people = [PeopleSample(sim_time_s=step / 2.0, robot=(1.0, 0.0), people={
        "human_7": ("walker", min(step / 2.0, 0.0), 0.0)}) for step in range(-8, 400)]
    profile = build_profile(shape=header.shape, records=records, phases=header.phases,
                            bookings=run.bookings, people=people, counts=header.counts)
    assert profile["penalties"]["by_situation"] == {
        "approximation/walker standing for the robot": {"robot moving": 0.0,
                                                        "robot standing": 2.0 * 20}}
