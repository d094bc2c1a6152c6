"""Would the robot, standing here, hold someone up? A condition on the costmap's people.

A walker stops while anyone stands in its lane (1.5 m ahead, 0.6 m either side) and waits as
long as it stays blocked (the original's ``TrajectoryActorPlugin``). A robot that stands still
of its own accord, to look round for a lost guest, in front of a walker that has stopped for it
holds them there for the whole look, and the referee books every second of it. The robot cannot
see which way a person faces, nor tell from one costmap whether they stand or walk: it sees
where they are (:func:`~bt_servicesim.planning.people.people_on_costmap`). So this asks whether
anyone stands near enough to have the robot in their lane
(:func:`~bt_servicesim.planning.give_way.held_up_on_costmap`); the mission then steps to a spot
off the lanes, clear of them, before it stands
(:class:`~bt_servicesim.behaviours.actions.goals.GiveWaySpot`). With a guest in tow, the guest
(who stops behind the robot of their own accord) is left out.
"""

from __future__ import annotations

from typing import Any, Protocol

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ConditionNode, Ports
from bt_servicesim.behaviours.ports import COSTMAP, GUEST_FOLLOWS, OCCUPANCY, ROBOT_POSE
from bt_servicesim.planning.give_way import HOLD_UP_REACH, held_up_on_costmap, recent_trail
from bt_servicesim.planning.guest_localisation import RfidHistory

__all__ = ["PeopleHeldUp", "held_up_near"]


class PeopleHeldUp(ConditionNode):
    """SUCCESS when the costmap shows someone within ``reach`` of the robot (the guest in tow
    left out), else FAILURE (also without a costmap: the robot then knows of nobody).

    Args:
        name: the behaviour's name
        reach: metres from the robot within which someone may have it in their lane
    """

    INPUT_PORTS: Ports = {
        "robot_pose": ROBOT_POSE,
        "occupancy": OCCUPANCY,
        "costmap": COSTMAP,
        "guest_follows": GUEST_FOLLOWS,
        "rfid_history": PortInformation(data_type=RfidHistory, required=False,
                                        description="where the robot was (its trail), needed "
                                                    "when a guest follows"),
    }
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str = "PeopleHeldUp", reach: float = HOLD_UP_REACH,
                 **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.reach = float(reach)

    def check(self) -> bool:
        """Find the people on the costmap near the robot."""
        held_up, self.feedback_message = held_up_near(self, reach=self.reach)
        return held_up


class _WithPorts(Protocol):
    def get_input(self, port_name: str, default: Any = None) -> Any: ...


def held_up_near(node: _WithPorts, *, reach: float) -> tuple[bool, str]:
    """Whether ``node``'s ports (``robot_pose``, ``occupancy``, ``costmap``, ``guest_follows``,
    ``rfid_history``) show someone the robot may hold up, and a sentence saying why."""
    try:
        robot = node.get_input("robot_pose")
        occupancy = node.get_input("occupancy")
    except NoDataAvailable as error:
        return False, f"cannot look for people: {error}"
    try:
        costmap = node.get_input("costmap")
    except NoDataAvailable:
        return False, "no costmap: nobody seen"
    trail = None
    if node.get_input("guest_follows"):
        try:
            history = node.get_input("rfid_history")
        except NoDataAvailable:
            history = []
        trail = recent_trail([(reading.x, reading.y) for reading in history])
    near = held_up_on_costmap(costmap, occupancy, robot=robot, trail=trail, reach=reach)
    if not len(near):
        return False, f"nobody within {reach:.1f} m"
    shown = ", ".join(f"({x:.1f}, {y:.1f})" for x, y in near[:4])
    return True, f"{len(near)} people within {reach:.1f} m: {shown}"
