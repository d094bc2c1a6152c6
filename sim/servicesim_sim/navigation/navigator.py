"""Navigation to a pose: plan on the costmap, follow the path, recover, succeed or abort.

The engine drives a :class:`Navigator` once per physics step: it hands over the robot's pose and
everyone's position, and gets the (v, w) to apply for that step. Everything runs in sim time.

Design intent:

* Following is pure pursuit on the planned polyline (0.5 m lookahead), as a differential drive:
  the robot turns on the spot when the way it should head is over 0.7 rad from the way it faces,
  and slows down for the goal. Within the goal checker's tolerance (the servicebot's 0.3 m) it
  stops and turns to the goal yaw (0.262 rad), like Nav2's stateful goal checker. Plans keep
  to the middle of doors, so the corners pursuit cuts stay clear of the jambs: on 1 m doors met
  at right angles the footprint kept over 0.2 m from the walls (a follower that stopped and
  turned at sharp corners kept 0.27 m but took 15-25 % longer, and was dropped).
* The costmap sees people through the lidar, five sweeps a sim second (the servicebot's
  costmaps' ``update_frequency``), whether or not a goal runs. The robot replans when it
  strays from its path, and reconsiders its path when the costmap changed: within a second
  when people now obstruct the next 4 m (taking the way round unless it is over 5 m longer),
  else every 5 s (taking only a way at least 1 m and 10 % shorter). So the robot neither
  dithers between routes as people come and go nor replans at every change (a plan takes
  ~15 ms on the full map). That is the default navigation tree; with Nav2's own default
  (:data:`~servicesim_sim.navigation.parameters.REPLAN_EVERY_SECOND`) the robot plans again
  every second while the costmap changes and takes the new path unless it is much longer than
  what is left of the current one: over 1 m and 10 % longer while the current path is clear
  (a way round someone beside it is taken), over 5 m while people obstruct it, as above: so the
  robot does not turn for good between two routes that are cheapest in turn as a person near
  it is seen and lost again.
* A person within 0.7 m ahead on the path (between the robot's front and their body) stops the
  robot: it waits a random 0.5–1.5 s, replans around the now-marked person and goes on. While
  no way exists because of people, the same wait-and-replan repeats, clearing stale marks every
  other time. Each wait is a recovery. Blocked for 20 s in all, navigation aborts.
* Every command is checked for the robot's 0.4 x 0.5 m box over the 0.3 s ahead, every
  0.025 m or 0.025 rad of the way, as move_base's local planner checked the footprint of each
  trajectory against its costmap (its ``sim_granularity``): the
  box must keep 1 cm off walls and off the bodies of the people marked in the costmap (or come
  no nearer than it is), else the nearest sampled twist that does is taken, else it stops. So
  the corners do not sweep into a person beside the robot as it turns or sets off. A refused
  turn on the spot, or a drive whose nearest clear sample backs off, is answered by a
  manoeuvre that makes room for it (a sampled arc, forward or backing off, held up to 1.5 s),
  not by samples that never free it (:mod:`~servicesim_sim.navigation.body_check`).
* A robot that has not moved 0.25 m in 10 s forgets the people marked outside a 3 m square
  round it (move_base's conservative reset), backs up 0.15 m when the costmap has room behind
  it, and replans (a recovery); after 20 s without progress navigation aborts. The people near
  stay marked, so the backing is checked against them as every command is (Nav2's BackUp stops
  on a collision ahead in its costmap).
* Failures carry Nav2's numeric codes: the planner's (ComputePathToPose), the follower's
  (FollowPath) or the navigator's own (NavigateToPose), with a sentence for a human.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from servicesim_sim.navigation.body_check import (
    STOP,
    Body,
    BodyCheck,
    Clearances,
    Pose,
    Twist,
)
from servicesim_sim.navigation.costmap import (
    INSCRIBED,
    PERSON_RADIUS,
    Costmap,
    Lidar,
    PersonMark,
)
from servicesim_sim.navigation.parameters import SERVICEBOT, NavigationParameters
from servicesim_sim.navigation.planner import (
    ComputePathToPoseError,
    Planner,
    PlanResult,
    path_length,
)
from servicesim_sim.world.files import OccupancyMap

NavigationStatus = Literal["idle", "running", "succeeded", "aborted", "canceled"]
OBSTRUCTION_RECHECK_M = 0.1
"""Metres along the path after which a path obstruction is looked for again (sooner if the
costmap changed)."""


class FollowPathError(IntEnum):
    """nav2_msgs/action/FollowPath result codes (Nav2 Kilted)."""

    NONE = 0
    UNKNOWN = 100
    INVALID_CONTROLLER = 101
    TF_ERROR = 102
    INVALID_PATH = 103
    PATIENCE_EXCEEDED = 104
    FAILED_TO_MAKE_PROGRESS = 105
    NO_VALID_CONTROL = 106
    CONTROLLER_TIMED_OUT = 107


class NavigateToPoseError(IntEnum):
    """nav2_msgs/action/NavigateToPose result codes (Nav2 Kilted)."""

    NONE = 0
    UNKNOWN = 9000
    FAILED_TO_LOAD_BEHAVIOR_TREE = 9001
    TF_ERROR = 9002
    TIMEOUT = 9003


@dataclass(frozen=True)
class Tuning:
    """How the navigator follows, waits and recovers (distances in m, times in sim s)."""

    lookahead: float = 0.5
    rotate_in_place_above: float = 0.7  # rad of heading error
    approach_gain: float = 0.8  # speed (m/s) per metre left to the goal
    creep_speed: float = 0.08
    turn_gain: float = 2.0
    min_turn_rate: float = 0.2
    observe_period: float = 0.2  # the costmap updates at 5 Hz, Nav2's default update_frequency
    replan_period: float = 1.0  # replan this often while people obstruct the path ...
    obstruction_horizon: float = 4.0  # ... this far ahead,
    detour_allowance: float = 5.0  # taking a new way round them up to this much longer;
    refresh_period: float = 5.0  # replan this often when the costmap changed anyhow,
    shortcut_gain: float = 1.0  # taking the new path only when it is this much shorter ...
    shortcut_fraction: float = 0.1  # ... and at least this share of the way left
    off_path: float = 0.6
    person_gap: float = 0.7  # from the robot's front to a person's body
    robot_front: float = 0.25
    person_radius: float = PERSON_RADIUS
    person_across: float = 0.5  # a person this near the path is on it
    wait: tuple[float, float] = (0.5, 1.5)
    blocked_patience: float = 20.0
    progress_distance: float = 0.25
    progress_window: float = 10.0
    backup_speed: float = 0.15
    backup_time: float = 1.0
    reset_distance: float = 3.0  # m: a recovery forgets marks outside this square round it
    body_horizon: float = 0.3  # s: a command is checked for the body this far ahead ...
    body_margin: float = 0.01  # m: ... to keep its outline this far off walls and people,
    person_body: float = 0.25  # m: a marked person's body as the lidar outlines it


class PolylinePath:
    """A planned path as a polyline with arc lengths."""

    def __init__(self, waypoints: list[tuple[float, float]]) -> None:
        self.points = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
        segments = np.diff(self.points, axis=0)
        self.lengths = np.hypot(segments[:, 0], segments[:, 1])
        self.arc = np.concatenate(([0.0], np.cumsum(self.lengths)))
        self.total = float(self.arc[-1])
        # asked at every control step: what locate() needs of every segment is kept as plain
        # floats, and arc lengths are searched with bisect (numpy's call overhead on the one or
        # two segments near the robot was most of the cost)
        self._arcs: list[float] = self.arc.tolist()
        self._corners: list[tuple[float, float]] = [(x, y) for x, y in self.points.tolist()]
        self._segments: list[tuple[float, ...]] = list(zip(
            *self.points[:-1].T.tolist(), *segments.T.tolist(),
            np.maximum(self.lengths ** 2, 1e-12).tolist(), self.lengths.tolist(),
            self._arcs[:-1], strict=True))

    def point_at(self, s: float) -> tuple[float, float]:
        """The path's point ``s`` metres along it (clamped to the path), in plain floats, with
        the same arithmetic as an element-wise numpy interpolation (so the same values)."""
        s = min(max(s, 0.0), self.total)
        index = min(bisect.bisect_right(self._arcs, s) - 1, len(self._segments) - 1)
        if index < 0 or self._segments[index][5] == 0.0:
            x, y = self._corners[max(index, 0)]
            return x, y
        start_x, start_y, span_x, span_y, _, length, arc = self._segments[index]
        fraction = (s - arc) / length
        return start_x + fraction * span_x, start_y + fraction * span_y

    def locate(self, x: float, y: float, *, near: float, reach: float = 1.5) -> tuple[float, float]:
        """(arc length, distance) of the path point nearest (x, y), ``reach`` past ``near``.

        Each segment's nearest point is worked out with the arithmetic numpy's element-wise
        version used (clamps as ``np.maximum``/``np.minimum`` make them, the distance by
        ``np.hypot``); the first nearest wins, as ``np.argmin`` picks it.
        """
        # only the segments that overlap the window can hold the answer
        segments = len(self._segments)
        low, high = near - 0.2, near + reach
        first = min(max(bisect.bisect_right(self._arcs, low) - 1, 0), segments - 1)
        last = min(max(bisect.bisect_left(self._arcs, high), first + 1), segments)
        best_arc, best_gap = near, math.inf
        for start_x, start_y, span_x, span_y, square, length, arc in self._segments[first:last]:
            fraction = ((x - start_x) * span_x + (y - start_y) * span_y) / square
            fraction = fraction if fraction >= 0.0 else 0.0
            fraction = fraction if fraction <= 1.0 else 1.0
            along = arc + fraction * length
            if low <= along <= high:
                gap = float(np.hypot(start_x + fraction * span_x - x,
                                     start_y + fraction * span_y - y))
                if gap < best_gap:
                    best_arc, best_gap = along, gap
        if not math.isfinite(best_gap):
            point_x, point_y = self.point_at(near)
            return near, float(np.hypot(point_x - x, point_y - y))
        return best_arc, best_gap

    def samples(self, s: float, length: float, *, step: float = 0.1) -> np.ndarray:
        """Points every ``step`` (or closer) along the path from ``s`` for ``length`` metres."""
        end = min(s + length, self.total)
        arcs = evenly_spaced(s, end, max(math.ceil((end - s) / step), 0) + 1)
        return np.column_stack((np.interp(arcs, self.arc, self.points[:, 0]),
                                np.interp(arcs, self.arc, self.points[:, 1])))


def evenly_spaced(start: float, stop: float, count: int) -> NDArray[np.float64]:
    """``np.linspace(start, stop, count)`` of floats, ``count`` at least 1: its arithmetic
    (multiples of the step from ``start``, ``stop`` last) without its wrappers, which cost
    more than the work on the path's few samples."""
    values = np.arange(count, dtype=np.float64)
    span = stop - start
    divisions = count - 1
    if divisions > 0:
        step = span / divisions
        if step == 0.0:
            values /= divisions
            values *= span
        else:
            values *= step
    else:
        values *= span
    values += start
    if divisions > 0:
        values[-1] = stop
    return values


def wrapped(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def clamped(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


@dataclass(frozen=True)
class Limits:
    max_speed: float
    max_turn_rate: float


def turn_towards(error: float, limits: Limits, tuning: Tuning) -> float:
    """A turn rate on the spot that closes a heading error without crawling at the end."""
    rate = clamped(tuning.turn_gain * error, limits.max_turn_rate)
    if abs(rate) < tuning.min_turn_rate:
        rate = math.copysign(min(tuning.min_turn_rate, limits.max_turn_rate), error)
    return rate


def pursue(path: PolylinePath, s: float, pose: Pose, limits: Limits, tuning: Tuning) -> Twist:
    """Pure pursuit of the path from arc length ``s``; turns on the spot when far off course."""
    x, y, yaw = pose
    target = path.point_at(s + tuning.lookahead)
    distance = math.hypot(target[0] - x, target[1] - y)
    error = wrapped(math.atan2(target[1] - y, target[0] - x) - yaw)
    if abs(error) > tuning.rotate_in_place_above:
        return 0.0, turn_towards(error, limits, tuning)
    to_goal = max(path.total - s, 0.0)
    speed = min(limits.max_speed, max(tuning.creep_speed, tuning.approach_gain * to_goal))
    speed *= 1.0 - 0.5 * abs(error) / tuning.rotate_in_place_above
    turn = 2.0 * speed * math.sin(error) / max(distance, 1e-3)
    if abs(turn) > limits.max_turn_rate:
        speed *= limits.max_turn_rate / abs(turn)
        turn = math.copysign(limits.max_turn_rate, turn)
    return speed, turn


class Navigator:
    """One navigation goal at a time, driven step by step by the engine (see module docstring).

    ``status``, ``error_code``, ``error_msg``, ``distance_remaining``, ``recoveries`` and
    ``path`` describe the current (or last) goal, like NavigateToPose's feedback and result.
    """

    def __init__(self, occupancy_map: OccupancyMap, *, max_speed: float = 0.5,
                 max_turn_rate: float = 1.0, rng: np.random.Generator,
                 parameters: NavigationParameters = SERVICEBOT,
                 tuning: Tuning | None = None, lidar: Lidar | None = None,
                 body: Body | None = None) -> None:
        self.tuning = tuning or Tuning()
        self.limits = Limits(max_speed=max_speed, max_turn_rate=max_turn_rate)
        self.parameters = parameters
        self.xy_tolerance = parameters.goal_checker.xy_goal_tolerance
        self.yaw_tolerance = parameters.goal_checker.yaw_goal_tolerance
        self.rng = rng
        self.costmap = Costmap(occupancy_map, layers=parameters.costmap,
                               person_radius=self.tuning.person_radius, lidar=lidar)
        self.planner = Planner(self.costmap, goal_tolerance=self.xy_tolerance)
        self.status: NavigationStatus = "idle"
        self.error_code = 0
        self.error_msg = ""
        self.distance_remaining = 0.0
        self.recoveries = 0
        self.path: list[tuple[float, float]] = []
        self._observed_at = -math.inf
        self._people: list[tuple[float, float]] = []
        self._listed_marks: tuple[tuple[PersonMark, ...], list[tuple[float, float]]] = ((), [])
        self.body_check = None if body is None else BodyCheck(
            body, marks=self._marks, horizon=self.tuning.body_horizon,
            margin=self.tuning.body_margin, person_body=self.tuning.person_body)
        self._reset_goal(goal=None, now=0.0, abort_after_s=None)

    def _reset_goal(self, *, goal: Pose | None, now: float, abort_after_s: float | None) -> None:
        self._goal = goal
        if self.body_check is not None:
            self.body_check.forget()
        self._abort_at = None if abort_after_s is None else now + abort_after_s
        self._track: PolylinePath | None = None
        self._located: tuple[PolylinePath, float, float] | None = None
        self._s = self._off_path = 0.0
        self._arrival_radius = self.xy_tolerance
        self._turning_to_goal = False
        self._replan_needed = True
        self._planned_at = -math.inf
        self._planned_version = -1
        self._obstruction_checked: tuple[int, int] | None = None
        self._obstructed = False
        self._blocked_since: float | None = None
        self._blocked_code = 0
        self._blocked_msg = ""
        self._retry_at = -math.inf
        self._waits = 0
        self._anchor: tuple[float, float, float] | None = None
        self._backed_up = False
        self._backing_until = -math.inf

    # ------------------------------------------------------------------ the engine's calls
    def start(self, x: float, y: float, yaw: float, *, now: float,
              abort_after_s: float | None = None) -> None:
        """Navigate to (x, y, yaw); a goal already running is replaced."""
        self._reset_goal(goal=(x, y, yaw), now=now, abort_after_s=abort_after_s)
        self.status, self.error_code, self.error_msg = "running", 0, ""
        self.recoveries, self.path, self.distance_remaining = 0, [], 0.0
        if not all(math.isfinite(value) for value in (x, y, yaw)):
            self._abort(ComputePathToPoseError.GOAL_OUTSIDE_MAP,
                        f"goal ({x}, {y}, {yaw}) is not a finite pose")

    def cancel(self) -> None:
        if self.status == "running":
            self.status = "canceled"
            self._reset_goal(goal=None, now=0.0, abort_after_s=None)

    def clear_costmaps(self) -> None:
        """Forget every person mark; a running goal replans on its next step."""
        self.costmap.clear()
        self._replan_needed = True

    def observation_due(self, now: float) -> bool:
        """Whether the costmap's next sweep is due (:attr:`Tuning.observe_period`)."""
        return not 0.0 <= now - self._observed_at < self.tuning.observe_period

    def observe(self, *, pose: Pose, people: list[tuple[float, float]], now: float) -> None:
        """A sweep of the costmap with no goal to drive, if one is due: the costmap marks and
        clears people at its own rate whether or not a goal runs, as Nav2's does."""
        self._people = people
        self._observe(pose, now)

    def command(self, *, pose: Pose, people: list[tuple[float, float]], now: float) -> Twist:
        """The (v, w) for this step; observes people first, stops unless a goal is running.
        A command that would bring the body against a wall or a person the costmap holds is
        changed for one that does not."""
        twist = self._command(pose=pose, people=people, now=now)
        return self._keeping_the_body_clear(pose, twist, now=now)

    def _keeping_the_body_clear(self, pose: Pose, twist: Twist, *, now: float) -> Twist:
        """``twist`` if it keeps the body's outline :attr:`Tuning.body_margin` off walls and
        off the bodies (:attr:`Tuning.person_body`) of the people marked in the costmap over
        the next :attr:`Tuning.body_horizon` (or no nearer than now), else what the
        :class:`~servicesim_sim.navigation.body_check.BodyCheck` gives way to: the footprint
        check move_base's local planner made of every trajectory it sampled against its
        costmap, where the lidar's hits on people are obstacles as walls are."""
        if self.body_check is None:
            return twist
        return self.body_check.command(pose, twist, now=now)

    def _clearances(self, pose: Pose) -> Clearances:
        """Metres from the body at ``pose`` to the nearest wall and to the nearest marked
        person's body (see :meth:`BodyCheck.clearances`)."""
        assert self.body_check is not None
        return self.body_check.clearances(pose)

    def _command(self, *, pose: Pose, people: list[tuple[float, float]], now: float) -> Twist:
        self._people = people
        self._observe(pose, now)
        if self.status != "running":
            return STOP
        if not all(math.isfinite(value) for value in pose):
            return self._abort(NavigateToPoseError.TF_ERROR, "the robot's pose is unknown")
        if self._abort_at is not None and now >= self._abort_at:
            return self._abort(NavigateToPoseError.UNKNOWN,
                               "navigation aborted: the simulator's random navigation failure")
        if now < self._backing_until:
            return -self.tuning.backup_speed, 0.0
        if self._turning_to_goal:
            return self._turn_to_goal(pose)
        if self._blocked_since is not None:
            return self._while_blocked(pose, now)
        if self._track is not None:
            self._locate(pose)
            if self._person_ahead():  # stop first: replanning round them comes after a wait
                self._block(now, FollowPathError.FAILED_TO_MAKE_PROGRESS,
                            "a person stands on the path ahead")
                return STOP
        if self._replan_required():
            if not self._replan(pose, now):
                return STOP
        elif self._reconsider_due(now):
            self._reconsider(pose, now)
        return self._follow(pose, now)

    # ------------------------------------------------------------------ planning
    def _replan_required(self) -> bool:
        """No path yet, the path was dropped, or the robot strayed from it."""
        return self._track is None or self._replan_needed or self._off_path > self.tuning.off_path

    def _reconsider_due(self, now: float) -> bool:
        """Whether the costmap changed since the last plan, and that plan is a second old with
        people now obstructing the next few metres of the path (or at all, when the navigation
        tree plans every second), or five seconds old."""
        if self.costmap.version == self._planned_version:
            return False
        since = now - self._planned_at
        if self.parameters.replans_every_second:
            return since >= self.tuning.replan_period
        return since >= self.tuning.refresh_period or (
            since >= self.tuning.replan_period and self._path_obstructed())

    def _path_obstructed(self) -> bool:
        """Whether the next metres of the path now cross lethal or inscribed cost.

        The answer is kept until the costmap changes, the path changes or the robot has gone
        :data:`OBSTRUCTION_RECHECK_M` further along it: asked every physics step while people
        move in view, it was a tenth of the simulator's time.
        """
        assert self._track is not None
        key = (self.costmap.version, math.floor(self._s / OBSTRUCTION_RECHECK_M))
        if self._obstruction_checked != key:
            ahead = self._track.samples(self._s, self.tuning.obstruction_horizon)
            self._obstructed = bool(
                np.any(self.costmap.costs_at(ahead[:, 0], ahead[:, 1]) >= INSCRIBED))
            self._obstruction_checked = key
        return self._obstructed

    def _reconsider(self, pose: Pose, now: float) -> None:
        """Plan afresh, but keep the current path unless the new one is worth the switch
        (with Nav2's default tree it always is: :meth:`_follow_new_plan`).

        Round people obstructing the path the new way is taken unless it is a long detour
        (a person crossing will likely be gone; one who stays stops the robot, which then
        waits and goes round). Otherwise only a clearly shorter way is taken, so the robot
        does not dither between routes as people come and go; that plan is skipped when even
        the static map's shortest way would not be short enough
        (:meth:`~servicesim_sim.navigation.planner.Planner.length_bound`).
        """
        assert self._track is not None and self._goal is not None
        start, goal = (pose[0], pose[1]), (self._goal[0], self._goal[1])
        if self.parameters.replans_every_second:
            self._follow_new_plan(start, goal, now)
            return
        tuning = self.tuning
        remaining = self._off_path + self._track.total - self._s
        if self._path_obstructed():
            worth = tuning.detour_allowance
        else:
            worth = -max(tuning.shortcut_gain, tuning.shortcut_fraction * remaining)
            if self.planner.length_bound(start, goal) > remaining + worth:
                # no way is short enough to switch to: already on (nearly) the shortest
                self._planned_at, self._planned_version = now, self.costmap.version
                return
        result = self.planner.plan(start, goal)
        self._planned_at, self._planned_version = now, self.costmap.version
        if result.waypoints is not None and path_length(result.waypoints) <= remaining + worth:
            self._take(result)

    def _follow_new_plan(self, start: tuple[float, float], goal: tuple[float, float],
                         now: float) -> None:
        """Nav2's default tree: plan afresh and follow the new path, unless it is much longer
        than what is left of the current one (see the module docstring); no path found (people
        in the way) keeps the current one, on which a person standing stops the robot."""
        result = self.planner.plan(start, goal)
        self._planned_at, self._planned_version = now, self.costmap.version
        if result.waypoints is None:
            return
        assert self._track is not None
        tuning = self.tuning
        remaining = self._off_path + self._track.total - self._s
        worth = (tuning.detour_allowance if self._path_obstructed()
                 else max(tuning.shortcut_gain, tuning.shortcut_fraction * remaining))
        if path_length(result.waypoints) <= remaining + worth:
            self._take(result)

    def _replan(self, pose: Pose, now: float) -> bool:
        """Plan from the pose; False when navigation aborted or now waits for people."""
        assert self._goal is not None
        start, goal = (pose[0], pose[1]), (self._goal[0], self._goal[1])
        result = self.planner.plan(start, goal)
        self._planned_at, self._planned_version = now, self.costmap.version
        self._replan_needed = False
        if result.succeeded:
            self._take(result)
            return True
        without_people = self.planner.plan(start, goal, with_people=False)
        if not without_people.succeeded:
            self._abort(without_people.error_code, without_people.error_msg)
            return False
        self._block(now, result.error_code, f"{result.error_msg} (people are in the way)")
        return False

    def _take(self, result: PlanResult) -> None:
        assert result.waypoints is not None and result.goal is not None and self._goal is not None
        self._track = PolylinePath(result.waypoints)
        self._obstruction_checked = None
        self._s = self._off_path = 0.0
        self.path = list(result.waypoints)
        self.distance_remaining = path_length(result.waypoints)
        snapped = math.dist(result.goal, self._goal[:2])
        self._arrival_radius = max(self.xy_tolerance - snapped, 0.05)

    # ------------------------------------------------------------------ following
    def _follow(self, pose: Pose, now: float) -> Twist:
        assert self._track is not None
        x, y, _ = pose
        self._locate(pose)
        self.distance_remaining = max(self._track.total - self._s, 0.0)
        end = self._track.points[-1]
        if math.hypot(end[0] - x, end[1] - y) <= self._arrival_radius:
            self._turning_to_goal = True
            return self._turn_to_goal(pose)
        recovery = self._check_progress(pose, now)
        if recovery is not None:
            return recovery
        return pursue(self._track, self._s, pose, self.limits, self.tuning)

    def _locate(self, pose: Pose) -> None:
        """Where along the path the robot is (``_s``) and how far off it; once per pose and path."""
        assert self._track is not None
        key = (self._track, pose[0], pose[1])
        if self._located != key:
            self._s, self._off_path = self._track.locate(pose[0], pose[1], near=self._s)
            self._located = key

    def _turn_to_goal(self, pose: Pose) -> Twist:
        assert self._goal is not None
        error = wrapped(self._goal[2] - pose[2])
        if abs(error) <= self.yaw_tolerance:
            self.status, self.distance_remaining = "succeeded", 0.0
            return STOP
        return 0.0, turn_towards(error, self.limits, self.tuning)

    def _person_ahead(self) -> bool:
        """Whether a visible person is within ``person_across`` of the path's next metre or so
        (from the robot's front to a person's body at ``person_gap``).

        Every point of that stretch lies within its length of where it starts, so people
        farther than that plus ``person_across`` (and a centimetre) from its start cannot be
        near it: when nobody is nearer, the stretch is not sampled at all.
        """
        people = self.costmap.visible_people
        if not people or self._track is None:
            return False
        tuning = self.tuning
        reach = tuning.robot_front + tuning.person_gap + tuning.person_radius
        start_x, start_y = self._track.point_at(self._s)
        bound = (reach + tuning.person_across + 0.01) ** 2
        if all((x - start_x) ** 2 + (y - start_y) ** 2 >= bound for x, y in people):
            return False
        samples = self._track.samples(self._s, reach)
        spots = np.asarray(people, dtype=np.float64)
        gaps = np.hypot(spots[:, None, 0] - samples[None, :, 0],
                        spots[:, None, 1] - samples[None, :, 1])
        return bool(np.any(gaps.min(axis=1) < tuning.person_across))

    # ------------------------------------------------------------------ recoveries
    def _block(self, now: float, code: int, message: str) -> None:
        """The way is blocked by people: wait (a recovery), then try again."""
        if self._blocked_since is None:
            self._blocked_since, self._waits = now, 0
        self._blocked_code, self._blocked_msg = int(code), message
        self.recoveries += 1
        self._waits += 1
        self._retry_at = now + float(self.rng.uniform(*self.tuning.wait))

    def _while_blocked(self, pose: Pose, now: float) -> Twist:
        assert self._blocked_since is not None
        self._anchor = (pose[0], pose[1], now)  # waiting is not a lack of progress
        patience = self.tuning.blocked_patience
        if now - self._blocked_since > patience:
            return self._abort(self._blocked_code,
                               f"{self._blocked_msg}; blocked for {patience:.0f} s")
        if now < self._retry_at:
            return STOP
        if self._waits % 2 == 0:  # every other try, forget marks that may be stale
            self.costmap.clear()
            self._observe(pose, now, force=True)
        if not self._replan(pose, now):
            return STOP
        if self._person_ahead():
            self._block(now, FollowPathError.FAILED_TO_MAKE_PROGRESS,
                        "a person stands on the path ahead")
            return STOP
        self._blocked_since = None
        return self._follow(pose, now)

    def _check_progress(self, pose: Pose, now: float) -> Twist | None:
        """None while the robot moves on, else a recovery (backing up) or an abort."""
        x, y, _ = pose
        tuning = self.tuning
        anchor = self._anchor
        if anchor is None or math.hypot(x - anchor[0], y - anchor[1]) >= tuning.progress_distance:
            self._anchor, self._backed_up = (x, y, now), False
            return None
        still = now - anchor[2]
        if still > 2.0 * tuning.progress_window:
            return self._abort(FollowPathError.FAILED_TO_MAKE_PROGRESS,
                               f"the robot has not moved {tuning.progress_distance:.2f} m in "
                               f"{2.0 * tuning.progress_window:.0f} s")
        if still > tuning.progress_window and not self._backed_up:
            self._backed_up, self._replan_needed = True, True
            self.recoveries += 1
            room_behind = self._room_behind(pose)
            # the people near stay marked, so the body check keeps the backing off them
            self.costmap.clear_beyond(x, y, tuning.reset_distance / 2.0)
            if room_behind:
                self._backing_until = now + tuning.backup_time
                return -tuning.backup_speed, 0.0
        return None

    def _room_behind(self, pose: Pose) -> bool:
        """Whether the costmap lets the robot's centre where backing up would take it."""
        x, y, yaw = pose
        reach = self.tuning.backup_speed * self.tuning.backup_time
        return self.costmap.cost_at(x - reach * math.cos(yaw),
                                    y - reach * math.sin(yaw)) < INSCRIBED

    # ------------------------------------------------------------------ bookkeeping
    def _marks(self) -> list[tuple[float, float]]:
        """Where the people marked in the costmap stand (the body check asks twice a control
        step or more: listed again only when the marks changed; not to be altered)."""
        marks = self.costmap.marks
        if marks is not self._listed_marks[0]:
            self._listed_marks = (marks, [(mark.x, mark.y) for mark in marks])
        return self._listed_marks[1]

    def _observe(self, pose: Pose, now: float, *, force: bool = False) -> None:
        if not force and not self.observation_due(now):
            return
        if not all(math.isfinite(value) for value in pose):
            return
        self._observed_at = now
        self.costmap.observe(pose[0], pose[1], pose[2], self._people, now)

    def _abort(self, code: int, message: str) -> Twist:
        self.status, self.error_code, self.error_msg = "aborted", int(code), message
        return STOP
