"""A task the simulator plays can be played: navigation finds a way from the robot's start to
the pick-up area, the drop-off area and back with every idler in place.

The first world here is a hall with a closet off it, through one 1.2 m door. One of its two idling
spots stands in that doorway: an idler there cuts the closet off (it is small enough that the
idlers' own rule, never to split the robot's floor, lets a pocket that size go), so a draw
that puts the idler there is drawn again; with the door walled up the task is refused. The
second (a deeper closet, the guest waiting inside) has walkers on a loop at its door: the
waiting guest holds them there for good, which cuts the closet off alike.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.people import IDLER, WALKER, WALKER_STOP_DISTANCE, WalkerStartError
from servicesim_sim.model.playable import GUEST, playable_engine, unreachable_areas
from servicesim_sim.model.scenario import Difficulty, ScenarioError, make_scenario
from servicesim_sim.world.files import DEFAULT_WORLD, World, load_world

RESOLUTION = 0.05
DOORWAY = (4.05, 1.5)
WORLD = """\
name: closet
map: map.yaml
areas:
  Closet: {min: [4.2, 0.8], max: [5.5, 2.2]}
  Hall: {min: [0.5, 0.5], max: [2.0, 2.0]}
  Entry: {min: [2.5, 0.5], max: [3.5, 2.5]}
task:
  pick_up: Closet
  drop_off: Hall
  guest: {name: human_12345, x: 5.0, y: 1.5, yaw: 0.0}
  start: {area: Entry, x: 3.0, y: 2.2, yaw: 0.0}
people: {walkers: 0, idlers: 1}
idling_areas:
  - {min: [4.05, 1.5], max: [4.05, 1.5], yaw: 0.0}
  - {min: [1.0, 2.6], max: [1.0, 2.6], yaw: 0.0}
"""


def box(pixels: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int) -> None:
    """Paint [x0, x1] x [y0, y1] (metres); image rows count down from the top."""
    rows = pixels.shape[0]
    c0, c1 = round(x0 / RESOLUTION), round(x1 / RESOLUTION)
    r0, r1 = rows - round(y1 / RESOLUTION), rows - round(y0 / RESOLUTION)
    pixels[r0:r1, c0:c1] = value


def closet_world(directory: Path, *, door: bool = True) -> Path:
    pixels = np.full((round(3.0 / RESOLUTION), round(6.0 / RESOLUTION)), 0, dtype=np.uint8)
    box(pixels, 0.1, 0.1, 4.0, 2.9, 254)  # the hall
    box(pixels, 4.1, 0.7, 5.6, 2.3, 254)  # the closet, 1.5 x 1.6 m
    if door:
        box(pixels, 4.0, 0.9, 4.1, 2.1, 254)  # its 1.2 m door
    Image.fromarray(pixels).save(directory / "map.pgm")
    (directory / "map.yaml").write_text(
        f"image: map.pgm\nresolution: {RESOLUTION}\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    path = directory / "world.yaml"
    # without a door the doorway's idling spot is wall, which a world may not name
    path.write_text(WORLD if door else WORLD.replace(
        "  - {min: [4.05, 1.5], max: [4.05, 1.5], yaw: 0.0}\n", ""))
    return path


def idler_spot(engine: SimEngine) -> tuple[float, float]:
    (spot,) = [(x, y) for _, role, x, y in engine.crowd.states() if role == IDLER]
    return spot


def test_an_idler_in_the_only_doorway_cuts_the_pick_up_area_off(tmp_path: Path) -> None:
    world = load_world(closet_world(tmp_path))
    blocked = [draw for draw in range(10) if idler_spot(SimEngine(
        world=world, scenario=make_scenario(world, draw=draw))) == DOORWAY]
    assert blocked, "no draw put the idler in the doorway"
    engine = SimEngine(world=world, scenario=make_scenario(world, draw=blocked[0]))
    assert unreachable_areas(engine) == ["Closet", GUEST]
    assert unreachable_areas(engine, with_idlers=False) == []


def test_a_draw_that_cannot_be_played_is_drawn_again_the_same_way_every_time(
        tmp_path: Path) -> None:
    world = load_world(closet_world(tmp_path))
    engine = playable_engine(world, seed=None)
    assert idler_spot(engine) != DOORWAY and unreachable_areas(engine) == []
    assert engine.scenario.task.pick_up == "Closet"  # the fixed task, other people
    again = playable_engine(world, seed=None)
    assert (again.scenario, idler_spot(again)) == (engine.scenario, idler_spot(engine))
    for seed in range(4):  # random tasks on this world: every one of them playable
        assert unreachable_areas(playable_engine(world, seed=seed)) == []


def test_the_office_plays_its_shipped_task_and_seeds_at_their_first_draw() -> None:
    office: World = load_world(DEFAULT_WORLD)
    for seed in (None, 0, 1):
        engine = playable_engine(office, seed=seed)
        assert engine.scenario == make_scenario(office, seed=seed)


def test_a_fixed_task_the_walls_cut_off_is_refused_in_one_line(tmp_path: Path) -> None:
    world = load_world(closet_world(tmp_path, door=False))
    with pytest.raises(ScenarioError, match="the task cannot be played: navigation finds no "
                                            "way from the robot's start to Closet"):
        playable_engine(world, seed=None)
    result = subprocess.run([sys.executable, "-m", "servicesim_sim", "--world",
                             str(tmp_path / "world.yaml")],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and result.stdout == ""
    (line,) = result.stderr.strip().splitlines()
    assert "the task cannot be played" in line and "Closet" in line


def test_a_seed_whose_walkers_find_no_start_is_drawn_again_the_same_way_every_time() -> None:
    """Seeds 59 and 41 (hard) draw a guest and a robot start beside the short 'private_a'
    loop, whose other waypoints the walkers drawn onto it already start at: the first draw
    has no free start for a walker, so the seed plays its next draw, every time."""
    office: World = load_world(DEFAULT_WORLD)
    for seed, difficulty in ((59, Difficulty.default()), (41, Difficulty.hard())):
        first = make_scenario(office, seed=seed, difficulty=difficulty)
        with pytest.raises(WalkerStartError, match="'private_a'"):
            SimEngine(world=office, scenario=first)
        engine = playable_engine(office, seed=seed, difficulty=difficulty)
        assert engine.scenario == make_scenario(office, seed=seed, difficulty=difficulty,
                                                draw=1)
        assert unreachable_areas(engine) == []
        task = engine.scenario.task
        walkers = [(x, y) for _, role, x, y in engine.crowd.states() if role == WALKER]
        assert len(walkers) == office.people.walkers
        for x, y in walkers:  # none starts within a stop distance of the robot or the guest
            assert min(np.hypot(x - task.start_x, y - task.start_y),
                       np.hypot(x - task.guest_x, y - task.guest_y)) >= WALKER_STOP_DISTANCE
        again = playable_engine(office, seed=seed, difficulty=difficulty)
        assert again.crowd.states() == engine.crowd.states()


# A hall and a deep closet through one door, with the guest waiting 1.5 m inside it: a walker
# on the 'door' loop walks at the door, has the guest in its lane from the doorway on and
# stands there for good (the world's routes: it waits as long as its lane is blocked).
GUEST_IN_THE_LANE = """\
name: deep closet
map: map.yaml
areas:
  Closet: {min: [4.2, 0.8], max: [6.5, 2.2]}
  Hall: {min: [0.5, 0.5], max: [2.0, 2.0]}
  Entry: {min: [2.5, 0.5], max: [3.5, 2.5]}
task:
  pick_up: Closet
  drop_off: Hall
  guest: {name: human_12345, x: 5.55, y: 1.5, yaw: 0.0}
  start: {area: Entry, x: 3.0, y: 2.2, yaw: 0.0}
people: {walkers: 2, idlers: 0}
walker_routes:
  - {name: door, waypoints: [[0.5, 1.5], [1.5, 1.5], [4.6, 1.5], [2.0, 2.7], [0.5, 2.7]]}
  - {name: corner, waypoints: [[0.4, 0.4], [1.4, 0.4], [1.4, 0.9], [0.4, 0.9]]}
"""
DEEP_DOORWAY_X = 4.05


def deep_closet_world(directory: Path) -> Path:
    pixels = np.full((round(3.0 / RESOLUTION), round(7.0 / RESOLUTION)), 0, dtype=np.uint8)
    box(pixels, 0.1, 0.1, 4.0, 2.9, 254)  # the hall
    box(pixels, 4.1, 0.7, 6.6, 2.3, 254)  # the closet, 2.5 x 1.6 m
    box(pixels, 4.0, 0.9, 4.1, 2.1, 254)  # its 1.2 m door
    Image.fromarray(pixels).save(directory / "map.pgm")
    (directory / "map.yaml").write_text(
        f"image: map.pgm\nresolution: {RESOLUTION}\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    path = directory / "world.yaml"
    path.write_text(GUEST_IN_THE_LANE)
    return path


def held(engine: SimEngine) -> list[tuple[float, float]]:
    task = engine.scenario.task
    return engine.crowd.held_for_good(others=[(task.guest_x, task.guest_y)])


def door_walkers(engine: SimEngine) -> int:
    return sum(1 for walker in engine.crowd.walkers if walker.route[:, 0].max() > 4.0)


def draws(world: World) -> list[SimEngine]:
    engines = []
    for draw in range(12):
        try:
            engines.append(SimEngine(world=world, scenario=make_scenario(world, draw=draw)))
        except WalkerStartError:
            continue
    return engines


def test_a_walker_the_waiting_guest_holds_in_the_only_doorway_cuts_the_closet_off(
        tmp_path: Path) -> None:
    world = load_world(deep_closet_world(tmp_path))
    engines = draws(world)
    one = [engine for engine in engines if door_walkers(engine) == 1]
    assert one, "no draw put one walker on the door loop"
    ((x, y),) = held(one[0])
    assert DEEP_DOORWAY_X - 0.1 < x < DEEP_DOORWAY_X + 0.1 and y == pytest.approx(1.5)
    assert unreachable_areas(one[0]) == ["Closet", GUEST]
    assert unreachable_areas(one[0], with_idlers=False) == []
    clear = [engine for engine in engines if door_walkers(engine) == 0]
    assert clear and held(clear[0]) == [] and unreachable_areas(clear[0]) == []


def test_walkers_queue_behind_a_walker_held_for_good(tmp_path: Path) -> None:
    world = load_world(deep_closet_world(tmp_path))
    two = [engine for engine in draws(world) if door_walkers(engine) == 2]
    assert two, "no draw put both walkers on the door loop"
    first, second = held(two[0])
    assert DEEP_DOORWAY_X - 0.1 < first[0] < DEEP_DOORWAY_X + 0.1
    # the second stops as the first did, with the first in its lane: 1.5 m behind it
    assert first[0] - second[0] == pytest.approx(WALKER_STOP_DISTANCE, abs=0.1)
    assert second[1] == pytest.approx(1.5)


def test_the_walker_model_stands_where_the_walking_crowd_stands_for_good(
        tmp_path: Path) -> None:
    """Walked on for a minute (the robot parked at its start), the held walkers stand where
    held_for_good said, and wait."""
    world = load_world(deep_closet_world(tmp_path))
    engine = next(engine for engine in draws(world) if door_walkers(engine) == 2)
    assert len(stand_where_held(engine, seconds=60.0)) == 2


def stand_where_held(engine: SimEngine, *, seconds: float) -> list[tuple[float, float]]:
    """What held_for_good says, once the crowd has walked ``seconds`` on (the robot parked at
    its start, the guest waiting) and stands just there: the walkers who have waited a while
    stand within 0.15 m of its spots, one each."""
    expected = sorted(held(engine))
    task = engine.scenario.task
    for _ in range(round(seconds / 0.1)):
        engine.crowd.step(0.1, robot=(task.start_x, task.start_y, task.start_yaw),
                          others=[(task.guest_x, task.guest_y)])
    standing = sorted((w.person.x, w.person.y) for w in engine.crowd.walkers if w.waited > 1.0)
    assert len(standing) == len(expected)
    for (x, y), (ex, ey) in zip(standing, expected, strict=True):
        assert math.hypot(x - ex, y - ey) < 0.15
    return expected


def test_a_draw_whose_walker_the_guest_holds_in_the_doorway_is_drawn_again(
        tmp_path: Path) -> None:
    world = load_world(deep_closet_world(tmp_path))
    first = SimEngine(world=world, scenario=make_scenario(world))
    assert door_walkers(first) == 1 and unreachable_areas(first) == ["Closet", GUEST]
    engine = playable_engine(world, seed=None)
    assert unreachable_areas(engine) == [] and door_walkers(engine) == 0
    assert engine.scenario == make_scenario(world, draw=1)  # the first draw that plays
    again = playable_engine(world, seed=None)
    assert (again.scenario, again.crowd.states()) == (engine.scenario, engine.crowd.states())


def test_seeds_whose_walkers_stand_in_the_cafes_only_door_play_their_next_draw() -> None:
    """Random 43 and 91 and hard 14: the waiting guest holds a walker in the only door of the
    room the robot must reach, for good (in the cafe's for 43 and 14, hard 14's guest drawn
    out of range into the cafe); each seed plays its next draw, every time."""
    office: World = load_world(DEFAULT_WORLD)
    for seed, difficulty in ((43, Difficulty.default()), (91, Difficulty.default()),
                             (14, Difficulty.hard())):
        first = SimEngine(world=office, scenario=make_scenario(office, seed=seed,
                                                               difficulty=difficulty))
        assert GUEST in unreachable_areas(first)
        assert unreachable_areas(first, with_idlers=False) == []
        engine = playable_engine(office, seed=seed, difficulty=difficulty)
        assert engine.scenario == make_scenario(office, seed=seed, difficulty=difficulty,
                                                draw=1)
        assert unreachable_areas(engine) == []
        again = playable_engine(office, seed=seed, difficulty=difficulty)
        assert again.crowd.states() == engine.crowd.states()


def test_a_walker_that_passes_before_the_held_walker_stands_queues_behind_it_a_lap_later() -> None:
    """Hard 40's first draw: the guest, out of range outside PrivateOfficeC, holds walker 20520
    in the corridor for good from 8 s on. Walker 59185 starts 4 m west of that spot and walks
    east past it at once, before 20520 gets there; it comes back round its loop from the east
    and stands behind 20520, in the office's door, from about 38 s on. The check marks it
    there, as the walking crowd (the robot parked at its start) stands, not at its start; the
    pick-up area is cut off, and the seed plays its next draw."""
    office: World = load_world(DEFAULT_WORLD)
    first = SimEngine(world=office, scenario=make_scenario(office, seed=40,
                                                           difficulty=Difficulty.hard()))
    assert unreachable_areas(first) == [first.scenario.task.pick_up] == ["PrivateOfficeC"]
    walker = next(w for w in first.crowd.walkers if w.person.name == "human_59185")
    start = (walker.person.x, walker.person.y)
    expected = stand_where_held(first, seconds=120.0)
    assert len(expected) == 3
    assert all(math.hypot(x - start[0], y - start[1]) > 0.3 for x, y in expected)
    assert math.hypot(walker.person.x + 20.7, walker.person.y - 18.8) < 0.2  # in the door
    engine = playable_engine(office, seed=40, difficulty=Difficulty.hard())
    assert engine.scenario == make_scenario(office, seed=40, difficulty=Difficulty.hard(), draw=1)
