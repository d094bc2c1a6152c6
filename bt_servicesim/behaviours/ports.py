"""Port declarations that several behaviours share, so each blackboard entry is described once."""

from __future__ import annotations

from py_trees.ports import PortInformation

from bt_servicesim.behaviours.node import Ports
from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import Costmap2D

GUEST_IN_RANGE_INPUTS: Ports = {
    "guest_name": PortInformation(data_type=str, required=True),
    "actors_in_range": PortInformation(data_type=list[str], required=True),
}
"""The guest's name and who RFID hears now: what every check on the guest reads."""

BOX = PortInformation(data_type=Box, description="a RoomInfo target area")
OCCUPANCY = PortInformation(data_type=OccupancyGrid2D, description="the map")
ROBOT_POSE = PortInformation(data_type=Pose2D, description="the robot's pose")
GOAL_OUT = PortInformation(data_type=Pose2D, required=False)
WAYPOINTS_OUT = PortInformation(data_type=list[Pose2D], required=False)
COSTMAP = PortInformation(data_type=Costmap2D, required=False,
                          description="navigation's costmap, where people stand")
GUEST_FOLLOWS = PortInformation(data_type=bool, required=False, default_value=False,
                                description="whether a guest follows the robot")
