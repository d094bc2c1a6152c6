"""What the people the points were booked near were doing, and the robot with them.

A cause says near whom a penalty was booked (``approximation/walker/human_3``); a *situation*
says what that person was doing then, in the terms a tree can act on, and whether the robot was
moving or standing:

* ``walker walking``: a walker on its way;
* ``walker standing for the robot``, ``... for the guest``, ``... for someone else``: a walker
  stops while anyone stands in its lane (:data:`~bt_servicesim.planning.rules.PEOPLE_LANE_LENGTH`
  ahead, :data:`~bt_servicesim.planning.rules.PEOPLE_LANE_HALF_WIDTH` either side of its way) and
  waits as long as the lane stays blocked, so a robot in a walker's lane holds the walker
  beside itself, for as long as it stays;
* ``walker standing``: standing with nobody in its lane as its latest steps point it (the way
  it faces is taken from where it last walked, so a walker who turned where it stopped may be
  counted here, as may one that has not walked yet);
* ``idler``, ``guest``.

A situation key is ``penalty/situation`` (``approximation/walker standing for the robot``); its
value splits the points into ``robot moving`` and ``robot standing``. Points booked near walls,
objects, or unattributed, have no situation.

Built from the recorded ground truth (``/servicesim/actors`` at 2 Hz, the robot's odometry): a
record of what happened, never an input to a mission. Each booked increment takes the
situation at its end (the sample of the people nearest to it); speeds are measured over
:data:`MOTION_WINDOW_S` round it.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from bt_servicesim.planning.rules import PEOPLE_LANE_HALF_WIDTH, PEOPLE_LANE_LENGTH

__all__ = ["ROBOT_MOVING", "ROBOT_STANDING", "PeopleSample", "situation_points"]

WALKING_SPEED = 0.3
"""m/s: a walker faster than this over :data:`MOTION_WINDOW_S` is walking (walkers walk at
0.9-1.2 m/s)."""
ROBOT_MOVING_SPEED = 0.15
"""m/s: the robot faster than this over :data:`MOTION_WINDOW_S` is moving."""
MOTION_WINDOW_S = 1.0
"""Seconds either side of a moment over which speeds are measured."""
HEADING_STEP = 0.3
"""Metres a walker must have walked for its last steps to give the way it faces."""
ROBOT_MOVING, ROBOT_STANDING = "robot moving", "robot standing"
PERSON_ROLES = ("guest", "walker", "idler")


@dataclass(frozen=True)
class PeopleSample:
    """Where the robot and everyone were at one moment: ``people`` maps a name to its role
    (``guest``, ``walker``, ``idler``) and position."""

    sim_time_s: float
    robot: tuple[float, float]
    people: Mapping[str, tuple[str, float, float]]


def situation_points(samples: Sequence[PeopleSample],
                     booked: Sequence[tuple[float, float, Mapping[str, float]]]
                     ) -> dict[str, dict[str, float]]:
    """Points by situation key, split by the robot's motion, for every person cause in
    ``booked`` (``(start, end, {cause: points})`` increments, as
    :func:`bt_servicesim.records.profile.increments` gives them)."""
    result: dict[str, dict[str, float]] = {}
    if not samples:
        return result
    scene = _Scene(samples)
    for _start, end, change in booked:
        for cause, points in change.items():
            parts = cause.split("/")
            if len(parts) != 3 or parts[1] not in PERSON_ROLES or points <= 0.0:
                continue
            penalty, role, name = parts
            index = scene.index_at(end)
            key = f"{penalty}/{scene.situation(index, role=role, name=name)}"
            motion = ROBOT_MOVING if scene.robot_moving(index) else ROBOT_STANDING
            split = result.setdefault(key, {ROBOT_MOVING: 0.0, ROBOT_STANDING: 0.0})
            split[motion] += points
    return {key: {motion: round(points, 3) for motion, points in split.items()}
            for key, split in sorted(result.items(), key=lambda item: -sum(item[1].values()))}


class _Scene:
    """The samples, looked up by time."""

    def __init__(self, samples: Sequence[PeopleSample]) -> None:
        self.samples = samples
        self.times = [sample.sim_time_s for sample in samples]
        self._situations: dict[tuple[int, str, str], str] = {}
        self._facings: dict[str, list[tuple[float, float] | None]] = {}

    def index_at(self, sim_time_s: float) -> int:
        """The sample nearest to ``sim_time_s``."""
        right = bisect.bisect_left(self.times, sim_time_s)
        if right == 0:
            return 0
        if right == len(self.times):
            return right - 1
        left = right - 1
        nearer_left = sim_time_s - self.times[left] <= self.times[right] - sim_time_s
        return left if nearer_left else right

    def facing(self, index: int, name: str) -> tuple[float, float] | None:
        """The way walker ``name`` faces at sample ``index``, from its latest steps."""
        if name not in self._facings:
            self._facings[name] = _facings(self, name)
        return self._facings[name][index]

    def _around(self, index: int) -> tuple[int, int]:
        now = self.times[index]
        before = self.index_at(now - MOTION_WINDOW_S)
        after = self.index_at(now + MOTION_WINDOW_S)
        return before, after

    def robot_moving(self, index: int) -> bool:
        before, after = self._around(index)
        span = self.times[after] - self.times[before]
        if span <= 0.0:
            return False
        moved = math.dist(self.samples[after].robot, self.samples[before].robot)
        return moved / span > ROBOT_MOVING_SPEED

    def situation(self, index: int, *, role: str, name: str) -> str:
        """The situation of person ``name`` at sample ``index`` (kept: a sample serves the
        increments of several periods)."""
        key = (index, role, name)
        if key not in self._situations:
            self._situations[key] = self._situation(index, role=role, name=name)
        return self._situations[key]

    def _situation(self, index: int, *, role: str, name: str) -> str:
        if role != "walker":
            return role
        before, after = self._around(index)
        here, there = self.samples[before].people.get(name), self.samples[after].people.get(name)
        span = self.times[after] - self.times[before]
        if here is not None and there is not None and span > 0.0 and math.dist(
                here[1:], there[1:]) / span > WALKING_SPEED:
            return "walker walking"
        return _standing(self, index, name)


def _standing(scene: _Scene, index: int, name: str) -> str:
    """The situation of walker ``name``, standing at sample ``index``: whom its lane holds."""
    sample = scene.samples[index]
    where = sample.people.get(name)
    facing = scene.facing(index, name) if where is not None else None
    if where is None or facing is None:
        return "walker standing"
    _role, x, y = where
    holders = [("the robot", sample.robot)] + [
        ("the guest" if role == "guest" else "someone else", (px, py))
        for other, (role, px, py) in sample.people.items() if other != name]
    held_by = {who for who, point in holders if _in_lane(point, (x, y), facing)}
    for who in ("the robot", "the guest", "someone else"):
        if who in held_by:
            return f"walker standing for {who}"
    return "walker standing"


def _facings(scene: _Scene, name: str) -> list[tuple[float, float] | None]:
    """For each sample, the unit vector of walker ``name``'s latest step of
    :data:`HEADING_STEP` or more up to it (None before its first, or where it is absent)."""
    facings: list[tuple[float, float] | None] = []
    anchor: tuple[float, float] | None = None
    facing: tuple[float, float] | None = None
    for sample in scene.samples:
        where = sample.people.get(name)
        if where is None:
            facings.append(None)
            continue
        here = (where[1], where[2])
        if anchor is None:
            anchor = here
        step = math.dist(here, anchor)
        if step >= HEADING_STEP:
            facing = ((here[0] - anchor[0]) / step, (here[1] - anchor[1]) / step)
            anchor = here
        facings.append(facing)
    return facings


def _in_lane(point: tuple[float, float], walker: tuple[float, float],
             facing: tuple[float, float]) -> bool:
    """Whether ``point`` stands in the lane of a walker at ``walker`` facing ``facing``."""
    dx, dy = point[0] - walker[0], point[1] - walker[1]
    ahead = dx * facing[0] + dy * facing[1]
    across = abs(dy * facing[0] - dx * facing[1])
    return ahead > 0.0 and math.hypot(dx, dy) <= PEOPLE_LANE_LENGTH and (
        across <= PEOPLE_LANE_HALF_WIDTH)
