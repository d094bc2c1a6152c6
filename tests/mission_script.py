"""Scripted stand-ins for the mission tree's leaves, for tree tests without a ROS graph.

:func:`scripted_registry` reads a tree file and makes, for every leaf tag it uses, a ports class
with exactly the ports the file wires, whose outcomes come from a :class:`Script`. The real
sim-time decorators (``SimTimeout``, ``SimWait``) are kept and run on a :class:`ManualClock`,
so the mission's structure (its retries, fallbacks and time limit) is what gets tested.
"""

from __future__ import annotations

import types
import xml.etree.ElementTree as ElementTree
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import py_trees
from py_trees.ports import BehaviourWithPorts, PortInformation
from rclpy.clock import ClockType
from rclpy.time import Time

from bt_servicesim.planning.geometry import Box, Pose2D

Status = py_trees.common.Status
KEEP_REAL = ("SimTimeout", "SimWait")
#: Input port types kept from the real leaf, so that constants in the tree file still convert.
SCALARS = (float, int, str, bool)
NOT_LEAVES = {"root", "BehaviorTree", "SubTree", "TreeNodesModel", "Sequence", "Fallback",
              "Selector", "Parallel"}

class Unscripted:
    """A value for an output no test looks into; its repr is the same in every run, so that two
    runs of a script write the same snapshot log."""

    def __repr__(self) -> str:
        return "<unscripted value>"


#: What a scripted leaf writes to each output port it has when it succeeds.
OUTPUT_VALUES: dict[str, Any] = {
    "pick_up_location": "FrontElevator", "drop_off_location": "PrivateCubicle_32_1",
    "guest_name": "human_20843", "start_pose": Pose2D(10.975, 3.75, 3.14),
    "box": Box(-1.5, 0.0, 1.5, 2.7), "goal": Pose2D(0.0, 1.3, 0.0), "copy": Pose2D(0.0, 1.3),
    "jittered": Pose2D(0.1, 1.3), "waypoints": [Pose2D(1.0, 1.0), Pose2D(-1.0, 1.0)],
    "robot_pose": Pose2D(0.0, 0.0), "occupancy": Unscripted(), "actors_in_range": [],
    "rfid_age": 0.0, "guest_last_seen": Pose2D(-5.0, 5.0), "distance_remaining": 0.0,
    "error_code": 0, "error_msg": "", "rfid_history": Unscripted(),
}


class ManualClock:
    """A node stand-in whose sim time the test advances."""

    def __init__(self) -> None:
        self.nanoseconds = 1_000_000_000

    def advance(self, seconds: float) -> None:
        self.nanoseconds += int(seconds * 1e9)

    def now(self) -> Time:
        return Time(nanoseconds=self.nanoseconds, clock_type=ClockType.ROS_TIME)

    def get_clock(self) -> ManualClock:
        return self


class Script:
    """Outcomes per leaf, by its name and any of its ancestors' (``"GoToStart.NavigateToGoal"``).

    An outcome is a Status, or ``(Status, n)``: RUNNING for ``n`` ticks, then the Status.
    A leaf with no outcomes left succeeds at once. Every activation is logged in ``calls``.
    """

    def __init__(self, outcomes: dict[str, list[Any]] | None = None) -> None:
        self.outcomes = {key: list(value) for key, value in (outcomes or {}).items()}
        self.calls: list[str] = []
        self.terminated: dict[str, list[Status]] = defaultdict(list)

    def next_outcome(self, name: str) -> tuple[Status, int]:
        self.calls.append(name)
        for key, queue in self.outcomes.items():
            if matches(name, key) and queue:
                outcome = queue.pop(0)
                return outcome if isinstance(outcome, tuple) else (outcome, 0)
        return Status.SUCCESS, 0

    def scripted(self, name: str) -> bool:
        """Whether outcomes are left for the behaviour called ``name``."""
        return any(matches(name, key) and queue for key, queue in self.outcomes.items())

    def count(self, key: str) -> int:
        return sum(1 for name in self.calls if matches(name, key))


def matches(name: str, key: str) -> bool:
    """Whether a dotted behaviour name fits a key such as ``"GoToStart.NavigateToGoal"``: the
    key's last part is the leaf's own name, its other parts ancestors' names, in order."""
    *ancestors, leaf = key.split(".")
    *path, own = name.split(".")
    if own != leaf:
        return False
    position = 0
    for ancestor in ancestors:
        try:
            position = path.index(ancestor, position) + 1
        except ValueError:
            return False
    return True


def _scripted_leaf(tag: str, ports: set[str], script: Script, real: type | None) -> type:
    """A stand-in whose ports are the real leaf's; its settings (``seconds``, ``grace``...)
    become constant string inputs."""
    real_ports = real if real is not None and issubclass(real, BehaviourWithPorts) else None
    real_declared = real_ports.input_ports() if real_ports is not None else {}
    real_inputs = set(real_declared)
    real_outputs = set(real_ports.output_ports()) if real_ports is not None else set()

    def port_info(names: set[str], data_type: type) -> dict[str, PortInformation]:
        return {port: PortInformation(data_type=data_type, required=False) for port in names}

    settings = ports - real_inputs - real_outputs
    scalars = {port for port in ports & real_inputs
               if real_declared[port].data_type in SCALARS}
    inputs = {**port_info(ports & real_inputs - scalars, object), **port_info(settings, str),
              **{port: real_declared[port] for port in scalars}}
    outputs = port_info(ports & real_outputs, object)

    def initialise(self: Any) -> None:
        self._outcome, self._running_ticks = script.next_outcome(self.name)

    def update(self: Any) -> Status:
        if self._running_ticks > 0:
            self._running_ticks -= 1
            return Status.RUNNING
        if self._outcome == Status.SUCCESS:
            for port in self.output_ports():
                self._set_output(port, OUTPUT_VALUES.get(port, Unscripted()))
        self.feedback_message = f"scripted {self._outcome.name}"
        outcome: Status = self._outcome
        return outcome

    def terminate(self: Any, new_status: Status) -> None:
        script.terminated[self.name].append(new_status)

    def body(namespace: dict[str, Any]) -> None:
        namespace.update(INPUT_PORTS=inputs, OUTPUT_PORTS=outputs,
                         initialise=initialise, update=update, terminate=terminate)

    return types.new_class(f"Scripted{tag}", (BehaviourWithPorts,), {"register": False}, body)


def leaf_ports(tree_file: Path) -> dict[str, set[str]]:
    """Every leaf tag the file uses, with the attributes it gives it (minus ``name``).

    py_trees' composites and decorators, and this project's own controls and decorators
    (a ``RecoveryNode``), are structure, not leaves: the script never stands in for them.
    """
    from bt_servicesim.behaviours import node_registry
    from bt_servicesim.behaviours.node import kind_of

    structure = {tag for tag, cls in node_registry().items()
                 if kind_of(cls) in ("Control", "Decorator")}
    ports: dict[str, set[str]] = defaultdict(set)
    decorators = {name.lower() for name in dir(py_trees.decorators)}
    for tree in ElementTree.parse(tree_file).getroot().findall("BehaviorTree"):
        for element in tree.iter():
            if (element.tag in NOT_LEAVES or element.tag.lower() in decorators
                    or element.tag in structure):
                continue
            ports[element.tag].update(key for key in element.attrib if key != "name")
    return ports


def scripted_registry(tree_file: Path, script: Script) -> dict[str, Callable[..., Any]]:
    from bt_servicesim.behaviours import node_registry
    from bt_servicesim.behaviours.node import kind_of

    real = node_registry()
    structure = {tag: cls for tag, cls in real.items() if kind_of(cls) in ("Control", "Decorator")}
    registry: dict[str, Callable[..., Any]] = {
        **structure, **{tag: real[tag] for tag in KEEP_REAL}}
    for tag, ports in leaf_ports(tree_file).items():
        if tag not in KEEP_REAL:
            registry[tag] = _scripted_leaf(tag, ports, script, real.get(tag))
    registry["StandoffTimeout"] = _scripted_standoff(script)
    return registry


def _scripted_standoff(script: Script) -> type:
    """The real StandoffTimeout with the world it reads scripted: the robot stands from the
    decorator's first tick (the scripted leaves never move it), and an activation whose outcome
    is FAILURE has someone near (so it stops its child once the robot has stood its
    ``seconds``), any other activation nobody."""
    from bt_servicesim.behaviours.decorators.standoff_timeout import StandoffTimeout
    from bt_servicesim.ros.sim_clock import sim_now_s

    class ScriptedStandoffTimeout(StandoffTimeout, register=False):
        def initialise(self) -> None:
            super().initialise()
            assert self._clock is not None
            self._started = sim_now_s(self._clock)
            self._someone_near = (script.scripted(self.name)
                                  and script.next_outcome(self.name)[0] == Status.FAILURE)

        def _stood(self) -> float:
            assert self._clock is not None
            return sim_now_s(self._clock) - self._started

        def _held_up(self) -> tuple[bool, str]:
            return self._someone_near, "scripted"

    return ScriptedStandoffTimeout
