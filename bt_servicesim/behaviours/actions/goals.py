"""Actions that compute where the robot goes next.

Thin wrappers over :mod:`bt_servicesim.planning.goals`.

Each reads its input ports, calls one planning function in ``update`` -- pure and
non-blocking; on the 1200x1200 office map the heaviest, :class:`DropOffGoal` and
:class:`ExplorationWaypoints`, take about 40 ms, the others a few milliseconds -- and writes its
one output port: SUCCESS with the result, or FAILURE with a feedback message naming the missing
input or why no goal exists.
"""

from __future__ import annotations

import random
import zlib
from typing import Any

import numpy as np
import py_trees
from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.behaviours.ports import (
    BOX,
    COSTMAP,
    GOAL_OUT,
    GUEST_FOLLOWS,
    OCCUPANCY,
    ROBOT_POSE,
    WAYPOINTS_OUT,
)
from bt_servicesim.planning.entrances import doorways_near
from bt_servicesim.planning.exploration import exploration_waypoints, guest_search_waypoints
from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.planning.give_way import (
    MAX_ROUTE,
    PEOPLE_REACH,
    give_way_spot,
    recent_trail,
    without_the_guest,
)
from bt_servicesim.planning.goals import (
    TrailingPlan,
    drop_off_goal,
    drop_off_reposition_goal,
    jitter_goal,
    pickup_goal,
    return_goal,
)
from bt_servicesim.planning.guest_localisation import RfidHistory
from bt_servicesim.planning.near_spot import near_spot
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import Costmap2D, people_on_costmap


class _Computation(ActionNode, register=False):
    """Read every input port, compute, write the one output port.

    FAILURE with a feedback message if a required input is missing or an input is of the wrong
    type, if a box is empty, or if :meth:`compute` finds nothing (it returns None and sets the
    message). An optional input without data (and without a default) is passed as None.
    """

    INPUT_PORTS: Ports = {}
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def update(self) -> Status:
        inputs = self._read_inputs()
        if inputs is None:
            return Status.FAILURE
        result = self.compute(**inputs)
        if result is None:
            return Status.FAILURE
        (output,) = self.OUTPUT_PORTS
        self._set_output(output, result)
        return Status.SUCCESS

    def compute(self, *args: Any, **inputs: Any) -> Any:
        """The output for the inputs (by port name); None, with a feedback message, if none.

        Each subclass names its inputs as parameters: ``*args`` lets it do so (it is called with
        keyword arguments only)."""
        raise NotImplementedError

    def _read_inputs(self) -> dict[str, Any] | None:
        inputs = {}
        for port in self.INPUT_PORTS:
            try:
                inputs[port] = self.get_input(port)
            except NoDataAvailable:
                if not self.INPUT_PORTS[port].required:  # optional: the computation does without
                    inputs[port] = None
                    continue
                self.feedback_message = f"no {port} on the blackboard"
                return None
            except TypeError:
                self.feedback_message = f"{port} is not a {self.INPUT_PORTS[port].data_type}"
                return None
        if isinstance(inputs.get("box"), Box) and inputs["box"].is_empty:
            self.feedback_message = f"the box {inputs['box']} is empty"
            return None
        return inputs


def describe(pose: Pose2D) -> str:
    return f"({pose.x:.2f}, {pose.y:.2f}, yaw {pose.yaw:.2f})"


class PickupGoal(_Computation):
    """The pick-up goal: inside the box, nearest the guest's spawn area, clear of the people
    navigation's costmap shows standing near the box (:func:`pickup_goal`). Without a costmap
    it is planned without people."""

    INPUT_PORTS: Ports = {"box": BOX, "occupancy": OCCUPANCY, "robot_pose": ROBOT_POSE,
                          "costmap": COSTMAP}
    OUTPUT_PORTS: Ports = {"goal": GOAL_OUT}

    def __init__(self, name: str = "PickupGoal", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def compute(self, box: Box, occupancy: OccupancyGrid2D, robot_pose: Pose2D,
                costmap: Costmap2D | None) -> Pose2D | None:
        people = None
        if costmap is not None:
            centre_x, centre_y = box.centre
            people = people_on_costmap(costmap, occupancy, x=centre_x, y=centre_y,
                                       reach=PEOPLE_REACH)
        goal = pickup_goal(box, occupancy, robot_pose, people=people)
        self.feedback_message = (f"pick-up goal {describe(goal)}" if goal is not None
                                 else "no reachable free spot inside the pick-up box")
        if people is not None:
            self.feedback_message += f" ({_seen(people)})"
        return goal


class DropOffGoal(_Computation):
    """The drop-off goal that leaves the trailing guest in the box (:func:`drop_off_goal`),
    clear of the doorways near the box (:func:`doorways_near`) and of the people navigation's
    costmap shows standing near the box (:func:`people_on_costmap`), the guest in tow left out
    (:func:`without_the_guest`, from the robot's trail in the RFID history). Without a costmap
    or a history it is planned without people."""

    INPUT_PORTS: Ports = {
        "box": BOX,
        "occupancy": OCCUPANCY,
        "robot_pose": ROBOT_POSE,
        "costmap": COSTMAP,
        "rfid_history": PortInformation(data_type=RfidHistory, required=False,
                                        description="where the robot was (its trail), to tell "
                                                    "the guest in tow from the others"),
    }
    OUTPUT_PORTS: Ports = {"goal": GOAL_OUT}

    def __init__(self, name: str = "DropOffGoal", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def compute(self, box: Box, occupancy: OccupancyGrid2D, robot_pose: Pose2D,
                costmap: Costmap2D | None, rfid_history: RfidHistory | None) -> Pose2D | None:
        doorways = doorways_near(occupancy, box)
        people = None
        if costmap is not None and rfid_history is not None:
            centre_x, centre_y = box.centre
            people = without_the_guest(
                people_on_costmap(costmap, occupancy, x=centre_x, y=centre_y, reach=PEOPLE_REACH),
                robot=robot_pose,
                trail=recent_trail([(reading.x, reading.y) for reading in rfid_history]))
        plan = drop_off_goal(box, occupancy, robot_pose, doorways=doorways, people=people)
        goal = _report_plan(self, plan, "drop-off goal", "no reachable drop-off goal")
        if people is not None:
            self.feedback_message += f" ({_seen(people)})"
        return goal


class DropOffRepositionGoal(_Computation):
    """After a refused drop-off, a move that pulls the guest deeper in
    (:func:`drop_off_reposition_goal`)."""

    INPUT_PORTS: Ports = {"box": BOX, "occupancy": OCCUPANCY, "robot_pose": ROBOT_POSE}
    OUTPUT_PORTS: Ports = {"goal": GOAL_OUT}

    def __init__(self, name: str = "DropOffRepositionGoal", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def compute(self, box: Box, occupancy: OccupancyGrid2D, robot_pose: Pose2D) -> Pose2D | None:
        plan = drop_off_reposition_goal(box, occupancy, robot_pose)
        return _report_plan(self, plan, "reposition goal", "no free way to reposition")


def _report_plan(
    behaviour: py_trees.behaviour.Behaviour, plan: TrailingPlan | None, what: str, none: str
) -> Pose2D | None:
    if plan is None:
        behaviour.feedback_message = none
        return None
    spot = plan.guest_spot
    behaviour.feedback_message = (f"{what} {describe(plan.goal)}, guest to stop at "
                                  f"({spot[0]:.2f}, {spot[1]:.2f}), margin {plan.margin:.2f} m")
    return plan.goal


class ReturnGoal(_Computation):
    """The start pose itself, snapped to free space if need be (:func:`return_goal`)."""

    INPUT_PORTS: Ports = {
        "start_pose": PortInformation(data_type=Pose2D, description="from the referee"),
        "occupancy": OCCUPANCY,
    }
    OUTPUT_PORTS: Ports = {"goal": GOAL_OUT}

    def __init__(self, name: str = "ReturnGoal", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def compute(self, start_pose: Pose2D, occupancy: OccupancyGrid2D) -> Pose2D | None:
        goal = return_goal(start_pose, occupancy)
        self.feedback_message = (f"return goal {describe(goal)}" if goal is not None
                                 else f"no free spot for the robot near {describe(start_pose)}")
        return goal


class JitterGoal(_Computation):
    """The goal moved by a small random offset onto free space (:func:`jitter_goal`).

    Args:
        name: the behaviour's name
        seed: the random seed; by default derived from the name and the run's seed (given to
            ``setup`` as ``run_seed``), so that a run repeats and another seed jitters anew
    """

    INPUT_PORTS: Ports = {"goal": PortInformation(data_type=Pose2D),
                                    "occupancy": OCCUPANCY}
    OUTPUT_PORTS: Ports = {"jittered": GOAL_OUT}

    def __init__(self, name: str = "JitterGoal", seed: int | None = None, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self._seed_given = seed is not None
        self.seed = zlib.crc32(name.encode()) if seed is None else int(seed)
        self.rng = random.Random(self.seed)

    def setup(self, **kwargs: Any) -> None:
        super().setup(**kwargs)
        run_seed = kwargs.get("run_seed")
        if run_seed is not None and not self._seed_given:
            self.seed = zlib.crc32(f"{self.name}:{int(run_seed)}".encode())
            self.rng = random.Random(self.seed)

    def compute(self, goal: Pose2D, occupancy: OccupancyGrid2D) -> Pose2D:
        jittered = jitter_goal(goal, occupancy, self.rng)
        self.feedback_message = (f"jittered goal {describe(jittered)}" if jittered != goal
                                 else f"no free spot near {describe(goal)}: goal unchanged")
        return jittered


class GiveWaySpot(_Computation):
    """Where to wait while people the robot cannot pass go by (:func:`give_way_spot`).

    The robot's trail comes from the RFID history, which keeps where the robot was at each
    reading (the last two minutes). With ``guest_follows`` the spot leaves room for the guest
    in tow, who stops short of it. The people standing near come from navigation's costmap
    (:func:`people_on_costmap`), the guest in tow left out (:func:`without_the_guest`): the
    spot keeps clear of them; without a costmap it is found without.

    Args:
        name: the behaviour's name
        max_route: metres of route within which the spot is looked for
    """

    INPUT_PORTS: Ports = {
        "robot_pose": ROBOT_POSE,
        "occupancy": OCCUPANCY,
        "rfid_history": PortInformation(data_type=RfidHistory,
                                        description="where the robot was, reading by reading"),
        "guest_follows": GUEST_FOLLOWS,
        "costmap": COSTMAP,
    }
    OUTPUT_PORTS: Ports = {"spot": GOAL_OUT}

    def __init__(self, name: str = "GiveWaySpot", max_route: float = MAX_ROUTE,
                 **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.max_route = float(max_route)

    def compute(self, robot_pose: Pose2D, occupancy: OccupancyGrid2D,
                rfid_history: RfidHistory, guest_follows: bool,
                costmap: Costmap2D | None) -> Pose2D | None:
        trail = recent_trail([(reading.x, reading.y) for reading in rfid_history])
        people = None
        if costmap is not None:
            people = people_on_costmap(costmap, occupancy, x=robot_pose.x, y=robot_pose.y,
                                       reach=PEOPLE_REACH)
            if guest_follows:
                people = without_the_guest(people, robot=robot_pose, trail=trail)
        spot = give_way_spot(occupancy, robot=robot_pose, trail=trail,
                             guest_follows=guest_follows, people=people,
                             max_route=self.max_route)
        self.feedback_message = (f"give way at {describe(spot)}" if spot is not None
                                 else "no spot to give way at") + f" ({_seen(people)})"
        return spot


def _seen(people: np.ndarray | None) -> str:
    """Who the costmap showed near, for a feedback message."""
    if people is None:
        return "no costmap"
    if not len(people):
        return "nobody near"
    shown = ", ".join(f"({x:.1f}, {y:.1f})" for x, y in people[:4])
    return f"{len(people)} people near: {shown}" + (", ..." if len(people) > 4 else "")


class NearestReachableSpot(_Computation):
    """The spot nearest a waypoint navigation could not reach that the robot reaches now, with
    the people the costmap shows standing as obstacles, clear of them (:func:`near_spot`);
    within RFID range of the waypoint, so it hears most of what the waypoint would have."""

    INPUT_PORTS: Ports = {
        "target": PortInformation(data_type=Pose2D, description="the waypoint not reached"),
        "robot_pose": ROBOT_POSE,
        "occupancy": OCCUPANCY,
        "costmap": COSTMAP,
    }
    OUTPUT_PORTS: Ports = {"spot": GOAL_OUT}

    def __init__(self, name: str = "NearestReachableSpot", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def compute(self, target: Pose2D, robot_pose: Pose2D, occupancy: OccupancyGrid2D,
                costmap: Costmap2D | None) -> Pose2D | None:
        people = None if costmap is None else people_on_costmap(
            costmap, occupancy, x=robot_pose.x, y=robot_pose.y, reach=PEOPLE_REACH)
        spot = near_spot(occupancy, robot=robot_pose, target=(target.x, target.y), people=people)
        self.feedback_message = (f"nearest reachable spot {describe(spot)}" if spot is not None
                                 else f"nothing reachable near {describe(target)}"
                                 ) + f" ({_seen(people)})"
        return spot


class ExplorationWaypoints(_Computation):
    """Waypoints covering the box and its surroundings (:func:`exploration_waypoints`)."""

    INPUT_PORTS: Ports = {"box": BOX, "occupancy": OCCUPANCY, "robot_pose": ROBOT_POSE}
    OUTPUT_PORTS: Ports = {"waypoints": WAYPOINTS_OUT}

    def __init__(self, name: str = "ExplorationWaypoints", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def compute(
        self, box: Box, occupancy: OccupancyGrid2D, robot_pose: Pose2D
    ) -> list[Pose2D] | None:
        waypoints = exploration_waypoints(box, occupancy, robot_pose)
        self.feedback_message = (f"{len(waypoints)} exploration waypoints" if waypoints
                                 else "nothing reachable near the box to explore")
        return waypoints or None


class GuestSearchWaypoints(_Computation):
    """The last-seen spot, then rings around it (:func:`guest_search_waypoints`)."""

    INPUT_PORTS: Ports = {
        "guest_last_seen": PortInformation(data_type=Pose2D, description="robot pose then"),
        "occupancy": OCCUPANCY,
        "robot_pose": ROBOT_POSE,
    }
    OUTPUT_PORTS: Ports = {"waypoints": WAYPOINTS_OUT}

    def __init__(self, name: str = "GuestSearchWaypoints", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def compute(
        self, guest_last_seen: Pose2D, occupancy: OccupancyGrid2D, robot_pose: Pose2D
    ) -> list[Pose2D] | None:
        waypoints = guest_search_waypoints(guest_last_seen, occupancy, robot_pose)
        self.feedback_message = (f"{len(waypoints)} search waypoints around "
                                 f"{describe(guest_last_seen)}" if waypoints
                                 else "nothing reachable near where the guest was last seen")
        return waypoints or None
