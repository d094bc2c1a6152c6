"""Worlds the simulator cannot play are one line on stderr and exit status 2, never a traceback.

Some break the world file itself (no areas, an area of zero size, a map file that is missing);
others load and only fail once the world is set in motion: a single target area and no fixed
task, too few targets for a random task, an area with no free spot, a guest that cannot stand
out of RFID range, more idlers than the map holds. All are found before ROS is touched. A
small world that can be played still is.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from servicesim_sim.model.scenario import Difficulty
from servicesim_sim.settings import SimSettings, playable_engine
from servicesim_sim.world.files import DEFAULT_WORLD, load_world

SIM = [sys.executable, "-m", "servicesim_sim"]
OFFICE_MAP = DEFAULT_WORLD.parent / "map.yaml"
ROOM_AREAS = """areas:
  West: {min: [0.5, 0.5], max: [1.5, 1.5]}
  East: {min: [2.5, 0.5], max: [3.5, 1.5]}
  North: {min: [0.5, 2.5], max: [1.5, 3.5]}
"""
#: Three areas in a 2.5 m room: no free spot in it lies 2.6 m from an area's centre.
CLOSET_AREAS = """areas:
  West: {min: [0.3, 0.3], max: [1.0, 1.0]}
  East: {min: [1.5, 0.3], max: [2.2, 1.0]}
  North: {min: [0.3, 1.5], max: [1.0, 2.2]}
"""


def simulator(*arguments: str) -> subprocess.CompletedProcess[str]:
    """The simulator's run; a world it would play instead runs into the timeout."""
    return subprocess.run([*SIM, *arguments], capture_output=True, text=True, timeout=60)


def assert_one_line_exit_2(result: subprocess.CompletedProcess[str], *named: str) -> None:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("python -m servicesim_sim: error: ")
    for text in named:
        assert text in lines[0], lines[0]
    assert result.stdout == ""


def room_map(directory: Path, *, metres: float = 4.0) -> Path:
    """A square room at 0.1 m a cell, walled all round: a map_server map."""
    size = round(metres / 0.1)
    pixels = bytearray(b"\xfe" * size * size)
    for index in range(size * size):
        row, col = divmod(index, size)
        if row in (0, size - 1) or col in (0, size - 1):
            pixels[index] = 0
    (directory / "room.pgm").write_bytes(f"P5 {size} {size} 255\n".encode() + bytes(pixels))
    path = directory / "room.yaml"
    path.write_text("image: room.pgm\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
                    "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return path


def world_file(directory: Path, body: str, *, map_path: Path | str = OFFICE_MAP) -> Path:
    path = directory / "world.yaml"
    path.write_text(f"name: bad\nmap: {map_path}\n{body}")
    return path


def test_a_single_target_area_and_no_fixed_task(tmp_path: Path) -> None:
    world = world_file(tmp_path, "areas:\n  Lobby: {min: [-1.5, 0.0], max: [1.5, 2.7]}\n")
    assert_one_line_exit_2(simulator("--world", str(world)), str(world), "3 target areas",
                           "offers 1")


def test_too_few_targets_for_a_random_task(tmp_path: Path) -> None:
    world = world_file(tmp_path, ROOM_AREAS + "targets: [West, East]\n",
                       map_path=room_map(tmp_path))
    assert_one_line_exit_2(simulator("--world", str(world), "--seed", "4"), str(world),
                           "3 target areas", "offers 2")


def test_an_area_with_no_free_spot(tmp_path: Path) -> None:
    outside = ("areas:\n  A: {min: [-29, -29], max: [-28, -28]}\n"
               "  B: {min: [-27, -29], max: [-26, -28]}\n  C: {min: [-25, -29], max: [-24, -28]}\n")
    world = world_file(tmp_path, outside)
    assert_one_line_exit_2(simulator("--world", str(world)), str(world), "no free spot")


def test_a_guest_that_cannot_stand_out_of_rfid_range(tmp_path: Path) -> None:
    world = world_file(tmp_path, CLOSET_AREAS + "people: {walkers: 0, idlers: 0}\n",
                       map_path=room_map(tmp_path, metres=2.5))
    assert_one_line_exit_2(simulator("--world", str(world), "--guest-out-of-range"),
                           str(world), "out of RFID range")


def test_more_idlers_than_the_map_holds_fails_at_once(tmp_path: Path) -> None:
    # drawing spots for 5000 idlers in the office took minutes before it gave up
    areas = ("areas:\n  Lobby: {min: [-1.5, 0.0], max: [1.5, 2.7]}\n"
             "  BathroomA: {min: [6.75, 3.0], max: [9.75, 4.5]}\n"
             "  BathroomB: {min: [9.85, 3.0], max: [12.85, 4.5]}\n")
    world = world_file(tmp_path, areas + "people: {walkers: 10, idlers: 5000}\n")
    assert_one_line_exit_2(simulator("--world", str(world)), str(world), "5000 idlers")


@pytest.mark.parametrize(
    ("body", "named"),
    [
        ("areas: {}\n", "names no target area"),
        ("", "missing key 'areas'"),
        ("areas:\n  Flat: {min: [1.0, 1.0], max: [1.0, 2.0]}\n", "areas.Flat"),
        ("areas:\n  Dot: {min: [1.0, 1.0], max: [1.0, 1.0]}\n", "must be below max"),
    ],
    ids=["no-areas", "areas-missing", "zero-width", "zero-size"],
)
def test_a_world_with_no_usable_areas(tmp_path: Path, body: str, named: str) -> None:
    world = world_file(tmp_path, body)
    assert_one_line_exit_2(simulator("--world", str(world)), str(world), named)


def test_a_map_file_that_is_missing(tmp_path: Path) -> None:
    world = world_file(tmp_path, ROOM_AREAS, map_path="no_such_map.yaml")
    assert_one_line_exit_2(simulator("--world", str(world)), str(world), "no_such_map.yaml")


def test_a_map_image_that_is_missing(tmp_path: Path) -> None:
    map_path = room_map(tmp_path)
    (tmp_path / "room.pgm").unlink()
    world = world_file(tmp_path, ROOM_AREAS, map_path=map_path)
    assert_one_line_exit_2(simulator("--world", str(world)), str(world), "room.pgm")


def test_a_small_world_that_can_be_played_still_is(tmp_path: Path) -> None:
    corners = ("areas:\n  West: {min: [0.5, 0.5], max: [1.5, 1.5]}\n"
               "  East: {min: [6.5, 0.5], max: [7.5, 1.5]}\n"
               "  North: {min: [0.5, 6.5], max: [1.5, 7.5]}\n")
    world = load_world(world_file(tmp_path, corners + "people: {walkers: 1, idlers: 2}\n",
                                  map_path=room_map(tmp_path, metres=8.0)))
    settings = SimSettings(world=world, seed=3, speed=0.0, difficulty=Difficulty.default(),
                           camera_rate_hz=0.0)
    engine = playable_engine(settings)
    task = engine.scenario.task
    assert {task.pick_up, task.drop_off, task.start_area} == {"West", "East", "North"}
    roles = sorted(role for _, role, _, _ in engine.people_states())
    assert roles == ["guest", "idler", "idler", "walker"]
