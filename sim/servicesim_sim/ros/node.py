"""The simulator's ROS 2 face: the competition's topics, services and navigation action.

Everything that happens lives in :class:`~servicesim_sim.model.engine.SimEngine`, stepped at a fixed
physics step in sim time; this node only turns engine state into messages and requests into
engine calls. Its loop steps the engine, publishes ``/clock`` and the sensors, then lets rclpy
handle requests; with a speed factor it sleeps (spinning) until the wall clock catches up,
and when it falls behind it slips rather than racing (:mod:`servicesim_sim.process.pacing`); with
speed 0 it never sleeps. Nothing here reads the wall clock for simulation purposes.

Service answers and navigation results are coroutines that wait in *sim* time (for the
service-latency knob and for navigation to finish), so no request ever blocks the loop, and a
request the original made fail is answered at once with a documented error answer.

A client may join the simulator's lockstep (:mod:`servicesim_sim.lockstep.server`): the loop then
announces each period's end, steps the next while the clients tick on it, holds until every
joined client has finished that tick, and serves its requests in a fixed order; the node's
handlers are counted and gated for that, and with nobody joined they run exactly as before.

Every request gets an answer, however many come at once: the services and the action's goal,
cancel and result services hold every request of a burst (:data:`EVERY_REQUEST`; with ROS's
default depth of 10 a burst of 1000 ``room_info`` requests got 12-25 answers), and the loop's
executor takes all that wait (:mod:`servicesim_sim.process.executor`). Navigation runs one goal at a
time, as Nav2's does: a new goal preempts the running one, which ends ABORTED with a result,
and a goal that cannot be executed (its frame, its numbers, off the map:
:mod:`servicesim_sim.navigation.goals`) is aborted with NavigateToPose's error code and a
sentence, never executed as something else.
"""

from __future__ import annotations

import array
import gc
import math
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeAlias

import numpy as np
import rclpy
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped, Twist
from nav2_msgs.action import NavigateToPose
from nav2_msgs.srv import ClearEntireCostmap
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.action import CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image, LaserScan
from servicesim_competition.msg import ActorNames, ActorStates, RefereeState, Score
from servicesim_competition.srv import (
    Drift,
    DropOffGuest,
    NewTask,
    PickUpGuest,
    RoomInfo,
    TaskInfo,
)
from std_srvs.srv import Empty
from tf2_msgs.msg import TFMessage

from servicesim_sim.lockstep.server import CountingActionServer, LockstepServer, drain_completely
from servicesim_sim.model.engine import NavigationState, SimEngine
from servicesim_sim.model.localisation import Pose
from servicesim_sim.model.scan import LIDAR_HEIGHT_M, LIDAR_OFFSET
from servicesim_sim.model.scenario import make_scenario
from servicesim_sim.navigation.goals import GoalPose, GoalRefusal, goal_in_map
from servicesim_sim.process.executor import DrainingExecutor
from servicesim_sim.process.pacing import Pacer
from servicesim_sim.process.stop_signals import STOP_SIGNALS, handled
from servicesim_sim.ros.episodes import EpisodeResets, ResetRequested, episodes_ros_node
from servicesim_sim.ros.marker_topics import MarkerTopics
from servicesim_sim.settings import SimSettings
from servicesim_sim.wire.actor_messages import ActorNamesBytes, ActorStatesBytes
from servicesim_sim.wire.costmap_message import OccupancyValues, serialised_occupancy_grid
from servicesim_sim.wire.pose_messages import (
    ClockBytes,
    Link,
    OdometryBytes,
    PoseWithCovarianceBytes,
    TransformsBytes,
)

RCLError = rclpy_implementation.RCLError
NavigationGoal: TypeAlias = ServerGoalHandle[
    NavigateToPose.Goal, NavigateToPose.Result, NavigateToPose.Feedback]
"""A NavigateToPose goal as the action server holds it."""
IO_PERIOD_S = 0.1  # ROS input/output every 0.1 s sim: /clock, odom, RFID at 10 Hz
PUBLIC_PERIOD_STEPS = 5  # referee state and people every 0.5 s sim
COSTMAP_PERIOD_STEPS = 10  # the global costmap every 1 s sim: Nav2's publish_frequency 1.0
GLOBAL_COSTMAP_TOPIC = "/servicebot/global_costmap/costmap"
FEEDBACK_PERIOD_S = 0.5  # navigation feedback at 2 Hz sim, as often as anyone reads it
IDLE_WAIT_S = 0.05  # wall seconds of one wait while an episode is over (see SimulatorNode._idle)
#: No default QoS-event handlers: each is a waitable the executor adds to every wait set, and
#: the loop waits (with timeout 0) once per I/O period, hundreds of times a wall second.
#: With them the idle wait costs about 4x as much. Mismatched QoS still shows in
#: ``ros2 topic info --verbose``.
NO_PUBLISHER_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)
NO_SUBSCRIPTION_EVENTS = SubscriptionEventCallbacks(use_default_callbacks=False)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Requests a service (or the action's goal, cancel and result services) holds until the loop
#: takes them: a burst is held whole instead of cut to ROS's default ten (about 2 MB for 5000
#: waiting room_info requests). Not KEEP_ALL: requests and replies share one profile, and a
#: KEEP_ALL reply writer whose client stopped acknowledging (a frozen process) blocks each
#: write ~100 ms once its history is full, then fails; that starved every other client of the
#: service. A KEEP_LAST writer drops the frozen client's oldest replies instead.
REQUEST_DEPTH = 10_000
EVERY_REQUEST = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=REQUEST_DEPTH,
                           reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.VOLATILE)
ROBOT_NAME = "servicebot"
MAP_FRAME, ODOM_FRAME, BASE_FRAME = "map", "odom", "base_footprint"  # as the original's AMCL
BASE_LINK_HEIGHT_M = 0.749  # servicebot.urdf: base_footprint -> base_link
LIDAR_FRAME = "lidar_frame"
GROUND_TRUTH_TOPIC = "/servicesim/ground_truth/odom"
NAVIGATION_ACTION = "/servicebot/navigate_to_pose"
MOVE_BASE_CLEAR_SERVICE = "/servicebot/move_base/clear_costmaps"
"""move_base's (ROS 1) clearing service, ``std_srvs/Empty``: what the baseline, the original's
example solution, calls."""
GLOBAL_COSTMAP_CLEAR_SERVICE = "/servicebot/global_costmap/clear_entirely_global_costmap"
LOCAL_COSTMAP_CLEAR_SERVICE = "/servicebot/local_costmap/clear_entirely_local_costmap"
"""Nav2's clearing services, ``nav2_msgs/srv/ClearEntireCostmap``, named as a Nav2 stack in the
robot's namespace names them (its ``global_costmap`` and ``local_costmap`` nodes). Nav2 clears
each costmap on its own service; our navigator keeps one costmap, so each clears all of it."""
INITIAL_POSE_TOPIC = "/servicebot/initialpose"
CMD_VEL_TOPIC = "/servicebot/cmd_vel"
"""The robot's true pose in map, as Gazebo's model state would give it: for records and
tests, never for an executive (a real robot has no such topic)."""


def stamp_ns(seconds: float) -> int:
    return round(max(seconds, 0.0) * 1e9)


def stamp(seconds: float) -> Time:
    whole, nanoseconds = divmod(stamp_ns(seconds), 1_000_000_000)
    return Time(sec=whole, nanosec=nanoseconds)


def duration(seconds: float) -> Duration:
    whole, nanoseconds = divmod(round(max(seconds, 0.0) * 1e9), 1_000_000_000)
    return Duration(sec=whole, nanosec=nanoseconds)


class SimulatorNode:
    """One simulated world on one ROS node; :meth:`run` until interrupted."""

    def __init__(self, settings: SimSettings, *, node: Node,
                 engine: SimEngine | None = None, resets: EpisodeResets | None = None) -> None:
        """``engine``: the world already set in motion for ``settings``; default: made here.
        ``resets``: where an episode reset is asked for; the loop then ends with
        :class:`~servicesim_sim.ros.episodes.ResetRequested` at the end of its period."""
        self.settings = settings
        self.node = node
        self.resets = resets
        self.engine = engine or SimEngine(
            world=settings.world, scenario=make_scenario(settings.world, seed=settings.seed,
                                                         difficulty=settings.difficulty))
        self.steps_per_io = max(1, round(IO_PERIOD_S / self.engine.dt))
        self._sleepers: list[tuple[float, Future[bool]]] = []
        self._active_goal: NavigationGoal | None = None
        self._navigations: list[_Navigation] = []
        self._io_count = 0
        self._had_client = False
        self._dropped = 0
        self._topic_names: dict[Any, str] = {}
        self._camera_next = 0.0
        self._frames: list[tuple[float, np.ndarray]] = []  # captured, not yet sent
        self.lockstep = LockstepServer(node)
        callbacks = self.lockstep.callback_group
        self._make_publishers()
        self._make_services()
        self._navigation = CountingActionServer(
            node, NavigateToPose, NAVIGATION_ACTION, lockstep=self.lockstep,
            execute_callback=self._navigate, goal_callback=lambda _: GoalResponse.ACCEPT,
            handle_accepted_callback=self._on_goal_accepted,  # served through the gate
            cancel_callback=lambda _: CancelResponse.ACCEPT,
            goal_service_qos_profile=EVERY_REQUEST, result_service_qos_profile=EVERY_REQUEST,
            cancel_service_qos_profile=EVERY_REQUEST, callback_group=callbacks,
        )
        node.create_subscription(PoseWithCovarianceStamped, INITIAL_POSE_TOPIC,
                                 self.lockstep.gated_message(INITIAL_POSE_TOPIC,
                                                             self._on_initial_pose),
                                 LATCHED, event_callbacks=NO_SUBSCRIPTION_EVENTS,
                                 callback_group=callbacks)
        node.create_subscription(Twist, CMD_VEL_TOPIC,
                                 self.lockstep.gated_message(CMD_VEL_TOPIC, self._on_cmd_vel),
                                 10, event_callbacks=NO_SUBSCRIPTION_EVENTS,
                                 callback_group=callbacks)
        self._send(self._map_publisher, self._map_message())

    # ----------------------------------------------------------------- wiring
    def _make_publishers(self) -> None:
        def publisher(kind: type, topic: str, qos: QoSProfile | int) -> Any:
            return self.node.create_publisher(kind, topic, qos,
                                              event_callbacks=NO_PUBLISHER_EVENTS)

        self._clock = publisher(Clock, "/clock", 10)
        self._odom = publisher(Odometry, "/servicebot/odom", 10)
        self._truth = publisher(Odometry, GROUND_TRUTH_TOPIC, 10)
        self._amcl_pose = publisher(PoseWithCovarianceStamped, "/servicebot/amcl_pose", LATCHED)
        self._tf = publisher(TFMessage, "/tf", 100)
        self._tf_static = publisher(TFMessage, "/tf_static", LATCHED)
        self._scan = publisher(LaserScan, "/servicebot/scan", 2)
        self._rfid = publisher(ActorNames, "/servicebot/rfid", 10)
        self._score = publisher(Score, "/servicesim/score", 10)
        self._referee = publisher(RefereeState, "/servicesim/referee", LATCHED)
        self._actors = publisher(ActorStates, "/servicesim/actors", 10)
        # a period sends up to three frames at once (at most 30 a sim second): keep them all
        self._camera = publisher(Image, "/servicebot/camera_front/image_raw", 4)
        self._map_publisher = publisher(OccupancyGrid, "/servicebot/map", LATCHED)
        self._costmap = publisher(OccupancyGrid, GLOBAL_COSTMAP_TOPIC, LATCHED)
        self._markers = MarkerTopics(engine=self.engine, make_publisher=publisher, send=self._send,
                                     latched=LATCHED, now=stamp(self.engine.sim_time))
        # the high-rate messages are serialised by hand (servicesim_sim.wire.pose_messages), or
        # built once and refilled: publish serialises at the call
        self._clock_bytes = ClockBytes()
        self._clock_message = self._clock_bytes.encode(stamp_ns=0)  # the last one sent
        self._score_message = Score()
        self._odom_bytes = OdometryBytes(frame_id=ODOM_FRAME, child_frame_id=BASE_FRAME)
        self._truth_bytes = OdometryBytes(frame_id=MAP_FRAME, child_frame_id=BASE_FRAME)
        self._amcl_pose_bytes = PoseWithCovarianceBytes(frame_id=MAP_FRAME)
        odom_link = Link(parent=ODOM_FRAME, child=BASE_FRAME)
        self._tf_unlocalised = TransformsBytes([odom_link])
        self._tf_localised = TransformsBytes([odom_link, Link(parent=MAP_FRAME,
                                                              child=ODOM_FRAME)])
        self._scan_next = 0.0
        self._costmap_values: OccupancyValues | None = None  # made at the first costmap sent
        self._rfid_bytes = ActorNamesBytes()
        self._actor_states_bytes = ActorStatesBytes()
        self._send(self._tf_static, TFMessage(transforms=[
            transform(BASE_FRAME, "base_link", (0.0, 0.0, 0.0), z=BASE_LINK_HEIGHT_M),
            transform("base_link", LIDAR_FRAME, LIDAR_OFFSET,
                      z=LIDAR_HEIGHT_M - BASE_LINK_HEIGHT_M)]))

    def _make_services(self) -> None:
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
        self._services = [self.node.create_service(kind, name,
                                                   self.lockstep.gated(name, callback),
                                                   qos_profile=EVERY_REQUEST,
                                                   callback_group=self.lockstep.callback_group)
                          for kind, name, callback in services]

    # ------------------------------------------------------------- sim sleep
    def sim_sleep(self, seconds: float) -> Future[bool]:
        """A future completed by the loop once ``seconds`` of sim time have passed."""
        future: Future[bool] = Future()
        self._sleepers.append((self.engine.sim_time + max(seconds, 0.0), future))
        return future

    def _wake_sleepers(self, executor: DrainingExecutor) -> bool:
        """Complete the sleeps that are over; whether any was.

        In lockstep each sleeper runs on before the next wakes, in the order they fell asleep
        (which the gate fixed): rclpy would resume them in the order their requests arrived.
        """
        now = self.engine.sim_time
        due = [future for when, future in self._sleepers if when <= now]
        self._sleepers = [(when, future) for when, future in self._sleepers if when > now]
        for future in due:
            future.set_result(True)
            if self.lockstep.active:
                executor.note_resumable()
                drain_completely(executor)
        return bool(due)

    async def _latency(self) -> None:
        latency = self.settings.difficulty.service_latency_s
        if latency > 0.0:
            await self.sim_sleep(latency)

    # -------------------------------------------------------------- services
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

    # ----------------------------------------------------------- navigation
    def _on_goal_accepted(self, goal_handle: NavigationGoal) -> None:
        """One goal at a time, as Nav2: the new goal preempts whatever runs, at once."""
        self._active_goal = goal_handle
        for navigation in self._navigations:
            self._end(navigation, self._preempted(navigation))
        self._navigations.clear()
        goal_handle.execute()

    async def _navigate(self, goal_handle: NavigationGoal) -> NavigateToPose.Result:
        """Start the goal and wait for its result, which :meth:`_advance_navigation` sets.

        The goal is followed by the loop itself, once per I/O period, rather than by this
        coroutine waking each period: every wake-up of a coroutine costs the executor another
        pass over its wait set, and that was a fifth of the simulator's time. A goal already
        preempted (a burst accepts several before any runs) or refused ends here.
        """
        if goal_handle is not self._active_goal:
            goal_handle.abort()
            return _preemption_result()
        goal = self._goal_in_map(goal_handle.request.pose)
        if isinstance(goal, GoalRefusal):
            self.node.get_logger().warning(f"navigate_to_pose: goal aborted: {goal.error_msg}")
            goal_handle.abort()
            return NavigateToPose.Result(error_code=goal.error_code, error_msg=goal.error_msg)
        navigation = _Navigation(
            handle=goal_handle, ticket=self.engine.navigate(*goal),
            started=self.engine.sim_time, feedback_due=self.engine.sim_time + IO_PERIOD_S)
        self._navigations.append(navigation)
        return await navigation.result

    def _goal_in_map(self, stamped: Any) -> tuple[float, float, float] | GoalRefusal:
        """The goal message's pose in ``map`` (through the engine's map -> odom), or why not."""
        position, orientation = stamped.pose.position, stamped.pose.orientation
        goal = GoalPose(frame_id=stamped.header.frame_id,
                        position=(position.x, position.y, position.z),
                        orientation=(orientation.x, orientation.y, orientation.z, orientation.w))
        return goal_in_map(goal, map_extent=self.settings.world.map.extent,
                           map_to_odom=self.engine.map_to_odom())

    def _end(self, navigation: _Navigation, result: NavigateToPose.Result) -> None:
        """Complete the goal's coroutine with its result (its terminal state is already set)."""
        navigation.result.set_result(result)

    def _advance_navigation(self) -> bool:
        """Once per I/O period: feedback, and the result of every goal that ended; whether
        any ended."""
        ended = False
        for navigation in list(self._navigations):
            result = self._navigation_outcome(navigation)
            if result is not None:
                self._navigations.remove(navigation)
                self._end(navigation, result)
                ended = True
        return ended

    def _navigation_outcome(self, navigation: _Navigation) -> NavigateToPose.Result | None:
        """The goal's result if it ended (preempted, canceled, reached, failed), else None."""
        handle = navigation.handle
        if handle is not self._active_goal:
            return self._preempted(navigation)
        if handle.is_cancel_requested:
            self.engine.cancel_navigation(navigation.ticket)
            handle.canceled()
            return NavigateToPose.Result(error_msg="canceled")
        state = self.engine.navigation_state(navigation.ticket)
        if self.engine.sim_time >= navigation.feedback_due - 1e-9:
            navigation.feedback_due = self.engine.sim_time + FEEDBACK_PERIOD_S
            handle.publish_feedback(self._feedback(state, navigation.started))
            self.lockstep.answered(f"{NAVIGATION_ACTION}:feedback")
        if state.status == "succeeded":
            handle.succeed()
            return NavigateToPose.Result(error_code=NavigateToPose.Result.NONE)
        if state.status != "running":
            handle.abort()
            return NavigateToPose.Result(error_code=state.error_code, error_msg=state.error_msg)
        return None

    def _preempted(self, navigation: _Navigation) -> NavigateToPose.Result:
        """Stop the goal's navigation and abort it: a newer goal has taken over."""
        self.engine.cancel_navigation(navigation.ticket)
        navigation.handle.abort()
        return _preemption_result()

    def _feedback(self, state: NavigationState, started: float) -> NavigateToPose.Feedback:
        feedback = NavigateToPose.Feedback()
        feedback.current_pose = self._pose_stamped()
        feedback.navigation_time = duration(self.engine.sim_time - started)
        feedback.estimated_time_remaining = duration(state.distance_remaining / 0.5)
        feedback.number_of_recoveries = int(state.recoveries)
        feedback.distance_remaining = float(state.distance_remaining)
        return feedback

    def _on_initial_pose(self, message: PoseWithCovarianceStamped) -> None:
        """AMCL's initialpose: taken in the global frame only, as Nav2's AMCL does."""
        if message.header.frame_id != MAP_FRAME:
            self.node.get_logger().warning(
                f"initial pose ignored: frame {message.header.frame_id!r}, must be {MAP_FRAME!r}")
            return
        pose = message.pose.pose
        yaw = 2.0 * math.atan2(pose.orientation.z, pose.orientation.w)
        self.engine.set_initial_pose(pose.position.x, pose.position.y, yaw)

    def _on_cmd_vel(self, message: Twist) -> None:
        self.engine.command_velocity(message.linear.x, message.angular.z)

    # ------------------------------------------------------------- messages
    def _pose_stamped(self) -> Any:
        """The robot's pose as Nav2's feedback gives it: the localisation's map pose."""
        from geometry_msgs.msg import PoseStamped

        x, y, yaw = self.engine.estimated_pose() or self.engine.robot_pose()
        message = PoseStamped()
        message.header.stamp = stamp(self.engine.sim_time)
        message.header.frame_id = "map"
        message.pose.position.x, message.pose.position.y = x, y
        message.pose.orientation.z, message.pose.orientation.w = (
            math.sin(yaw / 2.0), math.cos(yaw / 2.0))
        return message

    def _publish_costmap(self) -> None:
        """Navigation's costmap as Nav2's global costmap publishes it (``map`` frame, values
        by Nav2's table), only while someone listens; serialised here
        (:mod:`servicesim_sim.wire.costmap_message`).

        The people on it are where the lidar marked them. Nav2 places marks by the robot's
        estimated pose; this costmap places them where people stand (docs/fidelity.md)."""
        if self._costmap.get_subscription_count() == 0:
            return
        costmap = self.engine.navigator.costmap
        if self._costmap_values is None:
            self._costmap_values = OccupancyValues(costmap.static)
        now = stamp(self.engine.sim_time)
        self._send(self._costmap, serialised_occupancy_grid(
            self._costmap_values.of(costmap.costs()), costmap.frame, frame_id=MAP_FRAME,
            stamp=(now.sec, now.nanosec)))

    def _map_message(self) -> OccupancyGrid:
        occupancy = self.settings.world.map
        message = OccupancyGrid()
        message.header.frame_id = "map"
        message.info.resolution = float(occupancy.resolution)
        message.info.width, message.info.height = occupancy.width, occupancy.height
        message.info.origin.position.x = float(occupancy.origin_x)
        message.info.origin.position.y = float(occupancy.origin_y)
        message.info.origin.orientation.w = 1.0
        message.data = array.array("b", occupancy.grid.astype("int8").ravel().tobytes())
        return message

    def _publish_io(self) -> None:
        now = self.engine.sim_time
        self._clock_message = self._clock_bytes.encode(stamp_ns=stamp_ns(now))
        self._send(self._clock, self._clock_message)
        self._publish_odom()
        self._publish_localisation()
        self._publish_scan()
        names = self.engine.rfid_names()
        if names is not None:  # silent when nobody is near, or when a reading is dropped
            self._send(self._rfid, self._rfid_bytes.encode(names))
        self._io_count += 1
        if self._io_count % PUBLIC_PERIOD_STEPS == 0 or self.engine.referee_changed():
            self._send(self._referee, self._referee_state())
        if self._io_count % PUBLIC_PERIOD_STEPS == 0:
            self._send(self._actors, self._actor_states())
            self._markers.publish(stamp(now))
        if self._io_count % COSTMAP_PERIOD_STEPS == 0:
            self._publish_costmap()
        self._publish_camera()

    def _publish_scores(self, scores: list[float]) -> None:
        """The period's score messages, one per physics step (50 Hz sim), sent together.

        Sent with the period's /clock rather than as each step ends: a client's clock moves
        only with /clock, so it cannot tell the difference, and a burst wakes it once where
        five messages spread over the period woke it up to five times. Nobody subscribing
        (the run records the referee's state, which carries the score), nothing is sent.
        """
        if not scores or self._score.get_subscription_count() == 0:
            return
        for score in scores:
            self._score_message.score = score
            self._send(self._score, self._score_message)

    def _send(self, publisher: Any, message: Any) -> None:
        """Publish; a message DDS refuses is dropped with a warning, never the simulator.

        On a starved machine Fast DDS can give up on a reliable write whose reader has not
        acknowledged the writer's full history in time ("cannot publish data"); the next
        period's message carries the state on.
        """
        try:
            publisher.publish(message)
            self.lockstep.published(self._topic_of(publisher))
        except RCLError as error:
            self._dropped += 1
            if self._dropped in (1, 10, 100) or self._dropped % 1000 == 0:
                self.node.get_logger().warning(
                    f"{publisher.topic_name}: message dropped ({self._dropped} so far): "
                    f"{str(error).splitlines()[0]}")

    def _topic_of(self, publisher: Any) -> str:
        """The publisher's topic, asked of rclpy once (each ask takes its handle's lock)."""
        topic = self._topic_names.get(publisher)
        if topic is None:
            topic = self._topic_names[publisher] = publisher.topic_name
        return topic

    def _publish_odom(self) -> None:
        """Odometry (in ``odom``, zero at spawn) and the ground truth (in ``map``)."""
        now = stamp_ns(self.engine.sim_time)
        twist = self.engine.robot_velocity()
        self._send(self._odom, self._odom_bytes.encode(
            stamp_ns=now, pose=self.engine.odometry_pose(), twist=twist))
        self._send(self._truth, self._truth_bytes.encode(
            stamp_ns=now, pose=self.engine.robot_pose(), twist=twist))

    def _publish_localisation(self) -> None:
        """/tf every period (odom -> base as the diff drive does, map -> odom once AMCL is
        running), and ``amcl_pose`` when the filter updated."""
        now = stamp_ns(self.engine.sim_time)
        if self.engine.localisation.localised:
            transforms = self._tf_localised.encode(
                stamp_ns=now, poses=(self.engine.odometry_pose(), self.engine.map_to_odom()))
        else:
            transforms = self._tf_unlocalised.encode(stamp_ns=now,
                                                     poses=(self.engine.odometry_pose(),))
        self._send(self._tf, transforms)
        estimate = self.engine.new_estimate()
        if estimate is not None:
            self._send(self._amcl_pose, self._amcl_pose_bytes.encode(
                stamp_ns=now, pose=estimate.pose, std_m=estimate.std_m,
                std_rad=estimate.std_rad))

    def _publish_scan(self) -> None:
        """A sweep every 0.1 sim s (the original's 10 Hz), only while someone listens."""
        spec = self.engine.scanner.spec
        if self.engine.sim_time < self._scan_next - 1e-9:
            return
        self._scan_next = self.engine.sim_time + 1.0 / spec.rate_hz
        if self._scan.get_subscription_count() == 0:
            return
        scan = LaserScan(angle_min=spec.angle_min, angle_max=spec.angle_max,
                         angle_increment=spec.angle_increment, time_increment=0.0,
                         scan_time=1.0 / spec.rate_hz, range_min=spec.range_min,
                         range_max=spec.range_max)
        scan.header.stamp = stamp(self.engine.sim_time)
        scan.header.frame_id = LIDAR_FRAME
        scan.ranges = array.array("f", self.engine.scan_ranges().tobytes())
        self._send(self._scan, scan)

    def _capture_camera(self) -> None:
        """Render a frame when one is due, after a physics step, while someone subscribes.

        Frames fall due every 1 / rate sim s on a fixed schedule (at 24 Hz and 50 Hz physics:
        0.04 and 0.06 s apart, 24 a sim second), so the rate is kept between I/O periods;
        :meth:`_publish_camera` sends them with the period's /clock.
        """
        rate, now = self.settings.camera_rate_hz, self.engine.sim_time
        if rate <= 0.0 or now < self._camera_next - 1e-9:
            return
        self._camera_next = max(self._camera_next + 1.0 / rate, now)
        if self._camera.get_subscription_count() == 0:
            return
        self._frames.append((now, self.engine.camera_image()))

    def _publish_camera(self) -> None:
        for when, pixels in self._frames:
            image = Image(height=pixels.shape[0], width=pixels.shape[1], encoding="rgb8",
                          is_bigendian=0, step=pixels.shape[1] * 3)
            image.header.stamp = stamp(when)
            image.header.frame_id = "camera_front"
            image.data = pixels.tobytes()
            self._send(self._camera, image)
        self._frames.clear()

    def _referee_state(self) -> RefereeState:
        report = self.engine.referee_report()
        state = RefereeState()
        state.stamp = stamp(self.engine.sim_time)
        state.task_running = bool(report["running"])
        state.completed = bool(report["completed"])
        state.score = float(report["score"])
        state.task_sim_time = float(report["task_sim_time"])
        state.checkpoint_names = [c["name"] for c in report["checkpoints"]]
        state.checkpoint_done = [bool(c["done"]) for c in report["checkpoints"]]
        state.checkpoint_sim_time = [float(c["sim_time_s"]) for c in report["checkpoints"]]
        penalties = report["penalties"]
        state.failed_pickups = int(penalties["failed_pickup"])
        state.failed_dropoffs = int(penalties["failed_dropoff"])
        state.too_fast = int(penalties["too_fast"])
        state.drifts = int(penalties["drifts"])
        state.contact = float(penalties["contact"])
        state.approximation = float(penalties["approximation"])
        return state

    def _actor_states(self) -> bytes:
        """Everyone's place, serialised (:mod:`servicesim_sim.wire.actor_messages`)."""
        return self._actor_states_bytes.encode(
            stamp=divmod(stamp_ns(self.engine.sim_time), 1_000_000_000),
            people=self.engine.people_states(), guest_state=self.engine.guest_state())

    # ----------------------------------------------------------------- loop
    def run(self, executor: DrainingExecutor) -> None:
        """Step, publish and serve until the context shuts down, paced by the speed factor."""
        pacer = Pacer()
        period = 0
        while rclpy.ok(context=self.node.context):
            self._check_reset()
            scores: list[float] = []
            for _ in range(self.steps_per_io):
                self.engine.step()
                self._capture_camera()
                if self.engine.task_running():
                    scores.append(float(self.engine.score()))
            period += 1
            self._publish_scores(scores)
            self._publish_io()
            goals_ended = self._advance_navigation()
            sleeps_over = self._wake_sleepers(executor)
            if goals_ended or sleeps_over:
                executor.note_resumable()
            self.lockstep.end_period(period=period, sim_time_ns=stamp_ns(self.engine.sim_time),
                                     executor=executor)
            if period == 1 and self.settings.await_lockstep_s > 0.0:
                self.lockstep.await_client(
                    executor, wall_s=self.settings.await_lockstep_s,
                    meanwhile=self._repeat_clock)
            self._wait_for_wall_clock(pacer, executor)
            self.lockstep.hold(executor)
            self._had_client = self._had_client or self.lockstep.active
            if self._had_client and not self.lockstep.active and self._resets_used():
                self._idle(executor)

    def _repeat_clock(self) -> None:
        """While the loop holds at its first period for a client: the clock again, for late
        subscribers; a reset asked for meanwhile ends the hold."""
        self._check_reset()
        self._send(self._clock, self._clock_message)

    def _check_reset(self) -> None:
        if self.resets is not None:
            self.resets.check()

    def _resets_used(self) -> bool:
        return self.resets is not None and self.resets.used

    def _idle(self, executor: DrainingExecutor) -> None:
        """Hold still, serving requests, until a reset or a new lockstep client.

        Only in a simulator that plays episodes one after another (it has taken a reset):
        once the episode's lockstep client has left, the episode is over, and running on
        flat out until the next reset would only take a core from the episodes running
        beside it.
        """
        while not self.lockstep.active and rclpy.ok(context=self.node.context):
            self._check_reset()
            executor.wait_and_run(timeout_sec=IDLE_WAIT_S)

    def close(self, executor: DrainingExecutor) -> None:
        """Drop what the node's destruction leaves alive: the coroutines waiting on sim time,
        navigation or the gate, which no loop will resume now, and the navigation action
        server (a waitable)."""
        executor.drop_tasks_of(self.node)
        self._sleepers, self._navigations = [], []
        self._navigation.destroy()

    def _wait_for_wall_clock(self, pacer: Pacer, executor: DrainingExecutor) -> None:
        """Serve requests until the speed factor lets the next period start."""
        wait_s = pacer.wait_s(sim_time=self.engine.sim_time, speed=self._pace())
        if wait_s <= 0.0:  # flat out or behind: only look for requests (in lockstep the
            if not self.lockstep.active:  # gate looks, when what it waits for is not in)
                executor.run_ready()
            return
        due = time.monotonic() + wait_s
        while (remaining := due - time.monotonic()) > 0.0:
            executor.wait_and_run(timeout_sec=remaining)

    def _pace(self) -> float:
        """The speed factor now: at most real time until a task starts.

        Before ``new_task`` nothing is scored, and running flat out would only flood the
        machine while the executive starts and DDS discovers its endpoints — a response
        written before the server has matched the client's reader is lost. A lockstep client
        has found its endpoints before it joins, and the gate holds the world for it anyway.
        """
        speed = self.settings.speed
        if self.engine.task_started or self.lockstep.active or 0.0 < speed <= 1.0:
            return speed
        return 1.0


def transform(parent: str, child: str, pose: Pose, now: Time | None = None, *,
              z: float = 0.0) -> TransformStamped:
    """The planar transform parent -> child (``pose``: the child's origin in the parent)."""
    message = TransformStamped()
    if now is not None:
        message.header.stamp = now
    message.header.frame_id, message.child_frame_id = parent, child
    translation, rotation = message.transform.translation, message.transform.rotation
    translation.x, translation.y, translation.z = float(pose[0]), float(pose[1]), z
    rotation.z, rotation.w = math.sin(pose[2] / 2.0), math.cos(pose[2] / 2.0)
    return message


def _preemption_result() -> NavigateToPose.Result:
    return NavigateToPose.Result(error_code=NavigateToPose.Result.UNKNOWN,
                                 error_msg="preempted by a newer goal")


@dataclass
class _Navigation:
    """A NavigateToPose goal the loop follows; ``result`` completes the goal's coroutine."""

    handle: NavigationGoal
    ticket: int
    started: float
    feedback_due: float
    result: Future[NavigateToPose.Result] = field(default_factory=Future)


def simulator_ros_node(name: str = "servicesim") -> Node:
    """The simulator's node, without the parameter and type-description services.

    The simulator has no ROS parameters (its settings are command-line arguments), and each
    service is one more entity in every wait set the loop builds.
    """
    return Node(name, start_parameter_services=False, parameter_overrides=[
        Parameter("start_type_description_service", value=False)])


def run_simulator(settings: SimSettings, *, engine: SimEngine | None = None) -> int:
    """Run until Ctrl-C, SIGTERM or SIGHUP; returns the process exit status.

    Each episode is a :class:`SimulatorNode` on a node of its own; an accepted reset
    (:mod:`servicesim_sim.ros.episodes`) ends the episode's loop, drops its node and starts the
    next one from the reset's settings. The first stop signal ends the loop; from then on
    further ones are ignored, so that the shut-down (which deletes the DDS participant and its
    shared-memory segment) is not cut short: a run that dies sends one SIGTERM per thread it
    had (``PR_SET_PDEATHSIG``).
    """
    stopped: list[int] = []

    def stop(number: int, _frame: object) -> None:
        stopped.append(number)
        for each in STOP_SIGNALS:
            signal.signal(each, signal.SIG_IGN)
        raise KeyboardInterrupt

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    executor: DrainingExecutor | None = None
    resets: EpisodeResets | None = None
    simulator: SimulatorNode | None = None
    try:
        for number in handled():  # those the process was started with ignored stay ignored
            signal.signal(number, stop)
        executor = DrainingExecutor()
        resets = EpisodeResets(episodes_ros_node())
        executor.add_node(resets.node)
        while True:
            simulator = _start_episode(settings, engine, executor, resets)
            try:
                simulator.run(executor)
                break
            except ResetRequested:
                _end_episode(simulator, executor)
                simulator = None
                episode = resets.take()
                settings, engine = episode.settings, episode.engine
    except KeyboardInterrupt:
        pass
    except RuntimeError:  # the stop raised inside a pybind11 call, which turns it into this
        if not stopped:
            raise
    finally:
        for number in STOP_SIGNALS:  # a stop that came before the handler ran: clean up anyway
            signal.signal(number, signal.SIG_IGN)
        if simulator is not None and executor is not None:
            _end_episode(simulator, executor)
        if executor is not None:
            executor.shutdown()
        if resets is not None:
            resets.node.destroy_node()
        rclpy.try_shutdown()
    return 0


def _start_episode(settings: SimSettings, engine: SimEngine | None,
                   executor: DrainingExecutor, resets: EpisodeResets) -> SimulatorNode:
    """A new simulator node for ``settings``, spun by ``executor``; a reset waiting for it
    is answered."""
    node = simulator_ros_node()
    simulator = SimulatorNode(settings, node=node, engine=engine, resets=resets)
    executor.add_node(node)
    resets.started()
    executor.note_resumable()  # the reset's coroutine resumes, and answers, in the next drain
    # what lives now (modules, the world, the maps) lives for the episode: the cyclic collector
    # stops walking it, which was 5 % of a driven period's CPU (the last episode's is collected
    # first, so a warm simulator does not keep it)
    gc.unfreeze()
    gc.collect()
    gc.freeze()
    task = simulator.engine.scenario.task
    node.get_logger().info(
        f"world {settings.world.name}: task {task.pick_up} -> {task.drop_off}, "
        f"guest {task.guest_name}, seed {settings.seed}, speed {settings.speed}")
    return simulator


def _end_episode(simulator: SimulatorNode, executor: DrainingExecutor) -> None:
    """Drop the episode's node and everything on it."""
    simulator.close(executor)
    executor.remove_node(simulator.node)
    simulator.node.destroy_node()
