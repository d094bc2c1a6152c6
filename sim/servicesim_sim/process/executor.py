"""The simulator's executor: run what is ready, wait for requests, never spin on a parked task.

The simulator's loop owns time: it steps the engine, publishes, then lets rclpy handle what
arrived, and with a speed factor waits for the wall clock. Two things make rclpy's
``SingleThreadedExecutor`` a poor fit for that loop as it stands:

* it yields every unfinished coroutine task before it waits. A navigation goal's result
  coroutine stays unfinished for the whole goal, so ``spin_once(timeout)`` resumed it and
  returned at once instead of waiting: a simulator pacing itself at speed 5 kept a core busy
  for as long as the robot drove, and two such simulators (an evaluation at ``--jobs 2``)
  left their executives none;
* each pass also resumes that coroutine once more and sorts every entity through callback
  groups and task lists before it waits: about 210 µs per I/O period in a driven mission,
  mostly to find nothing new.

So :class:`DrainingExecutor` waits on its nodes' entities only (:class:`EntityWaitSet`:
subscriptions, services, clients, waitables such as the action server, and a guard condition
the context's shutdown triggers) and hands over to rclpy's executor only when one of them has
work, or when the loop itself completed a future a coroutine awaits (a navigation result, a
sim-time sleep) and says so with :meth:`DrainingExecutor.note_resumable`. Those are the only
ways anything new becomes runnable here: the simulator has no timers and no guard conditions
of its own. Looking costs about 170 µs a period; a paced loop looks while it waits, so
only a loop at speed 0 or behind its schedule pays it.

A burst must be served whole, and a flood must not stop the world: one pass of rclpy's executor
(one wait) takes at most *one* request from each service and the action server, so a drain
repeats passes for as long as an entity still has work, until nothing is left or it has spent
:data:`DRAIN_BUDGET_S` of wall time; the rest waits for the next drain, after the loop has
stepped. A drain that ended after its first pass served one request per service per I/O
period: 50 waiting requests took 50 drains.
"""

from __future__ import annotations

import time
from typing import Any

from rclpy.exceptions import InvalidHandle
from rclpy.executors import ShutdownException, SingleThreadedExecutor, TimeoutException
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.logging import get_logger
from rclpy.node import Node
from rclpy.waitable import NumberOfEntities

_READY_KINDS = ("subscription", "client", "service", "timer", "guard_condition")
#: The most wall time one drain spends before the loop steps on: a flood of requests slows
#: the simulation (its pacer then slips) but never stops it. Each I/O period drains at least
#: once, so at speed 0 a flood still gets this much time every 0.1 sim s.
DRAIN_BUDGET_S = 0.05
RCLError = rclpy_implementation.RCLError


class EntityWaitSet:
    """A wait over some nodes' entities that says whether any of them has work.

    Only entities are waited on, never tasks, so a wait with a timeout really blocks. Each
    wait builds its rcl wait set directly (a few microseconds), without the executor's
    callback-group and task bookkeeping, and destroys it before returning: a wait set kept
    across waits outlived the ROS context at interpreter exit and aborted the process.
    """

    def __init__(self, nodes: list[Node], context: Any, *,
                 wake_up: GuardCondition | None = None) -> None:
        self.nodes = nodes
        self._context = context
        self._wake_up = () if wake_up is None else (wake_up,)

    def wait(self, timeout_sec: float) -> bool:
        """Wait up to ``timeout_sec`` (0: only look) for an entity to have work; whether one has.

        Every handle is held while the wait set uses it, as rclpy's executor holds them, so a
        node destroyed meanwhile (from another thread) is destroyed only after the wait; an
        entity already destroyed counts as work, for the executor to find out.
        """
        subscriptions, clients, services, timers, guards, waitables = self._current()
        held: list[Any] = []
        try:
            for entity in (*subscriptions, *clients, *services, *timers, *guards):
                entity.handle.__enter__()
                held.append(entity.handle)
            for waitable in waitables:
                waitable.__enter__()
                held.append(waitable)
            self._context.handle.__enter__()
            held.append(self._context.handle)
        except InvalidHandle:
            self._release(held)
            return True
        try:
            return self._wait(timeout_sec, subscriptions, clients, services, timers, guards,
                              waitables)
        finally:
            self._release(held)

    def _wait(self, timeout_sec: float, subscriptions: tuple[Any, ...],
              clients: tuple[Any, ...], services: tuple[Any, ...], timers: tuple[Any, ...],
              guards: tuple[Any, ...], waitables: tuple[Any, ...]) -> bool:
        wait_set = self._new_wait_set(subscriptions, clients, services, timers, guards,
                                      waitables)
        try:
            for subscription in subscriptions:
                wait_set.add_subscription(subscription.handle)
            for client in clients:
                wait_set.add_client(client.handle)
            for service in services:
                wait_set.add_service(service.handle)
            for timer in timers:
                wait_set.add_timer(timer.handle)
            for guard in guards:
                wait_set.add_guard_condition(guard.handle)
            for waitable in waitables:
                waitable.add_to_wait_set(wait_set)
            wait_set.wait(max(int(timeout_sec * 1e9), 0))
            if any(wait_set.get_ready_entities(kind) for kind in _READY_KINDS):
                return True
            return any(waitable.is_ready(wait_set) for waitable in waitables)
        finally:
            wait_set.destroy_when_not_in_use()

    @staticmethod
    def _release(held: list[Any]) -> None:
        for handle in reversed(held):
            handle.__exit__(None, None, None)

    def _current(self) -> tuple[tuple[Any, ...], ...]:
        """The nodes' entities now."""
        subscriptions, clients, services, timers, guards, waitables = (
            tuple(item for node in self.nodes for item in getattr(node, kind))
            for kind in ("subscriptions", "clients", "services", "timers", "guards",
                         "waitables"))
        return subscriptions, clients, services, timers, guards + self._wake_up, waitables

    def _new_wait_set(self, subscriptions: tuple[Any, ...], clients: tuple[Any, ...],
                      services: tuple[Any, ...], timers: tuple[Any, ...],
                      guards: tuple[Any, ...], waitables: tuple[Any, ...]) -> Any:
        count = NumberOfEntities(len(subscriptions), len(guards), len(timers), len(clients),
                                 len(services))
        for waitable in waitables:
            count += waitable.get_num_entities()
        return rclpy_implementation.WaitSet(
            count.num_subscriptions, count.num_guard_conditions, count.num_timers,
            count.num_clients, count.num_services, count.num_events, self._context.handle)


class DrainingExecutor(SingleThreadedExecutor):
    """An executor that runs everything ready now, and waits only for its entities.

    Once per I/O period all pending requests, goal and cancel messages and resumed
    service/navigation coroutines run before the loop steps on (a fixed number of
    ``spin_once`` calls would starve them when the sim runs many times faster than real time):
    through :meth:`wait_and_run` while the loop waits for the wall clock, else through
    :meth:`run_ready`. A drain is bounded by ``drain_budget_s`` of wall time.
    """

    def __init__(self, *args: Any, drain_budget_s: float = DRAIN_BUDGET_S,
                 **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.drain_budget_s = drain_budget_s
        self.refused_sends = 0
        self._entity_wait_set: EntityWaitSet | None = None
        self._resumable = True  # whatever was added before the first pass runs in it
        # the context shutting down ends a wait at once, as it does rclpy's own waits
        self._shutting_down = GuardCondition(None, None, context=self.context)
        self.context.on_shutdown(self._shutting_down.trigger)

    @property
    def shutting_down(self) -> GuardCondition:
        """The guard condition the context's shutdown triggers: for waits of the loop's own."""
        return self._shutting_down

    @property
    def resumable(self) -> bool:
        """Whether a coroutine may resume (or a task was created) since the last pass."""
        return self._resumable

    def drop_tasks_of(self, node: Node) -> int:
        """Cancel ``node``'s unfinished callbacks (coroutines waiting on sim time, navigation
        or the gate) before the node is removed for good; how many there were.

        rclpy keeps a removed node's unfinished tasks in its list for ever, never to run them
        again, with everything they hold: an episode reset would keep each old episode's
        engine alive. A cancelled task's coroutine is closed where it waits and the next pass
        forgets it. (rclpy has no public way to list a node's tasks: this reads its ``_tasks``.)
        """
        with self._tasks_lock:
            tasks = [task for task, _, owner in self._tasks if owner is node]
        for task in tasks:
            task.cancel()
        return len(tasks)

    def note_resumable(self) -> None:
        """The loop completed a future a coroutine awaits: the next pass must resume it."""
        self._resumable = True

    def run_ready(self) -> int:
        """Drain when an entity has work or a coroutine can resume; how many callbacks ran."""
        if self._resumable or self._entities().wait(0.0):
            return self.drain()
        return 0

    def wait_and_run(self, *, timeout_sec: float) -> int:
        """Block up to ``timeout_sec`` for an entity to have work, then drain."""
        if self._resumable or self._entities().wait(timeout_sec):
            return self.drain()
        return 0

    def create_task(self, callback: Any, *args: Any, **kwargs: Any) -> Any:
        """rclpy's ``create_task``; the new task runs in the current pass or the next one."""
        self._resumable = True
        return super().create_task(callback, *args, **kwargs)

    def drain(self) -> int:
        """Run ready callbacks until none is ready (or the budget is spent); how many ran.

        A pass takes one request from each entity with work; passes repeat while an entity
        still has some, or a task was created meanwhile (a goal's execution, a future's done
        callback), and end once ``drain_budget_s`` of wall time has gone.
        """
        deadline = time.monotonic() + self.drain_budget_s
        ran = 0
        while True:
            self._resumable = False
            ran += self._pass()
            if not (self._resumable or self._entities().wait(0.0)):
                return ran
            if time.monotonic() >= deadline:
                self._resumable = True  # the next drain goes on where this one stopped
                return ran

    def _pass(self) -> int:
        """One wait of rclpy's executor: run what it yields until it times out."""
        count = 0
        while True:
            try:
                handler, _, _ = self.wait_for_ready_callbacks(timeout_sec=0.0)
            except (TimeoutException, ShutdownException):
                return count
            handler()
            count += 1
            self._raise_from(handler)

    def _raise_from(self, handler: Any) -> None:
        """Raise what the callback raised, but a reply DDS refused only costs that reply.

        Writing an answer fails when DDS gives up on it (a client that vanished, a writer whose
        reader stopped acknowledging): the client is gone or stuck, and the world goes on.
        """
        try:
            handler.result()
        except RCLError as error:
            self.refused_sends += 1
            if self.refused_sends in (1, 10, 100) or self.refused_sends % 1000 == 0:
                get_logger("servicesim.executor").warning(
                    f"a reply was dropped ({self.refused_sends} so far): "
                    f"{str(error).splitlines()[0]}")

    def _entities(self) -> EntityWaitSet:
        nodes = self.get_nodes()
        if self._entity_wait_set is None or self._entity_wait_set.nodes != nodes:
            self._entity_wait_set = EntityWaitSet(nodes, self.context,
                                                  wake_up=self._shutting_down)
        return self._entity_wait_set
