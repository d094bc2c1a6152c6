"""The referee's task services: ``NewTask`` starts the task, ``TaskInfo`` reads a running one."""

from typing import Any

from py_trees.ports import PortInformation
from servicesim_competition import srv

from bt_servicesim.behaviours.actions.service_call import ServiceCall
from bt_servicesim.behaviours.node import Ports
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.messages import pose_from_msg

_TASK_PORTS: dict[str, PortInformation] = {
    "pick_up_location": PortInformation(data_type=str, required=False),
    "drop_off_location": PortInformation(data_type=str, required=False),
    "guest_name": PortInformation(data_type=str, required=False),
    "start_pose": PortInformation(data_type=Pose2D, required=False),
}


class _TaskCall(ServiceCall, register=False):
    """Shared answer handling of NewTask and TaskInfo (same response type)."""

    INPUT_PORTS: Ports = {}
    OUTPUT_PORTS: Ports = _TASK_PORTS

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
        self._set_output("start_pose", pose_from_msg(response.robot_start_pose))


class NewTask(_TaskCall):
    """Start the task (the referee's clock starts with this call) and read it."""

    SERVICE_TYPE = srv.NewTask
    DEFAULT_SERVICE = "/servicesim/new_task"


class TaskInfo(_TaskCall):
    """Read the running task without starting one (resuming after a restart)."""

    SERVICE_TYPE = srv.TaskInfo
    DEFAULT_SERVICE = "/servicesim/task_info"
