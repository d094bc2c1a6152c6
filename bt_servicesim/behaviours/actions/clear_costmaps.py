"""Navigation's clear-costmaps step, the first rung of the recovery ladder: Nav2's two services.

Navigation is Nav2's ``NavigateToPose`` action, so its costmaps are cleared the way a Nav2
stack offers: one ``nav2_msgs/srv/ClearEntireCostmap`` server per costmap,
``<ns>/global_costmap/clear_entirely_global_costmap`` and
``<ns>/local_costmap/clear_entirely_local_costmap``. Nav2's own recovery subtree clears both,
one ``ClearEntireCostmap`` node each, in a sequence. This leaf does the same in one step: it asks
both servers at once and succeeds when both have answered (Kilted's answer is empty: an answer
is the clearing). Either one failing -- its server missing for ``server_timeout`` sim seconds,
no answer within ``timeout`` -- fails the step, as Nav2's sequence fails.

move_base's (ROS 1) ``std_srvs/Empty`` ``clear_costmaps`` service has another type, so it
cannot stand in through a service name; only our simulator offers it, for the baseline.

The lifecycle is py_trees', as for every service leaf
(:mod:`~bt_servicesim.behaviours.actions.service_call`): both requests are sent in
``initialise`` (each as soon as its server is up), ``update`` polls without blocking, and
``terminate`` withdraws a request still in flight. The service names are XML attributes,
``global_costmap_service`` and ``local_costmap_service``, defaulting to the names a Nav2 stack
in the robot's namespace, ``servicebot``, has.
"""

from collections.abc import Iterable
from typing import Any

from nav2_msgs.srv import ClearEntireCostmap

from bt_servicesim.behaviours.actions.service_call import ServiceExchange
from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.ros.node import shared_client
from bt_servicesim.ros.sim_clock import node_from_setup_kwargs

__all__ = [
    "GLOBAL_COSTMAP_SERVICE",
    "LOCAL_COSTMAP_SERVICE",
    "ClearCostmaps",
]

GLOBAL_COSTMAP_SERVICE = "/servicebot/global_costmap/clear_entirely_global_costmap"
LOCAL_COSTMAP_SERVICE = "/servicebot/local_costmap/clear_entirely_local_costmap"


class ClearCostmaps(ActionNode):
    """Clear navigation's global and local costmaps (Nav2's ``ClearEntireCostmap``, both at
    once); SUCCESS once both have answered, FAILURE as soon as either cannot.

    Args:
        name: the behaviour's name
        global_costmap_service: the global costmap's clearing service
        local_costmap_service: the local costmap's clearing service
        timeout: sim seconds to wait for each answer once its request is sent
        server_timeout: sim seconds to wait for each server to appear before failing
    """

    INPUT_PORTS: Ports = {}
    OUTPUT_PORTS: Ports = {}

    def __init__(
        self,
        name: str,
        global_costmap_service: str = GLOBAL_COSTMAP_SERVICE,
        local_costmap_service: str = LOCAL_COSTMAP_SERVICE,
        timeout: float = 30.0,
        server_timeout: float = 10.0,
        **kwargs: Any,
    ) -> None:
        super().__init__(name=name, **kwargs)
        self.services = (global_costmap_service or GLOBAL_COSTMAP_SERVICE,
                         local_costmap_service or LOCAL_COSTMAP_SERVICE)
        self.timeout = float(timeout)
        self.server_timeout = float(server_timeout)
        self.exchanges: tuple[ServiceExchange, ...] = ()

    def setup(self, **kwargs: Any) -> None:
        """One client per costmap's service on ``kwargs["node"]``."""
        node = node_from_setup_kwargs(self.name, kwargs)
        self.exchanges = tuple(
            ServiceExchange(service=service,
                            client=shared_client(node, ClearEntireCostmap, service),
                            clock=node.get_clock(), timeout=self.timeout,
                            server_timeout=self.server_timeout)
            for service in self.services)

    def initialise(self) -> None:
        """Ask both costmaps to clear; each request goes now if its server is ready."""
        for exchange in self._require_setup():
            exchange.begin(ClearEntireCostmap.Request())
        self.feedback_message = _joined(self.exchanges)

    def update(self) -> Status:
        """Poll both exchanges: the first failure fails the step, two answers succeed it."""
        exchanges = self._require_setup()
        statuses = [exchange.poll() for exchange in exchanges]
        for exchange, status in zip(exchanges, statuses, strict=True):
            if status == Status.FAILURE:
                self.feedback_message = exchange.message
                return Status.FAILURE
        if all(status == Status.SUCCESS for status in statuses):
            self.feedback_message = "costmaps cleared (global and local)"
            return Status.SUCCESS
        self.feedback_message = _joined(
            exchange for exchange, status in zip(exchanges, statuses, strict=True)
            if status == Status.RUNNING)
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        """Withdraw whichever request is still in flight (the other's failure, or a halt)."""
        withdrawn = [exchange for exchange in self.exchanges if exchange.withdraw()]
        if withdrawn and new_status == Status.INVALID:
            self.feedback_message = _joined(withdrawn)

    def _require_setup(self) -> tuple[ServiceExchange, ...]:
        if not self.exchanges:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self.exchanges


def _joined(exchanges: Iterable[ServiceExchange]) -> str:
    """The exchanges' messages, one clause each."""
    return "; ".join(exchange.message for exchange in exchanges)
