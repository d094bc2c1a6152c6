"""The suite started with the stop signals ignored still stops the processes its tests start.

A shell's background job (``make test &`` in a script, a CI step sent to the background) ignores
SIGINT, and children inherit that. ``conftest.py`` puts the stop signals back at their defaults
in every test process; here a pytest started with SIGINT and SIGHUP ignored runs the probe
below, which checks what a child started by a test would get.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

PROBE = ("import signal; print(signal.getsignal(signal.SIGINT) is signal.default_int_handler, "
         "signal.getsignal(signal.SIGHUP) is signal.SIG_DFL)")
ROOT = Path(__file__).resolve().parent.parent


def _ignore_stop_signals() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)


def test_a_child_started_by_a_test_gets_sigint_and_sighup_at_their_defaults() -> None:
    child = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                           timeout=60, check=True)
    assert child.stdout.split() == ["True", "True"]


def test_a_suite_started_with_the_stop_signals_ignored_hands_its_children_the_defaults() -> None:
    probe = f"{Path(__file__).relative_to(ROOT)}::" \
            "test_a_child_started_by_a_test_gets_sigint_and_sighup_at_their_defaults"
    environment = {key: value for key, value in os.environ.items()
                   if not key.startswith(("PYTEST_", "ROS_DOMAIN_ID"))}
    inner = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", probe],
        cwd=ROOT, env=environment, preexec_fn=_ignore_stop_signals, capture_output=True,
        text=True, timeout=120, check=False)
    assert inner.returncode == 0, inner.stdout[-2000:] + inner.stderr[-2000:]
    assert "1 passed" in inner.stdout
