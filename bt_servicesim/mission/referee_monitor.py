"""What the referee says, as opposed to what the executive believes.

The simulator's referee publishes its own account of the task (``RefereeState``: checkpoints,
penalties, score) on ``/servicesim/referee``, latched. The run command reads it for progress
lines and for ``report.json``, so a report can never claim a checkpoint the referee did not
count. No behaviour in the mission tree reads it: the executive decides from the robot's
sensors and the competition's services only.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from servicesim_competition.msg import RefereeState

from bt_servicesim.ros.shared_subscription import shared_subscription

REFEREE_TOPIC = "/servicesim/referee"
CHECKPOINT_NAMES = ("go_to_pick_up", "pick_up_guest", "drop_off_guest", "return_to_start")
LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)


class RefereeMonitor:
    """Keeps the latest referee state and turns it into the report's fields."""

    def __init__(self, node: Node) -> None:
        self.latest: RefereeState | None = None
        self.frozen = False
        self.task_first: tuple[float, float] | None = None
        """(task sim time, ``time.monotonic()``) of the first state taken while the task ran
        or once it was completed: when the run saw the task start, for benchmarks that measure
        a mission's real-time factor (never read by the mission)."""
        self.task_latest: tuple[float, float] | None = None
        """The same of the latest such state taken."""
        self._ended: Callable[[], bool] = lambda: False
        self._reader = shared_subscription(node, RefereeState, REFEREE_TOPIC, self._on_state,
                                           LATCHED)

    def _on_state(self, message: RefereeState) -> None:
        if not self.frozen and not self._ended():
            self.latest = message
            if message.task_running or message.completed:
                self.task_latest = (float(message.task_sim_time), time.monotonic())
                if self.task_first is None:
                    self.task_first = self.task_latest

    def freeze_when(self, ended: Callable[[], bool]) -> None:
        """Take no state once ``ended()`` holds: the books stay as the tick that ended the
        mission saw them. In lockstep the client may hand on the next period's messages before
        the run notices the end (when depends on the load); this keeps them out of the report."""
        self._ended = ended

    def freeze(self) -> None:
        """Keep the referee's books as they are now: the mission has ended, whatever the
        simulator goes on counting while the run shuts down."""
        self.frozen = True

    @property
    def completed(self) -> bool:
        return bool(self.latest is not None and self.latest.completed)

    def checkpoint(self) -> str:
        """A short progress word: how many of the four checkpoints are done."""
        if self.latest is None:
            return "0/4"
        return f"{sum(self.latest.checkpoint_done)}/{len(self.latest.checkpoint_done) or 4}"

    def score(self) -> float:
        return 0.0 if self.latest is None else float(self.latest.score)

    def task_sim_time(self) -> float:
        return 0.0 if self.latest is None else float(self.latest.task_sim_time)

    def unheard(self) -> str:
        """What a report adds when no referee state ever came, else nothing: a backend without
        this simulator's extension (Gazebo's ServiceSim, a robot) keeps its books unread."""
        if self.latest is not None:
            return ""
        return (f"no referee state came on {REFEREE_TOPIC} (this simulator's extension): "
                "what the referee counted is unknown")

    def task_timing(self) -> dict[str, Any] | None:
        """The report's ``task_timing``: the task sim time and this machine's monotonic clock
        (``CLOCK_MONOTONIC``, seconds, as ``time.monotonic()`` reads it in any process) when the
        run took the task's first and its latest referee state; ``None`` if it saw no task."""
        first, last = self.task_first, self.task_latest
        if first is None or last is None:
            return None
        return {"first": {"task_sim_time_s": first[0], "monotonic_s": round(first[1], 4)},
                "last": {"task_sim_time_s": last[0], "monotonic_s": round(last[1], 4)}}

    def report_fields(self) -> dict[str, Any]:
        """``completed``, ``score``, ``sim_time_s``, ``checkpoints``, ``penalties`` and
        ``referee_heard`` (whether any referee state came)."""
        state = self.latest
        if state is None:
            return {
                "completed": False, "referee_heard": False, "score": 0.0, "sim_time_s": 0.0,
                "checkpoints": [
                    {"name": name, "done": False, "sim_time_s": 0.0} for name in CHECKPOINT_NAMES
                ],
                "penalties": _penalties(None),
            }
        return {
            "completed": bool(state.completed),
            "referee_heard": True,
            "score": float(state.score),
            "sim_time_s": float(state.task_sim_time),
            "checkpoints": [
                {"name": name, "done": bool(done), "sim_time_s": float(time)}
                for name, done, time in zip(
                    state.checkpoint_names, state.checkpoint_done, state.checkpoint_sim_time,
                    strict=True,
                )
            ],
            "penalties": _penalties(state),
        }


def _penalties(state: RefereeState | None) -> dict[str, float | int]:
    if state is None:
        return {"failed_pickup": 0, "failed_dropoff": 0, "too_fast": 0, "drifts": 0,
                "contact": 0.0, "approximation": 0.0}
    return {
        "failed_pickup": int(state.failed_pickups),
        "failed_dropoff": int(state.failed_dropoffs),
        "too_fast": int(state.too_fast),
        "drifts": int(state.drifts),
        "contact": float(state.contact),
        "approximation": float(state.approximation),
    }
