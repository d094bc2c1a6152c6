"""Service-call leaves against real in-process servers over DDS.

The client side is a plain node on system time, so the time limits are small real durations;
the behaviours are ticked directly while the executor spins, as a tree would tick them.
"""

from __future__ import annotations

import textwrap
import time
from collections.abc import Iterator
from pathlib import Path

import py_trees
import pytest
from nav2_msgs.srv import ClearEntireCostmap
from py_trees.blackboard import Blackboard
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

from bt_servicesim.behaviours.actions.clear_costmaps import (
    GLOBAL_COSTMAP_SERVICE,
    LOCAL_COSTMAP_SERVICE,
    ClearCostmaps,
)
from bt_servicesim.behaviours.actions.guest_services import DropOffGuest, PickUpGuest
from bt_servicesim.behaviours.actions.room_info import RoomInfo
from bt_servicesim.behaviours.actions.service_call import ServiceCall
from bt_servicesim.behaviours.actions.task import NewTask, TaskInfo
from bt_servicesim.planning.geometry import Pose2D
from tests.fakes.graphs import ExecutiveGraph
from tests.fakes.leaves import ready
from tests.fakes.referee import ROOMS, FakeReferee

Status = py_trees.common.Status


@pytest.fixture
def graph(ros_context: object) -> Iterator[ExecutiveGraph]:
    graph = ExecutiveGraph(ros_context)
    yield graph
    graph.shutdown()


def task_ports() -> dict[str, str]:
    return {port: f"/{port}" for port in NewTask.output_ports()}


def test_new_task_writes_the_task_to_its_outputs(
    graph: ExecutiveGraph, ros_context: object
) -> None:
    graph.serve(FakeReferee(ros_context))
    new_task = ready(NewTask(name="new_task"), graph.node, **task_ports())
    assert graph.tick_until_done(new_task) == Status.SUCCESS
    assert Blackboard.get("/pick_up_location") == "FrontElevator"
    assert Blackboard.get("/drop_off_location") == "PublicCafe"
    assert Blackboard.get("/guest_name") == "human_20843"
    start = Blackboard.get("/start_pose")
    assert (start.x, start.y, start.yaw) == pytest.approx((10.975, 3.75, 3.14))
    assert "human_20843" in new_task.feedback_message


def test_new_task_error_answer_is_a_failure(graph: ExecutiveGraph, ros_context: object) -> None:
    referee = graph.serve(FakeReferee(ros_context))
    referee.task_running = True
    new_task = ready(NewTask(name="new_task"), graph.node, **task_ports())
    assert graph.tick_until_done(new_task) == Status.FAILURE
    assert "error answer" in new_task.feedback_message
    assert not Blackboard.exists("/pick_up_location")


def test_task_info_reads_the_task_under_another_service_name(
    graph: ExecutiveGraph, ros_context: object
) -> None:
    graph.serve(FakeReferee(ros_context))
    task_info = ready(
        TaskInfo(name="task_info", service="/referee/task_info"), graph.node, **task_ports()
    )
    assert task_info.service == "/referee/task_info"
    assert graph.tick_until_done(task_info) == Status.SUCCESS
    assert Blackboard.get("/guest_name") == "human_20843"


def test_room_info_writes_the_box(graph: ExecutiveGraph, ros_context: object) -> None:
    referee = graph.serve(FakeReferee(ros_context))
    Blackboard.set("/room", "FrontElevator")
    room_info = ready(RoomInfo(name="room_info"), graph.node, room="/room", box="/box")
    assert graph.tick_until_done(room_info) == Status.SUCCESS
    assert Blackboard.get("/box") == ROOMS["FrontElevator"]
    assert referee.requests[-1].name == "FrontElevator"


def test_room_info_zero_box_is_an_unknown_room(graph: ExecutiveGraph, ros_context: object) -> None:
    graph.serve(FakeReferee(ros_context))
    Blackboard.set("/room", "Atlantis")
    room_info = ready(RoomInfo(name="room_info"), graph.node, room="/room", box="/box")
    assert graph.tick_until_done(room_info) == Status.FAILURE
    assert room_info.feedback_message == "unknown room Atlantis"
    assert not Blackboard.exists("/box")


def test_room_info_without_a_room_fails_clearly(graph: ExecutiveGraph, ros_context: object) -> None:
    graph.serve(FakeReferee(ros_context))
    room_info = ready(RoomInfo(name="room_info"), graph.node, room="/room", box="/box")
    assert graph.tick_until_done(room_info) == Status.FAILURE
    assert "cannot build" in room_info.feedback_message


def test_pick_up_succeeds_only_on_success(graph: ExecutiveGraph, ros_context: object) -> None:
    referee = graph.serve(FakeReferee(ros_context))
    Blackboard.set("/guest", "human_20843")
    pick_up = ready(PickUpGuest(name="pick_up"), graph.node, guest_name="/guest")
    assert graph.tick_until_done(pick_up) == Status.SUCCESS
    assert (referee.requests[-1].guest_name, referee.requests[-1].robot_name) == (
        "human_20843", "servicebot",
    )
    assert pick_up.feedback_message == (
        "pick-up of human_20843 answered true (RFID confirms the following)")

    referee.pickup_ok = False  # a completed call is not a call that worked
    assert graph.tick_until_done(pick_up) == Status.FAILURE
    assert "refused" in pick_up.feedback_message


def test_pick_up_robot_name_comes_from_its_port(graph: ExecutiveGraph, ros_context: object) -> None:
    referee = graph.serve(FakeReferee(ros_context))
    Blackboard.set("/guest", "human_20843")
    Blackboard.set("/robot", "intruder")
    pick_up = ready(PickUpGuest(name="pick_up"), graph.node, guest_name="/guest",
                    robot_name="/robot")
    assert graph.tick_until_done(pick_up) == Status.FAILURE
    assert referee.requests[-1].robot_name == "intruder"


def test_drop_off_succeeds_only_on_success(graph: ExecutiveGraph, ros_context: object) -> None:
    graph.serve(FakeReferee(ros_context))
    Blackboard.set("/guest", "human_20843")
    drop_off = ready(DropOffGuest(name="drop_off"), graph.node, guest_name="/guest")
    assert graph.tick_until_done(drop_off) == Status.SUCCESS
    Blackboard.set("/guest", "human_99999")
    assert graph.tick_until_done(drop_off) == Status.FAILURE
    assert drop_off.feedback_message.startswith("drop-off of human_99999 refused")


def test_clear_costmaps_asks_nav2s_global_and_local_costmaps_and_succeeds_on_both_answers(
    graph: ExecutiveGraph, ros_context: object
) -> None:
    referee = graph.serve(FakeReferee(ros_context))
    clear = ready(ClearCostmaps(name="clear"), graph.node)
    assert clear.services == (
        "/servicebot/global_costmap/clear_entirely_global_costmap",
        "/servicebot/local_costmap/clear_entirely_local_costmap",
    )
    assert graph.tick_until_done(clear) == Status.SUCCESS
    assert clear.feedback_message == "costmaps cleared (global and local)"
    assert sorted(event.what for event in referee.log.events) == [
        "clear_global_costmap", "clear_local_costmap"]
    assert all(isinstance(request, ClearEntireCostmap.Request) for request in referee.requests)
    assert all(exchange.client.srv_type is ClearEntireCostmap for exchange in clear.exchanges)


def test_clear_costmaps_fails_when_one_costmap_has_no_server(
    graph: ExecutiveGraph, ros_context: object
) -> None:
    referee = graph.serve(FakeReferee(ros_context))
    clear = ready(ClearCostmaps(name="clear", local_costmap_service="/nobody/clear_local",
                                server_timeout=0.3), graph.node)
    assert graph.tick_until_done(clear) == Status.FAILURE
    assert clear.feedback_message == "service /nobody/clear_local not available after 0.3 sim s"
    assert [event.what for event in referee.log.events] == ["clear_global_costmap"]


def test_missing_server_fails_after_server_timeout(graph: ExecutiveGraph) -> None:
    clear = ready(ClearCostmaps(name="clear", global_costmap_service="/nobody/clear_global",
                                local_costmap_service="/nobody/clear_local",
                                server_timeout=0.3),
                  graph.node)
    started = time.monotonic()
    clear.tick_once()
    assert clear.status == Status.RUNNING
    assert "waiting for service" in clear.feedback_message
    assert graph.tick_until_done(clear) == Status.FAILURE
    assert time.monotonic() - started >= 0.3
    assert "not available after 0.3" in clear.feedback_message


def test_server_appearing_within_server_timeout_is_used(
    graph: ExecutiveGraph, ros_context: object
) -> None:
    late = "/late/clear_entirely_global_costmap"
    clear = ready(
        ClearCostmaps(name="clear", global_costmap_service=late, server_timeout=10.0),
        graph.node,
    )
    clear.tick_once()
    assert clear.status == Status.RUNNING
    assert f"waiting for service {late}" in clear.feedback_message
    referee = graph.serve(FakeReferee(ros_context))
    referee.node.create_service(ClearEntireCostmap, late, referee.clear_global)
    assert graph.tick_until_done(clear) == Status.SUCCESS
    assert len(referee.requests) == 2


def test_a_server_that_never_answers_times_out(graph: ExecutiveGraph, ros_context: object) -> None:
    referee = FakeReferee(ros_context, node_name="silent_referee")  # never spun: never answers
    clear = ready(ClearCostmaps(name="clear", timeout=0.3), graph.node)
    graph.spin_until(lambda: all(exchange.client.service_is_ready()
                                 for exchange in clear.exchanges))
    assert graph.tick_until_done(clear) == Status.FAILURE
    assert "no answer" in clear.feedback_message and "0.3" in clear.feedback_message
    assert referee.requests == []


def test_interrupting_withdraws_the_pending_request(
    graph: ExecutiveGraph, ros_context: object
) -> None:
    referee = FakeReferee(ros_context, node_name="slow_referee")  # not spun until after the stop
    Blackboard.set("/guest", "human_20843")
    pick_up = ready(PickUpGuest(name="pick_up"), graph.node, guest_name="/guest")
    graph.spin_until(pick_up.client.service_is_ready)
    pick_up.tick_once()
    assert pick_up.status == Status.RUNNING
    in_flight = pick_up.exchange.future
    assert in_flight is not None and not in_flight.done()
    pick_up.stop(Status.INVALID)
    assert pick_up.feedback_message == "call to /servicesim/pickup_guest cancelled"
    assert in_flight.cancelled()
    graph.serve(referee)  # the late answer arrives and is dropped
    graph.spin_until(lambda: len(referee.requests) == 1)
    for _ in range(20):
        graph.executor.spin_once(timeout_sec=0.01)
    assert pick_up.client._pending_requests == {}


def test_interrupting_the_clearing_withdraws_both_requests(
    graph: ExecutiveGraph, ros_context: object
) -> None:
    referee = FakeReferee(ros_context, node_name="slow_costmaps")  # not spun until after the stop
    clear = ready(ClearCostmaps(name="clear"), graph.node)
    graph.spin_until(lambda: all(exchange.client.service_is_ready()
                                 for exchange in clear.exchanges))
    clear.tick_once()
    assert clear.status == Status.RUNNING
    in_flight = [exchange.future for exchange in clear.exchanges]
    assert all(future is not None and not future.done() for future in in_flight)
    clear.stop(Status.INVALID)
    assert clear.feedback_message == (f"call to {GLOBAL_COSTMAP_SERVICE} cancelled; "
                                      f"call to {LOCAL_COSTMAP_SERVICE} cancelled")
    assert all(future is not None and future.cancelled() for future in in_flight)
    graph.serve(referee)  # the late answers arrive and are dropped
    graph.spin_until(lambda: len(referee.requests) == 2)
    for _ in range(20):
        graph.executor.spin_once(timeout_sec=0.01)
    assert all(exchange.client._pending_requests == {} for exchange in clear.exchanges)


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
      <ClearCostmaps name="clear" server_timeout="2.0"
                     global_costmap_service="/elsewhere/clear_entirely_global_costmap"/>
    </Sequence>
  </BehaviorTree>
</root>
"""


def test_tags_work_from_xml_with_remapping(
    graph: ExecutiveGraph, ros_context: object, tmp_path: Path
) -> None:
    referee = graph.serve(FakeReferee(ros_context))
    referee.node.create_service(ClearEntireCostmap, "/elsewhere/clear_entirely_global_costmap",
                                referee.clear_global)
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
    assert clear.services == ("/elsewhere/clear_entirely_global_costmap", LOCAL_COSTMAP_SERVICE)

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
        "PickUpGuest_Request", "ClearEntireCostmap_Request", "ClearEntireCostmap_Request",
    ]
    clears = [event.what for event in referee.log.events if event.what.startswith("clear")]
    assert sorted(clears) == ["clear_global_costmap", "clear_local_costmap"]
