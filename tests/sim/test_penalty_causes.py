"""The referee books contact and approximation points with their cause, where it takes depths.

A walker is made to cross the robot's way: the robot stands beside the walker's route, ahead of
it, while the walker walks past. The points booked must be the walker's, by name and role, and
the books by cause must add up to the referee's totals.
"""

from __future__ import annotations

import math

import pytest

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.people import WALKER
from servicesim_sim.model.scenario import make_scenario
from servicesim_sim.world.files import DEFAULT_WORLD, load_world

OFFSET_M = 0.7  # from the walker's route: within the ghost cylinder's reach of its body (1 m)


def engine(seed: int | None = 3) -> SimEngine:
    world = load_world(DEFAULT_WORLD)
    return SimEngine(world=world, scenario=make_scenario(world, seed=seed))


def others_far(sim: SimEngine, name: str, x: float, y: float) -> bool:
    return all(math.hypot(px - x, py - y) > 3.5
               for other, _, px, py in sim.people_states() if other != name)


def beside_a_walkers_way() -> tuple[SimEngine, str, float, float]:
    """The first seed with a walker and a free spot 1 m ahead of it on its way and 0.7 m to its
    side, walls more than 0.45 m away and nobody else within 3.5 m: the engine, the walker's
    name and the spot."""
    for seed in range(50):
        sim = engine(seed)
        for walker in sim.crowd.walkers:
            person = walker.person
            ahead_x = person.x + 1.0 * math.cos(person.yaw)
            ahead_y = person.y + 1.0 * math.sin(person.yaw)
            for side in (1.0, -1.0):
                x = ahead_x + side * OFFSET_M * -math.sin(person.yaw)
                y = ahead_y + side * OFFSET_M * math.cos(person.yaw)
                if (sim.world.map.is_free(x, y) and sim.robot.walls.at(x, y) > 0.45
                        and others_far(sim, person.name, x, y)):
                    return sim, person.name, x, y
    raise AssertionError("no walker with room beside its way")


def test_points_booked_as_a_walker_crosses_the_robots_way_are_the_walkers() -> None:
    sim, name, x, y = beside_a_walkers_way()
    sim.new_task()
    sim.robot.x, sim.robot.y = x, y
    for _ in range(int(3.0 / sim.dt)):
        sim.step()
    penalties = sim.referee.penalties
    cause = f"approximation/{WALKER}/{name}"
    assert penalties.by_cause.get(cause, 0.0) > 1.0
    approximation = {key: points for key, points in penalties.by_cause.items()
                     if key.startswith("approximation/")}
    assert sum(approximation.values()) == pytest.approx(penalties.approximation, rel=1e-9)
    assert set(approximation) == {cause}  # nobody else near, no wall within 0.35 m
    bookings, causes = sim.penalty_causes()
    assert bookings > 0 and causes[cause] == penalties.by_cause[cause]


def test_the_guest_is_a_cause_of_its_own() -> None:
    sim = engine()
    sim.new_task()
    sim.robot.x, sim.robot.y = sim.guest.x + 0.4, sim.guest.y
    sim.step()
    causes = sim.referee.penalties.by_cause
    guest = f"guest/{sim.guest.name}"
    assert causes[f"contact/{guest}"] > 0.0 and causes[f"approximation/{guest}"] > 0.0
    assert sum(points for key, points in causes.items() if key.startswith("contact/")) == \
        pytest.approx(sim.referee.penalties.contact, rel=1e-9)
