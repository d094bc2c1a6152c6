"""The tree, live, in the terminal during a run: unicode art with statuses, redrawn on change.

The view redraws the screen from its top-left corner: the mission tree as py_trees draws it
(short names, statuses, feedback messages, the tip in bold) with only the RUNNING branches
expanded, so the whole mission fits a terminal, and a status line under it. It redraws only
when the drawing or the status line changed, and at most once per ``redraw_period_s`` of wall
time, so a simulation at ten times real time costs the terminal no more than one at real time.
Lines are cut to the terminal's width and the tree to its height, so nothing scrolls.

:class:`~bt_servicesim.mission.progress.ProgressView` uses it on a terminal unless ``--headless``.
"""

from __future__ import annotations

import shutil
import time
from typing import TextIO

import py_trees

from bt_servicesim.tree.shape import ShadowTree, TreeShape, plain, walk

REDRAW_PERIOD_S = 0.25
HOME, CLEAR_LINE, CLEAR_BELOW = "\x1b[H", "\x1b[K", "\x1b[J"


class LiveTreeView:
    """Draws ``root`` and a status line in place on ``stream`` (a terminal).

    Args:
        root: the live tree's root; only read, never ticked
        stream: the terminal
        redraw_period_s: least wall time between two redraws
    """

    def __init__(self, *, root: py_trees.behaviour.Behaviour, stream: TextIO,
                 redraw_period_s: float = REDRAW_PERIOD_S) -> None:
        self.stream = stream
        self.redraw_period_s = redraw_period_s
        self.redraws = 0
        self._shadow = ShadowTree(TreeShape.of(root))
        self._behaviours = walk(root)
        self._last_screen: list[str] = []
        self._last_draw = -float("inf")
        self._started = False

    def draw(self, *, status_line: str, force: bool = False) -> bool:
        """Redraw if due and changed (or ``force``); whether it did."""
        now = time.monotonic()
        if not force and now - self._last_draw < self.redraw_period_s:
            return False
        screen = self.screen(status_line)
        if screen == self._last_screen and not force:
            return False
        if not self._started:
            self.stream.write("\x1b[2J")  # clear once; later frames overwrite in place
            self._started = True
        self.stream.write(HOME + "".join(line + CLEAR_LINE + "\n" for line in screen)
                          + CLEAR_BELOW)
        self.stream.flush()
        self._last_screen, self._last_draw = screen, now
        self.redraws += 1
        return True

    def screen(self, status_line: str) -> list[str]:
        """The lines of one frame: the tree, fitted to the terminal, then the status line."""
        columns, rows = shutil.get_terminal_size()
        self._shadow.copy_from(self._behaviours)
        tree = self._shadow.text(running_only=True, colour=True).splitlines()
        room = max(rows - 2, 3)
        if len(tree) > room:
            tree = [*tree[:room - 1], f"... ({len(tree) - room + 1} more lines)"]
        return [_fit(line, columns) for line in [*tree, status_line]]

    def close(self, *, status_line: str) -> None:
        """Leave the last tree on screen, with the final status line under it."""
        self.draw(status_line=status_line, force=True)


def _fit(line: str, columns: int) -> str:
    """``line`` cut to ``columns`` visible characters (an over-long line loses its colours)."""
    visible = plain(line)
    if len(visible) <= columns:
        return line
    return visible[: max(columns - 1, 1)] + "…"
