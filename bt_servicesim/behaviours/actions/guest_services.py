"""The referee's guest hand-over services: pick the guest up, drop them off.

A completed call is not a hand-over: only ``success=true`` is SUCCESS. Nor is ``success=true``
proof that the guest follows: the original referee answers true to any pick-up once checkpoint 2
is done (and to any drop-off once checkpoint 3 is), with no penalty, whether or not the guest
follows (``Checkpoint.cc``, ``CP_PickUp.cc``, ``CP_DropOff.cc``). So SUCCESS here means only
"the referee said yes"; the tree confirms that the guest follows from RFID while the robot
moves (``GuestFollowing``).
"""

from typing import Any

from py_trees.ports import PortInformation
from servicesim_competition import srv

from bt_servicesim.behaviours.actions.service_call import ServiceCall
from bt_servicesim.behaviours.node import Ports


class PickUpGuest(ServiceCall):
    """Ask the referee to hand the guest over; SUCCESS only if it says success."""

    SERVICE_TYPE = srv.PickUpGuest
    DEFAULT_SERVICE = "/servicesim/pickup_guest"
    INPUT_PORTS: Ports = {
        "guest_name": PortInformation(data_type=str, required=True),
        "robot_name": PortInformation(data_type=str, required=False, default_value="servicebot"),
    }
    OUTPUT_PORTS: Ports = {}

    def build_request(self) -> Any:
        """The guest and the robot from the ports."""
        return srv.PickUpGuest.Request(
            guest_name=self.get_input("guest_name"), robot_name=self.get_input("robot_name")
        )

    def check_response(self, response: Any) -> tuple[bool, str]:
        """Only ``success=true`` counts."""
        guest = self._request.guest_name
        if not response.success:
            return False, f"pick-up of {guest} refused (too far, wrong name or before CP1)"
        return True, f"pick-up of {guest} answered true (RFID confirms the following)"


class DropOffGuest(ServiceCall):
    """Ask the referee to accept the guest at the drop-off; SUCCESS only on success."""

    SERVICE_TYPE = srv.DropOffGuest
    DEFAULT_SERVICE = "/servicesim/dropoff_guest"
    INPUT_PORTS: Ports = {"guest_name": PortInformation(data_type=str, required=True)}
    OUTPUT_PORTS: Ports = {}

    def build_request(self) -> Any:
        """The guest from the port."""
        return srv.DropOffGuest.Request(guest_name=self.get_input("guest_name"))

    def check_response(self, response: Any) -> tuple[bool, str]:
        """Only ``success=true`` counts."""
        guest = self._request.guest_name
        if not response.success:
            return False, f"drop-off of {guest} refused (not in the area or not following)"
        return True, f"dropped off {guest}"
