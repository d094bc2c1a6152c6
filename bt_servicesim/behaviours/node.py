"""What a node of the mission tree is: BehaviorTree.CPP's node kinds, told by the base class.

BehaviorTree.CPP and Groot2 sort every node into a kind -- Action, Condition, Decorator or
Control -- and the kind is a promise about its statuses: a Condition answers at once, SUCCESS or
FAILURE, and never RUNNING; an Action may take many ticks. Here the base class a behaviour
derives from is its kind, so the promise lives in one place and the generated node model
(:mod:`bt_servicesim.tree.model`) reads the kind off the class instead of a hand-kept list:

- :class:`ActionNode`: any leaf that does something or waits for something.
- :class:`ConditionNode`: a leaf that only checks. It implements :meth:`ConditionNode.check`;
  the base class's ``update`` turns the answer into SUCCESS or FAILURE, so a condition cannot
  return RUNNING.
- a ``py_trees.decorators.Decorator`` is a Decorator, a ``py_trees.composites.Composite`` a
  Control (:mod:`bt_servicesim.behaviours.controls`).

Both leaf bases declare no ports, so py_trees' ports registry treats them as abstract and never
registers them as XML tags; every concrete subclass that declares ``INPUT_PORTS`` and
``OUTPUT_PORTS`` is registered under its class name when its module is imported
(:mod:`bt_servicesim.behaviours` imports them all).

Their ports find their blackboard entries once (:mod:`bt_servicesim.behaviours.port_keys`), and
they run py_trees' leaf lifecycle without its unread debug messages
(:mod:`bt_servicesim.behaviours.lifecycle`).
"""

from __future__ import annotations

import py_trees
from py_trees.ports import BehaviourWithPorts, PortInformation

from bt_servicesim.behaviours.lifecycle import LeafLifecycle
from bt_servicesim.behaviours.port_keys import PortKeys

__all__ = ["ActionNode", "ConditionNode", "Ports", "Status", "kind_of"]

Status = py_trees.common.Status
Ports = dict[str, PortInformation]
"""A port declaration: port name to its information."""


class ActionNode(LeafLifecycle, PortKeys, BehaviourWithPorts):
    """A leaf that acts or waits: any status, with the py_trees lifecycle.

    Configuration in ``__init__``, ROS handles in ``setup``, requests sent in ``initialise``, a
    non-blocking ``update``, and a ``terminate`` that cancels whatever is still in flight.
    """


class ConditionNode(LeafLifecycle, PortKeys, BehaviourWithPorts):
    """A leaf that checks: SUCCESS when :meth:`check` says yes, FAILURE otherwise, never RUNNING.

    Subclasses implement :meth:`check` and set ``feedback_message`` to say why.
    """

    def update(self) -> Status:
        """The check's answer as a status."""
        return Status.SUCCESS if self.check() else Status.FAILURE

    def check(self) -> bool:
        """True when the condition holds; sets ``feedback_message``."""
        raise NotImplementedError


def kind_of(cls: type) -> str:
    """BehaviorTree.CPP's kind of a behaviour class: Action, Condition, Decorator or Control."""
    if issubclass(cls, py_trees.decorators.Decorator):
        return "Decorator"
    if issubclass(cls, py_trees.composites.Composite):
        return "Control"
    if issubclass(cls, ConditionNode):
        return "Condition"
    return "Action"
