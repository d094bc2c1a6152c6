"""``python -m bt_servicesim.replay DIR``: the tree of a recorded run, as it was at any moment.

It reads the run's snapshot log (``DIR/tree_log.jsonl``, see :mod:`bt_servicesim.records.tree_log`)
and prints the unicode tree with every node's status and feedback message as logged: at the end of
the run by default, at a tick (``--tick N``) or at a sim time (``--time S``). ``--step`` walks
through the run one change at a time from there: Enter shows the next change, ``b`` the previous
one, ``q`` quits. It reads whole lines, so it works as well with a script piped into stdin as at
a terminal; at a terminal each step redraws the screen.

Exit status: 0, or 2 with one line on stderr for a missing or unreadable log or a moment before
the first record or after the last.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from bt_servicesim.cli import OneLineArgumentParser, interruptible
from bt_servicesim.mission.report import replay_caveat
from bt_servicesim.mission.settings import REPORT_NAME
from bt_servicesim.records.tree_log import (
    LOG_NAME,
    TreeHistory,
    TreeLogError,
    TreeState,
    read_tree_log,
)
from bt_servicesim.tree.shape import ShadowTree

EXIT_OK, EXIT_BAD_INPUT = 0, 2
PROG = "python -m bt_servicesim.replay"
CLEAR_SCREEN = "\x1b[H\x1b[2J"



def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog=PROG,
                                   description="Show a recorded run's tree at a moment.")
    parser.add_argument("run", type=Path, help=f"run directory (with {LOG_NAME}) or the log file")
    moment = parser.add_mutually_exclusive_group()
    moment.add_argument("--tick", type=int, help="the tree as it was at this tick")
    moment.add_argument("--time", type=float, help="the tree as it was at this sim time (s)")
    parser.add_argument("--step", action="store_true",
                        help="step through the changes: Enter = next, b = back, q = quit")
    parser.add_argument("--running-only", action="store_true",
                        help="expand only the running branches")
    parser.add_argument("--ascii", action="store_true", help="ascii symbols instead of unicode")
    return parser


def log_path(run: Path) -> Path:
    return run / LOG_NAME if run.is_dir() else run


def state_index(history: TreeHistory, *, tick: int | None, time: float | None) -> int:
    """Which logged state to show first: at ``tick`` or ``time``, else the last one."""
    if tick is not None:
        return history.index_at_tick(tick)
    if time is not None:
        return history.index_at_time(time)
    return history.index_at_tick(history.states[-1].tick if history.states else 0)


def frame(shadow: ShadowTree, state: TreeState, *, symbols: str, running_only: bool,
          colour: bool) -> str:
    """One screen: a heading line and the tree as logged in ``state``."""
    shadow.show(state.nodes, tip=state.tip)
    heading = (f"tick {state.tick}  sim time {state.sim_time_s:.1f} s  "
               f"root {state.root.name}  tip {state.tip or '-'}")
    tree = shadow.text(symbols=symbols, running_only=running_only, colour=colour)
    return f"{heading}\n{tree}"


def step_through(history: TreeHistory, start: int, *, draw: ShadowTree, symbols: str,
                 running_only: bool, commands: TextIO, out: TextIO) -> None:
    """Show states from ``start``; each command line moves: '' next, 'b' back, 'q' quit."""
    interactive = out.isatty()
    position = start
    while True:
        screen = frame(draw, history.states[position], symbols=symbols,
                       running_only=running_only, colour=interactive)
        last = position == len(history.states) - 1
        prompt = "[end of run] b = back, q = quit" if last else "Enter = next, b = back, q = quit"
        out.write((CLEAR_SCREEN if interactive else "") + screen + f"{prompt}\n")
        out.flush()
        command = commands.readline()
        if not command or command.strip().lower() == "q":
            return
        if command.strip().lower() == "b":
            position = max(position - 1, 0)
        elif not last:
            position += 1
        elif not interactive:
            return  # a script that keeps pressing Enter at the end is done


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    path = log_path(args.run)
    try:
        if not path.exists():
            raise TreeLogError(f"{args.run}: no {LOG_NAME} here (was the run given --out?)")
        if args.tick is not None and args.tick < 0:
            raise TreeLogError(f"--tick {args.tick}: must be 0 or more")
        if args.time is not None and not math.isfinite(args.time):
            raise TreeLogError(f"--time {args.time}: must be a finite number of sim seconds")
        history = read_tree_log(path)
        history.check_within(tick=args.tick, sim_time_s=args.time)
        start = state_index(history, tick=args.tick, time=args.time)
    except TreeLogError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    shadow = ShadowTree(history.shape)
    symbols = "ascii" if args.ascii else "unicode"
    if args.step:
        step_through(history, start, draw=shadow, symbols=symbols,
                     running_only=args.running_only, commands=sys.stdin, out=sys.stdout)
        return EXIT_OK
    sys.stdout.write(frame(shadow, history.states[start], symbols=symbols,
                           running_only=args.running_only, colour=sys.stdout.isatty()))
    command = reproduce_command(path.parent)
    if command:
        print(f"this mission again: {command}")
    return EXIT_OK


def reproduce_command(run: Path) -> str | None:
    """The command the run's report names for playing its mission again, if it names one."""
    try:
        report = json.loads((run / REPORT_NAME).read_text())
    except (OSError, ValueError):
        return None
    command = report.get("reproduce") if isinstance(report, dict) else None
    if not command:
        return None
    caveat = replay_caveat(report)
    return command if caveat is None else f"{command} ({caveat}: may differ)"


if __name__ == "__main__":
    sys.exit(interruptible(PROG, main))
