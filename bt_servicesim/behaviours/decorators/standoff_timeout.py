"""Fail a child (a navigation) once the robot has stood too long where it holds someone up.

A walker stops while anyone stands in its lane and waits as long as it stays blocked (the
original's ``TrajectoryActorPlugin``). Navigation that meets a walker head on in a corridor
stops short of them, waits and replans; with no way round it keeps trying until its own limit
(20 s without progress in our simulator's navigation, as in the servicebot's move_base) and only
then fails, while both stand face to face inside the referee's approximation zone. This
decorator stops the navigation much sooner: once the robot has stood ``seconds`` with someone
within a lane's length (a standoff: the costmap shows them; the guest in tow is left out), it
fails, and the mission's recovery gives way
(:class:`~bt_servicesim.behaviours.actions.goals.GiveWaySpot`). A robot that stands with nobody
near (waiting for a way to clear, turning in place) is left to its navigation.

Standing is measured in sim time from the robot's pose
(:class:`~bt_servicesim.planning.give_way.Standstill`), from the goal's start: a robot that
stood before its goal began is not taken for one held up on this goal, and one that turns to
set off (beside the guest it has just dropped off) starts counting again; one that neither
moves nor turns is held up from the start (someone stands where it must go).
"""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.ports import NoDataAvailable, PortsMixin
from rclpy.clock import Clock

from bt_servicesim.behaviours.conditions.people_held_up import PeopleHeldUp, held_up_near
from bt_servicesim.behaviours.node import Ports
from bt_servicesim.planning.give_way import HOLD_UP_REACH, Standstill
from bt_servicesim.ros.sim_clock import clock_from_setup_kwargs, sim_now_s

__all__ = ["StandoffTimeout"]

Status = py_trees.common.Status


class StandoffTimeout(PortsMixin, py_trees.decorators.Decorator):
    """FAILURE, stopping the child, once the robot has stood ``seconds`` sim seconds with
    someone within ``reach`` of it (see the module docstring); until then the child's status
    passes through. Without a pose, a map or a costmap on the blackboard it only passes through.

    Args:
        name: the decorator's name
        child: the decorated behaviour, a navigation
        seconds: sim seconds of standing beside someone before the child is stopped
        reach: metres from the robot within which someone may have it in their lane
    """

    INPUT_PORTS: Ports = dict(PeopleHeldUp.INPUT_PORTS)
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, seconds: float = 4.0,
                 reach: float = HOLD_UP_REACH, **kwargs: Any) -> None:
        super().__init__(name=name, child=child, **kwargs)
        self.seconds = float(seconds)
        self.reach = float(reach)
        self._standstill = Standstill()
        self._clock: Clock | None = None

    def setup(self, **kwargs: Any) -> None:
        """Take the clock from ``kwargs["node"]``."""
        self._clock = clock_from_setup_kwargs(self.name, kwargs)

    def initialise(self) -> None:
        """Start counting afresh."""
        if self._clock is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        self._standstill.forget()
        self.feedback_message = "watching for a standoff"

    def update(self) -> Status:
        """Pass the child's status through, unless the robot stands holding someone up."""
        status = self.decorated.status
        if status != Status.RUNNING:
            self.feedback_message = f"child finished: {status.value}"
            return status
        stood = self._stood()
        if stood < self.seconds:
            self.feedback_message = f"stood {stood:.1f}/{self.seconds:.1f} sim s"
            return Status.RUNNING
        held_up, why = self._held_up()
        self.feedback_message = f"stood {stood:.1f} sim s: {why}"
        return Status.FAILURE if held_up else Status.RUNNING

    def _held_up(self) -> tuple[bool, str]:
        """Whether the costmap shows someone the robot may hold up, and why."""
        return held_up_near(self, reach=self.reach)

    def _stood(self) -> float:
        """Sim seconds the robot has stood, zero without its pose or a running clock."""
        assert self._clock is not None
        now = sim_now_s(self._clock)
        try:
            robot = self.get_input("robot_pose")
        except NoDataAvailable:
            return 0.0
        return self._standstill.stood(robot.x, robot.y, robot.yaw, now) if now > 0.0 else 0.0

    def terminate(self, new_status: Status) -> None:
        """Note an interruption; Decorator.stop() stops the child."""
        if new_status == Status.INVALID:
            self.feedback_message = "standoff watch interrupted"
