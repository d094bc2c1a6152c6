"""Watch that the guest keeps following while the robot guides them.

A monitor that runs beside navigation: RUNNING while the guest stays within RFID range,
FAILURE once they have been out of range for longer than its ``grace`` period, never SUCCESS.
It remembers where the robot was when it last had the guest in range, where a search for a lost
guest starts. All times are sim time.
"""

from typing import Any

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.behaviours.ports import GUEST_IN_RANGE_INPUTS
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.sim_clock import SimStopwatch, node_from_setup_kwargs


class GuestFollowing(ActionNode):
    """RUNNING while the guest keeps within RFID range; FAILURE once lost. Never SUCCESS.

    The guest counts as seen at initialise (guiding starts right after a pick-up). Each tick
    with the guest in range writes the robot's pose to ``guest_last_seen``, where a search
    for a lost guest would start.

    Args:
        name: the behaviour's name
        grace: sim seconds the guest may be out of range before it counts as lost
    """

    INPUT_PORTS: Ports = {
        **GUEST_IN_RANGE_INPUTS,
        "robot_pose": PortInformation(data_type=Pose2D, required=False),
    }
    OUTPUT_PORTS: Ports = {
        "guest_last_seen": PortInformation(data_type=Pose2D, required=False),
    }

    def __init__(self, name: str = "GuestFollowing", grace: float = 3.0, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.grace = float(grace)
        self._since_seen: SimStopwatch | None = None

    def setup(self, **kwargs: Any) -> None:
        """Take the clock from ``kwargs["node"]``."""
        node = node_from_setup_kwargs(self.name, kwargs)
        self._since_seen = SimStopwatch(node.get_clock())

    def initialise(self) -> None:
        """Start the grace period."""
        self._require_setup().restart()
        self.feedback_message = f"watching the guest (grace {self.grace:.1f} sim s)"

    def update(self) -> Status:
        """Reset the grace period whenever the guest is in range."""
        since_seen = self._require_setup()
        try:
            guest = self.get_input("guest_name")
            actors = self.get_input("actors_in_range")
        except NoDataAvailable as error:
            self.feedback_message = f"cannot watch the guest: {error}"
            return Status.FAILURE
        if guest in actors:
            since_seen.restart()
            self._remember_where()
            self.feedback_message = f"{guest} following"
            return Status.RUNNING
        missing = since_seen.elapsed()
        if missing > self.grace:
            self.feedback_message = f"guest lost: not in RFID range for {missing:.1f} s"
            return Status.FAILURE
        self.feedback_message = f"{guest} out of range for {missing:.1f}/{self.grace:.1f} sim s"
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        """Nothing is in flight; note an interruption."""
        if new_status == Status.INVALID:
            self.feedback_message = "guest watch stopped"

    def _remember_where(self) -> None:
        try:
            pose = self.get_input("robot_pose")
        except NoDataAvailable:
            return
        self._set_output("guest_last_seen", pose)

    def _require_setup(self) -> SimStopwatch:
        if self._since_seen is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self._since_seen
