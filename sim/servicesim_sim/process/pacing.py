"""Pacing sim time against the wall clock at a speed factor.

Design intent: at speed *s* the simulator should advance *s* sim seconds per wall second, and
never faster. A loop that only computes "when is this sim time due" from a fixed anchor races
after any stretch where it fell behind (a slow planning step, a busy machine): it then runs
flat out until it has caught up, and a client ticking on ``/clock`` sees seconds of sim time
go by in a few milliseconds with no chance to react. Measured with two episodes at once at
speed 20 on two cores, the executive went 4–22 sim s without a single tick while one episode
alone never went 1 sim s. So a simulator that falls more than :data:`MAX_LAG_WALL_S` of wall
time (at least :data:`MIN_LAG_SIM_S`) behind *slips*: it re-anchors at the present and
carries on at its speed, giving up the lost wall time, as Gazebo does when it cannot hold its
real-time factor. The average speed then drops below the factor asked for, which is the truth
about the machine, and the benchmark reports it.
"""

from __future__ import annotations

import time
from collections.abc import Callable

#: How far behind its schedule, in wall seconds, the simulator may run before it slips. A lag
#: that size is scheduling noise (a full-map plan takes 15-20 ms, a core is briefly taken) and
#: is made up by running faster than the speed factor, only as much faster as the machine
#: allows; a longer one means the machine cannot hold the speed. Allowed as sim time, it grows
#: with the speed: 2 sim s at speed 50, 0.8 at speed 20. At speed 50 a fixed 0.2 sim s (4 ms)
#: made every plan a slip, and 1 sim s still 15 in a mission: the simulator held 46-47x.
MAX_LAG_WALL_S = 0.04
#: The least lag allowed in sim seconds (two I/O periods), whatever the speed.
MIN_LAG_SIM_S = 0.2


class Pacer:
    """Says how long to wait before the next step so that sim time keeps to ``speed``.

    Args:
        max_lag_wall_s: the largest lag, in wall seconds, made up by running faster; beyond
            it the schedule starts again from now
        min_lag_sim_s: a lag of up to this many sim seconds is made up at any speed
        clock: wall seconds (monotonic); injectable for tests
    """

    def __init__(self, *, max_lag_wall_s: float = MAX_LAG_WALL_S,
                 min_lag_sim_s: float = MIN_LAG_SIM_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.max_lag_wall_s = max_lag_wall_s
        self.min_lag_sim_s = min_lag_sim_s
        self.clock = clock
        self.slips = 0
        self._anchor: tuple[float, float, float] | None = None  # wall, sim, speed

    def max_lag_sim_s(self, speed: float) -> float:
        """The lag, in sim seconds, made up at ``speed`` before the simulator slips."""
        return max(self.min_lag_sim_s, self.max_lag_wall_s * speed)

    def wait_s(self, *, sim_time: float, speed: float) -> float:
        """Wall seconds until ``sim_time`` is due at ``speed`` (0 at speed 0: flat out)."""
        now = self.clock()
        if self._anchor is None or self._anchor[2] != speed:
            self._anchor = (now, sim_time, speed)
        if speed <= 0.0:
            return 0.0
        wall, sim, _ = self._anchor
        due = wall + (sim_time - sim) / speed
        if now - due > self.max_lag_sim_s(speed) / speed:
            self._anchor = (now, sim_time, speed)
            self.slips += 1
            return 0.0
        return max(due - now, 0.0)
