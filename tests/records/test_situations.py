"""What the person near was doing when points were booked: scripted scenes at 2 Hz."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from bt_servicesim.records.situations import (
    ROBOT_MOVING,
    ROBOT_STANDING,
    PeopleSample,
    situation_points,
)

Where = tuple[float, float]
HZ = 2.0


def scene(seconds: float, *, robot: Callable[[float], Where],
          people: dict[str, tuple[str, Callable[[float], Where]]]) -> list[PeopleSample]:
    """Samples at 2 Hz from 0 to ``seconds``: the robot's and each person's position by time."""
    samples = []
    for step in range(int(seconds * HZ) + 1):
        t = step / HZ
        samples.append(PeopleSample(sim_time_s=t, robot=robot(t), people={
            name: (role, *where(t)) for name, (role, where) in people.items()}))
    return samples


def walks_east_then_stops(at: float) -> Callable[[float], Where]:
    """A walker walking east at 1 m/s from x = 0, standing from ``at`` seconds on."""
    return lambda t: (min(t, at), 0.0)


def still(x: float, y: float) -> Callable[[float], Where]:
    return lambda _t: (x, y)


def points_at(t: float, cause: str, points: float = 10.0
              ) -> list[tuple[float, float, dict[str, float]]]:
    return [(t - 0.1, t, {cause: points})]


def test_a_walker_who_stopped_with_the_robot_in_its_lane_stands_for_the_robot() -> None:
    samples = scene(20.0, robot=still(6.0, 0.3), people={
        "human_1": ("walker", walks_east_then_stops(5.0))})
    result = situation_points(samples, points_at(12.0, "approximation/walker/human_1"))
    assert result == {"approximation/walker standing for the robot":
                      {ROBOT_MOVING: 0.0, ROBOT_STANDING: 10.0}}


@pytest.mark.parametrize(("role", "expected"), [
    ("guest", "walker standing for the guest"),
    ("idler", "walker standing for someone else"),
    ("walker", "walker standing for someone else"),
])
def test_a_walker_held_by_another_person_stands_for_them(role: str, expected: str) -> None:
    samples = scene(20.0, robot=still(3.0, 3.0), people={
        "human_1": ("walker", walks_east_then_stops(5.0)), "human_2": (role, still(6.2, -0.4))})
    result = situation_points(samples, points_at(12.0, "approximation/walker/human_1"))
    assert list(result) == [f"approximation/{expected}"]


def test_the_robot_in_the_lane_counts_before_the_guest_beside_it() -> None:
    samples = scene(20.0, robot=still(6.0, 0.3), people={
        "human_1": ("walker", walks_east_then_stops(5.0)), "guest": ("guest", still(6.3, -0.3))})
    result = situation_points(samples, points_at(12.0, "approximation/walker/human_1"))
    assert list(result) == ["approximation/walker standing for the robot"]


@pytest.mark.parametrize("robot", [
    (4.0, 0.3),  # behind the walker
    (6.0, 1.0),  # ahead, but beyond the lane's half width (0.6 m)
    (6.8, 0.0),  # on its line, beyond the lane's 1.5 m
])
def test_a_walker_standing_with_the_robot_outside_its_lane_is_not_held_by_it(
        robot: Where) -> None:
    samples = scene(20.0, robot=still(*robot), people={
        "human_1": ("walker", walks_east_then_stops(5.0))})
    result = situation_points(samples, points_at(12.0, "approximation/walker/human_1"))
    assert list(result) == ["approximation/walker standing"]


def test_a_walker_on_its_way_is_walking_and_the_robot_driving_past_is_moving() -> None:
    samples = scene(20.0, robot=lambda t: (10.0 - 0.5 * t, 0.8), people={
        "human_1": ("walker", walks_east_then_stops(30.0))})
    result = situation_points(samples, points_at(8.0, "approximation/walker/human_1", 4.0))
    assert result == {"approximation/walker walking": {ROBOT_MOVING: 4.0, ROBOT_STANDING: 0.0}}


def test_idlers_the_guest_and_contact_keep_their_role_and_walls_have_no_situation() -> None:
    samples = scene(10.0, robot=still(0.0, 0.0), people={
        "human_3": ("idler", still(0.5, 0.0)), "human_4": ("guest", still(-1.0, 0.0))})
    booked = [(4.9, 5.0, {"approximation/idler/human_3": 2.0, "contact/idler/human_3": 1.0,
                          "approximation/guest/human_4": 3.0, "approximation/walls": 5.0,
                          "approximation/unattributed": 7.0})]
    result = situation_points(samples, booked)
    assert result == {"approximation/guest": {ROBOT_MOVING: 0.0, ROBOT_STANDING: 3.0},
                      "approximation/idler": {ROBOT_MOVING: 0.0, ROBOT_STANDING: 2.0},
                      "contact/idler": {ROBOT_MOVING: 0.0, ROBOT_STANDING: 1.0}}


def test_points_add_up_by_situation_and_nothing_is_booked_without_samples() -> None:
    samples = scene(20.0, robot=still(6.0, 0.3), people={
        "human_1": ("walker", walks_east_then_stops(5.0))})
    booked = (points_at(2.0, "approximation/walker/human_1", 1.0)
              + points_at(12.0, "approximation/walker/human_1", 2.0)
              + points_at(14.0, "approximation/walker/human_1", 3.0))
    result = situation_points(samples, booked)
    assert result == {
        "approximation/walker standing for the robot": {ROBOT_MOVING: 0.0, ROBOT_STANDING: 5.0},
        "approximation/walker walking": {ROBOT_MOVING: 0.0, ROBOT_STANDING: 1.0}}
    assert situation_points([], booked) == {}
