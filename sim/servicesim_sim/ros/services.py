"""The competition's services: the task, room boxes, pick-up, drop-off, drift, and clearing the
costmaps as move_base and Nav2 name it.

Design intent: each answer is the engine's (:class:`~servicesim_sim.model.engine.SimEngine`);
a request the original made fail is answered at once with its documented error answer and a
warning naming the reason. The answers that the service-latency knob delays are coroutines
waiting in *sim* time, so no request ever blocks the loop; every handler is counted and gated
by lockstep.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from nav2_msgs.srv import ClearEntireCostmap
from rclpy.node import Node
from rclpy.task import Future
from servicesim_competition.srv import (
    Drift,
    DropOffGuest,
    NewTask,
    PickUpGuest,
    RoomInfo,
    TaskInfo,
)
from std_srvs.srv import Empty

from servicesim_sim.lockstep.server import LockstepServer
from servicesim_sim.model.engine import SimEngine
from servicesim_sim.ros.publishing import EVERY_REQUEST
from servicesim_sim.settings import SimSettings

MOVE_BASE_CLEAR_SERVICE = "/servicebot/move_base/clear_costmaps"
"""move_base's (ROS 1) clearing service, ``std_srvs/Empty``: what the baseline, the original's
example solution, calls."""
GLOBAL_COSTMAP_CLEAR_SERVICE = "/servicebot/global_costmap/clear_entirely_global_costmap"
LOCAL_COSTMAP_CLEAR_SERVICE = "/servicebot/local_costmap/clear_entirely_local_costmap"
"""Nav2's clearing services, ``nav2_msgs/srv/ClearEntireCostmap``, named as a Nav2 stack in the
robot's namespace names them (its ``global_costmap`` and ``local_costmap`` nodes). Nav2 clears
each costmap on its own service; our navigator keeps one costmap, so each clears all of it."""


class CompetitionServices:
    """The services on ``node``, answered from ``engine``; ``sim_sleep(seconds)`` is a future
    the loop completes once that much sim time has passed."""

    def __init__(self, *, node: Node, engine: SimEngine, settings: SimSettings,
                 lockstep: LockstepServer, sim_sleep: Callable[[float], Future[bool]]) -> None:
        self.node = node
        self.engine = engine
        self.settings = settings
        self._sim_sleep = sim_sleep
        services: list[tuple[Any, str, Callable[..., Any]]] = [
            (NewTask, "/servicesim/new_task", self._new_task),
            (TaskInfo, "/servicesim/task_info", self._task_info),
            (RoomInfo, "/servicesim/room_info", self._room_info),
            (PickUpGuest, "/servicesim/pickup_guest", self._pickup_guest),
            (DropOffGuest, "/servicesim/dropoff_guest", self._dropoff_guest),
            (Drift, "/servicesim/drift", self._drift),
            (Empty, MOVE_BASE_CLEAR_SERVICE, self._clear_costmaps),
            (ClearEntireCostmap, GLOBAL_COSTMAP_CLEAR_SERVICE, self._clear_costmaps),
            (ClearEntireCostmap, LOCAL_COSTMAP_CLEAR_SERVICE, self._clear_costmaps),
        ]
        self._services = [node.create_service(kind, name, lockstep.gated(name, callback),
                                              qos_profile=EVERY_REQUEST,
                                              callback_group=lockstep.callback_group)
                          for kind, name, callback in services]

    async def _latency(self) -> None:
        latency = self.settings.difficulty.service_latency_s
        if latency > 0.0:
            await self._sim_sleep(latency)

    async def _new_task(self, request: NewTask.Request, response: NewTask.Response) -> Any:
        await self._latency()
        started, reason = self.engine.new_task()
        if not started:
            self.node.get_logger().warning(f"new_task refused: {reason}")
            return response  # the documented error answer: every field empty
        return self._fill_task(response)

    async def _task_info(self, request: TaskInfo.Request, response: TaskInfo.Response) -> Any:
        await self._latency()
        if not self.engine.task_running():  # the original fails it before and after the task
            state = "has completed" if self.engine.task_started else "has been started"
            self.node.get_logger().warning(f"task_info refused: no task {state}")
            return response  # the documented error answer: every field empty
        return self._fill_task(response)

    def _fill_task(self, response: Any) -> Any:
        scenario = self.engine.scenario
        response.pick_up_location = scenario.task.pick_up
        response.drop_off_location = scenario.task.drop_off
        response.guest_name = scenario.task.guest_name
        start = response.robot_start_pose
        start.position.x, start.position.y, start.position.z = (
            scenario.task.start_x, scenario.task.start_y, 0.75)
        start.orientation.z = math.sin(scenario.task.start_yaw / 2.0)
        start.orientation.w = math.cos(scenario.task.start_yaw / 2.0)
        return response

    async def _room_info(self, request: RoomInfo.Request, response: RoomInfo.Response) -> Any:
        await self._latency()
        box = self.settings.world.areas.get(request.name)
        if box is None:
            self.node.get_logger().warning(f"room_info refused: unknown room {request.name!r}")
            return response  # the documented error answer: a zero-size box at the origin
        response.min.x, response.min.y = box.min_x, box.min_y
        response.max.x, response.max.y = box.max_x, box.max_y
        return response

    async def _pickup_guest(self, request: PickUpGuest.Request,
                            response: PickUpGuest.Response) -> Any:
        await self._latency()
        response.success, reason = self.engine.pickup(request.guest_name, request.robot_name)
        self._log_call("pickup_guest", response.success, reason)
        return response

    async def _dropoff_guest(self, request: DropOffGuest.Request,
                             response: DropOffGuest.Response) -> Any:
        await self._latency()
        response.success, reason = self.engine.dropoff(request.guest_name)
        self._log_call("dropoff_guest", response.success, reason)
        return response

    def _drift(self, request: Drift.Request, response: Drift.Response) -> Any:
        response.drift, reason = self.engine.force_drift()
        self._log_call("drift", response.drift, reason)
        return response

    def _clear_costmaps(self, request: Any, response: Any) -> Any:
        """move_base's ``clear_costmaps`` or either of Nav2's ``clear_entirely_*_costmap``:
        the one costmap forgets its people marks; the answer is empty in both types."""
        self.engine.clear_costmaps()
        return response

    def _log_call(self, service: str, success: bool, reason: str) -> None:
        # rclpy ties a severity to each logging call site, so one call per severity
        if success:
            self.node.get_logger().info(f"{service}: ok: {reason}")
        else:
            self.node.get_logger().warning(f"{service}: refused: {reason}")
