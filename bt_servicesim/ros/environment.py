"""Keep ROS 2 traffic on this machine unless the user asks for more.

Fast DDS announces itself by multicast on every network interface by default. A mission
executive that students run on a laptop in a lab, and that CI runs hundreds of times, must not
spray discovery traffic over the network, so every entry point calls
:func:`apply_localhost_defaults` before ``rclpy.init``. A user who wants the simulator and the
executive on two machines sets ``ROS_AUTOMATIC_DISCOVERY_RANGE`` (and ``ROS_DOMAIN_ID``)
themselves; their values are never overwritten.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping

DISCOVERY_RANGE_VARIABLE = "ROS_AUTOMATIC_DISCOVERY_RANGE"
LOCALHOST = "LOCALHOST"


def apply_localhost_defaults(environment: MutableMapping[str, str] | None = None) -> None:
    """Default DDS discovery to localhost in ``environment`` (``os.environ`` when omitted)."""
    target = os.environ if environment is None else environment
    if not target.get(DISCOVERY_RANGE_VARIABLE):
        target[DISCOVERY_RANGE_VARIABLE] = LOCALHOST
