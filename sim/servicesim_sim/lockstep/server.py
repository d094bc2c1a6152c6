"""The lockstep server: the simulator's side of the lockstep extension, on its ROS node.

:class:`LockstepServer` counts what the node publishes and answers, announces each period, and
wraps the node's request handlers so that, while a client is joined, a request is served only
when the gate (:mod:`servicesim_sim.lockstep.gate`) admits it: one at a time, in the gate's
order, each run to its first wait before the next starts. :class:`CountingActionServer` does
the same for the navigation action's goal, cancel and result requests, which rclpy would
answer as it takes them. With nobody joined every handler runs at once, ungated: a client that
never joins (a ``ros2`` command, an executive that runs free) sees no difference.

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
from rclpy.duration import Duration
from rclpy.exceptions import InvalidHandle
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rclpy.task import Future
from servicesim_competition.msg import LockstepDone, LockstepPeriod
from servicesim_competition.srv import LockstepJoin

from servicesim_sim.lockstep.gate import PIPELINE_LAG, Admission, LockstepGate
from servicesim_sim.lockstep.message import AnnouncementBytes, DoneReader
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
JOIN_ACK_WAIT_S = 1.0
"""Wall seconds a join waits at most for every reader to acknowledge what was published."""
LOOK_EVERY_PERIODS = 10
"""In lockstep the loop hands over to rclpy only when a coroutine resumes or the gate lacks a
request; at least this often it looks for other work (a join, a request from outside)."""


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
        self._done_reader = DoneReader()
        self._last: bytes | None = None
        """The last announcement, serialised (:mod:`servicesim_sim.lockstep.message`)."""
        self.callback_group = ReentrantCallbackGroup()
        """For every handler of the node: a handler waiting for its turn (or for sim time)
        must not keep the others from running, as one mutually exclusive group would -- the
        done message that opens the gate among them. The loop is one thread all the same."""
        self._announcer = node.create_publisher(LockstepPeriod, PERIOD_TOPIC, PROTOCOL_QOS)
        node.create_service(LockstepJoin, JOIN_SERVICE, self._on_join,
                            callback_group=self.callback_group)
        self._dones = node.create_subscription(  # raw: DoneReader reads the bytes
            LockstepDone, DONE_TOPIC, self._on_done, PROTOCOL_QOS, raw=True,
            callback_group=self.callback_group)
        self._periods_unlooked = 0

    @property
    def active(self) -> bool:
        return self.gate.active

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

        The done messages are taken here, straight from their subscription, and waited for on
        a wait set of that subscription alone: handing each over to rclpy's executor (a wait
        set of every entity, its callback bookkeeping, a look for more) cost the loop about as
        much as the rest of the gate. The executor runs only when the gate lacks requests
        (they must be taken to be served) and every :data:`LOOK_EVERY_PERIODS` periods.
        A client the gate waited on for too long is dropped, with one warning naming it.
        """
        self._periods_unlooked += 1
        while self.gate.active and not self._take_dones():
            if self.gate.lacks_done():
                self._wait_for_done(executor, timeout_s=GATE_WAIT_S)
            else:
                self._periods_unlooked = 0
                executor.wait_and_run(timeout_sec=GATE_WAIT_S)
            self._drop_silent()
        if self._periods_unlooked >= LOOK_EVERY_PERIODS:
            self._periods_unlooked = 0
            executor.run_ready()
        self.admit(executor)

    def _drop_silent(self) -> None:
        missing = self.gate.missing()
        for name in self.gate.drop_silent(time.monotonic()):
            self.node.get_logger().warning(
                f"lockstep: dropped client {name!r} after {self.gate.drop_after_s:.0f} s "
                f"of wall time at period {self.gate.period} without {', '.join(missing)}; "
                f"{'running free' if not self.gate.active else 'going on with the rest'}")

    def _take_dones(self) -> bool:
        """Take the done messages waiting; whether the gate is open now."""
        while True:
            try:
                with self._dones.handle:  # None once the queue is empty (rclpy's stub omits it)
                    taken: tuple[bytes, Any] | None = self._dones.handle.take_message(
                        LockstepDone, True)
            except InvalidHandle:
                return self.gate.is_open()
            if taken is None:
                return self.gate.is_open()
            self._on_done(taken[0])

    def _wait_for_done(self, executor: DrainingExecutor, *, timeout_s: float) -> None:
        """Block until a done message waits, the context shuts down or ``timeout_s`` passed."""
        guard = executor.shutting_down
        context = self.node.context.handle
        if context is None:
            raise RuntimeError("lockstep: the simulator's context is destroyed")
        with self._dones.handle, guard.handle, context:
            wait_set = rclpy_implementation.WaitSet(1, 1, 0, 0, 0, 0, context)
            try:
                wait_set.add_subscription(self._dones.handle)
                wait_set.add_guard_condition(guard.handle)
                wait_set.wait(int(timeout_s * 1e9))
            finally:
                wait_set.destroy_when_not_in_use()

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

    def _on_join(self, request: LockstepJoin.Request,
                 response: LockstepJoin.Response) -> LockstepJoin.Response:
        if not self._wait_for_acks(deadline=time.monotonic() + JOIN_ACK_WAIT_S):
            self.node.get_logger().warning(
                f"lockstep: a reader had not acknowledged everything published within "
                f"{JOIN_ACK_WAIT_S:g} s of wall time; client {request.name!r} joins all the "
                "same, and may count a message sent before its join as one sent after")
        response.client = self.gate.join(request.name)
        response.joined_at = self.last_announcement()
        self.node.get_logger().info(
            f"lockstep: client {request.name!r} joined at period {response.joined_at.period} "
            f"(id {response.client})")
        return response

    def _wait_for_acks(self, *, deadline: float) -> bool:
        """Until every reliable reader has acknowledged everything published so far (or the
        deadline passed); whether all had.

        Before a join is answered: a reader acknowledges a message once it holds it, and its
        process queued the message's arrival then, so what was sent before the join is queued
        in the client ahead of the answer (an executor takes its queue in order) instead of
        possibly after it, where the client's short wait for quiet would have to catch it
        (``bt_servicesim/ros/lockstep.py``, "JOIN_QUIET_S"). Acknowledgements take about a
        millisecond here (0.4-41 ms in three joins).
        """
        for publisher in list(self.node.publishers):
            left = deadline - time.monotonic()
            if left <= 0.0 or not publisher.wait_for_all_acked(Duration(seconds=left)):
                return False
        return True

    def _on_done(self, data: bytes) -> None:
        """A done message, serialised (:class:`~servicesim_sim.lockstep.message.DoneReader`)."""
        done = self._done_reader.read(data)
        if done.leaving:
            name = self.gate.leave(done.client)
            if name is not None:
                self.node.get_logger().info(f"lockstep: client {name!r} left")
            return
        self.gate.done(done.client, done.period, done.requests)


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
