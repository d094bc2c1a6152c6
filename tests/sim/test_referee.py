"""The referee's books and the guest's walk, without ROS: weights, penalties, following."""

from __future__ import annotations

import math

import pytest

from servicesim_sim.model import referee as rules
from servicesim_sim.model.guest import STOP_DISTANCE, Guest, GuestState
from servicesim_sim.model.referee import Referee


def started() -> Referee:
    referee = Referee()
    referee.start()
    return referee


def test_checkpoint_times_are_weighted_1_2_2_1() -> None:
    referee = started()
    for checkpoint, seconds in enumerate((10.0, 20.0, 30.0, 40.0)):
        referee.advance(seconds)
        referee.reach(checkpoint)
    assert referee.completed and not referee.running
    assert referee.score() == pytest.approx(10 * 1 + 20 * 2 + 30 * 2 + 40 * 1)
    referee.advance(100.0)  # the clock stops with the task
    assert referee.score() == pytest.approx(150.0)


def test_time_before_new_task_does_not_count() -> None:
    referee = Referee()
    referee.advance(50.0)
    assert referee.score() == 0.0
    referee.start()
    referee.advance(1.0)
    assert referee.score() == pytest.approx(1.0)


def test_failed_calls_and_too_fast_carry_their_penalties() -> None:
    referee = started()
    referee.failed_pickup()
    referee.failed_pickup()
    referee.failed_dropoff()
    referee.reach(rules.GO_TO_PICK_UP)
    referee.reach(rules.PICK_UP_GUEST)
    referee.guest_stopped_following(too_fast=True)
    assert referee.score() == pytest.approx(2 * 40 + 50 + 25)
    report = referee.report()["penalties"]
    assert (report["failed_pickup"], report["failed_dropoff"], report["too_fast"]) == (2, 1, 1)


def test_a_drift_sends_checkpoint_3_back_to_2_without_penalty() -> None:
    referee = started()
    referee.reach(rules.GO_TO_PICK_UP)
    referee.reach(rules.PICK_UP_GUEST)
    assert referee.current == rules.DROP_OFF_GUEST
    referee.guest_stopped_following(too_fast=False)
    assert referee.current == rules.PICK_UP_GUEST
    assert not referee.checkpoint_done[rules.PICK_UP_GUEST]
    assert referee.penalties.drifts == 1 and referee.score() == 0.0
    referee.advance(2.0)  # time after the drift counts against checkpoint 2 again
    assert referee.checkpoint_times[rules.PICK_UP_GUEST] == pytest.approx(2.0)


def test_contact_penalties_scale_with_the_original_500_hz_report_rate() -> None:
    referee = started()
    referee.contact(person_depth=0.01, object_depth=0.0, dt=0.02)  # 10 reports of 1 cm
    assert referee.penalties.contact == pytest.approx(10 * 40000 * 0.01)
    referee.approximation(person_depth=0.1, object_depth=0.2, dt=0.1)  # 50 reports
    assert referee.penalties.approximation == pytest.approx(50 * (1 * 0.1 + 0.25 * 0.2))


def test_the_report_has_the_run_report_shape() -> None:
    report = started().report()
    assert [c["name"] for c in report["checkpoints"]] == list(rules.CHECKPOINT_NAMES)
    assert set(report["penalties"]) == {"failed_pickup", "failed_dropoff", "too_fast", "drifts",
                                        "contact", "approximation"}


def walk(guest: Guest, path: list[tuple[float, float]], *, dt: float = 0.02,
         speed: float = 0.5) -> None:
    """Move a robot along ``path`` at ``speed`` while the guest follows."""
    x, y = path[0]
    for target_x, target_y in path[1:]:
        while math.hypot(target_x - x, target_y - y) > 1e-6:
            step = min(speed * dt, math.hypot(target_x - x, target_y - y))
            heading = math.atan2(target_y - y, target_x - x)
            x, y = x + step * math.cos(heading), y + step * math.sin(heading)
            guest.record_robot(x, y)
            guest.step(dt, robot_x=x, robot_y=y)
    for _ in range(500):  # the robot waits; the guest catches up
        guest.step(dt, robot_x=x, robot_y=y)


def test_the_guest_follows_the_trail_round_a_corner_and_stops_1_2_m_short() -> None:
    guest = Guest(name="human_00001", x=0.0, y=0.0, yaw=0.0)
    guest.start_following(1.0, 0.0)
    path = [(1.0, 0.0), (5.0, 0.0), (5.0, 5.0)]
    visited: list[tuple[float, float]] = []
    original_step = guest.step

    def recording_step(dt: float, *, robot_x: float, robot_y: float) -> None:
        original_step(dt, robot_x=robot_x, robot_y=robot_y)
        visited.append((guest.x, guest.y))

    guest.step = recording_step  # type: ignore[method-assign]
    walk(guest, path)
    assert math.hypot(guest.x - 5.0, guest.y - 5.0) == pytest.approx(STOP_DISTANCE, abs=0.06)
    # it turned the corner on the trail rather than cutting across the (imagined) wall
    assert all(y < 0.06 or x > 4.94 for x, y in visited)


def test_the_straight_guest_cuts_the_corner_through_walls_as_the_original_did() -> None:
    guest = Guest(name="human_00001", x=0.0, y=0.0, yaw=0.0, path="straight",
                  wall_clearance=lambda x, y: 0.0)  # walls everywhere: they do not matter
    guest.start_following(1.0, 0.0)
    visited: list[tuple[float, float]] = []
    original_step = guest.step

    def recording_step(dt: float, *, robot_x: float, robot_y: float) -> None:
        original_step(dt, robot_x=robot_x, robot_y=robot_y)
        visited.append((guest.x, guest.y))

    guest.step = recording_step  # type: ignore[method-assign]
    walk(guest, [(1.0, 0.0), (5.0, 0.0), (5.0, 5.0)])
    assert math.hypot(guest.x - 5.0, guest.y - 5.0) == pytest.approx(STOP_DISTANCE, abs=0.02)
    assert any(y > 0.2 and x < 4.8 for x, y in visited)  # across the corner, off the trail


def test_the_straight_guest_does_not_step_aside() -> None:
    guest = Guest(name="human_00001", x=0.0, y=0.0, yaw=0.0, path="straight")
    guest.start_following(0.5, 0.0)
    guest.step(0.1, robot_x=0.5, robot_y=0.0)
    assert (guest.x, guest.y) == (0.0, 0.0)


def test_an_unknown_guest_path_is_one_clear_line() -> None:
    with pytest.raises(ValueError, match="guest path 'zigzag': must be one of trail, straight"):
        Guest(name="human_00001", x=0.0, y=0.0, yaw=0.0, path="zigzag")


def test_a_guest_the_robot_drives_past_rejoins_its_trail_ahead_not_where_it_stood() -> None:
    """Picked up from the far side, the robot drives past the guest (who steps aside) and on:
    the guest joins the trail beside them instead of walking back to the pick-up spot."""
    guest = Guest(name="human_00001", x=0.0, y=0.0, yaw=0.0,
                  wall_clearance=lambda x, y: 5.0)
    guest.start_following(-1.2, 0.3)
    farthest_back, farthest_from_robot = 0.0, 0.0
    original_step = guest.step

    def recording_step(dt: float, *, robot_x: float, robot_y: float) -> None:
        nonlocal farthest_back, farthest_from_robot
        original_step(dt, robot_x=robot_x, robot_y=robot_y)
        farthest_back = min(farthest_back, guest.x)
        farthest_from_robot = max(farthest_from_robot, guest.distance_to(robot_x, robot_y))

    guest.step = recording_step  # type: ignore[method-assign]
    walk(guest, [(-1.2, 0.3), (4.0, 0.6), (4.0, -6.0)])
    assert farthest_back > -0.5  # never headed back to (-1.2, 0.3)
    assert farthest_from_robot < 3.0  # kept up, far from the 4 m "too fast" loss
    assert guest.distance_to(4.0, -6.0) == pytest.approx(STOP_DISTANCE, abs=0.06)


def wall_between_corridors(x: float, y: float) -> float:
    """Distance to a wall along y = 1 for x < 3 (corridors at y = 0 and y = 2 meet at x > 3)."""
    return abs(y - 1.0) if x < 3.0 else max(math.hypot(x - 3.0, y - 1.0), 0.0)


def test_a_rejoining_guest_goes_round_a_wall_not_through_it() -> None:
    """Right after a step aside in the lower corridor, the trail's later points in the upper
    corridor are the shortest way to the robot as the crow flies; the guest walks round."""
    guest = Guest(name="human_00001", x=0.5, y=0.0, yaw=0.0, wall_clearance=wall_between_corridors)
    guest.start_following(1.5, 0.0)
    trail = [(1.5 + 0.05 * k, 0.0) for k in range(1, 61)]  # east to (4.5, 0)
    trail += [(4.5, 0.05 * k) for k in range(1, 41)]  # north to (4.5, 2)
    trail += [(4.5 - 0.05 * k, 2.0) for k in range(1, 151)]  # west to (-3, 2)
    for x, y in trail:
        guest.record_robot(x, y)
    guest._off_trail = True  # as after a step aside
    robot = trail[-1]
    for _ in range(1000):
        guest.step(0.02, robot_x=robot[0], robot_y=robot[1])
        assert wall_between_corridors(guest.x, guest.y) >= 0.15
    assert guest.distance_to(*robot) == pytest.approx(STOP_DISTANCE, abs=0.06)


def test_the_guest_walks_no_faster_than_0_8_m_s() -> None:
    guest = Guest(name="human_00001", x=0.0, y=0.0, yaw=0.0)
    guest.start_following(1.5, 0.0)
    for index in range(1, 200):
        guest.record_robot(1.5 + index * 0.05, 0.0)
    before = guest.x
    guest.step(1.0, robot_x=11.5, robot_y=0.0)
    assert guest.x - before == pytest.approx(0.8, abs=1e-6)


def test_a_guest_not_following_does_not_move() -> None:
    guest = Guest(name="human_00001", x=2.0, y=3.0, yaw=0.0)
    guest.step(1.0, robot_x=10.0, robot_y=10.0)
    assert (guest.x, guest.y, guest.state) == (2.0, 3.0, GuestState.WAITING)
    guest.start_following(2.5, 3.0)
    guest.stop_following(GuestState.DRIFTED)
    guest.record_robot(9.0, 3.0)
    guest.step(1.0, robot_x=9.0, robot_y=3.0)
    assert (guest.x, guest.y) == (2.0, 3.0)


def test_a_guest_steps_out_of_the_way_of_a_robot_coming_too_close() -> None:
    guest = Guest(name="human_00001", x=0.0, y=0.0, yaw=0.0)
    guest.start_following(1.2, 0.0)
    guest.stop_following(GuestState.DROPPED_OFF)
    robot_x = 1.2
    for _ in range(100):  # the robot drives at the guest at 0.5 m/s for 2 s
        robot_x -= 0.01
        guest.step(0.02, robot_x=robot_x, robot_y=0.0)
        assert guest.distance_to(robot_x, 0.0) > 0.8
    assert guest.x < -0.5


def test_a_waiting_guest_stays_put_and_a_wall_turns_the_step_aside() -> None:
    waiting = Guest(name="human_00001", x=0.0, y=0.0, yaw=0.0)
    waiting.step(0.1, robot_x=0.5, robot_y=0.0)
    assert (waiting.x, waiting.y) == (0.0, 0.0)
    walled = Guest(name="human_00002", x=0.0, y=0.0, yaw=0.0,
                   wall_clearance=lambda x, y: 1.0 if x >= -0.001 else 0.0)  # a wall at x < 0
    walled.stop_following(GuestState.DRIFTED)
    walled.step(0.1, robot_x=0.5, robot_y=0.0)
    assert walled.x >= -0.001 and walled.y != 0.0
