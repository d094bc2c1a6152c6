"""Contact and approximation, booked every physics step as the original's ``PenaltyChecker``
takes them, with no ROS in it.

Approximation: the depth of a ghost cylinder centred on the robot's base (0.75 m for people,
0.35 m for objects) into each person's body and into the nearest wall. Contact: the depth of
the robot's 0.4 x 0.5 m body into each person's body and into walls and furniture, as
:mod:`servicesim_sim.world.footprint` measures them. Both are booked from the start of the world,
by cause (``ROLE/NAME`` for a person), in the referee's books.

Design intent: most steps nobody is near, so :class:`PenaltyChecker` looks at the people again
only once the nearest of them could have closed the gap at :data:`CLOSING_SPEED_BOUND`.
"""

from __future__ import annotations

import math

import numpy as np

from servicesim_sim.model.guest import Guest
from servicesim_sim.model.people import Crowd
from servicesim_sim.model.referee import Referee
from servicesim_sim.model.robot import Robot

__all__ = ["CLOSING_SPEED_BOUND", "OBJECT_APPROXIMATION_M", "PERSON_APPROXIMATION_M",
           "PERSON_BODY_RADIUS", "PenaltyChecker"]

PERSON_BODY_RADIUS = 0.25  # a person's collision box (0.44 x 0.60 m) as a disc
PERSON_APPROXIMATION_M = 0.75  # ghost cylinder radius, centred on the base (servicebot.urdf)
OBJECT_APPROXIMATION_M = 0.35  # ghost cylinder radius, centred on the base (servicebot.urdf)
CLOSING_SPEED_BOUND = 3.0  # m/s, with a margin: walkers 1.2 at most, the robot 0.5
APPROACH_REACH_M = PERSON_APPROXIMATION_M + PERSON_BODY_RADIUS
"""How far from the robot's origin a person's origin reaches its people's ghost cylinder (and
farther than its box reaches, 0.32 m, and a body's 0.25 m)."""
APPROACH_REACH_SQUARED = APPROACH_REACH_M * APPROACH_REACH_M * (1.0 + 1e-9)
"""Its square, with a margin over the rounding of squares against ``np.hypot``."""


class PenaltyChecker:
    """Books ``robot``'s contact and approximation with ``crowd``, ``guest`` and the walls into
    ``referee``."""

    def __init__(self, *, robot: Robot, guest: Guest, crowd: Crowd, referee: Referee) -> None:
        self.robot, self.guest, self.crowd, self.referee = robot, guest, crowd, referee
        self._nobody_near_until = -math.inf
        self._causes: list[str] = []

    def book(self, dt: float, *, now: float) -> None:
        """The step of ``dt`` sim seconds ending at sim time ``now``."""
        robot = self.robot
        clearance = robot.walls.at(robot.x, robot.y)  # centre to nearest wall
        if (clearance >= OBJECT_APPROXIMATION_M and robot.wall_depth == 0.0
                and not self._anyone_may_be_near(now)):
            return  # nobody and nothing near: the common case, nothing to book
        touching, approach = self._person_depths()
        causes = self._person_causes()
        # np.add.reduce is what ndarray.sum runs (the same pairwise sum), without its wrapper
        self.referee.contact(person_depth=float(np.add.reduce(touching, axis=None)),
                             object_depth=robot.wall_depth, dt=dt,
                             people=list(zip(causes, touching.tolist(), strict=True)))
        self.referee.approximation(
            person_depth=float(np.add.reduce(approach, axis=None)),
            object_depth=min(OBJECT_APPROXIMATION_M, max(0.0, OBJECT_APPROXIMATION_M - clearance)),
            dt=dt, people=list(zip(causes, approach.tolist(), strict=True)))

    def _person_depths(self) -> tuple[np.ndarray, np.ndarray]:
        """How deep the robot's box reaches into each person's body, and its people's ghost
        cylinder, everyone in :meth:`_person_causes`' order (the guest last).

        Worked out, with numpy's element-wise arithmetic, for the people whose origin may lie
        within :data:`APPROACH_REACH_M` of the robot's; the rest reach neither, and are the
        0.0 that arithmetic makes them, so the sums over everyone are the same bit for bit.
        """
        robot = self.robot
        x, y = robot.x, robot.y
        near: list[int] = []
        near_xs: list[float] = []
        near_ys: list[float] = []
        places = [(person.x, person.y) for person in self.crowd.people]
        for index, (px, py) in enumerate([*places, (self.guest.x, self.guest.y)]):
            dx, dy = px - x, py - y
            if dx * dx + dy * dy <= APPROACH_REACH_SQUARED:
                near.append(index)
                near_xs.append(px)
                near_ys.append(py)
        count = len(self.crowd.people) + 1
        touching, approach = np.zeros(count), np.zeros(count)
        if near:
            xs, ys = np.array(near_xs), np.array(near_ys)
            # np.maximum and np.minimum, not np.clip: the same values (no NaN, and no -0.0
            # from a constant minus a distance), without np.clip's wrappers
            touching[near] = robot.footprint.person_depths(robot.pose, xs, ys,
                                                           radius=PERSON_BODY_RADIUS)
            distances = np.hypot(xs - x, ys - y)
            approach[near] = np.minimum(
                np.maximum(PERSON_APPROXIMATION_M + PERSON_BODY_RADIUS - distances, 0.0),
                PERSON_APPROXIMATION_M)
        return touching, approach

    def _person_causes(self) -> list[str]:
        """Each person's cause key for the referee's books by cause (``ROLE/NAME``), in
        :meth:`_person_depths`' order; worked out again only when the number of people
        changed (names and roles never do)."""
        if len(self._causes) != len(self.crowd.people) + 1:
            self._causes = [*(f"{person.role}/{person.name}" for person in self.crowd.people),
                            f"guest/{self.guest.name}"]
        return self._causes

    def _anyone_may_be_near(self, now: float) -> bool:
        """Whether someone's body may be within the people's ghost cylinder.

        When the nearest person is farther, nobody can come within it before the gap closes
        at :data:`CLOSING_SPEED_BOUND`, so the people need not be looked at again until then.
        """
        if now < self._nobody_near_until:
            return False
        gap = self._nearest_person_distance() - (PERSON_APPROXIMATION_M + PERSON_BODY_RADIUS)
        if gap < 0.0:
            return True
        self._nobody_near_until = now + gap / CLOSING_SPEED_BOUND
        return False

    def _nearest_person_distance(self) -> float:
        """Distance from the robot's origin to the nearest person's origin (plain floats:
        this runs every few steps)."""
        x, y = self.robot.x, self.robot.y
        dx, dy = self.guest.x - x, self.guest.y - y
        nearest = dx * dx + dy * dy
        for person in self.crowd.people:
            dx, dy = person.x - x, person.y - y
            square = dx * dx + dy * dy
            if square < nearest:
                nearest = square
        return math.sqrt(nearest)
