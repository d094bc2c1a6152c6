"""Simulation time for behaviours: the node's clock, read in sim seconds, and a stopwatch on it.

Every duration in the executive is measured in SIM seconds. The node runs with
``use_sim_time``, so its clock follows ``/clock``; py_trees' own
:class:`~py_trees.timers.Timer` and :class:`~py_trees.decorators.Timeout` measure wall
time and would run fast or slow against the simulator (and keep running while it is paused).

Before the first ``/clock`` message a sim-time clock reads zero. That is taken to mean *time
is not advancing*: a :class:`SimStopwatch` reads zero elapsed seconds until the clock runs and
then starts counting from the first non-zero reading. A clock that jumps backwards (the
simulator restarted) restarts the stopwatch rather than producing negative durations.

Besides the stopwatch this module holds :func:`node_from_setup_kwargs`, the check every
ROS-facing behaviour makes in ``setup(node=...)``. The time behaviours built on it are
:class:`~bt_servicesim.behaviours.actions.sim_wait.SimWait` and the decorator
:class:`~bt_servicesim.behaviours.decorators.sim_timeout.SimTimeout`.
"""

from typing import Any

from rclpy.clock import Clock
from rclpy.node import Node

__all__ = [
    "SimStopwatch",
    "clock_from_setup_kwargs",
    "clock_now_ns",
    "node_from_setup_kwargs",
    "sim_now_s",
]

_NS_PER_S = 1e9



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
    clock: Clock = node.get_clock()
    return clock


def clock_now_ns(clock: Clock) -> int:
    """The clock's time in nanoseconds.

    Read from the clock's handle, as ``Clock.now`` does, without building the ``Time`` it
    returns: that costs twice the reading itself, and the executive reads its clock a few dozen
    times a period (stopwatches, the recorder's time stamps). A clock without a handle (a
    test's manual clock) is read with ``now()``.
    """
    handle = getattr(clock, "handle", None)
    if handle is None:
        return clock.now().nanoseconds
    with handle:
        now_ns: int = handle.get_now().nanoseconds
    return now_ns


def sim_now_s(clock: Clock) -> float:
    """The clock's time in seconds; zero means a sim-time clock that is not yet running."""
    return clock_now_ns(clock) / _NS_PER_S


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
        now_ns = clock_now_ns(self._clock)
        self._start_ns = now_ns if now_ns > 0 else None

    def elapsed(self) -> float:
        """Seconds since :meth:`restart`; zero while the clock reads zero."""
        now_ns = clock_now_ns(self._clock)
        if now_ns <= 0:
            return 0.0
        if self._start_ns is None or now_ns < self._start_ns:
            self._start_ns = now_ns
        return (now_ns - self._start_ns) / _NS_PER_S




