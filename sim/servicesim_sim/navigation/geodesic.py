"""Lower bounds on the length of collision-free paths: a lattice search that never overestimates.

Design intent: the kinematic bound of a task (:mod:`servicesim_sim.task_bound`) needs the
length of the shortest path the robot's origin can take through the static map, and it must
be a true *lower* bound, so that no mission can beat it. An 8-connected grid search
overestimates (up to 8 % 22.5 degrees off an axis), any-angle searches return some path, not
the shortest. So the search here runs on a graph built to contain a staircase copy of every
feasible path, and its result is shrunk by the staircase's known worst-case excess:

* **Free space.** The robot's origin may be in a map cell whose wall clearance (the simulator's
  distance transform, as :class:`servicesim_sim.model.robot.WallClearance` keeps it) is at least
  the body radius: :meth:`servicesim_sim.model.robot.Robot.step` refuses any other step. Free
  space ``F`` is the union of those (closed) cells, so the shortest path in it is a polyline
  that bends only at cell corners.
* **Nodes** are the cell corners (a lattice of pitch ``res``) within ``(1 + sqrt 2) res`` of a
  corner of a free cell; **edges** join nodes by the primitive lattice steps ``(a, b)`` with
  ``|a|, |b| <= max_step`` (32 directions for ``max_step`` 3), weighted by their length.
* **Why the search cannot overestimate.** Two neighbouring step directions ``u``, ``v`` span
  a unimodular cone (adjacent Farey fractions), so a segment between two corners in that cone
  is an integer sum of ``u`` and ``v`` steps; ordered greedily those steps stay within one
  ``res`` of the segment, and their length is at most ``1 / cos(gap / 2)`` times the
  segment's, ``gap`` being the largest angle between neighbouring directions
  (:attr:`LatticeGraph.ratio`, 1.013 for ``max_step`` 3). A task's path also passes through a
  few points that are no corners (its start, where it enters an area, where it picks up):
  moving each to a corner within ``res / sqrt 2`` lengthens the path by at most ``res sqrt 2``
  each (:meth:`LatticeGraph.junction_slack`) and moves its segments by as much. So every
  feasible path has a copy in the graph no longer than ``ratio`` times (its length plus the
  junctions' slack): the graph's shortest path divided by ``ratio``, less the slack, is a
  lower bound. Extra nodes and edges (the graph is generous near walls) only lower it further.

Searches are Dijkstra's algorithm from ``scipy.sparse.csgraph`` from a virtual source joined
to seed nodes by edges of the seeds' starting values, so one search continues where another
left off (reach an area, then the next one). A search told its *targets* (the nodes whose
distances the next step needs) settles only the nodes no farther than the farthest target it
can reach: Dijkstra's algorithm settles nodes in order of distance, so cut at any limit it has
given every node within the limit the distance of the whole search, and a way as short (the
same way where no two are exactly as short; the tests compare the ways too). The limit starts
at a guess from the straight-line distances and grows until every target the seeds can reach
(the graph's connected components say which) is settled. No ROS here.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage, sparse
from scipy.sparse import csgraph

DEFAULT_MAX_STEP = 3
SEED_OFFSET = 1.0  # added to every seed edge (scipy drops explicit zero weights), taken off after
FIRST_LIMIT_MARGIN = 1.25
"""The first limit of a search with targets: this times the farthest target's straight-line
reach (paths round walls are longer; most of a building's are within a quarter)."""
LIMIT_GROWTH = 1.5
"""How much a limit grows when a target it can reach lay beyond it."""


@dataclass(frozen=True)
class Search:
    """One seeded search: each node's graph distance and predecessor (inf and -9999 where it is
    unreachable, or farther than a search with targets needed to go)."""

    distances: np.ndarray
    predecessors: np.ndarray
    source: int

    def way_to(self, node: int) -> list[int]:
        """The nodes of the shortest way to ``node``, from the seed it started at."""
        way = [node]
        while True:
            previous = int(self.predecessors[way[-1]])
            if previous == self.source:
                return way[::-1]
            if previous < 0:
                raise ValueError(f"node {node} was not reached from any seed")
            way.append(previous)


def step_directions(max_step: int) -> list[tuple[int, int]]:
    """The primitive lattice steps ``(di, dj)`` with ``|di|, |dj| <= max_step``, by angle."""
    steps = {(di, dj) for di in range(-max_step, max_step + 1)
             for dj in range(-max_step, max_step + 1)
             if (di, dj) != (0, 0) and math.gcd(di, dj) == 1}
    return sorted(steps, key=lambda step: math.atan2(step[0], step[1]))


def worst_excess_ratio(max_step: int) -> float:
    """``1 / cos(gap / 2)``: the most a staircase of the steps exceeds the segment it copies."""
    slopes = sorted({Fraction(a, b) for b in range(1, max_step + 1) for a in range(0, b + 1)})
    gap = max(math.atan(float(high)) - math.atan(float(low))
              for low, high in itertools.pairwise(slopes))
    return 1.0 / math.cos(gap / 2.0)


class LatticeGraph:
    """The corner lattice of a map's free cells, searched for lower bounds on path lengths.

    ``free`` holds the cells the robot's origin may occupy (row 0 at ``origin_y``, rows growing
    with +y, as :class:`servicesim_sim.world.files.OccupancyMap`)."""

    def __init__(self, free: np.ndarray, *, resolution: float, origin: tuple[float, float],
                 max_step: int = DEFAULT_MAX_STEP) -> None:
        self.resolution = resolution
        self.ratio = worst_excess_ratio(max_step)
        touching = _corners_of(free)
        gap = ndimage.distance_transform_edt(~touching) if touching.any() else None
        allowed = (np.zeros_like(touching) if gap is None
                   else gap <= 1.0 + math.sqrt(2.0) + 1e-9)
        rows, cols = np.nonzero(allowed)
        if rows.size == 0:
            raise ValueError("the map has no cell where the robot fits")
        self._row0, self._col0 = int(rows.min()), int(cols.min())
        allowed = allowed[self._row0:rows.max() + 1, self._col0:cols.max() + 1]
        self.index: NDArray[np.int32] = np.full(allowed.shape, -1, dtype=np.int32)
        self.index[allowed] = np.arange(int(allowed.sum()), dtype=np.int32)
        self.nodes = int(allowed.sum())
        self.source = self.nodes  # the virtual node every search starts from
        node_rows, node_cols = np.nonzero(allowed)
        self._x0 = origin[0] + self._col0 * resolution
        self._y0 = origin[1] + self._row0 * resolution
        self.x = self._x0 + node_cols * resolution
        self.y = self._y0 + node_rows * resolution
        self._indptr, self._data, self._indices = self._edges(max_step)
        self._labels: np.ndarray | None = None

    def junction_slack(self, junctions: int) -> float:
        """Metres the graph's copy may add for ``junctions`` points of a path that are no
        corners (``res / sqrt 2`` on each side of an interior one; count ends as halves)."""
        return junctions * self.resolution * math.sqrt(2.0)

    def snap_radius(self) -> float:
        """How far a junction may move to a corner: regions must reach out this far."""
        return self.resolution / math.sqrt(2.0)

    def cell_corners(self, x: float, y: float) -> np.ndarray:
        """The nodes at the corners of the cell holding ``(x, y)``."""
        col = math.floor((x - self._x0) / self.resolution)
        row = math.floor((y - self._y0) / self.resolution)
        found = [int(self.index[r, c]) for r in (row, row + 1) for c in (col, col + 1)
                 if 0 <= r < self.index.shape[0] and 0 <= c < self.index.shape[1]
                 and self.index[r, c] >= 0]
        return np.array(found, dtype=np.int64)

    def search(self, seeds: np.ndarray, values: np.ndarray, *,
               targets: np.ndarray | None = None) -> Search:
        """Graph distances from the seeds, each starting at its value (metres). The seeds are
        written into the room the lattice keeps for them: one search at a time.

        Given ``targets`` (a mask over the nodes), the search goes only as far as it must to
        settle every target the seeds can reach: those, and every node no farther, get the
        distance the whole search gives them (and a way as short); farther nodes may be left
        unreached."""
        if seeds.size == 0:
            raise ValueError("a search needs at least one seed node")
        if seeds.size > self.nodes:
            raise ValueError("a search has at most one seed per node")
        edges = int(self._indptr[-1])
        self._data[edges:edges + seeds.size] = values + SEED_OFFSET
        self._indices[edges:edges + seeds.size] = seeds
        indptr = self._indptr.copy()
        indptr[-1] += seeds.size
        graph = sparse.csr_matrix(  # views of the edges and this search's seed edges after them
            (self._data[:edges + seeds.size], self._indices[:edges + seeds.size], indptr),
            shape=(self.nodes + 1, self.nodes + 1), copy=False)
        if targets is None:
            return self._dijkstra(graph, limit=np.inf)
        reached = targets & np.isin(self._components(), self._components()[seeds])
        if not reached.any():
            return self._dijkstra(graph, limit=0.0)  # the seeds alone: no target to settle
        limit = self._first_limit(seeds, values, reached)
        while True:
            search = self._dijkstra(graph, limit=limit)
            if np.isfinite(search.distances[reached]).all():
                return search
            limit *= LIMIT_GROWTH

    def _dijkstra(self, graph: sparse.csr_matrix, *, limit: float) -> Search:
        distances, predecessors = csgraph.dijkstra(  # a 0-d index: 1-d results
            graph, directed=True, indices=np.asarray(self.source), return_predecessors=True,
            limit=limit + SEED_OFFSET)
        return Search(distances=distances[:self.nodes] - SEED_OFFSET,
                      predecessors=predecessors[:self.nodes], source=self.source)

    def _first_limit(self, seeds: np.ndarray, values: np.ndarray, targets: np.ndarray) -> float:
        """A first guess at how far the farthest target lies: the least seed value, plus
        :data:`FIRST_LIMIT_MARGIN` times the straight-line gap from the farthest target to the
        seeds' bounding box (or one lattice step, if the targets lie within it)."""
        xs, ys = self.x[seeds], self.y[seeds]
        gap_x = np.maximum(np.maximum(xs.min() - self.x[targets], self.x[targets] - xs.max()), 0.0)
        gap_y = np.maximum(np.maximum(ys.min() - self.y[targets], self.y[targets] - ys.max()), 0.0)
        reach = max(float(np.hypot(gap_x, gap_y).max()), self.resolution)
        return float(values.min()) + FIRST_LIMIT_MARGIN * reach

    def _components(self) -> np.ndarray:
        """Each node's connected component (the steps go both ways), worked out once."""
        if self._labels is None:
            edges = int(self._indptr[-1])
            indptr = self._indptr[:self.nodes + 1]
            graph = sparse.csr_matrix((self._data[:edges], self._indices[:edges], indptr),
                                      shape=(self.nodes, self.nodes), copy=False)
            self._labels = csgraph.connected_components(graph, directed=False)[1]
        return self._labels

    def _edges(self, max_step: int) -> tuple[NDArray[np.int32], NDArray[np.float64],
                                              NDArray[np.int32]]:
        """Both directions of every step between two nodes, in CSR form (row pointers, lengths,
        nodes reached); the virtual source's row last and empty, with room after the edges for
        a search's seed edges.

        Built row by row: node ``n``'s steps are row ``n`` of a (nodes x steps) table of the
        nodes they reach, so no sort of some ten million edges is needed; and a search writes
        its seeds into the room left for them rather than copying the edges."""
        steps = step_directions(max_step)
        height, width = self.index.shape
        padded = np.full((height + 2 * max_step, width + 2 * max_step), -1, dtype=np.int32)
        padded[max_step:max_step + height, max_step:max_step + width] = self.index
        node_rows, node_cols = np.nonzero(self.index >= 0)  # row-major: node order
        reached = np.empty((self.nodes, len(steps)), dtype=np.int32)
        for column, (di, dj) in enumerate(steps):
            reached[:, column] = padded[node_rows + max_step + di, node_cols + max_step + dj]
        step = reached >= 0
        indptr = np.zeros(self.nodes + 2, dtype=np.int32)
        np.cumsum(step.sum(axis=1), out=indptr[1:self.nodes + 1])
        indptr[-1] = edges = indptr[-2]
        lengths = np.array([math.hypot(di, dj) * self.resolution for di, dj in steps])
        data = np.empty(edges + self.nodes)
        data[:edges] = np.broadcast_to(lengths, reached.shape)[step]
        indices = np.empty(edges + self.nodes, dtype=np.int32)
        indices[:edges] = reached[step]
        return indptr, data, indices


def _corners_of(free: np.ndarray) -> np.ndarray:
    """The corner lattice ``(H+1) x (W+1)``: True at every corner of a free cell."""
    height, width = free.shape
    corners = np.zeros((height + 1, width + 1), dtype=bool)
    for di in (0, 1):
        for dj in (0, 1):
            corners[di:di + height, dj:dj + width] |= free
    return corners
