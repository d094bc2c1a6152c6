"""The executive's side of lockstep: finding out whether the backend offers it, and counting."""

from __future__ import annotations

from typing import Any

from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.task import Future
from servicesim_competition.msg import LockstepDone

from bt_servicesim.ros.lockstep import _write_period, offered
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


def test_a_held_reader_sees_only_what_the_period_counts_however_early_the_rest_arrives() -> None:
    """Messages of period k+1 that arrive while the node waits for tick k stay held."""
    traffic, seen = Traffic(), []
    key, receive = traffic.counted_callback("/servicebot/odom", seen.append)
    traffic.hold({key}, set())
    for message in ("period 1", "period 2 (early)", "period 2 (also early)"):
        receive(message)
    assert seen == [] and traffic.received[key] == 3  # counted on arrival, handed on later
    traffic.release({key: 1}, {})
    assert seen == ["period 1"]
    traffic.release({key: 3}, {})
    assert seen == ["period 1", "period 2 (early)", "period 2 (also early)"]


def test_a_held_answer_completes_the_callers_future_only_when_released() -> None:
    traffic, client = Traffic(), FakeClient()
    traffic.watch_client(client)
    traffic.hold(set(), {"/servicesim/room_info"})
    handed = client.call_async(None)
    assert handed is not client.futures[0]  # the caller's own future
    client.futures[0].set_result("answer")
    assert traffic.answered == {"/servicesim/room_info": 1} and not handed.done()
    traffic.release({}, {"/servicesim/room_info": 0})
    assert not handed.done()
    traffic.release({}, {"/servicesim/room_info": 1})
    assert handed.result() == "answer"


def test_answers_are_handed_on_in_the_order_they_arrived_and_everything_at_the_end() -> None:
    traffic, client = Traffic(), FakeClient()
    traffic.watch_client(client)
    traffic.hold(set(), {"/servicesim/room_info"})
    first, second = client.call_async(None), client.call_async(None)
    client.futures[1].set_result("second's")  # the simulator answered the second first
    client.futures[0].set_result("first's")
    traffic.release({}, {"/servicesim/room_info": 1})
    assert second.result() == "second's" and not first.done()
    traffic.stop_holding()
    assert first.result() == "first's" and not traffic.holding


def test_answers_on_an_endpoint_the_simulator_does_not_serve_are_not_held() -> None:
    traffic, client = Traffic(), FakeClient()
    traffic.watch_client(client)
    traffic.hold(set(), {"/servicesim/task_info"})  # what the simulator announced it serves
    handed = client.call_async(None)
    client.futures[0].set_result("someone else's answer")
    assert handed.result() == "someone else's answer"


def test_reliable_readers_keep_two_periods_of_messages_and_best_effort_ones_stay() -> None:
    """The simulator publishes a period while the node still takes the last one's: a latched
    reader keeping one message lost the referee's state of one of them."""
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy, qos_profile_sensor_data

    from bt_servicesim.ros.node import MIN_READER_DEPTH, deep_enough

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    deeper = deep_enough(latched)
    assert deeper.depth == MIN_READER_DEPTH >= 10 and latched.depth == 1
    assert deeper.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert deep_enough(qos_profile_sensor_data).depth == qos_profile_sensor_data.depth
    assert deep_enough(1) == MIN_READER_DEPTH


class FakeReader:
    """A subscription as the join's wait looks at it."""

    def __init__(self, topic: str, qos: QoSProfile, *, publishers: int = 1) -> None:
        self.topic_name, self.qos_profile, self.publishers = topic, qos, publishers

    def get_publisher_count(self) -> int:
        return self.publishers


def test_the_join_waits_for_each_latched_readers_owed_history_only() -> None:
    """A latched reader is owed as many of the announced messages as its history keeps;
    volatile readers, and latched ones nobody publishes to, are owed nothing."""
    from types import SimpleNamespace

    from rclpy.qos import DurabilityPolicy, HistoryPolicy
    from servicesim_competition.msg import LockstepPeriod

    from bt_servicesim.ros.lockstep import LockstepClient

    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    keep_all = QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)
    readers = {0: FakeReader("/areas", latched), 1: FakeReader("/odom", QoSProfile(depth=10)),
               2: FakeReader("/pose", latched, publishers=0), 3: FakeReader("/log", keep_all)}
    client = SimpleNamespace(traffic=SimpleNamespace(readers=readers,
                                                     received={0: 0, 1: 0, 2: 0, 3: 0}))
    joined_at = LockstepPeriod(topics=["/areas", "/log", "/odom", "/pose"],
                               messages=[3, 2, 5, 1])

    def owed() -> bool:
        return LockstepClient._owed_history(client, joined_at)  # type: ignore[arg-type]

    assert not owed()  # /areas: 1 of 3 (its depth), /log: 2 (keeps all)
    client.traffic.received.update({0: 1, 3: 1})
    assert not owed()
    client.traffic.received[3] = 2
    assert owed()  # /odom is volatile, /pose has no publisher: nothing owed


def test_the_join_waits_until_every_announced_topics_reader_has_matched_a_writer() -> None:
    """A reader matched only after the join would be neither counted nor held: its messages
    would reach the tree whenever DDS delivered them. Readers of topics the simulator does not
    announce, and best-effort ones, are not waited for."""
    from types import SimpleNamespace

    from rclpy.qos import ReliabilityPolicy
    from servicesim_competition.msg import LockstepPeriod

    from bt_servicesim.ros.lockstep import LockstepClient

    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    readers = {0: FakeReader("/odom", QoSProfile(depth=10), publishers=0),
               1: FakeReader("/tf", QoSProfile(depth=10)),
               2: FakeReader("/elsewhere", QoSProfile(depth=10), publishers=0),
               3: FakeReader("/scan", best_effort, publishers=0)}
    client = SimpleNamespace(traffic=SimpleNamespace(readers=readers))
    joined_at = LockstepPeriod(topics=["/odom", "/scan", "/tf"], messages=[1, 1, 1])

    def unmatched() -> list[str]:
        return LockstepClient.unmatched(client, joined_at)  # type: ignore[arg-type]

    assert unmatched() == ["/odom"]
    readers[0].publishers = 1
    assert unmatched() == []


def test_a_done_kept_serialised_says_each_new_period_and_the_rest_unchanged() -> None:
    done = LockstepDone(client=7, endpoints=["/servicesim/room_info", "/x:goal"],
                        requests=[3, 1], reading_topics=["/camera"], reading_from=[12])
    kept = bytearray(serialize_message(done))
    for period in (1, 2, 255, 2**32 + 5, 2**64 - 1):
        _write_period(kept, period)
        done.period = period
        assert deserialize_message(bytes(kept), LockstepDone) == done
