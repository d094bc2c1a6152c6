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

import py_trees
from py_trees.ports import BehaviourWithPorts, NoDataAvailable, PortInformation
from rclpy.client import Client
from rclpy.node import Node
from rclpy.task import Future
from servicesim_competition import srv
from std_srvs.srv import Empty

from bt_servicesim.executive_node import shared_client
from bt_servicesim.geometry import Box, Pose2D
from bt_servicesim.sim_time import SimStopwatch, node_from_setup_kwargs

__all__ = [
    "ClearCostmaps",
    "DropOffGuest",
    "NewTask",
    "PickUpGuest",
    "RoomInfo",
    "ServiceCall",
    "TaskInfo",
]

Status = py_trees.common.Status

Ports = dict[str, PortInformation]
"""A port declaration: port name to its information."""


class ServiceCall(BehaviourWithPorts):
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
_TASK_PORTS: dict[str, PortInformation] = {
    "pick_up_location": PortInformation(data_type=str, required=False),
    "drop_off_location": PortInformation(data_type=str, required=False),
    "guest_name": PortInformation(data_type=str, required=False),
    "start_pose": PortInformation(data_type=Pose2D, required=False),
}


class _TaskCall(ServiceCall, register=False):
    """Shared answer handling of NewTask and TaskInfo (same response type)."""

    INPUT_PORTS: ClassVar[Ports] = {}
    OUTPUT_PORTS: ClassVar[Ports] = _TASK_PORTS

    def check_response(self, response: Any) -> tuple[bool, str]:
        """An empty pick-up location is the referee's error answer."""
        if not response.pick_up_location:
            return False, f"{self.service} gave an error answer (no pick-up location)"
        return True, (
            f"task: guide {response.guest_name} from {response.pick_up_location} "
            f"to {response.drop_off_location}"
        )

    def write_outputs(self, response: Any) -> None:
        """The task's locations, the guest and the robot's start pose."""
        self._set_output("pick_up_location", response.pick_up_location)
        self._set_output("drop_off_location", response.drop_off_location)
        self._set_output("guest_name", response.guest_name)
        self._set_output("start_pose", Pose2D.from_pose(response.robot_start_pose))


class NewTask(_TaskCall):
    """Start the task (the referee's clock starts with this call) and read it."""

    SERVICE_TYPE = srv.NewTask
    DEFAULT_SERVICE = "/servicesim/new_task"


class TaskInfo(_TaskCall):
    """Read the running task without starting one (resuming after a restart)."""

    SERVICE_TYPE = srv.TaskInfo
    DEFAULT_SERVICE = "/servicesim/task_info"


# ------------------------------------------------------------------------- rooms
class RoomInfo(ServiceCall):
    """Look up a room's target area: input ``room``, output ``box``."""

    SERVICE_TYPE = srv.RoomInfo
    DEFAULT_SERVICE = "/servicesim/room_info"
    INPUT_PORTS: ClassVar[Ports] = {"room": PortInformation(data_type=str, required=True)}
    OUTPUT_PORTS: ClassVar[Ports] = {"box": PortInformation(data_type=Box, required=False)}

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


# ------------------------------------------------------------------------- the guest
class PickUpGuest(ServiceCall):
    """Ask the referee to hand the guest over; SUCCESS only if it says success."""

    SERVICE_TYPE = srv.PickUpGuest
    DEFAULT_SERVICE = "/servicesim/pickup_guest"
    INPUT_PORTS: ClassVar[Ports] = {
        "guest_name": PortInformation(data_type=str, required=True),
        "robot_name": PortInformation(data_type=str, required=False, default_value="servicebot"),
    }
    OUTPUT_PORTS: ClassVar[Ports] = {}

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
        return True, f"picked up {guest}"


class DropOffGuest(ServiceCall):
    """Ask the referee to accept the guest at the drop-off; SUCCESS only on success."""

    SERVICE_TYPE = srv.DropOffGuest
    DEFAULT_SERVICE = "/servicesim/dropoff_guest"
    INPUT_PORTS: ClassVar[Ports] = {"guest_name": PortInformation(data_type=str, required=True)}
    OUTPUT_PORTS: ClassVar[Ports] = {}

    def build_request(self) -> Any:
        """The guest from the port."""
        return srv.DropOffGuest.Request(guest_name=self.get_input("guest_name"))

    def check_response(self, response: Any) -> tuple[bool, str]:
        """Only ``success=true`` counts."""
        guest = self._request.guest_name
        if not response.success:
            return False, f"drop-off of {guest} refused (not in the area or not following)"
        return True, f"dropped off {guest}"


# ------------------------------------------------------------------------- navigation
class ClearCostmaps(ServiceCall):
    """Clear navigation's costmaps (``std_srvs/Empty``); any answer is a success."""

    SERVICE_TYPE = Empty
    DEFAULT_SERVICE = "/servicebot/move_base/clear_costmaps"
    INPUT_PORTS: ClassVar[Ports] = {}
    OUTPUT_PORTS: ClassVar[Ports] = {}

    def check_response(self, response: Any) -> tuple[bool, str]:
        """An empty answer is all there is."""
        return True, "costmaps cleared"
