"""Tick a mission tree on a ROS node, in simulation time.

The executive owns no mission logic: it sets the tree up with the node (every behaviour creates
its ROS handles in ``setup``), ticks it every 0.1 s of the node's clock — which follows
``/clock`` when the node runs with ``use_sim_time`` (:mod:`bt_servicesim.ros.sim_ticker`) — and
remembers how the mission ended.
Interrupting it stops the tree, so behaviours cancel whatever they have in flight.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import py_trees
from rclpy.node import Node

from bt_servicesim.ros.node_features import keep_error
from bt_servicesim.ros.sim_ticker import Ticker, sim_ticker
from bt_servicesim.tree.lean_tree import LeanBehaviourTree
from bt_servicesim.tree.loading import DEFAULT_PHASES
from bt_servicesim.tree.shape import short_label

Status = py_trees.common.Status
TickHandler = Callable[[py_trees.trees.BehaviourTree], None]


class Executive(Protocol):
    """What the run command needs of an executive: the behaviour tree, or the seed's baseline."""

    outcome: py_trees.common.Status | None

    def setup(self, *, timeout_s: float = 15.0) -> None: ...
    def start(self) -> None: ...
    @property
    def finished(self) -> bool: ...
    def interrupt(self) -> None: ...
    def phase(self) -> str: ...
    def activity(self) -> str: ...


class MissionExecutive:
    """Runs one mission tree to SUCCESS or FAILURE."""

    def __init__(
        self,
        *,
        node: Node,
        root: py_trees.behaviour.Behaviour,
        tick_period_s: float = 0.1,
        phases: str = DEFAULT_PHASES,
        run_seed: int | None = None,
    ) -> None:
        """``phases`` names the composite whose children are the mission's phases
        (:func:`~bt_servicesim.tree.loading.phases_of` reads it from the tree file);
        ``run_seed``, the run's seed, is handed to every behaviour's ``setup`` (as
        ``run_seed``): a behaviour that draws random numbers draws them from it."""
        self.node = node
        self.run_seed = run_seed
        self.phases = phases
        self.tree = LeanBehaviourTree(root=root)
        self.tick_period_s = tick_period_s
        self.outcome: Status | None = None
        self.error: str | None = None
        """What a tick raised, as one line, when the mission failed because of it."""
        self.ticks = 0
        self._ticker: Ticker | None = None
        self._phase: tuple[int, str] = (-1, "-")

    def setup(self, *, timeout_s: float = 15.0) -> None:
        """Create every behaviour's ROS handles (publishers, clients, subscriptions)."""
        self.tree.setup(timeout=timeout_s, node=self.node, run_seed=self.run_seed)

    def add_post_tick_handler(self, handler: TickHandler) -> None:
        self.tree.add_post_tick_handler(handler)

    def start(self) -> None:
        """Tick every ``tick_period_s`` of the node's clock (sim time under ``use_sim_time``)."""
        self._ticker = sim_ticker(self.node, self.tick_period_s, self.tick)

    @property
    def finished(self) -> bool:
        return self.outcome is not None

    def tick(self) -> None:
        if self.finished:
            return
        try:
            self.tree.tick()
        except Exception as error:  # a behaviour's bug ends the mission, not the process
            self._fail(error)
            return
        self.ticks += 1
        if self.tree.root.status in (Status.SUCCESS, Status.FAILURE):
            self.outcome = self.tree.root.status
            self.stop_ticking()

    def _fail(self, error: Exception) -> None:
        """A tick raised: the mission fails with what it raised, and nothing stays in flight."""
        self.outcome = Status.FAILURE
        self.stop_ticking()
        where = _raising_behaviour(error) or "the tree"
        self.error = f"{type(error).__name__} in {where}: {' '.join(str(error).split())}"
        keep_error(self.node, error, where=where)
        try:
            self.tree.root.stop(Status.INVALID)
        except Exception as stop_error:  # stopping a broken tree may raise again: keep the first
            self.node.get_logger().warning(f"stopping the tree raised {stop_error!r}")

    def stop_ticking(self) -> None:
        if self._ticker is not None:
            self._ticker.cancel()
            self._ticker = None

    def interrupt(self) -> None:
        """Stop the tree: running behaviours are terminated and cancel what is in flight."""
        self.stop_ticking()
        self.tree.root.stop(Status.INVALID)

    def phase(self) -> str:
        """The running child of the phases' composite (BeginTask, Pickup, ...), else "-".

        The run asks after every callback it spins; the answer changes only with a tick.
        """
        if self._phase[0] != self.ticks:
            self._phase = (self.ticks, self._find_phase())
        return self._phase[1]

    def _find_phase(self) -> str:
        """The phases' composite's running child, named as the tree file places it.

        A phase wrapped in decorators (a retry) is named by what they wrap; a phase that is a
        subtree by its ``<SubTree name=...>``, which the parser puts in the qualified name
        between the subtree's parent and its root (``Mission.PickupPhaseRetry.Pickup.FetchGuest``:
        ``Pickup``); any other phase by its own name.
        """
        node, phase = self.tree.root.tip(), None
        while node is not None and node.parent is not None:
            if not isinstance(node, py_trees.decorators.Decorator):
                phase = node
            if short_label(node.parent.name) == self.phases:
                named = phase or node
                parent = named.parent or node.parent  # named is node or below it: never None
                return named.name[len(parent.name) + 1:].split(".", 1)[0]
            node = node.parent
        return "-"

    def activity(self) -> str:
        """The running leaf and its feedback, for a progress line."""
        tip = self.tree.root.tip()
        if tip is None:
            return ""
        leaf = short_label(tip.name)
        return f"{leaf}: {tip.feedback_message}" if tip.feedback_message else leaf


def _raising_behaviour(error: BaseException) -> str | None:
    """The short name of the innermost behaviour whose method the exception passed through."""
    name = None
    frame = error.__traceback__
    while frame is not None:
        candidate = frame.tb_frame.f_locals.get("self")
        if isinstance(candidate, py_trees.behaviour.Behaviour):
            name = short_label(candidate.name)
        frame = frame.tb_next
    return name
