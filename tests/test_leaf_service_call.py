"""Service-call leaves against real in-process servers over DDS.

The client side is a plain node on system time, so the time limits are small real durations;
the behaviours are ticked directly while the executor spins, as a tree would tick them.
"""

from __future__ import annotations

import textwrap
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import py_trees
import pytest
from py_trees.blackboard import Blackboard
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from servicesim_competition.srv import DropOffGuest as DropOffGuestSrv
from servicesim_competition.srv import NewTask as NewTaskSrv
from servicesim_competition.srv import PickUpGuest as PickUpGuestSrv
from servicesim_competition.srv import RoomInfo as RoomInfoSrv
from servicesim_competition.srv import TaskInfo as TaskInfoSrv
from std_srvs.srv import Empty

import bt_servicesim.ros.sim_clock  # noqa: F401  (registers SimTimeout/SimWait for the XML test)
from bt_servicesim.behaviours.actions.clear_costmaps import ClearCostmaps
from bt_servicesim.behaviours.actions.guest_services import DropOffGuest, PickUpGuest
from bt_servicesim.behaviours.actions.room_info import RoomInfo
from bt_servicesim.behaviours.actions.service_call import ServiceCall
from bt_servicesim.behaviours.actions.task import NewTask, TaskInfo
from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.ros.messages import pose_to_msg

Status = py_trees.common.Status

ROOMS = {"FrontElevator": Box(-1.5, 0.0, 1.5, 2.7), "PublicCafe": Box(5.0, 6.0, 8.0, 9.0)}


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    Blackboard.clear()
    yield
    Blackboard.clear()


class Referee:
    """A fake referee: the services the leaves call, on a node of its own."""

    def __init__(self, context: object, node_name: str = "referee") -> None:
        self.node = Node(node_name, context=context)
        self.requests: list[Any] = []
        self.task_running = False
        self.pickup_ok = True
        self.node.create_service(NewTaskSrv, "/servicesim/new_task", self.new_task)
        self.node.create_service(TaskInfoSrv, "/referee/task_info", self.new_task)
        self.node.create_service(RoomInfoSrv, "/servicesim/room_info", self.room_info)
        self.node.create_service(PickUpGuestSrv, "/servicesim/pickup_guest", self.pickup)
        self.node.create_service(DropOffGuestSrv, "/servicesim/dropoff_guest", self.dropoff)
        self.node.create_service(Empty, "/servicebot/move_base/clear_costmaps", self.clear)

    def new_task(self, request: Any, response: Any) -> Any:
        self.requests.append(request)
        if self.task_running:
            return response  # the error answer: everything empty
        self.task_running = True
        response.pick_up_location, response.drop_off_location = "FrontElevator", "PublicCafe"
        response.guest_name = "human_20843"
        response.robot_start_pose = pose_to_msg(Pose2D(10.975, 3.75, 3.14))
        return response

    def room_info(self, request: Any, response: Any) -> Any:
        self.requests.append(request)
        box = ROOMS.get(request.name)
        if box is not None:
            response.min.x, response.min.y = box.min_x, box.min_y
            response.max.x, response.max.y = box.max_x, box.max_y
        return response

    def pickup(self, request: Any, response: Any) -> Any:
        self.requests.append(request)
        response.success = self.pickup_ok and request.robot_name == "servicebot"
        return response

    def dropoff(self, request: Any, response: Any) -> Any:
        self.requests.append(request)
        response.success = request.guest_name == "human_20843"
        return response

    def clear(self, request: Any, response: Any) -> Any:
        self.requests.append(request)
        return response


class Graph:
    """A client node and an executor; servers join with :meth:`serve`."""

    def __init__(self, context: object) -> None:
        self.context = context
        self.node = Node("executive", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.referees: list[Referee] = []

    def serve(self, referee: Referee) -> Referee:
        self.executor.add_node(referee.node)
        self.referees.append(referee)
        return referee

    def tick_until_done(
        self, behaviour: py_trees.behaviour.Behaviour, limit_s: float = 10.0
    ) -> Status:
        deadline = time.monotonic() + limit_s
        while True:
            behaviour.tick_once()
            if behaviour.status != Status.RUNNING:
                return behaviour.status
            assert time.monotonic() < deadline, f"still RUNNING: {behaviour.feedback_message}"
            self.executor.spin_once(timeout_sec=0.01)

    def spin_until(self, done: Callable[[], bool], limit_s: float = 10.0) -> None:
        deadline = time.monotonic() + limit_s
        while not done():
            assert time.monotonic() < deadline, "condition not reached"
            self.executor.spin_once(timeout_sec=0.01)


@pytest.fixture
def graph(ros_context: object) -> Iterator[Graph]:
    graph = Graph(ros_context)
    yield graph
    graph.executor.shutdown()
    for node in [graph.node, *(referee.node for referee in graph.referees)]:
        node.destroy_node()


def ready(behaviour: ServiceCall, graph: Graph, **remappings: str) -> ServiceCall:
    """Ports wired to the given absolute blackboard keys, ROS set up on the graph's node."""
    behaviour.setup_ports(port_remappings=remappings)
    behaviour.setup(node=graph.node)
    return behaviour


def task_ports() -> dict[str, str]:
    return {port: f"/{port}" for port in NewTask.output_ports()}


def test_new_task_writes_the_task_to_its_outputs(graph: Graph, ros_context: object) -> None:
    graph.serve(Referee(ros_context))
    new_task = ready(NewTask(name="new_task"), graph, **task_ports())
    assert graph.tick_until_done(new_task) == Status.SUCCESS
    assert Blackboard.get("/pick_up_location") == "FrontElevator"
    assert Blackboard.get("/drop_off_location") == "PublicCafe"
    assert Blackboard.get("/guest_name") == "human_20843"
    start = Blackboard.get("/start_pose")
    assert (start.x, start.y, start.yaw) == pytest.approx((10.975, 3.75, 3.14))
    assert "human_20843" in new_task.feedback_message


def test_new_task_error_answer_is_a_failure(graph: Graph, ros_context: object) -> None:
    referee = graph.serve(Referee(ros_context))
    referee.task_running = True
    new_task = ready(NewTask(name="new_task"), graph, **task_ports())
    assert graph.tick_until_done(new_task) == Status.FAILURE
    assert "error answer" in new_task.feedback_message
    assert not Blackboard.exists("/pick_up_location")


def test_task_info_reads_the_task_under_another_service_name(
    graph: Graph, ros_context: object
) -> None:
    graph.serve(Referee(ros_context))
    task_info = ready(
        TaskInfo(name="task_info", service="/referee/task_info"), graph, **task_ports()
    )
    assert task_info.service == "/referee/task_info"
    assert graph.tick_until_done(task_info) == Status.SUCCESS
    assert Blackboard.get("/guest_name") == "human_20843"


def test_room_info_writes_the_box(graph: Graph, ros_context: object) -> None:
    referee = graph.serve(Referee(ros_context))
    Blackboard.set("/room", "FrontElevator")
    room_info = ready(RoomInfo(name="room_info"), graph, room="/room", box="/box")
    assert graph.tick_until_done(room_info) == Status.SUCCESS
    assert Blackboard.get("/box") == ROOMS["FrontElevator"]
    assert referee.requests[-1].name == "FrontElevator"


def test_room_info_zero_box_is_an_unknown_room(graph: Graph, ros_context: object) -> None:
    graph.serve(Referee(ros_context))
    Blackboard.set("/room", "Atlantis")
    room_info = ready(RoomInfo(name="room_info"), graph, room="/room", box="/box")
    assert graph.tick_until_done(room_info) == Status.FAILURE
    assert room_info.feedback_message == "unknown room Atlantis"
    assert not Blackboard.exists("/box")


def test_room_info_without_a_room_fails_clearly(graph: Graph, ros_context: object) -> None:
    graph.serve(Referee(ros_context))
    room_info = ready(RoomInfo(name="room_info"), graph, room="/room", box="/box")
    assert graph.tick_until_done(room_info) == Status.FAILURE
    assert "cannot build" in room_info.feedback_message


def test_pick_up_succeeds_only_on_success(graph: Graph, ros_context: object) -> None:
    referee = graph.serve(Referee(ros_context))
    Blackboard.set("/guest", "human_20843")
    pick_up = ready(PickUpGuest(name="pick_up"), graph, guest_name="/guest")
    assert graph.tick_until_done(pick_up) == Status.SUCCESS
    assert (referee.requests[-1].guest_name, referee.requests[-1].robot_name) == (
        "human_20843", "servicebot",
    )
    assert pick_up.feedback_message == "picked up human_20843"

    referee.pickup_ok = False  # a completed call is not a call that worked
    assert graph.tick_until_done(pick_up) == Status.FAILURE
    assert "refused" in pick_up.feedback_message


def test_pick_up_robot_name_comes_from_its_port(graph: Graph, ros_context: object) -> None:
    referee = graph.serve(Referee(ros_context))
    Blackboard.set("/guest", "human_20843")
    Blackboard.set("/robot", "intruder")
    pick_up = ready(PickUpGuest(name="pick_up"), graph, guest_name="/guest", robot_name="/robot")
    assert graph.tick_until_done(pick_up) == Status.FAILURE
    assert referee.requests[-1].robot_name == "intruder"


def test_drop_off_succeeds_only_on_success(graph: Graph, ros_context: object) -> None:
    graph.serve(Referee(ros_context))
    Blackboard.set("/guest", "human_20843")
    drop_off = ready(DropOffGuest(name="drop_off"), graph, guest_name="/guest")
    assert graph.tick_until_done(drop_off) == Status.SUCCESS
    Blackboard.set("/guest", "human_99999")
    assert graph.tick_until_done(drop_off) == Status.FAILURE
    assert drop_off.feedback_message.startswith("drop-off of human_99999 refused")


def test_clear_costmaps(graph: Graph, ros_context: object) -> None:
    referee = graph.serve(Referee(ros_context))
    clear = ready(ClearCostmaps(name="clear"), graph)
    assert graph.tick_until_done(clear) == Status.SUCCESS
    assert clear.feedback_message == "costmaps cleared"
    assert len(referee.requests) == 1


def test_missing_server_fails_after_server_timeout(graph: Graph) -> None:
    clear = ready(ClearCostmaps(name="clear", service="/nobody/clear", server_timeout=0.3), graph)
    started = time.monotonic()
    clear.tick_once()
    assert clear.status == Status.RUNNING
    assert "waiting for service" in clear.feedback_message
    assert graph.tick_until_done(clear) == Status.FAILURE
    assert time.monotonic() - started >= 0.3
    assert "not available after 0.3" in clear.feedback_message


def test_server_appearing_within_server_timeout_is_used(
    graph: Graph, ros_context: object
) -> None:
    clear = ready(
        ClearCostmaps(name="clear", service="/late/clear_costmaps", server_timeout=10.0), graph
    )
    clear.tick_once()
    assert clear.status == Status.RUNNING
    assert "waiting for service" in clear.feedback_message
    referee = graph.serve(Referee(ros_context))
    referee.node.create_service(Empty, "/late/clear_costmaps", referee.clear)
    assert graph.tick_until_done(clear) == Status.SUCCESS
    assert len(referee.requests) == 1


def test_a_server_that_never_answers_times_out(graph: Graph, ros_context: object) -> None:
    referee = Referee(ros_context, node_name="silent_referee")  # never spun: never answers
    clear = ready(ClearCostmaps(name="clear", timeout=0.3), graph)
    graph.spin_until(clear.client.service_is_ready)
    assert graph.tick_until_done(clear) == Status.FAILURE
    assert "no answer" in clear.feedback_message and "0.3" in clear.feedback_message
    assert referee.requests == []


def test_interrupting_withdraws_the_pending_request(graph: Graph, ros_context: object) -> None:
    referee = Referee(ros_context, node_name="slow_referee")  # not spun until after the stop
    Blackboard.set("/guest", "human_20843")
    pick_up = ready(PickUpGuest(name="pick_up"), graph, guest_name="/guest")
    graph.spin_until(pick_up.client.service_is_ready)
    pick_up.tick_once()
    assert pick_up.status == Status.RUNNING
    in_flight = pick_up._future
    assert in_flight is not None and not in_flight.done()
    pick_up.stop(Status.INVALID)
    assert pick_up.feedback_message == "call to /servicesim/pickup_guest cancelled"
    assert in_flight.cancelled()
    graph.serve(referee)  # the late answer arrives and is dropped
    graph.spin_until(lambda: len(referee.requests) == 1)
    for _ in range(20):
        graph.executor.spin_once(timeout_sec=0.01)
    assert pick_up.client._pending_requests == {}


def test_service_call_base_is_abstract_and_not_a_tag() -> None:
    with pytest.raises(TypeError, match="abstract"):
        ServiceCall(name="call")
    registry = py_trees.ports.get_ports_registry()
    assert "ServiceCall" not in registry and "_TaskCall" not in registry
    assert {"NewTask", "TaskInfo", "RoomInfo", "PickUpGuest", "DropOffGuest"} <= set(registry)


XML = """
<root main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="mission" memory="true">
      <NewTask name="new_task" guest_name="{guest}" pick_up_location="{pick_up}"
               drop_off_location="{drop_off}" start_pose="{start}" timeout="5.0"/>
      <RoomInfo name="pick_up_area" room="{pick_up}" box="{pick_up_box}"/>
      <RoomInfo name="cafe_area" room="PublicCafe" box="{cafe_box}"
                service="/servicesim/room_info"/>
      <SimTimeout name="limit" seconds="30.0">
        <SimWait name="pause" seconds="0.05"/>
      </SimTimeout>
      <PickUpGuest name="pick_up" guest_name="{guest}"/>
      <ClearCostmaps name="clear" server_timeout="2.0"/>
    </Sequence>
  </BehaviorTree>
</root>
"""


def test_tags_work_from_xml_with_remapping(
    graph: Graph, ros_context: object, tmp_path: Path
) -> None:
    referee = graph.serve(Referee(ros_context))
    xml_file = tmp_path / "mission.xml"
    xml_file.write_text(textwrap.dedent(XML))
    root = parse_behaviour_tree_xml(str(xml_file), node_registry="auto")
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(node=graph.node, timeout=5.0)
    nodes = {node.name: node for node in root.iterate()}
    new_task = next(n for n in nodes.values() if isinstance(n, NewTask))
    assert new_task.timeout == 5.0
    clear = next(n for n in nodes.values() if isinstance(n, ClearCostmaps))
    assert clear.server_timeout == 2.0

    deadline = time.monotonic() + 15.0
    while root.status != Status.SUCCESS:
        assert root.status != Status.FAILURE, root.tip().feedback_message
        assert time.monotonic() < deadline, "the XML tree did not finish"
        tree.tick()
        graph.executor.spin_once(timeout_sec=0.01)
    assert Blackboard.get("/guest") == "human_20843"
    assert Blackboard.get("/pick_up_box") == ROOMS["FrontElevator"]
    assert Blackboard.get("/cafe_box") == ROOMS["PublicCafe"]
    assert isinstance(Blackboard.get("/start"), Pose2D)
    assert [type(r).__name__ for r in referee.requests] == [
        "NewTask_Request", "RoomInfo_Request", "RoomInfo_Request",
        "PickUpGuest_Request", "Empty_Request",
    ]
