"""The clients' done messages, taken straight from their subscription into the gate.

Design intent: the loop waits for dones every period, so :class:`DoneInbox` takes them itself
and waits on a wait set of their subscription alone: handing each over to rclpy's executor (a
wait set of every entity, its callback bookkeeping, a look for more) cost the loop about as
much as the rest of the gate. The bytes are read by
:class:`~servicesim_sim.lockstep.message.DoneReader`; a done that says the client is leaving
takes it out of the gate.
"""

from __future__ import annotations

from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.exceptions import InvalidHandle
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.qos import QoSProfile
from servicesim_competition.msg import LockstepDone

from servicesim_sim.lockstep.gate import LockstepGate
from servicesim_sim.lockstep.message import DoneReader
from servicesim_sim.process.executor import DrainingExecutor

__all__ = ["DoneInbox"]


class DoneInbox:
    """The subscription to ``topic`` on ``node``, feeding ``gate``.

    rclpy's executor still runs :meth:`receive` for a done it takes first (the subscription is
    in the node's ``callback_group``); :meth:`take` empties the queue without it.
    """

    def __init__(self, node: Node, *, gate: LockstepGate, topic: str, qos: QoSProfile,
                 callback_group: CallbackGroup) -> None:
        self.node = node
        self.gate = gate
        self._reader = DoneReader()
        self._subscription = node.create_subscription(  # raw: DoneReader reads the bytes
            LockstepDone, topic, self.receive, qos, raw=True, callback_group=callback_group)

    def take(self) -> bool:
        """Take the done messages waiting; whether the gate is open now."""
        subscription = self._subscription
        while True:
            try:
                with subscription.handle:  # None once the queue is empty (rclpy's stub omits it)
                    taken: tuple[bytes, Any] | None = subscription.handle.take_message(
                        LockstepDone, True)
            except InvalidHandle:
                return self.gate.is_open()
            if taken is None:
                return self.gate.is_open()
            self.receive(taken[0])

    def wait(self, executor: DrainingExecutor, *, timeout_s: float) -> None:
        """Block until a done message waits, the context shuts down or ``timeout_s`` passed."""
        guard = executor.shutting_down
        context = self.node.context.handle
        if context is None:
            raise RuntimeError("lockstep: the simulator's context is destroyed")
        with self._subscription.handle, guard.handle, context:
            wait_set = rclpy_implementation.WaitSet(1, 1, 0, 0, 0, 0, context)
            try:
                wait_set.add_subscription(self._subscription.handle)
                wait_set.add_guard_condition(guard.handle)
                wait_set.wait(int(timeout_s * 1e9))
            finally:
                wait_set.destroy_when_not_in_use()

    def receive(self, data: bytes) -> None:
        """A done message, serialised."""
        done = self._reader.read(data)
        if done.leaving:
            name = self.gate.leave(done.client)
            if name is not None:
                self.node.get_logger().info(f"lockstep: client {name!r} left")
            return
        self.gate.done(done.client, done.period, done.requests, done.readings)
