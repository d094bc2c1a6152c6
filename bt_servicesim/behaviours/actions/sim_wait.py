"""Wait a number of seconds of sim time: py_trees' own ``Timer`` counts wall time."""

from typing import Any

import py_trees

from bt_servicesim.behaviours.node import ActionNode, Ports
from bt_servicesim.ros.sim_clock import SimStopwatch, clock_from_setup_kwargs


class SimWait(ActionNode):
    """RUNNING until ``seconds`` sim seconds have passed since initialise, then SUCCESS.

    Args:
        name: the behaviour's name
        seconds: how long to wait, in sim seconds
    """

    INPUT_PORTS: Ports = {}
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str = "SimWait", seconds: float = 1.0, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.seconds = float(seconds)
        self._stopwatch: SimStopwatch | None = None

    def setup(self, **kwargs: Any) -> None:
        """Take the clock from ``kwargs["node"]``."""
        self._stopwatch = SimStopwatch(clock_from_setup_kwargs(self.name, kwargs))

    def initialise(self) -> None:
        """Start the stopwatch."""
        self._require_setup().restart()
        self.feedback_message = f"waiting {self.seconds:.1f} sim s"

    def update(self) -> py_trees.common.Status:
        """SUCCESS once the wait is over."""
        elapsed = self._require_setup().elapsed()
        if elapsed >= self.seconds:
            self.feedback_message = f"waited {elapsed:.1f} sim s"
            return py_trees.common.Status.SUCCESS
        self.feedback_message = f"waiting: {elapsed:.1f}/{self.seconds:.1f} sim s"
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        """Nothing is in flight; record an interruption."""
        if new_status == py_trees.common.Status.INVALID:
            self.feedback_message = "wait interrupted"

    def _require_setup(self) -> SimStopwatch:
        if self._stopwatch is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self._stopwatch
