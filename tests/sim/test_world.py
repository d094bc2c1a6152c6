"""World files: the default ServiceSim office, map_server semantics and broken inputs."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image
from scipy import ndimage

from servicesim_sim.world import office
from servicesim_sim.world.files import (
    DEFAULT_WORLD,
    AreaBox,
    IdlingArea,
    OccupancyMap,
    World,
    WorldError,
    load_map,
    load_world,
    read_areas,
)

REFERENCE = next(parent / "shared" / "reference" / "servicesim"  # from main or a worktree
                 for parent in Path(__file__).resolve().parents
                 if (parent / "shared" / "reference" / "servicesim").is_dir())
ROBOT_CLEARANCE_M = 0.35


@pytest.fixture(scope="module")
def world() -> World:
    return load_world(DEFAULT_WORLD)


def reference_areas() -> dict[str, AreaBox]:
    data = yaml.safe_load((REFERENCE / "target_areas.yaml").read_text())["target_areas"]
    return {name: AreaBox(min_x=box["min"][0], min_y=box["min"][1],
                          max_x=box["max"][0], max_y=box["max"][1])
            for name, box in data.items()}


def reachable_regions(occupancy: OccupancyMap, clearance: float) -> np.ndarray:
    """Connected-region labels of the free space left once walls grow by ``clearance``."""
    reach = math.ceil(clearance / occupancy.resolution)
    rows, cols = np.mgrid[-reach:reach + 1, -reach:reach + 1]
    disk = (rows**2 + cols**2) * occupancy.resolution**2 <= clearance**2
    eroded = ~ndimage.binary_dilation(occupancy.blocked_mask(), structure=disk)
    labels, _ = ndimage.label(eroded)
    return labels


def region_at(occupancy: OccupancyMap, labels: np.ndarray, x: float, y: float) -> int:
    row, col = occupancy.world_to_cell(x, y)
    return int(labels[row, col])


# --------------------------------------------------------------------------- the office
def test_office_has_the_70_reference_target_areas(world: World) -> None:
    expected = reference_areas()
    assert len(world.areas) == 70
    assert world.areas == expected
    assert list(world.areas) == list(expected)
    assert world.targets == tuple(expected)


def test_office_has_the_19_reference_idling_areas(world: World) -> None:
    data = yaml.safe_load((REFERENCE / "idling_areas.yaml").read_text())["idling_areas"]
    expected = [(min(a["min"][0], a["max"][0]), a["min"][1], max(a["min"][0], a["max"][0]),
                 a["max"][1], a["yaw"]) for a in data]
    got = [(a.min_x, a.min_y, a.max_x, a.max_y, a.yaw) for a in world.idling_areas]
    assert len(got) == 19
    assert np.asarray(got) == pytest.approx(np.asarray(expected), abs=1e-5)
    assert all(world.map.is_free(*area_centre) for area_centre in
               [((a.min_x + a.max_x) / 2, (a.min_y + a.max_y) / 2) for a in world.idling_areas])


def test_reference_area_file_loads_as_a_separate_area_file(world: World) -> None:
    assert read_areas(REFERENCE / "target_areas.yaml", occupancy=world.map) == world.areas


def test_office_map_geometry_matches_the_competition_map(world: World) -> None:
    occupancy = world.map
    assert (occupancy.width, occupancy.height) == (1200, 1200)
    assert occupancy.resolution == pytest.approx(0.05)
    assert (occupancy.origin_x, occupancy.origin_y) == (-30.0, -30.0)
    assert occupancy.grid.dtype == np.int8
    assert set(np.unique(occupancy.grid)) == {-1, 0, 100}
    assert not occupancy.is_free(-29.0, -29.0)  # outside the building: unknown
    assert occupancy.grid[occupancy.world_to_cell(-29.0, -29.0)] == -1


def test_every_target_area_is_reachable_from_every_other(world: World) -> None:
    labels = reachable_regions(world.map, ROBOT_CLEARANCE_M)
    regions = {name: region_at(world.map, labels, *box.centre) for name, box in world.areas.items()}
    unreachable = sorted(name for name, region in regions.items() if region == 0)
    assert unreachable == []
    assert len(set(regions.values())) == 1
    task = world.task
    assert task is not None
    hall = regions["FrontElevator"]
    assert region_at(world.map, labels, task.start_x, task.start_y) == hall
    assert region_at(world.map, labels, task.guest_x, task.guest_y) == hall


def test_every_room_is_open_and_reachable(world: World) -> None:
    labels = reachable_regions(world.map, ROBOT_CLEARANCE_M)
    hall = region_at(world.map, labels, *world.areas["FrontElevator"].centre)
    assert len(office.ROOMS) == 19
    for room in office.ROOMS:
        inside = ((room.low[0] + room.high[0]) / 2, (room.low[1] + room.high[1]) / 2)
        assert region_at(world.map, labels, *inside) == hall, room.name


def test_a_door_is_a_gap_of_door_width_in_its_wall() -> None:
    wall = office.Wall((0.0, 5.0), (4.0, 5.0), doors=(1.5,))
    west, east = wall.blocks()
    assert east.min_x - west.max_x == pytest.approx(office.DOOR)
    assert (west.min_x, east.max_x) == (-office.WALL / 2, 4.0 + office.WALL / 2)
    assert (west.min_y, west.max_y) == pytest.approx((5.0 - office.WALL / 2, 5.0 + office.WALL / 2))
    occupancy = load_world(DEFAULT_WORLD).map
    for room in office.ROOMS:  # the door gap is free on the committed map
        (x0, y0), (x1, y1) = room.low, room.high
        door = {"south": (room.door_at, y0), "north": (room.door_at, y1),
                "west": (x0, room.door_at), "east": (x1, room.door_at)}[room.door_side]
        assert occupancy.is_free(*door), room.name


def test_the_closed_doors_variant_shuts_the_shipped_worlds_closed_rooms_and_plays(
        tmp_path: Path) -> None:
    # service.world.erb / room.erb: a room whose door is shut gets no target area; the shipped
    # world's rooms without one are the eight shut here, and everything else stays reachable
    assert office.main(["--closed-doors", "--out", str(tmp_path)]) == 0
    closed = load_world(tmp_path / "world.yaml")
    assert closed.name == "office_closed_doors"
    assert len(office.CLOSED_IN_SHIPPED) == 8
    assert not office.CLOSED_IN_SHIPPED & set(closed.areas)
    labels = reachable_regions(closed.map, ROBOT_CLEARANCE_M)
    hall = region_at(closed.map, labels, *closed.areas["FrontElevator"].centre)
    for room in office.ROOMS:
        (x0, y0), (x1, y1) = room.low, room.high
        door = {"south": (room.door_at, y0), "north": (room.door_at, y1),
                "west": (x0, room.door_at), "east": (x1, room.door_at)}[room.door_side]
        shut = room.name in office.CLOSED_IN_SHIPPED
        assert closed.map.is_free(*door) is not shut, room.name
        inside = region_at(closed.map, labels, (x0 + x1) / 2, (y0 + y1) / 2)
        assert (inside == hall) is not shut, room.name
    assert {region_at(closed.map, labels, *box.centre) for box in closed.areas.values()} == {hall}
    task = closed.task
    assert task is not None
    assert region_at(closed.map, labels, task.start_x, task.start_y) == hall
    assert region_at(closed.map, labels, task.guest_x, task.guest_y) == hall


def test_office_has_the_shipped_task(world: World) -> None:
    task = world.task
    assert task is not None
    assert (task.pick_up, task.drop_off, task.guest_name) == (
        "FrontElevator", "PrivateCubicle_32_1", "human_20843")
    assert (task.guest_x, task.guest_y) == (-0.043, 1.512)
    assert (task.start_area, task.start_x, task.start_y, task.start_yaw) == (
        "PublicBathroomB", 10.975, 3.75, 3.14)
    assert world.map.is_free(task.guest_x, task.guest_y)
    assert world.map.is_free(task.start_x, task.start_y)
    assert (world.people.walkers, world.people.idlers) == (10, 30)
    drift = world.drift
    assert (drift.start_s, drift.min_interval_s, drift.max_interval_s, drift.count) == (
        200.0, 100.0, 300.0, 30)
    assert world.name == "office"


def test_committed_office_files_equal_a_fresh_generation(tmp_path: Path) -> None:
    assert office.main(["--out", str(tmp_path)]) == 0
    for name in ("map.pgm", "map.yaml", "world.yaml"):
        assert (tmp_path / name).read_bytes() == (DEFAULT_WORLD.parent / name).read_bytes(), name
    assert (DEFAULT_WORLD.parent / "map.pgm").read_bytes() == office.pgm_bytes(office.rasterise())


def test_generator_refuses_an_unusable_output_directory(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    assert office.main(["--out", str(blocker)]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and str(blocker) in error


# --------------------------------------------------------------------------- map_server semantics
GREYS = np.array([[0, 50, 100, 128, 200, 205, 254, 255]], dtype=np.uint8)
U = -1
EXPECTED = {
    # mode, negate: cells for the grey values above
    ("trinary", 0): [100, 100, U, U, U, U, 0, 0],
    ("trinary", 1): [0, U, U, U, 100, 100, 100, 100],
    ("scale", 0): [100, 100, 91, 67, 4, 0, 0, 0],
    ("raw", 0): [0, 50, 100, U, U, U, U, U],
    ("raw", 1): [0, 50, 100, U, U, U, U, U],  # raw ignores negate
}


def write_map(directory: Path, image: Image.Image, *, suffix: str = "pgm", mode: str = "trinary",
              negate: int = 0) -> Path:
    image.save(directory / f"map.{suffix}")
    return write_map_settings(directory, f"map.{suffix}", mode=mode, negate=negate)


def write_map_settings(directory: Path, image: str, *, mode: str, negate: int = 0) -> Path:
    """A map YAML at 0.5 m per cell with its origin at (1, 2)."""
    settings = {"image": image, "resolution": 0.5, "origin": [1.0, 2.0, 0.0], "negate": negate,
                "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": mode}
    path = directory / "map.yaml"
    path.write_text(yaml.safe_dump(settings))
    return path


@pytest.mark.parametrize("suffix", ["pgm", "png"])
@pytest.mark.parametrize(("mode", "negate"), list(EXPECTED))
def test_map_modes_give_map_server_cell_values(tmp_path: Path, suffix: str, mode: str,
                                                negate: int) -> None:
    occupancy = load_map(write_map(tmp_path, Image.fromarray(GREYS), suffix=suffix,
                                   mode=mode, negate=negate))
    assert occupancy.grid.dtype == np.int8
    assert occupancy.grid.tolist() == [EXPECTED[mode, negate]]


def test_map_rows_follow_occupancy_grid_order(tmp_path: Path) -> None:
    image = Image.fromarray(np.array([[0, 254, 205], [254, 254, 0]], dtype=np.uint8))
    occupancy = load_map(write_map(tmp_path, image))
    assert occupancy.grid.tolist() == [[0, 0, 100], [100, 0, -1]]  # row 0 = the image's last
    assert (occupancy.width, occupancy.height) == (3, 2)
    assert occupancy.world_to_cell(1.6, 2.9) == (1, 1)
    assert occupancy.cell_to_world(1, 2) == (2.25, 2.75)
    assert occupancy.is_free(1.2, 2.2) and occupancy.is_free(1.7, 2.7)
    assert not occupancy.is_free(2.2, 2.2)  # occupied
    assert not occupancy.is_free(2.2, 2.7)  # unknown
    assert not occupancy.is_free(0.9, 2.2) and not occupancy.is_free(1.2, 3.1)  # off the map
    assert occupancy.blocked_mask().tolist() == [[False, False, True], [True, False, True]]
    assert not occupancy.grid.flags.writeable


def test_alpha_is_averaged_in_trinary_and_means_unknown_in_scale(tmp_path: Path) -> None:
    pixels = np.array([[[0, 0], [255, 0], [255, 255], [128, 255], [0, 128]]], dtype=np.uint8)
    image = Image.fromarray(pixels)  # two channels: LA
    trinary = load_map(write_map(tmp_path, image, suffix="png"))
    assert trinary.grid.tolist() == [[100, U, 0, U, 100]]
    scale = load_map(write_map(tmp_path, image, suffix="png", mode="scale"))
    assert scale.grid.tolist() == [[U, U, 0, 67, U]]


def test_colour_channels_are_averaged(tmp_path: Path) -> None:
    pixels = np.array([[[255, 0, 0], [255, 255, 0], [255, 255, 255], [0, 0, 0]]], dtype=np.uint8)
    occupancy = load_map(write_map(tmp_path, Image.fromarray(pixels), suffix="png"))
    assert occupancy.grid.tolist() == [[100, U, 0, 100]]


def test_sixteen_bit_images_scale_by_their_full_range(tmp_path: Path) -> None:
    values = [0, 65535, 32768, 40 * 257]
    header = f"P5\n{len(values)} 1\n65535\n".encode()
    (tmp_path / "map.pgm").write_bytes(header + b"".join(v.to_bytes(2, "big") for v in values))
    for mode, expected in (("trinary", [100, 0, U, 100]), ("raw", [0, U, U, 40])):
        occupancy = load_map(write_map_settings(tmp_path, "map.pgm", mode=mode))
        assert occupancy.grid.tolist() == [expected], mode


@pytest.mark.parametrize(("mode", "negate"), list(EXPECTED))
def test_a_grey_map_reads_as_the_same_image_in_colour_does(tmp_path: Path, mode: str,
                                                           negate: int) -> None:
    """8-bit grey images are read without a colour copy; every grey level must still give the
    cell the mean of the three colour channels gives."""
    levels = np.arange(256, dtype=np.uint8).reshape(16, 16)
    grey_dir, colour_dir = tmp_path / "grey", tmp_path / "colour"
    grey_dir.mkdir()
    colour_dir.mkdir()
    grey = load_map(write_map(grey_dir, Image.fromarray(levels, mode="L"), mode=mode,
                              negate=negate))
    colour = load_map(write_map(colour_dir, Image.fromarray(levels, mode="L").convert("RGB"),
                                suffix="png", mode=mode, negate=negate))
    assert np.array_equal(grey.grid, colour.grid)
    assert len(np.unique(grey.grid)) > 2


def test_area_box_geometry() -> None:
    box = AreaBox(min_x=1.0, min_y=2.0, max_x=4.0, max_y=3.0)
    assert box.centre == (2.5, 2.5) and (box.width, box.height) == (3.0, 1.0)
    assert box.contains(1.0, 2.0) and box.contains(2.5, 2.9)
    assert not box.contains(0.9, 2.5) and not box.contains(2.5, 3.1)
    assert box.contains(2.5, 2.5, margin=0.4) and not box.contains(1.3, 2.5, margin=0.4)


def test_wall_distance_is_metres_to_the_nearest_obstacle_cell_worked_out_once() -> None:
    grid = np.zeros((6, 9), dtype=np.int8)
    grid[0, :] = 100  # a wall along the bottom row
    grid[4, 7] = -1  # an unknown cell is an obstacle too
    grid[2, 2] = 49  # the highest free value
    occupancy = OccupancyMap(grid=grid, resolution=0.5, origin_x=0.0, origin_y=0.0)
    obstacles = np.argwhere(occupancy.blocked_mask())
    expected = np.array([[0.5 * min(math.hypot(row - r, col - c) for r, c in obstacles)
                          for col in range(9)] for row in range(6)])
    distance = occupancy.wall_distance
    np.testing.assert_allclose(distance, expected)
    assert distance[0, 3] == 0.0 and distance[4, 7] == 0.0 and distance[2, 2] == 1.0
    assert occupancy.wall_distance is distance and not distance.flags.writeable


# --------------------------------------------------------------------------- broken world files
WORLD = """\
name: tiny
map: map.yaml
areas:
  Hall: {min: [0.5, 0.5], max: [1.5, 1.5]}
  Kitchen: {min: [2.5, 2.5], max: [3.5, 3.5]}
  Study: {min: [0.5, 2.5], max: [1.5, 3.5]}
task:
  pick_up: Hall
  drop_off: Kitchen
  guest: {name: human_12345, x: 0.7, y: 0.7, yaw: 0.0}
  start: {area: Study, x: 1.0, y: 3.0, yaw: 1.57}
people: {walkers: 2, idlers: 3}
idling_areas:
  - {min: [2.5, 0.5], max: [3.5, 0.5], yaw: 1.5708}
drift: {start_s: 10.0, min_interval_s: 5.0, max_interval_s: 6.0, count: 2}
targets: [Hall, Kitchen, Study]
"""
MAP = "image: map.pgm\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n" \
      "occupied_thresh: 0.65\nfree_thresh: 0.196\n"


def tiny_world(directory: Path) -> Path:
    """A 4 x 4 m room with a pillar at (1.0..1.2, 1.2..1.4) inside the Hall area."""
    pixels = np.full((40, 40), 254, dtype=np.uint8)
    pixels[0, :] = pixels[-1, :] = pixels[:, 0] = pixels[:, -1] = 0
    pixels[40 - 14:40 - 12, 10:12] = 0  # image rows count from the top
    Image.fromarray(pixels).save(directory / "map.pgm")
    (directory / "map.yaml").write_text(MAP)
    path = directory / "world.yaml"
    path.write_text(WORLD)
    return path


def test_tiny_world_loads(tmp_path: Path) -> None:
    world = load_world(tiny_world(tmp_path))
    assert world.name == "tiny" and list(world.areas) == ["Hall", "Kitchen", "Study"]
    assert world.task is not None and world.task.start_yaw == 1.57
    assert (world.people.walkers, world.drift.max_interval_s) == (2, 6.0)
    assert not world.map.is_free(1.1, 1.3) and world.map.is_free(0.7, 0.7)
    assert world.idling_areas == (IdlingArea(min_x=2.5, min_y=0.5, max_x=3.5, max_y=0.5,
                                             yaw=1.5708),)
    assert world.people.walker_patience_s == math.inf  # the original's: waits while blocked


def test_world_defaults_when_optional_parts_are_left_out(tmp_path: Path) -> None:
    path = tiny_world(tmp_path)
    path.write_text(WORLD.split("task:")[0])
    world = load_world(path)
    assert world.name == "tiny" and world.task is None
    assert world.targets == ("Hall", "Kitchen", "Study")
    assert (world.people.walkers, world.people.idlers) == (10, 30)
    assert (world.drift.start_s, world.drift.count) == (200.0, 30)
    assert world.idling_areas == ()


Breakage = Callable[[Path], None]


def replace(old: str, new: str, file: str = "world.yaml") -> Breakage:
    def edit(directory: Path) -> None:
        path = directory / file
        text = path.read_text()
        assert old in text, f"{old!r} not in {file}"
        path.write_text(text.replace(old, new))
    return edit


def write(file: str, content: bytes | str) -> Breakage:
    def edit(directory: Path) -> None:
        path = directory / file
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content)
    return edit


def remove(file: str) -> Breakage:
    return lambda directory: (directory / file).unlink()


BROKEN = [
    # id, how to break the tiny world, file named, problem named
    ("no-world-file", remove("world.yaml"), "world.yaml", "no such file"),
    ("bad-yaml", write("world.yaml", "areas: [unclosed\n"), "world.yaml", "not valid YAML"),
    ("not-a-mapping", write("world.yaml", "- a\n- b\n"), "world.yaml", "must be a mapping"),
    ("no-map-key", replace("map: map.yaml\n", ""), "world.yaml", "missing key 'map'"),
    ("unknown-key", replace("areas:", "zones:"), "world.yaml", "unknown key 'zones'"),
    ("no-areas-key", write("world.yaml", "map: map.yaml\n"), "world.yaml", "missing key 'areas'"),
    ("map-wrong-type", replace("map: map.yaml", "map: 3"), "world.yaml", "map must be a non-empty"),
    ("no-map-file", remove("map.yaml"), "map.yaml", "no such file"),
    ("map-no-resolution", replace("resolution: 0.1\n", "", "map.yaml"), "map.yaml",
     "missing key 'resolution'"),
    ("map-zero-resolution", replace("resolution: 0.1", "resolution: 0", "map.yaml"), "map.yaml",
     "resolution must be more than 0"),
    ("map-bad-origin", replace("[0.0, 0.0, 0.0]", "origin", "map.yaml"), "map.yaml",
     "origin must be a list"),
    ("map-bad-thresholds", replace("free_thresh: 0.196", "free_thresh: 0.9", "map.yaml"),
     "map.yaml", "thresholds must satisfy"),
    ("map-threshold-text", replace("free_thresh: 0.196", "free_thresh: low", "map.yaml"),
     "map.yaml", "free_thresh must be a number"),
    ("map-bad-mode", replace("negate: 0", "negate: 0\nmode: fuzzy", "map.yaml"), "map.yaml",
     "mode must be one of"),
    ("map-bad-negate", replace("negate: 0", "negate: 2", "map.yaml"), "map.yaml",
     "negate must be 0 or 1"),
    ("no-image", remove("map.pgm"), "map.pgm", "no such image file"),
    ("unreadable-image", write("map.pgm", b"P5 this is not an image"), "map.pgm",
     "cannot read the map image"),
    ("image-bomb", write("map.pgm", b"P5\n100000 100000\n255\n\0"), "map.pgm",
     "cannot read the map image: Image size (10000000000 pixels) exceeds limit"),
    ("area-not-a-mapping", replace("Hall: {min: [0.5, 0.5], max: [1.5, 1.5]}", "Hall: 3"),
     "world.yaml", "areas.Hall must be a mapping"),
    ("area-no-max", replace(", max: [1.5, 1.5]}", "}"), "world.yaml",
     "missing key 'areas.Hall.max'"),
    ("area-point-text", replace("min: [0.5, 0.5]", "min: [a, 0.5]"), "world.yaml",
     "areas.Hall.min must be a number"),
    ("area-point-short", replace("min: [0.5, 0.5]", "min: [0.5]"), "world.yaml",
     "areas.Hall.min must be a list [x, y]"),
    ("area-min-above-max", replace("min: [2.5, 2.5]", "min: [3.5, 2.5]"), "world.yaml",
     "areas.Kitchen: min (3.5, 2.5) must be below max"),
    ("area-off-the-map", replace("max: [3.5, 3.5]}\n  Study", "max: [4.5, 3.5]}\n  Study"),
     "world.yaml", "areas.Kitchen lies outside the map"),
    ("area-twice", replace("  Study:", "  Hall:"), "world.yaml", "duplicate key 'Hall'"),
    ("no-areas", write("world.yaml", "map: map.yaml\nareas: {}\n"), "world.yaml",
     "areas names no target area"),
    ("task-unknown-area", replace("drop_off: Kitchen", "drop_off: Attic"), "world.yaml",
     "task.drop_off names an unknown area 'Attic'"),
    ("task-same-areas", replace("drop_off: Kitchen", "drop_off: Hall"), "world.yaml",
     "task.pick_up and task.drop_off are both 'Hall'"),
    ("task-no-guest", replace("  guest: {name: human_12345, x: 0.7, y: 0.7, yaw: 0.0}\n", ""),
     "world.yaml", "missing key 'task.guest'"),
    ("guest-outside-area", replace("x: 0.7, y: 0.7", "x: 2.0, y: 0.7"), "world.yaml",
     "task.guest (2, 0.7) lies outside its area 'Hall'"),
    ("guest-on-pillar", replace("x: 0.7, y: 0.7", "x: 1.1, y: 1.3"), "world.yaml",
     "task.guest (1.1, 1.3) is not on a free map cell"),
    ("start-unknown-area", replace("area: Study", "area: Attic"), "world.yaml",
     "task.start.area names an unknown area 'Attic'"),
    ("start-outside-area", replace("x: 1.0, y: 3.0", "x: 3.0, y: 3.0"), "world.yaml",
     "task.start (3, 3) lies outside its area 'Study'"),
    ("guest-no-name", replace("name: human_12345", "name: ''"), "world.yaml",
     "task.guest.name must be a non-empty string"),
    ("people-negative", replace("walkers: 2", "walkers: -1"), "world.yaml", "must be 0 or more"),
    ("people-text", replace("idlers: 3", "idlers: many"), "world.yaml",
     "people.idlers must be a whole number"),
    ("people-unknown", replace("walkers: 2", "runners: 2"), "world.yaml",
     "unknown key 'people.runners'"),
    ("people-patience-zero", replace("idlers: 3}", "idlers: 3, walker_patience_s: 0}"),
     "world.yaml", "people.walker_patience_s must be more than 0, not 0"),
    ("idling-areas-not-a-list", replace("idling_areas:\n  - {min: [2.5, 0.5], max: [3.5, 0.5], "
                                        "yaw: 1.5708}", "idling_areas: 3"), "world.yaml",
     "idling_areas must be a non-empty list"),
    ("idling-area-no-yaw", replace(", yaw: 1.5708}", "}"), "world.yaml",
     "missing key 'idling_areas[0].yaw'"),
    ("idling-area-min-above-max", replace("min: [2.5, 0.5], max: [3.5, 0.5]",
                                          "min: [3.6, 0.5], max: [3.5, 0.5]"), "world.yaml",
     "idling_areas[0]: min (3.6, 0.5) must not exceed max (3.5, 0.5)"),
    ("idling-area-off-the-map", replace("max: [3.5, 0.5]", "max: [4.5, 0.5]"), "world.yaml",
     "idling_areas[0] lies outside the map"),
    ("idling-area-unknown-key", replace("yaw: 1.5708}", "yaw: 1.5708, count: 2}"),
     "world.yaml", "unknown key 'idling_areas[0].count'"),
    ("drift-interval-order", replace("min_interval_s: 5.0", "min_interval_s: 7.0"), "world.yaml",
     "drift.min_interval_s (7) must not exceed drift.max_interval_s (6)"),
    ("drift-boolean", replace("count: 2", "count: true"), "world.yaml",
     "drift.count must be a whole number, not the boolean true"),
    ("drift-count-huge", replace("count: 2", "count: 1000000000"), "world.yaml",
     "drift.count must be within 0..10000, not 1000000000"),
    ("drift-infinite", replace("start_s: 10.0", "start_s: .inf"), "world.yaml",
     "drift.start_s must be a finite number"),
    ("drift-times-not-a-list", replace("count: 2", "count: 2, times: 12"), "world.yaml",
     "drift.times must be a list of sim times in seconds, not int 12"),
    ("drift-times-falling", replace("count: 2", "count: 2, times: [20, 12]"), "world.yaml",
     "drift.times must rise, from 0 or more"),
    ("drift-times-negative", replace("count: 2", "count: 2, times: [-1, 12]"), "world.yaml",
     "drift.times must rise, from 0 or more"),
    ("drift-times-boolean", replace("count: 2", "count: 2, times: [true]"), "world.yaml",
     "drift.times must be a list of sim times in seconds"),
    ("targets-unknown", replace("[Hall, Kitchen, Study]", "[Hall, Attic]"), "world.yaml",
     "targets names an unknown area 'Attic'"),
    ("targets-twice", replace("[Hall, Kitchen, Study]", "[Hall, Hall]"), "world.yaml",
     "targets names 'Hall' twice"),
    ("targets-empty", replace("[Hall, Kitchen, Study]", "[]"), "world.yaml",
     "targets must be a non-empty list"),
]


@pytest.mark.parametrize(("breaks", "file", "problem"), [case[1:] for case in BROKEN],
                         ids=[case[0] for case in BROKEN])
def test_broken_world_files_name_the_file_and_the_problem(tmp_path: Path, breaks: Breakage,
                                                          file: str, problem: str) -> None:
    path = tiny_world(tmp_path)
    breaks(tmp_path)
    with pytest.raises(WorldError) as raised:
        load_world(path)
    message = str(raised.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    assert str(tmp_path / file) in message
    assert problem in message


def test_a_separate_area_file_loads_and_its_problems_name_it(tmp_path: Path) -> None:
    path = tiny_world(tmp_path)
    text = path.read_text()
    (tmp_path / "zones.yaml").write_text(
        "target_areas:\n" + text[text.index("  Hall:"):text.index("task:")])
    start, end = text.index("areas:"), text.index("task:")
    path.write_text(text[:start] + "areas: zones.yaml\n" + text[end:])
    assert list(load_world(path).areas) == ["Hall", "Kitchen", "Study"]
    (tmp_path / "zones.yaml").write_text("Hall: {min: [0.5, 0.5], max: [0.5, 1.5]}\n")
    with pytest.raises(WorldError, match=r"zones\.yaml: Hall: min \(0\.5, 0\.5\) must be below"):
        load_world(path)
    (tmp_path / "zones.yaml").unlink()
    with pytest.raises(WorldError, match=r"zones\.yaml: no such file"):
        load_world(path)
