"""The run's own simulator, started before the executive's heavy imports.

A run has two processes to bring up: the simulator (its imports, the world, the first
episode: about 1.3 s here) and the executive (rclpy, the behaviours and their libraries, the
tree: about 1.2 s). Started one after the other they cost the sum; the machine has a core for
each. So the run command checks what it can check cheaply (the arguments, the tree file's
structure), starts the simulator, and only then imports the behaviours and loads the tree
(:func:`bt_servicesim.run.main`).

The input is not all checked when the simulator starts: the tree's nodes are checked while it
comes up, and the simulator checks its own (the world file, ``--sim-arg``) meanwhile, saying so
down a pipe before it brings up ROS (:meth:`HeadStart.simulator_refusal`). The run hands the
directory over only once both passed. A refused tree or world must still leave nothing behind,
so :class:`HeadStart` keeps track of what it made -- the run directory and its parents, the
simulator's log, the process, the claimed ROS domain -- and :meth:`HeadStart.abandon` takes all
of it back: the one-line error is then the only trace. Until the checks pass the log is written
under a temporary name, so that an earlier run's files in a directory reused with
``--overwrite`` are kept as they were, its ``sim.log`` too.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from types import TracebackType

from bt_servicesim.cli import UsageError
from bt_servicesim.mission.settings import STARTUP_LIMIT_S, RunSettings
from bt_servicesim.mission.simulator_process import SIMULATOR_LOG_NAME, SimulatorProcess
from bt_servicesim.ros.domain import DomainClaim, claim_domain
from bt_servicesim.ros.environment import apply_localhost_defaults

__all__ = ["HeadStart"]

STARTING_LOG_NAME = f"{SIMULATOR_LOG_NAME}.starting"
"""The simulator's log while the rest of the input is checked."""


class HeadStart:
    """The run directory, a ROS domain of the run's own and its simulator, made up front.

    Use as a context manager around the rest of the run: leaving it stops a simulator that was
    never handed on (:meth:`hand_over`) and releases the domain.
    """

    def __init__(self, settings: RunSettings, *, sim_args: tuple[str, ...]) -> None:
        self.settings = settings
        self.sim_args = sim_args
        self.simulator: SimulatorProcess | None = None
        self._claim: DomainClaim | None = None
        self._made: list[Path] = []
        self._handed_over = False

    def begin(self, *, users_domain: int | None) -> None:
        """Make the run directory; unless the run attaches, claim a domain (not the user's:
        the run only ever talks to its own simulator) and start the simulator in it.

        Raises UsageError (the directory) or NoFreeDomainError; what was made by then stays
        for :meth:`abandon`.
        """
        self._make_directory(self.settings.out)
        apply_localhost_defaults()
        if self.settings.attach:
            return
        self._claim = claim_domain(avoid=users_domain)
        os.environ["ROS_DOMAIN_ID"] = str(self._claim.domain_id)
        self.simulator = SimulatorProcess.for_run(
            self.settings, self.sim_args, log_path=self.settings.out / STARTING_LOG_NAME)
        self.simulator.start(announce_checks=True)

    def simulator_refusal(self) -> tuple[int, str] | None:
        """The simulator's exit status and how it ended, if it refused its input (a world
        file, a ``--sim-arg``); None once it has checked its input, or if the run started none.
        Waits for its word up to the run's start-up limit."""
        if self.simulator is None:
            return None
        refusal = self.simulator.input_refusal(timeout_s=STARTUP_LIMIT_S)
        code = self.simulator.exit_code()
        return None if refusal is None or code is None else (code, refusal)

    def hand_over(self) -> SimulatorProcess | None:
        """The input is good: the log takes its own name, and the run owns the simulator."""
        self._handed_over = True
        if self.simulator is not None:
            self.simulator.rename_log(self.settings.out / SIMULATOR_LOG_NAME)
        return self.simulator

    def abandon(self) -> None:
        """Take back everything :meth:`begin` made: the simulator, its log, the directories."""
        if self.simulator is not None:
            self.simulator.stop()
            with contextlib.suppress(FileNotFoundError):
                self.simulator.log_path.unlink()
            self.simulator = None
        for directory in reversed(self._made):
            with contextlib.suppress(OSError):  # not empty: somebody else's now
                directory.rmdir()
        self._made = []
        self._release()

    def __enter__(self) -> HeadStart:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if not self._handed_over:
            self.abandon()
        self._release()

    def _make_directory(self, path: Path) -> None:
        """Make ``path`` and its missing parents; :class:`UsageError` naming ``--out`` if it
        cannot be made (what was made by then stays for :meth:`abandon`)."""
        missing = [parent for parent in (path, *path.parents) if not parent.exists()]
        self._made = list(reversed(missing))  # outermost first
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise UsageError(f"--out {path}: cannot make the run directory there "
                             f"({error.strerror or error})") from None

    def _release(self) -> None:
        if self._claim is not None:
            self._claim.release()
            self._claim = None
