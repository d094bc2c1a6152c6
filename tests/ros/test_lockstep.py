"""The executive's side of lockstep: finding out whether the backend offers it, and counting."""

from __future__ import annotations

from typing import Any

from rclpy.executors import SingleThreadedExecutor
from rclpy.task import Future

from bt_servicesim.ros.lockstep import offered
from bt_servicesim.ros.node import ExecutiveNode, reliable
from bt_servicesim.ros.traffic import Traffic


def test_a_backend_without_lockstep_is_found_out_within_the_bound(ros_context: Any) -> None:
    node = ExecutiveNode("no_lockstep_here", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    try:
        assert offered(node, executor, wait_s=0.5) is False
        assert list(node.clients) == []  # the probe's client is gone again
    finally:
        executor.shutdown()
        node.destroy_node()


class FakeClient:
    srv_name = "servicesim/room_info"

    def __init__(self) -> None:
        self.futures: list[Future] = []

    def call_async(self, _request: object) -> Future:
        self.futures.append(Future())
        return self.futures[-1]


def test_requests_and_answers_are_counted_per_endpoint_as_the_simulator_names_them() -> None:
    traffic, client = Traffic(), FakeClient()
    arrivals: list[int] = []
    traffic.on_arrival = lambda: arrivals.append(1)
    traffic.watch_client(client)
    first, second = client.call_async(None), client.call_async(None)
    assert traffic.sent == {"/servicesim/room_info": 2}
    first.set_result("answer")
    second.cancel()  # a withdrawn request counts as answered: nothing more will come for it
    assert traffic.answered == {"/servicesim/room_info": 2} and len(arrivals) == 2


def test_each_reader_counts_its_own_messages_and_protocol_topics_are_not_counted() -> None:
    traffic = Traffic()
    key_a, read_a = traffic.counted_callback("/servicebot/odom", lambda _m: None)
    key_b, read_b = traffic.counted_callback("/servicebot/odom", lambda _m: None)
    key_p, read_p = traffic.counted_callback("/servicesim/lockstep/period", lambda _m: None)
    read_a("m")
    read_a("m")
    read_b("m")
    read_p("m")
    assert key_p is None and traffic.received == {key_a: 2, key_b: 1}


def test_best_effort_becomes_reliable_and_reliable_stays_as_it_is() -> None:
    from rclpy.qos import ReliabilityPolicy, qos_profile_sensor_data

    upgraded = reliable(qos_profile_sensor_data)
    assert upgraded.reliability == ReliabilityPolicy.RELIABLE and upgraded.depth >= 10
    assert reliable(10) == 10
