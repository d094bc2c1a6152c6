"""What one mission run is asked to do, checked before anything starts.

:class:`RunSettings` is the run command's input once every argument has been checked; the
mission run (:mod:`bt_servicesim.mission.run`) takes nothing else. The constants here are the
run's own limits, in wall seconds where they guard against a process that never comes up.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

from bt_servicesim.monitor.live_server import LiveAddress

__all__ = [
    "CLOCKS", "DEFAULT_SPEED", "DEFAULT_TIME_LIMIT_S", "EXECUTIVES", "NAV_PARAMS_NAME",
    "REPORT_NAME", "STARTUP_LIMIT_S", "TRAJECTORY_POLICIES", "RunSettings", "nav_params_record",
]

EXECUTIVES = ("bt", "baseline")
"""The behaviour tree, and the seed's state machine."""
DEFAULT_SPEED = 10.0
"""Sim seconds per wall second unless the run names another speed."""
DEFAULT_TIME_LIMIT_S = 900.0
"""The mission time limit in sim seconds, unless the run names another."""
STARTUP_LIMIT_S = 60.0
"""Wall seconds the simulator gets to come up."""
CLOCKS = ("sim", "system")
"""What the executive keeps time by: the backend's ``/clock`` (a simulator, Gazebo), or the
system clock (a real robot, which publishes no ``/clock``: ``use_sim_time`` false)."""
TRAJECTORY_POLICIES = ("always", "failed", "never")
"""When the run draws ``trajectory.png``: after every run, only after a mission that did not
complete (an evaluation: the picture is the CPU of a tenth of a warm episode), or never (a run
whose figures are all that is wanted: the drawing costs about a CPU second, matplotlib's import
with it). Any run's picture can be drawn later from its ``run.mcap`` with ``python -m
bt_servicesim.trajectory DIR``."""
NAV_PARAMS_NAME = "nav_params.yaml"
"""The copy of the navigation parameters file a run was given, in its run directory."""
REPORT_NAME = "report.json"
"""The report in the run directory: score, checkpoints and penalties as the referee counted."""


@dataclass(frozen=True)
class RunSettings:
    """One run's checked input."""

    world: Path | None
    seed: int | None
    speed: float
    tree: Path
    out: Path
    time_limit_s: float
    headless: bool
    executive: str
    run_id: str = ""
    """Carried by the report, so that whoever started the run can tell the report is its own."""
    attach: bool = False
    """Start no simulator: run against the backend already on the environment's ROS domain."""
    groot: tuple[str, int] | None = None
    """Where the Groot2 monitor listens (address, port), or ``None`` for no monitor."""
    foxglove: LiveAddress | None = None
    """Serve the live topics to Foxglove on this address (``run --foxglove``); None: no server."""
    free_running: bool = False
    """Do not join the backend's lockstep even if it offers one (for comparisons)."""
    trajectory: str = "always"
    """One of :data:`TRAJECTORY_POLICIES`."""
    clock: str = "sim"
    """One of :data:`CLOCKS`; ``system`` only with ``attach``."""
    profile: bool = True
    """Count every node's ticks as the tree ticks and write ``profile.json`` at the end
    (``run --no-profile`` turns both off: for benchmarks that measure what they cost)."""
    nav_params: Path | None = None
    """The robot's navigation parameters file (``run --nav-params``), absolute, passed to the
    simulator; None: its default, the original servicebot's configuration."""

    def draws_trajectory(self, *, completed: bool) -> bool:
        """Whether the run draws ``trajectory.png`` after a mission that did or did not
        complete, as :attr:`trajectory` says."""
        return self.trajectory == "always" or (self.trajectory == "failed" and not completed)


def nav_params_record(path: Path | None) -> dict[str, str] | None:
    """What a report says of the navigation parameters a run was given: the file and its
    content's SHA-256 (two runs with the same digest were given the same parameters); None
    for the simulator's default. An unreadable file is said so, not raised."""
    if path is None:
        return None
    try:
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError as error:
        digest = f"unreadable: {error.strerror or error}"
    return {"file": str(path), "sha256": digest}
