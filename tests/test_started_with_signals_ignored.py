"""The suite started with the stop signals ignored still stops the processes its tests start.

A shell's background job (``make test &`` in a script, a CI step sent to the background) ignores
SIGINT, and children inherit that. ``conftest.py`` puts the stop signals back at their defaults
in every test process; here a pytest started with SIGINT and SIGHUP ignored, with the suite's
conftest as a plugin, runs a probe test that starts a child and says what the child got.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PROBE = '''
import signal, subprocess, sys

def test_probe():
    child = subprocess.run(
        [sys.executable, "-c", "import signal; print(signal.getsignal(signal.SIGINT) is "
         "signal.default_int_handler, signal.getsignal(signal.SIGHUP) is signal.SIG_DFL)"],
        capture_output=True, text=True, timeout=60, check=True)
    print("child:", child.stdout.strip())
'''


def _ignore_stop_signals() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)


def probe(tmp_path: Path, *plugins: str) -> str:
    """What a child started by a test gets, in a pytest started with the signals ignored."""
    test_file = tmp_path / "test_probe.py"
    test_file.write_text(PROBE)
    environment = {key: value for key, value in os.environ.items()
                   if not key.startswith(("PYTEST_", "ROS_DOMAIN_ID"))}
    arguments = [argument for plugin in plugins for argument in ("-p", plugin)]
    inner = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-s", "-p", "no:cacheprovider", "-p", "no:xdist",
         "--rootdir", str(tmp_path), *arguments, str(test_file)],
        cwd=ROOT, env=environment, preexec_fn=_ignore_stop_signals, capture_output=True,
        text=True, timeout=120, check=False)
    assert inner.returncode == 0, inner.stdout[-2000:] + inner.stderr[-2000:]
    return next(line for line in inner.stdout.splitlines() if "child:" in line)


def test_a_suite_started_with_the_stop_signals_ignored_hands_its_children_the_defaults(
        tmp_path: Path) -> None:
    (tmp_path / "without").mkdir()
    assert probe(tmp_path / "without").endswith("child: False False")  # what it would be
    assert probe(tmp_path, "tests.conftest").endswith("child: True True")
