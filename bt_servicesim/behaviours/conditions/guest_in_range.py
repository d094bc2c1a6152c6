"""Is the guest in RFID range right now? A plain condition on the RFID list."""

from __future__ import annotations

from typing import Any

from py_trees.ports import NoDataAvailable

from bt_servicesim.behaviours.node import ConditionNode, Ports
from bt_servicesim.behaviours.ports import GUEST_IN_RANGE_INPUTS

__all__ = ["GuestInRange"]


class GuestInRange(ConditionNode):
    """SUCCESS if the guest is among ``actors_in_range``, else FAILURE."""

    INPUT_PORTS: Ports = dict(GUEST_IN_RANGE_INPUTS)
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str = "GuestInRange", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def check(self) -> bool:
        """Look the guest up in the RFID list."""
        try:
            guest = self.get_input("guest_name")
            actors = self.get_input("actors_in_range")
        except NoDataAvailable as error:
            self.feedback_message = f"cannot check the guest: {error}"
            return False
        in_range = guest in actors
        self.feedback_message = f"{guest} {'in' if in_range else 'not in'} RFID range"
        return in_range
