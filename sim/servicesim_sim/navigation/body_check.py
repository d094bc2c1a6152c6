"""The body check of navigation's commands: the robot's box kept off walls and marked people.

move_base's local planner scored every trajectory it sampled by the footprint's cost in its
costmap, where the lidar's hits on people are obstacles as walls are, and dropped those that
touched. The navigator's follower gives one twist a step; :class:`BodyCheck` takes it when the
box stays clear over a short horizon, else gives way to a sample of its own.

Design intent:

* A twist keeps clear when the 0.4 x 0.5 m box, at every pose the twist takes it through over
  the horizon (0.3 s), is 1 cm off walls and off the bodies of the people marked in the
  costmap, or no nearer to either than it is now (a box already within the margin may still
  move away). The poses are :data:`SIM_GRANULARITY` apart, in metres driven or radians
  turned, whichever is more, as TrajectoryPlanner checked the footprint along each sampled
  trajectory (``sim_granularity`` and ``angular_sim_granularity``, whose 0.025 default the
  servicebot's configuration kept): a turning box's corner can reach into a wall between two
  poses farther apart and be out of it again at both.
* A refused twist gives way to the nearest clear sample of :data:`BODY_SAMPLES` (turn first,
  then speed): setting off beside someone, the robot drives straight on until its turn clears.
* A refused turn on the spot is the case where the nearest sample does not help: beside a wall
  or a person the box cannot turn, and driving straight forwards or backwards never makes the
  room (a robot pinned so flip-flopped between backing off and creeping on until navigation
  gave up). So is a refused drive whose nearest clear sample drives the other way (backing
  off, then creeping on into the same refusal). Like a sampling planner's window of
  velocities and the escapes of move_base's TrajectoryPlanner, the check then looks further:
  it holds each moving sample (nearest first) up to :data:`ESCAPE_HOLD` and takes the first,
  shortest hold after which the refused twist keeps clear for :data:`ESCAPE_FREE`. When no
  hold frees it, a turn on the spot takes the sample that leaves the box's centre the most
  room from walls and people (the room a turn needs, whatever the heading), a drive the
  nearest clear sample, each for :data:`ROOM_COMMIT` before looking again. A manoeuvre is held
  for its time while it keeps clear and navigation commands anything but a stop, so the robot
  does not alternate between two opposite samples step after step, and the search (dozens of
  footprint checks) runs at most twice a second while the robot stays pinned.
* Everything is a pure function of poses, the marks and sim time: a seed replays exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

Pose = tuple[float, float, float]
Twist = tuple[float, float]
Clearances = tuple[float, float]  # metres from the body to walls, and to marked people
STOP: Twist = (0.0, 0.0)

TURNS = (1.0, 0.5, 0.2, 0.0, -0.2, -0.5, -1.0)
BODY_SAMPLES: tuple[Twist, ...] = (
    *((v, w) for v in (0.3, 0.15) for w in TURNS),
    *((0.0, w) for w in TURNS if w != 0.0),
    *((-0.1, w) for w in (0.5, 0.2, 0.0, -0.2, -0.5)))
"""The twists tried, as a sampling local planner would, when the follower's own would bring
the body against a wall or a marked person: forward arcs, turns on the spot, backing off
straight or in an arc; gentle turns (0.2 rad/s) too, whose corners swing out least."""
SIM_GRANULARITY = 0.025
"""Metres driven, or radians turned, between the poses at which a command is checked over the
horizon (TrajectoryPlanner's default ``sim_granularity`` and ``angular_sim_granularity``)."""
ESCAPE_STEP = 0.15
"""Seconds between the poses at which a held sample or a turn is checked."""
ESCAPE_HOLD = 1.5
"""Seconds a sample is held at most to make room for a refused twist."""
ESCAPE_FREE = 0.6
"""Seconds the refused twist must then keep clear for (a turn on the spot: 0.6 rad)."""
ROOM_HOLD = 1.0
"""Seconds a sample is held, when no hold frees a turn, to judge the room it makes."""
ROOM_COMMIT = 0.5
"""Seconds a sample taken when no hold frees the refused twist is kept before looking again."""

GAP_BOUND_SLACK = 1e-6
"""Metres past the body margin a bound of the gap to the people must be to be taken for the
gap: less the body's width it is still past the margin, however the sums round."""


class Body(Protocol):
    """The robot's body on the map (:class:`servicesim_sim.world.footprint.Footprint`)."""

    def clearance(self, pose: Pose, *, beyond: float = 0.0) -> float:
        """Metres between the body at ``pose`` and the nearest wall (see Footprint)."""
        ...

    def nearest_gap(self, pose: Pose, points: Sequence[tuple[float, float]], *,
                    beyond: float = 0.0) -> float:
        """Metres between the body at ``pose`` and the nearest point (see Footprint)."""
        ...

    def centre_clearance(self, x: float, y: float) -> float:
        """Metres between the point (x, y) and the nearest wall (see Footprint)."""
        ...


def arc_end(pose: Pose, twist: Twist, seconds: float) -> Pose:
    """Where (v, w) held for ``seconds`` takes a differential drive from ``pose``."""
    x, y, yaw = pose
    v, w = twist
    turn = w * seconds
    if abs(turn) > 1e-9:
        radius = v / w
        return (x + radius * (math.sin(yaw + turn) - math.sin(yaw)),
                y - radius * (math.cos(yaw + turn) - math.cos(yaw)), yaw + turn)
    return x + v * seconds * math.cos(yaw), y + v * seconds * math.sin(yaw), yaw


def check_times(twist: Twist, horizon: float) -> tuple[float, ...]:
    """Seconds ahead at which ``twist`` is checked: evenly over ``horizon``, at most
    :data:`SIM_GRANULARITY` metres or radians apart, and at least halfway and at the end."""
    v, w = twist
    steps = max(2, math.ceil(max(abs(v), abs(w)) * horizon / SIM_GRANULARITY - 1e-9))
    return tuple(horizon * step / steps for step in range(1, steps + 1))


@dataclass(frozen=True)
class Manoeuvre:
    """A sample held until ``until`` (sim s) while it keeps clear."""

    twist: Twist
    until: float


class BodyCheck:
    """Checks each command for the body and gives way when it would touch (module docstring).

    ``marks`` gives the positions of the people marked in the costmap when asked.
    """

    def __init__(self, body: Body, *, marks: Callable[[], list[tuple[float, float]]],
                 horizon: float, margin: float, person_body: float) -> None:
        self.body = body
        self.marks = marks
        self.horizon = horizon
        self.margin = margin
        self.person_body = person_body
        self._manoeuvre: Manoeuvre | None = None

    def command(self, pose: Pose, twist: Twist, *, now: float) -> Twist:
        """``twist`` if it keeps clear, else the manoeuvre held, else a sample that does,
        else stop."""
        held = self._manoeuvre
        if (held is not None and now < held.until and twist != STOP
                and self.keeps_clear(pose, held.twist, self.clearances(pose))):
            return held.twist
        self._manoeuvre = None
        if twist == STOP or self.keeps_clear(pose, twist, None):
            return twist
        clearances = self.clearances(pose)
        options = sorted(BODY_SAMPLES, key=lambda option: (abs(option[1] - twist[1]),
                                                           abs(option[0] - twist[0])))
        nearest = next((option for option in options
                        if self.keeps_clear(pose, option, clearances)), STOP)
        if nearest != STOP and (twist[0] == 0.0 or nearest[0] * twist[0] < 0.0):
            self._manoeuvre = self._making_room(pose, twist, options, clearances, now,
                                                nearest=nearest)
            return self._manoeuvre.twist
        return nearest

    def forget(self) -> None:
        """Drop the manoeuvre held (a new goal, or none)."""
        self._manoeuvre = None

    def keeps_clear(self, pose: Pose, twist: Twist, now: Clearances | None) -> bool:
        """Whether ``twist`` keeps the body off walls and marked people at every pose over the
        horizon (:func:`check_times`), or, given its clearances ``now``, brings it no nearer to
        either that it is within the margin of."""
        return self._holds_clear(pose, twist, check_times(twist, self.horizon), now)

    def clearances(self, pose: Pose) -> Clearances:
        """Metres from the body at ``pose`` to the nearest wall and to the nearest marked
        person's body (gaps wider than the margin may be any gap wider than it: only whether
        a gap is within the margin, and then how it compares with a gap now, decides)."""
        margin, person_body = self.margin, self.person_body
        walls = self.body.clearance(pose, beyond=margin)
        beyond = margin + person_body + GAP_BOUND_SLACK
        people = self.body.nearest_gap(pose, self.marks(), beyond=beyond) - person_body
        return walls, people

    def _holds_clear(self, pose: Pose, twist: Twist, times: Sequence[float],
                     now: Clearances | None) -> bool:
        """Whether the body keeps clear (as :meth:`keeps_clear` says) at each of ``times``."""
        margin = self.margin
        for seconds in times:
            ahead = self.clearances(arc_end(pose, twist, seconds))
            for index, gap in enumerate(ahead):
                if gap < margin and (now is None or gap <= now[index] + 1e-4):
                    return False
        return True

    def _making_room(self, pose: Pose, twist: Twist, options: list[Twist], now: Clearances,
                     time: float, *, nearest: Twist) -> Manoeuvre:
        """The manoeuvre that makes room for the refused ``twist``: the shortest hold of a
        moving sample (of ``options``, nearest the twist first) after which the twist keeps
        clear; else, for a turn on the spot, the sample whose hold leaves the centre the most
        room, else the ``nearest`` clear sample, held a while before looking again."""
        moving = [option for option in options
                  if option[0] != 0.0 and self.keeps_clear(pose, option, now)]
        found = self._freeing(pose, twist, moving, now)
        if found is not None:
            return Manoeuvre(twist=found[0], until=time + found[1])
        holds = [step * ESCAPE_STEP for step in range(1, round(ROOM_HOLD / ESCAPE_STEP) + 1)]
        roomy = [option for option in moving if twist[0] == 0.0
                 and self._holds_clear(pose, option, holds, now)]
        best = max(roomy, default=nearest,
                   key=lambda option: round(self._room(arc_end(pose, option, ROOM_HOLD)), 3))
        return Manoeuvre(twist=best, until=time + ROOM_COMMIT)

    def _freeing(self, pose: Pose, twist: Twist, moving: list[Twist],
                 now: Clearances) -> tuple[Twist, float] | None:
        """The first of ``moving`` and the shortest hold of it, every :data:`ESCAPE_STEP` up
        to :data:`ESCAPE_HOLD`, that keeps clear and after which ``twist`` keeps clear for
        :data:`ESCAPE_FREE` (a turn on the spot at the full rate, as far as it may need to
        go); None if none does."""
        freed = (0.0, math.copysign(1.0, twist[1])) if twist[0] == 0.0 else twist
        ahead = [step * ESCAPE_STEP
                 for step in range(1, math.ceil(ESCAPE_FREE / ESCAPE_STEP) + 1)]
        alive = moving
        for step in range(1, round(ESCAPE_HOLD / ESCAPE_STEP) + 1):
            seconds = step * ESCAPE_STEP
            alive = [option for option in alive
                     if self._holds_clear(pose, option, (seconds,), now)]
            for option in alive:
                end = arc_end(pose, option, seconds)
                if self._holds_clear(end, freed, ahead, self.clearances(end)):
                    return option, seconds
        return None

    def _room(self, pose: Pose) -> float:
        """Metres between the body's centre at ``pose`` and the nearest wall or marked
        person's body: the room a turn on the spot needs, whatever the heading."""
        x, y, _ = pose
        people = min((math.hypot(px - x, py - y) for px, py in self.marks()), default=math.inf)
        return min(self.body.centre_clearance(x, y), people - self.person_body)

