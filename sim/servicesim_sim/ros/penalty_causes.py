"""The referee's contact and approximation points by cause, as a record topic.

Design intent: the referee books every contact and approximation penalty with what the robot was
near (:mod:`servicesim_sim.model.referee`, its books by cause), where it computes the depths.
This publishes those running sums for the run's records, on :data:`PENALTY_CAUSES_TOPIC`
(``std_msgs/String``, latched: the competition's message types are left as they are), JSON
``{"sim_time_s": T, "sums": {CAUSE: POINTS}}``, at the end of every I/O period in which they
grew. Like ``/servicesim/referee`` it is this simulator's extension: a mission executive must not
use it to decide.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from std_msgs.msg import String

from servicesim_sim.model.engine import SimEngine

PENALTY_CAUSES_TOPIC = "/servicesim/referee/penalty_causes"


class PenaltyCausesTopic:
    """Sends the referee's sums by cause when they changed since the last message."""

    def __init__(self, *, engine: SimEngine, make_publisher: Callable[..., Any],
                 send: Callable[[Any, Any], None], latched: Any) -> None:
        self.engine = engine
        self._publisher = make_publisher(String, PENALTY_CAUSES_TOPIC, latched)
        self._send = send
        self._sent = -1

    def publish(self) -> None:
        """The sums, if a step booked points since the last message."""
        bookings, causes = self.engine.penalty_causes()
        if bookings == self._sent:
            return
        self._sent = bookings
        self._send(self._publisher, String(data=json.dumps({
            "sim_time_s": round(self.engine.sim_time, 6),
            "sums": {cause: round(points, 6) for cause, points in sorted(causes.items())}})))
