"""Would the robot, standing here, hold someone up? A condition on the costmap's people.

A walker stops while anyone stands in its lane (1.5 m ahead, 0.6 m either side) and waits as
long as it stays blocked (the original's ``TrajectoryActorPlugin``). A robot that stands still
of its own accord, to look round for a lost guest, in front of a walker that has stopped for it
holds them there for the whole look, and the referee books every second of it. The robot cannot
see which way a person faces, nor tell from one costmap whether they stand or walk: it sees
where they are (:func:`~bt_servicesim.planning.people.people_on_costmap`). So this asks whether
anyone stands near enough to have the robot in their lane
(:func:`~bt_servicesim.planning.give_way.people_held_up`); the mission then steps to a spot
off the lanes, clear of them, before it stands
(:class:`~bt_servicesim.behaviours.actions.goals.GiveWaySpot`).
"""

from __future__ import annotations

from typing import Any

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ConditionNode, Ports
from bt_servicesim.behaviours.ports import OCCUPANCY, ROBOT_POSE
from bt_servicesim.planning.give_way import HOLD_UP_REACH, people_held_up
from bt_servicesim.planning.people import Costmap2D, people_on_costmap

__all__ = ["PeopleHeldUp"]


class PeopleHeldUp(ConditionNode):
    """SUCCESS when the costmap shows someone within ``reach`` of the robot, else FAILURE (also
    without a costmap: the robot then knows of nobody).

    Args:
        name: the behaviour's name
        reach: metres from the robot within which someone may have it in their lane
    """

    INPUT_PORTS: Ports = {
        "robot_pose": ROBOT_POSE,
        "occupancy": OCCUPANCY,
        "costmap": PortInformation(data_type=Costmap2D, required=False,
                                   description="navigation's costmap, where people stand"),
    }
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str = "PeopleHeldUp", reach: float = HOLD_UP_REACH,
                 **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.reach = float(reach)

    def check(self) -> bool:
        """Find the people on the costmap near the robot."""
        try:
            robot = self.get_input("robot_pose")
            occupancy = self.get_input("occupancy")
        except NoDataAvailable as error:
            self.feedback_message = f"cannot look for people: {error}"
            return False
        try:
            costmap = self.get_input("costmap")
        except NoDataAvailable:
            self.feedback_message = "no costmap: nobody seen"
            return False
        people = people_on_costmap(costmap, occupancy, x=robot.x, y=robot.y, reach=self.reach)
        near = people_held_up(people, robot=robot, reach=self.reach)
        if not len(near):
            self.feedback_message = f"nobody within {self.reach:.1f} m"
            return False
        shown = ", ".join(f"({x:.1f}, {y:.1f})" for x, y in near[:4])
        self.feedback_message = f"{len(near)} people within {self.reach:.1f} m: {shown}"
        return True
