"""What every command of this project shares: exit codes, one-line errors, argument parsing.

A user who mistypes gets one line on stderr that names the problem, prefixed with the command,
and exit status 2, whichever command it was; a command that ran reports how through its exit
status. Every command (``run``, ``evaluate``, ``dump``, ``replay``, ``trajectory``,
``tree_model``) and every benchmark parses its arguments with :class:`OneLineArgumentParser`.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from typing import NoReturn

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_COMPLETED",
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_OUTPUT_CLOSED",
    "OneLineArgumentParser",
    "UsageError",
    "error_line",
    "interruptible",
    "output_closed",
]

EXIT_OK = EXIT_COMPLETED = 0
"""The command did what it was asked; for a run, the referee counted all four checkpoints."""
EXIT_FAILED = 1
"""The command ran, and what it ran failed: a mission that did not complete, a stale model."""
EXIT_BAD_INPUT = 2
"""Bad input: arguments, files or settings; nothing was started."""
EXIT_INTERRUPTED = 130
"""Stopped by Ctrl-C (128 + SIGINT), after cleaning up."""
EXIT_OUTPUT_CLOSED = 141
"""The reader of its output went away (``| head``): 128 + SIGPIPE, as a shell reports a Unix
tool that SIGPIPE ended."""


class UsageError(ValueError):
    """Bad command-line input; the message is the one line the user sees."""


class OneLineArgumentParser(argparse.ArgumentParser):
    """argparse, but an error is a single line and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def error_line(prog: str, error: object) -> int:
    """Print ``prog: error: ...`` as one line on stderr; return :data:`EXIT_BAD_INPUT`."""
    text = " ".join(str(error).split()) or type(error).__name__
    print(f"{prog}: error: {text}", file=sys.stderr)
    return EXIT_BAD_INPUT


def interruptible(prog: str, main: Callable[[], int]) -> int:
    """``main()``'s exit status, with Ctrl-C while it runs one line and
    :data:`EXIT_INTERRUPTED` instead of a traceback: for the commands that start nothing and
    write their files whole (a viewer, a drawing, a dump); ``run`` and ``evaluate`` clean up
    after a stop signal themselves.

    Output whose reader went away (``| head``) ends the command quietly with
    :data:`EXIT_OUTPUT_CLOSED`, as SIGPIPE ends a Unix tool, instead of a traceback.
    """
    try:
        return main()
    except KeyboardInterrupt:
        print(f"{prog}: stopped by SIGINT", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        output_closed()
        return EXIT_OUTPUT_CLOSED


def output_closed() -> None:
    """Send what standard output still holds, and anything written later, to ``/dev/null``:
    the interpreter's flush at exit would find the closed pipe again and print a traceback."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, sys.stdout.fileno())
    finally:
        os.close(devnull)
