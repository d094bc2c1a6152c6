"""The executive's picture of the building: a read-only occupancy grid that knows its clearance.

The executive knows the world only from the ``/servicebot/map`` OccupancyGrid (plus RoomInfo
boxes, odometry and RFID), so every goal it computes is checked against this one model.
:class:`OccupancyGrid2D` is built once per map message (``MapToBlackboard`` converts in its
subscription callback) and then only read, so the expensive parts are done up front:

- one Euclidean distance transform at construction gives every cell's *clearance*, the
  distance from the cell's centre to the nearest occupied or unknown cell (outside the map
  counts as unknown), so "is there room for the robot here?" is an array look-up;
- connected components of the cells with a given clearance are labelled once per clearance
  and cached, so a goal can be restricted to the part of the building the robot can reach;
- :class:`RouteTree` holds the shortest routes from one start (Dijkstra over a 0.1 m lattice of
  reachable cells), for behaviours that need the side from which the robot will arrive.

Conventions follow nav_msgs/OccupancyGrid: row 0 lies at ``origin_y``, column 0 at
``origin_x``, ``data[row * width + col]``; a value in 0..49 is free, 50..100 occupied and -1
unknown. Rotated map origins are refused.

scipy is imported by the functions that compute with it, not with the module: the behaviours
declare their ports with :class:`OccupancyGrid2D`, and a command that refuses a tree file
imports every behaviour but computes nothing.
"""

from __future__ import annotations

import hashlib
import itertools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from scipy import sparse

__all__ = ["Cell", "OccupancyGrid2D", "RouteTree", "Window"]

OCCUPIED_FROM = 50
"""Cell values from this up are occupied; below it (and not negative) free."""

SEED_RADIUS = 0.5
"""How far (m) a start may be snapped to reach a cell with the requested clearance."""

ROUTES_KEPT = 4
"""Route trees an :class:`OccupancyGrid2D` keeps (see :meth:`OccupancyGrid2D.routes_from`)."""

LATTICE_SPACING = 0.1
"""Spacing (m) of the lattice :class:`RouteTree` searches over."""

_EIGHT_CONNECTED = np.ones((3, 3), dtype=bool)


class Cell(NamedTuple):
    """A grid index: ``row`` counts up from ``origin_y``, ``col`` from ``origin_x``."""

    row: int
    col: int


@dataclass(frozen=True)
class Window:
    """The cells whose centres lie in a rectangle, clipped to the map, with those centres."""

    rows: slice
    cols: slice
    xs: np.ndarray
    """Centre x of each column in the window (1-D)."""
    ys: np.ndarray
    """Centre y of each row in the window (1-D)."""

    @property
    def is_empty(self) -> bool:
        return self.xs.size == 0 or self.ys.size == 0


@dataclass(frozen=True, eq=False)
class OccupancyGrid2D:
    """A frozen, numpy-backed view of a nav_msgs/OccupancyGrid with per-cell clearance.

    Args:
        values: the cell values, shape (height, width), row 0 at ``origin_y``
        resolution: metres per cell
        origin_x: world x of the map's lower-left corner
        origin_y: world y of the map's lower-left corner
    """

    values: np.ndarray = field(repr=False)
    resolution: float
    origin_x: float
    origin_y: float
    clearances: np.ndarray = field(init=False, repr=False)
    """Metres from each cell's centre to the nearest blocked cell; 0 for blocked cells."""
    _components: dict[float, np.ndarray] = field(init=False, repr=False, default_factory=dict)
    _routes: dict[tuple[float, float, float], RouteTree | None] = field(
        init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        values = np.array(self.values, dtype=np.int16, copy=True)
        if values.ndim != 2 or values.size == 0:
            raise ValueError(f"occupancy values must be a non-empty 2-D array, not {values.shape}")
        if not (math.isfinite(self.resolution) and self.resolution > 0.0):
            raise ValueError(f"map resolution must be positive, not {self.resolution}")
        values.flags.writeable = False
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "clearances", _clearances(values, self.resolution))

    @classmethod
    def from_message(cls, message: Any) -> OccupancyGrid2D:
        """From a ``nav_msgs/OccupancyGrid``; ``ValueError`` names what is wrong with it."""
        info = message.info
        width, height = int(info.width), int(info.height)
        data = np.asarray(message.data, dtype=np.int16)
        if width <= 0 or height <= 0 or data.size != width * height:
            raise ValueError(f"map of {width}x{height} cells carries {data.size} values, "
                             f"expected {width * height}")
        q = info.origin.orientation
        if abs(2.0 * (q.w * q.z + q.x * q.y)) > 1e-6:
            raise ValueError("rotated map origins are not supported")
        return cls(
            values=data.reshape(height, width), resolution=float(info.resolution),
            origin_x=float(info.origin.position.x), origin_y=float(info.origin.position.y),
        )

    def __repr__(self) -> str:
        return (f"OccupancyGrid2D({self.width}x{self.height} at {self.resolution} m, "
                f"origin ({self.origin_x}, {self.origin_y}))")

    # ------------------------------------------------------------------ cells and coordinates
    @property
    def width(self) -> int:
        return int(self.values.shape[1])

    @property
    def height(self) -> int:
        return int(self.values.shape[0])

    def world_to_cell(self, x: float, y: float) -> Cell:
        """The cell containing (x, y); it may lie outside the map (see :meth:`contains_cell`)."""
        return Cell(row=math.floor((y - self.origin_y) / self.resolution),
                    col=math.floor((x - self.origin_x) / self.resolution))

    def cell_to_world(self, cell: Cell) -> tuple[float, float]:
        """The centre of ``cell``."""
        return (self.origin_x + (cell.col + 0.5) * self.resolution,
                self.origin_y + (cell.row + 0.5) * self.resolution)

    def contains_cell(self, cell: Cell) -> bool:
        return 0 <= cell.row < self.height and 0 <= cell.col < self.width

    def window(self, min_x: float, min_y: float, max_x: float, max_y: float) -> Window:
        """The cells whose centres lie within the rectangle, clipped to the map."""
        first = self._first_index_at_or_above
        cols = slice(first(min_x, self.origin_x, self.width),
                     first(max_x, self.origin_x, self.width, inclusive_end=True))
        rows = slice(first(min_y, self.origin_y, self.height),
                     first(max_y, self.origin_y, self.height, inclusive_end=True))
        xs = self.origin_x + (np.arange(cols.start, cols.stop) + 0.5) * self.resolution
        ys = self.origin_y + (np.arange(rows.start, rows.stop) + 0.5) * self.resolution
        return Window(rows=rows, cols=cols, xs=xs, ys=ys)

    def _first_index_at_or_above(
        self, value: float, origin: float, size: int, *, inclusive_end: bool = False
    ) -> int:
        """Index of the first cell whose centre is >= value (or, as an end, > value)."""
        position = (value - origin) / self.resolution - 0.5
        index = math.floor(position) + 1 if inclusive_end else math.ceil(position)
        return min(max(index, 0), size)

    # ------------------------------------------------------------------ free space
    def clearance(self, x: float, y: float) -> float:
        """Metres from (x, y)'s cell centre to the nearest occupied or unknown cell (0: blocked)."""
        cell = self.world_to_cell(x, y)
        if not self.contains_cell(cell):
            return 0.0
        return float(self.clearances[cell])

    def is_free(self, x: float, y: float, clearance: float = 0.0) -> bool:
        """Whether (x, y) lies in a free cell with at least ``clearance`` metres around it."""
        room = self.clearance(x, y)
        return room > 0.0 and room >= clearance

    def passable(self, clearance: float) -> np.ndarray:
        """Boolean mask of the free cells with at least ``clearance`` metres around them."""
        return self.clearances >= max(clearance, np.finfo(np.float32).tiny)

    def nearest_free(
        self, x: float, y: float, *, clearance: float, max_radius: float,
        within: np.ndarray | None = None,
    ) -> tuple[float, float] | None:
        """(x, y) itself if free with ``clearance``, else the nearest such cell centre.

        Only cells within ``max_radius`` of (x, y), and in the mask ``within`` if given, count;
        None if there is none.
        """
        if self.is_free(x, y, clearance) and (within is None or within[self.world_to_cell(x, y)]):
            return (x, y)
        window = self.window(x - max_radius, y - max_radius, x + max_radius, y + max_radius)
        if window.is_empty:
            return None
        candidates = self.passable(clearance)[window.rows, window.cols]
        if within is not None:
            candidates = candidates & within[window.rows, window.cols]
        squared = (window.xs[None, :] - x) ** 2 + (window.ys[:, None] - y) ** 2
        squared = np.where(candidates & (squared <= max_radius**2), squared, np.inf)
        best = np.unravel_index(int(np.argmin(squared)), squared.shape)
        if not np.isfinite(squared[best]):
            return None
        return (float(window.xs[best[1]]), float(window.ys[best[0]]))

    def clear_lines(
        self, x: float, y: float, xs: ArrayLike, ys: ArrayLike, clearance: float
    ) -> NDArray[np.bool_]:
        """For each end (xs[i], ys[i]), whether the straight line from (x, y) keeps ``clearance``.

        The lines are sampled every cell, which is exact enough for a clearance of a few cells.
        """
        xs, ys = np.atleast_1d(np.asarray(xs, float)), np.atleast_1d(np.asarray(ys, float))
        if xs.size == 0:
            return np.zeros(0, dtype=bool)
        longest = float(np.max(np.hypot(xs - x, ys - y)))
        steps = max(2, math.ceil(longest / self.resolution) + 1)
        t = np.linspace(0.0, 1.0, steps)[None, :]
        room = self._clearances_at(x + (xs[:, None] - x) * t, y + (ys[:, None] - y) * t)
        clear: NDArray[np.bool_] = np.all(room >= max(clearance, np.finfo(np.float32).tiny),
                                          axis=1)
        return clear

    def clearances_at(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Clearance at many points at once (0 outside the map), in the points' shape."""
        return self._clearances_at(np.asarray(xs, dtype=float), np.asarray(ys, dtype=float))

    def _clearances_at(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Clearance at many points at once (0 outside the map)."""
        cols = np.floor((xs - self.origin_x) / self.resolution).astype(np.int64)
        rows = np.floor((ys - self.origin_y) / self.resolution).astype(np.int64)
        inside = (rows >= 0) & (rows < self.height) & (cols >= 0) & (cols < self.width)
        room = np.zeros(xs.shape, dtype=np.float32)
        room[inside] = self.clearances[rows[inside], cols[inside]]
        return room

    # ------------------------------------------------------------------ reachability
    def components(self, clearance: float) -> np.ndarray:
        """Labels of the 8-connected regions of cells with ``clearance`` (0: not passable).

        Computed once per clearance and cached.
        """
        key = round(float(clearance), 4)
        labels = self._components.get(key)
        if labels is None:
            from scipy import ndimage

            labels, _count = ndimage.label(self.passable(key), structure=_EIGHT_CONNECTED)
            labels.flags.writeable = False
            self._components[key] = labels
        return labels

    def reachable_from(self, x: float, y: float, clearance: float) -> np.ndarray:
        """Boolean mask of the cells with ``clearance`` connected to (x, y).

        A start a little too close to an obstacle is snapped to the nearest cell with the
        clearance within :data:`SEED_RADIUS`; the mask is all False if there is none.
        """
        labels = self.components(clearance)
        seed = self.nearest_free(x, y, clearance=clearance, max_radius=SEED_RADIUS)
        if seed is None:
            return np.zeros(labels.shape, dtype=bool)
        reachable: NDArray[np.bool_] = labels == labels[self.world_to_cell(*seed)]
        return reachable

    def routes_from(self, x: float, y: float, clearance: float) -> RouteTree | None:
        """The shortest routes from (x, y) over cells with ``clearance``; None if boxed in.

        The last :data:`ROUTES_KEPT` are kept (a route tree over a building takes tens of
        milliseconds, and behaviours ask again from the same places, such as an area).
        """
        key = (round(float(x), 3), round(float(y), 3), round(float(clearance), 4))
        if key not in self._routes:
            if len(self._routes) >= ROUTES_KEPT:
                del self._routes[next(iter(self._routes))]
            self._routes[key] = RouteTree.build(self, x, y, clearance)
        return self._routes[key]


_last_clearances: list[tuple[tuple[bytes, tuple[int, ...], float], np.ndarray]] = []
"""The last map's clearances, by its cells' digest: an evaluation's warm executive builds the
same map every episode, and the distance transform costs ten times the digest (25 ms of CPU
on the office against 2 ms)."""


def _clearances(values: np.ndarray, resolution: float) -> np.ndarray:
    """Per-cell clearance from one distance transform; the map's border counts as unknown.

    The result is read-only, so the last one is handed out again for the same cells."""
    key = (hashlib.blake2b(values.tobytes(), digest_size=16).digest(), values.shape, resolution)
    if _last_clearances and _last_clearances[0][0] == key:
        return _last_clearances[0][1]
    clearances = _computed_clearances(values, resolution)
    _last_clearances[:] = [(key, clearances)]
    return clearances


def _computed_clearances(values: np.ndarray, resolution: float) -> np.ndarray:
    blocked = (values < 0) | (values >= OCCUPIED_FROM)
    cells = _cells_to_blocked(np.pad(~blocked, 1, constant_values=False))[1:-1, 1:-1]
    clearances = np.where(blocked, 0.0, (cells - 0.5) * resolution).astype(np.float32)
    clearances.flags.writeable = False
    return clearances


def _cells_to_blocked(free: np.ndarray) -> np.ndarray:
    """``scipy.ndimage.distance_transform_edt(free)``, worked out on the free cells' bounding
    box and the ring of cells around it: a map is mostly obstacle (the office's building fills
    under a third of its grid), and the box gives every cell the same value. A free cell's
    nearest blocked cell beyond the ring has a blocked cell of the ring, the one met by clamping
    it into the box, no farther away along either axis; blocked cells are 0 either way."""
    from scipy import ndimage

    rows = np.flatnonzero(free.any(axis=1))
    cells = np.zeros(free.shape, dtype=np.float64)
    if rows.size == 0:
        return cells
    cols = np.flatnonzero(free.any(axis=0))
    box = (slice(max(int(rows[0]) - 1, 0), min(int(rows[-1]) + 2, free.shape[0])),
           slice(max(int(cols[0]) - 1, 0), min(int(cols[-1]) + 2, free.shape[1])))
    cells[box] = ndimage.distance_transform_edt(free[box])
    return cells


@dataclass(frozen=True, eq=False)
class RouteTree:
    """Shortest 8-connected routes from one start, over a lattice of the reachable cells.

    The lattice takes every ``stride``-th cell (about :data:`LATTICE_SPACING` apart) of the
    start's component; distances are route lengths in metres (octile, so up to 8 % longer
    than the straight line in open space).
    """

    grid: OccupancyGrid2D
    stride: int
    node_of: np.ndarray = field(repr=False)
    """Lattice-shaped node index, -1 where the lattice cell is not reachable."""
    node_cells: np.ndarray = field(repr=False)
    """(n, 2) grid cell (row, col) of each node."""
    distances: np.ndarray = field(repr=False)
    predecessors: np.ndarray = field(repr=False)

    @classmethod
    def build(cls, grid: OccupancyGrid2D, x: float, y: float, clearance: float) -> RouteTree | None:
        stride = max(1, round(LATTICE_SPACING / grid.resolution))
        lattice = grid.reachable_from(x, y, clearance)[::stride, ::stride]
        node_cells = np.argwhere(lattice) * stride
        if node_cells.size == 0:
            return None
        node_of = np.full(lattice.shape, -1, dtype=np.int64)
        node_of[lattice] = np.arange(len(node_cells))
        graph = _lattice_graph(node_of, stride * grid.resolution)
        start = _nearest_node(grid, node_cells, x, y)
        from scipy.sparse import csgraph

        distances, predecessors = csgraph.dijkstra(  # a 0-d index: 1-d results
            graph, directed=False, indices=np.asarray(start), return_predecessors=True
        )
        return cls(grid=grid, stride=stride, node_of=node_of, node_cells=node_cells,
                   distances=distances, predecessors=predecessors)

    def distance_to(self, x: float, y: float) -> float:
        """Route length from the start to (x, y) (via the best nearby node); inf if unreachable."""
        best = self._best_node(x, y)
        return math.inf if best is None else best[1]

    def distances_at(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Route lengths from the start to many points (each via its best node within one
        lattice step, as :meth:`distance_to`); inf where unreachable."""
        return self._best_nodes(np.asarray(xs, dtype=float), np.asarray(ys, dtype=float))[1]

    def path_back_from(self, x: float, y: float, max_length: float) -> np.ndarray:
        """World points of the route to (x, y), walking back from (x, y) towards the start.

        The first point is the lattice node the route reaches (x, y) from; the walk stops after
        ``max_length`` metres or at the start. Shape (k, 2); empty if (x, y) is unreachable.
        """
        best = self._best_node(x, y)
        if best is None:
            return np.zeros((0, 2))
        node, nodes = best[0], []
        stop_at = self.distances[node] - max_length
        while node >= 0 and self.distances[node] >= stop_at:
            nodes.append(node)
            node = int(self.predecessors[node])
        return self.points(np.array(nodes, dtype=np.int64))

    def points(self, nodes: np.ndarray) -> np.ndarray:
        """World points (cell centres) of ``nodes``; shape (n, 2)."""
        centres = (self.node_cells[nodes] + 0.5) * self.grid.resolution
        return np.column_stack([self.grid.origin_x + centres[:, 1],
                                self.grid.origin_y + centres[:, 0]])

    def route_to(self, node: int) -> np.ndarray:
        """The nodes of the route from the start to ``node``, in order."""
        nodes = []
        while node >= 0:
            nodes.append(node)
            node = int(self.predecessors[node])
        return np.array(nodes[::-1], dtype=np.int64)

    def _best_node(self, x: float, y: float) -> tuple[int, float] | None:
        """The node within one lattice step of (x, y) minimising route length plus the last hop.

        The same search as :meth:`_best_nodes` (same order, same ties), on plain floats: a
        drop-off goal asks this for one point at a time, dozens of times in one tick, and
        numpy's per-call cost made that most of the tick.
        """
        grid, stride, resolution = self.grid, self.stride, self.grid.resolution
        row = round(math.floor((y - grid.origin_y) / resolution) / stride)
        col = round(math.floor((x - grid.origin_x) / resolution) / stride)
        height, width = self.node_of.shape
        best: tuple[int, float] | None = None
        for d_row, d_col in itertools.product((-1, 0, 1), repeat=2):
            r, c = row + d_row, col + d_col
            if not (0 <= r < height and 0 <= c < width) or (node := int(self.node_of[r, c])) < 0:
                continue
            cell_row, cell_col = self.node_cells[node]
            hop = math.hypot(grid.origin_x + (cell_col + 0.5) * resolution - x,
                             grid.origin_y + (cell_row + 0.5) * resolution - y)
            total = float(self.distances[node]) + hop
            if math.isfinite(total) and (best is None or total < best[1]):
                best = (node, total)
        return best

    def _best_nodes(self, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For each point, the node within one lattice step minimising route length plus the
        last hop, and that total (node -1 and inf where there is none)."""
        grid, stride = self.grid, self.stride
        rows = np.rint(np.floor((ys - grid.origin_y) / grid.resolution) / stride).astype(np.intp)
        cols = np.rint(np.floor((xs - grid.origin_x) / grid.resolution) / stride).astype(np.intp)
        height, width = self.node_of.shape
        best_nodes, best = np.full(xs.shape, -1, dtype=np.int64), np.full(xs.shape, np.inf)
        for d_row, d_col in itertools.product((-1, 0, 1), repeat=2):
            r, c = rows + d_row, cols + d_col
            inside = (r >= 0) & (r < height) & (c >= 0) & (c < width)
            nodes = np.where(inside, self.node_of[np.clip(r, 0, height - 1),
                                                  np.clip(c, 0, width - 1)], -1)
            found = nodes >= 0
            centres = self.node_cells[np.where(found, nodes, 0)] + 0.5
            hop = np.hypot(grid.origin_x + centres[..., 1] * grid.resolution - xs,
                           grid.origin_y + centres[..., 0] * grid.resolution - ys)
            totals = np.where(found, self.distances[np.where(found, nodes, 0)] + hop, np.inf)
            better = totals < best
            best_nodes, best = np.where(better, nodes, best_nodes), np.where(better, totals, best)
        return best_nodes, best


def _lattice_graph(node_of: np.ndarray, spacing: float) -> sparse.csr_matrix:
    """Undirected 8-neighbour edges between lattice nodes, weighted by length in metres."""
    from scipy import sparse

    rows, cols = node_of.shape
    sources, targets, weights = [], [], []
    for d_row, d_col in ((0, 1), (1, 0), (1, 1), (1, -1)):
        source = node_of[0:rows - d_row, max(0, -d_col):cols - max(0, d_col)]
        target = node_of[d_row:rows, max(0, d_col):cols - max(0, -d_col)]
        linked = (source >= 0) & (target >= 0)
        sources.append(source[linked])
        targets.append(target[linked])
        weights.append(np.full(int(linked.sum()), spacing * math.hypot(d_row, d_col)))
    count = int(node_of.max()) + 1
    return sparse.csr_matrix(
        (np.concatenate(weights), (np.concatenate(sources), np.concatenate(targets))),
        shape=(count, count),
    )


def _nearest_node(grid: OccupancyGrid2D, node_cells: np.ndarray, x: float, y: float) -> int:
    xs = grid.origin_x + (node_cells[:, 1] + 0.5) * grid.resolution
    ys = grid.origin_y + (node_cells[:, 0] + 0.5) * grid.resolution
    return int(np.argmin((xs - x) ** 2 + (ys - y) ** 2))
