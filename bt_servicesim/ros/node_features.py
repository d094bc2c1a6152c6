"""What the plumbing may ask of a node beyond rclpy's ``Node``, asked for by type.

The tickers, shared subscriptions, lockstep and the executive take any rclpy node: a test's
plain node, a tool's, or the run's :class:`~bt_servicesim.ros.node.ExecutiveNode`. Only the
last keeps what a callback raised instead of letting it kill the process, counts its traffic
and joins lockstep, and each of those is a feature the code must do without on another node.
So each is a :class:`typing.Protocol`, checked with ``isinstance`` where a node comes in: the
type checker sees what a node offers, and a node that offers it need not inherit from anything
(``ExecutiveNode`` matches by its attributes alone).

* :class:`ErrorKeeper` (here): keeps the first error a callback or a tick raised, for the run
  to fail the mission with; elsewhere the caller logs or raises it.
* :class:`~bt_servicesim.ros.lockstep.LockstepHost` (beside the client it hosts): counts what
  passes its doors and holds its lockstep client once joined; elsewhere the node runs free on
  its clock and hands every message on as it comes.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["ErrorKeeper", "keep_error"]


@runtime_checkable
class ErrorKeeper(Protocol):
    """A node that keeps the first error its callbacks or ticks raised."""

    def note_error(self, error: BaseException, *, where: str) -> None:
        """Keep ``error``, raised in ``where``, unless one is kept already."""


def keep_error(node: object, error: BaseException, *, where: str) -> bool:
    """Keep ``error`` on ``node`` if it is an :class:`ErrorKeeper`; whether it was kept."""
    if isinstance(node, ErrorKeeper):
        node.note_error(error, where=where)
        return True
    return False
