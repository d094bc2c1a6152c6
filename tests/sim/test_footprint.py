"""The robot's body: the original's 0.4 x 0.5 m box, what it touches and what that costs.

The office's outer wall runs along y = 0 below the lobby; at x = 10.975 the floor above it is
clear for metres, so the tests put the robot there, facing or beside the wall.
"""

from __future__ import annotations

import itertools
import math
from functools import cache

import numpy as np
import pytest

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.people import IDLER, Person
from servicesim_sim.model.referee import CONTACT_REPORT_RATE_HZ, OBJECT_CONTACT_WEIGHT
from servicesim_sim.model.scenario import make_scenario
from servicesim_sim.navigation.body_check import BodyCheck, arc_end, check_times
from servicesim_sim.world.files import DEFAULT_WORLD, World, load_world
from servicesim_sim.world.footprint import (
    CIRCUMSCRIBED_RADIUS,
    CONTACT_SURFACE_LAYER,
    Footprint,
)

WALL_X = 10.975  # the lobby's south wall, its face at y = 0


@cache
def office() -> World:
    return load_world(DEFAULT_WORLD)


def robot_at(pose: tuple[float, float, float]) -> SimEngine:
    """The shipped task with nobody else about and the robot at ``pose``, localised there."""
    sim = SimEngine(world=office(), scenario=make_scenario(office()))
    sim.crowd.people.clear()
    sim.guest.x, sim.guest.y = -20.0, 20.0
    robot = sim.robot
    robot.x, robot.y, robot.yaw = pose
    robot.wall_depth = robot.footprint.wall_depth(pose)
    sim.set_initial_pose(*pose)
    return sim


def drive(sim: SimEngine, v: float, w: float, seconds: float) -> None:
    for _ in range(round(seconds / sim.dt)):
        sim.command_velocity(v, w)
        sim.step()


def test_the_body_is_the_originals_box_0_4_m_long_and_0_5_m_wide() -> None:
    box = Footprint(office().map)
    along, across = 0.2, 0.25
    assert pytest.approx(math.hypot(along, across)) == CIRCUMSCRIBED_RADIUS
    people_x = np.array([along + 0.25 - 0.01, 0.0, along + 0.3])
    people_y = np.array([0.0, across + 0.25 - 0.02, 0.0])
    depths = box.person_depths((0.0, 0.0, 0.0), people_x, people_y, radius=0.25)
    assert depths == pytest.approx([0.01, 0.02, 0.0])
    turned = box.person_depths((0.0, 0.0, math.pi / 2), people_x, people_y, radius=0.25)
    assert turned == pytest.approx([0.06, 0.0, 0.0])  # its long side now faces +x


def test_the_box_turning_in_place_beside_a_wall_touches_it_where_a_disc_would_not() -> None:
    box = Footprint(office().map)
    beside = (WALL_X, 0.28, 0.0)  # its side 3 cm off the wall, the centre 0.28 m
    assert box.wall_depth(beside) == 0.0
    assert box.wall_depth((WALL_X, 0.28, math.pi / 4)) == pytest.approx(0.038, abs=0.005)


def test_driving_into_a_wall_rests_the_surface_layer_deep_and_books_20000_per_report() -> None:
    sim = robot_at((WALL_X, 1.0, -math.pi / 2))
    drive(sim, 0.5, 0.0, 3.0)
    robot = sim.robot
    assert robot.y == pytest.approx(0.2, abs=0.02) and robot.v == 0.0  # stopped by the wall
    assert 0.0 < robot.wall_depth <= CONTACT_SURFACE_LAYER
    before = sim.referee.penalties.contact
    drive(sim, 0.5, 0.0, 1.0)  # pressing on for a second
    booked = sim.referee.penalties.contact - before
    expected = OBJECT_CONTACT_WEIGHT * robot.wall_depth * CONTACT_REPORT_RATE_HZ
    assert booked == pytest.approx(expected, rel=0.05) and booked > 50_000.0


def test_turning_in_place_beside_a_wall_costs_the_contact_penalty() -> None:
    sim = robot_at((WALL_X, 0.28, 0.0))
    drive(sim, 0.0, 1.0, 1.0)
    assert sim.referee.penalties.contact > 10_000.0
    assert abs(sim.robot.yaw) < 0.5  # the wall holds the turn


def test_backing_away_from_a_wall_ends_the_contact() -> None:
    sim = robot_at((WALL_X, 1.0, -math.pi / 2))
    drive(sim, 0.5, 0.0, 3.0)
    drive(sim, -0.2, 0.0, 1.0)
    assert sim.robot.wall_depth == 0.0
    before = sim.referee.penalties.contact
    drive(sim, 0.0, 0.0, 1.0)
    assert sim.referee.penalties.contact == before


def test_navigation_turns_the_box_clear_of_a_wall_it_stands_beside() -> None:
    # the goal lies behind the robot: a turn on the spot would sweep a corner into the wall
    sim = robot_at((WALL_X, 0.30, 0.0))
    ticket = sim.navigate(WALL_X + 0.8, 0.9, math.pi / 2)
    for _ in range(round(40.0 / sim.dt)):
        sim.step()
        if sim.navigation_state(ticket).status != "running":
            break
    assert sim.navigation_state(ticket).status == "succeeded"
    assert sim.referee.penalties.contact == 0.0


def navigate(sim: SimEngine, goal: tuple[float, float, float], *, seconds: float) -> str:
    """Run navigation to ``goal`` until it ends or ``seconds`` pass; its last status."""
    ticket = sim.navigate(*goal)
    for _ in range(round(seconds / sim.dt)):
        sim.step()
        if sim.navigation_state(ticket).status != "running":
            break
    return sim.navigation_state(ticket).status


def person_beside(sim: SimEngine, *, across: float) -> Person:
    """Someone standing ``across`` metres to the robot's left (right when negative), 0.56 m
    from its centre: clear of its side, but within reach of its corners (0.32 m) and their
    0.25 m body as it turns."""
    x, y, _ = sim.robot.pose
    person = Person(name="human_00001", role=IDLER, x=x, y=y + across, yaw=0.0)
    sim.crowd.people.append(person)
    return person


@pytest.mark.parametrize("across", [0.56, -0.56])
def test_navigation_sets_off_without_sweeping_a_corner_into_a_person_beside_it(
        across: float) -> None:
    # the goal lies behind: a turn on the spot towards the person's side sweeps a corner into
    # them, as when the robot sets off again beside a walker who stopped for it
    sim = robot_at((WALL_X, 2.0, 0.0))
    person = person_beside(sim, across=across)
    assert navigate(sim, (WALL_X - 1.5, 2.0, math.pi), seconds=40.0) == "succeeded"
    assert sim.referee.penalties.contact == 0.0
    assert any(math.dist((mark.x, mark.y), (person.x, person.y)) < 0.05
               for mark in sim.navigator.costmap.marks)  # navigation knew of them


def test_navigation_turns_to_the_goal_yaw_clear_of_a_person_beside_it() -> None:
    # at the goal already, facing the wrong way: the turn to the goal's yaw sweeps a corner
    # into the person standing beside the robot unless the box is moved clear first
    sim = robot_at((WALL_X, 2.0, 0.0))
    person_beside(sim, across=0.56)
    assert navigate(sim, (WALL_X, 2.0, math.pi), seconds=40.0) == "succeeded"
    assert sim.referee.penalties.contact == 0.0


def pinned() -> SimEngine:
    """Hard seed 27's robot: its side 1.7 cm off the wall to its right, someone 0.11 m off its
    front corner. A turn on the spot either way sweeps a corner into the wall, and driving
    straight on or back never makes the room to turn."""
    sim = robot_at((-11.42, 5.97, math.radians(-176.0)))
    sim.crowd.people.append(Person(name="human_00001", role=IDLER, x=-11.8, y=5.4, yaw=0.0))
    return sim


def test_navigation_makes_room_to_turn_when_pinned_between_a_wall_and_a_person() -> None:
    sim = pinned()
    assert navigate(sim, (-5.97, 7.18, -2.92), seconds=60.0) == "succeeded"  # behind it
    assert sim.referee.penalties.contact == 0.0


def test_a_pinned_robot_does_not_flip_flop_between_backing_off_and_creeping_on() -> None:
    sim = pinned()
    sim.navigate(-5.97, 7.18, -2.92)
    drives = []
    for _ in range(round(10.0 / sim.dt)):
        sim.step()
        drives.append(sim.robot.v)
    reversals = sum(1 for before, after in itertools.pairwise(drives) if before * after < 0.0)
    assert reversals <= 3
    assert math.dist(sim.robot.pose[:2], (-11.42, 5.97)) > 0.25


def test_the_nearest_gap_is_the_least_gap_or_a_bound_beyond_the_threshold() -> None:
    """Within ``beyond`` the answer is the least of the gaps, bit for bit; past it, it may be
    any gap past it, so whoever compares it with a threshold up to ``beyond`` decides alike."""
    body = Footprint(office().map)
    rng = np.random.default_rng(8)
    bounded = exact = 0
    for _ in range(3000):
        pose = (float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)),
                float(rng.uniform(-math.pi, math.pi)))
        points = [(float(x), float(y))
                  for x, y in rng.uniform(-6, 6, size=(int(rng.integers(1, 12)), 2))]
        if rng.uniform() < 0.5:  # one point right at the reach of the corners and the margin
            angle = float(rng.uniform(-math.pi, math.pi))
            reach = CIRCUMSCRIBED_RADIUS + 0.26 + float(rng.choice([-1e-12, 0.0, 1e-12]))
            points.append((pose[0] + reach * math.cos(angle), pose[1] + reach * math.sin(angle)))
        beyond = float(rng.choice([0.0, 0.26, 0.5]))
        least = float(Footprint.gaps_to(pose, np.array([p[0] for p in points]),
                                        np.array([p[1] for p in points])).min())
        answer = body.nearest_gap(pose, points, beyond=beyond)
        if answer <= beyond:
            assert answer == least
            exact += 1
        else:
            assert least > beyond
            bounded += 1
    assert exact > 300 and bounded > 300
    assert body.nearest_gap((0.0, 0.0, 0.0), []) == math.inf


def test_the_centre_gap_reads_the_maps_distance_grid_cell_by_cell_bit_for_bit() -> None:
    occupancy = office().map
    footprint = Footprint(occupancy)
    rng = np.random.default_rng(11)
    (min_x, min_y, max_x, max_y) = occupancy.extent
    xs = rng.uniform(min_x - 1.0, max_x + 1.0, size=4000)
    ys = rng.uniform(min_y - 1.0, max_y + 1.0, size=4000)
    xs[:1000] = np.round(xs[:1000] / occupancy.resolution) * occupancy.resolution  # cell edges
    for x, y in zip(xs.tolist(), ys.tolist(), strict=True):
        row, col = occupancy.world_to_cell(x, y)
        inside = occupancy.in_bounds(row, col)
        assert occupancy.flat_index(x, y) == (row * occupancy.width + col if inside else None)
        expected = (float(occupancy.wall_distance[row, col]) - 1.5 * occupancy.resolution
                    if inside else 0.0)
        assert footprint._centre_gap(x, y) == expected


def test_a_turn_whose_corner_grazes_a_wall_between_two_checks_far_apart_is_refused() -> None:
    """Hard seed 72 at 156.5 sim s: beside a door post, an arc of 0.3 m/s at 1 rad/s keeps the
    box over 1 cm off the wall 0.15 and 0.3 s ahead, yet its corner is 2 mm into the wall
    0.06 s ahead. Checked every 0.025 rad of the turn, as TrajectoryPlanner checked its
    trajectories, it is refused."""
    footprint = Footprint(office().map)
    pose, twist = (-12.361, 17.881, 0.48), (0.3, 1.0)
    assert all(footprint.clearance(arc_end(pose, twist, seconds)) > 0.01
               for seconds in (0.15, 0.3))
    assert min(footprint.clearance(arc_end(pose, twist, step * 0.01))
               for step in range(1, 31)) < 0.0
    check = BodyCheck(footprint, marks=list, horizon=0.3, margin=0.01, person_body=0.25)
    assert not check.keeps_clear(pose, twist, None)
    assert check.keeps_clear(pose, (0.0, -1.0), None), "turning away keeps clear"
    given = check.command(pose, twist, now=0.0)
    assert min(footprint.clearance(arc_end(pose, given, step * 0.01))
               for step in range(1, 31)) > 0.0, f"{given} keeps off the wall throughout"


@pytest.mark.parametrize(("twist", "count"), [
    ((0.5, 0.0), 6),  # 0.15 m driven: 0.025 m apart
    ((0.3, 1.0), 12),  # 0.3 rad turned: 0.025 rad apart
    ((0.1, 0.0), 2),  # slow: halfway and at the end
])
def test_commands_are_checked_every_0_025_m_or_rad_of_the_way(twist: tuple[float, float],
                                                               count: int) -> None:
    times = check_times(twist, 0.3)
    assert len(times) == count and times[-1] == pytest.approx(0.3)
    assert times == tuple(sorted(times)) and times[0] == pytest.approx(0.3 / count)
