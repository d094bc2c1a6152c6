"""The kinematic lower bound of a task: known answers on small worlds, never above a real
mission, and the command's one-line errors.

The known answers are routes one can draw by hand (a straight corridor, an open room, a wall
to go round); the bound must lie at or below the route's time at top speed, and within the
lattice's known excess (1.3 %) and the junctions' slack of it.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from servicesim_sim.model.robot import MAX_SPEED
from servicesim_sim.model.scenario import Difficulty, Scenario, make_scenario
from servicesim_sim.navigation.geodesic import step_directions, worst_excess_ratio
from servicesim_sim.task_bound import TaskBoundError, free_lattice, main, task_bound
from servicesim_sim.world.files import (
    DEFAULT_WORLD,
    AreaBox,
    OccupancyMap,
    TaskSpec,
    World,
    load_world,
)

RESOLUTION = 0.05
TIGHT = 0.97  # the bound is within 3 % of a hand-drawn shortest route's time
PROG = "python -m servicesim_sim.task_bound: error: "


def walled_world(*, width: float, height: float, areas: dict[str, AreaBox],
                 walls: tuple[tuple[float, float, float, float], ...] = ()) -> World:
    """Free space ``[0, width] x [0, height]`` walled round (0.5 m of wall), with extra wall
    boxes ``(min_x, min_y, max_x, max_y)``, on a 0.05 m map with its origin at (-0.5, -0.5)."""
    cols, rows = round((width + 1.0) / RESOLUTION), round((height + 1.0) / RESOLUTION)
    x = -0.5 + (np.arange(cols) + 0.5) * RESOLUTION
    y = -0.5 + (np.arange(rows) + 0.5) * RESOLUTION
    xx, yy = np.meshgrid(x, y)
    blocked = (xx < 0) | (xx > width) | (yy < 0) | (yy > height)
    for min_x, min_y, max_x, max_y in walls:
        blocked |= (xx >= min_x) & (xx <= max_x) & (yy >= min_y) & (yy <= max_y)
    grid = np.where(blocked, 100, 0).astype(np.int8)
    occupancy = OccupancyMap(grid=grid, resolution=RESOLUTION, origin_x=-0.5, origin_y=-0.5)
    return World(name="test", path=Path("test-world"), map=occupancy, areas=areas,
                 targets=tuple(areas))


def scenario(*, guest: tuple[float, float], start: tuple[float, float],
             guest_path: str = "trail") -> Scenario:
    task = TaskSpec(pick_up="PickUp", drop_off="DropOff", guest_name="human_10000",
                    guest_x=guest[0], guest_y=guest[1], guest_yaw=0.0, start_area="Start",
                    start_x=start[0], start_y=start[1], start_yaw=1.0)
    return Scenario(task=task, drift_times=(), people_seed=0, knob_seed=0,
                    difficulty=Difficulty(guest_path=guest_path), seed=None)


def corridor() -> World:
    """A 20 x 2 m corridor: start area at its west end, pick-up in the middle, drop-off east."""
    return walled_world(width=20.0, height=2.0, areas={
        "Start": AreaBox(0.0, 0.0, 2.0, 2.0), "PickUp": AreaBox(8.0, 0.0, 10.0, 2.0),
        "DropOff": AreaBox(16.0, 0.0, 18.0, 2.0)})


def assert_tight_bound(bound_s: float, route_m: float) -> None:
    exact = route_m / MAX_SPEED
    assert bound_s <= exact + 1e-9, f"{bound_s} s is above the {exact} s of a feasible route"
    assert bound_s >= TIGHT * exact, f"{bound_s} s is a loose bound of {exact} s"


def test_the_excess_ratio_is_the_worst_staircase_over_its_segment() -> None:
    assert len(step_directions(1)) == 8
    assert len(step_directions(3)) == 32
    assert worst_excess_ratio(1) == pytest.approx(1.0 / math.cos(math.radians(22.5)))
    # the widest gap between neighbouring steps for max_step 3 is atan(1/3), 18.4 degrees
    assert worst_excess_ratio(3) == pytest.approx(1.0 / math.cos(math.atan(1.0 / 3.0) / 2.0))


def test_a_straight_corridor_there_and_back() -> None:
    # 7 m to the pick-up area (the guest then within 2 m), 8 m on into the drop-off area,
    # 14 m back into the start area: 29 m
    bound = task_bound(corridor(), scenario(guest=(9.0, 1.0), start=(1.0, 1.0)))
    assert_tight_bound(bound.bound_s, 29.0)
    lengths = [leg.length_m for leg in bound.legs]
    assert lengths == pytest.approx([7.0, 0.0, 8.0, 14.0], rel=0.015, abs=0.06)
    assert [leg.checkpoint for leg in bound.legs] == [
        "go_to_pick_up", "pick_up_guest", "drop_off_guest", "return_to_start"]
    assert bound.legs[2].end[0] == pytest.approx(16.0, abs=0.06)
    assert bound.waits_s == 0.0


def test_the_pick_up_needs_the_area_first_then_the_guest_within_reach() -> None:
    # a guest 3 m short of the pick-up area (out of range, as in the hard set): the robot
    # passes within 2 m of them on its way, but the pick-up counts only after the area
    bound = task_bound(corridor(), scenario(guest=(5.0, 1.0), start=(1.0, 1.0)))
    assert [leg.length_m for leg in bound.legs] == pytest.approx([7.0, 1.0, 9.0, 14.0],
                                                                 rel=0.015, abs=0.06)
    assert_tight_bound(bound.bound_s, 7.0 + 1.0 + 9.0 + 14.0)


def test_the_original_straight_guest_is_dropped_off_from_4_m() -> None:
    # the guest walks through walls and is lost beyond 4 m: the robot need only get to 12 m
    bound = task_bound(corridor(), scenario(guest=(9.0, 1.0), start=(1.0, 1.0),
                                            guest_path="straight"))
    assert_tight_bound(bound.bound_s, 7.0 + 4.0 + 10.0)


def test_a_guest_who_walks_through_the_drop_off_area_to_the_robot_needs_no_drive_there() -> None:
    # the guest (out of range, east of the pick-up area) walks straight to the robot once
    # picked up, through the drop-off area between them: the drop-off can come at once
    hall = walled_world(width=20.0, height=2.0, areas={
        "Start": AreaBox(0.0, 0.0, 2.0, 2.0), "PickUp": AreaBox(4.0, 0.0, 6.0, 2.0),
        "DropOff": AreaBox(6.5, 0.0, 7.0, 2.0)})
    bound = task_bound(hall, scenario(guest=(7.5, 1.0), start=(1.0, 1.0)))
    # 3 m into the pick-up area, 1.5 m on to within 2 m of the guest, 3.5 m back: 8 m
    assert 0.95 * 16.0 <= bound.bound_s <= 16.0
    assert bound.legs[2].length_m == 0.0


def test_diagonal_legs_in_an_open_room() -> None:
    room = walled_world(width=10.0, height=10.0, areas={
        "Start": AreaBox(0.5, 0.5, 1.5, 1.5), "PickUp": AreaBox(6.0, 6.0, 7.0, 7.0),
        "DropOff": AreaBox(6.0, 1.0, 7.0, 2.0)})
    bound = task_bound(room, scenario(guest=(6.5, 6.5), start=(1.0, 1.0)))
    # to the pick-up area's corner (6, 6), down to (6, 2), back to the start area's (1.5, 1.5)
    assert_tight_bound(bound.bound_s, 5.0 * math.sqrt(2.0) + 4.0 + math.hypot(4.5, 0.5))


def test_a_wall_in_the_way_is_driven_round() -> None:
    # a wall from the floor to 8 m splits the room; the straight line to the pick-up is 7 m
    room = walled_world(width=10.0, height=10.0, walls=((4.9, -1.0, 5.1, 8.0),), areas={
        "Start": AreaBox(0.5, 0.5, 1.5, 1.5), "PickUp": AreaBox(7.5, 0.5, 8.5, 1.5),
        "DropOff": AreaBox(7.5, 2.5, 8.5, 3.5)})
    bound = task_bound(room, scenario(guest=(8.0, 1.0), start=(1.0, 1.0)))
    # round the wall's tip, clear of it by the body radius: at least 2 x hypot(3.4, 7.2)
    around = 2.0 * math.hypot(5.0 - 0.1 - 0.25 - 1.5, 8.0 - 1.0)
    assert around * 0.97 < bound.legs[0].length_m < 2.0 * math.hypot(4.0, 7.6)


def test_an_area_the_robot_cannot_reach_has_no_bound() -> None:
    room = walled_world(width=10.0, height=10.0, walls=((4.9, -1.0, 5.1, 11.0),), areas={
        "Start": AreaBox(0.5, 0.5, 1.5, 1.5), "PickUp": AreaBox(7.5, 0.5, 8.5, 1.5),
        "DropOff": AreaBox(1.5, 2.5, 2.5, 3.5)})
    with pytest.raises(TaskBoundError, match="go_to_pick_up"):
        task_bound(room, scenario(guest=(8.0, 1.0), start=(1.0, 1.0)))


#: Completed missions of an earlier evaluation (commit 7ee4ae9, the office, speed 20): (set,
#: seed, task sim time s), those closest to their bound of the 66 per set and executive:
#: the tree's best three on random (1.17-1.30 times the bound), on the shipped task and on
#: hard; the seed's best on random.
REAL_MISSIONS = (("random", 13, 132.04), ("random", 55, 158.08), ("random", 17, 97.12),
                 ("default", None, 162.7), ("hard", 26, 180.7), ("random", 18, 188.68))


def test_no_real_mission_beat_its_bound() -> None:
    office = load_world(DEFAULT_WORLD)
    lattice = free_lattice(office)  # the office's search graph, for every task (as the command)
    for scenario_set, seed, mission_s in REAL_MISSIONS:
        difficulty = Difficulty.hard() if scenario_set == "hard" else Difficulty.default()
        bound = task_bound(office, make_scenario(office, seed=seed, difficulty=difficulty),
                           lattice=lattice)
        assert 0.65 * mission_s < bound.bound_s <= mission_s, (scenario_set, seed)


# ------------------------------------------------------------------------------ the command
def one_line_error(capsys: pytest.CaptureFixture[str], code: int, *named: str) -> None:
    captured = capsys.readouterr()
    assert code == 2
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(PROG), captured.err
    for text in named:
        assert text in lines[0]
    assert captured.out == ""


def exit_code(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as stop:  # argparse's own errors
        return int(stop.code or 0)


@pytest.mark.parametrize(("argv", "named"), [
    (["--seed", "-1"], ["--seed -1"]),
    (["--bogus"], ["--bogus"]),
    (["--world", "/nonexistent/world.yaml"], ["/nonexistent/world.yaml"]),
    (["--difficulty", "extreme"], ["--difficulty"]),
    (["--episodes", "/nonexistent/episodes.json"], ["--episodes", "/nonexistent"]),
])
def test_bad_arguments_are_one_line_and_exit_2(capsys: pytest.CaptureFixture[str],
                                               argv: list[str], named: list[str]) -> None:
    one_line_error(capsys, exit_code(argv), *named)


@pytest.mark.parametrize(("content", "named"), [
    ("not json", ["not JSON"]),
    ('{"seed": 1}', ["JSON list"]),
    ('[{"seed": "one"}]', ["episode 0", "seed must be an integer"]),
    ('[{"seed": 1}, 7]', ["episode 1", "must be an object"]),
    ('[{"seed": 1, "speed": 2}]', ["episode 0", "unknown key 'speed'"]),
    ('[{"seed": 1, "sim_args": "--difficulty hard"}]', ["episode 0", "list of strings"]),
    ('[{"seed": 1}, {"seed": 2, "sim_args": ["--difficulty", "extreme"]}]',
     ["episode 1", "--difficulty"]),
    ('[{"seed": 1, "world": "/nonexistent/w.yaml"}]', ["episode 0", "/nonexistent/w.yaml"]),
])
def test_a_bad_episodes_file_is_one_line_naming_the_episode(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str,
        named: list[str]) -> None:
    episodes = tmp_path / "episodes.json"
    episodes.write_text(content)
    one_line_error(capsys, exit_code(["--episodes", str(episodes)]), *named)


@pytest.mark.parametrize(("change", "named"), [
    (("walkers: 0", "walkers: 1000000000"), "people.walkers must be within 0..200"),
    (("idlers: 0}", "idlers: 0}\nidling_areas:\n  - {min: [-0.5, -0.5], max: [-0.45, 2.0], "
                    "yaw: 0.0}"), "idling_areas[0] has no free map cell"),
])
def test_a_world_the_simulator_refuses_is_refused_by_the_bound_too(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], change: tuple[str, str],
        named: str) -> None:
    """The bound reads worlds with the simulator's own loader: what one refuses, both do."""
    world = tmp_path / "world.yaml"
    write_corridor_world(tmp_path, world)
    world.write_text(world.read_text().replace(*change))
    one_line_error(capsys, exit_code(["--world", str(world), "--seed", "1"]), str(world), named)


def test_episodes_and_a_seed_on_the_command_line_are_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    episodes = tmp_path / "episodes.json"
    episodes.write_text("[]")
    one_line_error(capsys, exit_code(["--episodes", str(episodes), "--seed", "3"]),
                   "in the file")


def test_the_command_prints_one_bound_per_episode_in_order(tmp_path: Path) -> None:
    world = tmp_path / "world.yaml"
    write_corridor_world(tmp_path, world)
    episodes = tmp_path / "episodes.json"
    episodes.write_text(json.dumps([{"world": str(world), "seed": 3, "sim_args": []},
                                    {"world": str(world), "seed": 4,
                                     "sim_args": ["--difficulty", "hard"]}]))
    done = subprocess.run([sys.executable, "-m", "servicesim_sim.task_bound", "--episodes",
                           str(episodes)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    answers = json.loads(done.stdout)
    loaded = load_world(world)
    for answer, (seed, difficulty) in zip(answers, ((3, Difficulty.default()),
                                                    (4, Difficulty.hard())), strict=True):
        expected = task_bound(loaded, make_scenario(loaded, seed=seed, difficulty=difficulty))
        assert answer["seed"] == seed
        assert answer["bound_s"] == expected.bound_s > 0.0
        assert [leg["checkpoint"] for leg in answer["legs"]] == [
            leg.checkpoint for leg in expected.legs]


def write_corridor_world(directory: Path, world: Path) -> None:
    """A 12 x 3 m hall at 0.1 m a cell with three target areas along it, on disk."""
    cols, rows = 130, 40
    pixels = bytearray(b"\xfe" * cols * rows)
    for index in range(cols * rows):
        row, col = divmod(index, cols)
        if row < 5 or row >= rows - 5 or col < 5 or col >= cols - 5:
            pixels[index] = 0
    (directory / "hall.pgm").write_bytes(f"P5 {cols} {rows} 255\n".encode() + bytes(pixels))
    (directory / "hall.yaml").write_text(
        "image: hall.pgm\nresolution: 0.1\norigin: [-0.5, -0.5, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    world.write_text("name: hall\nmap: hall.yaml\npeople: {walkers: 0, idlers: 0}\nareas:\n"
                     "  West: {min: [0.0, 0.0], max: [3.0, 3.0]}\n"
                     "  Middle: {min: [4.5, 0.0], max: [7.5, 3.0]}\n"
                     "  East: {min: [9.0, 0.0], max: [12.0, 3.0]}\n")
