"""Simulation time for behaviours: a stopwatch on the node's clock, a wait and a timeout.

Every duration in the executive is measured in SIM seconds. The node runs with
``use_sim_time``, so its clock follows ``/clock``; py_trees' own
:class:`~py_trees.timers.Timer` and :class:`~py_trees.decorators.Timeout` measure wall
time and would run fast or slow against the simulator (and keep running while it is paused).

Before the first ``/clock`` message a sim-time clock reads zero. That is taken to mean *time
is not advancing*: a :class:`SimStopwatch` reads zero elapsed seconds until the clock runs and
then starts counting from the first non-zero reading. A clock that jumps backwards (the
simulator restarted) restarts the stopwatch rather than producing negative durations.

Besides the stopwatch this module holds the two time behaviours, :class:`SimWait` and the
decorator :class:`SimTimeout`, and :func:`node_from_setup_kwargs`, the check every ROS-facing
behaviour in this package makes in ``setup(node=...)``.
"""

import contextlib
from typing import Any, ClassVar

import py_trees
from py_trees.ports import BehaviourWithPorts, NoDataAvailable, PortInformation, PortsMixin
from rclpy.clock import Clock
from rclpy.node import Node

__all__ = [
    "SimStopwatch",
    "SimTimeout",
    "SimWait",
    "clock_from_setup_kwargs",
    "node_from_setup_kwargs",
    "sim_now_s",
]

_NS_PER_S = 1e9

Ports = dict[str, PortInformation]
"""A port declaration: port name to its information."""


def node_from_setup_kwargs(behaviour_name: str, kwargs: dict[str, Any]) -> Node:
    """Return the rclpy node handed to ``setup(node=...)``, or raise a clear error.

    Raises:
        KeyError: if ``node`` is missing from the setup keyword arguments.
        TypeError: if it is not an :class:`rclpy.node.Node`.
    """
    try:
        node = kwargs["node"]
    except KeyError as error:
        raise KeyError(
            f"{behaviour_name}: setup() needs the rclpy node, e.g. tree.setup(node=node) "
            "or behaviour.setup(node=node)"
        ) from error
    if not isinstance(node, Node):
        raise TypeError(f"{behaviour_name}: setup(node=...) expects an rclpy Node, got {node!r}")
    return node


def clock_from_setup_kwargs(behaviour_name: str, kwargs: dict[str, Any]) -> Clock:
    """The clock of whatever ``setup(node=...)`` was given: an rclpy node, or any object with
    ``get_clock()`` (a test's manual clock). Behaviours that only measure time use this."""
    if "node" not in kwargs:
        raise KeyError(
            f"{behaviour_name}: setup() needs the rclpy node, e.g. tree.setup(node=node)"
        )
    node = kwargs["node"]
    if not callable(getattr(node, "get_clock", None)):
        raise TypeError(f"{behaviour_name}: setup(node=...) expects an rclpy Node, got {node!r}")
    return node.get_clock()


def sim_now_s(clock: Clock) -> float:
    """The clock's time in seconds; zero means a sim-time clock that is not yet running."""
    return clock.now().nanoseconds / _NS_PER_S


class SimStopwatch:
    """Elapsed seconds on a (sim-time) clock, frozen while the clock is not running.

    Args:
        clock: the clock to read, normally ``node.get_clock()``
    """

    def __init__(self, clock: Clock) -> None:
        self._clock = clock
        self._start_ns: int | None = None

    def restart(self) -> None:
        """Start counting from now (or from the first reading once the clock runs)."""
        now_ns = self._clock.now().nanoseconds
        self._start_ns = now_ns if now_ns > 0 else None

    def elapsed(self) -> float:
        """Seconds since :meth:`restart`; zero while the clock reads zero."""
        now_ns = self._clock.now().nanoseconds
        if now_ns <= 0:
            return 0.0
        if self._start_ns is None or now_ns < self._start_ns:
            self._start_ns = now_ns
        return (now_ns - self._start_ns) / _NS_PER_S


class SimWait(BehaviourWithPorts):
    """RUNNING until ``seconds`` sim seconds have passed since initialise, then SUCCESS.

    Args:
        name: the behaviour's name
        seconds: how long to wait, in sim seconds
    """

    INPUT_PORTS: ClassVar[Ports] = {}
    OUTPUT_PORTS: ClassVar[Ports] = {}

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

    INPUT_PORTS: ClassVar[Ports] = {
        "seconds": PortInformation(data_type=float, required=False),
    }
    OUTPUT_PORTS: ClassVar[Ports] = {}

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
