"""Finding the guest in the front camera's picture, on drawn pictures and on the simulator's.

The simulator's camera module is imported here only to render test pictures (a test may; the
executive may not): the detector judges them by HSV thresholds, as it judges any camera's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.guest_camera import (
    STAND_OFF,
    CameraModel,
    GuestSighting,
    camera_goal,
    find_guest,
    guest_position,
    look_turns,
)
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from servicesim_sim.model.camera import OTHER_SHIRTS, OTHER_TROUSERS, render_front_camera
from servicesim_sim.world.files import OccupancyMap

CAMERA = CameraModel()
GUEST = "human_20843"
BLUE, RED, GREY = (20, 40, 230), (210, 25, 25), (150, 150, 150)


def blank() -> np.ndarray:
    return np.full((480, 640, 3), GREY, dtype=np.uint8)


def draw_figure(image: np.ndarray, *, left: int, top: int, width: int, height: int,
                shirt: tuple[int, int, int] = BLUE,
                trousers: tuple[int, int, int] = RED) -> None:
    """A figure ``height`` px tall, the upper 7/15 shirt, the lower 8/15 trousers."""
    middle = top + round(height * 7 / 15)
    image[top:middle, left:left + width] = shirt
    inset = width // 8
    image[middle:top + height, left + inset:left + width - inset] = trousers


def test_a_blue_shirt_over_red_trousers_gives_bearing_and_distance_from_the_blob() -> None:
    image = blank()
    draw_figure(image, left=100, top=200, width=40, height=150)
    sighting = find_guest(image)
    assert sighting is not None
    assert sighting.height_px == 150
    assert sighting.column == pytest.approx(120.0, abs=0.5)
    assert sighting.bearing == pytest.approx(math.atan((320 - 120) / CAMERA.focal_length))
    depth = CAMERA.focal_length * 1.5 / 150
    assert sighting.distance == pytest.approx(depth / math.cos(sighting.bearing))
    assert not sighting.clipped


def test_shading_and_noise_do_not_hide_the_guest() -> None:
    image = blank()
    draw_figure(image, left=400, top=180, width=30, height=120)
    rng = np.random.default_rng(0)
    shaded = image.astype(float) * np.linspace(0.35, 1.0, 640)[None, :, None]
    noisy = np.clip(shaded + rng.normal(0.0, 6.0, shaded.shape), 0, 255).astype(np.uint8)
    sighting = find_guest(noisy)
    assert sighting is not None
    assert sighting.height_px == pytest.approx(120, abs=2)
    assert sighting.bearing < 0.0  # right of centre


@pytest.mark.parametrize("outfit", [
    pytest.param((RED, BLUE), id="red over blue"),
    pytest.param((BLUE, GREY), id="blue over grey"),
    pytest.param((BLUE, (232, 132, 40)), id="blue over orange"),
    pytest.param(((58, 76, 122), RED), id="denim over red"),
    pytest.param(((180, 70, 150), RED), id="purple over red"),
])
def test_other_outfits_are_not_the_guest(outfit: tuple[tuple[int, int, int], ...]) -> None:
    image = blank()
    draw_figure(image, left=300, top=150, width=40, height=160, shirt=outfit[0],
                trousers=outfit[1])
    assert find_guest(image) is None


def test_blue_with_red_far_below_it_is_not_the_guest() -> None:
    image = blank()
    image[100:150, 300:340] = BLUE
    image[250:300, 300:340] = RED
    assert find_guest(image) is None


def test_a_blob_too_small_to_be_sure_of_is_not_the_guest() -> None:
    image = blank()
    draw_figure(image, left=300, top=230, width=3, height=12)
    assert find_guest(image) is None


def test_the_nearest_of_two_blobs_is_taken_and_a_clipped_one_says_so() -> None:
    image = blank()
    draw_figure(image, left=50, top=220, width=20, height=60)
    draw_figure(image, left=400, top=100, width=120, height=380)
    sighting = find_guest(image)
    assert sighting is not None and sighting.height_px == 380 and sighting.clipped


def test_a_picture_that_is_no_rgb_image_is_refused_with_its_shape() -> None:
    with pytest.raises(ValueError, match=r"\(480, 640\)"):
        find_guest(np.zeros((480, 640), dtype=np.uint8))


# ---------------------------------------------------------------- the simulator's pictures
RESOLUTION = 0.05


def hall_cells(*, inner_wall_x: float | None = None) -> np.ndarray:
    """A 20 x 20 m hall, walls at x, y = 0 and 20 (cells of 5 cm from (-1, -1))."""
    grid = np.zeros((440, 440), dtype=np.int8)
    grid[:20, :] = grid[-20:, :] = grid[:, :20] = grid[:, -20:] = 100
    if inner_wall_x is not None:
        col = round((inner_wall_x + 1.0) / RESOLUTION)
        grid[:, col:col + 2] = 100
    return grid


def sim_picture(robot: tuple[float, float, float], people: list[tuple[str, str, float, float]],
                cells: np.ndarray | None = None) -> np.ndarray:
    occupancy = OccupancyMap(grid=hall_cells() if cells is None else cells,
                             resolution=RESOLUTION, origin_x=-1.0, origin_y=-1.0)
    return render_front_camera(robot=robot, people=people, guest_name=GUEST,
                               occupancy_map=occupancy)


@pytest.mark.parametrize("guest", [(10.0, 5.0), (6.0, 6.9), (14.0, 2.0), (4.5, 5.8)])
def test_the_simulators_guest_is_found_where_they_stand(guest: tuple[float, float]) -> None:
    robot = Pose2D(2.0, 5.0, 0.0)
    image = sim_picture((robot.x, robot.y, robot.yaw), [(GUEST, "guest", *guest)])
    sighting = find_guest(image)
    assert sighting is not None
    x, y = guest_position(robot, sighting)
    true_distance = math.hypot(guest[0] - robot.x, guest[1] - robot.y)
    assert math.hypot(x - guest[0], y - guest[1]) < 0.05 * true_distance
    assert sighting.bearing == pytest.approx(math.atan2(guest[1] - 5.0, guest[0] - 2.0),
                                             abs=0.01)


def test_everyone_elses_outfit_in_the_simulator_is_not_the_guest() -> None:
    names = [f"human_{n:05d}" for n in range(40)]
    outfits = {(shirt, trousers) for shirt in OTHER_SHIRTS for trousers in OTHER_TROUSERS}
    assert len(outfits) == len(OTHER_SHIRTS) * len(OTHER_TROUSERS)
    people = [(name, "idler", 6.0 + (i % 8) * 0.9, 1.5 + (i // 8) * 1.6)
              for i, name in enumerate(names)]
    for yaw in (0.0, 0.4, -0.4):
        assert find_guest(sim_picture((1.0, 5.0, yaw), people)) is None


def test_the_guest_among_others_and_half_hidden_is_still_found() -> None:
    others = [("human_11111", "idler", 7.6, 5.4), ("human_22222", "idler", 8.4, 4.3),
              ("human_33333", "walker", 6.0, 4.85)]
    image = sim_picture((2.0, 5.0, 0.0), [*others, (GUEST, "guest", 8.0, 5.0)])
    sighting = find_guest(image)
    assert sighting is not None
    assert sighting.distance == pytest.approx(6.0, rel=0.05)


def test_a_guest_behind_a_wall_is_not_seen() -> None:
    image = sim_picture((2.0, 5.0, 0.0), [(GUEST, "guest", 10.0, 5.0)],
                        cells=hall_cells(inner_wall_x=6.0))
    assert find_guest(image) is None


# ---------------------------------------------------------------- the goal
def open_grid() -> OccupancyGrid2D:
    return OccupancyGrid2D(values=hall_cells(), resolution=RESOLUTION, origin_x=-1.0,
                           origin_y=-1.0)


def sighting_at(*, bearing: float, distance: float) -> GuestSighting:
    return GuestSighting(bearing=bearing, distance=distance, column=320.0, height_px=100,
                         clipped=False)


def test_the_goal_lies_short_of_the_guest_on_the_line_of_sight_facing_them() -> None:
    robot = Pose2D(5.0, 5.0, math.pi / 2)
    goal = camera_goal(robot, sighting_at(bearing=-math.pi / 2, distance=6.0), open_grid())
    assert goal is not None
    assert (goal.x, goal.y) == pytest.approx((5.0 + 6.0 - STAND_OFF, 5.0), abs=0.05)
    assert goal.yaw == pytest.approx(0.0, abs=0.02)


def test_a_guest_within_the_stand_off_is_faced_from_where_the_robot_stands() -> None:
    robot = Pose2D(5.0, 5.0, 0.0)
    goal = camera_goal(robot, sighting_at(bearing=0.5, distance=1.2), open_grid())
    assert goal == Pose2D(5.0, 5.0, 0.5)


def test_a_goal_in_a_wall_moves_to_free_floor_or_gives_none() -> None:
    grid = open_grid()
    robot = Pose2D(15.0, 10.0, 0.0)  # the guest at the far wall (x = 19 to 20)
    goal = camera_goal(robot, sighting_at(bearing=0.0, distance=5.5), grid)
    assert goal is not None and grid.is_free(goal.x, goal.y, 0.35)
    walled = np.full((440, 440), 100, dtype=np.int8)
    walled[200:240, 200:240] = 0  # a closet of 2 m around (10, 10)
    closet = OccupancyGrid2D(values=walled, resolution=RESOLUTION, origin_x=-1.0,
                             origin_y=-1.0)
    assert camera_goal(Pose2D(10.0, 10.0, 0.0), sighting_at(bearing=0.0, distance=8.0),
                       closet) is None


# ---------------------------------------------------------------- the look round
def test_a_look_round_faces_the_guests_last_place_first_and_then_every_way() -> None:
    turns = look_turns(Pose2D(0.0, 0.0, 0.0), towards=Pose2D(-3.0, -0.1), step=0.9)
    assert turns[0] == pytest.approx(-math.pi + math.atan(0.1 / 3.0))
    assert turns[1:] == [-0.9] * 6  # on the same way round
    headings = np.cumsum(turns)
    gaps = np.diff(np.sort(np.mod(headings, 2 * math.pi)))
    assert max([*gaps, 2 * math.pi - np.ptp(np.mod(headings, 2 * math.pi))]) < CAMERA.hfov


def test_without_a_last_place_the_first_look_is_straight_ahead() -> None:
    assert look_turns(Pose2D(1.0, 1.0, 2.0), towards=None, step=1.0) == [0.0] + [1.0] * 6
    assert look_turns(Pose2D(1.0, 1.0, 2.0), towards=Pose2D(1.1, 1.0), step=1.0)[0] == 0.0
    with pytest.raises(ValueError, match="step"):
        look_turns(Pose2D(0.0, 0.0), towards=None, step=0.0)


def test_the_goal_keeps_clear_of_someone_standing_beside_the_guest() -> None:
    robot = Pose2D(5.0, 5.0, 0.0)
    sighting = sighting_at(bearing=0.0, distance=6.0)  # the guest at (11, 5)
    plain = camera_goal(robot, sighting, open_grid())
    assert plain is not None and (plain.x, plain.y) == pytest.approx((9.4, 5.0), abs=0.05)
    idler = (9.4, 5.6)
    goal = camera_goal(robot, sighting, open_grid(), bystanders=[idler])
    assert goal is not None
    assert math.dist((goal.x, goal.y), idler) >= 1.0
    assert math.dist((goal.x, goal.y), (plain.x, plain.y)) <= 0.6
    crowd = [(9.4 + dx, 5.0 + dy) for dx in (-0.6, 0.0, 0.6) for dy in (-0.6, 0.6)]
    assert camera_goal(robot, sighting, open_grid(), bystanders=crowd) is None
