"""The task's core rules as the original plays them, engine only (no ROS): what fires the area
checkpoints, what a pick-up and a drop-off need, RFID's range and the people's counts.

Each test pins a row of ``docs/fidelity.md``; the engine's own tests cover the rest of the rules.
"""

from __future__ import annotations

import math
from functools import cache

from servicesim_sim.model import referee as rules
from servicesim_sim.model.engine import RFID_RANGE_M, SimEngine
from servicesim_sim.model.people import IDLER, WALKER
from servicesim_sim.model.scenario import make_scenario
from servicesim_sim.world.files import DEFAULT_WORLD, World, load_world


@cache
def office() -> World:
    return load_world(DEFAULT_WORLD)


def shipped() -> SimEngine:
    world = office()
    return SimEngine(world=world, scenario=make_scenario(world))


def put_robot(sim: SimEngine, x: float, y: float) -> None:
    sim.robot.x, sim.robot.y = x, y
    sim.step()


def test_checkpoints_1_and_4_fire_on_the_robots_origin_in_the_area_box() -> None:
    sim = shipped()
    sim.new_task()
    box = sim.world.areas[sim.scenario.task.pick_up]
    put_robot(sim, box.centre[0], box.min_y - 0.05)  # its front half inside, its origin not
    assert not sim.referee.checkpoint_done[rules.GO_TO_PICK_UP]
    put_robot(sim, box.centre[0], box.min_y + 0.05)  # the origin just inside
    assert sim.referee.checkpoint_done[rules.GO_TO_PICK_UP]
    sim.referee.reach(rules.PICK_UP_GUEST)
    sim.referee.reach(rules.DROP_OFF_GUEST)
    start = sim.world.areas[sim.scenario.task.start_area]
    put_robot(sim, start.max_x + 0.05, start.centre[1])
    assert not sim.referee.completed
    put_robot(sim, start.max_x - 0.05, start.centre[1])
    assert sim.referee.completed


def test_a_pick_up_needs_the_guest_within_2_m_of_the_robot_not_the_robot_in_the_area() -> None:
    sim = shipped()
    sim.new_task()
    box = sim.world.areas[sim.scenario.task.pick_up]
    put_robot(sim, *box.centre)  # checkpoint 1
    guest = sim.guest
    put_robot(sim, guest.x, box.min_y - 0.3)  # out of the area again, the guest 1.8 m away
    assert not box.contains(sim.robot.x, sim.robot.y)
    assert math.hypot(guest.x - sim.robot.x, guest.y - sim.robot.y) <= 2.0
    assert sim.pickup(guest.name, "servicebot")[0]
    assert sim.guest_state() == "following"


def test_a_pick_up_from_just_beyond_2_m_fails_with_its_40_points() -> None:
    sim = shipped()
    sim.new_task()
    box = sim.world.areas[sim.scenario.task.pick_up]
    put_robot(sim, *box.centre)
    guest = sim.guest
    guest.x, guest.y = sim.robot.x + 2.01, sim.robot.y
    assert not sim.pickup(guest.name, "servicebot")[0]
    assert sim.referee.penalties.failed_pickup == 1 and sim.score() >= 40.0


def test_a_drop_off_needs_the_guests_origin_in_the_box_wherever_the_robot_is() -> None:
    sim = shipped()
    sim.new_task()
    put_robot(sim, *sim.world.areas[sim.scenario.task.pick_up].centre)
    sim.robot.x, sim.robot.y = sim.guest.x + 1.5, sim.guest.y
    assert sim.pickup(sim.guest.name, "servicebot")[0]
    drop = sim.world.areas[sim.scenario.task.drop_off]
    sim.guest.x, sim.guest.y = drop.centre[0], drop.max_y + 0.05  # just outside
    sim.robot.x, sim.robot.y = drop.centre  # the robot inside does not count
    assert not sim.dropoff(sim.guest.name)[0]
    assert sim.referee.penalties.failed_dropoff == 1
    sim.guest.x, sim.guest.y = drop.centre[0], drop.max_y - 0.05
    sim.robot.x, sim.robot.y = drop.centre[0], drop.max_y + 1.3  # the robot outside
    assert not drop.contains(sim.robot.x, sim.robot.y)
    assert sim.dropoff(sim.guest.name)[0]


def test_rfid_hears_people_within_2_m_in_the_plane_and_no_farther() -> None:
    sim = shipped()
    assert RFID_RANGE_M == 2.0
    guest = sim.guest
    sim.robot.x, sim.robot.y = guest.x + 1.99, guest.y
    assert guest.name in (sim.rfid_names() or [])
    sim.robot.x = guest.x + 2.01
    assert guest.name not in (sim.rfid_names() or [])


def test_the_office_has_the_originals_10_walkers_and_30_idlers() -> None:
    sim = shipped()
    roles = [role for _, role, _, _ in sim.crowd.states()]
    assert (roles.count(WALKER), roles.count(IDLER)) == (10, 30)
