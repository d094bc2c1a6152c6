"""A leaf that raises on its first tick: the stand-in for a behaviour with a bug.

Imported only by the process that runs the mission in the reliability tests (never by the test
process itself), so its XML tag exists only there.
"""

from __future__ import annotations

from typing import Any, ClassVar

from bt_servicesim.behaviours.node import ActionNode, Ports, Status

MESSAGE = "a behaviour's bug"


class RaiseOnTick(ActionNode):
    """Raises ``RuntimeError(MESSAGE)`` from ``update``."""

    INPUT_PORTS: ClassVar[Ports] = {}
    OUTPUT_PORTS: ClassVar[Ports] = {}

    def __init__(self, name: str = "RaiseOnTick", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def update(self) -> Status:
        raise RuntimeError(MESSAGE)
