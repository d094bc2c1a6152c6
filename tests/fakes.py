"""What several test modules share: fake servers, graphs to spin, leaf wiring, maps, commands.

One place for each stand-in, so that the tests of different packages script the same fakes:

- spinning: :func:`spin_until` (with a deadline), :func:`wait_for_subscription`,
  :func:`clock_message`, :func:`unique_name`;
- graphs a test spins from its own thread: :class:`ExecutiveGraph` (a behaviour's node, with
  ``tick_until_done``) and :class:`SimTimeGraph` (a node on sim time and a simulator node
  publishing ``/clock``; :class:`SensorWorld` adds the RFID and odometry publishers);
- fake servers, scripted and logging what they saw: :class:`FakeReferee` (the competition's
  services), :class:`FakeNavigator` (a NavigateToPose action server), :class:`ServerThread`
  (spins fakes in a thread of their own, as a real server runs) and :class:`FakeSimulator`
  (referee and navigation under one namespace, one event log);
- leaves: :func:`ready` (ports remapped as given) and :func:`wire` (every port to ``/<port>``);
- maps, costmaps and RFID: :func:`grid_message`, :func:`cells`, :func:`fill`, :func:`open_room`,
  :func:`costmap_of` (navigation's costmap with people on it),
  :func:`drive` (RFID readings along a path), :func:`check_approach`;
- recorded runs: :class:`RecordedRun` (the errand tree of :class:`Step` leaves run to its end
  with a tree log, and what every tick really was);
- commands: :func:`run_module` (``python -m``, output captured).

The fixtures built on these (``ros_context``, ``sim_clock``, ``world``, the blackboard cleaned
round every test) are in ``conftest.py``.
"""

from __future__ import annotations

import itertools
import math
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np
import py_trees
from builtin_interfaces.msg import Time
from nav2_msgs.action import NavigateToPose
from nav2_msgs.srv import ClearEntireCostmap
from nav_msgs.msg import OccupancyGrid, Odometry
from py_trees.blackboard import Blackboard
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml
from py_trees.ports import BehaviourWithPorts, PortInformation
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.executors import Executor, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rosgraph_msgs.msg import Clock
from servicesim_competition import srv
from servicesim_competition.msg import ActorNames
from std_srvs.srv import Empty
from tf2_msgs.msg import TFMessage

from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.planning.guest_localisation import RfidHistory, RfidReading
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import Costmap2D
from bt_servicesim.records.drawing import tree_text
from bt_servicesim.records.tree_log import TreeLog
from bt_servicesim.ros.messages import pose_from_msg, pose_to_msg
from bt_servicesim.tree.shape import NodeState, TreeShape, walk

Status = py_trees.common.Status
GUEST = "human_20843"
OTHER = "human_99999"
_names = itertools.count()


def unique_name(prefix: str) -> str:
    """``prefix`` with a number no other name of this process has: DDS remembers old nodes."""
    return f"{prefix}_{next(_names)}"


# ============================================================================ spinning
def spin_until(executor: Executor, done: Callable[[], bool], what: str = "the condition", *,
               before: Callable[[], Any] = lambda: None, limit_s: float = 20.0,
               step_s: float = 0.01) -> None:
    """Spin ``executor`` until ``done()``, calling ``before()`` ahead of each spin; fail after
    ``limit_s`` wall seconds."""
    deadline = time.monotonic() + limit_s
    while not done():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        before()
        executor.spin_once(timeout_sec=step_s)


def wait_for_subscription(publisher: Publisher, limit_s: float = 10.0) -> None:
    """Wait (without spinning) until a subscription has matched ``publisher``."""
    deadline = time.monotonic() + limit_s
    while publisher.get_subscription_count() == 0:
        assert time.monotonic() < deadline, f"nobody subscribed to {publisher.topic_name}"
        time.sleep(0.01)


def clock_message(seconds: float, *, nanoseconds_short: int = 0) -> Clock:
    """The ``/clock`` message for ``seconds`` of sim time (less ``nanoseconds_short``)."""
    total = round(seconds * 1e9) - nanoseconds_short
    return Clock(clock=Time(sec=total // 10**9, nanosec=total % 10**9))


# ============================================================================ graphs
T = TypeVar("T", bound="FakeServer")


class ExecutiveGraph:
    """A behaviour's node and the executor the test spins between ticks; fakes join it with
    :meth:`serve` and are then answered from the test's thread."""

    def __init__(self, context: object, node_name: str = "executive") -> None:
        self.node = Node(node_name, context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.served: list[FakeServer] = []

    def serve(self, server: T) -> T:
        self.executor.add_node(server.node)
        self.served.append(server)
        return server

    def spin_until(self, done: Callable[[], bool], what: str = "the condition",
                   limit_s: float = 10.0) -> None:
        spin_until(self.executor, done, what, limit_s=limit_s)

    def tick_until(self, behaviour: py_trees.behaviour.Behaviour, done: Callable[[], bool],
                   limit_s: float = 10.0) -> None:
        """Tick, spinning between ticks, until ``done()`` after a tick."""
        deadline = time.monotonic() + limit_s
        while True:
            behaviour.tick_once()
            if done():
                return
            assert time.monotonic() < deadline, f"still RUNNING: {behaviour.feedback_message}"
            self.executor.spin_once(timeout_sec=0.01)

    def tick_until_done(self, behaviour: py_trees.behaviour.Behaviour,
                        limit_s: float = 10.0) -> Status:
        self.tick_until(behaviour, lambda: behaviour.status != Status.RUNNING, limit_s)
        return behaviour.status

    def shutdown(self) -> None:
        self.executor.shutdown()
        for node in [self.node, *(server.node for server in self.served)]:
            node.destroy_node()


class SimTimeGraph:
    """A node on sim time and a simulator node publishing ``/clock``, on one executor the test
    spins from its own thread."""

    def __init__(self, context: object, node_name: str = "executive",
                 simulator_name: str = "simulator") -> None:
        self.node = Node(node_name, context=context, parameter_overrides=[
            Parameter("use_sim_time", Parameter.Type.BOOL, True)])
        self.simulator = Node(simulator_name, context=context)
        self.clock = self.simulator.create_publisher(Clock, "/clock", 10)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.simulator)

    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds / 1e9

    def spin_until(self, done: Callable[[], bool], what: str = "the condition", *,
                   before: Callable[[], Any] = lambda: None, limit_s: float = 20.0) -> None:
        spin_until(self.executor, done, what, before=before, limit_s=limit_s)

    def jump_to(self, seconds: float, limit_s: float = 20.0) -> None:
        """Publish ``/clock`` = ``seconds`` until the node's clock reads exactly that."""
        message = clock_message(seconds)
        target = round(seconds * 1e9)
        self.spin_until(lambda: self.node.get_clock().now().nanoseconds == target,
                        f"sim time {seconds}", before=lambda: self.clock.publish(message),
                        limit_s=limit_s)

    def shutdown(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.simulator.destroy_node()


class SensorWorld(SimTimeGraph):
    """A :class:`SimTimeGraph` whose simulator also publishes the robot's RFID, odometry and
    transforms."""

    def __init__(self, context: object) -> None:
        super().__init__(context)
        self.rfid = self.simulator.create_publisher(ActorNames, "/servicebot/rfid", 10)
        self.odom = self.simulator.create_publisher(Odometry, "/servicebot/odom", 10)
        self.tf = self.simulator.create_publisher(TFMessage, "/tf", 100)


# ============================================================================ fake servers
@dataclass
class Event:
    """Something a fake server saw, at the sim time the test had published last."""

    what: str
    sim_time: float
    detail: Any = None


@dataclass
class EventLog:
    """What the fake servers saw, in order; the test keeps ``sim_time`` up to date."""

    events: list[Event] = field(default_factory=list)
    sim_time: float = 0.0

    def add(self, what: str, detail: Any = None) -> None:
        self.events.append(Event(what, self.sim_time, detail))

    def named(self, what: str) -> list[Event]:
        return [event for event in self.events if event.what == what]


class FakeServer:
    """A fake's own node and the log it writes; spun by a graph (:meth:`ExecutiveGraph.serve`),
    by a :class:`ServerThread`, or not at all (a server that never answers)."""

    def __init__(self, context: object, node_name: str, log: EventLog | None = None) -> None:
        self.node = Node(node_name, context=context)
        self.log = log if log is not None else EventLog()
        self.stopping = False


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


class FakeNavigator(FakeServer):
    """A scripted NavigateToPose server at ``action``.

    Each goal (accepted while ``accept``) takes the next of ``outcomes``, or ``outcome`` once
    they are used up: ``steps`` feedbacks ``step_s`` apart (none when ``silent``), then
    ``succeed``, ``abort`` (a planner timeout), or ``hang`` until cancelled. A cancel request is
    granted. Goals are kept in ``goals``; each goal executed and each cancel request is logged.
    """

    def __init__(self, context: object, action: str, node_name: str | None = None, *,
                 log: EventLog | None = None) -> None:
        super().__init__(context, node_name or unique_name("navigator"), log)
        self.steps = 3
        self.step_s = 0.02
        self.outcome = "succeed"
        self.outcomes: list[str] = []
        self.accept = True
        self.goals: list[Any] = []
        self.cancel_requests = 0
        self.server = ActionServer(
            self.node, NavigateToPose, action,
            execute_callback=self.execute,
            goal_callback=self.on_goal,
            cancel_callback=self.on_cancel,
        )

    def on_goal(self, goal: Any) -> GoalResponse:
        self.goals.append(goal)
        return GoalResponse.ACCEPT if self.accept else GoalResponse.REJECT

    def on_cancel(self, handle: Any) -> CancelResponse:
        self.cancel_requests += 1
        self.log.add("cancel")
        return CancelResponse.ACCEPT

    def execute(self, handle: Any) -> Any:
        goal = handle.request.pose.pose
        self.log.add("goal", pose_from_msg(goal))
        outcome = self.outcomes.pop(0) if self.outcomes else self.outcome
        for remaining in range(self.steps, 0, -1):
            if self.stopping:
                return Result(error_msg="server shut down")
            if handle.is_cancel_requested:
                handle.canceled()
                return Result(error_msg="canceled")
            if outcome != "silent":
                feedback = NavigateToPose.Feedback(distance_remaining=float(remaining))
                feedback.current_pose.pose.position.x = goal.position.x - remaining
                handle.publish_feedback(feedback)
            time.sleep(self.step_s)
        while outcome == "hang" and not handle.is_cancel_requested and not self.stopping:
            time.sleep(0.005)
        if handle.is_cancel_requested:
            handle.canceled()
            return Result(error_msg="canceled")
        if outcome == "abort":
            handle.abort()
            return Result(error_code=Result.TIMEOUT, error_msg="planner timed out")
        handle.succeed()
        return Result(error_code=Result.NONE)

    def vanish(self) -> None:
        """The navigation stack dies mid-goal: its server goes without a last word."""
        self.server.destroy()
        self.stopping = True


class ServerThread:
    """Fake servers spun by a multi-threaded executor in a thread of their own, as a simulator
    serves: requests are answered whether or not the test is spinning."""

    def __init__(self, context: object, *servers: FakeServer, threads: int = 4) -> None:
        self.servers = servers
        self.executor = MultiThreadedExecutor(num_threads=threads, context=context)
        for server in servers:
            self.executor.add_node(server.node)
        self._turn = threading.Lock()
        """Held while the executor takes its next turn (builds its wait set and hands out
        what is ready): an entity destroyed meanwhile is one the wait set may still use."""
        self._stopped = threading.Event()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while not self._stopped.is_set():
            with self._turn:
                self.executor.spin_once(timeout_sec=0.05)

    def between_turns(self, change: Callable[[], None]) -> None:
        """``change`` the servers (destroy one) while the executor is between two turns."""
        with self._turn:
            change()

    def shutdown(self) -> None:
        for server in self.servers:
            server.stopping = True
        self._stopped.set()
        self.thread.join(timeout=5.0)
        self.executor.shutdown()
        for server in self.servers:
            server.node.destroy_node()


class FakeSimulator:
    """A :class:`FakeReferee` and a :class:`FakeNavigator` under ``namespace``, served from a
    thread of their own, writing one :class:`EventLog`."""

    def __init__(self, context: object, namespace: str = "", *, task: Task | None = None,
                 rooms: dict[str, Box] | None = None, move_base_clearing: bool = True) -> None:
        self.log = EventLog()
        self.referee = FakeReferee(context, unique_name("fake_referee"), namespace=namespace,
                                   rooms=rooms, task=task, log=self.log,
                                   move_base_clearing=move_base_clearing)
        self.navigator = FakeNavigator(context, f"{namespace}/servicebot/navigate_to_pose",
                                       log=self.log)
        self.navigator.steps = 0
        self.thread = ServerThread(context, self.referee, self.navigator)

    @property
    def events(self) -> list[Event]:
        return self.log.events

    def named(self, what: str) -> list[Event]:
        return self.log.named(what)

    def shutdown(self) -> None:
        self.thread.shutdown()


# ============================================================================ leaves
def ready(behaviour: Any, node: Node | None = None, **remappings: str) -> Any:
    """Ports remapped to the given blackboard keys; ROS set up on ``node`` if there is one."""
    behaviour.setup_ports(port_remappings=remappings)
    if node is not None:
        behaviour.setup(node=node)
    return behaviour


def wire(behaviour: Any, node: Any = None, **inputs: Any) -> Any:
    """Every port wired to ``/<port>``, set up on ``node`` if given, ``inputs`` put there."""
    ports = {**behaviour.input_ports(), **behaviour.output_ports()}
    behaviour.setup_ports(port_remappings={port: f"/{port}" for port in ports})
    if node is not None:
        behaviour.setup(node=node)
    for key, value in inputs.items():
        Blackboard.set(f"/{key}", value)
    return behaviour


# ============================================================================ maps and RFID
RESOLUTION = 0.05
RFID_RANGE = 2.0
SPEED = 0.5  # m/s, the robot's navigation limit
RFID_PERIOD = 0.1  # s between RFID messages


def grid_message(
    values: np.ndarray, resolution: float = RESOLUTION, origin: tuple[float, float] = (0.0, 0.0)
) -> OccupancyGrid:
    """A message whose row 0 lies at origin y, as the map topic has it."""
    message = OccupancyGrid()
    message.header.frame_id = "map"
    message.info.resolution = resolution
    message.info.height, message.info.width = values.shape
    message.info.origin.position.x, message.info.origin.position.y = origin
    message.data = values.astype(np.int8).ravel().tolist()
    return message


def cells(width_m: float, height_m: float) -> np.ndarray:
    """A free grid of ``width_m`` x ``height_m`` at :data:`RESOLUTION`."""
    return np.zeros((round(height_m / RESOLUTION), round(width_m / RESOLUTION)), dtype=np.int8)


def fill(values: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int = 100) -> None:
    """Mark the cells of the rectangle [x0, x1] x [y0, y1] (origin at 0, 0)."""
    values[round(y0 / RESOLUTION):round(y1 / RESOLUTION),
           round(x0 / RESOLUTION):round(x1 / RESOLUTION)] = value


def costmap_of(grid: OccupancyGrid2D, people: list[tuple[float, float]], *,
               stamp_s: float = 0.0) -> Costmap2D:
    """Navigation's costmap over ``grid`` as the simulator draws it: walls lethal, each person
    lethal within 0.3 m of their centre and inscribed (99) out to 0.55 m."""
    xs = grid.origin_x + (np.arange(grid.width) + 0.5) * grid.resolution
    ys = grid.origin_y + (np.arange(grid.height) + 0.5) * grid.resolution
    gx, gy = np.meshgrid(xs, ys)
    values = np.where(grid.values >= 100, 100, 0).astype(np.int8)
    for px, py in people:
        gap = np.hypot(gx - px, gy - py)
        values = np.where(gap <= 0.55, np.maximum(values, 99), values)
        values = np.where(gap <= 0.3, 100, values)
    return Costmap2D(values=values.astype(np.int8), origin_x=grid.origin_x,
                     origin_y=grid.origin_y, resolution=grid.resolution, stamp_s=stamp_s)


def open_room(size: float = 14.0) -> OccupancyGrid2D:
    """A square room with 0.1 m walls round it."""
    values = cells(size, size)
    for wall in ((0, 0, size, 0.1), (0, size - 0.1, size, size),
                 (0, 0, 0.1, size), (size - 0.1, 0, size, size)):
        fill(values, *wall)
    return OccupancyGrid2D.from_message(grid_message(values))


def drive(history: RfidHistory, path: list[tuple[float, float]], guest: tuple[float, float],
          *, start: float = 0.0, stop_on_hearing: bool = False) -> float:
    """Drive ``path`` (straight legs) at SPEED, hearing the guest within RFID_RANGE every
    RFID_PERIOD, as the simulator's sensor does; returns the time.

    With ``stop_on_hearing`` the drive ends at the first reading naming the guest, as
    exploration does."""
    now = start
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        steps = max(1, round(math.dist((x0, y0), (x1, y1)) / (SPEED * RFID_PERIOD)))
        for k in range(steps + 1):
            x, y = x0 + (x1 - x0) * k / steps, y0 + (y1 - y0) * k / steps
            heard = math.dist((x, y), guest) <= RFID_RANGE
            history.add(RfidReading(now, x, y, frozenset({GUEST, OTHER} if heard else {OTHER})))
            now += RFID_PERIOD
            if heard and stop_on_hearing:
                return now
    return now


def check_approach(goal: Pose2D | None, grid: OccupancyGrid2D, robot: Pose2D,
                   guest: tuple[float, float]) -> None:
    """The approach goal puts the robot within pick-up reach of the guest without crowding
    them, on free space it can reach, facing them."""
    assert goal is not None
    to_guest = math.dist((goal.x, goal.y), guest)
    assert 0.75 < to_guest <= 1.8, f"goal {goal} is {to_guest:.2f} m from the guest"
    assert grid.is_free(goal.x, goal.y, 0.35)
    assert grid.reachable_from(robot.x, robot.y, 0.35)[grid.world_to_cell(goal.x, goal.y)]
    facing = math.atan2(guest[1] - goal.y, guest[0] - goal.x)
    assert abs(math.remainder(goal.yaw - facing, 2.0 * math.pi)) < math.pi / 2.0


# ============================================================================ recorded runs
#: The errand tree: a sequence, a subtree with a fallback, a decorator, of scripted :class:`Step`
#: leaves; it runs to its end in a few ticks.
ERRAND_XML = """<root BTCPP_format="4" main_tree_to_execute="Errand">
  <BehaviorTree ID="Errand">
    <Sequence name="Errand" memory="true">
      <Step name="Approach" outcomes="RUNNING RUNNING SUCCESS" progress="{progress}"/>
      <SubTree ID="Deliver" name="Deliver" progress="{progress}"/>
      <Inverter name="NotDoneYet"><Step name="Check" outcomes="FAILURE"/></Inverter>
      <Step name="Linger" outcomes="RUNNING RUNNING RUNNING SUCCESS"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Deliver">
    <Fallback name="Deliver" memory="true">
      <Step name="Direct" outcomes="RUNNING FAILURE" progress="{progress}"/>
      <Step name="Detour" outcomes="RUNNING RUNNING SUCCESS" progress="{progress}"/>
    </Fallback>
  </BehaviorTree>
</root>
"""


class Step(BehaviourWithPorts, register=False):
    """Plays a list of outcomes, one per tick; writes its progress to the blackboard."""

    INPUT_PORTS: ClassVar[dict[str, PortInformation]] = {}
    OUTPUT_PORTS: ClassVar[dict[str, PortInformation]] = {
        "progress": PortInformation(data_type=str, required=False)}

    def __init__(self, name: str, outcomes: str = "SUCCESS", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.outcomes = [Status[word] for word in outcomes.split()]
        self.played = 0

    def initialise(self) -> None:
        self.played = 0

    def update(self) -> Status:
        outcome = self.outcomes[min(self.played, len(self.outcomes) - 1)]
        self.played += 1
        self.feedback_message = f"step {self.played} of {len(self.outcomes)}"
        self._set_output("progress", f"{self.name.rsplit('.', 1)[-1]} step {self.played}")
        return outcome


def errand_tree(tmp_path: Path) -> py_trees.trees.BehaviourTree:
    tree_file = tmp_path / "errand.xml"
    tree_file.write_text(ERRAND_XML)
    return py_trees.trees.BehaviourTree(
        parse_behaviour_tree_xml(str(tree_file), node_registry={"Step": Step}))


class RecordedRun:
    """The errand tree run to its end with a TreeLog, and the truth captured at every tick."""

    def __init__(self, tmp_path: Path) -> None:
        self.tree = errand_tree(tmp_path)
        self.sim_time_s = 100.0
        self.path = tmp_path / "tree_log.jsonl"
        self.log = TreeLog(tree=self.tree, path=self.path, sim_time_s=lambda: self.sim_time_s,
                           tree_file="errand.xml")
        self.tree.add_post_tick_handler(self.log)
        self.tree.add_post_tick_handler(self._capture)
        self.truth: dict[int, dict[str, NodeState]] = {}
        self.text: dict[int, str] = {}
        self.blackboard: dict[int, dict[str, Any]] = {}
        while self.tree.root.status not in (Status.SUCCESS, Status.FAILURE):
            self.tree.tick()
            self.sim_time_s += 0.1
        self.log.close()

    def _capture(self, tree: py_trees.trees.BehaviourTree) -> None:
        keys = TreeShape.of(tree.root).keys
        tick = tree.count + 1
        self.truth[tick] = {
            key: (behaviour.status, behaviour.feedback_message)
            for key, behaviour in zip(keys, walk(tree.root), strict=True)
        }
        self.text[tick] = tree_text(tree.root)
        self.blackboard[tick] = dict(py_trees.blackboard.Blackboard.storage)


# ============================================================================ commands
def run_module(module: str, *arguments: str, cwd: Path | None = None,
               timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """``python -m module arguments`` in ``cwd``, its output captured as text."""
    return subprocess.run([sys.executable, "-m", module, *arguments], capture_output=True,
                          text=True, cwd=cwd, timeout=timeout)
