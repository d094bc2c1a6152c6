"""A leaf made ready to tick: :func:`ready` (ports remapped as given) and :func:`wire` (every
port to ``/<port>``)."""

from __future__ import annotations

from typing import Any

from py_trees.blackboard import Blackboard
from rclpy.node import Node


def ready(behaviour: Any, node: Node | None = None, **remappings: str) -> Any:
    """Ports remapped to the given blackboard keys; ROS set up on ``node`` if there is one."""
    behaviour.setup_ports(port_remappings=remappings)
    if node is not None:
        behaviour.setup(node=node)
    return behaviour


def wire(behaviour: Any, node: Any = None, **inputs: Any) -> Any:
    """Every port wired to ``/<port>``, set up on ``node`` if given, ``inputs`` put there."""
    ports = {**behaviour.input_ports(), **behaviour.output_ports()}
    behaviour.setup_ports(port_remappings={port: f"/{port}" for port in ports})
    if node is not None:
        behaviour.setup(node=node)
    for key, value in inputs.items():
        Blackboard.set(f"/{key}", value)
    return behaviour
