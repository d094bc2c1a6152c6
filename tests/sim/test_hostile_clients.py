"""The simulator survives hostile and heavy clients, so that no executive under test can bring
it down: every request is answered, nothing crashes it, and a goal it cannot execute is aborted
the way Nav2 aborts it.

Over real DDS, a simulator node looping in a thread of the test process: goals at 1e308, inf
and nan; goals in frames other than ``map``, with a zero quaternion; a burst of 200 goals and
one of 1000 ``room_info`` requests. Bursts are checked by how many answers arrive within a
generous wall-time bound, never by how fast. Below them, the pieces that make it so, without
ROS: goals brought into ``map`` or refused, the planner and the robot fed absurd numbers, and
the executor's drain serving a whole burst in one go without starving the loop.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import rclpy
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from servicesim_competition.srv import RoomInfo
from std_srvs.srv import Empty

from bt_servicesim.ros.environment import delete_participant
from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.scenario import Difficulty, make_scenario
from servicesim_sim.navigation.goals import GoalPose, GoalRefusal, goal_in_map, yaw_of
from servicesim_sim.navigation.navigator import NavigateToPoseError
from servicesim_sim.navigation.planner import ComputePathToPoseError
from servicesim_sim.process.executor import DrainingExecutor
from servicesim_sim.ros.node import SimulatorNode
from servicesim_sim.settings import SimSettings
from servicesim_sim.world.files import DEFAULT_WORLD, World, load_world

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: The probe's own replies must not be cut to the newest ten either: a client's reply reader
#: keeps only its depth, whatever the server sends.
DEEP = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10_000,
                  reliability=ReliabilityPolicy.RELIABLE)
START = (10.975, 3.75, 3.14)  # the shipped task's start pose, in PublicBathroomB
REACHABLE = (10.3, 3.75)  # 0.7 m along the bathroom from the start
FRONT_ELEVATOR = (-1.5, 0.0, 1.5, 2.7)
BURST_WAIT_S = 60.0  # a generous bound on waiting for a burst's answers; not a benchmark
ABORTED, SUCCEEDED = GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_SUCCEEDED


@pytest.fixture(scope="module")
def office() -> World:
    return load_world(DEFAULT_WORLD)


class Graph:
    """A simulator node looping in a thread, and a probe node the test spins.

    The probe has a context (a DDS participant) of its own, as a client in another process
    would: on one shared participant its action client once saw the server's three services
    on the graph but never became ready in 30 s under the suite's load.
    """

    def __init__(self, context: Context, world: World) -> None:
        settings = SimSettings(world=world, seed=None, speed=0.0,
                               difficulty=Difficulty.default(), camera_rate_hz=0.0)
        self.sim_node = Node("servicesim", context=context)
        self.simulator = SimulatorNode(settings, node=self.sim_node)
        self.sim_executor = DrainingExecutor(context=context)
        self.sim_executor.add_node(self.sim_node)
        self.crashed: list[BaseException] = []
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.probe_context = Context()
        rclpy.init(context=self.probe_context)
        self.probe = Node("probe", context=self.probe_context)
        self.executor = SingleThreadedExecutor(context=self.probe_context)
        self.executor.add_node(self.probe)
        self.rooms = self.probe.create_client(RoomInfo, "/servicesim/room_info",
                                              qos_profile=DEEP)
        self.navigation = ActionClient(
            self.probe, NavigateToPose, "/servicebot/navigate_to_pose",
            goal_service_qos_profile=DEEP, result_service_qos_profile=DEEP,
            cancel_service_qos_profile=DEEP)
        self.thread.start()

    def _run(self) -> None:
        try:
            self.simulator.run(self.sim_executor)
        except Exception as error:  # the context shutting down ends the loop, too
            if self.sim_node.context.ok():
                self.crashed.append(error)

    def alive(self) -> bool:
        return self.thread.is_alive() and not self.crashed

    def spin_until(self, done: Callable[[], bool], limit_s: float = 30.0) -> bool:
        """Spin the probe until ``done()`` or ``limit_s`` wall seconds; whether it is done."""
        deadline = time.monotonic() + limit_s
        while not done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return done()

    def localise(self) -> None:
        publisher = self.probe.create_publisher(PoseWithCovarianceStamped,
                                                "/servicebot/initialpose", LATCHED)
        message = PoseWithCovarianceStamped()
        message.header.frame_id = "map"
        message.pose.pose.position.x, message.pose.pose.position.y = START[:2]
        message.pose.pose.orientation.z = math.sin(START[2] / 2.0)
        message.pose.pose.orientation.w = math.cos(START[2] / 2.0)
        publisher.publish(message)
        assert self.spin_until(lambda: self.simulator.engine._localised)

    def room(self, name: str) -> tuple[float, float, float, float] | None:
        """The box ``room_info`` answers for ``name``; None when no answer came."""
        assert self.spin_until(self.rooms.service_is_ready)
        future = self.rooms.call_async(RoomInfo.Request(name=name))
        if not self.spin_until(future.done, 10.0):
            return None
        answer = future.result()
        return answer.min.x, answer.min.y, answer.max.x, answer.max.y

    def send(self, goal: NavigateToPose.Goal) -> Future:
        """Send a goal; the future's result is the goal's (status, result) once it ends."""
        outcome = Future()

        def on_answer(sent: Future) -> None:
            handle = sent.result()
            if not handle.accepted:
                outcome.set_result((GoalStatus.STATUS_UNKNOWN, None))
                return
            handle.get_result_async().add_done_callback(
                lambda done: outcome.set_result((done.result().status, done.result().result)))

        self.navigation.send_goal_async(goal).add_done_callback(on_answer)
        return outcome

    def navigate(self, goal: NavigateToPose.Goal, limit_s: float = 60.0) -> tuple[int, Any]:
        assert self.spin_until(self.navigation.server_is_ready), self.account()
        outcome = self.send(goal)
        assert self.spin_until(outcome.done, limit_s), f"the goal got no result; {self.account()}"
        return outcome.result()

    def account(self) -> str:
        """What the probe sees of the graph and whether the simulator's loop lives: for a
        failing assertion's message."""
        services = [name for name, _ in self.probe.get_service_names_and_types()
                    if "navigate_to_pose" in name]
        topics = {kind: self.probe.count_publishers(f"/servicebot/navigate_to_pose/_action/{kind}")
                  for kind in ("feedback", "status")}
        return (f"the probe sees {services or 'no navigation services'} and publishers of "
                f"{topics}; simulator loop "
                f"{'alive' if self.alive() else f'gone: {self.crashed}'} at sim time "
                f"{self.simulator.engine.sim_time:.1f} s, "
                f"{self.sim_executor.refused_sends} of its replies refused by DDS")

    def shutdown(self) -> None:
        self.executor.shutdown()
        delete_participant(self.probe_context)  # the probe's action client with it


@pytest.fixture
def graph(ros_context: Context, office: World) -> Iterator[Graph]:
    graph = Graph(ros_context, office)
    yield graph
    graph.shutdown()


def goal(x: float, y: float, *, frame: str = "map", yaw: float = 0.0,
         quaternion: tuple[float, float, float, float] | None = None) -> NavigateToPose.Goal:
    message = NavigateToPose.Goal()
    message.pose.header.frame_id = frame
    message.pose.pose.position.x, message.pose.pose.position.y = x, y
    qx, qy, qz, qw = quaternion or (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))
    orientation = message.pose.pose.orientation
    orientation.x, orientation.y, orientation.z, orientation.w = qx, qy, qz, qw
    return message


# ------------------------------------------------------------------ goals it cannot execute
@pytest.mark.parametrize("where", [(1e308, 1e308), (math.inf, 3.75), (9.5, -math.inf),
                                   (math.nan, math.nan), (100.0, 100.0)],
                         ids=["1e308", "inf", "minus-inf", "nan", "off-the-map"])
def test_an_impossible_goal_is_aborted_and_the_simulator_answers_on(
        graph: Graph, where: tuple[float, float]) -> None:
    graph.localise()  # unlocalised, every goal aborts before it reaches the planner
    status, result = graph.navigate(goal(*where))
    assert status == ABORTED
    assert result.error_code == NavigateToPose.Result.UNKNOWN
    assert "not finite" in result.error_msg or "outside the map" in result.error_msg
    time.sleep(0.5)  # a crash in the loop would show within a few periods
    assert graph.alive(), graph.crashed
    assert graph.room("FrontElevator") == FRONT_ELEVATOR
    status, result = graph.navigate(goal(*REACHABLE, yaw=START[2]))
    assert (status, result.error_code) == (SUCCEEDED, NavigateToPose.Result.NONE)


@pytest.mark.parametrize("frame", ["", "base_link", "Map"])
def test_a_goal_in_a_frame_with_no_transform_to_map_aborts_with_tf_error(
        graph: Graph, frame: str) -> None:
    graph.localise()
    status, result = graph.navigate(goal(*REACHABLE, frame=frame))
    assert (status, result.error_code) == (ABORTED, NavigateToPose.Result.TF_ERROR)
    assert repr(frame) in result.error_msg and "'map'" in result.error_msg
    assert graph.simulator.engine.navigator.status == "idle"  # it never started


@pytest.mark.parametrize("quaternion", [(0.0, 0.0, 0.0, 0.0), (0.0, 0.0, math.nan, 1.0),
                                        (math.inf, 0.0, 0.0, 1.0)],
                         ids=["zero", "nan", "inf"])
def test_a_goal_with_an_invalid_orientation_aborts(
        graph: Graph, quaternion: tuple[float, float, float, float]) -> None:
    graph.localise()
    status, result = graph.navigate(goal(*REACHABLE, quaternion=quaternion))
    assert (status, result.error_code) == (ABORTED, NavigateToPose.Result.UNKNOWN)
    assert "invalid orientation" in result.error_msg


def test_a_goal_in_odom_goes_through_the_map_to_odom_transform(graph: Graph) -> None:
    # odometry starts at zero at the spawn pose: odom's origin is the start, facing west
    graph.localise()
    ahead = START[0] - REACHABLE[0]  # REACHABLE lies straight ahead of the start pose
    status, result = graph.navigate(goal(ahead, 0.0, frame="odom", yaw=0.0))
    assert (status, result.error_code) == (SUCCEEDED, NavigateToPose.Result.NONE)
    x, y, yaw = graph.simulator.engine.robot_pose()
    assert math.dist((x, y), REACHABLE) <= 0.3  # the goal tolerance, around the map point
    assert abs(math.remainder(yaw - START[2], 2.0 * math.pi)) <= 0.262  # facing west still


# ------------------------------------------------------------------ bursts
def test_each_of_200_goals_sent_back_to_back_gets_a_result(graph: Graph) -> None:
    graph.localise()
    assert graph.spin_until(graph.navigation.server_is_ready)
    outcomes = [graph.send(goal(*START[:2], yaw=START[2])) for _ in range(200)]
    graph.spin_until(lambda: all(outcome.done() for outcome in outcomes), BURST_WAIT_S)
    ended = [outcome.result() for outcome in outcomes if outcome.done()]
    assert len(ended) == 200, f"{len(ended)} of 200 goals got a result"
    assert ended[-1][0] == SUCCEEDED  # the last one ran to the end
    for status, result in ended[:-1]:  # the others were preempted, unless done before that
        assert status in (SUCCEEDED, ABORTED)
        assert status == SUCCEEDED or (result.error_code == NavigateToPose.Result.UNKNOWN
                                       and "preempted" in result.error_msg)
    assert graph.alive(), graph.crashed


def test_each_of_1000_room_info_requests_sent_at_once_gets_an_answer(graph: Graph) -> None:
    assert graph.spin_until(graph.rooms.service_is_ready)
    futures = [graph.rooms.call_async(RoomInfo.Request(name="FrontElevator"))
               for _ in range(1000)]
    graph.spin_until(lambda: all(future.done() for future in futures), BURST_WAIT_S)
    answers = [future.result() for future in futures if future.done()]
    assert len(answers) == 1000, f"{len(answers)} of 1000 requests answered"
    assert all((a.min.x, a.min.y, a.max.x, a.max.y) == FRONT_ELEVATOR for a in answers)


# ------------------------------------------------------------------ goals into map, no ROS
MAP_EXTENT = (-30.0, -30.0, 30.0, 30.0)
IDENTITY = (0.0, 0.0, 0.0)


def in_map(frame: str, x: float, y: float, quaternion: tuple[float, float, float, float], *,
           map_to_odom: tuple[float, float, float] = IDENTITY) -> Any:
    return goal_in_map(GoalPose(frame, (x, y, 0.0), quaternion), map_extent=MAP_EXTENT,
                       map_to_odom=map_to_odom)


def test_goals_are_brought_into_map_or_refused_with_nav2s_codes() -> None:
    level = (0.0, 0.0, 0.0, 1.0)
    assert in_map("map", 1.0, 2.0, level) == (1.0, 2.0, 0.0)
    turned = in_map("odom", 1.0, 0.0, level, map_to_odom=(2.0, 3.0, math.pi / 2))
    assert turned == pytest.approx((2.0, 4.0, math.pi / 2))
    refusals = {
        "frame": in_map("laser", 1.0, 2.0, level),
        "empty frame": in_map("", 1.0, 2.0, level),
        "position": in_map("map", math.nan, 2.0, level),
        "orientation": in_map("map", 1.0, 2.0, (0.0, 0.0, 0.0, 0.0)),
        "off the map": in_map("map", 1e308, 1e308, level),
        "odom off the map": in_map("odom", 29.0, 0.0, level, map_to_odom=(2.0, 0.0, 0.0)),
    }
    assert all(isinstance(refusal, GoalRefusal) for refusal in refusals.values())
    codes = {name: refusal.error_code for name, refusal in refusals.items()}
    assert codes == {"frame": NavigateToPoseError.TF_ERROR,
                     "empty frame": NavigateToPoseError.TF_ERROR,
                     "position": NavigateToPoseError.UNKNOWN,
                     "orientation": NavigateToPoseError.UNKNOWN,
                     "off the map": NavigateToPoseError.UNKNOWN,
                     "odom off the map": NavigateToPoseError.UNKNOWN}
    assert "'laser'" in refusals["frame"].error_msg
    assert "''" in refusals["empty frame"].error_msg


def test_a_quaternion_not_normalised_is_normalised() -> None:
    assert yaw_of((0.0, 0.0, 3.0, 3.0)) == pytest.approx(math.pi / 2)
    assert yaw_of((0.0, 0.0, 1e300, 1e300)) == pytest.approx(math.pi / 2)  # no overflow
    assert in_map("map", 1.0, 2.0, (0.0, 0.0, 0.0, 5.0)) == (1.0, 2.0, 0.0)


# ------------------------------------------------------------------ the engine, no ROS
def test_the_planner_and_navigator_refuse_goals_no_cell_can_hold(office: World) -> None:
    engine = SimEngine(world=office, scenario=make_scenario(office))
    planner = engine.navigator.planner
    for far in (1e308, -1e308, math.inf, math.nan):
        result = planner.plan(START[:2], (far, far))
        assert result.error_code == ComputePathToPoseError.GOAL_OUTSIDE_MAP
        assert planner.length_bound(START[:2], (far, far)) == 0.0
    engine.set_initial_pose(*START)
    engine.navigate(1e308, 1e308, 0.0)  # the engine's own callers are not checked upstream
    for _ in range(10):
        engine.step()
    assert engine.navigator.status == "aborted"


def test_a_non_finite_velocity_command_stops_the_robot(office: World) -> None:
    engine = SimEngine(world=office, scenario=make_scenario(office))
    before = engine.robot_pose()
    engine.command_velocity(math.nan, math.nan)
    for _ in range(10):
        engine.step()
    assert engine.robot_pose() == before
    assert engine.odometry_pose() == (0.0, 0.0, 0.0)


# ------------------------------------------------------------------ the executor's drain
class Pinged:
    """A node with an ``Empty`` service on a draining executor, and a client to flood it."""

    def __init__(self, context: Context, *, drain_budget_s: float = 0.05,
                 answer: Callable[[], None] = lambda: None) -> None:
        self.node = Node("drained", context=context)
        self.executor = DrainingExecutor(context=context, drain_budget_s=drain_budget_s)
        self.executor.add_node(self.node)
        self.calls = 0

        def on_request(request: Empty.Request, response: Empty.Response) -> Empty.Response:
            self.calls += 1
            answer()
            return response

        self.node.create_service(Empty, "/hostile_test/ping", on_request, qos_profile=DEEP)
        self.client_node = Node("flooder", context=context)
        self.client_executor = SingleThreadedExecutor(context=context)
        self.client_executor.add_node(self.client_node)
        self.client = self.client_node.create_client(Empty, "/hostile_test/ping",
                                                     qos_profile=DEEP)
        assert self.client.wait_for_service(timeout_sec=10.0)
        self.executor.run_ready()  # whatever discovery left behind

    def flood(self, count: int) -> list[Future]:
        """``count`` requests, given time to arrive before anyone takes them."""
        futures = [self.client.call_async(Empty.Request()) for _ in range(count)]
        time.sleep(0.5)
        return futures

    def drains_until(self, calls: int, limit_s: float = 30.0) -> int:
        """Drain (as the loop does once per I/O period) until ``calls`` requests were served;
        how many drains that took. Requests still on their way make it take more."""
        drains, deadline = 0, time.monotonic() + limit_s
        while self.calls < calls and time.monotonic() < deadline:
            self.executor.run_ready()
            drains += 1
            time.sleep(0.01)
        assert self.calls == calls
        return drains

    def close(self) -> None:
        """Both executors shut down and both nodes destroyed, before the test's context is:
        an executor left to the garbage collector warns once the context is gone."""
        self.executor.shutdown()
        self.client_executor.shutdown()
        self.client_node.destroy_node()
        self.node.destroy_node()


@pytest.fixture
def pinged(ros_context: Context) -> Iterator[Callable[..., Pinged]]:
    """Makes :class:`Pinged` nodes on the test's context; each is closed after the test, pass
    or fail, before the context is shut down."""
    made: list[Pinged] = []

    def make(**kwargs: Any) -> Pinged:
        made.append(Pinged(ros_context, **kwargs))
        return made[-1]

    yield make
    for each in made:
        each.close()


def test_one_drain_answers_every_waiting_request(pinged: Callable[..., Pinged]) -> None:
    drained = pinged(drain_budget_s=30.0)  # only "nothing left" ends a drain
    drained.flood(50)
    assert drained.drains_until(50) <= 5  # one, unless some were still on their way (was 50)


def test_a_flood_is_served_over_several_drains_without_stopping_the_loop(
        pinged: Callable[..., Pinged]) -> None:
    drained = pinged(drain_budget_s=0.05, answer=lambda: time.sleep(0.01))
    drained.flood(30)
    drained.executor.run_ready()
    assert 1 <= drained.calls < 30  # the budget ended the drain: the loop steps on
    drained.drains_until(30)


def test_a_reply_dds_refuses_costs_that_reply_not_the_simulator(
        pinged: Callable[..., Pinged]) -> None:
    from servicesim_sim.process.executor import RCLError

    def refuse() -> None:
        raise RCLError("failed to send response: cannot publish data")

    drained = pinged(answer=refuse)
    drained.flood(3)
    drained.drains_until(3)  # the error was raised out of the loop before
    assert drained.executor.refused_sends == 3
