"""Commands run as a user runs them: :func:`run_module` (``python -m``, output captured), and
:func:`stop_child`, which ends a process a test started however the test went."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path


def run_module(module: str, *arguments: str, cwd: Path | None = None,
               timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """``python -m module arguments`` in ``cwd``, its output captured as text."""
    return subprocess.run([sys.executable, "-m", module, *arguments], capture_output=True,
                          text=True, cwd=cwd, timeout=timeout)


def stop_child(process: subprocess.Popen[bytes] | subprocess.Popen[str], *,
               limit_s: float = 30.0) -> None:
    """SIGINT, as Ctrl-C would, then SIGKILL if the process is still there after ``limit_s``:
    a test's clean-up never leaves a simulator running at full speed after it."""
    if process.poll() is not None:
        return
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=limit_s)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
