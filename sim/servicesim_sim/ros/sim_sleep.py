"""Sleeping in sim time: futures the loop completes once enough sim time has passed.

Design intent: a handler that must wait in sim time (the service-latency knob) awaits one of
these futures rather than blocking, so the loop steps on meanwhile; the loop wakes the
sleepers after each period, in the order they fell asleep.
"""

from __future__ import annotations

from rclpy.task import Future

from servicesim_sim.lockstep.server import LockstepServer, drain_completely
from servicesim_sim.model.engine import SimEngine
from servicesim_sim.process.executor import DrainingExecutor


class SimSleepers:
    """The sleeps in progress on ``engine``'s sim clock."""

    def __init__(self, *, engine: SimEngine, lockstep: LockstepServer) -> None:
        self.engine = engine
        self.lockstep = lockstep
        self._sleepers: list[tuple[float, Future[bool]]] = []

    def sleep(self, seconds: float) -> Future[bool]:
        """A future completed by the loop once ``seconds`` of sim time have passed."""
        future: Future[bool] = Future()
        self._sleepers.append((self.engine.sim_time + max(seconds, 0.0), future))
        return future

    def wake(self, executor: DrainingExecutor) -> bool:
        """Complete the sleeps that are over; whether any was.

        In lockstep each sleeper runs on before the next wakes, in the order they fell asleep
        (which the gate fixed): rclpy would resume them in the order their requests arrived.
        """
        now = self.engine.sim_time
        due = [future for when, future in self._sleepers if when <= now]
        self._sleepers = [(when, future) for when, future in self._sleepers if when > now]
        for future in due:
            future.set_result(True)
            if self.lockstep.active:
                executor.note_resumable()
                drain_completely(executor)
        return bool(due)

    def clear(self) -> None:
        """Forget every sleep (their coroutines are dropped with the node)."""
        self._sleepers = []
