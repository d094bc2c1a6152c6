"""Nav2's ``RecoveryNode``: run an action; when it fails, run a recovery and try the action again.

Without it a tree spells the pattern with four nodes -- ``Retry`` over a ``Fallback`` of the
action and a ``SuccessIsFailure`` around the recovery -- and gets it subtly wrong: the recovery
also runs after the last attempt, when nothing will use it, and a recovery that fails is retried
over as if it had worked. This control says what is meant in one node, with Nav2's semantics
(``nav2_behavior_tree/plugins/control/recovery_node.cpp``), so a tree written for Nav2 reads the
same here and Groot2 shows it as the control it is:

- exactly two children: first the action, second the recovery;
- the action succeeds: SUCCESS. It runs: RUNNING;
- the action fails while fewer than ``number_of_retries`` recoveries have succeeded: tick the
  recovery, in the same tick. It runs: RUNNING. It fails: FAILURE, no more attempts. It
  succeeds: one more retry spent, the recovery is reset and the action starts afresh, still in
  the same tick, as Nav2 loops;
- the action fails with every retry spent: FAILURE, and the recovery does not run.

So the action gets ``number_of_retries + 1`` attempts at most (a negative number allows one).
Each tick stays bounded: at most ``2 * (number_of_retries + 1)`` child ticks, and a child that
returns RUNNING ends the tick. ``number_of_retries`` is an input port (``number_of_retries="3"`` in
a tree file, or a ``{key}``), read on every tick as Nav2 does; unwired, the constructor's value
applies. The count of retries starts from zero each time the node starts; stopped from above (a
higher priority, a time limit), it stops whichever child is running, as every py_trees composite
does. Being a ``Composite``, it is a Control in the generated node model; the ports registry
knows it as the tag ``<RecoveryNode>``.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import py_trees
from py_trees.ports import PortInformation, PortsMixin

from bt_servicesim.behaviours.node import Ports, Status

__all__ = ["RecoveryNode"]

ACTION, RECOVERY = 0, 1


class RecoveryNode(PortsMixin, py_trees.composites.Composite):
    """The first child, retried after the second child (a recovery) succeeds; Nav2 semantics.

    Args:
        name: the control's name
        children: the action, then the recovery (exactly two)
        number_of_retries: recoveries allowed when the ``number_of_retries`` port is not wired
    """

    INPUT_PORTS: Ports = {
        "number_of_retries": PortInformation(
            data_type=int, required=False, default_value=1,
            description="recoveries (so retries of the action) allowed before FAILURE"),
    }
    OUTPUT_PORTS: Ports = {}

    def __init__(
        self,
        name: str = "RecoveryNode",
        children: Sequence[py_trees.behaviour.Behaviour] | None = None,
        number_of_retries: int = 1,
        **kwargs: Any,
    ) -> None:
        super().__init__(name=name, children=children, **kwargs)
        if children is not None:
            self._check_children()
        self.number_of_retries = int(number_of_retries)
        self.retries = 0
        self._index = ACTION

    def initialise(self) -> None:
        """Start over: no retry spent, the action first."""
        self.retries = 0
        self._index = ACTION

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """Tick the action, and the recovery after a failure, as Nav2's ``RecoveryNode::tick``.

        Yields:
            every behaviour ticked below this one, then this one
        """
        self.logger.debug(f"{self.__class__.__name__}.tick()")
        self._check_children()
        if self.status != Status.RUNNING:
            for child in self.children:  # a fresh start, as a Sequence makes one
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
            self.initialise()
        allowed = self._allowed_retries()
        action, recovery = self.children
        while True:
            child = self.children[self._index]
            self.current_child = child
            yield from child.tick()
            attempt = f"attempt {self.retries + 1} of {max(allowed, 0) + 1}"
            if child.status == Status.RUNNING:
                self.feedback_message = (f"{attempt} running" if child is action
                                         else f"recovering after {attempt} failed")
                self.status = Status.RUNNING
                yield self
                return
            if child is action and child.status == Status.SUCCESS:
                self.feedback_message = f"{attempt} succeeded"
                self.stop(Status.SUCCESS)
                yield self
                return
            if child is action and self.retries >= allowed:
                self.feedback_message = f"{attempt} failed: no retry left"
                self.stop(Status.FAILURE)
                yield self
                return
            if child is action:
                self._index = RECOVERY
                continue
            if child.status != Status.SUCCESS:
                self.feedback_message = f"the recovery after {attempt} failed"
                self.stop(Status.FAILURE)
                yield self
                return
            self.retries += 1
            recovery.stop(Status.INVALID)  # halted, as Nav2 halts it
            action.stop(Status.INVALID)  # the action starts afresh
            self._index = ACTION

    def terminate(self, new_status: Status) -> None:
        """Note an interruption; ``Composite.stop`` stops the running child."""
        if new_status == Status.INVALID:
            self.feedback_message = "interrupted"

    def _allowed_retries(self) -> int:
        """The ``number_of_retries`` port's value when it has one, else the constructor's."""
        if self._blackboard_client is None:  # built in code: no ports set up
            return self.number_of_retries
        return int(self.get_input("number_of_retries", default=self.number_of_retries))

    def _check_children(self) -> None:
        if len(self.children) != 2:
            raise ValueError(
                f"RecoveryNode '{self.name}' needs exactly 2 children (the action, then the "
                f"recovery), not {len(self.children)}")
