"""A benchmark's figures as a JSON file: the commit they were measured on, and reading them back.

The benchmarks whose figures ``results.md`` states (``benchmarks/reproducibility.py``,
``benchmarks/throughput.py``) write them with ``--json FILE`` and name the checkout's commit
(:func:`checkout_commit`) and write it whole (:func:`write_figures`); ``evaluate`` reads such a
file before anything starts (:func:`read_figures`), so that a file that cannot be read is one
line naming the problem.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

from bt_servicesim.mission.report import write_report

__all__ = ["checkout_commit", "read_figures", "write_figures"]


def checkout_commit() -> str | None:
    """The short commit of the checkout this package was imported from, or ``None``."""
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, check=True, timeout=10,
                             cwd=Path(__file__).resolve().parent)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


def read_figures(path: Path) -> Any:
    """The JSON document in ``path``; ``ValueError`` with one line naming the problem."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise ValueError(f"{path}: cannot be read ({error.strerror or error})") from error
    except ValueError as error:
        raise ValueError(f"{path}: not JSON ({error})") from error


def write_figures(path: Path, document: dict[str, Any]) -> None:
    """Write ``document`` to ``path`` whole, as a run's report is written (a temporary file
    renamed over it): a benchmark cut short leaves the last figures, never half of them."""
    write_report(path, document)
