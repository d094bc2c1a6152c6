"""The simulator's rules on the default world, engine only (no ROS): checkpoints, penalties,
the guest following, getting lost and drifting, RFID silence, determinism per seed."""

from __future__ import annotations

import dataclasses
import math
from functools import cache

import pytest

from servicesim_sim.engine import TF_ERROR, SimEngine
from servicesim_sim.scenario import Difficulty, make_scenario
from servicesim_sim.world import DEFAULT_WORLD, World, load_world


@cache
def office() -> World:
    return load_world(DEFAULT_WORLD)


def engine(*, seed: int | None = None, difficulty: Difficulty | None = None) -> SimEngine:
    world = office()
    return SimEngine(world=world, scenario=make_scenario(world, seed=seed, difficulty=difficulty))


def place_robot(sim: SimEngine, x: float, y: float) -> None:
    sim.robot.x, sim.robot.y = x, y
    sim.step()


def at_pick_up_beside_guest(sim: SimEngine) -> None:
    """Robot inside the pick-up area (checkpoint 1) and 1.5 m from the guest."""
    box = sim.world.areas[sim.scenario.task.pick_up]
    place_robot(sim, *box.centre)
    assert sim.referee.checkpoint_done[0]
    guest = sim.guest
    for angle in range(0, 360, 15):
        x = guest.x + 1.5 * math.cos(math.radians(angle))
        y = guest.y + 1.5 * math.sin(math.radians(angle))
        if box.contains(x, y) and sim.robot.walls.at(x, y) > 0.3:
            place_robot(sim, x, y)
            return
    place_robot(sim, *box.centre)


def test_the_default_scenario_is_the_shipped_task() -> None:
    scenario = engine().scenario
    assert (scenario.task.pick_up, scenario.task.drop_off, scenario.task.guest_name) == (
        "FrontElevator", "PrivateCubicle_32_1", "human_20843")
    assert (scenario.task.start_x, scenario.task.start_y) == (10.975, 3.75)


def test_new_task_twice_is_refused_and_time_starts_with_the_first() -> None:
    sim = engine()
    for _ in range(50):
        sim.step()
    assert sim.score() == 0.0 and not sim.task_running()
    assert sim.new_task()[0]
    assert not sim.new_task()[0]
    for _ in range(50):
        sim.step()
    assert sim.score() == pytest.approx(50 * sim.dt)


@pytest.mark.parametrize(
    ("guest", "robot", "reason"),
    [("human_20843", "otherbot", "unknown robot"), ("human_11111", "servicebot", "not the guest")],
)
def test_a_pickup_with_a_wrong_name_fails_with_a_penalty(guest: str, robot: str,
                                                         reason: str) -> None:
    sim = engine()
    sim.new_task()
    at_pick_up_beside_guest(sim)
    success, why = sim.pickup(guest, robot)
    assert not success and reason in why
    assert sim.referee.penalties.failed_pickup == 1


def test_a_pickup_before_checkpoint_1_or_from_too_far_fails() -> None:
    sim = engine()
    sim.new_task()
    success, why = sim.pickup("human_20843", "servicebot")  # robot still at the start
    assert not success and "checkpoint 1" in why
    box = sim.world.areas["FrontElevator"]
    place_robot(sim, box.max_x - 0.2, box.min_y + 0.3)  # in the area, but guest > 2 m away?
    sim.guest.x, sim.guest.y = box.min_x - 1.5, box.max_y  # move the guest out of reach
    success, why = sim.pickup("human_20843", "servicebot")
    assert not success and "more than 2.0 m" in why
    assert sim.referee.penalties.failed_pickup == 2
    assert sim.score() >= 80.0


def test_pickup_then_dropoff_inside_the_area_then_return_completes() -> None:
    sim = engine()
    sim.new_task()
    at_pick_up_beside_guest(sim)
    assert sim.pickup("human_20843", "servicebot")[0]
    assert sim.guest_state() == "following"
    drop = sim.world.areas["PrivateCubicle_32_1"]
    success, why = sim.dropoff("human_20843")  # the guest is far from the drop-off area
    assert not success and "outside" in why
    assert sim.referee.penalties.failed_dropoff == 1
    sim.guest.x, sim.guest.y = drop.centre  # as if guided there
    place_robot(sim, drop.centre[0] + 1.2, drop.centre[1])
    assert sim.dropoff("human_20843")[0]
    start = sim.world.areas[sim.scenario.task.start_area]
    place_robot(sim, *start.centre)
    report = sim.referee_report()
    assert report["completed"] and all(c["done"] for c in report["checkpoints"])
    assert not sim.task_running()


def test_a_robot_more_than_4_m_ahead_loses_the_guest_too_fast() -> None:
    sim = engine()
    sim.new_task()
    at_pick_up_beside_guest(sim)
    sim.pickup("human_20843", "servicebot")
    place_robot(sim, sim.guest.x + 4.5, sim.guest.y)
    assert sim.guest_state() == "lost"
    assert sim.referee.penalties.too_fast == 1
    assert sim.referee.current == 1  # back to checkpoint 2: pick up again
    assert sim.pickup("human_20843", "servicebot")[0] is False  # 4.5 m away: too far
    place_robot(sim, sim.guest.x + 1.5, sim.guest.y)
    assert sim.pickup("human_20843", "servicebot")[0]


def test_scheduled_and_forced_drifts_stop_the_guest_where_they_are() -> None:
    sim = engine(difficulty=Difficulty(drift_scale=0.01))  # first drift 2 s into the task
    assert not sim.force_drift()[0]  # nobody is following yet
    sim.new_task()
    at_pick_up_beside_guest(sim)
    sim.pickup("human_20843", "servicebot")
    for _ in range(int(3.0 / sim.dt)):
        sim.step()
    assert sim.guest_state() == "drifted" and sim.referee.penalties.drifts == 1
    spot = (sim.guest.x, sim.guest.y)
    place_robot(sim, sim.robot.x + 0.3, sim.robot.y)
    assert (sim.guest.x, sim.guest.y) == spot
    place_robot(sim, sim.guest.x + 1.5, sim.guest.y)
    assert sim.pickup("human_20843", "servicebot")[0]
    assert sim.force_drift()[0] and sim.guest_state() == "drifted"


def test_rfid_is_silent_with_nobody_near_and_names_the_guest_near() -> None:
    sim = engine()
    sim.robot.x, sim.robot.y = sim.guest.x + 1.5, sim.guest.y
    assert sim.scenario.task.guest_name in (sim.rfid_names() or [])
    far = [(x, y) for x in range(-25, 20) for y in range(1, 22)
           if sim.robot.walls.at(x, y) > 0.5
           and all(math.hypot(px - x, py - y) > 2.5 for _, _, px, py in sim.people_states())]
    sim.robot.x, sim.robot.y = far[0]
    assert sim.rfid_names() is None


def test_rfid_dropout_loses_readings() -> None:
    sim = engine(difficulty=Difficulty(rfid_dropout=0.5))
    sim.robot.x, sim.robot.y = sim.guest.x + 1.0, sim.guest.y
    readings = [sim.rfid_names() for _ in range(400)]
    lost = sum(reading is None for reading in readings)
    assert 120 < lost < 280


def test_navigation_before_an_initial_pose_fails_with_tf_error() -> None:
    sim = engine()
    ticket = sim.navigate(0.0, 1.5, 0.0)
    state = sim.navigation_state(ticket)
    assert (state.status, state.error_code) == ("aborted", TF_ERROR)
    assert "initialpose" in state.error_msg


def test_touching_a_person_costs_the_contact_penalty() -> None:
    sim = engine()
    sim.new_task()
    sim.robot.x, sim.robot.y = sim.guest.x + 0.4, sim.guest.y
    sim.step()
    assert sim.referee.penalties.contact > 0.0
    assert sim.referee.penalties.approximation > 0.0


def test_the_same_seed_gives_the_same_task_and_people() -> None:
    first, second, other = engine(seed=7), engine(seed=7), engine(seed=8)
    assert dataclasses.asdict(first.scenario) == dataclasses.asdict(second.scenario)
    assert dataclasses.asdict(first.scenario) != dataclasses.asdict(other.scenario)
    for _ in range(100):
        first.step()
        second.step()
    assert first.people_states() == second.people_states()


def test_an_out_of_range_guest_stands_beyond_rfid_range_of_the_area_centre() -> None:
    for seed in range(5):
        sim = engine(seed=seed, difficulty=Difficulty(guest_out_of_range=True))
        x, y = sim.world.areas[sim.scenario.task.pick_up].centre
        assert math.hypot(sim.guest.x - x, sim.guest.y - y) > 2.0
        assert sim.world.map.is_free(sim.guest.x, sim.guest.y)


def test_random_tasks_use_three_different_areas_and_free_spots() -> None:
    for seed in range(10):
        scenario = engine(seed=seed).scenario
        task = scenario.task
        assert len({task.pick_up, task.drop_off, task.start_area}) == 3
        assert office().areas[task.start_area].contains(task.start_x, task.start_y)
        assert office().map.is_free(task.guest_x, task.guest_y)


def test_the_robot_never_starts_within_the_guests_personal_space() -> None:
    # seed 37 draws a start area next to the pick-up area: its centre stood 0.55 m from the
    # guest, and the robot booked contact before it moved
    for seed in range(100):
        task = make_scenario(office(), seed=seed).task
        gap = math.dist((task.start_x, task.start_y), (task.guest_x, task.guest_y))
        # 0.9 m, not 1.5: seed 37's start area overlaps the pick-up area, and the start must
        # also keep inside its area (see the next test); contact needs 0.5 m
        assert gap >= 0.9, f"seed {seed}: the robot starts {gap:.2f} m from the guest"


def test_the_start_pose_lies_far_enough_inside_its_area_for_a_return_within_goal_tolerance(
) -> None:
    # seed 37's start, pushed away from the guest, stood 6.5 cm inside its area's edge: the
    # robot came back to within the 0.3 m goal tolerance, outside the area, and never got
    # checkpoint 4
    world = office()
    for seed in range(100):
        task = make_scenario(world, seed=seed).task
        area = world.areas[task.start_area]
        assert area.contains(task.start_x, task.start_y, margin=0.3), (
            f"seed {seed}: start ({task.start_x}, {task.start_y}) is within 0.3 m of the edge "
            f"of {task.start_area}")
