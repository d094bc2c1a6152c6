"""Service-call leaves: one non-blocking request/response exchange per round of activity.

:class:`ServiceCall` is the shared base; it is abstract (it declares no ports) and so is never
registered as an XML tag. The lifecycle follows py_trees strictly:

* ``__init__``: configuration only (service name, time limits), no ROS.
* ``setup(node=...)``: the client is created on the given rclpy node.
* ``initialise``: the request is built from the input ports (:meth:`ServiceCall.build_request`)
  and sent at once if the server is ready; otherwise the behaviour waits, RUNNING, for up to
  ``server_timeout`` sim seconds for it to appear, then fails.
* ``update``: polls the future, never blocks. A completed call is not a call that worked:
  :meth:`ServiceCall.check_response` judges the answer (e.g. its ``success`` field) before
  :meth:`ServiceCall.write_outputs` writes the output ports. No answer within ``timeout`` sim
  seconds is a FAILURE.
* ``terminate``: a request still in flight is withdrawn from the client, so a late answer to
  an interrupted call is never mistaken for the answer to the next one.

The concrete tags are the referee's services (``NewTask``, ``TaskInfo``, ``RoomInfo``,
``PickUpGuest``, ``DropOffGuest``) and navigation's ``ClearCostmaps``. Each takes a
``service`` keyword (an XML attribute) to override the default service name.
"""

from typing import Any, ClassVar

from py_trees.ports import NoDataAvailable
from rclpy.client import Client
from rclpy.node import Node
from rclpy.task import Future

from bt_servicesim.behaviours.node import ActionNode, Status
from bt_servicesim.ros.node import shared_client
from bt_servicesim.ros.sim_clock import SimStopwatch, node_from_setup_kwargs

__all__ = [
    "ServiceCall",
]




class ServiceCall(ActionNode):
    """Call a ROS service once per round of activity, without blocking the tick.

    Subclasses set :attr:`SERVICE_TYPE`, :attr:`DEFAULT_SERVICE` and the port declarations,
    and override :meth:`build_request`, :meth:`check_response` and :meth:`write_outputs`.

    Args:
        name: the behaviour's name
        service: the service name (default: the subclass's :attr:`DEFAULT_SERVICE`)
        timeout: sim seconds to wait for the answer once the request is sent
        server_timeout: sim seconds to wait for the server to appear before failing
    """

    SERVICE_TYPE: ClassVar[Any]
    DEFAULT_SERVICE: ClassVar[str]

    def __init__(
        self,
        name: str,
        service: str = "",
        timeout: float = 30.0,
        server_timeout: float = 10.0,
        **kwargs: Any,
    ) -> None:
        super().__init__(name=name, **kwargs)
        self.service = service or self.DEFAULT_SERVICE
        self.timeout = float(timeout)
        self.server_timeout = float(server_timeout)
        self.node: Node | None = None
        self.client: Client | None = None
        self._future: Future | None = None
        self._request: Any = None
        self._error: str | None = None
        self._server_wait: SimStopwatch | None = None
        self._answer_wait: SimStopwatch | None = None

    # ---------------------------------------------------------------- overridables
    def build_request(self) -> Any:
        """The request to send, built from the input ports (default: an empty request)."""
        return self.SERVICE_TYPE.Request()

    def check_response(self, response: Any) -> tuple[bool, str]:
        """Whether the answer means the call worked, and a message saying so or why not."""
        if hasattr(response, "success") and not response.success:
            return False, f"{self.service} answered success=false"
        return True, f"{self.service} succeeded"

    def write_outputs(self, response: Any) -> None:
        """Write the accepted answer to the output ports (default: nothing)."""

    # ---------------------------------------------------------------- lifecycle
    def setup(self, **kwargs: Any) -> None:
        """Create the client on ``kwargs["node"]``."""
        self.node = node_from_setup_kwargs(self.name, kwargs)
        self.client = shared_client(self.node, self.SERVICE_TYPE, self.service)
        self._server_wait = SimStopwatch(self.node.get_clock())
        self._answer_wait = SimStopwatch(self.node.get_clock())

    def initialise(self) -> None:
        """Build the request; send it now if the server is ready."""
        client, server_wait = self._require_setup()
        self._future, self._error = None, None
        server_wait.restart()
        try:
            self._request = self.build_request()
        except NoDataAvailable as error:
            self._error = f"cannot build the {self.service} request: {error}"
            self.feedback_message = self._error
            return
        if client.service_is_ready():
            self._send()
        else:
            self.feedback_message = f"waiting for service {self.service}"

    def update(self) -> Status:
        """Poll: wait for the server, then for the answer, then judge it."""
        if self._error is not None:
            self.feedback_message = self._error
            return Status.FAILURE
        if self._future is None:
            return self._wait_for_server()
        if not self._future.done():
            return self._wait_for_answer()
        return self._judge(self._future)

    def terminate(self, new_status: Status) -> None:
        """Withdraw a request that is still in flight."""
        future, self._future = self._future, None
        if future is not None and not future.done():
            if self.client is not None:
                self.client.remove_pending_request(future)
            future.cancel()
            if new_status == Status.INVALID:
                self.feedback_message = f"call to {self.service} cancelled"

    # ---------------------------------------------------------------- helpers
    def _require_setup(self) -> tuple[Client, SimStopwatch]:
        if self.client is None or self._server_wait is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self.client, self._server_wait

    def _send(self) -> None:
        client, _ = self._require_setup()
        assert self._answer_wait is not None
        self._answer_wait.restart()
        self._future = client.call_async(self._request)
        self.feedback_message = f"called {self.service}, waiting for the answer"

    def _wait_for_server(self) -> Status:
        client, server_wait = self._require_setup()
        if client.service_is_ready():
            self._send()
            return Status.RUNNING
        if server_wait.elapsed() >= self.server_timeout:
            self.feedback_message = (
                f"service {self.service} not available after {self.server_timeout:.1f} sim s"
            )
            return Status.FAILURE
        self.feedback_message = f"waiting for service {self.service}"
        return Status.RUNNING

    def _wait_for_answer(self) -> Status:
        assert self._answer_wait is not None
        elapsed = self._answer_wait.elapsed()
        if elapsed > self.timeout:
            self.feedback_message = f"no answer from {self.service} within {self.timeout:.1f} sim s"
            return Status.FAILURE
        self.feedback_message = f"waiting for {self.service} ({elapsed:.1f} sim s)"
        return Status.RUNNING

    def _judge(self, future: Future) -> Status:
        error = future.exception()
        response = None if error is not None or future.cancelled() else future.result()
        if response is None:
            self.feedback_message = f"call to {self.service} failed: {error or 'no response'}"
            return Status.FAILURE
        ok, message = self.check_response(response)
        self.feedback_message = message
        if not ok:
            return Status.FAILURE
        self.write_outputs(response)
        return Status.SUCCESS


# ------------------------------------------------------------------------- the task








# ------------------------------------------------------------------------- rooms




# ------------------------------------------------------------------------- the guest




# ------------------------------------------------------------------------- navigation
