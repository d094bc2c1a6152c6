"""The signals that stop the simulator: Ctrl-C's (SIGINT), a process manager's (SIGTERM) and a
closed terminal's (SIGHUP).

Kept apart from :mod:`servicesim_sim.node`, which imports rclpy, so that the command can take
them over first thing (:mod:`servicesim_sim.__main__`) and a stop while it starts is one line.
"""

from __future__ import annotations

import signal

__all__ = ["STOP_SIGNALS"]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
