"""Estimate where the guest stands from the RFID history and place a goal close to them.

A thin wrapper over :func:`~bt_servicesim.planning.guest_localisation.estimate_guest`,
:func:`~bt_servicesim.planning.guest_localisation.locate_bystanders` and
:func:`~bt_servicesim.planning.guest_localisation.approach_goal`: the guest is picked out of
the RFID lists by name, and the goal keeps clear of the others the lists name.
"""

from __future__ import annotations

from typing import Any

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.planning.geometry import Box, Point, Pose2D
from bt_servicesim.planning.guest_localisation import (
    SIGHTING_GAP,
    RfidHistory,
    approach_goal,
    estimate_guest,
    locate_bystanders,
)
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.ros.sim_clock import clock_from_setup_kwargs, sim_now_s


class GuestApproachGoal(ActionNode):
    """Estimate where the guest stands and write a goal close to them (``goal``).

    SUCCESS with the goal; FAILURE if the guest has not been heard lately, no approach spot is
    reachable, or the robot is already close enough — then the mission asks for the guest from
    where it stands.
    """

    INPUT_PORTS: Ports = {
        "guest_name": PortInformation(data_type=str, required=True),
        "rfid_history": PortInformation(data_type=RfidHistory, required=True),
        "occupancy": PortInformation(data_type=OccupancyGrid2D, required=True),
        "robot_pose": PortInformation(data_type=Pose2D, required=True),
        "sighting_gap": PortInformation(
            data_type=float, required=False,
            description="sim s of pause that ends a run of sightings (long: a waiting guest)"),
        "leave_towards": PortInformation(
            data_type=Box, required=False,
            description="the area the guest is to be led to: stand on their side towards it"),
    }
    OUTPUT_PORTS: Ports = {
        "goal": PortInformation(data_type=Pose2D, required=False),
    }

    def __init__(self, name: str = "GuestApproachGoal", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self._clock: Any = None

    def setup(self, **kwargs: Any) -> None:
        """Take the clock from ``kwargs["node"]``."""
        self._clock = clock_from_setup_kwargs(self.name, kwargs)

    def update(self) -> Status:
        """Estimate, then place the goal."""
        try:
            guest, history = self.get_input("guest_name"), self.get_input("rfid_history")
            grid, robot = self.get_input("occupancy"), self.get_input("robot_pose")
        except (NoDataAvailable, TypeError) as error:
            self.feedback_message = f"cannot estimate the guest's position: {error}"
            return Status.FAILURE
        now = sim_now_s(self._clock)
        estimate = estimate_guest(history, guest, grid, now, self._sighting_gap())
        if estimate is None:
            self.feedback_message = f"{guest} not heard lately: no estimate"
            return Status.FAILURE
        others = locate_bystanders(history, guest, grid, now)
        goal = approach_goal(estimate, grid, robot, leave_towards=self._leave_towards(),
                             bystanders=others)
        where = f"{guest} near ({estimate.x:.2f}, {estimate.y:.2f}), {len(others)} others near"
        if goal is None:
            self.feedback_message = f"{where}: already close, or no reachable spot near"
            return Status.FAILURE
        self._set_output("goal", goal)
        self.feedback_message = f"{where}: approach ({goal.x:.2f}, {goal.y:.2f})"
        return Status.SUCCESS

    def _leave_towards(self) -> Point | None:
        try:
            box = self.get_input("leave_towards")
        except (NoDataAvailable, TypeError):
            return None
        return box.centre if isinstance(box, Box) else None

    def _sighting_gap(self) -> float:
        try:
            return float(self.get_input("sighting_gap"))
        except (NoDataAvailable, TypeError, ValueError):
            return SIGHTING_GAP
