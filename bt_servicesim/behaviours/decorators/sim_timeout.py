"""Fail a child that runs longer than a number of sim seconds.

py_trees' own ``Timeout`` counts wall time; the mission runs on sim time.
"""

import contextlib
from typing import Any

import py_trees
from py_trees.ports import NoDataAvailable, PortInformation, PortsMixin

from bt_servicesim.behaviours.node import Ports
from bt_servicesim.ros.sim_clock import SimStopwatch, clock_from_setup_kwargs


class SimTimeout(PortsMixin, py_trees.decorators.Decorator):
    """FAILURE, stopping the child, once the child has run for over ``seconds`` sim seconds.

    Until then the child's status passes through unchanged. The time counts from the
    decorator's own initialise, i.e. from the first tick of this round of activity. The limit
    is an input port, so a tree file can wire it to a key (``seconds="{time_limit}"``) that the
    run command sets; unwired, the constructor's value applies.

    Args:
        name: the decorator's name
        child: the decorated behaviour
        seconds: the time limit, in sim seconds, when the ``seconds`` port is not wired
    """

    INPUT_PORTS: Ports = {
        "seconds": PortInformation(data_type=float, required=False),
    }
    OUTPUT_PORTS: Ports = {}

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        seconds: float = 10.0,
        **kwargs: Any,
    ) -> None:
        super().__init__(name=name, child=child, **kwargs)
        self.seconds = float(seconds)
        self._stopwatch: SimStopwatch | None = None

    def setup(self, **kwargs: Any) -> None:
        """Take the clock from ``kwargs["node"]``."""
        self._stopwatch = SimStopwatch(clock_from_setup_kwargs(self.name, kwargs))

    def initialise(self) -> None:
        """Start the stopwatch."""
        if self._stopwatch is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        self._stopwatch.restart()
        if self._blackboard_client is not None:  # built from XML: the port may be wired
            with contextlib.suppress(NoDataAvailable):  # not wired: the constructor's limit
                self.seconds = float(self.get_input("seconds"))
        self.feedback_message = f"time limit {self.seconds:.1f} sim s"

    def update(self) -> py_trees.common.Status:
        """Pass the child's status through, unless it has run too long."""
        status = self.decorated.status
        if status != py_trees.common.Status.RUNNING:
            self.feedback_message = f"child finished: {status.value}"
            return status
        assert self._stopwatch is not None
        elapsed = self._stopwatch.elapsed()
        if elapsed > self.seconds:
            self.feedback_message = (
                f"timed out: '{self.decorated.name}' ran {elapsed:.1f} sim s "
                f"> {self.seconds:.1f} sim s"
            )
            return py_trees.common.Status.FAILURE
        self.feedback_message = f"child running {elapsed:.1f}/{self.seconds:.1f} sim s"
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        """Note an interruption; Decorator.stop() stops the child."""
        if new_status == py_trees.common.Status.INVALID:
            self.feedback_message = "time limit interrupted"
