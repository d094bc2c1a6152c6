"""The seed's state machine: the baseline the behaviour tree is measured against.

ServiceSim shipped an example solution, a four-state machine (BeginTask → Pickup → DropOff →
ReturnToStart). This module ports it to rclpy *faithfully, flaws included*, so that evaluation
compares the behaviour tree with what the competition handed out, not with a straw man:

* navigation is one loop at 1 Hz: cancel goals, clear costmaps, sleep 0.5 s, send a goal at the
  area's centre shifted −1 m in x (±0.1 m jitter, facing −x), wait up to 10 s for the result,
  and repeat until a goal succeeds;
* the answers of ``pickup_guest`` and ``dropoff_guest`` are never looked at (the seed wrapped
  them in a list, which is always truthy): a failed pick-up moves on all the same;
* there is no search for a guest out of RFID range and no drift handling;
* the return goal is the start pose −1 m, which can leave the robot just outside the start box.

It clears move_base's costmaps (``std_srvs/Empty`` on ``/servicebot/move_base/clear_costmaps``),
a ROS 1 service that only our simulator still offers; a Nav2 robot has no such server. So the
wait for that server is bounded (:data:`CLEAR_SERVER_WAIT_S`): without it the attempt goes on to
its goal uncleared, and later attempts do not wait for the server again (they still call it if it
has come): on a Nav2 robot the baseline navigates as the seed did, less the clearing.

BeginTask also publishes the task's start pose on ``/servicebot/initialpose``: in the original
the competition's launch gave localisation the start pose; here the simulator, like AMCL, needs
it before any goal can succeed, and the behaviour tree does the same.

What is *not* ported is the seed's way of waiting. The seed blocked in ``sleep`` and
``wait_for_result``; here every state is a coroutine (a generator) polled by a timer on the
node's clock, so waits are in sim time under ``use_sim_time``, futures are polled and nothing
sleeps or spins inside a callback. The poll period is 0.1 s, the period of actionlib's own wait
loop; the 1 Hz rate applies to navigation attempts, as in the seed. Interrupting cancels the goal
in flight. The seed had no time limit; the run's limit (``time_limit_s``) ends the baseline with
FAILURE, so both executives are cut at the same sim time.

The class implements :class:`bt_servicesim.tree.executive.Executive`, so the run command drives it
unchanged (``python -m bt_servicesim.run --executive baseline``).
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Generator
from typing import Any

import py_trees
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionClient
from rclpy.client import Client
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.task import Future
from servicesim_competition import srv
from std_srvs.srv import Empty

from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.ros.initial_pose import INITIAL_POSE_QOS, initial_pose_message
from bt_servicesim.ros.messages import pose_from_msg, pose_to_msg
from bt_servicesim.ros.navigate_to_pose import (
    NavigationClient,
    NavigationGoalHandle,
    NavigationResult,
)
from bt_servicesim.ros.sim_clock import SimStopwatch, sim_now_s
from bt_servicesim.ros.sim_ticker import sim_ticker

__all__ = ["SEED_STATES", "SeedStateMachine", "seed_goal"]

Status = py_trees.common.Status
Waiting = Generator[None, None, Any]
"""A coroutine the timer polls: each ``yield`` waits one poll period; ``return`` gives a value."""

SEED_STATES = ("BeginTask", "Pickup", "DropOff", "ReturnToStart")
ROBOT_NAME = "servicebot"
POLL_PERIOD_S = 0.1
ATTEMPT_PERIOD_S = 1.0  # the seed's 1 Hz loop
SETTLE_S = 0.5  # the seed's sleep between clearing costmaps and sending the goal
RESULT_WAIT_S = 10.0  # the seed's wait_for_result limit
CLEAR_SERVER_WAIT_S = 5.0
"""Sim seconds an attempt waits for move_base's clearing server before going on without it."""
GOAL_OFFSET_X = -1.0  # the seed's goal: area centre (or start pose) shifted −1 m in x
JITTER_M = 0.1
FACING_MINUS_X = math.pi


def seed_goal(x: float, y: float, jitter: Callable[[], float]) -> Pose2D:
    """The seed's goal for a point: −1 m in x, each coordinate jittered, facing −x."""
    return Pose2D(x=x + GOAL_OFFSET_X + jitter(), y=y + jitter(), yaw=FACING_MINUS_X)


class SeedStateMachine:
    """BeginTask → Pickup → DropOff → ReturnToStart, as the seed did it; see the module notes.

    Args:
        node: the rclpy node (with ``use_sim_time`` in a run)
        seed: seeds the goal jitter, so a run with a task seed is reproducible
        time_limit_s: sim seconds after :meth:`start` at which the run gives up
        namespace: a prefix for every service and action name (a simulator in a namespace)
    """

    def __init__(
        self,
        *,
        node: Node,
        seed: int | None = None,
        time_limit_s: float = 900.0,
        namespace: str = "",
    ) -> None:
        self.node = node
        self.time_limit_s = time_limit_s
        self.namespace = namespace.rstrip("/")
        self.navigate_action = f"{self.namespace}/servicebot/navigate_to_pose"
        self.outcome: Status | None = None
        self.states_entered: list[str] = []
        self.goals_sent: list[Pose2D] = []
        self.ignored_answers: list[tuple[str, bool]] = []
        self._jitter = random.Random(0 if seed is None else seed).uniform  # never OS entropy
        self._state = "-"
        self._activity = ""
        self._clients: dict[str, Client[Any, Any]] = {}
        self._navigator: NavigationClient | None = None
        self._initial_pose: Publisher[PoseWithCovarianceStamped] | None = None
        self._ticker: Any = None
        self._clock: SimStopwatch | None = None
        self._body: Generator[None, None, None] | None = None
        self._pending_call: tuple[Client[Any, Any], Future[Any]] | None = None
        self._clearing_missing = False
        self._goal: GoalInFlight | None = None
        self._task: Any = None

    # ---------------------------------------------------------------- Executive
    def setup(self, *, timeout_s: float = 15.0) -> None:
        """Create the service and action clients (the seed waited for them as it went)."""
        services: dict[str, tuple[Any, str]] = {
            "new_task": (srv.NewTask, "/servicesim/new_task"),
            "room_info": (srv.RoomInfo, "/servicesim/room_info"),
            "pickup_guest": (srv.PickUpGuest, "/servicesim/pickup_guest"),
            "dropoff_guest": (srv.DropOffGuest, "/servicesim/dropoff_guest"),
            "clear_costmaps": (Empty, "/servicebot/move_base/clear_costmaps"),
        }
        self._clients = {key: self.node.create_client(kind, self.namespace + name)
                         for key, (kind, name) in services.items()}
        self._navigator = ActionClient(self.node, NavigateToPose, self.navigate_action)
        self._initial_pose = self.node.create_publisher(
            PoseWithCovarianceStamped, f"{self.namespace}/servicebot/initialpose",
            INITIAL_POSE_QOS)

    def start(self) -> None:
        """Poll the state machine every POLL_PERIOD_S of the node's (sim) clock."""
        self._clock = SimStopwatch(self.node.get_clock())
        self._clock.restart()
        self._body = self._run_states()
        self._ticker = sim_ticker(self.node, POLL_PERIOD_S, self.poll)

    @property
    def finished(self) -> bool:
        return self.outcome is not None

    def interrupt(self) -> None:
        """Stop polling; cancel the goal and withdraw the request in flight."""
        self._stop_timer()
        self._cancel_goal()
        self._withdraw_call()
        if self._body is not None:
            self._body.close()

    def phase(self) -> str:
        """The seed's state: BeginTask, Pickup, DropOff or ReturnToStart ("-" before)."""
        return self._state

    def activity(self) -> str:
        return self._activity

    # ---------------------------------------------------------------- polling
    def poll(self) -> None:
        """One step of the running state; the timer calls this every poll period."""
        if self.finished or self._body is None:
            return
        assert self._clock is not None
        if self._clock.elapsed() > self.time_limit_s:
            self._finish(Status.FAILURE, f"time limit of {self.time_limit_s:.0f} sim s reached")
            return
        try:
            next(self._body)
        except StopIteration:
            self._finish(Status.SUCCESS, "all four states done")
        except TaskRefusedError as refused:
            self._finish(Status.FAILURE, str(refused))

    def _finish(self, outcome: Status, activity: str) -> None:
        self._activity = activity
        self.interrupt()
        self.outcome = outcome

    def _stop_timer(self) -> None:
        if self._ticker is not None:
            self._ticker.cancel()
            self._ticker = None

    # ---------------------------------------------------------------- the four states
    def _run_states(self) -> Generator[None, None, None]:
        """Every state ends in "succeeded" in the seed, so the transitions are a straight line."""
        bodies = (self._begin_task, self._pickup, self._drop_off, self._return_to_start)
        for name, body in zip(SEED_STATES, bodies, strict=True):
            self._state = name
            self.states_entered.append(name)
            yield from body()

    def _begin_task(self) -> Waiting:
        answer = yield from self._call("new_task", srv.NewTask.Request())
        if not answer.pick_up_location:
            raise TaskRefusedError("new_task gave an error answer")
        self._task = answer
        self._localise(pose_from_msg(answer.robot_start_pose))
        self._activity = (f"task: {answer.guest_name} from {answer.pick_up_location} "
                          f"to {answer.drop_off_location}")

    def _localise(self, start: Pose2D) -> None:
        if self._initial_pose is None:
            raise RuntimeError("SeedStateMachine: call setup() before start()")
        stamp = self.node.get_clock().now().to_msg()
        self._initial_pose.publish(initial_pose_message(start, stamp=stamp))

    def _pickup(self) -> Waiting:
        x, y = yield from self._area_centre(self._task.pick_up_location)
        yield from self._navigate(x, y)
        request = srv.PickUpGuest.Request(guest_name=self._task.guest_name, robot_name=ROBOT_NAME)
        answer = yield from self._call("pickup_guest", request)
        self._ignore("pickup_guest", bool(answer.success))

    def _drop_off(self) -> Waiting:
        x, y = yield from self._area_centre(self._task.drop_off_location)
        yield from self._navigate(x, y)
        request = srv.DropOffGuest.Request(guest_name=self._task.guest_name)
        answer = yield from self._call("dropoff_guest", request)
        self._ignore("dropoff_guest", bool(answer.success))

    def _return_to_start(self) -> Waiting:
        start = pose_from_msg(self._task.robot_start_pose)
        yield from self._navigate(start.x, start.y)

    def _ignore(self, service: str, success: bool) -> None:
        """The seed's ``[answer]`` is always truthy: record the answer and move on regardless."""
        self.ignored_answers.append((service, success))
        self._activity = f"{service} answered success={success}; moving on"

    def _area_centre(self, room: str) -> Waiting:
        answer = yield from self._call("room_info", srv.RoomInfo.Request(name=room))
        box = Box(min_x=answer.min.x, min_y=answer.min.y, max_x=answer.max.x, max_y=answer.max.y)
        return box.centre

    # ---------------------------------------------------------------- navigation
    def _navigate(self, x: float, y: float) -> Waiting:
        """The seed's loop: attempts at 1 Hz until one goal succeeds."""
        attempts = 0
        while True:
            attempts += 1
            began = self._now()
            if (yield from self._attempt(x, y, attempts)):
                return
            yield from self._sleep_until(began + ATTEMPT_PERIOD_S)

    def _attempt(self, x: float, y: float, attempt: int) -> Waiting:
        """Cancel, clear costmaps, sleep 0.5 s, send a jittered goal, wait up to 10 s for it."""
        self._cancel_goal()
        yield from self._clear_costmaps()
        yield from self._sleep_until(self._now() + SETTLE_S)
        goal = seed_goal(x, y, lambda: self._jitter(-JITTER_M, JITTER_M))
        result = yield from self._send_goal(goal, attempt)
        return result is not None and result.status == GoalStatus.STATUS_SUCCEEDED

    def _clear_costmaps(self) -> Waiting:
        """Call move_base's clear_costmaps; a server missing for CLEAR_SERVER_WAIT_S (a Nav2
        robot has none) is skipped, and not waited for again."""
        limit_s = 0.0 if self._clearing_missing else CLEAR_SERVER_WAIT_S
        present = yield from self._await_server("clear_costmaps", limit_s=limit_s)
        self._clearing_missing = not present
        if present:
            yield from self._call("clear_costmaps", Empty.Request())
        else:
            self._activity = (f"no server for {self._clients['clear_costmaps'].srv_name}: "
                              "navigating without clearing the costmaps")

    def _send_goal(self, goal: Pose2D, attempt: int) -> Waiting:
        """The goal's wrapped result, or None if it did not finish within 10 s."""
        navigator = self._require_navigator()
        while not navigator.server_is_ready():
            self._activity = f"waiting for navigation server {self.navigate_action}"
            yield
        message = NavigateToPose.Goal()
        message.pose.header.frame_id = "map"
        message.pose.header.stamp = self.node.get_clock().now().to_msg()
        message.pose.pose = pose_to_msg(goal)
        self.goals_sent.append(goal)
        self._goal = GoalInFlight(navigator.send_goal_async(message))
        self._activity = f"attempt {attempt}: goal ({goal.x:.2f}, {goal.y:.2f})"
        deadline = self._now() + RESULT_WAIT_S
        while self._now() < deadline:
            result = self._goal.result()
            if result is not None:
                return result
            yield
        return None

    def _cancel_goal(self) -> None:
        """Cancel the goal in flight (the seed's cancel_all_goals); do not wait for the reply."""
        goal, self._goal = self._goal, None
        if goal is not None:
            goal.cancel()

    # ---------------------------------------------------------------- services and time
    def _call(self, service: str, request: Any) -> Waiting:
        """Call a service when its server is up, and wait for the answer as long as it takes."""
        client = self._clients[service]
        while not client.service_is_ready():
            self._activity = f"waiting for service {client.srv_name}"
            yield
        future = client.call_async(request)
        self._pending_call = (client, future)
        while not future.done():
            yield
        self._pending_call = None
        if future.exception() is not None or future.result() is None:
            raise TaskRefusedError(f"{client.srv_name} failed: {future.exception() or 'no answer'}")
        return future.result()

    def _await_server(self, service: str, *, limit_s: float) -> Waiting:
        """Whether the service's server is up within ``limit_s`` sim seconds."""
        client = self._clients[service]
        deadline = self._now() + limit_s
        while not client.service_is_ready():
            if self._now() >= deadline:
                return False
            self._activity = f"waiting for service {client.srv_name}"
            yield
        return True

    def _withdraw_call(self) -> None:
        if self._pending_call is not None:
            client, future = self._pending_call
            client.remove_pending_request(future)
            future.cancel()
            self._pending_call = None

    def _sleep_until(self, when_s: float) -> Waiting:
        while self._now() < when_s:
            yield

    def _now(self) -> float:
        return sim_now_s(self.node.get_clock())

    def _require_navigator(self) -> NavigationClient:
        if self._navigator is None:
            raise RuntimeError("SeedStateMachine: call setup() before start()")
        return self._navigator


class TaskRefusedError(RuntimeError):
    """The referee refused the task or a call failed outright (the seed would have crashed)."""


class GoalInFlight:
    """One NavigateToPose goal: its acceptance, then its result, polled without blocking."""

    def __init__(self, acceptance: Future[NavigationGoalHandle]) -> None:
        self.acceptance = acceptance
        self.handle: NavigationGoalHandle | None = None
        self.outcome: Future[NavigationResult] | None = None

    def result(self) -> Any:
        """The wrapped result (``status``, ``result``) once there is one; None until then."""
        if self.outcome is None:
            if not self.acceptance.done():
                return None
            handle = None if self.acceptance.exception() is not None else self.acceptance.result()
            if handle is None or not handle.accepted:
                return REJECTED
            self.handle, self.outcome = handle, handle.get_result_async()
        if not self.outcome.done() or self.outcome.exception() is not None:
            return None
        return self.outcome.result()

    def cancel(self) -> None:
        """Ask the server to cancel the goal if it is still active; a late acceptance too."""
        if self.outcome is not None and self.outcome.done():
            return
        if self.acceptance.done():
            _cancel_once_accepted(self.acceptance)
        else:
            self.acceptance.add_done_callback(_cancel_once_accepted)


class _Rejected:
    """Stands in for the wrapped result of a goal the server rejected."""

    status = GoalStatus.STATUS_ABORTED


REJECTED = _Rejected()


def _cancel_once_accepted(future: Future[NavigationGoalHandle]) -> None:
    """Cancel a goal whose acceptance arrives after it was abandoned."""
    if future.cancelled() or future.exception() is not None:
        return
    handle = future.result()
    if handle is not None and handle.accepted:
        handle.cancel_goal_async()
