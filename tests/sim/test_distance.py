"""The distance transforms worked out where they are read equal scipy's on the whole grid: the
free space's on its bounding box cell for cell, the depths into obstacles within their reach."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from servicesim_sim.world.distance import depth_in_blocked, distance_to_blocked
from servicesim_sim.world.files import DEFAULT_WORLD, load_world


def _grid(seed: int, *, shape: tuple[int, int], box: tuple[slice, slice],
          free_share: float) -> np.ndarray:
    """Free cells scattered (and in blobs) inside ``box`` of an otherwise blocked grid."""
    rng = np.random.default_rng(seed)
    free = np.zeros(shape, dtype=bool)
    inner = rng.random(free[box].shape) < free_share
    free[box] = ndimage.binary_dilation(inner) if seed % 2 else inner
    return free


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("box", [
    (slice(10, 30), slice(5, 50)),  # well inside the grid
    (slice(0, 25), slice(0, 60)),  # touching the bottom, left and right edges
    (slice(3, 40), slice(20, 21)),  # one column wide
])
def test_the_boxed_transform_equals_the_whole_grids(seed: int, box: tuple[slice, slice]) -> None:
    free = _grid(seed, shape=(40, 60), box=box, free_share=0.3)
    assert np.array_equal(distance_to_blocked(free), ndimage.distance_transform_edt(free))


@pytest.mark.parametrize("free", [
    np.zeros((7, 9), dtype=bool),  # nothing free
    np.eye(7, 9, dtype=bool),  # a diagonal from corner to corner
    np.pad(np.ones((3, 3), dtype=bool), 2),  # one room
])
def test_edge_cases_equal_the_whole_grids_transform(free: np.ndarray) -> None:
    assert np.array_equal(distance_to_blocked(free), ndimage.distance_transform_edt(free))


def test_the_office_maps_wall_distance_is_the_whole_grids_transform() -> None:
    occupancy = load_world(DEFAULT_WORLD).map
    whole = ndimage.distance_transform_edt(occupancy.free_mask()) * occupancy.resolution
    assert np.array_equal(occupancy.wall_distance, whole)


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("box", [
    (slice(10, 30), slice(5, 50)),  # well inside the grid
    (slice(0, 25), slice(0, 60)),  # touching the bottom, left and right edges
    (slice(3, 40), slice(20, 21)),  # one column wide
])
@pytest.mark.parametrize("reach", [1, 4, 100])
def test_depths_within_the_reach_equal_the_whole_grids_transform_and_none_beyond_it_reads_less(
        seed: int, box: tuple[slice, slice], reach: int) -> None:
    blocked = ~_grid(seed, shape=(40, 60), box=box, free_share=0.3)
    whole = ndimage.distance_transform_edt(blocked)
    depth = depth_in_blocked(blocked, reach=reach)
    near = whole <= reach
    assert np.array_equal(depth[near], whole[near])
    assert np.all((depth[~near] == whole[~near]) | (depth[~near] == reach))


def test_with_no_free_cell_every_depth_is_the_reach() -> None:
    assert np.array_equal(depth_in_blocked(np.ones((5, 6), dtype=bool), reach=3),
                          np.full((5, 6), 3.0))


def test_the_office_depths_near_its_free_space_are_the_whole_grids_transform() -> None:
    occupancy = load_world(DEFAULT_WORLD).map
    blocked = np.pad(occupancy.blocked_mask(), 1, constant_values=True)
    whole = ndimage.distance_transform_edt(blocked)
    depth = depth_in_blocked(blocked, reach=40)
    near = whole <= 40
    assert np.array_equal(depth[near], whole[near])
    assert np.all((depth[~near] == whole[~near]) | (depth[~near] == 40))
    assert np.count_nonzero(depth[~near] == 40) > blocked.size // 2, "most of the grid is far out"
