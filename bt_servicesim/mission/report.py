"""The run's report, ``report.json``: written whole or not at all, and always the run's own.

A report is written twice: when the run starts (``"status": "running"``, so that a run that is
killed outright still leaves a record of what it was) and when it ends, with the referee's
account. Each write goes to a temporary file in the same directory that then replaces the
report in one rename, so a reader never sees half a report. Every report carries the run's
``run_id`` (given by the caller, or drawn at random), so a tool that started the run can tell its
own report from one an earlier run left behind.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

__all__ = ["left_lockstep", "read_report", "replay_caveat", "write_report"]


def write_report(path: Path, report: dict[str, Any]) -> None:
    """Write ``report`` as JSON to ``path`` atomically (a temporary file, then a rename)."""
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w") as stream:
            stream.write(json.dumps(report, indent=2) + "\n")
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def read_report(path: Path) -> dict[str, Any] | None:
    """The report at ``path``, or None if there is none or it is not a JSON object."""
    try:
        report = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return report if isinstance(report, dict) else None


def left_lockstep(report: dict[str, Any]) -> bool:
    """Whether a run that joined lockstep left its guarantee on the way: it ticked a period
    without every message, or the simulator dropped it and it ran free from there."""
    return bool(report.get("lockstep_stalls") or report.get("lockstep_dropped"))


def replay_caveat(report: dict[str, Any]) -> str | None:
    """Why the report's ``reproduce`` command may play another mission, in words; None for a
    run that was in lockstep from start to end."""
    if report.get("timing") != "lockstep":
        return "ran free"
    dropped = report.get("lockstep_dropped")
    if isinstance(dropped, dict):
        return (f"the simulator dropped the run from lockstep at {dropped.get('sim_time_s')} "
                "s sim, and it ran free from there")
    if report.get("lockstep_stalls"):
        return f"{report['lockstep_stalls']} lockstep period(s) went on without every message"
    return None
