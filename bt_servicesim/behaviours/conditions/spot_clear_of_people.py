"""Is a spot clear of people? A condition on a goal and navigation's costmap.

A search goes from waypoint to waypoint, standing at each as long as it takes to turn to the
next. Waypoints are laid out over the floor before anyone is seen, so one can fall where an idler
stands, or where a walker has stopped: navigation then takes the robot as near as it may, and
the robot stands there, inside the referee's ghost cylinder, booked for every moment it stays.
A drop-off goal is planned clear of the people the costmap shows, but the robot sees the room
only as it comes near: two walkers who wait for each other for good can stand on it. A robot
that sees someone standing on its next spot goes elsewhere instead: for a waypoint, the
nearest spot clear of them
(:class:`~bt_servicesim.behaviours.actions.goals.NearestReachableSpot`), which hears through
RFID nearly all the waypoint would have; for a drop-off, a goal planned again with them seen.

"Beside" is the referee's reach: the ghost cylinder for people (0.75 m) and a person's body,
:data:`~bt_servicesim.planning.near_spot.NEAR_PEOPLE_KEEP`, the same distance the near spot
keeps. The costmap is how the robot knows of people
(:func:`~bt_servicesim.planning.people.people_within`): someone it has not seen is nobody. A
guest in tow, who stops behind the robot as it arrives, is nobody either
(:func:`~bt_servicesim.planning.give_way.guest_in_tow`, told from the robot's trail).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ConditionNode, Ports
from bt_servicesim.behaviours.ports import COSTMAP, GUEST_FOLLOWS, OCCUPANCY
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.give_way import PEOPLE_REACH, guest_in_tow, recent_trail
from bt_servicesim.planning.guest_localisation import RfidHistory
from bt_servicesim.planning.near_spot import NEAR_PEOPLE_KEEP
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import Costmap2D, people_on_costmap, people_within

__all__ = ["SAME_PERSON", "SpotClearOfPeople"]

SAME_PERSON = 0.3
"""Metres within which two disc centres found on one costmap are the same person."""


class SpotClearOfPeople(ConditionNode):
    """SUCCESS when the costmap shows nobody within ``keep`` metres of ``spot``, else FAILURE.
    Without a costmap the robot knows of nobody: SUCCESS. Without a spot: FAILURE, saying so.
    With ``guest_follows``, the guest in tow (told from ``robot_pose`` and the trail in
    ``rfid_history``) is left out.

    Args:
        name: the behaviour's name
        keep: metres from the spot within which someone makes it a spot beside them
    """

    INPUT_PORTS: Ports = {
        "spot": PortInformation(data_type=Pose2D, required=True,
                                description="where the robot is to stand"),
        "occupancy": OCCUPANCY,
        "costmap": COSTMAP,
        "guest_follows": GUEST_FOLLOWS,
        "robot_pose": PortInformation(data_type=Pose2D, required=False,
                                      description="the robot's pose, needed when a guest "
                                                  "follows"),
        "rfid_history": PortInformation(data_type=RfidHistory, required=False,
                                        description="where the robot was (its trail), needed "
                                                    "when a guest follows"),
    }
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str = "SpotClearOfPeople", keep: float = NEAR_PEOPLE_KEEP,
                 **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.keep = float(keep)

    def check(self) -> bool:
        """Look for people on the costmap near the spot."""
        try:
            spot: Pose2D = self.get_input("spot")
            occupancy: OccupancyGrid2D = self.get_input("occupancy")
        except NoDataAvailable as error:
            self.feedback_message = f"cannot check the spot: {error}"
            return False
        try:
            costmap: Costmap2D = self.get_input("costmap")
        except NoDataAvailable:
            self.feedback_message = "no costmap: nobody seen"
            return True
        people = people_within(costmap, occupancy, x=spot.x, y=spot.y, radius=self.keep)
        if len(people) and self.get_input("guest_follows"):
            people = self._without_the_guest(people, costmap, occupancy)
        where = f"{self.keep:.1f} m of ({spot.x:.1f}, {spot.y:.1f})"
        if len(people) == 0:
            self.feedback_message = f"nobody within {where}"
            return True
        shown = ", ".join(f"({px:.1f}, {py:.1f})" for px, py in people)
        self.feedback_message = f"{len(people)} people within {where}: {shown}"
        return False

    def _without_the_guest(self, people: np.ndarray, costmap: Costmap2D,
                           occupancy: OccupancyGrid2D) -> np.ndarray:
        """``people`` less whoever stands where the guest in tow does."""
        try:
            robot: Pose2D = self.get_input("robot_pose")
            history: RfidHistory = self.get_input("rfid_history")
        except NoDataAvailable:
            return people
        near_robot = people_on_costmap(costmap, occupancy, x=robot.x, y=robot.y,
                                       reach=PEOPLE_REACH)
        trail = recent_trail([(reading.x, reading.y) for reading in history])
        guest = guest_in_tow(near_robot, robot=robot, trail=trail)
        if guest is None:
            return people
        gx, gy = near_robot[guest]
        others: np.ndarray = people[np.hypot(people[:, 0] - gx, people[:, 1] - gy) > SAME_PERSON]
        return others
