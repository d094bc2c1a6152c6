"""The simulator node over real DDS: its services' answers and error answers, the referee's
account, /clock and the latched map, and the NavigateToPose action (success, abort, cancel)."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav2_msgs.action import NavigateToPose
from nav2_msgs.srv import ClearEntireCostmap
from nav_msgs.msg import OccupancyGrid
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from servicesim_competition.msg import RefereeState, Score
from servicesim_competition.srv import Drift, NewTask, PickUpGuest, RoomInfo, TaskInfo

from servicesim_sim.model.scenario import Difficulty
from servicesim_sim.navigation.costmap import PersonMark
from servicesim_sim.process.executor import DrainingExecutor
from servicesim_sim.ros.node import SimulatorNode
from servicesim_sim.ros.world_topics import GLOBAL_COSTMAP_TOPIC
from servicesim_sim.settings import SimSettings
from servicesim_sim.world.files import DEFAULT_WORLD, load_world

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


class Graph:
    """The simulator spinning in a thread, and a client node the test drives."""

    def __init__(self, context: Context, *, speed: float) -> None:
        settings = SimSettings(world=load_world(DEFAULT_WORLD), seed=None, speed=speed,
                               difficulty=Difficulty.default(), camera_rate_hz=0.0)
        self.sim_node = Node("servicesim", context=context)
        self.simulator = SimulatorNode(settings, node=self.sim_node)
        self.sim_executor = DrainingExecutor(context=context)
        self.sim_executor.add_node(self.sim_node)
        self.ended_by = "nothing"
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.client = Node("probe", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.client)
        self.thread.start()

    def _run(self) -> None:
        try:
            self.simulator.run(self.sim_executor)
        except Exception as error:  # the context shutting down ends the loop
            self.ended_by = repr(error)

    def account(self) -> str:
        """Whether the simulator's loop lives and how far it got: for a failing wait."""
        return (f"simulator loop {'alive' if self.thread.is_alive() else 'gone'} "
                f"(ended by {self.ended_by}) at sim time "
                f"{self.simulator.engine.sim_time:.1f} s, "
                f"{self.sim_executor.refused_sends} of its replies refused by DDS")

    def spin_until(self, done: Callable[[], bool], limit_s: float = 20.0) -> None:
        deadline = time.monotonic() + limit_s
        while not done():
            assert time.monotonic() < deadline, f"condition not reached in time; {self.account()}"
            self.executor.spin_once(timeout_sec=0.02)

    def call(self, kind: Any, name: str, request: Any) -> Any:
        client = self.client.create_client(kind, name)
        self.spin_until(client.service_is_ready)
        future = client.call_async(request)
        self.spin_until(future.done)
        return future.result()


@pytest.fixture
def graph(ros_context: Context) -> Iterator[Graph]:
    yield Graph(ros_context, speed=0.0)


def test_clock_runs_and_the_map_is_latched(graph: Graph) -> None:
    clocks: list[float] = []
    maps: list[OccupancyGrid] = []
    graph.client.create_subscription(
        Clock, "/clock", lambda m: clocks.append(m.clock.sec + m.clock.nanosec * 1e-9), 10)
    graph.client.create_subscription(OccupancyGrid, "/servicebot/map", maps.append, LATCHED)
    graph.spin_until(lambda: len(clocks) > 20 and bool(maps))
    assert clocks == sorted(clocks) and clocks[-1] > clocks[0]
    assert (maps[0].info.width, maps[0].info.height) == (1200, 1200)
    assert maps[0].info.resolution == pytest.approx(0.05)


def test_room_info_answers_a_box_or_the_zero_box_for_an_unknown_room(graph: Graph) -> None:
    known = graph.call(RoomInfo, "/servicesim/room_info", RoomInfo.Request(name="FrontElevator"))
    assert (known.min.x, known.min.y, known.max.x, known.max.y) == (-1.5, 0.0, 1.5, 2.7)
    unknown = graph.call(RoomInfo, "/servicesim/room_info", RoomInfo.Request(name="Attic"))
    assert (unknown.min.x, unknown.min.y, unknown.max.x, unknown.max.y) == (0.0, 0.0, 0.0, 0.0)


def test_task_info_new_task_and_a_second_new_task(graph: Graph) -> None:
    before = graph.call(TaskInfo, "/servicesim/task_info", TaskInfo.Request())
    assert before.pick_up_location == ""  # the error answer: no task yet
    task = graph.call(NewTask, "/servicesim/new_task", NewTask.Request())
    assert (task.pick_up_location, task.drop_off_location, task.guest_name) == (
        "FrontElevator", "PrivateCubicle_32_1", "human_20843")
    assert (task.robot_start_pose.position.x, task.robot_start_pose.position.y) == (10.975, 3.75)
    again = graph.call(NewTask, "/servicesim/new_task", NewTask.Request())
    assert again.pick_up_location == ""
    info = graph.call(TaskInfo, "/servicesim/task_info", TaskInfo.Request())
    assert info.guest_name == "human_20843"
    referee = graph.simulator.engine.referee
    referee.running, referee.completed = False, True  # as if checkpoint 4 were reached
    after = graph.call(TaskInfo, "/servicesim/task_info", TaskInfo.Request())
    assert after.guest_name == ""  # the error answer: the task has completed
    once_more = graph.call(NewTask, "/servicesim/new_task", NewTask.Request())
    assert once_more.pick_up_location == ""  # one task per simulator run


def test_a_refused_pickup_is_booked_and_the_score_runs_with_the_task(graph: Graph) -> None:
    scores: list[float] = []
    states: list[RefereeState] = []
    graph.client.create_subscription(Score, "/servicesim/score",
                                     lambda m: scores.append(m.score), 10)
    graph.client.create_subscription(RefereeState, "/servicesim/referee", states.append, LATCHED)
    graph.spin_until(lambda: bool(states))
    assert not scores  # no task, no score
    graph.call(NewTask, "/servicesim/new_task", NewTask.Request())
    answer = graph.call(PickUpGuest, "/servicesim/pickup_guest",
                        PickUpGuest.Request(guest_name="human_20843", robot_name="servicebot"))
    assert answer.success is False  # before checkpoint 1
    graph.spin_until(lambda: states[-1].failed_pickups == 1 and len(scores) > 10)
    assert scores[-1] >= 40.0
    drift = graph.call(Drift, "/servicesim/drift", Drift.Request())
    assert drift.drift is True  # armed even with nobody following, as the original


NAV2_CLEARING = ("/servicebot/global_costmap/clear_entirely_global_costmap",
                 "/servicebot/local_costmap/clear_entirely_local_costmap")


def mark_someone_behind_the_robot(graph: Graph) -> PersonMark:
    """A person mark 2 m behind the robot, out of the lidar's view, so no sweep clears it: set
    (from this thread, while the loop runs) until it is seen to stay."""
    costmap = graph.simulator.engine.navigator.costmap
    x, y, yaw = graph.simulator.engine.robot_pose()
    mark = PersonMark(x - 2.0 * math.cos(yaw), y - 2.0 * math.sin(yaw), seen_at=-1.0)
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline:
        costmap.marks = (*costmap.marks, mark)
        costmap.version += 1  # as a sweep's new mark does: the combined grid is built anew
        time.sleep(0.1)
        if mark in costmap.marks:
            return mark
    raise AssertionError("the mark never stayed in the costmap")


def test_nav2s_two_clearing_services_are_served_through_the_gate_and_forget_the_people(
        graph: Graph) -> None:
    graph.spin_until(lambda: all(
        (name, ["nav2_msgs/srv/ClearEntireCostmap"]) in graph.client.get_service_names_and_types()
        for name in NAV2_CLEARING))
    assert set(NAV2_CLEARING) <= graph.simulator.lockstep.served  # counted and gated
    costmap = graph.simulator.engine.navigator.costmap
    for service in NAV2_CLEARING:
        mark = mark_someone_behind_the_robot(graph)
        answer = graph.call(ClearEntireCostmap, service, ClearEntireCostmap.Request())
        assert isinstance(answer, ClearEntireCostmap.Response)
        assert mark not in costmap.marks, f"{service} left the mark"


def navigate(graph: Graph, x: float, y: float, *, cancel_after_s: float | None = None) -> Any:
    client = ActionClient(graph.client, NavigateToPose, "/servicebot/navigate_to_pose")
    graph.spin_until(client.server_is_ready)
    goal = NavigateToPose.Goal()
    goal.pose.header.frame_id = "map"
    goal.pose.pose.position.x, goal.pose.pose.position.y = x, y
    goal.pose.pose.orientation.w = 1.0
    sent = client.send_goal_async(goal)
    graph.spin_until(sent.done)
    handle = sent.result()
    assert handle.accepted
    if cancel_after_s is not None:
        started = time.monotonic()
        graph.spin_until(lambda: time.monotonic() - started > cancel_after_s)
        handle.cancel_goal_async()
    result = handle.get_result_async()
    graph.spin_until(result.done, limit_s=60.0)
    return result.result()


def localise(graph: Graph) -> None:
    publisher = graph.client.create_publisher(PoseWithCovarianceStamped,
                                              "/servicebot/initialpose", LATCHED)
    message = PoseWithCovarianceStamped()
    message.header.frame_id = "map"
    message.pose.pose.position.x, message.pose.pose.position.y = 10.975, 3.75
    message.pose.pose.orientation.z, message.pose.pose.orientation.w = math.sin(1.57), math.cos(
        1.57)
    publisher.publish(message)
    started = time.monotonic()
    graph.spin_until(lambda: time.monotonic() - started > 0.5)


def test_a_goal_before_an_initial_pose_is_taken_on_amcls_launch_pose(graph: Graph) -> None:
    # a metre ahead of the launch pose (-24.469, 6.278, 0.15): a metre ahead of the robot
    outcome = navigate(graph, -23.48, 6.43, cancel_after_s=0.5)
    assert outcome.status == GoalStatus.STATUS_CANCELED  # running, not refused with TF_ERROR


def test_navigation_succeeds_aborts_without_a_path_and_cancels(graph: Graph) -> None:
    localise(graph)
    reached = navigate(graph, 9.5, 3.75)
    assert reached.status == GoalStatus.STATUS_SUCCEEDED
    assert reached.result.error_code == NavigateToPose.Result.NONE
    walled = navigate(graph, -29.0, -29.0)  # outside the building: unknown space
    assert walled.status == GoalStatus.STATUS_ABORTED
    assert walled.result.error_code != 0 and walled.result.error_msg
    cancelled = navigate(graph, -20.0, 10.0, cancel_after_s=0.3)
    assert cancelled.status == GoalStatus.STATUS_CANCELED


def test_a_message_dds_refuses_is_dropped_with_a_warning_and_the_loop_goes_on(
        ros_context: Context) -> None:
    from servicesim_sim.ros.publishing import RCLError

    settings = SimSettings(world=load_world(DEFAULT_WORLD), seed=None, speed=0.0,
                           difficulty=Difficulty.default(), camera_rate_hz=0.0)
    node = Node("servicesim_refused", context=ros_context)
    simulator = SimulatorNode(settings, node=node)

    class Refusing:
        topic_name = "/servicesim/actors"

        def publish(self, message: Any) -> None:
            raise RCLError("Failed to publish: cannot publish data")

    simulator.world_topics.actors = Refusing()
    for _ in range(15):
        simulator._publish_io()  # the people go out every fifth period
    assert simulator.publishing.dropped == 3
    node.destroy_node()


def test_the_global_costmap_is_published_once_a_sim_second_with_the_people_marked(
        graph: Graph) -> None:
    costmaps: list[OccupancyGrid] = []
    graph.client.create_subscription(OccupancyGrid, GLOBAL_COSTMAP_TOPIC, costmaps.append, LATCHED)
    graph.spin_until(lambda: bool(costmaps))
    mark = mark_someone_behind_the_robot(graph)
    frame = graph.simulator.engine.navigator.costmap.frame
    row, col = frame.cell_of(mark.x, mark.y)

    def marked(message: OccupancyGrid) -> bool:
        return message.data[row * message.info.width + col] == 100

    graph.spin_until(lambda: len(costmaps) >= 3 and marked(costmaps[-1]))
    message = costmaps[-1]
    assert message.header.frame_id == "map"
    assert (message.info.width, message.info.height) == (frame.cols, frame.rows)
    assert (message.info.origin.position.x, message.info.origin.position.y) == (
        pytest.approx(frame.origin_x), pytest.approx(frame.origin_y))
    assert message.info.resolution == pytest.approx(frame.resolution)
    # a metre from the mark, in the corridor the robot starts in, the floor is free
    free_row, free_col = frame.cell_of(mark.x, mark.y + 1.0)
    assert message.data[free_row * message.info.width + free_col] < 99
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in costmaps[-3:]]
    assert np.diff(stamps) == pytest.approx([1.0, 1.0])

