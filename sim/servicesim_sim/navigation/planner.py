"""The global planner: cheapest paths on the costmap, shortened by line of sight.

Design intent:

* The search is Dijkstra's algorithm run by ``scipy.sparse.csgraph`` (a heap in compiled code)
  on the costmap's 8-connected grid. Measured on the default office (0.1 m cells, 78 000
  traversable), across the building: one single-source search ~12 ms on an idle machine; the
  same search made goal-directed (A* with the octile heuristic, as reduced edge costs and a
  growing search limit) was only ~20 % faster over random pairs, needs ~5 ms per goal to
  reweight the edges and repeated searches to prove a goal unreachable; a pure-Python heap A*
  took 120-400 ms, 5-20 times as long. So the planner runs plain Dijkstra; the octile distance
  is just the length of a grid step. The search first stops a little past the straight-line
  distance to the goal (scipy's ``limit``: nodes beyond it are never settled), which is exact
  for every goal within that bound and halves the planning time of a mission's replans; only
  a goal beyond it costs a second, unbounded search.
* The graph's shape (which cells join which) is built once from the static layer. Only the edge
  weights follow the people marks: stepping onto a cell costs its length times
  ``1 + cost_weight * cost / 252`` and a lethal cell cannot be entered. The static layer's
  weights are worked out once; on a costmap change only the steps onto the cells whose cost
  differs from it (a few hundred around the people marks) are weighed again: 0.8 ms rather
  than 3.1 ms for the office's 600 000 steps. The graph's index arrays
  are int32, the type scipy works in, which spares a copy of them at every search.
* A start in lethal cost (the robot pressed against a wall or a person) first escapes to the
  nearest non-lethal cell; a lethal goal snaps to the nearest non-lethal cell close enough that
  reaching it still meets the goal tolerance, else the plan fails with GOAL_OCCUPIED.
* The cell path is shortened greedily: a waypoint is dropped when the straight segment that
  replaces it crosses no cell costlier than the stretch of path it replaces, so shortening never
  brings the path nearer a wall or a person.
* Failures carry Nav2's ComputePathToPose error codes (nav2_msgs, Kilted) and a sentence.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse import csgraph

from servicesim_sim.navigation.costmap import INSCRIBED, MAX_INFLATED, Costmap

Point = tuple[float, float]

#: The octile grid distance between a straight line's ends is at most this many times its
#: length (the worst case, 22.5 degrees off a grid axis).
OCTILE_RATIO = math.sqrt(4.0 - 2.0 * math.sqrt(2.0))
#: How many goals' static distance fields the planner keeps (about 1 MB each on the office).
DISTANCE_FIELDS_KEPT = 4

#: The first search stops at this many times the straight-line distance to the goal, plus
#: the margin (in cells); only a goal beyond that is searched for over the whole grid.
SEARCH_BOUND_FACTOR = 1.6
SEARCH_BOUND_MARGIN_CELLS = 30.0

# The 8 grid steps: (row offset, column offset).
STEPS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


class ComputePathToPoseError(IntEnum):
    """nav2_msgs/action/ComputePathToPose result codes (Nav2 Kilted)."""

    NONE = 0
    UNKNOWN = 200
    INVALID_PLANNER = 201
    TF_ERROR = 202
    START_OUTSIDE_MAP = 203
    GOAL_OUTSIDE_MAP = 204
    START_OCCUPIED = 205
    GOAL_OCCUPIED = 206
    TIMEOUT = 207
    NO_VALID_PATH = 208


@dataclass(frozen=True)
class PlanResult:
    """A plan: waypoints from the start to ``goal`` (the goal actually reached), or a failure."""

    waypoints: list[Point] | None
    error_code: int = ComputePathToPoseError.NONE
    error_msg: str = ""
    goal: Point | None = None

    @property
    def succeeded(self) -> bool:
        return self.waypoints is not None


def failure(code: ComputePathToPoseError, message: str) -> PlanResult:
    return PlanResult(waypoints=None, error_code=int(code), error_msg=message)


class GridGraph:
    """The 8-connected graph of the cells the static layer lets the robot's centre enter."""

    def __init__(self, static_costs: np.ndarray) -> None:
        rows, cols = static_costs.shape
        self.shape = (rows, cols)
        index = np.arange(rows * cols).reshape(rows, cols)
        open_cells = static_costs < INSCRIBED
        sources, targets, lengths = [], [], []
        for d_row, d_col in STEPS:
            here = (slice(max(-d_row, 0), rows - max(d_row, 0)),
                    slice(max(-d_col, 0), cols - max(d_col, 0)))
            there = (slice(max(d_row, 0), rows - max(-d_row, 0)),
                     slice(max(d_col, 0), cols - max(-d_col, 0)))
            both = open_cells[here] & open_cells[there]
            sources.append(index[here][both])
            targets.append(index[there][both])
            lengths.append(np.full(int(both.sum()), math.hypot(d_row, d_col)))
        sources_all = np.concatenate(sources)
        order = np.argsort(sources_all, kind="stable")
        # scipy's sparse matrices and csgraph index with int32 where it fits: arrays of any
        # other type were converted (copied) by every matrix built and every search run
        index_type = np.int32 if rows * cols < np.iinfo(np.int32).max else np.int64
        self.targets: NDArray[np.int32 | np.int64] = np.concatenate(targets)[order].astype(
            index_type)
        self.lengths = np.concatenate(lengths)[order]
        self.indptr: NDArray[np.int32 | np.int64] = np.searchsorted(sources_all[order],
                                      np.arange(rows * cols + 1)).astype(index_type)
        # the steps onto each cell (indices into targets), for re-weighing a few cells' steps
        self._static = np.array(static_costs).ravel()
        self._onto = np.argsort(self.targets, kind="stable")
        self._onto_ptr = np.searchsorted(self.targets[self._onto], np.arange(rows * cols + 1))
        self._static_weights: dict[float, np.ndarray] = {}

    def unweighted(self) -> sparse.csr_matrix:
        """The graph with each step weighted by its length alone (it is symmetric)."""
        size = self.shape[0] * self.shape[1]
        return sparse.csr_matrix((self.lengths, self.targets, self.indptr), shape=(size, size))

    def weighted(self, costs: np.ndarray, *, cost_weight: float) -> sparse.csr_matrix:
        """The graph with each step weighted by the cost of the cell it enters.

        The static layer's weights are worked out once; only the steps onto cells whose cost
        differs from it (the people marks: a few hundred of the grid's cells) are weighed
        anew, by the same arithmetic, so the weights are exactly those of weighing every step.
        """
        weights = self._static_weights.get(cost_weight)
        if weights is None:
            weights = step_weights(self._static[self.targets], self.lengths,
                                   cost_weight=cost_weight)
            self._static_weights[cost_weight] = weights
        flat = costs.ravel()
        cells = np.flatnonzero(flat != self._static)
        weights = weights.copy()
        if cells.size:
            steps = self._steps_onto(cells)
            weights[steps] = step_weights(flat[self.targets[steps]], self.lengths[steps],
                                          cost_weight=cost_weight)
        size = self.shape[0] * self.shape[1]
        return sparse.csr_matrix((weights, self.targets, self.indptr), shape=(size, size))

    def _steps_onto(self, cells: np.ndarray) -> np.ndarray:
        """The indices (into :attr:`targets`) of every step onto one of ``cells``."""
        starts = self._onto_ptr[cells]
        counts = self._onto_ptr[cells + 1] - starts
        firsts = np.cumsum(counts) - counts
        steps: NDArray[np.intp] = self._onto[np.arange(int(counts.sum()))
                                             - np.repeat(firsts - starts, counts)]
        return steps


def step_weights(entered: np.ndarray, lengths: np.ndarray, *,
                 cost_weight: float) -> np.ndarray:
    """Each step's weight: its length times ``1 + cost_weight * cost / 252`` of the cell it
    enters (``entered``), infinite onto an inscribed or lethal cell."""
    costs = entered.astype(np.float64)
    weights = lengths * (1.0 + cost_weight * costs / MAX_INFLATED)
    weights[costs >= INSCRIBED] = np.inf
    return weights


class Planner:
    """Plans on one costmap; build it once and call :meth:`plan` as often as needed.

    Args:
        costmap: static walls and people marks
        cost_weight: how many grid steps a step onto a cell of cost 252 is worth, beyond its own
        goal_tolerance: a lethal goal may snap this close (less a 5 cm margin) to a free cell
        escape_radius: how far a lethal start may escape to a free cell
    """

    def __init__(self, costmap: Costmap, *, cost_weight: float = 4.0,
                 goal_tolerance: float = 0.3, escape_radius: float = 0.6) -> None:
        self.costmap = costmap
        self.cost_weight = cost_weight
        self.goal_snap = max(goal_tolerance - 0.05, 0.0)
        self.escape_radius = escape_radius
        self.graph = GridGraph(costmap.static)
        self._weighted: dict[bool, tuple[int, sparse.csr_matrix]] = {}
        self._distance_fields: dict[int, np.ndarray] = {}  # goal cell index to cells away

    def plan(self, start: Point, goal: Point, *, with_people: bool = True) -> PlanResult:
        """A path from ``start`` to ``goal``; ``with_people=False`` ignores the people marks."""
        frame = self.costmap.frame
        if not frame.covers(*start):
            return failure(ComputePathToPoseError.START_OUTSIDE_MAP,
                           f"start ({start[0]:.2f}, {start[1]:.2f}) is outside the map")
        if not frame.covers(*goal):
            return failure(ComputePathToPoseError.GOAL_OUTSIDE_MAP,
                           f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is outside the map")
        start_cell, goal_cell = frame.cell_of(*start), frame.cell_of(*goal)
        costs = self.costmap.costs() if with_people else self.costmap.static
        source = self._nearest_open(costs, start_cell, self.escape_radius)
        if source is None:
            return failure(ComputePathToPoseError.START_OCCUPIED,
                           f"start ({start[0]:.2f}, {start[1]:.2f}) is in an obstacle with no "
                           f"free space within {self.escape_radius:.2f} m")
        target = self._nearest_open(costs, goal_cell, self.goal_snap)
        if target is None:
            return failure(ComputePathToPoseError.GOAL_OCCUPIED,
                           f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is in an obstacle with no "
                           f"free space within {self.goal_snap:.2f} m")
        cells = self._cheapest_cells(costs, source, target, with_people=with_people)
        if cells is None:
            return failure(ComputePathToPoseError.NO_VALID_PATH,
                           f"no path from ({start[0]:.2f}, {start[1]:.2f}) to "
                           f"({goal[0]:.2f}, {goal[1]:.2f}): the goal is cut off")
        return self._result(costs, cells, start, goal, goal_cell=goal_cell)

    def length_bound(self, start: Point, goal: Point) -> float:
        """A lower bound on the length of any path :meth:`plan` can return (0 if unknown).

        People only ever lengthen a plan, so the static grid's shortest distance bounds it,
        shrunk by the most a straight line undercuts the octile grid (8.24 %) and by a cell
        at either end. One search out from the goal gives it for every start; the last few
        goals' searches are kept. The navigator uses it to skip a periodic replan that could
        not find a way short enough to be worth switching to.
        """
        frame = self.costmap.frame
        if not (frame.covers(*start) and frame.covers(*goal)):
            return 0.0
        start_cell, goal_cell = frame.cell_of(*start), frame.cell_of(*goal)
        if not (frame.contains(*start_cell) and frame.contains(*goal_cell)
                and self._statically_open(start_cell) and self._statically_open(goal_cell)):
            return 0.0
        cols = self.graph.shape[1]
        cells_away = self._distance_field(goal_cell[0] * cols + goal_cell[1])
        away = float(cells_away[start_cell[0] * cols + start_cell[1]])
        if not math.isfinite(away):
            return 0.0
        return max((away / OCTILE_RATIO - 2.0) * frame.resolution, 0.0)

    def _distance_field(self, goal_index: int) -> np.ndarray:
        field = self._distance_fields.get(goal_index)
        if field is None:
            field = csgraph.dijkstra(self.graph.unweighted(), directed=True,
                                     indices=np.asarray(goal_index))  # 0-d: a 1-d field
            while len(self._distance_fields) >= DISTANCE_FIELDS_KEPT:
                self._distance_fields.pop(next(iter(self._distance_fields)))
            self._distance_fields[goal_index] = field
        return field

    # ------------------------------------------------------------------ search
    def _cheapest_cells(self, costs: np.ndarray, source: tuple[int, int],
                        target: tuple[int, int], *, with_people: bool) -> np.ndarray | None:
        cols = self.graph.shape[1]
        source_index, target_index = source[0] * cols + source[1], target[0] * cols + target[1]
        if source_index == target_index:
            return np.array([source_index])
        graph = self._graph(costs, with_people=with_people)
        # First a search bounded a little past the straight-line distance (most plans), then,
        # if the goal lies beyond that bound, the whole grid.
        d_row, d_col = abs(source[0] - target[0]), abs(source[1] - target[1])
        octile = max(d_row, d_col) + (math.sqrt(2.0) - 1.0) * min(d_row, d_col)
        for limit in (SEARCH_BOUND_FACTOR * octile + SEARCH_BOUND_MARGIN_CELLS, np.inf):
            distances, predecessors = csgraph.dijkstra(
                graph, directed=True, indices=source_index, return_predecessors=True,
                limit=limit)
            if np.isfinite(distances[target_index]):
                break
        else:
            return None
        chain = [target_index]
        while chain[-1] != source_index:
            chain.append(int(predecessors[chain[-1]]))
        return np.array(chain[::-1])

    def _graph(self, costs: np.ndarray, *, with_people: bool) -> sparse.csr_matrix:
        version = self.costmap.version if with_people else -1
        cached = self._weighted.get(with_people)
        if cached is None or cached[0] != version:
            cached = (version, self.graph.weighted(costs, cost_weight=self.cost_weight))
            self._weighted[with_people] = cached
        return cached[1]

    def _nearest_open(self, costs: np.ndarray, cell: tuple[int, int],
                      radius: float) -> tuple[int, int] | None:
        """``cell`` when the robot may stand there, else the nearest such cell within radius."""
        if costs[cell] < INSCRIBED and self._statically_open(cell):
            return cell
        reach = int(radius / self.costmap.frame.resolution)
        row0, col0 = max(cell[0] - reach, 0), max(cell[1] - reach, 0)
        window = costs[row0:cell[0] + reach + 1, col0:cell[1] + reach + 1]
        static = self.costmap.static[row0:cell[0] + reach + 1, col0:cell[1] + reach + 1]
        rows, cols = np.nonzero((window < INSCRIBED) & (static < INSCRIBED))
        if rows.size == 0:
            return None
        gaps = np.hypot(rows + row0 - cell[0], cols + col0 - cell[1])
        best = int(np.argmin(gaps))
        if gaps[best] > reach:
            return None
        return int(rows[best] + row0), int(cols[best] + col0)

    def _statically_open(self, cell: tuple[int, int]) -> bool:
        return bool(self.costmap.static[cell] < INSCRIBED)

    # ------------------------------------------------------------------ result
    def _result(self, costs: np.ndarray, cells: np.ndarray, start: Point, goal: Point, *,
                goal_cell: tuple[int, int]) -> PlanResult:
        cols = self.graph.shape[1]
        rows_, cols_ = cells // cols, cells % cols
        kept = shortcut(costs, rows_, cols_)
        xs, ys = self.costmap.frame.centres(rows_[kept], cols_[kept])
        points = [(float(x), float(y)) for x, y in zip(xs, ys, strict=True)]
        reached_goal = goal if (int(rows_[-1]), int(cols_[-1])) == goal_cell else points[-1]
        first = (int(rows_[0]), int(cols_[0]))
        waypoints = [start, *points[1:-1], reached_goal]
        if first != self.costmap.frame.cell_of(*start):
            waypoints.insert(1, points[0])  # the escape from a lethal start
        return PlanResult(waypoints=_without_repeats(waypoints), goal=reached_goal)


def shortcut(costs: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> list[int]:
    """Indices of the cells kept when a cell path is shortened by line of sight.

    From each kept cell the next kept one is the farthest (found by doubling, then bisection)
    whose straight segment crosses no cell costlier than the path between them; a last pass
    drops any kept cell whose neighbours see each other.
    """
    path_costs = costs[rows, cols]
    kept = [0]
    last = len(rows) - 1
    while kept[-1] < last:
        here = kept[-1]
        good, step = here + 1, 1
        bad = None
        while good < last:
            probe = min(here + 2 * step, last)
            if _straight_ok(costs, rows, cols, path_costs, here, probe):
                good, step = probe, 2 * step
            else:
                bad = probe
                break
        while bad is not None and bad - good > 1:
            middle = (good + bad) // 2
            if _straight_ok(costs, rows, cols, path_costs, here, middle):
                good = middle
            else:
                bad = middle
        kept.append(good)
    return _pruned(costs, rows, cols, path_costs, kept)


def _pruned(costs: np.ndarray, rows: np.ndarray, cols: np.ndarray, path_costs: np.ndarray,
            kept: list[int]) -> list[int]:
    """``kept`` without the vertices whose neighbours see each other (left-over stair steps)."""
    pruned = [kept[0]]
    for index, vertex in enumerate(kept[1:-1], start=1):
        if not _straight_ok(costs, rows, cols, path_costs, pruned[-1], kept[index + 1]):
            pruned.append(vertex)
    if len(kept) > 1:
        pruned.append(kept[-1])
    return pruned


def _straight_ok(costs: np.ndarray, rows: np.ndarray, cols: np.ndarray, path_costs: np.ndarray,
                 first: int, last: int) -> bool:
    """Whether the segment between two path cells is no costlier than the path between them."""
    span = max(abs(int(rows[last] - rows[first])), abs(int(cols[last] - cols[first])))
    t = np.linspace(0.0, 1.0, 2 * span + 1)
    line_rows = np.rint(rows[first] + t * (rows[last] - rows[first])).astype(np.intp)
    line_cols = np.rint(cols[first] + t * (cols[last] - cols[first])).astype(np.intp)
    return bool(costs[line_rows, line_cols].max() <= path_costs[first:last + 1].max())


def _without_repeats(points: list[Point]) -> list[Point]:
    result = [points[0]]
    for point in points[1:]:
        if math.dist(point, result[-1]) > 1e-6:
            result.append(point)
    if len(result) == 1:
        result.append(points[-1])
    return result


def path_length(waypoints: list[Point]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(waypoints))
