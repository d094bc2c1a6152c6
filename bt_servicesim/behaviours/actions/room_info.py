"""The referee's ``RoomInfo`` service: a room's target area as a ``Box``."""

from typing import Any

from py_trees.ports import PortInformation
from servicesim_competition import srv

from bt_servicesim.behaviours.actions.service_call import ServiceCall
from bt_servicesim.behaviours.node import Ports
from bt_servicesim.planning.geometry import Box


class RoomInfo(ServiceCall):
    """Look up a room's target area: input ``room``, output ``box``."""

    SERVICE_TYPE = srv.RoomInfo
    DEFAULT_SERVICE = "/servicesim/room_info"
    INPUT_PORTS: Ports = {"room": PortInformation(data_type=str, required=True)}
    OUTPUT_PORTS: Ports = {"box": PortInformation(data_type=Box, required=False)}

    def build_request(self) -> Any:
        """Ask for the room on the ``room`` port."""
        return srv.RoomInfo.Request(name=self.get_input("room"))

    def check_response(self, response: Any) -> tuple[bool, str]:
        """A zero-size box is the referee's answer for an unknown room."""
        box = _box_from(response)
        if box.is_empty:
            return False, f"unknown room {self._request.name}"
        return True, f"room {self._request.name}: {box}"

    def write_outputs(self, response: Any) -> None:
        """The room's target area."""
        self._set_output("box", _box_from(response))


def _box_from(response: Any) -> Box:
    return Box(
        min_x=response.min.x, min_y=response.min.y, max_x=response.max.x, max_y=response.max.y
    )
