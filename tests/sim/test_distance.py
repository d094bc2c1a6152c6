"""The free space's distance transform, worked out on its bounding box, equals scipy's on the
whole grid cell for cell."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from servicesim_sim.world.distance import distance_to_blocked
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
