"""Keep the RFID history that locates the guest: every reading with where the robot stood.

Runs every tick beside the topic readers; the history itself and what it means are in
:mod:`bt_servicesim.planning.guest_localisation`.
"""

from __future__ import annotations

import math
from typing import Any

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.guest_localisation import (
    HISTORY_LENGTH,
    READING_PERIOD,
    SILENCE,
    RfidHistory,
    RfidReading,
)
from bt_servicesim.ros.sim_clock import clock_from_setup_kwargs, sim_now_s


class RecordRfidReadings(ActionNode):
    """Append each new RFID reading, with the robot's position, to ``rfid_history``; SUCCESS.

    A new message shows as a new stamp (now − ``rfid_age``). Silence longer than
    :data:`SILENCE` is recorded as an empty reading every :data:`READING_PERIOD`. The same
    :class:`RfidHistory` object stays on the blackboard for the whole run.

    Args:
        name: the behaviour's name
        length: readings kept
    """

    INPUT_PORTS: Ports = {
        "actors_in_range": PortInformation(data_type=list[str], required=True),
        "rfid_age": PortInformation(data_type=float, required=True),
        "robot_pose": PortInformation(data_type=Pose2D, required=True),
    }
    OUTPUT_PORTS: Ports = {
        "rfid_history": PortInformation(data_type=RfidHistory, required=False),
    }

    def __init__(self, name: str = "RecordRfidReadings", length: int = HISTORY_LENGTH,
                 **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.history = RfidHistory(int(length))
        self._clock: Any = None
        self._last_stamp = -math.inf

    def setup(self, **kwargs: Any) -> None:
        """Take the clock from ``kwargs["node"]``."""
        self._clock = clock_from_setup_kwargs(self.name, kwargs)

    def update(self) -> Status:
        """Record the reading, if there is a new one."""
        self._set_output("rfid_history", self.history)
        try:
            names, age = self.get_input("actors_in_range"), float(self.get_input("rfid_age"))
            pose = self.get_input("robot_pose")
        except NoDataAvailable as error:
            self.feedback_message = f"nothing to record yet: {error}"
            return Status.SUCCESS
        now = sim_now_s(self._require_clock())
        reading = self._new_reading(now, age, names, pose)
        if reading is not None:
            self.history.add(reading)
            self._last_stamp = reading.stamp
        self.feedback_message = repr(self.history)
        return Status.SUCCESS

    def _new_reading(
        self, now: float, age: float, names: list[str], pose: Pose2D
    ) -> RfidReading | None:
        if age > SILENCE:
            if now - self._last_stamp < READING_PERIOD - 1e-6:
                return None
            return RfidReading(now, pose.x, pose.y, frozenset())
        stamp = now - age
        if abs(stamp - self._last_stamp) < READING_PERIOD / 4.0:
            return None
        return RfidReading(stamp, pose.x, pose.y, frozenset(names))

    def _require_clock(self) -> Any:
        if self._clock is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self._clock
