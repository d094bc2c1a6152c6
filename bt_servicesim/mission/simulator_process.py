"""The simulator as a child process, reached only over ROS.

The executive never imports the simulator: the run command starts it as its own process
(``python -m servicesim_sim``), so it can be swapped for Gazebo + Nav2 by starting something
else. Its output goes to a log file in the run directory; when it refuses its input (a broken
world file, say) its last error line is what the user sees, and when it dies the run says how.

A run must know that the simulator took its input (the world, ``--sim-arg``) before it takes
its run directory: a refused world must leave an earlier run's files as they were, and a fresh
directory empty. :meth:`SimulatorProcess.start` with ``announce_checks`` hands the simulator the
write end of a pipe (``--checked-fd FD``); the simulator writes one line to it once its
arguments and its world are checked, before it brings up ROS, and the run waits for that line
(:meth:`SimulatorProcess.input_refusal`) while it has loaded its tree meanwhile. A simulator that
refuses its input exits with the pipe unwritten, and its exit is the refusal.

The simulator never outlives the run. The run stops it on every way out it sees; for the one
it cannot see, a SIGKILL of the run, the simulator is started with Linux's parent-death signal
(``PR_SET_PDEATHSIG``): the kernel sends it SIGTERM the moment the run is gone.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import subprocess
import sys
from pathlib import Path

from bt_servicesim.mission.settings import STARTUP_LIMIT_S, RunSettings
from bt_servicesim.mission.stopping import parent_death_signal

SIMULATOR_MODULE = "servicesim_sim"
CHECKED_FD_OPTION = "--checked-fd"
"""The simulator's option naming the pipe it writes to once its input is checked."""
EXIT_WAIT_S = 5.0
"""Wall seconds a simulator that closed its pipe unwritten is given to exit."""
SIMULATOR_LOG_NAME = "sim.log"
"""The simulator's output, in the run directory."""


def simulator_arguments(settings: RunSettings, sim_args: tuple[str, ...]) -> tuple[str, ...]:
    """The simulator's arguments for this run but the world, seed and speed: the hold for the
    lockstep client (unless the run runs free), the robot's navigation parameters file if the
    run was given one, and the run's ``--sim-arg`` ones."""
    await_lockstep = () if settings.free_running else (
        "--await-lockstep", f"{STARTUP_LIMIT_S:.0f}")
    nav_params = () if settings.nav_params is None else ("--nav-params", str(settings.nav_params))
    return (*await_lockstep, *nav_params, *sim_args)


class SimulatorProcess:
    """Start, watch and stop one simulator process."""

    def __init__(
        self,
        *,
        world: Path | None,
        seed: int | None,
        speed: float,
        log_path: Path,
        extra_args: tuple[str, ...] = (),
    ) -> None:
        self.command = [sys.executable, "-m", SIMULATOR_MODULE, "--speed", repr(speed)]
        if world is not None:
            self.command += ["--world", str(world)]
        if seed is not None:
            self.command += ["--seed", str(seed)]
        self.command += list(extra_args)
        self.log_path = log_path
        self._process: subprocess.Popen[bytes] | None = None
        self._asked = False  # SIGINT sent by ask_to_stop
        self._checks: int | None = None  # the read end of the simulator's checked-fd pipe

    @classmethod
    def for_run(cls, settings: RunSettings, sim_args: tuple[str, ...], *,
                log_path: Path | None = None) -> SimulatorProcess:
        """The simulator a run with ``settings`` starts (log: the run directory's
        ``sim.log`` unless ``log_path`` says otherwise)."""
        return cls(world=settings.world, seed=settings.seed, speed=settings.speed,
                   log_path=log_path or settings.out / SIMULATOR_LOG_NAME,
                   extra_args=simulator_arguments(settings, sim_args))

    @property
    def started(self) -> bool:
        return self._process is not None

    def rename_log(self, path: Path) -> None:
        """Give the log another name; the process goes on writing to it."""
        os.replace(self.log_path, path)
        self.log_path = path

    def start(self, *, announce_checks: bool = False) -> None:
        """Start the process (once: a started simulator is not started again); with
        ``announce_checks`` it says when it has checked its input (:meth:`input_refusal`)."""
        if self._process is not None:
            return
        parent = os.getpid()
        command = self.command
        passed: tuple[int, ...] = ()
        if announce_checks:
            self._checks, write_end = os.pipe()
            command, passed = [*self.command, CHECKED_FD_OPTION, str(write_end)], (write_end,)
        try:
            with self.log_path.open("wb") as log:
                self._process = subprocess.Popen(
                    command, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                    env=os.environ.copy(), start_new_session=True, pass_fds=passed,
                    preexec_fn=parent_death_signal(parent),
                )
        finally:
            for write_end in passed:  # the simulator's now: its exit closes the pipe
                os.close(write_end)

    def input_refusal(self, *, timeout_s: float) -> str | None:
        """How the simulator ended if it refused its input (:meth:`describe_exit`), or None once
        it said its input is good, or after ``timeout_s`` (the run's own wait for it then
        decides). Only for a simulator started with ``announce_checks``."""
        if self._checks is None or self._process is None:
            return None
        try:
            ready, _, _ = select.select([self._checks], [], [], timeout_s)
            said = os.read(self._checks, 64) if ready else b"checked"
        finally:
            os.close(self._checks)
            self._checks = None
        if said:
            return None
        with contextlib.suppress(subprocess.TimeoutExpired):  # closed as it exits
            self._process.wait(timeout=EXIT_WAIT_S)
        return self.describe_exit()

    @property
    def pid(self) -> int | None:
        return None if self._process is None else self._process.pid

    def describe_exit(self) -> str:
        """How the simulator ended, for the report: the signal that killed it, or its code and
        last line."""
        code = self.exit_code()
        if code is None:
            return "the simulator is still running"
        if code < 0:
            return f"the simulator was killed by {signal.Signals(-code).name}"
        stopped_by = _signal_name(code - 128)
        if stopped_by is not None:  # it caught the signal and ended as commands do: 128 + N
            return f"the simulator was stopped by {stopped_by} (exit status {code})"
        return f"the simulator exited with code {code}: {self.last_error()}"

    def exit_code(self) -> int | None:
        """None while it runs."""
        return None if self._process is None else self._process.poll()

    def killed(self) -> bool:
        """Whether it ended by a signal it did not handle (SIGKILL, a crash): it then ended
        without deleting its DDS participant, whatever it was doing with its peers."""
        code = self.exit_code()
        return code is not None and code < 0

    def last_error(self) -> str:
        """The simulator's last non-empty output line (its one-line error when it refused)."""
        try:
            lines = self.log_path.read_text(errors="replace").strip().splitlines()
        except OSError:
            return "no simulator output"
        return lines[-1].strip() if lines else "no simulator output"

    def ask_to_stop(self) -> None:
        """SIGINT, without waiting: the simulator shuts down while the caller finishes its own
        work, then :meth:`stop` waits for it."""
        if self._process is not None and self._process.poll() is None:
            self._process.send_signal(signal.SIGINT)
            self._asked = True

    def stop(self, *, grace_s: float = 5.0) -> None:
        """SIGINT (unless :meth:`ask_to_stop` sent it), then SIGKILL if it does not exit within
        ``grace_s``."""
        if self._checks is not None:  # never asked whether its input was good
            os.close(self._checks)
            self._checks = None
        if self._process is None or self._process.poll() is not None:
            return
        if not self._asked:
            self._process.send_signal(signal.SIGINT)
        try:
            self._process.wait(timeout=grace_s)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()


def _signal_name(number: int) -> str | None:
    """``SIGTERM`` for 15; None for a number that is no signal."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return None
