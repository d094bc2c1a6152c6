"""Hold a pick-up back until the guest has stayed in RFID range for a moment.

An action, not a condition: it waits (RUNNING) for enough readings taken since it started.
"""

from __future__ import annotations

from typing import Any

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.planning.guest_localisation import (
    STEADY_FOR,
    STEADY_PATIENCE,
    STEADY_READINGS,
    RfidHistory,
)
from bt_servicesim.ros.sim_clock import clock_from_setup_kwargs, sim_now_s


class GuestSteadilyInRange(ActionNode):
    """SUCCESS once every reading over the last :data:`STEADY_FOR` sim s names the guest.

    Only readings taken since the behaviour started count (the robot stands by then). RUNNING
    while too few have come; FAILURE at once on a reading without the guest, or after
    :data:`STEADY_PATIENCE` sim s without a steady run.
    """

    INPUT_PORTS: Ports = {
        "guest_name": PortInformation(data_type=str, required=True),
        "rfid_history": PortInformation(data_type=RfidHistory, required=True),
    }
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str = "GuestSteadilyInRange", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self._clock: Any = None
        self._started = 0.0

    def setup(self, **kwargs: Any) -> None:
        """Take the clock from ``kwargs["node"]``."""
        self._clock = clock_from_setup_kwargs(self.name, kwargs)

    def initialise(self) -> None:
        """Readings count from now."""
        self._started = sim_now_s(self._clock)

    def update(self) -> Status:
        """Judge the readings since the start."""
        try:
            guest, history = self.get_input("guest_name"), self.get_input("rfid_history")
        except (NoDataAvailable, TypeError) as error:
            self.feedback_message = f"cannot check the guest: {error}"
            return Status.FAILURE
        now = sim_now_s(self._clock)
        readings = history.since(self._started)
        if any(guest not in reading.names for reading in readings):
            self.feedback_message = f"{guest} dropped out of RFID range"
            return Status.FAILURE
        if now - self._started >= STEADY_FOR and len(readings) >= STEADY_READINGS:
            self.feedback_message = f"{guest} steadily in range ({len(readings)} readings)"
            return Status.SUCCESS
        if now - self._started > STEADY_PATIENCE:
            self.feedback_message = f"too few readings of {guest} in {STEADY_PATIENCE} sim s"
            return Status.FAILURE
        self.feedback_message = f"{guest} in range on {len(readings)} readings so far"
        return Status.RUNNING
