"""The competition's services, scripted: :class:`FakeReferee`, answering the :class:`Task` it
is given (by default the guest :data:`~tests.fakes.guest.GUEST` at the front elevator) and the
boxes of :data:`ROOMS`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from nav2_msgs.action import NavigateToPose
from nav2_msgs.srv import ClearEntireCostmap
from servicesim_competition import srv
from std_srvs.srv import Empty

from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.ros.messages import pose_to_msg
from tests.fakes.guest import GUEST
from tests.fakes.servers import EventLog, FakeServer

ROOMS = {"FrontElevator": Box(-1.5, 0.0, 1.5, 2.7), "PublicCafe": Box(5.0, 6.0, 8.0, 9.0)}
START = Pose2D(10.975, 3.75, 3.14)


@dataclass(frozen=True)
class Task:
    """What the fake referee's NewTask answers."""

    pick_up: str = "FrontElevator"
    drop_off: str = "PublicCafe"
    guest: str = GUEST
    start: Pose2D = START


class FakeReferee(FakeServer):
    """The competition's services, scripted, under ``namespace``.

    NewTask (and TaskInfo, at ``/referee/task_info``) answer the task once; while a task runs
    (``task_running``) they give the error answer, everything empty. RoomInfo answers the box of
    a room in ``rooms`` and the zero box for any other. A pick-up works for the robot
    ``servicebot`` while ``pickup_ok``; a drop-off for the task's guest while ``dropoff_ok``.
    Navigation's clearing services are here too: move_base's ``clear_costmaps`` (the baseline's)
    and Nav2's two ``ClearEntireCostmap`` services (the tree's); ``move_base_clearing=False``
    leaves move_base's out, as on a Nav2 robot. Every request is kept in ``requests`` and
    logged.
    """

    def __init__(self, context: object, node_name: str = "referee", *, namespace: str = "",
                 rooms: dict[str, Box] | None = None, task: Task | None = None,
                 log: EventLog | None = None, move_base_clearing: bool = True) -> None:
        super().__init__(context, node_name, log)
        self.rooms = ROOMS if rooms is None else rooms
        self.task = task or Task()
        self.requests: list[Any] = []
        self.task_running = False
        self.pickup_ok = True
        self.dropoff_ok = True
        ns = namespace
        self.node.create_service(srv.NewTask, f"{ns}/servicesim/new_task", self.new_task)
        self.node.create_service(srv.TaskInfo, f"{ns}/referee/task_info", self.new_task)
        self.node.create_service(srv.RoomInfo, f"{ns}/servicesim/room_info", self.room_info)
        self.node.create_service(srv.PickUpGuest, f"{ns}/servicesim/pickup_guest", self.pickup)
        self.node.create_service(srv.DropOffGuest, f"{ns}/servicesim/dropoff_guest",
                                 self.dropoff)
        if move_base_clearing:  # a Nav2 robot has none
            self.node.create_service(Empty, f"{ns}/servicebot/move_base/clear_costmaps",
                                     self.clear)
        self.node.create_service(
            ClearEntireCostmap, f"{ns}/servicebot/global_costmap/clear_entirely_global_costmap",
            self.clear_global)
        self.node.create_service(
            ClearEntireCostmap, f"{ns}/servicebot/local_costmap/clear_entirely_local_costmap",
            self.clear_local)

    def _saw(self, what: str, request: Any, detail: Any = None) -> None:
        self.requests.append(request)
        self.log.add(what, detail)

    def new_task(self, request: Any, response: Any) -> Any:
        self._saw("new_task", request)
        if self.task_running:
            return response  # the error answer: everything empty
        self.task_running = True
        response.pick_up_location, response.drop_off_location = (self.task.pick_up,
                                                                  self.task.drop_off)
        response.guest_name = self.task.guest
        response.robot_start_pose = pose_to_msg(self.task.start)
        return response

    def room_info(self, request: Any, response: Any) -> Any:
        self._saw("room_info", request, request.name)
        box = self.rooms.get(request.name)
        if box is not None:
            response.min.x, response.min.y = box.min_x, box.min_y
            response.max.x, response.max.y = box.max_x, box.max_y
        return response

    def pickup(self, request: Any, response: Any) -> Any:
        self._saw("pickup_guest", request, (request.guest_name, request.robot_name))
        response.success = self.pickup_ok and request.robot_name == "servicebot"
        return response

    def dropoff(self, request: Any, response: Any) -> Any:
        self._saw("dropoff_guest", request, request.guest_name)
        response.success = self.dropoff_ok and request.guest_name == self.task.guest
        return response

    def clear(self, request: Any, response: Any) -> Any:
        self._saw("clear_costmaps", request)
        return response

    def clear_global(self, request: Any, response: Any) -> Any:
        self._saw("clear_global_costmap", request)
        return response

    def clear_local(self, request: Any, response: Any) -> Any:
        self._saw("clear_local_costmap", request)
        return response


Result = NavigateToPose.Result
