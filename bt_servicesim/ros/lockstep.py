"""Lockstep with a simulator that offers it: the executive's side of the extension protocol.

The protocol is described once, in docs/reference/simulator.md, "Lockstep". Here is its client:
a :class:`LockstepClient` joins, then ticks the executive exactly once per period the simulator
announces, in order, none skipped, and only once everything the announcement counts that this
node can receive has arrived (the messages on every topic it subscribes to reliably, the
answers to its requests), so a tick never depends on which message DDS delivered first. After
the tick it sends its *done* with the requests it has sent since it joined; what the tick only
records waits until the done has gone out (:meth:`LockstepClient.after_done`).

Invariants the client keeps:

* what arrives early (the simulator steps period *k*+1 while the client ticks on *k*) is held
  in the node (:mod:`bt_servicesim.ros.traffic`) and handed on before the tick of its own
  period, reader by reader, then endpoint by endpoint, each in arrival order;
* the node's clock is set to the period's sim time before the tick;
* a client the simulator stopped waiting for learns it exactly, from an announcement more than
  two periods past its last done: it hands on what it held, stops saying done, ticks free on
  the newest announcement and reports that the run will not replay
  (:attr:`LockstepClient.dropped_at`);
* answers are totals per endpoint: every answer on an endpoint this node has a client for is
  taken as its own (one executive per simulator);
* a subscription made after the join to a topic the simulator announces (the camera's, made
  for a look) is named in the next done with the period it is counted from, two periods on
  (:data:`PIPELINE_REACH`): the simulator publishes a topic it renders only for readers from
  exactly that period, so from then on the subscription is counted and held like the others,
  and its first message reaches the same tick in every run. A subscription destroyed is no
  longer named.

:func:`offered` finds out, within a bounded wall time, whether the backend offers lockstep; a
backend without it (Gazebo, a real robot) is run free on
:class:`~bt_servicesim.ros.sim_ticker.SimTicker`.
"""

from __future__ import annotations

import struct
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from rclpy.client import Client
from rclpy.clock import ROSClock
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos import ReliabilityPolicy as Reliability
from rclpy.serialization import serialize_message
from rclpy.time import Time
from servicesim_competition.msg import LockstepDone, LockstepPeriod
from servicesim_competition.srv import LockstepJoin

from bt_servicesim.ros.node_features import ErrorKeeper
from bt_servicesim.ros.spinning import Spinner
from bt_servicesim.ros.traffic import Traffic

__all__ = ["LockstepClient", "LockstepHost", "LockstepTicker", "lockstep_of", "offered"]

JOIN_SERVICE = "/servicesim/lockstep/join"
PERIOD_TOPIC = "/servicesim/lockstep/period"
DONE_TOPIC = "/servicesim/lockstep/done"
PROTOCOL_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                          reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.VOLATILE)
OFFER_WAIT_S = 3.0
"""Wall seconds a run waits for the join service once the simulator's own services are up."""
JOIN_SETTLE_S = 3.0
"""Wall seconds at most after the join for what the simulator sent before it to arrive."""
JOIN_QUIET_S = 0.02
"""Wall seconds without an arrival that end that wait."""
FINAL_PERIODS = 3
"""Periods the client stays in step after its last ticker stopped: what the last tick sent is
served (after the next period: the pipeline's one period later) and answered; then it holds
the simulator still until :meth:`LockstepClient.leave`, so that what the run reports of the
end does not depend on how long it takes to report."""
STALL_WARNING_S = 10.0
"""Wall seconds a period may wait for its messages before the client ticks anyway and says so."""
PIPELINE_REACH = 2
"""Periods a simulator that waits for this client announces at most past the client's last done:
the one it steps while the client ticks, and the one that done lets it step. A subscription
named in the done for period *k* is counted from period *k* + this: one the simulator cannot
have stepped yet, whatever its pipeline."""
DUE_TOLERANCE_NS = 10_000_000
"""A period's sim time within this of a tick's due time counts as reaching it."""


@runtime_checkable
class LockstepHost(ErrorKeeper, Protocol):
    """A node lockstep can run on (:mod:`bt_servicesim.ros.node_features`): it counts its
    traffic and holds its lockstep client."""

    traffic: Traffic
    """What the node sent and received."""
    lockstep: LockstepClient | None
    """The lockstep client once joined, else None (the node runs free)."""


def lockstep_of(node: object) -> LockstepClient | None:
    """The lockstep client ``node`` has joined with, if it is a host that has one.

    Looks at the attribute alone: a check against the runtime protocol
    :class:`LockstepHost` (every member looked up) costs tens of microseconds, and only a
    host ever holds a :class:`LockstepClient` (the client puts itself there when it joins).
    """
    client = getattr(node, "lockstep", None)
    return client if isinstance(client, LockstepClient) else None


def offered(node: Node, executor: Spinner, *, wait_s: float = OFFER_WAIT_S) -> bool:
    """Whether the backend offers lockstep: its join service appears within ``wait_s``."""
    client: Client[Any, Any] = node.create_client(LockstepJoin, JOIN_SERVICE)
    try:
        deadline = time.monotonic() + wait_s
        while not client.service_is_ready() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        return client.service_is_ready()
    finally:
        node.destroy_client(client)


def after_this_period(node: Node, work: Callable[[], None]) -> None:
    """Run ``work``, which only records, once the period ``node`` is ticking has said done.

    At once when the node has no lockstep client (free running) or is between periods; see
    :meth:`LockstepClient.after_done`.
    """
    client = lockstep_of(node)
    if client is None:
        work()
    else:
        client.after_done(work)


class LockstepTicker:
    """Calls ``callback`` every ``period_s`` of announced sim time; ``cancel`` stops it."""

    def __init__(self, client: LockstepClient, period_s: float,
                 callback: Callable[[], None]) -> None:
        if not period_s > 0.0:
            raise ValueError(f"tick period {period_s}: must be more than 0")
        self.client = client
        self.callback = callback
        self.period_ns = round(period_s * 1e9)
        self.due_ns: int | None = None
        self.error: Exception | None = None

    def cancel(self) -> None:
        self.client.remove(self)

    def tick_if_due(self, sim_time_ns: int) -> None:
        if self.due_ns is None:  # the first call a period on, as a timer's
            self.due_ns = sim_time_ns + self.period_ns
            return
        if sim_time_ns + DUE_TOLERANCE_NS < self.due_ns:
            return
        self.due_ns += self.period_ns * max(1, (sim_time_ns + DUE_TOLERANCE_NS - self.due_ns)
                                            // self.period_ns + 1)
        try:
            self.callback()
        except Exception as error:  # escaping an executor's callback kills the process
            self.cancel()
            self.error = error
            self.client.host.note_error(error, where="a tick")


class LockstepClient:
    """One node's lockstep with the simulator; see the module docstring."""

    def __init__(self, node: Node, *, name: str) -> None:
        if not isinstance(node, LockstepHost):
            raise TypeError(f"{node.get_name()}: lockstep needs a node that counts its traffic")
        clock = node.get_clock()
        if not isinstance(clock, ROSClock):
            raise TypeError(f"{node.get_name()}: lockstep needs a node on ROS time")
        self.node: Node = node
        self.host: LockstepHost = node
        """The same node, as lockstep's host: where the client puts itself once joined."""
        self._clock = clock
        """The node's clock, which each period's announcement sets."""
        self.name = name
        self.traffic = node.traffic
        self.client_id: int | None = None
        self.periods = 0
        """Periods this client has ticked for since it joined."""
        self.stalls = 0
        """Periods ticked without every counted message (after :data:`STALL_WARNING_S`), and a
        join that ran out of :data:`JOIN_SETTLE_S` before it had taken what came before it."""
        self.dropped_at: LockstepPeriod | None = None
        """The first period the simulator announced without waiting for this client (it dropped
        it); from then on the client runs free on the announcements. None while in step."""
        self._tickers: list[LockstepTicker] = []
        self._late: dict[int, tuple[str, int]] = {}
        """Subscriptions made after the join, by reader key: (topic, first period counted)."""
        self._keys_seen = 0
        """Reader keys below this were made before the join or have been looked at since."""
        self._after_done: list[Callable[[], None]] | None = None
        """Work left for after this period's done (:meth:`after_done`); None between periods."""
        self._idle_periods: int | None = None
        """Periods since the last ticker stopped; None while one ticks (or none ever did)."""
        self._pending: deque[LockstepPeriod] = deque()
        """Announcements not ticked yet, oldest first."""
        self._pending_since = 0.0
        """Wall time since the oldest pending announcement waits."""
        self._scheduled = False
        self._ticked = -1
        """The last period ticked (or joined at)."""
        self._head_targets: tuple[LockstepPeriod | None, dict[int, int], dict[str, int]] = (
            None, {}, {})
        self._ready_no_sooner = 0
        """The arrivals the oldest pending period cannot tick before (from the last look)."""
        self._reader_offsets: dict[int, tuple[str, int]] = {}
        self._answer_offsets: dict[str, int] = {}
        self._answers_at_join: dict[str, int] = {}
        self._sent_at_join: dict[str, int] = {}
        self._done_message: bytearray | None = None
        """The last done, serialised: from one tick to the next mostly only its period changes."""
        self._done_counts: dict[str, int] = {}
        self._done_late: dict[int, tuple[str, int]] = {}
        self._done = node.create_publisher(LockstepDone, DONE_TOPIC, PROTOCOL_QOS)
        node.create_subscription(LockstepPeriod, PERIOD_TOPIC, self._on_period, PROTOCOL_QOS)
        self._joining: Client[Any, Any] | None = node.create_client(LockstepJoin, JOIN_SERVICE)
        """Made with the client, before the run waits for the backend to discover its readers
        (:mod:`bt_servicesim.ros.discovery`): a join client made after that wait could have its
        answer sent before the simulator had discovered the reader it goes to, and lost (the
        run then went on free running: a seed's replay decided by a race)."""

    # ------------------------------------------------------------------ join
    def join(self, executor: Spinner, *, wait_s: float = OFFER_WAIT_S) -> bool:
        """Join the simulator's lockstep; whether it took us (bounded in wall time)."""
        client = self._joining
        if client is None:
            raise RuntimeError(f"{self.name}: joins once")
        try:
            future = client.call_async(LockstepJoin.Request(name=self.name))
            deadline = time.monotonic() + wait_s
            while not future.done() and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            answer = future.result() if future.done() else None
            if answer is None:
                return False
            self._take_what_came_before(executor, answer.joined_at)
        finally:
            self.node.destroy_client(client)
            self._joining = None
        self._synchronise(answer.joined_at)
        self._keys_seen = len(self.traffic.received)
        self._ticked = int(answer.joined_at.period)
        self.client_id = int(answer.client)
        self.traffic.hold(set(self._reader_offsets), set(answer.joined_at.endpoints))
        self._publish_done(int(answer.joined_at.period))
        while self._pending and self._pending[0].period <= answer.joined_at.period:
            self._pending.popleft()  # announced before the join: done with it above
        self._pending_since = time.monotonic()
        self.traffic.on_arrival = self._check
        self.host.lockstep = self
        self._stop_following_clock_topic()
        self._check()
        return True

    def _stop_following_clock_topic(self) -> None:
        """Let only the announcements move the node's clock: rclpy's own /clock reader took
        every period's /clock (one more wake-up a period) and set the clock to the next
        period's time whenever that arrived before the tick."""
        time_source = getattr(self.node, "_time_source", None)  # rclpy's, private (Kilted)
        if time_source is not None and hasattr(time_source, "detach_node"):
            time_source.detach_node()

    def _take_what_came_before(self, executor: Spinner, joined_at: LockstepPeriod) -> None:
        """Take what the simulator sent before it answered the join, so that the offsets
        count it as before the join.

        From its answer until this client's first done the simulator sends nothing (the gate
        holds it at the join's period), and what it sent before the answer was delivered to
        this process ahead of the answer (one writer process, one port, in order), except a
        latched topic's history: a reliable writer sends a newly matched reader that on its
        own time. So the wait ends once every reader of a topic the simulator announces has
        matched its writer (:meth:`unmatched`: a reader matched only after the join would be
        neither counted nor held, and would hand its messages on whenever they came), every
        latched reader has what it is owed (:meth:`_owed_history`) and nothing has arrived for
        :data:`JOIN_QUIET_S`. It is bounded by :data:`JOIN_SETTLE_S`: a few hundredths of a
        second, mostly; a join that runs out of it says what it lacked and counts as a stall.
        """
        deadline = time.monotonic() + JOIN_SETTLE_S
        seen, quiet_since = self.traffic.arrivals, time.monotonic()
        while (now := time.monotonic()) < deadline and (
                now - quiet_since < JOIN_QUIET_S or not self._owed_history(joined_at)
                or self.unmatched(joined_at)):
            executor.spin_once(timeout_sec=JOIN_QUIET_S)
            if self.traffic.arrivals != seen:
                seen, quiet_since = self.traffic.arrivals, time.monotonic()
        lacking = [*(f"a writer for {topic}" for topic in self.unmatched(joined_at)),
                   *([] if self._owed_history(joined_at) else ["latched history"])]
        if lacking:
            self.stalls += 1
            self.node.get_logger().warning(
                f"lockstep: joined without {', '.join(lacking)} after {JOIN_SETTLE_S:.0f} s: "
                "this run may not replay")

    def unmatched(self, joined_at: LockstepPeriod) -> list[str]:
        """The topics the simulator announces that a reliable reader of this node reads
        without having matched a writer yet (by topic name)."""
        announced = set(joined_at.topics)
        return sorted({subscription.topic_name
                       for subscription in self.traffic.readers.values()
                       if subscription.topic_name in announced
                       and subscription.qos_profile.reliability == Reliability.RELIABLE
                       and subscription.get_publisher_count() == 0})

    def _owed_history(self, joined_at: LockstepPeriod) -> bool:
        """Whether every matched latched (transient-local) reader holds what DDS owes it: of
        the messages announced on its topic, as many as its history keeps, whether they came
        as they were sent or as history when the reader matched."""
        announced = dict(zip(joined_at.topics, joined_at.messages, strict=False))
        for key, subscription in self.traffic.readers.items():
            qos = subscription.qos_profile
            if (qos.durability != DurabilityPolicy.TRANSIENT_LOCAL
                    or subscription.get_publisher_count() == 0):
                continue
            owed = int(announced.get(subscription.topic_name, 0))
            if qos.history != HistoryPolicy.KEEP_ALL:
                owed = min(owed, qos.depth)
            if self.traffic.received[key] < owed:
                return False
        return True

    def _synchronise(self, joined_at: LockstepPeriod) -> None:
        """Offsets: what was announced at the join against what has arrived by now."""
        announced = dict(zip(joined_at.topics, joined_at.messages, strict=False))
        self._reader_offsets = {
            key: (topic, int(announced.get(topic, 0)) - self.traffic.received[key])
            for key, topic in self._counted_readers()}
        self._answers_at_join = {endpoint: int(count) for endpoint, count in
                                 zip(joined_at.endpoints, joined_at.answers, strict=False)}
        self._answer_offsets = {
            endpoint: self._answers_at_join.get(endpoint, 0)
            - self.traffic.answered.get(endpoint, 0) for endpoint in self.traffic.endpoints}
        self._sent_at_join = dict(self.traffic.sent)
        self._done_message = None  # counted from this join, by this client id

    def _counted_readers(self) -> list[tuple[int, str]]:
        """The subscriptions that receive every message of their topic: reliable, matched."""
        return [(key, subscription.topic_name)
                for key, subscription in self.traffic.readers.items()
                if subscription.qos_profile.reliability == Reliability.RELIABLE
                and subscription.get_publisher_count() > 0]

    # --------------------------------------------------------------- tickers
    def ticker(self, period_s: float, callback: Callable[[], None]) -> LockstepTicker:
        ticker = LockstepTicker(self, period_s, callback)
        self._tickers.append(ticker)
        self._idle_periods = None
        return ticker

    def remove(self, ticker: LockstepTicker) -> None:
        if ticker in self._tickers:
            self._tickers.remove(ticker)
            if not self._tickers:
                self._idle_periods = 0

    def after_done(self, work: Callable[[], None]) -> None:
        """Run ``work`` once the period being ticked has said done; at once between periods.

        For what only records the tick: it sees the same state (nothing runs between the tick
        and its done), but the simulator no longer waits for it. Work runs in the order it was
        left; what it raises is kept as a callback's error is (the node's ``note_error``), not
        raised into the executor.
        """
        if self._after_done is None:
            work()
        else:
            self._after_done.append(work)

    @property
    def holding(self) -> bool:
        """Whether the client holds the simulator still (its executive has finished)."""
        return self._idle_periods is not None and self._idle_periods >= FINAL_PERIODS

    def leave(self) -> None:
        """Leave the lockstep: the simulator no longer waits for this client."""
        if self.client_id is not None:
            if self.dropped_at is None:
                self._done.publish(LockstepDone(client=self.client_id, leaving=True))
            self.client_id = None
            self.traffic.on_arrival = None
            self.traffic.stop_holding()

    @property
    def in_step(self) -> bool:
        """Whether the simulator waits for this client: joined, not left, not dropped."""
        return self.client_id is not None and self.dropped_at is None

    # ---------------------------------------------------------------- period
    def _on_period(self, message: LockstepPeriod) -> None:
        last = self._pending[-1].period if self._pending else self._ticked
        if message.period <= last:
            return
        if self.in_step and message.period > self._ticked + PIPELINE_REACH:
            self._go_free(message)
        if self.dropped_at is not None:
            self._pending.clear()  # free: the newest period is the time, as /clock would be
        if not self._pending:
            self._pending_since = time.monotonic()
        self._pending.append(message)
        if self.client_id is not None:
            self._check()

    def _go_free(self, message: LockstepPeriod) -> None:
        """The simulator went on without this client: hand on what was held, run free."""
        self.dropped_at = message
        self.node.get_logger().warning(
            f"lockstep: the simulator announced period {message.period} without waiting for "
            f"this client's done for period {self._ticked + 1}: it dropped this client (it "
            "waits a bounded wall time for a done); running free from here, so this run will "
            "not replay")
        self.traffic.on_arrival = None
        self.traffic.stop_holding()

    def missing(self) -> list[str]:
        """What the oldest pending period still waits for, in words; empty when it may tick."""
        if not self._pending:
            return ["no period announced"]
        head = self._pending[0]
        if self._head_targets[0] is not head:  # worked out once per period, not per arrival
            self._head_targets = (head, *self._targets(head))
        _, messages, answers = self._head_targets
        lacking = [self._reader_offsets[key][0] for key, count in messages.items()
                   if self.traffic.received[key] < count]
        lacking.extend(endpoint for endpoint, count in answers.items()
                       if self.traffic.answered.get(endpoint, 0) < count)
        shortfall = (sum(max(0, count - self.traffic.received[key])
                         for key, count in messages.items())
                     + sum(max(0, count - self.traffic.answered.get(endpoint, 0))
                           for endpoint, count in answers.items()))
        self._ready_no_sooner = self.traffic.arrivals + shortfall
        return lacking

    def _targets(self, period: LockstepPeriod) -> tuple[dict[int, int], dict[str, int]]:
        """What ``period`` counts, in this node's own terms: messages per reader (by topic
        name), answers per endpoint (by name)."""
        announced = dict(zip(period.topics, period.messages, strict=False))
        messages = {key: int(announced.get(topic, 0)) - offset
                    for key, (topic, offset) in sorted(self._reader_offsets.items(),
                                                       key=lambda item: (item[1][0], item[0]))
                    if key in self.traffic.readers}
        answers = {endpoint: int(count) - self._answer_offset(endpoint)
                   for endpoint, count in sorted(zip(period.endpoints, period.answers,
                                                     strict=False))
                   if endpoint in self.traffic.endpoints}
        return messages, answers

    def _answer_offset(self, endpoint: str) -> int:
        """Announced answers on ``endpoint`` that are not this node's: those before the join
        (a client made after it had none before)."""
        offset = self._answer_offsets.get(endpoint)
        return self._answers_at_join.get(endpoint, 0) if offset is None else offset

    def _check(self) -> None:
        """Schedule the tick of the oldest pending period if everything it counts is in.

        Called on every arrival: while fewer messages have arrived than the period lacked at
        the last full look, nothing is looked at (each arrival makes up at most one)."""
        if (not self._pending or self._scheduled or self.holding or self.client_id is None):
            return
        if self.dropped_at is not None:  # free: tick the newest period as it comes
            self._schedule_period()
            return
        if ((self.traffic.arrivals < self._ready_no_sooner
                    and self._head_targets[0] is self._pending[0])
                or self.missing()):
            return
        self._schedule_period()

    def check_stalled(self) -> None:
        """Tick a period that waited too long for its messages anyway, and say what lacked."""
        if (not self._pending or self._scheduled or self.holding or not self.in_step
                or time.monotonic() - self._pending_since < STALL_WARNING_S):
            return
        self.stalls += 1
        self.node.get_logger().warning(
            f"lockstep: period {self._pending[0].period} ticked without "
            f"{', '.join(self.missing())} after {STALL_WARNING_S:.0f} s: this run may not replay")
        self._schedule_period()

    def _schedule_period(self) -> None:
        """Tick the oldest pending period in a task of the node's executor, so that callbacks
        of what just arrived (a future's) run before the tick."""
        executor = self.node.executor
        if executor is None:
            raise RuntimeError(f"{self.name}: lockstep needs the node on an executor")
        self._scheduled = True
        executor.create_task(self._run_period)

    def _run_period(self) -> None:
        self._scheduled = False
        if not self._pending or self.client_id is None:
            return
        period = self._pending.popleft()
        self._pending_since = time.monotonic()
        now_ns = period.sim_time.sec * 1_000_000_000 + period.sim_time.nanosec
        self._clock.set_ros_time_override(Time(nanoseconds=now_ns))
        in_step = self.in_step
        self._after_done = []
        try:
            if in_step:  # on the period's clock: /clock of the next may be in already
                self._release(period)
            for ticker in list(self._tickers):
                ticker.tick_if_due(now_ns)
            if self._idle_periods is not None:
                self._idle_periods += 1
            self.periods += 1
            self._ticked = int(period.period)
            if in_step and self.in_step:  # a tick may have learned of the drop
                self._count_late_readers(period)
                self._publish_done(self._ticked)
        finally:
            self._run_after_done()
        self._check()  # the next period may have arrived whole meanwhile

    def _run_after_done(self) -> None:
        work, self._after_done = self._after_done or [], None
        for step in work:
            try:
                step()
            except Exception as error:  # escaping an executor's callback kills the process
                self.host.note_error(error, where="recording a tick")

    def _count_late_readers(self, period: LockstepPeriod) -> None:
        """Name the subscriptions made since the last done, forget the destroyed, and count
        from the next period those named to be counted from it."""
        received = self.traffic.received
        if not self._late and len(received) == self._keys_seen:
            return  # most periods: no subscription made, none to count
        readers = self.traffic.readers
        for key in [key for key in self._late if key not in readers]:
            del self._late[key]
            self._reader_offsets.pop(key, None)
        announced = dict(zip(period.topics, period.messages, strict=False))
        for key in range(self._keys_seen, len(received)):  # keys are given in order
            if key in readers:
                self._name_late_reader(key, readers[key].topic_name,
                                       readers[key].qos_profile, announced)
        self._keys_seen = len(received)
        for key, (topic, first) in self._late.items():
            if first == self._ticked + 1:  # its messages come from the next period on
                self._reader_offsets[key] = (topic, int(announced.get(topic, 0)))
                self._head_targets, self._ready_no_sooner = (None, {}, {}), 0

    def _name_late_reader(self, key: int, topic: str, qos: QoSProfile,
                          announced: dict[str, int]) -> None:
        """Count reader ``key`` from two periods on, if the simulator counts its topic and
        it receives every message (reliable); hold what arrives for it from now on."""
        if topic not in announced or qos.reliability != Reliability.RELIABLE:
            return
        if topic in {named for named, _ in self._done_late.values()}:
            self.stalls += 1
            self.node.get_logger().warning(
                f"lockstep: a new subscription to {topic} while the simulator still publishes "
                "it for the last done's: how many of those messages reach the new one depends "
                "on DDS; this run may not replay")
        self._late[key] = (topic, self._ticked + PIPELINE_REACH)
        self.traffic.hold_reader(key)

    def _release(self, period: LockstepPeriod) -> None:
        """Hand on what ``period`` counts; what a callback raises is kept, not raised."""
        messages, answers = self._targets(period)
        try:
            self.traffic.release(messages, answers)
        except Exception as error:  # escaping an executor's callback kills the process
            self.host.note_error(error, where=f"handing on period {period.period}")

    def _publish_done(self, period: int) -> None:
        """Say the tick of ``period`` is done, with the requests sent since the join.

        Most ticks send nothing: the last done, kept serialised, then goes again with the new
        period written into its bytes (:func:`_write_period`), rather than its endpoint names
        and counts being built, checked and converted anew.
        """
        sent, late = self.traffic.sent, self._late
        if (self._done_message is None or self._done_counts != sent
                or self._done_late != late):
            counts = {endpoint: count - self._sent_at_join.get(endpoint, 0)
                      for endpoint, count in sent.items()}
            endpoints = sorted(counts)
            readings = sorted(late.values())
            self._done_message = bytearray(serialize_message(LockstepDone(
                client=self.client_id or 0, endpoints=endpoints,
                requests=[counts[e] for e in endpoints],
                reading_topics=[topic for topic, _ in readings],
                reading_from=[first for _, first in readings])))
            self._done_counts, self._done_late = dict(sent), dict(late)
        _write_period(self._done_message, period)
        self._done.publish(bytes(self._done_message))


_PERIOD_AT = 12
"""Where a serialised ``LockstepDone`` holds its ``uint64 period``: after the 4-byte CDR
encapsulation header, the ``uint32 client`` and 4 bytes of padding to the period's alignment."""
_PERIOD = {0: struct.Struct(">Q"), 1: struct.Struct("<Q")}
"""The period's layout by the encapsulation's second byte: big- or little-endian CDR."""


def _write_period(done: bytearray, period: int) -> None:
    """Write ``period`` into ``done``, a serialised ``LockstepDone``."""
    _PERIOD[done[1] & 1].pack_into(done, _PERIOD_AT, period)
