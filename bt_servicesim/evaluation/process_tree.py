"""A process and everything below it, stopped for good: what an evaluation does to an episode's
process (a run, or a warm pair's worker) that has to go.

Processes are found and told apart through ``/proc``: a pid is only signalled while it is still
the process that was collected (same pid and start time), so a pid the kernel gave to someone
else meanwhile is never hit.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time
from collections.abc import Iterable
from pathlib import Path

from bt_servicesim.evaluation.settings import STOP_GRACE_S

__all__ = ["descendants", "start_time", "stop_process_tree"]

PARENT_FIELD, STATE_FIELD, START_TIME_FIELD = 4, 3, 22  # of /proc/<pid>/stat
GONE_WAIT_S = 5.0  # wall seconds to wait for SIGKILLed processes to be gone


def stop_process_tree(process: subprocess.Popen[bytes]) -> None:
    """SIGINT the episode (it then stops its simulator and writes its report), then SIGKILL
    whatever is left, and wait until it is gone.

    The run starts its simulator in a session of its own, so the tree is collected from
    ``/proc`` before anything is signalled, and again before the SIGKILL (a run stopped while
    starting may have started its simulator meanwhile); a process is only killed if it is
    still the one that was collected (same pid and start time).
    """
    identities = _identities([process.pid, *descendants(process.pid)])
    _signal(process.pid, signal.SIGINT)
    with contextlib.suppress(subprocess.TimeoutExpired):
        process.wait(timeout=STOP_GRACE_S)
    if process.poll() is None:
        identities.update(_identities(descendants(process.pid)))
    for pid, started in identities.items():
        if _alive_as(pid, started):
            _signal(pid, signal.SIGKILL)
    process.wait()
    deadline = time.monotonic() + GONE_WAIT_S
    while any(_alive_as(pid, started) for pid, started in identities.items()):
        if time.monotonic() > deadline:
            break
        time.sleep(0.02)


def _identities(pids: Iterable[int]) -> dict[int, int]:
    """Each pid's start time, for the pids that are running."""
    found = {pid: start_time(pid) for pid in pids}
    return {pid: started for pid, started in found.items() if started is not None}


def _alive_as(pid: int, started: int) -> bool:
    """Whether ``pid`` is still the process that started at ``started`` and not a zombie."""
    return start_time(pid) == started and _state(pid) not in (None, "Z", "X")


def descendants(pid: int) -> list[int]:
    """Every process below ``pid``, found through ``/proc/<pid>/stat`` parent ids."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            parent = _stat_field(int(entry.name), PARENT_FIELD)
            if parent is not None:
                children.setdefault(int(parent), []).append(int(entry.name))
    found, frontier = [], [pid]
    while frontier:
        below = children.get(frontier.pop(), [])
        found += below
        frontier += below
    return found


def start_time(pid: int) -> int | None:
    """The process's start time in clock ticks since boot; None if it is gone."""
    value = _stat_field(pid, START_TIME_FIELD)
    return None if value is None else int(value)


def _state(pid: int) -> str | None:
    """The process's state letter (R, S, Z, ...); None if it is gone."""
    return _stat_field(pid, STATE_FIELD)


def _stat_field(pid: int, number: int) -> str | None:
    """Field ``number`` (1-based, as proc(5) counts) of ``/proc/<pid>/stat``."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    after_name = text[text.rfind(")") + 2:].split()  # the name (field 2) may hold spaces
    return after_name[number - 3]


def _signal(pid: int, signal_number: int) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal_number)
