"""Commands run as a user runs them: :func:`run_module` (``python -m``, output captured)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def run_module(module: str, *arguments: str, cwd: Path | None = None,
               timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """``python -m module arguments`` in ``cwd``, its output captured as text."""
    return subprocess.run([sys.executable, "-m", module, *arguments], capture_output=True,
                          text=True, cwd=cwd, timeout=timeout)
