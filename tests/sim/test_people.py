"""The simulator's walkers and idlers on a small office map.

The map is a 20 x 12 m building with three rooms off a long wall, an open hall with a pillar,
and unknown space outside.
"""

from __future__ import annotations

import bisect
import itertools
import math
import re
from collections.abc import Callable

import numpy as np
import pytest
from scipy import ndimage

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.people import (
    IDLER,
    ROBOT_BELOW_WALKER,
    WALKER,
    WALKER_STOP_DISTANCE,
    Crowd,
    CrowdError,
    Person,
    Walker,
    in_stop_lane,
    standing_near_legs,
)
from servicesim_sim.model.scenario import make_scenario
from servicesim_sim.world.files import (
    DEFAULT_WORLD,
    IdlingArea,
    OccupancyMap,
    PlacedWalker,
    WalkerRoute,
    World,
    load_world,
)
from servicesim_sim.world.office import SHIPPED_WALKERS

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


def walked_speed(people: Crowd, *, dt: float = 0.1, steps: int = 200) -> float:
    """The mean speed of a crowd's one walker over ``steps``, checking every hop."""
    walker = walkers_of(people)[0]
    path, last = 0.0, (walker.x, walker.y)
    for _ in range(steps):
        people.step(dt, robot=FAR_AWAY)
        hop = math.hypot(walker.x - last[0], walker.y - last[1])
        assert hop <= 1.2 * dt + 1e-9
        path, last = path + hop, (walker.x, walker.y)
    return path / (dt * steps)


def test_walkers_move_at_their_own_speed_between_0_9_and_1_2_metres_a_second() -> None:
    speeds = [walked_speed(crowd(seed, walkers=1)) for seed in (4, 5, 6)]  # alone: nobody stops
    assert all(0.9 * 0.97 <= speed <= 1.2 + 1e-9 for speed in speeds), speeds  # 3%: corners
    assert len({round(speed, 3) for speed in speeds}) > 1


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
    people = crowd(5, walkers=1)
    walker = walkers_of(people)[0]
    assert steps_moved(people, walker, robot_at(distance=1.0, bearing=math.radians(25.0))) == 0
    assert steps_moved(people, walker, far_away) > 0.85


def at_lane_offset(*, ahead: float, side: float) -> Callable[[Person], Robot]:
    """A robot kept ``ahead`` metres along a walker's heading and ``side`` metres left of it."""
    return robot_at(distance=math.hypot(ahead, side), bearing=math.atan2(side, ahead))


@pytest.mark.parametrize(("ahead", "side"), [
    (1.1, 0.0),  # straight ahead, just inside the 1.12 m the 3-D 1.5 m leaves on the floor
    (0.9, 0.55),  # to one side, just inside the 0.6 m half-width (1.06 m away)
    (0.3, -0.55),  # close, to the other side
])
def test_a_walker_stops_for_a_robot_in_its_lane(ahead: float, side: float) -> None:
    # TrajectoryActorPlugin.cc 186-199: nearer than 1.5 m in 3-D from the walker's origin 1 m
    # up to the robot's on the floor, ahead, within 0.4 x 1.5 m sideways
    people = crowd(5, walkers=1)
    walker = walkers_of(people)[0]
    assert steps_moved(people, walker, at_lane_offset(ahead=ahead, side=side)) == 0


@pytest.mark.parametrize(("ahead", "side"), [
    (-1.0, 0.0),  # behind
    (1.0, 0.7),  # ahead but beside the lane (the old +-60 degree cone stopped for this)
    (0.2, 0.78),  # close at its shoulder (the old give-way disc stopped for this)
    (1.55, 0.0),  # ahead but further than 1.5 m
    (1.3, 0.8),  # ahead and within 1.5 m, but beside the lane
    (1.2, 0.0),  # straight ahead within 1.5 m on the floor, but 1.56 m from the walker's origin
])
def test_a_walker_does_not_stop_for_a_robot_outside_its_lane(ahead: float, side: float) -> None:
    people = crowd(5, walkers=1)
    walker = walkers_of(people)[0]
    assert steps_moved(people, walker, at_lane_offset(ahead=ahead, side=side)) > 0.85


def test_the_guest_stops_a_walker_from_the_full_1_5_m_the_robot_does_not() -> None:
    # the guest's origin is 1 m up like the walker's (service.world.erb 1152-1159)
    spot = robot_at(distance=1.45, bearing=0.0)
    people = crowd(5, walkers=1)
    walker = walkers_of(people)[0]
    assert steps_moved(people, walker, spot) > 0.85  # the robot there: it walks on
    people = crowd(5, walkers=1)
    walker = walkers_of(people)[0]
    guest_x, guest_y, _ = spot(walker)
    before = (walker.x, walker.y)
    people.step(0.1, robot=FAR_AWAY, others=[(guest_x, guest_y)])
    assert (walker.x, walker.y) == before


def test_a_walker_waits_for_the_robot_as_long_as_it_stays_in_the_lane() -> None:
    # TrajectoryActorPlugin.cc 250: no time-out, it waits while the way is blocked
    people = crowd(5, walkers=1)
    walker = walkers_of(people)[0]
    robot = robot_at(distance=1.0, bearing=0.0)(walker)  # stays where it was put
    before = (walker.x, walker.y)
    for _ in range(600):  # a sim minute
        people.step(0.1, robot=robot)
    assert (walker.x, walker.y) == before
    assert steps_moved(people, walker, far_away) > 0.85


def test_a_walker_with_patience_turns_back_after_it() -> None:
    people = Crowd(office_map(), rng=np.random.default_rng(5), walkers=1, idlers=12,
                   taken_names=set(), keep_clear=KEEP_CLEAR, walker_patience_s=5.0)
    walker = walkers_of(people)[0]
    robot = robot_at(distance=1.0, bearing=0.0)(walker)
    blocked = 0.0
    while steps_moved(people, walker, lambda _: robot) == 0.0:
        blocked += 1.0
        assert blocked < 10.0, "still waiting after 10 s"
    assert 4.0 <= blocked <= 5.0
    gap_before = math.hypot(walker.x - robot[0], walker.y - robot[1])
    steps_moved(people, walker, lambda _: robot)
    assert math.hypot(walker.x - robot[0], walker.y - robot[1]) > gap_before + 0.5


def test_a_walker_stops_for_the_guest_in_its_lane_too() -> None:
    people = crowd(5, walkers=1)
    walker = walkers_of(people)[0]
    guest = robot_at(distance=1.0, bearing=0.2)(walker)
    before = (walker.x, walker.y)
    for _ in range(100):
        people.step(0.1, robot=FAR_AWAY, others=[guest[:2]])
    assert (walker.x, walker.y) == before
    people.step(0.1, robot=FAR_AWAY, others=[])
    assert (walker.x, walker.y) != before


def lane_holds(walker: tuple[float, float, float], x: float, y: float) -> bool:
    """Whether (x, y) lies in the lane of a walker at pose ``walker``: the original's rule."""
    wx, wy, yaw = walker
    dx, dy = x - wx, y - wy
    ahead = dx * math.cos(yaw) + dy * math.sin(yaw)
    side = -dx * math.sin(yaw) + dy * math.cos(yaw)
    return math.hypot(dx, dy) < 1.5 and ahead > 0.0 and abs(side) < 0.6


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_walkers_stop_for_each_other_and_no_standoff_lasts(seed: int) -> None:
    people = crowd(seed, walkers=6, idlers=12)
    stood = dict.fromkeys((p.name for p in walkers_of(people)), 0.0)
    waited_for_a_walker = False
    for _ in range(1200):
        before = {p.name: (p.x, p.y, p.yaw) for p in walkers_of(people)}
        people.step(0.1, robot=FAR_AWAY)
        for walker in walkers_of(people):
            ahead = [o for o in walkers_of(people) if o is not walker
                     and lane_holds(before[walker.name], *before[o.name][:2])]
            if (walker.x, walker.y) == before[walker.name][:2]:
                waited_for_a_walker |= bool(ahead)
                stood[walker.name] += 0.1
                assert stood[walker.name] <= 10.5, "stood longer than two standoffs"
            else:
                assert not ahead, "walked on with a walker in its lane"
                stood[walker.name] = 0.0
    assert waited_for_a_walker


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_idler_ever_stands_in_a_walker_lane(seed: int) -> None:
    # a walker stopped by someone who never moves would stand there for the whole run
    people = crowd(seed, walkers=3, idlers=14)
    standing = [(p.x, p.y) for p in idlers_of(people)]
    for _ in range(600):
        people.step(0.1, robot=FAR_AWAY)
        for walker in walkers_of(people):
            assert not any(lane_holds((walker.x, walker.y, walker.yaw), x, y)
                           for x, y in standing)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_idlers_without_idling_areas_stand_apart_anywhere_off_walls(seed: int) -> None:
    office = office_map()
    people = crowd(seed, idlers=20, occupancy_map=office)
    standing = idlers_of(people)
    spots = np.array([(p.x, p.y) for p in standing])
    gaps = np.hypot(*(spots[:, None, :] - spots[None, :, :]).transpose(2, 0, 1))
    assert gaps[~np.eye(len(spots), dtype=bool)].min() >= 1.0
    assert all(body_is_free(office, x, y, 0.55) for x, y in spots)
    assert all(-1.0 <= x <= 21.0 and -1.0 <= y <= 13.0 for x, y in spots)  # in the building
    assert len({round(p.yaw, 6) for p in standing}) == len(standing)
    for _ in range(20):
        people.step(0.1, robot=FAR_AWAY)
    assert [(p.x, p.y) for p in idlers_of(people)] == [tuple(s) for s in spots]


def test_targets_keep_no_idler_away_only_an_occupied_spot_does() -> None:
    # the original places idlers with no regard to targets; the walker keep-clear discs are
    # no exclusion zone for them, only a body already standing there is
    spots = [(p.x, p.y) for seed in range(8) for p in idlers_of(crowd(seed, idlers=20))]
    assert any(math.hypot(x - cx, y - cy) < r for x, y in spots for cx, cy, r in KEEP_CLEAR)
    guest = (2.0, 2.0, 0.25)
    for seed in range(8):
        people = Crowd(office_map(), rng=np.random.default_rng(seed), walkers=0, idlers=20,
                       taken_names=set(), keep_clear=[], occupied=[guest])
        assert all(math.hypot(p.x - 2.0, p.y - 2.0) >= 0.5 for p in idlers_of(people))


HALL_AREAS = (  # two idling areas in the hall and a line of spots along the room wall
    IdlingArea(min_x=1.0, min_y=6.0, max_x=4.0, max_y=7.0, yaw=0.0),
    IdlingArea(min_x=9.0, min_y=9.0, max_x=11.0, max_y=11.0, yaw=math.pi / 2),
    IdlingArea(min_x=16.0, min_y=4.5, max_x=19.0, max_y=4.5, yaw=-math.pi / 2),
)


def area_of(person: Person) -> IdlingArea | None:
    return next((a for a in HALL_AREAS if a.min_x <= person.x <= a.max_x
                 and a.min_y <= person.y <= a.max_y), None)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_idlers_stand_in_idling_areas_facing_their_yaw_and_apart(seed: int) -> None:
    # idling_humans.erb 20-40 and the loop after: a random area, a random point of it, the
    # area's yaw +- 0.5 rad, at least 1 m from every idler placed before
    people = Crowd(office_map(), rng=np.random.default_rng(seed), walkers=2, idlers=8,
                   taken_names=set(), keep_clear=KEEP_CLEAR, idling_areas=HALL_AREAS)
    standing = idlers_of(people)
    assert len(standing) == 8
    for person in standing:
        area = area_of(person)
        assert area is not None, person
        turn = math.remainder(person.yaw - area.yaw, 2 * math.pi)
        assert abs(turn) <= 0.5
    spots = np.array([(p.x, p.y) for p in standing])
    gaps = np.hypot(*(spots[:, None, :] - spots[None, :, :]).transpose(2, 0, 1))
    assert gaps[~np.eye(len(spots), dtype=bool)].min() >= 1.0


def test_idlers_use_every_idling_area_and_spread_their_yaw() -> None:
    people = [p for seed in range(6) for p in idlers_of(
        Crowd(office_map(), rng=np.random.default_rng(seed), walkers=0, idlers=8,
              taken_names=set(), keep_clear=[], idling_areas=HALL_AREAS))]
    assert {HALL_AREAS.index(area_of(p)) for p in people} == {0, 1, 2}
    turns = [math.remainder(p.yaw - area_of(p).yaw, 2 * math.pi) for p in people]
    assert min(turns) < -0.3 and max(turns) > 0.3


def test_too_many_idlers_for_the_idling_areas_are_refused_with_a_clear_message() -> None:
    with pytest.raises(CrowdError, match=r"room for only \d+ of 40 idlers in the world.s idling"):
        Crowd(office_map(), rng=np.random.default_rng(0), walkers=0, idlers=40,
              taken_names=set(), keep_clear=[], idling_areas=HALL_AREAS)
    walled = (IdlingArea(min_x=14.2, min_y=8.2, max_x=14.8, max_y=8.8, yaw=0.0),)  # the pillar
    with pytest.raises(CrowdError, match="no idling area has a free cell"):
        Crowd(office_map(), rng=np.random.default_rng(0), walkers=0, idlers=1,
              taken_names=set(), keep_clear=[], idling_areas=walled)


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


def office_crowd(seed: int) -> tuple[Crowd, World]:
    """The office's crowd as the engine makes it for the shipped task (guest, start occupied)."""
    office = load_world(DEFAULT_WORLD)
    task = office.task
    assert task is not None
    return Crowd(office.map, rng=np.random.default_rng(seed), walkers=0, idlers=30,
                 taken_names={task.guest_name}, keep_clear=[],
                 occupied=[(task.guest_x, task.guest_y, 0.25), (task.start_x, task.start_y, 0.3)],
                 idling_areas=office.idling_areas), office


def test_office_idlers_stand_in_its_idling_areas_and_some_near_the_shipped_pick_up() -> None:
    # RFID at the shipped pick-up hears an idler too: area 10 of idling_humans.erb lies 1.8 m
    # east of FrontElevator's centre
    near_pick_up = 0
    for seed in range(6):
        people, office = office_crowd(seed)
        standing = idlers_of(people)
        assert len(standing) == 30
        for person in standing:
            assert any(a.min_x <= person.x <= a.max_x and a.min_y <= person.y <= a.max_y
                       for a in office.idling_areas), person
        centre = office.areas["FrontElevator"].centre
        near_pick_up += any(math.hypot(p.x - centre[0], p.y - centre[1]) <= 2.0
                            for p in standing)
    assert near_pick_up >= 2


def test_many_lines_at_once_answer_as_each_line_alone() -> None:
    """The routes' corner cutting checks lines in batches; each answer must be the one the
    line alone gets, or the same seed would draw other routes."""
    from servicesim_sim.model.people import Clearance

    clearance = Clearance.of(office_map())
    walkable = clearance.metres >= 0.3
    rng = np.random.default_rng(7)
    for _ in range(40):
        start = rng.uniform((0.2, 0.2), (19.8, 11.8))  # inside the window
        ends = rng.uniform((0.2, 0.2), (19.8, 11.8), size=(int(rng.integers(1, 20)), 2))
        ends[0] = start  # a zero-length line among them
        batch = clearance.lines_are_clear(start, ends, walkable)
        alone = [clearance.line_is_clear(start, end, walkable) for end in ends]
        assert batch.tolist() == alone
    assert not all(alone) and any(alone), "the draws must meet both answers"


def test_a_map_measures_its_clearance_once_and_no_episode_can_change_it() -> None:
    from servicesim_sim.model.people import Clearance

    occupancy = office_map()
    first, again = Clearance.of(occupancy), Clearance.of(occupancy)
    assert first is again
    assert Clearance.of(office_map()) is not first  # another map object: its own
    with pytest.raises(ValueError):
        first.metres[0, 0] = 1.0


def walker_place_reference(walker: Walker) -> tuple[float, float, float]:
    """(x, y, yaw) of a walker as its route and ``travelled`` give them, worked out afresh:
    the leg found by bisection, the reverse heading by atan2."""
    xs, ys = walker.route[:, 0].tolist(), walker.route[:, 1].tolist()
    along = walker.along.tolist()
    leg = min(bisect.bisect_right(along, walker.travelled) - 1, len(along) - 2)
    t = (walker.travelled - along[leg]) / (along[leg + 1] - along[leg])
    heading = math.atan2(ys[leg + 1] - ys[leg], xs[leg + 1] - xs[leg])
    yaw = heading if walker.direction > 0 else math.atan2(-math.sin(heading), -math.cos(heading))
    return xs[leg] + t * (xs[leg + 1] - xs[leg]), ys[leg] + t * (ys[leg + 1] - ys[leg]), yaw


def test_walkers_stand_where_their_route_puts_them_bit_for_bit() -> None:
    rng = np.random.default_rng(4)
    for _ in range(60):
        points = rng.uniform(-10.0, 10.0, size=(int(rng.integers(2, 8)), 2))
        route = np.vstack([points, points[:1]])
        person = Person(name="human_00001", role=WALKER, x=0.0, y=0.0, yaw=0.0)
        walker = Walker.on(person, route, speed=1.0, start=float(rng.uniform()))
        for _ in range(300):
            if rng.uniform() < 0.02:
                walker.turn_back()
            else:
                walker.advance(walker.direction * float(rng.choice([0.036, 0.048, 0.0, 3.7])))
            yaw = person.yaw
            assert (person.x, person.y, yaw) == walker_place_reference(walker)
            assert (walker._cos, walker._sin) == (math.cos(yaw), math.sin(yaw))


def test_a_walkers_lane_test_answers_as_the_rule_for_each_point_bit_for_bit() -> None:
    rng = np.random.default_rng(6)
    for _ in range(200):
        route = rng.uniform(0.0, 4.0, size=(int(rng.integers(2, 6)), 2))
        person = Person(name="human_00001", role=WALKER, x=0.0, y=0.0, yaw=0.0)
        walker = Walker.on(person, np.vstack([route, route[:1]]), speed=1.0,
                           start=float(rng.uniform()))
        x, y, (cos, sin) = person.x, person.y, walker.facing_unit
        points = rng.uniform(0.0, 4.0, size=(int(rng.integers(1, 50)), 2))
        # some points right at the edge of the reach and of the lane, where rounding decides
        edge = len(points) // 2
        bearing = person.yaw + rng.uniform(-0.5, 0.5, size=edge)
        reach = WALKER_STOP_DISTANCE * (1.0 + rng.choice([-1e-15, 0.0, 1e-15], size=edge))
        points[:edge] = (x, y) + reach[:, None] * np.column_stack(
            [np.cos(bearing), np.sin(bearing)])
        places = [*points.tolist(), (x, y)]  # its own place too
        for below in (0.0, ROBOT_BELOW_WALKER):
            for px, py in places:
                assert walker.blocked([(px, py)], below=below) == in_stop_lane(
                    px - x, py - y, cos, sin, below=below)
            assert walker.blocked(places, below=below) == any(
                in_stop_lane(px - x, py - y, cos, sin, below=below) for px, py in places)
        assert not walker.blocked([(x, y)])  # never ahead of itself


def test_the_standing_points_near_a_leg_are_all_that_can_stop_a_walker_on_it() -> None:
    rng = np.random.default_rng(7)
    for _ in range(40):
        corners = rng.uniform(0.0, 8.0, size=(int(rng.integers(2, 6)), 2))
        route = np.vstack([corners, corners[:1]])
        standing = [tuple(point) for point in rng.uniform(-2.0, 10.0, size=(30, 2)).tolist()]
        near_legs = standing_near_legs(route, standing)
        assert len(near_legs) == len(route) - 1
        person = Person(name="human_00001", role=WALKER, x=0.0, y=0.0, yaw=0.0)
        walker = Walker.on(person, route, speed=1.0, start=0.0)
        for _ in range(400):
            walker.advance(float(rng.uniform(0.0, 0.5)))
            if rng.uniform() < 0.1:
                walker.turn_back()
            kept = near_legs[walker.leg]
            assert set(kept) <= set(standing)
            for point in standing:
                if point not in kept:
                    assert math.dist(point, (person.x, person.y)) > WALKER_STOP_DISTANCE
                    assert not walker.blocked([point])


def step_one_by_one(people: Crowd, dt: float, *, robot: tuple[float, float, float],
                    others: list[tuple[float, float]]) -> None:
    """The crowd's step as the rule says it, walker by walker, point by point."""
    standing = [(p.x, p.y) for p in idlers_of(people)]
    moving = [(w.person.x, w.person.y) for w in people.walkers]

    def stops(walker: Walker, points: list[tuple[float, float]], below: float = 0.0) -> bool:
        x, y, (cos, sin) = walker.person.x, walker.person.y, walker.facing_unit
        return any(in_stop_lane(px - x, py - y, cos, sin, below=below) for px, py in points)

    for index, walker in enumerate(people.walkers):
        by_people = (stops(walker, [robot[:2]], below=ROBOT_BELOW_WALKER)
                     or stops(walker, others + standing))
        by_walkers = stops(walker, moving[:index] + moving[index + 1:])
        if not (by_people or by_walkers):
            walker.waited = 0.0
            walker.advance(walker.direction * walker.speed * dt)
            continue
        walker.waited += dt
        if walker.waited >= (people.walker_patience_s if by_people else people.standoff_s):
            walker.turn_back()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_crowd_steps_as_the_rule_walker_by_walker_bit_for_bit(seed: int) -> None:
    arrays, reference = office_engine(seed).crowd, office_engine(seed).crowd
    rng = np.random.default_rng(seed)
    stopped = 0
    for step in range(3000):
        # the robot and the guest often just ahead of a walker, else somewhere about
        walker = arrays.walkers[int(rng.integers(len(arrays.walkers)))].person
        ahead = float(rng.uniform(0.5, 1.6))
        robot = (walker.x + ahead * math.cos(walker.yaw), walker.y + ahead * math.sin(walker.yaw),
                 0.0) if step % 3 else (float(rng.uniform(-20, 20)), 10.0, 0.0)
        guest = [(robot[0] + float(rng.normal(0, 1.0)), robot[1] + float(rng.normal(0, 1.0)))]
        arrays.step(0.04, robot=robot, others=guest)
        step_one_by_one(reference, 0.04, robot=robot, others=guest)
        for mine, theirs in zip(arrays.walkers, reference.walkers, strict=True):
            assert (mine.person.x, mine.person.y, mine.person.yaw, mine.waited,
                    mine.direction) == (theirs.person.x, theirs.person.y, theirs.person.yaw,
                                        theirs.waited, theirs.direction)
            stopped += mine.waited > 0.0
    assert stopped > 300  # the robot and the guest stopped walkers often


# ----------------------------------------------------------------- the world's walker routes
def office_engine(seed: int | None) -> SimEngine:
    office = load_world(DEFAULT_WORLD)
    return SimEngine(world=office, scenario=make_scenario(office, seed=seed))


def first_waypoint_and_route(walker: Walker, routes: tuple[WalkerRoute, ...]) -> tuple[str, int]:
    """Which of the world's loops the walker walks, from which waypoint, one way round."""
    points = [tuple(point) for point in walker.route.tolist()]
    for route in routes:
        for first in range(len(route.waypoints)):
            loop = route.waypoints[first:] + route.waypoints[:first + 1]
            if points == [tuple(point) for point in loop]:
                return route.name, first
    raise AssertionError(f"{walker.person.name} walks none of the world's loops")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_office_walkers_draw_the_originals_loops_speeds_and_first_waypoints(seed: int) -> None:
    sim = office_engine(seed)
    routes = sim.world.walker_routes
    assert sum(route.weight for route in routes) == 12 and len(routes) == 9
    starts = []
    for walker in sim.crowd.walkers:
        name, first = first_waypoint_and_route(walker, routes)
        starts.append(dict((r.name, r) for r in routes)[name].waypoints[first])
        assert 0.9 <= walker.speed <= 1.2 and walker.direction == 1
    assert len(set(starts)) == len(starts)  # no two walkers start at one waypoint


def test_the_shipped_task_plays_the_shipped_worlds_walkers_three_passing_the_start() -> None:
    sim = office_engine(None)
    walkers = sim.crowd.walkers
    assert [(*first_waypoint_and_route(w, sim.world.walker_routes), round(w.speed, 4))
            for w in walkers] == [tuple(entry) for entry in SHIPPED_WALKERS]
    task = sim.scenario.task
    passing = [w for w in walkers
               if min(math.hypot(x - task.start_x, y - task.start_y)
                      for x, y in dense(w.route)) <= 0.55]
    assert len(passing) == 3


def dense(route: np.ndarray) -> list[tuple[float, float]]:
    """Points every 5 cm along a polyline."""
    points = []
    for (x0, y0), (x1, y1) in itertools.pairwise(route.tolist()):
        steps = max(1, int(math.hypot(x1 - x0, y1 - y0) / 0.05))
        points += [(x0 + (x1 - x0) * i / steps, y0 + (y1 - y0) * i / steps)
                   for i in range(steps)]
    return points


def test_on_the_worlds_routes_an_idler_in_the_lane_stops_a_walker_for_good() -> None:
    route = WalkerRoute(name="hall", weight=1, waypoints=((1.0, 6.0), (18.0, 6.0), (18.0, 10.0),
                                                          (1.0, 10.0)))
    spot = IdlingArea(min_x=9.0, min_y=6.0, max_x=9.0, max_y=6.0, yaw=0.0)
    people = Crowd(office_map(), rng=np.random.default_rng(0), walkers=1, idlers=1,
                   taken_names=set(), keep_clear=[], idling_areas=(spot,), routes=(route,),
                   placed=(PlacedWalker(route="hall", start=0, speed=1.0),))
    walker = people.walkers[0]
    for _ in range(600):  # 60 s
        people.step(0.1, robot=FAR_AWAY)
    assert 7.4 <= walker.person.x < 9.0 and walker.person.y == 6.0  # stopped short of the idler
    assert walker.direction == 1 and walker.waited > 50.0  # it never turns back


def test_on_the_worlds_routes_walkers_meeting_head_on_wait_for_each_other_for_good() -> None:
    east = WalkerRoute(name="east", weight=1, waypoints=((1.0, 6.0), (18.0, 6.0)))
    west = WalkerRoute(name="west", weight=1, waypoints=((18.0, 6.0), (1.0, 6.0)))
    people = Crowd(office_map(), rng=np.random.default_rng(0), walkers=2, idlers=0,
                   taken_names=set(), keep_clear=[], routes=(east, west),
                   placed=(PlacedWalker(route="east", start=0, speed=1.0),
                           PlacedWalker(route="west", start=0, speed=1.0)))
    for _ in range(600):  # 60 s
        people.step(0.1, robot=FAR_AWAY)
    one, other = people.walkers
    assert 1.0 < other.person.x - one.person.x < 1.5  # face to face, in each other's lane
    assert (one.direction, other.direction) == (1, 1) and min(one.waited, other.waited) > 40.0
