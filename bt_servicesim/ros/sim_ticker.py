"""A periodic callback on sim time that needs no ROS timer.

Both executives run on sim time: the tree ticks every 0.1 sim s and the baseline polls its
state machine. rclpy's timers on ROS time work with its Python executors but not with its C++
``EventsExecutor`` (Kilted: a 0.1 sim s timer fired about every 0.6 sim s), which the run
spins because it takes a message for a quarter of the CPU (:mod:`bt_servicesim.mission.run`).
So :class:`SimTicker` keeps the period from the node's clock itself: a jump handler on the
clock sees every ``/clock`` update once the clock has taken it, and when a period is due the
callback is scheduled as a task on the node's executor, never run inside the clock's own
callback.

Design intent:

* due times lie on a fixed grid from the start (start + k·period), as rclpy's timers do;
  periods missed while the process was busy are skipped, not made up (a tree ticked twice in
  a row would see no time pass between the two);
* a clock update within a tenth of a period of a due time counts as reaching it: sim stamps
  are floats rounded to nanoseconds, and a stamp a nanosecond short of the due time would
  otherwise put every tick off to the next update, halving the rate;
* :meth:`SimTicker.cancel` unregisters the handler, and a tick already scheduled then does
  nothing.

On a node without sim time (its clock never jumps) the ticker falls back to a plain timer.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from rclpy.clock import JumpThreshold, ROSClock
from rclpy.duration import Duration
from rclpy.node import Node

from bt_servicesim.ros.lockstep import lockstep_of
from bt_servicesim.ros.node_features import keep_error
from bt_servicesim.ros.sim_clock import clock_now_ns

__all__ = ["SimTicker", "Ticker", "sim_ticker"]

_LIVE: dict[int, set[SimTicker]] = {}
"""Tickers registered on a clock, by node, kept alive until cancelled."""
DUE_TOLERANCE = 0.1
"""How early, as a share of the period, a clock update may be and still count as due."""


class SimTicker:
    """Calls ``callback`` every ``period_s`` of the node's sim time (see module docstring)."""

    def __init__(self, node: Node, period_s: float, callback: Callable[[], None]) -> None:
        if not period_s > 0.0:
            raise ValueError(f"tick period {period_s}: must be more than 0")
        self.node = node
        self.callback = callback
        self._period_ns = round(period_s * 1e9)
        self._tolerance_ns = round(self._period_ns * DUE_TOLERANCE)
        self._clock = node.get_clock()
        self._start_ns = clock_now_ns(self._clock)
        self._due_ns = self._start_ns + self._period_ns  # the first call a period on, as a timer
        self._scheduled = False
        self._cancelled = False
        self._timer = None
        self._jump_handle = None
        self.error: Exception | None = None
        """What the callback raised, if it did: the ticker stops then."""
        if isinstance(self._clock, ROSClock) and self._clock.ros_time_is_active:
            if node.executor is None:
                raise RuntimeError(f"{node.get_name()}: add the node to an executor before "
                                   "ticking on its sim clock")
            threshold = JumpThreshold(min_forward=Duration(nanoseconds=1), min_backward=None,
                                      on_clock_change=False)
            self._jump_handle = self._clock.create_jump_callback(
                threshold, post_callback=self._on_clock)
            # rclpy's clock keeps only a raw pointer to the handle: a ticker nobody holds on to
            # would be collected while registered, and the clock would call freed memory
            _LIVE.setdefault(id(node), set()).add(self)
        else:
            # the EventsExecutor hands a timer's callback a TimerInfo; the ticker needs none
            self._timer = node.create_timer(period_s, lambda *_info: self._tick())

    def cancel(self) -> None:
        """No more calls; idempotent."""
        self._cancelled = True
        if self._jump_handle is not None:
            self._jump_handle.unregister()
            self._jump_handle = None
            _LIVE.get(id(self.node), set()).discard(self)
        if self._timer is not None:
            self.node.destroy_timer(self._timer)
            self._timer = None

    def _on_clock(self, _jump: object) -> None:
        if self._scheduled or self._cancelled:
            return
        if clock_now_ns(self._clock) + self._tolerance_ns >= self._due_ns:
            executor = self.node.executor
            if executor is None:
                raise RuntimeError(f"{self.node.get_name()}: left its executor while ticking")
            self._scheduled = True
            executor.create_task(self._fire)

    def _fire(self) -> None:
        self._scheduled = False
        if self._cancelled:
            return
        reached = clock_now_ns(self._clock) + self._tolerance_ns
        if reached < self._due_ns:  # time went back after it was scheduled
            return
        periods = (reached - self._start_ns) // self._period_ns + 1
        self._due_ns = self._start_ns + periods * self._period_ns
        self._tick()

    def _tick(self) -> None:
        if self._cancelled:
            return
        try:
            self.callback()
        except Exception as error:  # escaping an executor's callback kills the process
            self.cancel()
            self.error = error
            if not keep_error(self.node, error, where="a tick"):
                self.node.get_logger().error(f"tick raised {type(error).__name__}: {error}")


class Ticker(Protocol):
    """What a ticker on sim time offers, in lockstep or not."""

    error: Exception | None
    """What the callback raised, if it did: the ticker stops then."""

    def cancel(self) -> None:
        """No more calls; idempotent."""


def sim_ticker(node: Node, period_s: float, callback: Callable[[], None]) -> Ticker:
    """A ticker on the node's sim time: in lockstep once the node has joined one
    (:mod:`bt_servicesim.ros.lockstep`: exactly once per announced period), else a
    :class:`SimTicker`."""
    lockstep = lockstep_of(node)
    if lockstep is not None:
        return lockstep.ticker(period_s, callback)
    return SimTicker(node, period_s, callback)
