"""The bound on a run's shut-down (:mod:`bt_servicesim.mission.shutdown_limit`), in processes of
its own: one whose shut-down hangs ends at the limit with the status it was given and every
thread's stack on stderr; one that ends in time ends as it would have; one whose hang holds the
interpreter's lock is ended by the backstop."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
WALL_LIMIT_S = 60.0  # a generous bound on a loaded machine; not a benchmark


def python(script: str) -> tuple[subprocess.CompletedProcess[str], float]:
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True,
                          text=True, timeout=WALL_LIMIT_S)
    return done, time.monotonic() - started


ARMED = ("import threading, time\n"
         "from bt_servicesim.mission.shutdown_limit import bound_the_shutdown\n"
         "bound_the_shutdown(exit_status=7, limit_s={limit}, backstop_s={backstop})\n")


def test_a_shutdown_that_hangs_ends_at_the_limit_with_the_status_and_the_stacks() -> None:
    done, took_s = python(ARMED.format(limit=0.5, backstop=30.0)
                          + "threading.Event().wait()  # the hang\n")
    assert done.returncode == 7, done.stderr
    assert "did not end within 0.5 s of its report: ending the process with exit status 7" \
        in done.stderr
    assert "threading.Event().wait()" not in done.stdout
    assert 'File "<string>", line 4' in done.stderr, "the hung thread's stack"
    assert took_s < 30.0, "the timer ended it, not the backstop"


def test_a_process_that_ends_in_time_ends_as_it_would_have() -> None:
    done, _ = python(ARMED.format(limit=20.0, backstop=10.0) + "raise SystemExit(3)\n")
    assert done.returncode == 3
    assert done.stderr == ""


def test_a_hang_that_holds_the_interpreter_lock_is_ended_by_the_backstop() -> None:
    # the regular expression engine never lets the lock go: the Python timer cannot run
    hang = "import re\nre.match(r'(a+)+$', 'a' * 64 + 'b')\n"
    done, _ = python(ARMED.format(limit=0.3, backstop=0.5) + hang)
    assert done.returncode == 1, done.stderr
    assert "Timeout (0:00:00.800000)!" in done.stderr
    assert 'File "<string>", line 5' in done.stderr
    assert "ending the process with exit status 7" not in done.stderr
