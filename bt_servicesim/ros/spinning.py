"""What code that waits on ROS needs of an executor: one turn at a time.

A run waits for its backend, its discovery and its lockstep join by spinning the node's
executor one bounded turn at a time (``spin_once``) until a condition holds or a wall-time
limit passes. The run hands these waits an executor wrapped so that a deferred stop signal is
raised between turns (:class:`~bt_servicesim.mission.stopping.BetweenSpins`), not rclpy's
``Executor`` itself: so they take any :class:`Spinner`.
"""

from __future__ import annotations

from typing import Protocol

__all__ = ["Spinner"]


class Spinner(Protocol):
    """An executor as the waits use it."""

    def spin_once(self, timeout_sec: float | None = None) -> None:
        """Run one callback that is ready, or wait up to ``timeout_sec`` for one."""
