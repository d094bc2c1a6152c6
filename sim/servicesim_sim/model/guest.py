"""The guest: waits to be picked up, then follows the robot along its trail.

The original guest walked straight at the robot, through walls (``FollowActorPlugin.cc``); that
is still here, as ``path="straight"`` (the simulator's ``--guest-path straight``), and does
nothing else: no trail, no stepping aside. By default (``path="trail"``) the guest follows the
robot's *trail* — the points the robot's origin passed, recorded every few centimetres — so it
takes the same doors and corridors the robot took. It walks at up to 0.8 m/s, stops when it is
within 1.2 m of the robot, and stops following for good (until picked up again) in two ways the
referee cares about: the robot gets more than 4.0 m ahead ("too fast"), or a scheduled drift
makes it wander off its task and stay where it is.

Whatever its state, a guest who is not waiting to be picked up steps out of the robot's way
when it comes closer than 0.9 m — straight back, or aside where a wall is behind them — as a
person would: a robot turning back past the person it guides, or leaving the spot where it
dropped them off, does not walk through them. A following guest who stepped aside rejoins the
trail by the shortest way to the robot (straight to a trail point clear of walls, then along
the trail), as a person would, rather than walking back to the trail point they left: that
could lie behind them, where the robot stood when it picked them up, and lose them "too fast"
as the robot drove on.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from collections.abc import Callable
from enum import Enum

FOLLOW_SPEED = 0.8  # m/s
STOP_DISTANCE = 1.2  # m from the robot
LOST_DISTANCE = 4.0  # m: the robot is "too fast" beyond this
DRIFT_TIME_TOLERANCE = 0.5  # s: a drift is due this long either side of its time
# (FollowActorPlugin.cc 80, 294-307: any update within 0.5 s of it while the guest follows)
TRAIL_SPACING = 0.05  # m between trail points
YIELD_DISTANCE = 0.9  # m: closer than this, the guest steps out of the robot's way
WALL_CLEARANCE = 0.3  # m: the guest keeps this far from walls when stepping aside
YIELD_DIRECTIONS = (0.0, 0.6, -0.6, 1.2, -1.2, 1.57, -1.57)  # rad off "straight away"
REJOIN_LOOKAHEAD = 400  # trail points (20 m) searched for the nearest when rejoining
REJOIN_CLEARANCE = 0.2  # m: a rejoining guest walks straight only this far clear of walls
GUEST_PATHS = ("trail", "straight")  # ours (the default), the original's


class GuestState(Enum):
    WAITING = "waiting"  # at the pick-up spot, never picked up
    FOLLOWING = "following"
    LOST = "lost"  # the robot went more than 4 m ahead
    DRIFTED = "drifted"  # a drift made them stop following
    DROPPED_OFF = "dropped_off"


class Guest:
    """Position and state of the guest; :meth:`step` moves them."""

    def __init__(self, *, name: str, x: float, y: float, yaw: float,
                 wall_clearance: Callable[[float, float], float] | None = None,
                 path: str = "trail") -> None:
        if path not in GUEST_PATHS:
            raise ValueError(f"guest path {path!r}: must be one of {', '.join(GUEST_PATHS)}")
        self.name = name
        self.path = path
        self.wall_clearance = wall_clearance
        self.x, self.y, self.yaw = x, y, yaw
        self.state = GuestState.WAITING
        self.trail: deque[tuple[float, float]] = deque()
        self._off_trail = False

    @property
    def following(self) -> bool:
        return self.state is GuestState.FOLLOWING

    def distance_to(self, x: float, y: float) -> float:
        return math.hypot(x - self.x, y - self.y)

    def start_following(self, robot_x: float, robot_y: float) -> None:
        """Picked up: the trail starts with the straight line to where the robot stands."""
        self.state = GuestState.FOLLOWING
        self.trail.clear()
        self._off_trail = False
        steps = max(1, int(self.distance_to(robot_x, robot_y) / TRAIL_SPACING))
        for index in range(1, steps + 1):
            fraction = index / steps
            self.trail.append((self.x + fraction * (robot_x - self.x),
                               self.y + fraction * (robot_y - self.y)))

    def stop_following(self, state: GuestState) -> None:
        self.state = state
        self.trail.clear()

    def record_robot(self, robot_x: float, robot_y: float) -> None:
        """Extend the trail with the robot's origin when it has moved far enough."""
        if not self.following or self.path == "straight":
            return
        last = self.trail[-1] if self.trail else (self.x, self.y)
        if math.hypot(robot_x - last[0], robot_y - last[1]) >= TRAIL_SPACING:
            self.trail.append((robot_x, robot_y))

    def step(self, dt: float, *, robot_x: float, robot_y: float) -> None:
        """Walk along the trail towards the robot, stopping 1.2 m short of it; step aside when
        the robot comes too close. On the ``straight`` path, walk straight at the robot."""
        if self.path == "straight":
            self._walk_straight(dt, robot_x=robot_x, robot_y=robot_y)
            return
        if self.state is not GuestState.WAITING and self.distance_to(robot_x, robot_y) < (
                YIELD_DISTANCE):
            self._step_aside(dt, robot_x=robot_x, robot_y=robot_y)
            return
        if not self.following:
            return
        if self._off_trail:
            self._rejoin_trail()
        budget = FOLLOW_SPEED * dt
        while budget > 1e-9 and self.trail:
            if self.distance_to(robot_x, robot_y) <= STOP_DISTANCE:
                return
            target_x, target_y = self.trail[0]
            gap = self.distance_to(target_x, target_y)
            if gap <= budget:
                self.x, self.y = target_x, target_y
                self.trail.popleft()
                budget -= gap
                continue
            self.yaw = math.atan2(target_y - self.y, target_x - self.x)
            self.x += budget * math.cos(self.yaw)
            self.y += budget * math.sin(self.yaw)
            budget = 0.0

    def _walk_straight(self, dt: float, *, robot_x: float, robot_y: float) -> None:
        """The original's guest: straight at the robot, walls or not, until 1.2 m short."""
        gap = self.distance_to(robot_x, robot_y)
        if not self.following or gap <= STOP_DISTANCE:
            return
        self.yaw = math.atan2(robot_y - self.y, robot_x - self.x)
        self.x += FOLLOW_SPEED * dt * math.cos(self.yaw)
        self.y += FOLLOW_SPEED * dt * math.sin(self.yaw)

    def _rejoin_trail(self) -> None:
        """Drop the trail points before the one where walking straight there, then on along
        the trail, is the shortest way to the robot (of those the guest can walk straight to).

        The trail can double back (the robot turned round, or drove past the guest it had just
        picked up), so the nearest point is not always the right one: the shortest way skips
        the loop.
        """
        self._off_trail = False
        ahead = list(itertools.islice(self.trail, REJOIN_LOOKAHEAD))
        along = list(itertools.accumulate(
            (math.dist(a, b) for a, b in itertools.pairwise(ahead)), initial=0.0))
        by_way = sorted(range(len(ahead)),
                        key=lambda index: self.distance_to(*ahead[index]) - along[index])
        start = next((index for index in by_way if self._walkable_to(*ahead[index])), 0)
        for _ in range(start):
            self.trail.popleft()

    def _walkable_to(self, x: float, y: float) -> bool:
        if self.wall_clearance is None:
            return True
        steps = max(1, math.ceil(self.distance_to(x, y) / TRAIL_SPACING))
        return all(self.wall_clearance(self.x + (x - self.x) * k / steps,
                                       self.y + (y - self.y) * k / steps) >= REJOIN_CLEARANCE
                   for k in range(1, steps + 1))

    def _step_aside(self, dt: float, *, robot_x: float, robot_y: float) -> None:
        """Move away from the robot at walking speed, onto a spot clear of walls."""
        self._off_trail = True
        away = math.atan2(self.y - robot_y, self.x - robot_x)
        step = FOLLOW_SPEED * dt
        for offset in YIELD_DIRECTIONS:
            heading = away + offset
            x, y = self.x + step * math.cos(heading), self.y + step * math.sin(heading)
            if self.wall_clearance is None or self.wall_clearance(x, y) >= WALL_CLEARANCE:
                self.x, self.y = x, y
                return
