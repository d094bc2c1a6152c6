"""A bound on a run's shut-down: once its report is written, the process ends.

After the run has written its report and its last line, what is left is closing handles: the
executor, the node, rclpy's context, then the interpreter's finalisation with Fast DDS's
threads. None of it waits on the mission, but rclpy's and Fast DDS's shut-down can deadlock:
one run in some thousands in the test suite wrote a complete report and then never exited,
and the evaluation that waited for it waited until its episode's wall-time limit. A process
that has said everything must not hold its caller.

:func:`bound_the_shutdown` gives the shut-down :data:`SHUTDOWN_LIMIT_S` wall seconds. Past
them it writes one line and every thread's stack to standard error (the run's log: what a bug
report needs) and ends the process at once with the run's own exit status, which the report
already explains. A Python timer does that; if a thread holds the interpreter's lock and the
timer cannot run, :mod:`faulthandler`'s own C thread dumps the stacks and exits (status 1)
:data:`BACKSTOP_S` later.

Only the ``run`` command's process arms it: a caller that made the run in its own process
(a test, the warm worker) goes on after it and decides for itself.
"""

from __future__ import annotations

import faulthandler
import os
import sys
import threading
from typing import TextIO

SHUTDOWN_LIMIT_S = 30.0
"""Wall seconds the run's shut-down may take once its report is written: it takes well under
one on an idle machine."""
BACKSTOP_S = 10.0
"""Wall seconds after the limit at which :mod:`faulthandler` ends a process whose Python
timer could not run."""


def bound_the_shutdown(*, exit_status: int, limit_s: float = SHUTDOWN_LIMIT_S,
                       backstop_s: float = BACKSTOP_S,
                       stream: TextIO | None = None) -> threading.Timer:
    """End the process with ``exit_status`` if it still runs ``limit_s`` wall seconds from now,
    after writing why and every thread's stack to ``stream`` (standard error by default);
    ``backstop_s`` later with status 1 if the timer could not run.

    The returned timer is a daemon: a process that ends in time ends as it would have.
    ``timer.cancel()`` and :func:`faulthandler.cancel_dump_traceback_later` take the bound back.
    """
    out = sys.stderr if stream is None else stream
    faulthandler.dump_traceback_later(limit_s + backstop_s, exit=True, file=out)
    timer = threading.Timer(limit_s, _end, kwargs={"exit_status": exit_status,
                                                   "limit_s": limit_s, "stream": out})
    timer.daemon = True
    timer.name = "shutdown-limit"
    timer.start()
    return timer


def _end(*, exit_status: int, limit_s: float, stream: TextIO) -> None:
    print(f"the run's shut-down did not end within {limit_s:g} s of its report: ending the "
          f"process with exit status {exit_status}; every thread's stack follows",
          file=stream, flush=True)
    faulthandler.dump_traceback(file=stream, all_threads=True)
    stream.flush()
    os._exit(exit_status)
