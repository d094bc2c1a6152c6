"""Live progress of a run in the terminal: phase, checkpoints, sim time, score.

Headless, it prints a plain line whenever the phase or the checkpoint count changes (and a
heartbeat now and then), which reads well in CI logs. On a terminal it redraws one status line
in place, at most a few times a second of wall time, so a fast simulation does not flood it;
when the executive is a behaviour tree, the live tree
(:mod:`bt_servicesim.mission.live_view`) is drawn above that line.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

import py_trees

from bt_servicesim.mission.live_view import LiveTreeView
from bt_servicesim.mission.referee_monitor import RefereeMonitor
from bt_servicesim.tree.executive import Executive

REDRAW_PERIOD_S = 0.25
HEARTBEAT_PERIOD_S = 10.0


class ProgressView:
    """Prints progress lines; see the module docstring."""

    def __init__(self, *, headless: bool, stream: TextIO | None = None,
                 tree_root: py_trees.behaviour.Behaviour | None = None) -> None:
        self.stream = stream or sys.stdout
        self.live = not headless and self.stream.isatty()
        self.tree_view = (LiveTreeView(root=tree_root, stream=self.stream)
                          if self.live and tree_root is not None else None)
        self._last_key: tuple[str, str] | None = None
        self._last_print = 0.0

    def update(self, *, executive: Executive, monitor: RefereeMonitor,
               sim_time_s: float) -> None:
        if self.tree_view is not None:
            self.tree_view.draw(status_line=self._line(executive, monitor, sim_time_s))
            return
        now = time.monotonic()
        key = (executive.phase(), monitor.checkpoint())
        changed = key != self._last_key
        period = REDRAW_PERIOD_S if self.live else HEARTBEAT_PERIOD_S
        if not changed and now - self._last_print < period:
            return
        self._last_key, self._last_print = key, now
        line = self._line(executive, monitor, sim_time_s)
        if self.live:
            self.stream.write("\r\x1b[2K" + line[:160])
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self, *, executive: Executive, monitor: RefereeMonitor,
              sim_time_s: float) -> None:
        line = self._line(executive, monitor, sim_time_s)
        if self.tree_view is not None:
            self.tree_view.close(status_line=line)
            return
        self.stream.write(("\r\x1b[2K" + line + "\n") if self.live else line + "\n")
        self.stream.flush()

    @staticmethod
    def _line(executive: Executive, monitor: RefereeMonitor, sim_time_s: float) -> str:
        return (f"[{sim_time_s:7.1f} s sim] {executive.phase():<13} "
                f"checkpoints {monitor.checkpoint()}  score {monitor.score():8.1f}  "
                f"{executive.activity()}")
