"""What the simulator's periods cost it: CPU time of the loop's thread, summed over a task.

Design intent: the simulator's CPU per sim second is what sets how many episodes an hour two
cores play, and the part of it spent in the model (the physics steps) against the part spent
turning it into messages is the first thing to know about a change. The loop reads its own
thread's CPU clock (``time.thread_time``, three reads a period, about a microsecond each)
between its stages and logs the means once the episode ends, so a benchmark has the figure
from any whole mission without a profiler (``benchmarks/cpu_per_sim_second.py`` reads it).
Only periods of a running task count: before it the loop waits for the executive, after it
the records' end. Nothing here feeds back into the simulation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

__all__ = ["SUMMARY_PREFIX", "PeriodCosts"]

SUMMARY_PREFIX = "CPU per period of the task"
"""How the logged summary line starts (the benchmark looks for it)."""


@dataclass
class PeriodCosts:
    """Sums of the loop thread's CPU seconds over the periods counted so far."""

    periods: int = 0
    step_s: float = 0.0
    """The physics steps (and the camera's frames)."""
    publishing_s: float = 0.0
    """The period's messages."""
    period_s: float = 0.0
    """The whole period: steps, messages, requests served, the lockstep's waits."""

    @staticmethod
    def now() -> float:
        """The loop thread's CPU clock, in seconds."""
        return time.thread_time()

    def add(self, *, started: float, stepped: float, published: float, ended: float) -> None:
        """One period, from four readings of :meth:`now`: at its start, after the physics
        steps, after its messages, and at its end."""
        self.periods += 1
        self.step_s += stepped - started
        self.publishing_s += published - stepped
        self.period_s += ended - started

    def summary(self) -> str:
        """One line: the mean milliseconds per period of each stage."""
        if self.periods == 0:
            return f"{SUMMARY_PREFIX}: no period of a running task"
        scale = 1e3 / self.periods
        return (f"{SUMMARY_PREFIX} ({self.periods} periods, the loop thread's CPU): "
                f"step {self.step_s * scale:.3f} ms, publishing {self.publishing_s * scale:.3f} "
                f"ms, whole period {self.period_s * scale:.3f} ms")
