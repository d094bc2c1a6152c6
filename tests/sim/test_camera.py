"""The simulator's front camera: walls, and people the way OSRF's guest detector sees them.

The detector judges a blue shirt over red trousers and reads distance as 550·1.5 / height px;
these tests look at the pictures the same way, with colour thresholds rather than exact values.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from rclpy.context import Context
from rclpy.node import Node
from scipy import ndimage
from sensor_msgs.msg import Image

from servicesim_sim.model.camera import (
    CAMERA_HEIGHT,
    CEILING,
    COLUMNS_PER_RAY,
    FLOOR,
    HEAD,
    RATE_HZ,
    SHIRT,
    SKIN,
    TROUSERS,
    WALL,
    WALL_HEIGHT,
    FrontCamera,
    outfit,
    render_front_camera,
)
from servicesim_sim.model.scenario import Difficulty
from servicesim_sim.ros.node import SimulatorNode
from servicesim_sim.settings import SimSettings
from servicesim_sim.world.files import DEFAULT_WORLD, OccupancyMap, load_world

RESOLUTION = 0.05
GUEST = "human_20843"
WIDTH, HEIGHT = 640, 480


def hall(*, inner_wall_x: float | None = None) -> OccupancyMap:
    """A 20 x 20 m hall, walls at x, y = 0 and 20; optionally a wall across it at x."""
    grid = np.zeros((440, 440), dtype=np.int8)  # 22 x 22 m from (-1, -1)
    grid[:20, :] = grid[-20:, :] = grid[:, :20] = grid[:, -20:] = 100
    if inner_wall_x is not None:
        col = round((inner_wall_x + 1.0) / RESOLUTION)
        grid[:, col:col + 2] = 100
    return OccupancyMap(grid=grid, resolution=RESOLUTION, origin_x=-1.0, origin_y=-1.0)


HALL = hall()


def picture(robot: tuple[float, float, float], people: list[tuple[str, str, float, float]],
            occupancy_map: OccupancyMap = HALL) -> np.ndarray:
    return render_front_camera(robot=robot, people=people, guest_name=GUEST,
                               occupancy_map=occupancy_map)


def blue(image: np.ndarray) -> np.ndarray:
    r, g, b = (image[..., i].astype(int) for i in range(3))
    return (b >= 150) & (r <= 90) & (g <= 90)


def red(image: np.ndarray) -> np.ndarray:
    r, g, b = (image[..., i].astype(int) for i in range(3))
    return (r >= 150) & (g <= 90) & (b <= 90)


def box(mask: np.ndarray) -> tuple[int, int, int, int]:
    """(top, bottom, left, right) of the largest blob, bottom and right exclusive."""
    labels, count = ndimage.label(mask)
    assert count, "no blob"
    largest = np.argmax(np.bincount(labels.ravel())[1:]) + 1
    rows, cols = np.nonzero(labels == largest)
    return rows.min(), rows.max() + 1, cols.min(), cols.max() + 1


def blue_over_red(image: np.ndarray) -> bool:
    """Whether some column has blue pixels directly above red ones (a few rows' gap allowed)."""
    shirt, trousers = blue(image), red(image)
    below = np.zeros_like(trousers)
    for gap in range(1, 4):
        below[:-gap] |= trousers[gap:]
    return bool((shirt & below).any())


def test_the_picture_is_640_by_480_rgb8() -> None:
    image = picture((10.0, 10.0, 0.0), [])
    assert image.shape == (HEIGHT, WIDTH, 3) and image.dtype == np.uint8


@pytest.mark.parametrize("distance", [2.0, 3.0, 6.0])
def test_a_guest_straight_ahead_is_blue_over_red_centred_and_sized_by_the_pinhole(
        distance: float) -> None:
    image = picture((5.0, 10.0, 0.0), [(GUEST, "guest", 5.0 + distance, 10.0)])
    shirt_top, shirt_bottom, shirt_left, shirt_right = box(blue(image))
    trousers_top, trousers_bottom, trousers_left, trousers_right = box(red(image))
    assert shirt_bottom <= trousers_top + 1  # the shirt sits on the trousers
    for left, right in ((shirt_left, shirt_right), (trousers_left, trousers_right)):
        assert abs((left + right) / 2.0 - WIDTH / 2.0) <= 3.0
    expected = 550.0 * 1.5 / distance
    assert abs((trousers_bottom - shirt_top) - expected) <= 0.15 * expected


def test_a_guest_to_the_left_appears_left_of_centre_where_the_pinhole_puts_them() -> None:
    image = picture((5.0, 10.0, 0.0), [(GUEST, "guest", 9.0, 11.0)])  # 4 m ahead, 1 m left
    _, _, left, right = box(blue(image))
    focal = (WIDTH / 2.0) / math.tan(1.0629 / 2.0)
    assert abs((left + right) / 2.0 - (WIDTH / 2.0 - focal * 1.0 / 4.0)) <= 3.0


@pytest.mark.parametrize("yaw", [math.pi, math.pi / 2.0, -math.pi / 2.0])
def test_a_guest_behind_or_beside_the_robot_is_not_drawn(yaw: float) -> None:
    image = picture((5.0, 10.0, yaw), [(GUEST, "guest", 8.0, 10.0)])
    assert not blue(image).any() and not red(image).any()


def test_a_guest_behind_a_wall_is_not_drawn_and_one_before_it_is() -> None:
    walled = hall(inner_wall_x=7.0)
    hidden = picture((5.0, 10.0, 0.0), [(GUEST, "guest", 9.0, 10.0)], walled)
    assert not blue(hidden).any() and not red(hidden).any()
    seen = picture((5.0, 10.0, 0.0), [(GUEST, "guest", 6.5, 10.0)], walled)
    assert blue_over_red(seen)


def test_a_nearer_person_hides_the_guest_behind_them() -> None:
    alone = picture((5.0, 10.0, 0.0), [(GUEST, "guest", 10.0, 10.0)])
    hidden = picture((5.0, 10.0, 0.0), [(GUEST, "guest", 10.0, 10.0),
                                        ("human_00001", "walker", 7.0, 10.0)])
    assert blue(alone).sum() > 1000
    assert not blue(hidden).any()


def non_guest_names() -> list[str]:
    return [f"human_{n:05d}" for n in range(0, 100_000, 37) if f"human_{n:05d}" != GUEST]


def swatch(colour: tuple[int, int, int]) -> np.ndarray:
    return np.array([[colour]], dtype=np.uint8)


def test_nobody_but_the_guest_wears_blue_over_red() -> None:
    shirt, trousers = outfit(GUEST, guest_name=GUEST)
    assert blue(swatch(shirt)).all() and red(swatch(trousers)).all()
    outfits = {outfit(name, guest_name=GUEST) for name in non_guest_names()}
    assert len(outfits) > 10  # people differ
    assert not any(blue(swatch(shirt)).all() and red(swatch(trousers)).all()
                   for shirt, trousers in outfits)
    for name in non_guest_names()[::70]:
        image = picture((5.0, 10.0, 0.0), [(name, "idler", 8.0, 10.0)])
        assert not blue_over_red(image), name


def test_the_same_name_always_wears_the_same_colours() -> None:
    names = non_guest_names()
    assert [outfit(n, guest_name=GUEST) for n in names] == [
        outfit(n, guest_name=GUEST) for n in names]


def wall_rows(image: np.ndarray, column: int) -> int:
    """How many rows of a column are neither ceiling nor floor colour."""
    pixels = image[:, column]
    return int((np.any(pixels != CEILING, axis=1) & np.any(pixels != FLOOR, axis=1)).sum())


@pytest.mark.parametrize("distance", [1.0, 4.0, 8.0])
def test_a_wall_ahead_spans_the_rows_the_pinhole_gives_for_its_distance(distance: float) -> None:
    image = picture((20.0 - distance, 10.0, 0.0), [])
    focal = FrontCamera(HALL).focal_length
    top = max(0.0, HEIGHT / 2.0 - focal * 1.5 / distance)  # the wall is 2.5 m tall and
    bottom = min(HEIGHT, HEIGHT / 2.0 + focal * 1.0 / distance)  # the camera 1.0 m high
    assert abs(wall_rows(image, WIDTH // 2) - (bottom - top)) <= 0.05 * (bottom - top) + 2


def test_a_nearer_wall_looks_taller_and_the_floor_and_ceiling_differ() -> None:
    near, far = picture((17.0, 10.0, 0.0), []), picture((5.0, 10.0, 0.0), [])
    assert wall_rows(near, WIDTH // 2) > 2 * wall_rows(far, WIDTH // 2)
    assert tuple(far[0, WIDTH // 2]) == CEILING and tuple(far[-1, WIDTH // 2]) == FLOOR
    assert CEILING != FLOOR


@pytest.mark.filterwarnings("error")
def test_a_robot_against_a_wall_sees_nothing_but_wall() -> None:
    image = picture((20.0, 10.0, 0.0), [])  # right on the face of the wall at x = 20
    assert wall_rows(image, WIDTH // 2) == HEIGHT


def test_a_bad_camera_size_is_refused() -> None:
    with pytest.raises(ValueError, match="hfov"):
        FrontCamera(HALL, hfov=0.0)


# ------------------------------------------------------------------ the node's frame rate
def test_the_node_renders_the_originals_24_frames_a_sim_second_only_for_a_subscriber(
        ros_context: Context) -> None:
    # servicebot.urdf: the FrontCamera sensor's update_rate is 24; frames fall between the
    # 0.1 s I/O periods, so the rate is not capped at the I/O rate (10 a sim second)
    settings = SimSettings(world=load_world(DEFAULT_WORLD), seed=None, speed=0.0,
                           difficulty=Difficulty.default(), camera_rate_hz=RATE_HZ)
    node = Node("servicesim_camera", context=ros_context)
    simulator = SimulatorNode(settings, node=node)
    run_for(simulator, sim_seconds=1.0)
    assert simulator.camera.frames == []  # nobody subscribes: nothing rendered
    viewer = Node("viewer", context=ros_context)
    viewer.create_subscription(Image, "/servicebot/camera_front/image_raw", lambda _: None, 50)
    deadline = time.monotonic() + 20.0
    while simulator.camera.publisher.get_subscription_count() == 0:
        assert time.monotonic() < deadline, "the viewer was never discovered"
        time.sleep(0.05)
    start = simulator.engine.sim_time
    stamps = run_for(simulator, sim_seconds=2.0)
    assert len(stamps) == 48
    gaps = np.round(np.diff(stamps), 6)
    assert set(gaps) <= {0.04, 0.06}
    assert start < stamps[0] and stamps[-1] <= start + 2.0 + 1e-9
    simulator.camera.publish()
    assert simulator.camera.frames == []
    viewer.destroy_node()
    node.destroy_node()


def run_for(simulator: SimulatorNode, *, sim_seconds: float) -> list[float]:
    """Step the simulator's engine as its loop does, capturing frames; their stamps."""
    simulator.camera.frames.clear()
    for _ in range(round(sim_seconds / simulator.engine.dt)):
        simulator.engine.step()
        simulator.camera.capture()
    return [when for when, _ in simulator.camera.frames]


class RayByRayCamera(FrontCamera):
    """The camera drawing walls a ray at a time and every part of every figure, with no
    shortcut: the reference the frames must equal bit for bit."""

    def _draw_room(self, image: np.ndarray, depths: np.ndarray, along_x: np.ndarray) -> None:
        horizon = self.height // 2
        image[:horizon] = CEILING
        image[horizon:] = FLOOR
        fx, centre = self.focal_length, self.height / 2.0
        tops = np.clip(np.rint(centre - fx * (WALL_HEIGHT - CAMERA_HEIGHT) / depths), 0,
                       self.height).astype(int)
        bottoms = np.clip(np.rint(centre + fx * CAMERA_HEIGHT / depths), 0,
                          self.height).astype(int)
        shade = np.clip(1.0 - depths / 30.0, 0.35, 1.0) * np.where(along_x, 0.86, 1.0)
        colours = shade[:, None] * np.asarray(WALL, dtype=float)
        for ray, (top, bottom) in enumerate(zip(tops, bottoms, strict=True)):
            first = ray * COLUMNS_PER_RAY
            image[top:bottom, first:first + COLUMNS_PER_RAY] = colours[ray]

    def _draw_figure(self, image: np.ndarray, column_depths: np.ndarray, *, depth: float,
                     lateral: float, outfit: tuple[tuple[int, int, int],
                                                   tuple[int, int, int]]) -> None:
        shirt, trousers = outfit
        for (_part, bottom, top, width), colour in ((TROUSERS, trousers), (SHIRT, shirt),
                                                    (HEAD, SKIN)):
            scale = self.focal_length / depth
            middle = self.width / 2.0 - lateral * scale
            left = max(0, round(middle - width / 2.0 * scale))
            right = min(self.width, round(middle + width / 2.0 * scale))
            upper = max(0, round(self.height / 2.0 - (top - CAMERA_HEIGHT) * scale))
            lower = min(self.height, round(self.height / 2.0 - (bottom - CAMERA_HEIGHT) * scale))
            if left >= right or upper >= lower:
                continue
            seen = column_depths[left:right] > depth
            image[upper:lower, left:right][:, seen] = colour


@pytest.mark.parametrize("width", [WIDTH, 62])
def test_frames_equal_the_ray_by_ray_drawing_bit_for_bit(width: int) -> None:
    office = load_world(DEFAULT_WORLD).map
    camera, reference = FrontCamera(office, width=width), RayByRayCamera(office, width=width)
    rng = np.random.default_rng(15)
    free = np.argwhere(office.free_mask())
    for _ in range(40):
        row, col = free[rng.integers(len(free))]
        x, y = office.cell_to_world(int(row), int(col))
        robot = (x, y, float(rng.uniform(-math.pi, math.pi)))
        people = [(f"human_{index:05d}", "idler", x + float(dx), y + float(dy))
                  for index, (dx, dy) in enumerate(rng.uniform(-6.0, 6.0, size=(30, 2)))]
        people.append((GUEST, "guest", x + 1.5 * math.cos(robot[2]), y + 1.5 * math.sin(robot[2])))
        assert np.array_equal(camera.render(robot=robot, people=people, guest_name=GUEST),
                              reference.render(robot=robot, people=people, guest_name=GUEST))
