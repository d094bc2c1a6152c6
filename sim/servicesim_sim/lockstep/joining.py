"""The join service: a client joins the gate once the simulator's readers hold what was sent.

Design intent: a reader acknowledges a message once it holds it, and its process queued the
message's arrival then. Answering a join only after every reliable reader acknowledged
everything published puts what was sent before the join in the client's queues ahead of the
answer (an executor takes its queue in order) instead of possibly after it, where the client's
short wait for quiet would have to catch it (``bt_servicesim/ros/lockstep.py``,
"JOIN_QUIET_S"). Acknowledgements take about a millisecond here (0.4-41 ms in three joins).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from rclpy.callback_groups import CallbackGroup
from rclpy.duration import Duration
from rclpy.node import Node
from servicesim_competition.msg import LockstepPeriod
from servicesim_competition.srv import LockstepJoin

from servicesim_sim.lockstep.gate import LockstepGate

__all__ = ["JOIN_ACK_WAIT_S", "JoinService"]

JOIN_ACK_WAIT_S = 1.0
"""Wall seconds a join waits at most for every reader to acknowledge what was published."""


class JoinService:
    """``service`` on ``node``: joins a client to ``gate`` at the period ``announced()`` gives."""

    def __init__(self, node: Node, *, gate: LockstepGate, service: str,
                 announced: Callable[[], LockstepPeriod], callback_group: CallbackGroup) -> None:
        self.node = node
        self.gate = gate
        self._announced = announced
        node.create_service(LockstepJoin, service, self.answer, callback_group=callback_group)

    def answer(self, request: LockstepJoin.Request,
               response: LockstepJoin.Response) -> LockstepJoin.Response:
        if not self._wait_for_acks(deadline=time.monotonic() + JOIN_ACK_WAIT_S):
            self.node.get_logger().warning(
                f"lockstep: a reader had not acknowledged everything published within "
                f"{JOIN_ACK_WAIT_S:g} s of wall time; client {request.name!r} joins all the "
                "same, and may count a message sent before its join as one sent after")
        response.client = self.gate.join(request.name)
        response.joined_at = self._announced()
        self.node.get_logger().info(
            f"lockstep: client {request.name!r} joined at period {response.joined_at.period} "
            f"(id {response.client})")
        return response

    def _wait_for_acks(self, *, deadline: float) -> bool:
        """Until every reliable reader has acknowledged everything published so far (or the
        deadline passed); whether all had."""
        for publisher in list(self.node.publishers):
            left = deadline - time.monotonic()
            if left <= 0.0 or not publisher.wait_for_all_acked(Duration(seconds=left)):
                return False
        return True
