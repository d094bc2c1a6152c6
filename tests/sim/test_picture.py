"""The world picture: drawing parts, the whole picture and the command's input checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import FancyArrow, Rectangle
from PIL import Image

from servicesim_sim import picture
from servicesim_sim.world.files import DEFAULT_WORLD, AreaBox, OccupancyMap, World, load_world

PEOPLE = [("human_10001", "guest", 1.0, 2.0), ("human_10002", "walker", 3.0, 4.0),
          ("human_10003", "walker", 5.0, 6.0), ("human_10004", "idler", 7.0, 8.0)]


@pytest.fixture(scope="module")
def world() -> World:
    return load_world(DEFAULT_WORLD)


def axes_of_new_figure() -> Axes:
    return Figure().add_subplot()


def test_map_colours_show_free_occupied_unknown_and_shades() -> None:
    grid = np.array([[0, 100], [-1, 50]], dtype=np.int8)
    occupancy = OccupancyMap(grid=grid, resolution=1.0, origin_x=0.0, origin_y=0.0)
    colours = picture.map_colours(occupancy)
    assert colours.shape == (2, 2, 3)
    assert colours[0, 0].tolist() == [1.0, 1.0, 1.0]
    assert colours[0, 1].tolist() == [0.0, 0.0, 0.0]
    assert colours[1, 0].tolist() == list(picture.UNKNOWN_COLOUR)
    assert colours[1, 1].tolist() == [0.5, 0.5, 0.5]


def test_people_are_drawn_by_role_and_the_guest_is_named() -> None:
    axes = axes_of_new_figure()
    picture.draw_people(axes, iter(PEOPLE))
    points = sorted(tuple(map(tuple, collection.get_offsets().tolist()))
                    for collection in axes.collections)
    assert points == [((1.0, 2.0),), ((3.0, 4.0), (5.0, 6.0)), ((7.0, 8.0),)]
    assert [text.get_text() for text in axes.texts] == ["human_10001"]


def test_areas_are_boxes_labelled_with_their_names() -> None:
    axes = axes_of_new_figure()
    areas = {"Hall": AreaBox(0.0, 0.0, 3.0, 1.0), "Strip": AreaBox(5.0, 0.0, 6.0, 4.0)}
    picture.draw_areas(axes, areas)
    boxes = [(patch.get_x(), patch.get_y(), patch.get_width(), patch.get_height())
             for patch in axes.patches]
    assert boxes == [(0.0, 0.0, 3.0, 1.0), (5.0, 0.0, 1.0, 4.0)]
    labels = {text.get_text(): (text.get_position(), text.get_rotation()) for text in axes.texts}
    assert labels == {"Hall": ((1.5, 0.5), 0.0), "Strip": ((5.5, 2.0), 90.0)}


def test_task_highlights_its_areas_and_shows_start_pose_and_guest(world: World) -> None:
    axes = axes_of_new_figure()
    task = world.task
    assert task is not None
    picture.draw_task(axes, task, world.areas)
    highlighted = {(patch.get_x(), patch.get_y()) for patch in axes.patches
                   if isinstance(patch, Rectangle)}
    assert highlighted == {(world.areas[name].min_x, world.areas[name].min_y)
                           for name in (task.pick_up, task.drop_off, task.start_area)}
    arrows = [patch for patch in axes.patches if isinstance(patch, FancyArrow)]
    assert len(arrows) == 1
    heading = np.array([np.cos(task.start_yaw), np.sin(task.start_yaw)])
    along = (arrows[0].get_xy() - [task.start_x, task.start_y]) @ heading
    assert (along.min(), along.max()) == pytest.approx((0.0, 1.2), abs=0.01)  # start pose, yaw
    assert axes.collections[0].get_offsets().tolist() == [[task.guest_x, task.guest_y]]


def test_known_extent_frames_the_building(world: World) -> None:
    low_x, low_y, high_x, high_y = picture.known_extent(world.map)
    assert low_x == pytest.approx(-28.6, abs=0.2) and high_x == pytest.approx(22.2, abs=0.2)
    assert low_y == pytest.approx(-1.1, abs=0.2) and high_y == pytest.approx(23.6, abs=0.2)


def test_seeded_picture_shows_the_simulator_scenario_and_its_people(world: World) -> None:
    task, people = picture.task_and_people(world, seed=3)
    again, _ = picture.task_and_people(world, seed=3)
    assert task is not None and people is not None and again is not None
    assert (task.pick_up, task.drop_off, task.guest_name) == (
        again.pick_up, again.drop_off, again.guest_name)
    roles = [role for _, role, _, _ in people]
    assert roles.count("guest") == 1
    assert (roles.count("walker"), roles.count("idler")) == (
        world.people.walkers, world.people.idlers)
    guest = next(person for person in people if person[1] == "guest")
    assert guest[0] == task.guest_name and world.areas[task.pick_up].contains(guest[2], guest[3])
    assert picture.title(world, task).endswith(
        f"fetch {task.guest_name} from {task.pick_up} to {task.drop_off}, "
        f"start in {task.start_area}")


@pytest.mark.long
def test_command_writes_the_picture(tmp_path: Path) -> None:
    out = tmp_path / "office.png"
    assert picture.main(["--world", str(DEFAULT_WORLD), "--out", str(out)]) == 0
    with Image.open(out) as image:
        pixels = np.asarray(image.convert("RGB"))
    assert pixels.shape[1] > 1.5 * pixels.shape[0] > 1500  # the office is wide
    colours = {tuple(colour) for colour in pixels.reshape(-1, 3)[::7].tolist()}
    unknown = tuple(round(channel * 255) for channel in picture.UNKNOWN_COLOUR)
    assert (0, 0, 0) in colours and (255, 255, 255) in colours and unknown in colours


@pytest.mark.parametrize(("arguments", "problem"), [
    (["--out", "{tmp}/x.png", "--seed", "-1"], "--seed -1: must be 0 or more"),
    (["--out", "{tmp}/x.txt"], "the name must end in .png"),
    (["--out", "{tmp}/missing/x.png"], "no such directory"),
    (["--out", "{tmp}/x.png", "--world", "{tmp}/nowhere.yaml"], "nowhere.yaml: no such file"),
    (["--out", "{tmp}/x.png", "--seed", "many"], "invalid int value: 'many'"),
    (["--seed", "1"], "the following arguments are required: --out"),
])
def test_command_refuses_bad_input_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                               arguments: list[str], problem: str) -> None:
    with pytest.raises(SystemExit) as raised:
        picture.main([argument.format(tmp=tmp_path) for argument in arguments])
    assert raised.value.code == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith(f"{picture.PROG}: error: ")
    assert problem in error
    assert not (tmp_path / "x.png").exists()
