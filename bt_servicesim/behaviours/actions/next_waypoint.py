"""Hand out a list of waypoints one at a time, to drive a visiting loop."""

from __future__ import annotations

from typing import Any

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.actions.goals import describe
from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.behaviours.ports import GOAL_OUT
from bt_servicesim.planning.geometry import Pose2D


class NextWaypoint(ActionNode):
    """Each tick, the next of ``waypoints`` to ``goal``; FAILURE once the list is exhausted.

    A new list object on the blackboard starts again from its first waypoint.
    """

    INPUT_PORTS: Ports = {"waypoints": PortInformation(data_type=list[Pose2D])}
    OUTPUT_PORTS: Ports = {"goal": GOAL_OUT}

    def __init__(self, name: str = "NextWaypoint", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self._waypoints: list[Pose2D] | None = None
        self._next = 0

    def update(self) -> Status:
        try:
            waypoints = self.get_input("waypoints")
        except (NoDataAvailable, TypeError):
            self.feedback_message = "no list of waypoints on the blackboard"
            return Status.FAILURE
        if waypoints is not self._waypoints:
            self._waypoints, self._next = waypoints, 0
        if self._next >= len(waypoints):
            self.feedback_message = f"all {len(waypoints)} waypoints visited"
            return Status.FAILURE
        goal = waypoints[self._next]
        self._next += 1
        self._set_output("goal", goal)
        self.feedback_message = f"waypoint {self._next}/{len(waypoints)} {describe(goal)}"
        return Status.SUCCESS
