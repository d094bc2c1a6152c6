"""Service-call leaves: one non-blocking request/response exchange per round of activity.

:class:`ServiceExchange` is the exchange itself, one request to one server, polled without
blocking: it waits, in sim time, for the server and then for the answer. A leaf runs one per
server it asks; :class:`ServiceCall` runs one, ``ClearCostmaps`` (navigation's costmaps, Nav2's
global and local clearing services at once) runs two.

:class:`ServiceCall` is the shared base of the one-service leaves; it is abstract (it declares
no ports) and so is never registered as an XML tag. The lifecycle follows py_trees strictly:

* ``__init__``: configuration only (service name, time limits), no ROS.
* ``setup(node=...)``: the client is created on the given rclpy node.
* ``initialise``: the request is built from the input ports (:meth:`ServiceCall.build_request`)
  and sent at once if the server is ready; otherwise the behaviour waits, RUNNING, for up to
  ``server_timeout`` sim seconds for it to appear, then fails.
* ``update``: polls the exchange, never blocks. A completed call is not a call that worked:
  :meth:`ServiceCall.check_response` judges the answer (e.g. its ``success`` field) before
  :meth:`ServiceCall.write_outputs` writes the output ports. No answer within ``timeout`` sim
  seconds is a FAILURE.
* ``terminate``: a request still in flight is withdrawn from the client, so a late answer to
  an interrupted call is never mistaken for the answer to the next one.

The concrete tags are the referee's services (``NewTask``, ``TaskInfo``, ``RoomInfo``,
``PickUpGuest``, ``DropOffGuest``). Each takes a ``service`` keyword (an XML attribute) to
override the default service name.
"""

from typing import Any, ClassVar

from py_trees.ports import NoDataAvailable
from rclpy.client import Client
from rclpy.clock import Clock
from rclpy.node import Node
from rclpy.task import Future

from bt_servicesim.behaviours.node import ActionNode, Status
from bt_servicesim.ros.node import shared_client
from bt_servicesim.ros.sim_clock import SimStopwatch, node_from_setup_kwargs

__all__ = [
    "ServiceCall",
    "ServiceExchange",
]


class ServiceExchange:
    """One request to one service, polled without blocking: wait for the server, send the
    request, wait for the answer; every wait is bounded in sim seconds.

    :meth:`poll` says where the exchange stands: RUNNING while it waits, SUCCESS once an answer
    came (in :attr:`response`; whether the answer means the call *worked* is the leaf's to
    judge), FAILURE when the server never came, the answer never came or the call failed.
    :attr:`message` says which, in words for the leaf's feedback.

    Args:
        service: the service name, for the messages
        client: the service's client (the node's shared one)
        clock: the clock the limits are measured on (the node's, in sim time)
        timeout: sim seconds to wait for the answer once the request is sent
        server_timeout: sim seconds to wait for the server to appear
    """

    def __init__(self, *, service: str, client: Client[Any, Any], clock: Clock, timeout: float,
                 server_timeout: float) -> None:
        self.service = service
        self.client = client
        self.timeout = timeout
        self.server_timeout = server_timeout
        self.future: Future[Any] | None = None
        self.response: Any = None
        self.message = ""
        self._request: Any = None
        self._server_wait = SimStopwatch(clock)
        self._answer_wait = SimStopwatch(clock)

    def begin(self, request: Any) -> None:
        """Start a new exchange: send ``request`` now if the server is ready, else wait for it."""
        self.future, self.response, self._request = None, None, request
        self._server_wait.restart()
        if self.client.service_is_ready():
            self._send()
        else:
            self.message = f"waiting for service {self.service}"

    def poll(self) -> Status:
        """Where the exchange stands (see the class notes); sends once the server is up."""
        if self.future is None:
            return self._wait_for_server()
        if not self.future.done():
            return self._wait_for_answer()
        return self._take_answer(self.future)

    def withdraw(self) -> bool:
        """Withdraw the request if it is still in flight; whether it was."""
        future, self.future = self.future, None
        if future is None or future.done():
            return False
        self.client.remove_pending_request(future)
        future.cancel()
        self.message = f"call to {self.service} cancelled"
        return True

    def _send(self) -> None:
        self._answer_wait.restart()
        self.future = self.client.call_async(self._request)
        self.message = f"called {self.service}, waiting for the answer"

    def _wait_for_server(self) -> Status:
        if self.client.service_is_ready():
            self._send()
            return Status.RUNNING
        if self._server_wait.elapsed() >= self.server_timeout:
            self.message = (
                f"service {self.service} not available after {self.server_timeout:.1f} sim s"
            )
            return Status.FAILURE
        self.message = f"waiting for service {self.service}"
        return Status.RUNNING

    def _wait_for_answer(self) -> Status:
        elapsed = self._answer_wait.elapsed()
        if elapsed > self.timeout:
            self.message = f"no answer from {self.service} within {self.timeout:.1f} sim s"
            return Status.FAILURE
        self.message = f"waiting for {self.service} ({elapsed:.1f} sim s)"
        return Status.RUNNING

    def _take_answer(self, future: Future[Any]) -> Status:
        error = future.exception()
        self.response = None if error is not None or future.cancelled() else future.result()
        if self.response is None:
            self.message = f"call to {self.service} failed: {error or 'no response'}"
            return Status.FAILURE
        self.message = f"{self.service} answered"
        return Status.SUCCESS


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
        self.client: Client[Any, Any] | None = None
        self.exchange: ServiceExchange | None = None
        self._request: Any = None
        self._error: str | None = None

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
        self.exchange = ServiceExchange(
            service=self.service, client=self.client, clock=self.node.get_clock(),
            timeout=self.timeout, server_timeout=self.server_timeout)

    def initialise(self) -> None:
        """Build the request; send it now if the server is ready."""
        exchange = self._require_setup()
        self._error = None
        try:
            self._request = self.build_request()
        except NoDataAvailable as error:
            self._error = f"cannot build the {self.service} request: {error}"
            self.feedback_message = self._error
            return
        exchange.begin(self._request)
        self.feedback_message = exchange.message

    def update(self) -> Status:
        """Poll: wait for the server, then for the answer, then judge it."""
        if self._error is not None:
            self.feedback_message = self._error
            return Status.FAILURE
        exchange = self._require_setup()
        status = exchange.poll()
        self.feedback_message = exchange.message
        if status != Status.SUCCESS:
            return status
        return self._judge(exchange.response)

    def terminate(self, new_status: Status) -> None:
        """Withdraw a request that is still in flight."""
        if self.exchange is not None and self.exchange.withdraw() and (
                new_status == Status.INVALID):
            self.feedback_message = self.exchange.message

    # ---------------------------------------------------------------- helpers
    def _require_setup(self) -> ServiceExchange:
        if self.exchange is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self.exchange

    def _judge(self, response: Any) -> Status:
        ok, message = self.check_response(response)
        self.feedback_message = message
        if not ok:
            return Status.FAILURE
        self.write_outputs(response)
        return Status.SUCCESS
