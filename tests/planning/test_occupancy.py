"""The occupancy model: message conventions, clearance, free-space queries, reachability, routes.

Maps are small synthetic nav_msgs/OccupancyGrid messages (``tests.fakes.maps.grid_message``), so
every expected figure can be worked out by hand from the walls the test draws.
"""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys

import numpy as np
import pytest

from bt_servicesim.planning.occupancy import Cell, OccupancyGrid2D
from tests.fakes.maps import RESOLUTION, cells, fill, grid_message


def two_rooms(door_width: float) -> OccupancyGrid2D:
    """10 x 6 m, split at x = 5 by a 0.2 m wall with a door at y = 2.5 .. 2.5 + door_width."""
    values = cells(10.0, 6.0)
    fill(values, 5.0, 0.0, 5.2, 2.5)
    fill(values, 5.0, 2.5 + door_width, 5.2, 6.0)
    return OccupancyGrid2D.from_message(grid_message(values))


def test_the_behaviours_import_the_grid_without_scipy() -> None:
    """A command that refuses a tree file imports every behaviour, whose ports name the grid,
    and computes nothing: scipy comes with the first computation, not with the import."""
    program = ("import sys, bt_servicesim.tree.loading; "
               "print(sorted(name for name in sys.modules if name.split('.')[0] == 'scipy'))")
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.strip() == "[]"


def test_message_layout_row_zero_at_origin_y() -> None:
    values = np.zeros((3, 4), dtype=np.int8)
    values[2, 1] = 100  # third row from the bottom, second column
    grid = OccupancyGrid2D.from_message(grid_message(values, resolution=0.5, origin=(-1.0, 2.0)))
    assert (grid.width, grid.height) == (4, 3)
    assert grid.world_to_cell(-0.25, 3.25) == Cell(row=2, col=1)
    assert grid.cell_to_world(Cell(row=2, col=1)) == (-0.25, 3.25)
    assert not grid.is_free(-0.25, 3.25)
    assert grid.is_free(-0.75, 3.25)
    assert grid.world_to_cell(-1.1, 1.9) == Cell(row=-1, col=-1)
    assert not grid.contains_cell(grid.world_to_cell(-1.1, 1.9))


def test_clearance_is_the_distance_to_the_nearest_blocked_cell() -> None:
    values = cells(6.0, 4.0)
    fill(values, 3.0, 0.0, 3.5, 4.0)  # a wall from x = 3.0 to 3.5
    grid = OccupancyGrid2D.from_message(grid_message(values))
    # the map's own edge counts as unknown, so the middle of the left part is 1.5 m from both
    assert grid.clearance(1.5, 2.0) == pytest.approx(1.5, abs=0.03)
    assert grid.clearance(2.6, 2.0) == pytest.approx(0.4, abs=0.03)
    assert grid.clearance(3.2, 2.0) == 0.0
    assert grid.clearance(-0.5, 2.0) == 0.0  # outside the map
    assert grid.is_free(2.6, 2.0, clearance=0.35)
    assert not grid.is_free(2.75, 2.0, clearance=0.35)


def test_the_same_map_again_reuses_its_clearances_and_another_map_gets_its_own() -> None:
    values = cells(6.0, 4.0)
    fill(values, 3.0, 0.0, 3.5, 4.0)
    first = OccupancyGrid2D.from_message(grid_message(values))
    again = OccupancyGrid2D.from_message(grid_message(values))  # an executive's next episode
    assert again.clearances is first.clearances
    assert not again.clearances.flags.writeable
    fill(values, 1.0, 1.0, 1.5, 1.5)  # a pillar: the clearances must see it
    other = OccupancyGrid2D.from_message(grid_message(values))
    assert other.clearances is not first.clearances
    assert other.clearance(1.25, 1.25) == 0.0 < first.clearance(1.25, 1.25)
    coarser = OccupancyGrid2D.from_message(grid_message(values, resolution=2 * RESOLUTION))
    assert coarser.clearances is not other.clearances, "the resolution counts"
    assert np.allclose(coarser.clearances, 2.0 * other.clearances)  # same cells, twice the size


@pytest.mark.parametrize("seed", range(6))
def test_clearances_are_one_distance_transform_of_the_whole_padded_map(seed: int) -> None:
    """Worked out on the free cells' bounding box, every cell's clearance is the one the whole
    map's transform gives, the map's edge counting as unknown: free space inside the map, and
    free space that reaches its edges."""
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    values = cells(6.0, 4.0)
    values[:] = -1
    rows, cols = values.shape
    top, left = (0, 0) if seed % 2 else (rows // 4, cols // 5)
    room = rng.random((rows - top - rows // 6, cols - left - cols // 7)) < 0.7
    values[top:top + room.shape[0], left:left + room.shape[1]] = np.where(room, 0, 100)
    grid = OccupancyGrid2D.from_message(grid_message(values, resolution=RESOLUTION * (1 + seed)))
    blocked = (values < 0) | (values >= 50)
    whole = ndimage.distance_transform_edt(~np.pad(blocked, 1, constant_values=True))[1:-1, 1:-1]
    expected = np.where(blocked, 0.0, (whole - 0.5) * RESOLUTION * (1 + seed)).astype(np.float32)
    assert np.array_equal(grid.clearances, expected)


def test_unknown_and_intermediate_values() -> None:
    values = cells(4.0, 4.0)
    fill(values, 2.0, 0.0, 4.0, 4.0, value=-1)
    values[10, 10] = 49  # a probability below the occupied threshold is free
    values[10, 20] = 50
    grid = OccupancyGrid2D.from_message(grid_message(values))
    assert not grid.is_free(3.0, 2.0)
    assert grid.clearance(1.5, 2.0) == pytest.approx(0.5, abs=0.03)
    assert grid.is_free(0.525, 0.525)
    assert not grid.is_free(1.025, 0.525)


def test_nearest_free_with_clearance_within_radius_and_mask() -> None:
    grid = two_rooms(door_width=1.0)
    assert grid.nearest_free(2.0, 3.0, clearance=0.35, max_radius=1.0) == (2.0, 3.0)
    x, y = grid.nearest_free(4.9, 1.0, clearance=0.35, max_radius=1.0)
    assert grid.clearance(x, y) >= 0.35
    assert math.dist((x, y), (4.9, 1.0)) == pytest.approx(0.25 + 0.025, abs=0.04)
    assert grid.nearest_free(5.1, 1.0, clearance=0.35, max_radius=0.3) is None
    right = np.zeros((grid.height, grid.width), dtype=bool)
    right[:, round(5.2 / RESOLUTION):] = True
    x, y = grid.nearest_free(4.9, 1.0, clearance=0.35, max_radius=1.0, within=right)
    assert x > 5.2 and grid.clearance(x, y) >= 0.35


def test_reachable_through_a_door_only_if_it_is_wide_enough() -> None:
    wide, narrow = two_rooms(door_width=1.0), two_rooms(door_width=0.6)
    for grid, connected in ((wide, True), (narrow, False)):
        reachable = grid.reachable_from(1.0, 1.0, 0.35)
        assert reachable[grid.world_to_cell(1.0, 5.0)]
        assert bool(reachable[grid.world_to_cell(8.0, 3.0)]) is connected
        assert not reachable[grid.world_to_cell(5.1, 1.0)]
    assert narrow.reachable_from(1.0, 1.0, 0.2)[narrow.world_to_cell(8.0, 3.0)]


def test_reachable_from_snaps_a_start_close_to_a_wall_and_caches_labels() -> None:
    grid = two_rooms(door_width=1.0)
    near_wall = grid.reachable_from(4.8, 1.0, 0.35)  # 0.2 m from the wall
    assert near_wall[grid.world_to_cell(1.0, 1.0)]
    inside_wall = grid.reachable_from(5.1, 1.0, 0.35)  # 0.45 m from room on either side
    assert inside_wall[grid.world_to_cell(1.0, 1.0)] or inside_wall[grid.world_to_cell(8.0, 1.0)]
    assert not grid.reachable_from(-1.0, -1.0, 0.35).any()  # off the map, far from free space
    assert grid.components(0.35) is grid.components(0.35)
    assert grid.components(0.35) is not grid.components(0.2)


def test_clear_lines() -> None:
    grid = two_rooms(door_width=1.0)
    clear = grid.clear_lines(1.0, 3.0, np.array([4.0, 8.0, 8.0]), np.array([3.0, 3.0, 1.0]), 0.35)
    assert clear.tolist() == [True, True, False]


def test_routes_go_round_the_wall_through_the_door() -> None:
    grid = two_rooms(door_width=1.0)
    routes = grid.routes_from(2.0, 1.0, 0.35)
    assert routes is not None
    via_door = math.dist((2.0, 1.0), (5.1, 3.0)) + math.dist((5.1, 3.0), (8.0, 1.0))
    distance = routes.distance_to(8.0, 1.0)
    assert via_door <= distance <= via_door * 1.1
    path = routes.path_back_from(8.0, 1.0, max_length=100.0)
    assert math.dist(path[0], (8.0, 1.0)) < 0.1
    assert math.dist(path[-1], (2.0, 1.0)) < 0.1
    crossing = path[np.argmin(abs(path[:, 0] - 5.1))]
    assert 2.5 + 0.3 <= crossing[1] <= 3.5 - 0.3
    assert len(routes.path_back_from(8.0, 1.0, max_length=1.0)) <= 12
    assert routes.distance_to(5.1, 1.0) == math.inf
    assert grid.routes_from(-1.0, -1.0, 0.35) is None
    # node by node, the same route from the start, in order
    end = int(np.argmin(np.hypot(*(routes.points(np.arange(len(routes.node_cells)))
                                   - (8.0, 1.0)).T)))
    nodes = routes.route_to(end)
    assert routes.distances[nodes[0]] == 0.0 and nodes[-1] == end
    assert np.all(np.diff(routes.distances[nodes]) > 0.0)
    steps = np.hypot(*np.diff(routes.points(nodes), axis=0).T)  # lattice neighbours each
    assert np.all(steps <= routes.stride * grid.resolution * math.sqrt(2) + 1e-9)


def test_window_holds_the_cells_whose_centres_lie_inside() -> None:
    grid = two_rooms(door_width=1.0)
    window = grid.window(1.0, 2.0, 1.2, 2.1)
    assert window.xs.tolist() == pytest.approx([1.025, 1.075, 1.125, 1.175])
    assert window.ys.tolist() == pytest.approx([2.025, 2.075])
    assert grid.window(-3.0, -3.0, -1.0, -1.0).is_empty
    clipped = grid.window(-1.0, -1.0, 0.1, 0.1)
    assert (clipped.rows, clipped.cols) == (slice(0, 2), slice(0, 2))


def test_the_model_is_frozen() -> None:
    grid = two_rooms(door_width=1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        grid.resolution = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        grid.values[0, 0] = 100
    with pytest.raises(ValueError, match="read-only"):
        grid.clearances[0, 0] = 1.0


def test_bad_messages_are_refused_with_the_reason() -> None:
    message = grid_message(np.zeros((3, 4), dtype=np.int8))
    message.data = [0] * 11
    with pytest.raises(ValueError, match="3 cells carries 11 values, expected 12"):
        OccupancyGrid2D.from_message(message)
    rotated = grid_message(np.zeros((3, 4), dtype=np.int8))
    rotated.info.origin.orientation.z = math.sin(0.25)
    rotated.info.origin.orientation.w = math.cos(0.25)
    with pytest.raises(ValueError, match="rotated map origins"):
        OccupancyGrid2D.from_message(rotated)
    zero = grid_message(np.zeros((3, 4), dtype=np.int8), resolution=0.0)
    with pytest.raises(ValueError, match="resolution must be positive"):
        OccupancyGrid2D.from_message(zero)


def test_route_lengths_to_many_points_at_once_agree_with_one_at_a_time() -> None:
    grid = two_rooms(door_width=1.0)
    routes = grid.routes_from(2.0, 1.0, 0.35)
    assert routes is not None
    xs, ys = np.array([8.0, 2.5, 5.1, 6.33, 1.07]), np.array([1.0, 3.3, 1.0, 2.71, 0.52])
    many = routes.distances_at(xs, ys)
    assert many.tolist() == [routes.distance_to(x, y) for x, y in zip(xs, ys, strict=True)]
    assert many[2] == math.inf  # inside the wall
    scattered = np.random.default_rng(5).uniform(-1.0, 11.0, (2, 500))  # some off the map
    at_once = routes.distances_at(*scattered).tolist()
    one_by_one = [routes.distance_to(x, y) for x, y in scattered.T]
    assert at_once == one_by_one and any(math.isinf(d) for d in at_once)


def test_route_trees_are_kept_for_the_places_last_asked_about() -> None:
    grid = two_rooms(door_width=1.0)
    routes = grid.routes_from(2.0, 1.0, 0.35)
    assert grid.routes_from(2.0, 1.0, 0.35) is routes
    for x in (1.0, 1.5, 2.5, 3.0):
        grid.routes_from(x, 1.0, 0.35)
    again = grid.routes_from(2.0, 1.0, 0.35)
    assert again is not routes and again is not None
    assert again.distance_to(8.0, 1.0) == routes.distance_to(8.0, 1.0)
