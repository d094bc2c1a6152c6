"""The simulator's walkers and idlers on a small office map.

The map is a 20 x 12 m building with three rooms off a long wall, an open hall with a pillar,
and unknown space outside.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable

import numpy as np
import pytest
from scipy import ndimage

from servicesim_sim.people import IDLER, WALKER, Crowd, Person
from servicesim_sim.world import OccupancyMap

RESOLUTION = 0.05
ORIGIN = (-2.0, -2.0)
KEEP_CLEAR = [(2.0, 2.0, 1.5), (10.0, 6.0, 1.5)]


def wall(grid: np.ndarray, x0: float, y0: float, x1: float, y1: float) -> None:
    """Mark the rectangle [x0, x1] x [y0, y1] (metres) occupied."""
    c0, c1 = (round((v - ORIGIN[0]) / RESOLUTION) for v in (x0, x1))
    r0, r1 = (round((v - ORIGIN[1]) / RESOLUTION) for v in (y0, y1))
    grid[r0:r1 + 1, c0:c1 + 1] = 100


def office_map() -> OccupancyMap:
    grid = np.full((320, 480), -1, dtype=np.int8)  # 24 x 16 m
    wall(grid, 0.0, 0.0, 20.0, 12.0)
    grid[42:279, 42:439] = 0  # inside the outer walls
    wall(grid, 0.0, 4.0, 3.0, 4.1)  # room wall with three 1.2 m doors
    wall(grid, 4.2, 4.0, 9.0, 4.1)
    wall(grid, 10.2, 4.0, 15.0, 4.1)
    wall(grid, 16.2, 4.0, 20.0, 4.1)
    wall(grid, 6.5, 0.0, 6.6, 4.0)
    wall(grid, 13.0, 0.0, 13.1, 4.0)
    wall(grid, 14.0, 8.0, 15.0, 9.0)  # a pillar in the hall
    return OccupancyMap(grid=grid, resolution=RESOLUTION, origin_x=ORIGIN[0], origin_y=ORIGIN[1])


def crowd(seed: int, *, walkers: int = 5, idlers: int = 12,
          occupancy_map: OccupancyMap | None = None, taken: set[str] | None = None) -> Crowd:
    return Crowd(occupancy_map or office_map(), rng=np.random.default_rng(seed), walkers=walkers,
                 idlers=idlers, taken_names=taken or set(), keep_clear=KEEP_CLEAR)


def walkers_of(people: Crowd) -> list[Person]:
    return [p for p in people.people if p.role == WALKER]


def idlers_of(people: Crowd) -> list[Person]:
    return [p for p in people.people if p.role == IDLER]


FAR_AWAY = (-100.0, -100.0, 0.0)


def test_the_same_seed_gives_the_same_crowd_and_the_same_walks() -> None:
    first, second, other = crowd(7), crowd(7), crowd(8)
    assert first.states() == second.states()
    assert first.states() != other.states()
    for _ in range(50):
        first.step(0.1, robot=FAR_AWAY)
        second.step(0.1, robot=FAR_AWAY)
    assert first.states() == second.states()


def test_names_are_unique_five_digit_humans_and_avoid_taken_names() -> None:
    taken = {f"human_{n:05d}" for n in range(0, 100_000, 2)}  # every even number is taken
    people = crowd(3, taken=taken)
    names = [name for name, _, _, _ in people.states()]
    assert len(names) == 17 and len(set(names)) == 17
    assert all(re.fullmatch(r"human_\d{5}", name) for name in names)
    assert not taken & set(names)
    roles = [role for _, role, _, _ in people.states()]
    assert roles.count(WALKER) == 5 and roles.count(IDLER) == 12


def body_is_free(occupancy_map: OccupancyMap, x: float, y: float, radius: float) -> bool:
    """The centre and eight points on a circle of ``radius`` around it lie on free cells."""
    ring = [(x + radius * math.cos(a), y + radius * math.sin(a))
            for a in np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)]
    return all(occupancy_map.is_free(px, py) for px, py in [(x, y), *ring])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_walkers_keep_off_walls_idlers_and_keep_clear_discs(seed: int) -> None:
    office = office_map()
    people = crowd(seed, occupancy_map=office)
    standing = [(p.x, p.y) for p in idlers_of(people)]
    for _ in range(300):
        people.step(0.1, robot=FAR_AWAY)
        for walker in walkers_of(people):
            assert body_is_free(office, walker.x, walker.y, 0.25), (walker, "in a wall")
            assert all(math.hypot(walker.x - x, walker.y - y) >= 0.5 for x, y in standing)
            assert all(math.hypot(walker.x - x, walker.y - y) >= r for x, y, r in KEEP_CLEAR)


def test_walkers_move_at_their_own_speed_between_0_9_and_1_2_metres_a_second() -> None:
    people = crowd(4)
    dt, steps = 0.1, 200
    start = {p.name: (p.x, p.y) for p in walkers_of(people)}
    paths = dict.fromkeys(start, 0.0)
    last = dict(start)
    for _ in range(steps):
        people.step(dt, robot=FAR_AWAY)
        for walker in walkers_of(people):
            hop = math.hypot(walker.x - last[walker.name][0], walker.y - last[walker.name][1])
            assert hop <= 1.2 * dt + 1e-9
            paths[walker.name] += hop
            last[walker.name] = (walker.x, walker.y)
    speeds = [path / (dt * steps) for path in paths.values()]
    assert all(0.9 * 0.97 <= speed <= 1.2 + 1e-9 for speed in speeds), speeds  # 3%: corners
    assert len({round(speed, 3) for speed in speeds}) > 1
    assert all(math.hypot(walker.x - start[walker.name][0], walker.y - start[walker.name][1])
               > 0.0 for walker in walkers_of(people))


Robot = tuple[float, float, float]


def robot_at(*, distance: float, bearing: float) -> Callable[[Person], Robot]:
    """A robot kept ``distance`` from a walker, ``bearing`` radians off its current heading."""

    def place(walker: Person) -> Robot:
        heading = walker.yaw + bearing
        return (walker.x + distance * math.cos(heading),
                walker.y + distance * math.sin(heading), 0.0)

    return place


def far_away(_walker: Person) -> Robot:
    return FAR_AWAY


def steps_moved(people: Crowd, walker: Person, robot: Callable[[Person], Robot]) -> float:
    """How far the walker walks in ten steps of 0.1 s, the robot placed by ``robot`` each step."""
    walked = 0.0
    for _ in range(10):
        before = (walker.x, walker.y)
        people.step(0.1, robot=robot(walker))
        walked += math.hypot(walker.x - before[0], walker.y - before[1])
    return walked


def test_a_walker_stops_for_a_robot_in_front_and_walks_on_when_it_is_gone() -> None:
    people = crowd(5)
    walker, *others = walkers_of(people)
    others_before = [(p.x, p.y) for p in others]
    assert steps_moved(people, walker, robot_at(distance=1.2, bearing=math.radians(40.0))) == 0
    assert all((p.x, p.y) != xy for p, xy in zip(others, others_before, strict=True))
    assert steps_moved(people, walker, far_away) > 0.85


@pytest.mark.parametrize(("distance", "bearing"), [
    (1.0, math.pi),  # behind
    (1.0, math.radians(75.0)),  # beside, outside the +-60 degree cone
    (1.8, 0.0),  # ahead but further than 1.5 m
    (0.7, math.radians(120.0)),  # close, but behind its shoulder
])
def test_a_walker_does_not_stop_for_a_robot_behind_beside_or_far(distance: float,
                                                                  bearing: float) -> None:
    people = crowd(5)
    walker = walkers_of(people)[0]
    assert steps_moved(people, walker, robot_at(distance=distance, bearing=bearing)) > 0.85


def test_a_walker_blocked_by_the_robot_for_5_s_turns_back_and_walks_away() -> None:
    people = crowd(5)
    walker = walkers_of(people)[0]
    robot = robot_at(distance=1.2, bearing=0.0)(walker)  # stays where it was put
    blocked = 0.0
    while steps_moved(people, walker, lambda _: robot) == 0.0:
        blocked += 1.0
        assert blocked < 10.0, "still waiting after 10 s"
    assert 4.0 <= blocked <= 5.0
    gap_before = math.hypot(walker.x - robot[0], walker.y - robot[1])
    steps_moved(people, walker, lambda _: robot)
    assert math.hypot(walker.x - robot[0], walker.y - robot[1]) > gap_before + 0.5


def test_a_walker_gives_way_to_a_robot_close_at_its_side() -> None:
    people = crowd(5)
    walker = walkers_of(people)[0]
    assert steps_moved(people, walker, robot_at(distance=0.8, bearing=math.radians(80.0))) == 0


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_idlers_stand_apart_off_walls_and_out_of_keep_clear_discs(seed: int) -> None:
    office = office_map()
    people = crowd(seed, idlers=20, occupancy_map=office)
    standing = idlers_of(people)
    spots = np.array([(p.x, p.y) for p in standing])
    gaps = np.hypot(*(spots[:, None, :] - spots[None, :, :]).transpose(2, 0, 1))
    assert gaps[~np.eye(len(spots), dtype=bool)].min() >= 1.0
    assert all(body_is_free(office, x, y, 0.55) for x, y in spots)
    assert all(math.hypot(x - cx, y - cy) > r for x, y in spots for cx, cy, r in KEEP_CLEAR)
    assert all(-1.0 <= x <= 21.0 and -1.0 <= y <= 13.0 for x, y in spots)  # in the building
    assert len({round(p.yaw, 6) for p in standing}) == len(standing)
    for _ in range(20):
        people.step(0.1, robot=FAR_AWAY)
    assert [(p.x, p.y) for p in idlers_of(people)] == [tuple(s) for s in spots]


def two_rooms_and_a_corridor() -> OccupancyMap:
    """Two 4 x 4 m rooms joined by a 6 m corridor 1.6 m wide: room enough for an idler."""
    grid = np.full((200, 400), -1, dtype=np.int8)
    wall(grid, 0.0, 0.0, 4.1, 4.1)
    wall(grid, 10.0, 0.0, 14.1, 4.1)
    wall(grid, 4.0, 1.2, 10.1, 2.9)
    grid[42:120, 42:120] = 0
    grid[42:120, 242:320] = 0
    grid[66:97, 100:262] = 0  # the corridor, y 1.3..2.85
    return OccupancyMap(grid=grid, resolution=RESOLUTION, origin_x=ORIGIN[0], origin_y=ORIGIN[1])


def robot_can_cross(occupancy_map: OccupancyMap, idlers: list[tuple[float, float]]) -> bool:
    """Whether a robot needing 0.3 m from walls and 0.55 m from idlers gets between rooms.

    It can when one connected stretch of the space open to it reaches into both rooms.
    """
    free = ~occupancy_map.blocked_mask()
    room = ndimage.distance_transform_edt(free) * RESOLUTION >= 0.3
    rows, cols = np.indices(free.shape)
    xs, ys = ORIGIN[0] + (cols + 0.5) * RESOLUTION, ORIGIN[1] + (rows + 0.5) * RESOLUTION
    for x, y in idlers:
        room &= np.hypot(xs - x, ys - y) >= 0.55
    labels, _ = ndimage.label(room)
    largest = np.argmax(np.bincount(labels.ravel())[1:]) + 1
    return bool((xs[labels == largest] < 3.0).any() and (xs[labels == largest] > 11.0).any())


@pytest.mark.parametrize("seed", range(6))
def test_idlers_never_block_the_only_way_between_two_rooms(seed: int) -> None:
    corridor = two_rooms_and_a_corridor()
    assert robot_can_cross(corridor, [])
    people = Crowd(corridor, rng=np.random.default_rng(seed), walkers=0, idlers=8,
                   taken_names=set(), keep_clear=[])
    assert robot_can_cross(corridor, [(p.x, p.y) for p in people.people])


def test_impossible_crowds_are_refused_with_a_clear_message() -> None:
    with pytest.raises(ValueError, match="counts must be 0 or more"):
        crowd(0, walkers=-1)
    with pytest.raises(ValueError, match=r"room for only \d+ of 400 idlers"):
        crowd(0, walkers=0, idlers=400)
    with pytest.raises(ValueError, match="dt"):
        crowd(0).step(-0.1, robot=FAR_AWAY)
