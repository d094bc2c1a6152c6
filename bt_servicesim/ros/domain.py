"""A ROS domain of the run's own, so that it only ever talks to the simulator it started.

Two runs in one shell share its ``ROS_DOMAIN_ID``: each executive then sees both simulators,
calls whichever answers first, and the referee that counts is not the one it asked. So a run
that starts its own simulator claims a domain nobody else on this machine is using, and gives it
to the simulator through the environment. Claims are advisory locks (``flock``) on one file per
domain in a directory every run of this user shares; a lock goes with the process that held it,
however it ended, so a crashed run never keeps a domain. The user's own ``ROS_DOMAIN_ID`` (their
robot graph) is never claimed.

Only runs of this project take part; another ROS program could still pick a claimed domain. On
loopback discovery (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) the domains 1 to 101 are
plenty: an evaluation runs a handful of episodes at once.
"""

from __future__ import annotations

import fcntl
import os
import tempfile
from pathlib import Path
from typing import IO

__all__ = ["DOMAINS", "DomainClaim", "NoFreeDomainError", "claim_domain"]

DOMAINS = range(1, 102)
"""Domains a run may claim; 0, the default of every ROS program, is left to the user."""


class NoFreeDomainError(RuntimeError):
    """Every domain is claimed by another run."""


class DomainClaim:
    """A claimed domain; :meth:`release` (or the process's end) frees it."""

    def __init__(self, domain_id: int, lock: IO[bytes]) -> None:
        self.domain_id = domain_id
        self._lock: IO[bytes] | None = lock

    def release(self) -> None:
        if self._lock is not None:
            self._lock.close()
            self._lock = None


def lock_directory() -> Path:
    """Where the claims live: one directory per user, under the system's temporary directory."""
    return Path(tempfile.gettempdir()) / f"bt_servicesim-ros-domains-{os.getuid()}"


def claim_domain(*, start: int | None = None, avoid: int | None = None) -> DomainClaim:
    """Claim a free domain, trying from ``start`` (default: by process id) round the range."""
    directory = lock_directory()
    directory.mkdir(mode=0o700, exist_ok=True)
    first = (os.getpid() if start is None else start) % len(DOMAINS)
    for offset in range(len(DOMAINS)):
        domain_id = DOMAINS[(first + offset) % len(DOMAINS)]
        if domain_id == avoid:
            continue
        lock = (directory / f"{domain_id}.lock").open("ab")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            continue
        return DomainClaim(domain_id, lock)
    raise NoFreeDomainError(f"every ROS domain {DOMAINS.start}-{DOMAINS.stop - 1} is claimed "
                            f"by another run (locks in {directory})")
