"""The simulator's rules on the default world, engine only (no ROS): checkpoints, penalties,
the guest following, getting lost and drifting, RFID silence, determinism per seed."""

from __future__ import annotations

import dataclasses
import itertools
import math
from functools import cache

import numpy as np
import pytest

from servicesim_sim.model.contacts import PERSON_APPROXIMATION_M, PERSON_BODY_RADIUS
from servicesim_sim.model.engine import TF_ERROR, SimEngine
from servicesim_sim.model.scenario import Difficulty, make_scenario
from servicesim_sim.world.files import DEFAULT_WORLD, World, load_world
from servicesim_sim.world.footprint import Footprint
from servicesim_sim.world.office import SHIPPED_DRIFT_TIMES


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
    near_people = sim.referee.penalties.approximation  # the shipped start has walkers passing
    assert sim.score() == near_people and not sim.task_running()
    assert sim.new_task()[0]
    assert not sim.new_task()[0]
    for _ in range(50):
        sim.step()
    near_people = sim.referee.penalties.approximation
    assert sim.score() - near_people == pytest.approx(50 * sim.dt)


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
    # drift_scale 0.01: the first drift 3-5 world s after the world starts
    sim = engine(difficulty=Difficulty(drift_scale=0.01))
    sim.new_task()
    at_pick_up_beside_guest(sim)
    sim.pickup("human_20843", "servicebot")
    for _ in range(int(5.0 / sim.dt)):
        sim.step()
    assert sim.guest_state() == "drifted" and sim.referee.penalties.drifts == 1
    spot = (sim.guest.x, sim.guest.y)
    place_robot(sim, sim.robot.x + 0.3, sim.robot.y)
    assert (sim.guest.x, sim.guest.y) == spot
    place_robot(sim, sim.guest.x + 1.5, sim.guest.y)
    assert sim.pickup("human_20843", "servicebot")[0]
    assert sim.force_drift()[0]
    sim.step()
    assert sim.guest_state() == "drifted"


def test_drift_times_are_world_times_after_the_start_time_not_200_s_after_new_task() -> None:
    for seed in range(8):
        times = engine(seed=seed).scenario.drift_times
        assert len(times) == 30
        assert 300.0 <= times[0] <= 500.0  # start_time 200 + U(100, 300), as the original drew
        gaps = [later - earlier for earlier, later in itertools.pairwise(times)]
        assert all(100.0 <= gap <= 300.0 for gap in gaps)
        assert all(time.is_integer() for time in times)  # Ruby's rand(100..300): whole seconds
        hard = engine(seed=seed, difficulty=Difficulty.hard()).scenario.drift_times
        assert 75.0 <= hard[0] <= 125.0  # hard scales the whole schedule by 0.25
        assert all(25.0 <= b - a <= 75.0 for a, b in itertools.pairwise(hard))
        assert all((4 * time).is_integer() for time in hard)


def test_the_shipped_task_plays_the_shipped_worlds_drift_times() -> None:
    # worlds/service.world 43207-43265
    times = engine().scenario.drift_times
    assert times[:4] == (487.0, 654.0, 889.0, 1038.0) and times[-1] == 6619.0
    assert times == tuple(float(time) for time in SHIPPED_DRIFT_TIMES)
    hard = engine(difficulty=Difficulty.hard()).scenario.drift_times
    assert hard == tuple(time * 0.25 for time in times)


def drift_at_6_s(*, task_at: float = 0.0) -> SimEngine:
    """The shipped task with drifts at 6 and 500 s, started at ``task_at``, the robot at the
    pick-up beside the guest."""
    sim = engine()
    sim.scenario = dataclasses.replace(sim.scenario, drift_times=(6.0, 500.0))
    sim.task_rules._drifts = list(sim.scenario.drift_times)
    while sim.sim_time < task_at:
        sim.step()
    sim.new_task()
    at_pick_up_beside_guest(sim)
    return sim


def step_until(sim: SimEngine, sim_time: float) -> None:
    while sim.sim_time < sim_time - 1e-9:
        sim.step()


def test_a_drift_fires_at_its_world_time_however_late_the_task_started() -> None:
    sim = drift_at_6_s(task_at=3.0)
    assert sim.pickup("human_20843", "servicebot")[0]
    step_until(sim, 5.45)
    assert sim.guest_state() == "following"
    step_until(sim, 5.55)  # 3 s after new_task, not 6, and from 0.5 s early as the original's
    assert sim.guest_state() == "drifted"  # (FollowActorPlugin.cc 294-307)
    assert sim.referee.current == 1


def test_a_drift_is_due_for_the_whole_second_round_its_time_and_then_only() -> None:
    # FollowActorPlugin.cc 294-307: a following guest drifts at any update within 0.5 s of a
    # drift time, either side, and the times are kept: picked up inside that second, again
    def picked_up_at(pick_up_at: float, *, until: float) -> str:
        sim = drift_at_6_s()
        step_until(sim, pick_up_at)
        assert sim.pickup("human_20843", "servicebot")[0]
        step_until(sim, until)
        return sim.guest_state()

    assert picked_up_at(5.8, until=5.9) == "drifted"  # within the second, before the time
    assert picked_up_at(6.3, until=6.4) == "drifted"  # and after it
    assert picked_up_at(6.6, until=8.0) == "following"  # its second is over
    sim = drift_at_6_s()
    assert sim.pickup("human_20843", "servicebot")[0]
    step_until(sim, 5.6)
    assert sim.guest_state() == "drifted"
    sim.guest.x, sim.guest.y = sim.robot.x + 1.0, sim.robot.y  # back within reach at once
    assert sim.pickup("human_20843", "servicebot")[0]
    sim.step()
    assert sim.guest_state() == "drifted"  # picked up again inside the second: drifts again
    step_until(sim, 6.6)
    sim.guest.x, sim.guest.y = sim.robot.x + 1.0, sim.robot.y
    assert sim.pickup("human_20843", "servicebot")[0]
    step_until(sim, 8.0)
    assert sim.guest_state() == "following"


@pytest.mark.parametrize("seed", [3, 13, 33])
def test_random_walker_routes_keep_off_the_tasks_area_centres_start_and_guest_spot(
        seed: int) -> None:
    # their route cells are 2.25 m from each area's centre and 1.75 m from the two spots;
    # the legs between cells may cut a corner by a little, and an area's edge may be near
    sim = engine(seed=seed, difficulty=Difficulty(walker_routes="random"))
    task, areas = sim.scenario.task, sim.world.areas
    kept = [(*areas[name].centre, 2.0) for name in (task.pick_up, task.drop_off, task.start_area)]
    kept += [(task.start_x, task.start_y, 1.5), (task.guest_x, task.guest_y, 1.5)]
    walkers = [person for person in sim.crowd.people if person.role == "walker"]
    assert walkers
    for _ in range(1500):  # 30 sim s
        sim.step()
        for walker in walkers:
            assert all(math.hypot(walker.x - x, walker.y - y) >= radius
                       for x, y, radius in kept), (walker.x, walker.y)


def test_a_pickup_or_drop_off_again_after_its_checkpoint_answers_true_for_free() -> None:
    sim = engine()
    sim.new_task()
    at_pick_up_beside_guest(sim)
    assert sim.pickup("human_20843", "servicebot")[0]
    assert sim.pickup("human_20843", "servicebot")[0]  # checkpoint 2 done: true
    assert sim.pickup("human_11111", "otherbot")[0]  # whatever the names
    drop = sim.world.areas["PrivateCubicle_32_1"]
    sim.guest.x, sim.guest.y = drop.centre
    place_robot(sim, drop.centre[0] + 1.1, drop.centre[1])
    assert sim.dropoff("human_20843")[0]
    assert sim.dropoff("human_20843")[0]  # checkpoint 3 done: true
    penalties = sim.referee.penalties
    assert (penalties.failed_pickup, penalties.failed_dropoff) == (0, 0)


def test_a_pickup_after_the_drop_off_makes_the_guest_follow_again() -> None:
    sim = engine()
    sim.new_task()
    at_pick_up_beside_guest(sim)
    sim.pickup("human_20843", "servicebot")
    drop = sim.world.areas["PrivateCubicle_32_1"]
    sim.guest.x, sim.guest.y = drop.centre
    place_robot(sim, drop.centre[0] + 1.1, drop.centre[1])
    sim.dropoff("human_20843")
    assert sim.guest_state() == "dropped_off"
    assert sim.pickup("human_20843", "servicebot") == (
        True, "checkpoint 2 is done; human_20843 follows servicebot again")
    assert sim.guest_state() == "following"
    assert sim.referee.current == 3  # the task stays at checkpoint 4
    place_robot(sim, sim.guest.x + 4.5, sim.guest.y)  # lost after checkpoint 3: no penalty
    assert sim.guest_state() == "lost" and sim.referee.penalties.too_fast == 0
    assert sim.referee.current == 3


def test_pickup_and_drop_off_before_new_task_book_their_points_once_scoring_starts() -> None:
    sim = engine()
    assert sim.pickup("human_20843", "servicebot")[0] is False
    assert sim.dropoff("human_20843")[0] is False
    assert sim.score() == pytest.approx(90.0)
    assert not sim.task_running()  # the score is only published while a task runs
    sim.new_task()
    sim.step()
    near_people = sim.referee.penalties.approximation  # the shipped start has walkers passing
    assert sim.score() - near_people == pytest.approx(90.0 + sim.dt)


def spot_beside_guest(sim: SimEngine, distance: float) -> tuple[float, float]:
    guest = sim.guest
    for angle in range(0, 360, 5):
        x = guest.x + distance * math.cos(math.radians(angle))
        y = guest.y + distance * math.sin(math.radians(angle))
        if sim.robot.walls.at(x, y) > 0.45:
            return x, y
    raise AssertionError(f"no free spot {distance} m from the guest")


def test_drift_with_nobody_following_fires_after_the_next_pickup_beyond_1_2_m() -> None:
    sim = engine()
    assert sim.force_drift() == (True, "drift armed")  # nobody follows: armed, true
    sim.new_task()
    at_pick_up_beside_guest(sim)
    place_robot(sim, *spot_beside_guest(sim, 1.1))
    assert sim.pickup("human_20843", "servicebot")[0]
    for _ in range(20):
        sim.step()
    assert sim.guest_state() == "following"  # within 1.2 m: the armed drift waits
    place_robot(sim, *spot_beside_guest(sim, 1.6))
    assert sim.guest_state() == "drifted" and sim.referee.current == 1
    sim.robot.x, sim.robot.y = spot_beside_guest(sim, 1.6)
    assert sim.pickup("human_20843", "servicebot")[0]
    sim.step()
    assert sim.guest_state() == "following"  # the drift fired once; nothing is armed


def far_from_people(sim: SimEngine, x: float, y: float) -> bool:
    return all(math.hypot(px - x, py - y) > 2.0 for _, _, px, py in sim.people_states())


def test_approximation_and_contact_count_from_the_start_of_the_world() -> None:
    sim = engine()
    sim.robot.x, sim.robot.y = spot_beside_guest(sim, 0.8)
    sim.step()  # before new_task
    assert sim.referee.penalties.approximation == pytest.approx(
        500 * sim.dt * (0.75 + 0.25 - 0.8), rel=0.05)
    assert sim.score() > 0.0


def test_walls_are_approximated_by_the_0_35_m_ghost_cylinder_around_the_origin() -> None:
    sim = engine()
    walls, grid = sim.robot.walls, sim.robot.walls.grid
    for clearance, depth in ((0.45, 0.0), (0.30, 0.05)):
        rows, cols = np.nonzero(np.abs(grid - clearance) < 0.01)
        spots = [sim.world.map.cell_to_world(r, c) for r, c in zip(rows, cols, strict=True)]
        x, y = next(spot for spot in spots if far_from_people(sim, *spot))
        before = sim.referee.penalties.approximation
        sim.robot.x, sim.robot.y = x, y
        sim.step()
        booked = sim.referee.penalties.approximation - before
        expected = 500 * sim.dt * 0.25 * (0.35 - walls.at(x, y)) if depth else 0.0
        assert booked == pytest.approx(expected, abs=1e-9)


def test_cmd_vel_persists_until_the_next_command() -> None:
    sim = engine()
    yaw = sim.robot.yaw
    sim.command_velocity(0.0, 0.5)
    for _ in range(int(2.0 / sim.dt)):
        sim.step()
    turned = math.remainder(sim.robot.yaw - yaw, math.tau)
    assert turned == pytest.approx(1.0, abs=0.03)  # 2 s at 0.5 rad/s, no 0.5 s stop
    sim.command_velocity(0.0, 0.0)
    sim.step()
    assert sim.robot_velocity() == (0.0, 0.0)


def test_a_command_beyond_the_robots_limits_drives_at_the_limits() -> None:
    sim = engine()
    sim.command_velocity(5.0, -4.0)
    sim.step()
    assert sim.robot_velocity() == (0.5, -1.0)


def test_a_goal_cancelled_mid_drive_leaves_the_robot_stopped() -> None:
    sim = engine()  # the shipped start, facing -x along PublicBathroomB
    sim.set_initial_pose(*sim.robot_pose())
    ticket = sim.navigate(8.5, 3.75, 3.14)
    for _ in range(int(2.0 / sim.dt)):
        sim.step()
    assert sim.robot_velocity()[0] > 0.1  # driving
    sim.cancel_navigation(ticket)
    sim.step()
    pose = sim.robot_pose()
    for _ in range(50):
        sim.step()
    assert sim.robot_pose() == pose  # the controller's last word was a stop, as Nav2's is


def test_rfid_lists_names_in_the_worlds_order_walkers_idlers_then_the_guest() -> None:
    sim = engine()
    people = sim.crowd.people
    first, second = next((a, b) for a, b in itertools.combinations(people, 2)
                         if a.name > b.name)  # world order is not alphabetical here
    x, y = sim.guest.x + 1.2, sim.guest.y
    for person, offset in ((first, 0.5), (second, -0.5)):
        person.x, person.y = x, y + offset
    sim.robot.x, sim.robot.y = x, y
    names = sim.rfid_names() or []
    world_order = [name for name, *_ in sim.people_states() if name in names]
    assert names == world_order and names.index(first.name) < names.index(second.name)
    assert names[-1] == sim.guest.name


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


def test_navigation_before_an_initial_pose_fails_with_tf_error_where_amcl_waits_for_one() -> None:
    world = dataclasses.replace(office(), amcl_initial_pose=None)
    sim = SimEngine(world=world, scenario=make_scenario(world))
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


def test_a_person_does_not_stop_the_robot_driving_into_them() -> None:
    # ours: people are no physics bodies; the original's collision boxes would block the robot
    # (worlds/actor_trajectory.erb 55-74, src/AttachModelPlugin.cc); docs/fidelity.md says so
    sim = engine()
    sim.new_task()
    guest = (sim.guest.x, sim.guest.y)
    sim.robot.x, sim.robot.y, sim.robot.yaw = guest[0] - 1.0, guest[1], 0.0
    assert sim.world.map.is_free(guest[0] - 1.0, guest[1]) and sim.world.map.is_free(
        guest[0] + 0.6, guest[1])  # floor all the way
    sim.command_velocity(0.5, 0.0)
    for _ in range(int(3.0 / sim.dt)):
        sim.step()
    assert sim.robot.x > guest[0]  # through the guest's disc
    assert sim.referee.penalties.contact > 0.0


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


def test_navigation_is_shown_the_guest_following_or_not() -> None:
    """The costmap's lidar decides whom navigation sees (±120°, line of sight), as Nav2's would;
    a following guest is not hidden from it, so a robot that turns back towards the guest it
    leads does not drive into them (evaluation seed 10 on `random` did: 1.3e6 contact)."""
    sim = engine()
    sim.new_task()
    at_pick_up_beside_guest(sim)
    assert (sim.guest.x, sim.guest.y) in sim._obstacles()
    assert sim.pickup(sim.guest.name, "servicebot")[0]
    assert sim.guest_state() == "following"
    assert (sim.guest.x, sim.guest.y) in sim._obstacles()


def test_navigations_costmap_marks_and_clears_people_while_no_goal_runs() -> None:
    """move_base's and Nav2's costmaps update at their own rate (the servicebot's 5 Hz) whether
    or not a goal runs: a robot standing with no goal marks the person it faces, and clears the
    mark once they have gone."""
    sim = engine()
    sim.new_task()
    at_pick_up_beside_guest(sim)
    guest = sim.guest
    sim.robot.yaw = math.atan2(guest.y - sim.robot.y, guest.x - sim.robot.x)
    spot = (guest.x, guest.y)

    def marked() -> bool:
        return any(math.hypot(mark.x - spot[0], mark.y - spot[1]) < 0.05
                   for mark in sim.navigator.costmap.marks)

    for _ in range(15):  # 0.3 sim s
        sim.step()
    assert sim.navigator.status == "idle" and marked()
    guest.x, guest.y = sim.robot.x, sim.robot.y - 40.0  # gone, far out of view
    for _ in range(15):
        sim.step()
    assert sim.navigator.status == "idle" and not marked()


def test_the_depth_sums_are_what_ndarray_sum_gives_bit_for_bit() -> None:
    """_book_contacts sums depths with np.add.reduce (ndarray.sum without its wrapper): the
    same pairwise summation, whatever the number of people and where the zeros fall."""
    rng = np.random.default_rng(12)
    for _ in range(2000):
        distances = rng.uniform(0.0, 3.0, size=int(rng.integers(0, 80)))
        depths = np.maximum(1.0 - distances, 0.0)
        assert float(np.add.reduce(depths, axis=None)).hex() == float(depths.sum()).hex()


def test_the_depths_booked_are_the_element_wise_ones_over_everyone_bit_for_bit() -> None:
    sim = engine()
    rng = np.random.default_rng(13)
    robot, people = sim.robot, [*sim.crowd.people, sim.guest]
    for _ in range(300):
        robot.x, robot.y, robot.yaw = (float(value) for value in rng.uniform(-3.0, 3.0, 3))
        bearings = rng.uniform(-math.pi, math.pi, size=len(people))
        # some right at the ghost cylinder's reach, where rounding decides
        reach = (PERSON_APPROXIMATION_M + PERSON_BODY_RADIUS) * (
            1.0 + rng.choice([-1e-15, 0.0, 1e-15], size=len(people)))
        distances = np.where(rng.uniform(size=len(people)) < 0.3, reach,
                             rng.uniform(0.0, 1.6, size=len(people)))
        for person, bearing, distance in zip(people, bearings, distances, strict=True):
            person.x = robot.x + float(distance) * math.cos(bearing)
            person.y = robot.y + float(distance) * math.sin(bearing)
        touching, approach = sim.penalty_checker._person_depths()
        xs, ys = np.array([p.x for p in people]), np.array([p.y for p in people])
        assert touching.tobytes() == Footprint.person_depths(
            robot.pose, xs, ys, radius=PERSON_BODY_RADIUS).tobytes()
        assert approach.tobytes() == np.minimum(np.maximum(
            PERSON_APPROXIMATION_M + PERSON_BODY_RADIUS - np.hypot(xs - robot.x, ys - robot.y),
            0.0), PERSON_APPROXIMATION_M).tobytes()


def test_rfid_names_everyone_the_plane_distance_puts_within_2_m_bit_for_bit() -> None:
    sim = engine()
    rng = np.random.default_rng(16)
    people = [*sim.crowd.people, sim.guest]
    for _ in range(200):
        sim.robot.x, sim.robot.y = (float(value) for value in rng.uniform(-3.0, 3.0, 2))
        bearings = rng.uniform(-math.pi, math.pi, size=len(people))
        # many right at the range, and along the axes, where rounding decides
        bearings[rng.uniform(size=len(people)) < 0.3] = rng.choice([0.0, math.pi / 2, math.pi])
        distances = np.where(rng.uniform(size=len(people)) < 0.5,
                             2.0 * (1.0 + rng.choice([-1e-16, 0.0, 1e-16], size=len(people))),
                             rng.uniform(0.0, 4.0, size=len(people)))
        for person, bearing, distance in zip(people, bearings, distances, strict=True):
            person.x = sim.robot.x + float(distance) * math.cos(bearing)
            person.y = sim.robot.y + float(distance) * math.sin(bearing)
        expected = [name for name, _, x, y in sim.people_states()
                    if math.hypot(x - sim.robot.x, y - sim.robot.y) <= 2.0]
        assert sim.rfid_names() == (expected or None)
