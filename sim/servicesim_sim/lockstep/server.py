"""The lockstep server: the simulator's side of the lockstep extension, on its ROS node.

:class:`LockstepServer` counts what the node publishes and answers, announces each period, and
wraps the node's request handlers so that, while a client is joined, a request is served only
when the gate (:mod:`servicesim_sim.lockstep.gate`) admits it: one at a time, in the gate's
order, each run to its first wait before the next starts. :class:`CountingActionServer` does
the same for the navigation action's goal, cancel and result requests, which rclpy would
answer as it takes them. With nobody joined every handler runs at once, ungated: a client that
never joins (a ``ros2`` command, an executive that runs free) sees no difference. Clients join
through :class:`~servicesim_sim.lockstep.joining.JoinService` and say they are done through
:class:`~servicesim_sim.lockstep.dones.DoneInbox`.

A topic the node publishes only while someone reads it (the camera) is *offered*
(:meth:`LockstepServer.offer`): announced from the start, with 0 messages, so that a client
that subscribes to it later knows the simulator counts it. While a client is joined, whether
such a topic is published in a period is the clients' word, not DDS's: their done messages
name the topics they subscribed to after the join and the period each counts from
(:meth:`~servicesim_sim.lockstep.gate.LockstepGate.readers_next`), and :meth:`LockstepServer.hold`
holds that period until the topic's writer has matched as many readers as the clients name
(:meth:`LockstepServer.reads`). How long DDS took to match a new subscription then costs wall
time only, never a different first message.

The protocol (join, period announcements, done messages) is described in
``docs/reference/simulator.md#lockstep``.
"""

from __future__ import annotations

import inspect
import math
import os
import time
from collections.abc import Callable
from typing import Any

from rclpy.action import ActionServer
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rclpy.task import Future
from servicesim_competition.msg import LockstepPeriod

from servicesim_sim.lockstep.dones import DoneInbox
from servicesim_sim.lockstep.gate import PIPELINE_LAG, Admission, LockstepGate
from servicesim_sim.lockstep.joining import JoinService
from servicesim_sim.lockstep.message import AnnouncementBytes
from servicesim_sim.process.executor import DrainingExecutor

__all__ = ["DONE_TOPIC", "JOIN_SERVICE", "PERIOD_TOPIC", "CountingActionServer",
           "LockstepServer"]

JOIN_SERVICE = "/servicesim/lockstep/join"
PERIOD_TOPIC = "/servicesim/lockstep/period"
DONE_TOPIC = "/servicesim/lockstep/done"
PROTOCOL_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                          reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.VOLATILE)
GATE_WAIT_S = 0.05
"""Wall seconds of one wait for the clients inside the gate (then the drop rule is checked)."""
LOOK_EVERY_PERIODS = 10
LOOK_EVERY_S = 0.05
"""In lockstep the loop hands over to rclpy only when a coroutine resumes or the gate lacks a
request; it looks for other work (a join, a request from outside) once at least this many
periods and this much wall time have passed since it last did. What it finds is served as
ever: a gated request in the gate's order, whenever it was taken; anything else as it comes,
as from any process outside the lockstep. A look costs a few hundred microseconds (a wait
on every entity of the node), a tenth of a period's own work each period at
:data:`LOOK_EVERY_PERIODS` alone when the simulator runs many times faster than real time."""
MATCH_WAIT_S = 10.0
"""Wall seconds :meth:`LockstepServer.hold` waits at most for a writer to match the readers
the clients name (then it steps on, with a warning, and the client stalls on what it lacks)."""


LAG_VARIABLE = "SERVICESIM_LOCKSTEP_LAG"
"""For measuring only (``benchmarks/sim_rtf.py --lockstep-lag``): 0 makes the simulator wait
for each tick before it steps on, with no pipelining; unset, the pipeline's lag."""


def pipeline_lag() -> int:
    """:data:`PIPELINE_LAG`, or 0 or 1 from :data:`LAG_VARIABLE`; anything else is refused."""
    value = os.environ.get(LAG_VARIABLE, "").strip()
    if not value:
        return PIPELINE_LAG
    if value not in ("0", "1"):
        raise SystemExit(f"{LAG_VARIABLE}={value!r}: must be 0 or 1")
    return int(value)


class LockstepServer:
    """The simulator's side of lockstep on ``node``; see the module docstring."""

    def __init__(self, node: Node, *, gate: LockstepGate | None = None) -> None:
        self.node = node
        self.gate = gate or LockstepGate(lag=pipeline_lag())
        self.messages: dict[str, int] = {}
        self.answers: dict[str, int] = {}
        self.served: set[str] = set()
        """The endpoints the node answers on, announced from the start (with 0 answers): a
        client holds answers only on those, and passes on the answers of anyone else's."""
        self._announcements = AnnouncementBytes()
        self._last: bytes | None = None
        """The last announcement, serialised (:mod:`servicesim_sim.lockstep.message`)."""
        self.callback_group = ReentrantCallbackGroup()
        """For every handler of the node: a handler waiting for its turn (or for sim time)
        must not keep the others from running, as one mutually exclusive group would -- the
        done message that opens the gate among them. The loop is one thread all the same."""
        self._announcer = node.create_publisher(LockstepPeriod, PERIOD_TOPIC, PROTOCOL_QOS)
        self.joining = JoinService(node, gate=self.gate, service=JOIN_SERVICE,
                                   announced=self.last_announcement,
                                   callback_group=self.callback_group)
        self.dones = DoneInbox(node, gate=self.gate, topic=DONE_TOPIC, qos=PROTOCOL_QOS,
                               callback_group=self.callback_group)
        self._periods_unlooked = 0
        self._next_look_s = 0.0
        """The wall time (``time.monotonic``) before which the loop does not look again."""
        self._writers: dict[str, Any] = {}
        """Offered topics' publishers, and others the clients read, found once by topic."""
        self._readers: dict[str, int] | None = None
        """The topics the clients read in the period stepped next, with their subscriptions;
        None while nobody is joined."""

    @property
    def active(self) -> bool:
        return self.gate.active

    # ------------------------------------------------------------- readings
    def offer(self, publisher: Any) -> None:
        """``publisher``'s topic is published only while someone reads it: announce it from
        the start (0 messages) and let the clients' readings decide it in lockstep."""
        topic = publisher.topic_name
        self._writers[topic] = publisher
        self.messages.setdefault(topic, 0)

    def reads(self, topic: str) -> bool | None:
        """Whether a joined client reads ``topic`` in the period being stepped; None while
        nobody is joined (then whoever subscribes decides)."""
        readers = self._readers
        return None if readers is None else topic in readers

    # ------------------------------------------------------------- counting
    def published(self, topic: str) -> None:
        self.messages[topic] = self.messages.get(topic, 0) + 1

    def answered(self, endpoint: str) -> None:
        self.answers[endpoint] = self.answers.get(endpoint, 0) + 1

    def took(self, endpoint: str) -> int:
        return self.gate.take(endpoint)

    # ------------------------------------------------------------- wrapping
    def gated(self, endpoint: str, handler: Callable[..., Any]) -> Callable[..., Any]:
        """``handler`` (a service callback), counted and gated; its return is the answer."""
        self.gate.endpoints.add(endpoint)
        self.served.add(endpoint)

        async def call(*args: Any) -> Any:
            turn = self.turn(endpoint, self.gate.take(endpoint))
            if turn is not None:
                await turn
            result = handler(*args)
            if inspect.isawaitable(result):
                result = await result
            self.answered(endpoint)
            return result

        return call

    def turn(self, endpoint: str, number: int) -> Future[bool] | None:
        """While a client is joined, a future the gate completes when it admits request
        ``number`` on ``endpoint``; None when nobody is joined (serve at once)."""
        if not self.gate.active:
            return None
        turn: Future[bool] = Future()
        self.gate.admit_later(Admission(endpoint=endpoint, number=number,
                                        serve=lambda: turn.set_result(True)))
        return turn

    def gated_message(self, topic: str, callback: Callable[[Any], None]) -> Callable[[Any], None]:
        """A subscription callback, counted and, while a client is joined, gated."""
        self.gate.endpoints.add(topic)

        def receive(message: Any) -> None:
            number = self.gate.take(topic)
            if self.gate.active:
                self.gate.admit_later(Admission(endpoint=topic, number=number,
                                                serve=lambda: callback(message)))
            else:
                callback(message)

        return receive

    # ----------------------------------------------------------------- loop
    def end_period(self, *, period: int, sim_time_ns: int, executor: DrainingExecutor) -> None:
        """Serve what the period made ready, then announce the period.

        With a client joined the drain is complete (no wall budget): every answer, feedback
        and result due in this period goes out before the announcement that counts it.
        """
        if self.gate.active and executor.resumable:  # requests wait for the gate anyway
            drain_completely(executor)
        self._last = self._announcements.encode(
            period=period, sim_time_ns=sim_time_ns, messages=self.messages, served=self.served,
            answers=self.answers)
        self._announcer.publish(self._last)
        self.gate.announced(period)

    def await_client(self, executor: DrainingExecutor, *, wall_s: float,
                     meanwhile: Callable[[], None]) -> None:
        """Serve requests until a client joins or ``wall_s`` of wall time has passed.

        Held at the first period, every run that joins meets the same world: the task then
        starts at the same sim time whenever the client's process got going. ``meanwhile``
        runs every :data:`GATE_WAIT_S` (the node repeats its clock for late subscribers).
        """
        deadline = time.monotonic() + wall_s
        while not self.gate.active and time.monotonic() < deadline:
            meanwhile()
            executor.wait_and_run(timeout_sec=GATE_WAIT_S)
        if not self.gate.active:
            self.node.get_logger().warning(
                f"lockstep: no client joined within {wall_s:.0f} s of wall time; running on")

    def hold(self, executor: DrainingExecutor) -> None:
        """Until every joined client is done with the period, then serve its requests in order.

        The done messages are taken and waited for by :class:`DoneInbox`, without rclpy's
        executor, which runs only when the gate lacks requests (they must be taken to be
        served) and once :data:`LOOK_EVERY_PERIODS` periods and :data:`LOOK_EVERY_S` have passed
        since it last looked.
        A client the gate waited on for too long is dropped, with one warning naming it.
        """
        self._periods_unlooked += 1
        while self.gate.active and not self.dones.take():
            if self.gate.lacks_done():
                self.dones.wait(executor, timeout_s=GATE_WAIT_S)
            else:
                self._periods_unlooked = 0
                executor.wait_and_run(timeout_sec=GATE_WAIT_S)
            self._drop_silent()
        if self._periods_unlooked >= LOOK_EVERY_PERIODS and (
                (now := time.monotonic()) >= self._next_look_s):
            self._periods_unlooked, self._next_look_s = 0, now + LOOK_EVERY_S
            executor.run_ready()
        self.admit(executor)
        self._readers = self.gate.readers_next() if self.gate.active else None
        if self._readers:
            self._await_readers(executor, self._readers)

    def _await_readers(self, executor: DrainingExecutor, readers: dict[str, int]) -> None:
        """Until each topic's writer has matched the subscriptions the clients read it with:
        a message published before would not reach a reader its writer has not matched."""
        deadline = time.monotonic() + MATCH_WAIT_S
        for topic, count in sorted(readers.items()):
            writer = self._writer(topic)
            if writer is None:
                continue
            while writer.get_subscription_count() < count:
                if time.monotonic() > deadline:
                    self.node.get_logger().warning(
                        f"lockstep: {topic} has matched {writer.get_subscription_count()} of "
                        f"the {count} reader(s) the clients named after {MATCH_WAIT_S:.0f} s "
                        f"of wall time; stepping period {self.gate.period + 1} all the same")
                    break
                executor.wait_and_run(timeout_sec=GATE_WAIT_S / 10.0)

    def _writer(self, topic: str) -> Any:
        """The node's publisher on ``topic``, or None if it publishes none."""
        writer = self._writers.get(topic)
        if writer is None:
            writer = next((publisher for publisher in self.node.publishers
                           if publisher.topic_name == topic), None)
            if writer is not None:
                self._writers[topic] = writer
        return writer

    def _drop_silent(self) -> None:
        now = time.monotonic()
        missing = self.gate.missing() if self.gate.overdue(now) else []  # words only for a drop
        for name in self.gate.drop_silent(now):
            self.node.get_logger().warning(
                f"lockstep: dropped client {name!r} after {self.gate.drop_after_s:.0f} s "
                f"of wall time at period {self.gate.period} without {', '.join(missing)}; "
                f"{'running free' if not self.gate.active else 'going on with the rest'}")

    def admit(self, executor: DrainingExecutor) -> None:
        """Serve the admitted requests one at a time, in the gate's order."""
        for admission in self.gate.due_admissions():
            admission.serve()
            executor.note_resumable()
            drain_completely(executor)

    # ------------------------------------------------------------- protocol
    def last_announcement(self) -> LockstepPeriod:
        """The last period announced, as announced (period 0 before the first)."""
        if self._last is None:
            return LockstepPeriod(period=0)
        return deserialize_message(self._last, LockstepPeriod)



def drain_completely(executor: DrainingExecutor) -> None:
    """Run everything ready, with no wall budget; nothing at all when nothing is ready."""
    budget, executor.drain_budget_s = executor.drain_budget_s, math.inf
    try:
        executor.run_ready()
    finally:
        executor.drain_budget_s = budget


class CountingActionServer(ActionServer[Any, Any, Any]):
    """rclpy's action server, counting the requests it takes and the answers it sends, and
    serving its requests through the gate.

    Goal and cancel answers go out as their request is served; a result when the goal ends
    (or at once for a goal the server does not know). While a client is joined a request is
    served only when the gate admits it, as a service's: rclpy answers goal and cancel
    requests as it takes them, and a request of tick *k* taken while the simulator steps
    *k*+1 would otherwise be answered in period *k*+1 or *k*+2 by luck. The result is counted
    in ``_send_result_response``, rclpy's own (private, Kilted) hook for sending it: no public
    callback sees it go.
    """

    KINDS = ("goal", "cancel", "result")

    def __init__(self, node: Node, action_type: Any, action_name: str, *,
                 lockstep: LockstepServer, **kwargs: Any) -> None:
        self._lockstep = lockstep
        self._endpoint = action_name
        lockstep.gate.endpoints.update(f"{action_name}:{kind}" for kind in self.KINDS)
        lockstep.served.update(f"{action_name}:{kind}" for kind in (*self.KINDS, "feedback"))
        super().__init__(node, action_type, action_name, **kwargs)

    async def execute(self, taken_data: Any) -> None:
        turns = {kind: self._lockstep.turn(f"{self._endpoint}:{kind}",
                                           self._lockstep.took(f"{self._endpoint}:{kind}"))
                 for kind in self.KINDS if kind in taken_data}
        for kind, turn in turns.items():
            if turn is not None:
                await turn
            await self._serve(kind, taken_data[kind])
        if "expired" in taken_data:
            await self._execute_expire_goals(taken_data["expired"])

    async def _serve(self, kind: str, request: Any) -> None:
        endpoint = f"{self._endpoint}:{kind}"
        if kind == "goal":
            await self._execute_goal_request(request)
            self._lockstep.answered(endpoint)
        elif kind == "cancel":
            await self._execute_cancel_request(request)
            self._lockstep.answered(endpoint)
        else:
            unknown = bytes(request[1].goal_id.uuid) not in self._goal_handles
            await self._execute_get_result_request(request)
            if unknown:
                self._lockstep.answered(endpoint)

    def _send_result_response(self, request_header: Any, future: Any) -> None:
        super()._send_result_response(request_header, future)
        self._lockstep.answered(f"{self._endpoint}:result")
