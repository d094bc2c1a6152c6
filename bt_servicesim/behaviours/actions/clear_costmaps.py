"""Navigation's clear-costmaps service, the first rung of the recovery ladder."""

from typing import Any, ClassVar

from std_srvs.srv import Empty

from bt_servicesim.behaviours.actions.service_call import ServiceCall
from bt_servicesim.behaviours.node import Ports


class ClearCostmaps(ServiceCall):
    """Clear navigation's costmaps (``std_srvs/Empty``); any answer is a success."""

    SERVICE_TYPE = Empty
    DEFAULT_SERVICE = "/servicebot/move_base/clear_costmaps"
    INPUT_PORTS: ClassVar[Ports] = {}
    OUTPUT_PORTS: ClassVar[Ports] = {}

    def check_response(self, response: Any) -> tuple[bool, str]:
        """An empty answer is all there is."""
        return True, "costmaps cleared"
