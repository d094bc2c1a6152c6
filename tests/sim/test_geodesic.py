"""The lattice search with targets: it stops once every target its seeds can reach is settled,
and gives every node no farther than the farthest of them the distance and the way the whole
search gives it (on random maps, against the search without targets)."""

from __future__ import annotations

import numpy as np
import pytest

from servicesim_sim.navigation.geodesic import LatticeGraph


def random_lattice(seed: int) -> tuple[LatticeGraph, np.random.Generator]:
    """A 40 x 40 map of 0.1 m cells with random walls (some of it walled off)."""
    rng = np.random.default_rng(seed)
    free = rng.random((40, 40)) > 0.3
    free[:, 15:25] = False  # a 1 m wall across, with a door in it for half the maps
    if seed % 2:
        free[18:22, 15:25] = True
    return LatticeGraph(free, resolution=0.1, origin=(0.0, 0.0)), rng


@pytest.mark.parametrize("seed", range(8))
def test_a_search_with_targets_settles_them_as_the_whole_search_does(seed: int) -> None:
    lattice, rng = random_lattice(seed)
    seeds = rng.choice(lattice.nodes, size=5, replace=False)
    values = rng.random(5) * 2.0
    targets = np.zeros(lattice.nodes, dtype=bool)
    targets[rng.choice(lattice.nodes, size=20, replace=False)] = True
    whole = lattice.search(seeds, values)
    cut = lattice.search(seeds, values, targets=targets)
    reached = targets & np.isfinite(whole.distances)
    assert np.array_equal(cut.distances[targets], whole.distances[targets])
    near = whole.distances <= whole.distances[reached].max() if reached.any() else (
        whole.distances < -1.0)
    assert np.array_equal(cut.distances[near], whole.distances[near])
    assert np.array_equal(cut.predecessors[near], whole.predecessors[near])
    for node in np.flatnonzero(reached)[:5]:
        assert cut.way_to(int(node)) == whole.way_to(int(node))


def test_a_search_whose_targets_are_near_goes_no_farther() -> None:
    free = np.ones((10, 200), dtype=bool)  # a 1 x 20 m corridor
    lattice = LatticeGraph(free, resolution=0.1, origin=(0.0, 0.0))
    seeds = lattice.cell_corners(0.55, 0.55)
    targets = (lattice.x <= 2.0)
    cut = lattice.search(seeds, np.zeros(seeds.size), targets=targets)
    assert np.isfinite(cut.distances[targets]).all()
    assert not np.isfinite(cut.distances[lattice.x >= 10.0]).any()


def test_targets_the_seeds_cannot_reach_are_left_unreached() -> None:
    free = np.ones((20, 50), dtype=bool)
    free[:, 20:30] = False  # a 1 m wall from side to side: two rooms (the lattice, generous
    # near walls, steps over a thin one)
    lattice = LatticeGraph(free, resolution=0.1, origin=(0.0, 0.0))
    seeds = lattice.cell_corners(0.55, 0.55)
    beyond = lattice.x >= 3.0
    cut = lattice.search(seeds, np.zeros(seeds.size), targets=beyond)
    assert not np.isfinite(cut.distances[beyond]).any()
    both = beyond | (lattice.x <= 1.0)
    cut = lattice.search(seeds, np.zeros(seeds.size), targets=both)
    whole = lattice.search(seeds, np.zeros(seeds.size))
    assert np.array_equal(cut.distances[both], whole.distances[both])
