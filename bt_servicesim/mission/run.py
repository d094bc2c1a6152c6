"""One mission on a live ROS graph: the simulator process, the executive node, the report.

Split from :mod:`bt_servicesim.run` so the command checks its input before rclpy is imported.
The run waits (in wall time, bounded) for the simulator's clock and referee, ticks the tree on
sim time until it ends, then waits briefly for the referee's last word and writes the report.

Beside the report, :class:`RunRecords` keeps the run's records in the run directory: the tree's
snapshot log (``tree_log.jsonl``) and its final tick (``final_tree.txt``) when the executive is
a behaviour tree, the trajectory picture (``trajectory.png``) and the ROS traffic (``run.mcap``).
They are written on every way out, Ctrl-C included; a record that cannot be written costs a
warning line, never the report.

The executive's node is spun by rclpy's experimental C++ ``EventsExecutor``, which takes a
message for about a quarter of the CPU rclpy's ``SingleThreadedExecutor`` needs: at high speed
the executive's share of the machine is mostly that per-message work. Two things it does
differently are handled here: it runs no timers on ROS time (Kilted), so the executives tick
from the clock itself
(:mod:`bt_servicesim.ros.sim_ticker`); and it catches SIGINT and SIGTERM itself to shut the
context down, so the run puts Python's handlers back: Ctrl-C must reach the run as
``KeyboardInterrupt``, which stops the tree and cancels what is in flight first. While the node
spins, a stop signal is raised between two turns of the executor, never inside a callback
(:meth:`~bt_servicesim.mission.stopping.StopSignals.defer`).
"""

from __future__ import annotations

import gc
import os
import shutil
import signal
import sys
import time
import traceback
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import rclpy
from rclpy.action import ActionClient
from rclpy.client import Client
from rclpy.executors import Executor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from servicesim_competition.srv import NewTask

from bt_servicesim.cli import EXIT_BAD_INPUT, EXIT_COMPLETED, EXIT_FAILED
from bt_servicesim.mission.progress import ProgressView
from bt_servicesim.mission.referee_monitor import REFEREE_TOPIC, RefereeMonitor
from bt_servicesim.mission.report import replay_caveat, write_report
from bt_servicesim.mission.run_records import RunRecords
from bt_servicesim.mission.settings import (
    NAV_PARAMS_NAME,
    REPORT_NAME,
    STARTUP_LIMIT_S,
    RunSettings,
    nav_params_record,
)
from bt_servicesim.mission.shutdown_limit import bound_the_shutdown
from bt_servicesim.mission.simulator_process import SimulatorProcess
from bt_servicesim.mission.stopping import (
    BetweenSpins,
    StopSignals,
    Terminated,
    exit_code_for,
    stop_for,
)
from bt_servicesim.monitor.live_server import LiveServer
from bt_servicesim.records.html_report import HTML_NAME, write_run_report
from bt_servicesim.records.profile import PROFILE_NAME, penalties_explained
from bt_servicesim.records.trajectory import TRAJECTORY_NAME
from bt_servicesim.ros import lockstep
from bt_servicesim.ros.discovery import (
    SIM_CLOCK_PROBE,
    SYSTEM_CLOCK_PROBE,
    await_backend_discovery,
)
from bt_servicesim.ros.environment import end_keeping_the_participant
from bt_servicesim.ros.node import ExecutiveNode, stop_behind
from bt_servicesim.ros.sim_clock import clock_now_ns, sim_now_s
from bt_servicesim.ros.spinning import Spinner
from bt_servicesim.tree.executive import Executive
from bt_servicesim.tree.files import shown_path

if TYPE_CHECKING:  # a run starts Groot2's server only when asked to (run --groot)
    from bt_servicesim.monitor.groot2_server import Groot2Server

TRACEBACK_NAME = "traceback.txt"  # what a tick, a callback or the run raised
DISCOVERY_LIMIT_S = 10.0  # wall seconds the backend may take to discover the readers set up
SERVER_WAIT_LIMIT_S = 30.0  # wall seconds the run waits for every server its executive calls
FINAL_STATE_WAIT_S = 3.0  # wall seconds to wait for the referee's last state
SIM_TIME_BACKSTOP_S = 60.0  # sim seconds past the time limit before the run gives up itself
SIMULATOR_CHECK_PERIOD_S = 0.1  # wall seconds between looks at whether the simulator exited


class MissionRun:
    """Everything one ``python -m bt_servicesim.run`` does once its input is good."""

    def __init__(
        self,
        *,
        settings: RunSettings,
        make_executive: Callable[[Node], Executive],
        extra_sim_args: tuple[str, ...] = (),
        monitor: Groot2Server | None = None,
        live_server: LiveServer | None = None,
        backend: SimulatorProcess | None = None,
        simulator: SimulatorProcess | None = None,
        shutdown_limit_s: float | None = None,
    ) -> None:
        """``monitor``, when given, serves the tree from the moment it exists; the caller
        closes it. ``live_server``: Foxglove's server, open, to forward the run's topics to.

        ``backend``: a simulator someone else started, keeps and has reset for this run (a
        warm episode, :mod:`bt_servicesim.evaluation.warm_worker`): the run watches it but
        never starts or stops it, and is started with :meth:`play` in a process that keeps
        rclpy initialised.

        ``simulator``: the run's own simulator, already started by the command
        (:mod:`bt_servicesim.mission.head_start`); the run stops it as one it started itself.

        ``shutdown_limit_s``: the process ends that many wall seconds after the run's report is
        written, whatever its shut-down still does (:mod:`bt_servicesim.mission.shutdown_limit`);
        only for the ``run`` command's own process. That process also ends at once, its
        participant kept, when its own simulator was killed
        (:func:`~bt_servicesim.ros.environment.end_keeping_the_participant`).
        """
        self.settings = settings
        self.shutdown_limit_s = shutdown_limit_s
        self.extra_sim_args = extra_sim_args
        self.make_executive = make_executive
        self.monitor = monitor
        self.live_server = live_server
        self.owns_simulator = backend is None
        self.simulator = backend or simulator or (
            None if settings.attach else SimulatorProcess.for_run(settings, extra_sim_args))
        self.started_wall = time.monotonic()
        self.failure: str | None = None
        self.traceback: str | None = None
        self.timing: str | None = None
        """How the executive keeps time with the backend, as the report says it: "lockstep" or
        "free running", None until the run has found out (a report written while it starts)."""
        self.lockstep: lockstep.LockstepClient | None = None
        self._left_lockstep = False

    def execute(self, *, noted: StopSignals | None = None) -> int:
        """Run the mission and write the report; the exit status (see :mod:`bt_servicesim.cli`).

        ``noted``: the caller's stop signals, held (only noted) since it made this run, so that
        no moment of the start-up is left without a handler; a signal they noted stops the run
        as one that comes once it is under way.

        A stop signal that came while the run cleaned up (when it is only noted) still makes
        the exit status 128 + its number: the report tells how the mission went, the status
        that the run was stopped, so that a shell loop around it stops too.
        """
        with StopSignals() as stops:
            try:
                self._clear_what_an_earlier_run_left()
                self._keep_the_nav_params()
                write_report(self.settings.out / REPORT_NAME, self._header("running"))
                if noted is not None and noted.first is not None:
                    raise stop_for(noted.first)
                if self.simulator is not None:
                    self.simulator.start()
                rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
                code = self._execute_on(self._node(), stops)
            except (KeyboardInterrupt, Terminated) as stop:  # before the node was up
                code = self._stopped_while_starting(stop, stops)
            finally:
                stops.hold()
                if self.simulator is not None:
                    self.simulator.stop()
                rclpy.try_shutdown()
            return stops.exit_status(code)

    def play(self) -> int:
        """:meth:`execute` for a warm episode: rclpy is up and the backend is the caller's.

        A stop signal that came while the run cleaned up (when it is only noted) still makes
        the exit status 128 + its number, so that the caller stops too.
        """
        with StopSignals() as stops:
            try:
                self._clear_what_an_earlier_run_left()
                self._keep_the_nav_params()
                write_report(self.settings.out / REPORT_NAME, self._header("running"))
                code = self._execute_on(self._node(), stops)
            except (KeyboardInterrupt, Terminated) as stop:  # before the node was up
                return self._stopped_while_starting(stop, stops)
            finally:
                stops.hold()
            return stops.exit_status(code)

    def _clear_what_an_earlier_run_left(self) -> None:
        """In a directory reused with ``--overwrite``: the records a run writes only sometimes
        (what it raised, the picture, which a completed run draws only when asked, the profile)
        and the page written at the end would be taken for this run's. Everything else a run
        writes it writes anew."""
        for name in (TRACEBACK_NAME, TRAJECTORY_NAME, PROFILE_NAME, HTML_NAME, NAV_PARAMS_NAME):
            (self.settings.out / name).unlink(missing_ok=True)

    def _keep_the_nav_params(self) -> None:
        """A copy of the navigation parameters file the run was given, in its records (the
        report names the file and its digest: :func:`nav_params_record`)."""
        if self.settings.nav_params is None:
            return
        try:
            shutil.copyfile(self.settings.nav_params, self.settings.out / NAV_PARAMS_NAME)
        except OSError as error:  # the simulator read it at its start: the run goes on
            print(f"warning: could not keep {self.settings.nav_params} in the run's records: "
                  f"{error.strerror or error}", file=sys.stderr)

    def _node(self) -> ExecutiveNode:
        """The executive's node, on sim time unless the run keeps the system clock.

        Its subscriptions are reliable from the start when the backend is this project's
        simulator and the run will ask it for lockstep (which it always offers), rather than
        from the offer on: the records subscribe before the offer, and a best-effort recording
        subscription cannot be shared with the tree's reliable reader of the same topic, so
        the simulator would send odometry, transforms and RFID to the executive twice.
        """
        node = ExecutiveNode("bt_servicesim_executive",
                             use_sim_time=self.settings.clock == "sim")
        node.reliable_subscriptions = self.reliable_from_the_start()
        return node

    def reliable_from_the_start(self) -> bool:
        """Whether the node's subscriptions are reliable before the lockstep offer: the backend
        is this project's simulator (which always offers lockstep) and the run will join."""
        return self._asks_for_lockstep() and self.simulator is not None

    def _stopped_while_starting(self, stop: BaseException, stops: StopSignals) -> int:
        stops.hold(stop)
        self.failure = f"stopped by {_signal_name(stop)} while starting"
        write_report(self.settings.out / REPORT_NAME,
                     {**self._header("interrupted"), "failure": self.failure})
        return exit_code_for(stop)

    def _execute_on(self, node: ExecutiveNode, stops: StopSignals) -> int:
        executor = events_executor()
        executor.add_node(node)
        monitor = RefereeMonitor(node)
        executive = self.make_executive(node)
        # a failed mission's books are those its last tick saw; a completed one's come after
        # it (the referee books checkpoint 4 a moment after the tree), see _run
        monitor.freeze_when(lambda: executive.finished and not _succeeded(executive))
        tree = getattr(executive, "tree", None)
        if self.monitor is not None and tree is not None:
            self.monitor.watch(tree)
        records = RunRecords(node=node, executive=executive, out=self.settings.out,
                             tree_file=self.settings.tree, live_server=self.live_server,
                             profile=self.settings.profile)
        stops.defer()  # a signal is raised between the executor's turns, not in a callback
        try:
            try:
                code = self._run(node, BetweenSpins(executor, stops), monitor, executive, records)
            except Exception as error:
                if (stop := stop_behind(error)) is not None:
                    raise stop from error  # a signal that landed inside rclpy's C++
                raise
        except (KeyboardInterrupt, Terminated) as stop:
            stops.hold(stop)
            monitor.freeze()
            executive.interrupt()
            self._spin_for(executor, 0.5)
            self.failure = f"interrupted ({_signal_name(stop)})"
            code = exit_code_for(stop)
        except Exception as error:  # a bug of the run's own: still stop cleanly and report
            stops.hold()
            monitor.freeze()
            self.failure = f"the run failed: {type(error).__name__}: {error}"
            self.traceback = "".join(traceback.format_exception(error))
            code = EXIT_FAILED
        stops.hold()
        simulator = self.simulator if self.owns_simulator else None
        if self.owns_simulator:
            self._leave_lockstep()
        if simulator is not None:
            simulator.ask_to_stop()  # it shuts down on the other core while the records close
        try:
            records.finish(title=self._title(monitor), trajectory=self.settings.draws_trajectory(
                completed=code == EXIT_COMPLETED))
        finally:
            if simulator is not None:
                simulator.stop()
        self._finish(monitor, code, executive, profile=records.profile)
        if self.shutdown_limit_s is not None:
            bound_the_shutdown(exit_status=code, limit_s=self.shutdown_limit_s)
        self._leave_lockstep()  # a kept simulator held still until the run's end is written
        executor.shutdown()
        if self.shutdown_limit_s is not None and self.simulator is not None \
                and self.simulator.killed():  # deleting the participant could crash the run
            end_keeping_the_participant(stops.exit_status(code))
        node.destroy_node()
        return code

    def _leave_lockstep(self) -> None:
        if self.lockstep is not None and not self._left_lockstep:
            self.lockstep.leave()
            self._left_lockstep = True

    def _run(self, node: ExecutiveNode, executor: Spinner, monitor: RefereeMonitor,
             executive: Executive, records: RunRecords) -> int:
        refused = self._wait_for_simulator(node, executor)
        if refused is not None:
            return refused
        client = self._lockstep_offer(node, executor)
        executive.setup()
        self._wait_for_servers(node, executor)
        self._await_discovery(node, executor)
        self._say_if_no_referee(node)
        self._join_lockstep(client, executor)
        _keep_out_of_the_collector()
        started_ns = node.get_clock().now().nanoseconds
        shown_from_ns = started_ns if self.settings.clock == "system" else 0  # not the epoch
        executive.start()
        view = ProgressView(headless=self.settings.headless,
                            tree_root=records.tree.root if records.tree else None)
        next_exit_check = time.monotonic()
        looked_at = -1
        while not executive.finished:
            executor.spin_once(timeout_sec=0.05)
            if node.lockstep is not None:  # the clock moves once a period: look once a period
                if node.lockstep.periods == looked_at and time.monotonic() < next_exit_check:
                    continue
                looked_at = node.lockstep.periods
            now_ns = clock_now_ns(node.get_clock())
            records.note_phase(executive.phase())
            view.update(executive=executive, monitor=monitor,
                        sim_time_s=(now_ns - shown_from_ns) / 1e9)
            if node.callback_error is not None and not executive.finished:
                return self._fail(f"a callback raised {node.callback_error}", executive, node)
            if time.monotonic() >= next_exit_check:  # a system call: ten times a wall second
                next_exit_check = time.monotonic() + SIMULATOR_CHECK_PERIOD_S
                if self.simulator is not None and self.simulator.exit_code() is not None:
                    return self._fail(self.simulator.describe_exit(), executive, node)
            if outlived_time_limit(started_ns=started_ns, now_ns=now_ns,
                                   time_limit_s=self.settings.time_limit_s):
                return self._fail("the mission tree outlived its time limit", executive, node)
            if node.lockstep is not None:
                node.lockstep.check_stalled()
        if _succeeded(executive):  # the referee books checkpoint 4 a moment after the tree
            self._spin_until(executor, lambda: monitor.completed, FINAL_STATE_WAIT_S)
        monitor.freeze()  # the report is the referee's books when the mission ended
        view.close(executive=executive, monitor=monitor,
                   sim_time_s=sim_now_s(node.get_clock()) - shown_from_ns / 1e9)
        if not monitor.completed:
            self.failure = "; ".join(
                part for part in (self._ending(executive, node), monitor.unheard()) if part)
        return EXIT_COMPLETED if monitor.completed else EXIT_FAILED

    def _fail(self, failure: str, executive: Executive, node: ExecutiveNode) -> int:
        """End the mission now, for ``failure``; the traceback of a callback's error is kept."""
        self.failure = failure
        self.traceback = self.traceback or node.callback_traceback
        executive.interrupt()
        return EXIT_FAILED

    def _ending(self, executive: Executive, node: ExecutiveNode) -> str:
        """Why a mission that ended did not complete."""
        error = getattr(executive, "error", None)
        if error:
            self.traceback = node.callback_traceback
            return f"the mission tree raised {error}"
        if executive.outcome is not None:
            return f"the mission tree ended with {executive.outcome.name}"
        return "the mission did not end"

    def _wait_for_simulator(self, node: Node, executor: Spinner) -> int | None:
        """Until /clock runs and the referee answers; an exit code if the simulator refused."""
        client: Client[NewTask.Request, NewTask.Response] = node.create_client(
            NewTask, "/servicesim/new_task")
        deadline = time.monotonic() + STARTUP_LIMIT_S
        while not (client.service_is_ready() and node.get_clock().now().nanoseconds > 0):
            code = None if self.simulator is None else self.simulator.exit_code()
            if self.simulator is not None and code is not None:
                self.failure = self.simulator.describe_exit()
                print(f"python -m bt_servicesim.run: error: {self.failure}", file=sys.stderr)
                return EXIT_BAD_INPUT if code == EXIT_BAD_INPUT else EXIT_FAILED
            if time.monotonic() > deadline:
                backend = "the simulator" if self.simulator else "no backend (--attach)"
                self.failure = f"{backend} did not come up within {STARTUP_LIMIT_S:.0f} s"
                return EXIT_FAILED
            executor.spin_once(timeout_sec=0.1)
        node.destroy_client(client)
        return None

    def _lockstep_offer(self, node: ExecutiveNode,
                        executor: Spinner) -> lockstep.LockstepClient | None:
        """A lockstep client if the backend offers lockstep (and the run wants it), else None.

        Decided before the tree sets up: in lockstep every subscription is reliable, so that
        the client can count every message the simulator announces.
        """
        self.timing = "free running"  # until the join
        if not self._asks_for_lockstep():
            print("free running: " + ("--free-running asked for it" if self.settings.free_running
                                      else "the run keeps the system clock (--clock system)"),
                  flush=True)
            return None
        if not lockstep.offered(node, executor, wait_s=self._lockstep_wait_s()):
            print("free running: the backend offers no lockstep", flush=True)
            return None
        node.reliable_subscriptions = True
        return lockstep.LockstepClient(node, name=node.get_fully_qualified_name())

    def _asks_for_lockstep(self) -> bool:
        return not self.settings.free_running and self.settings.clock == "sim"

    def _lockstep_wait_s(self) -> float:
        """How long the offer and the join may take: this project's simulator always offers
        lockstep, so as long as it may take to come up; another backend, briefly."""
        return STARTUP_LIMIT_S if self.simulator is not None else lockstep.OFFER_WAIT_S

    def _join_lockstep(self, client: lockstep.LockstepClient | None,
                       executor: Spinner) -> None:
        if client is None:
            return
        if client.join(executor, wait_s=self._lockstep_wait_s()):
            self.timing, self.lockstep = "lockstep", client
            print("lockstep with the simulator", flush=True)
        else:
            print("free running: the simulator did not answer the lockstep join", flush=True)

    @staticmethod
    def _wait_for_servers(node: Node, executor: Spinner) -> None:
        """Until every service and action the executive set up a client for has a server.

        A client is "ready" once its requests reach the server; the server's answers reach
        the client only once the server has discovered the client's reader in turn, which on a
        busy machine can take seconds. An answer sent before that is lost (a drop-off the
        referee granted looked like a timeout), so the tree starts only when every client is
        ready, and the backend has discovered its readers (:meth:`_await_discovery`).
        Bounded: a server that never comes is the tree's to wait for and report.
        """
        def every_server_ready() -> bool:
            actions = [w for w in node.waitables if isinstance(w, ActionClient)]
            return (all(client.service_is_ready() for client in node.clients)
                    and all(action.server_is_ready() for action in actions))

        MissionRun._spin_until(executor, every_server_ready, SERVER_WAIT_LIMIT_S)

    def _await_discovery(self, node: Node, executor: Spinner) -> None:
        """Until the backend has discovered every reader the executive set up (a probe on
        /clock, or /tf on the system clock, :mod:`bt_servicesim.ros.discovery`); bounded,
        then said and gone on with."""
        probe = SYSTEM_CLOCK_PROBE if self.settings.clock == "system" else SIM_CLOCK_PROBE
        if not await_backend_discovery(node, executor, limit_s=DISCOVERY_LIMIT_S, probe=probe):
            print(f"the backend's {probe[1]} did not reach a new reader within "
                  f"{DISCOVERY_LIMIT_S:.0f} s: its first answers may be lost", flush=True)

    @staticmethod
    def _say_if_no_referee(node: Node) -> None:
        """Once the backend is discovered: whether it keeps the referee's books (our extension)."""
        if node.count_publishers(REFEREE_TOPIC) == 0:
            print(f"the backend publishes no referee state ({REFEREE_TOPIC}): the report "
                  "cannot say what the referee counted", flush=True)

    def _title(self, monitor: RefereeMonitor) -> str:
        fields = monitor.report_fields()
        world = self.settings.world.stem if self.settings.world else "ServiceSim office"
        seed = "shipped task" if self.settings.seed is None else f"seed {self.settings.seed}"
        outcome = "completed" if fields["completed"] else "not completed"
        done = sum(1 for checkpoint in fields["checkpoints"] if checkpoint["done"])
        return (f"{world}, {seed}, {self.settings.executive} executive: {outcome}, "
                f"{done}/4 checkpoints, score {fields['score']:.1f}, "
                f"{fields['sim_time_s']:.0f} s sim")

    def _header(self, status: str) -> dict[str, Any]:
        """What the report says of the run itself, from its start."""
        return {
            "status": status,
            "run_id": self.settings.run_id,
            "seed": self.settings.seed,
            "world": str(self.settings.world) if self.settings.world else "default",
            "executive": self.settings.executive,
            "ros_domain_id": int(os.environ.get("ROS_DOMAIN_ID", "0") or 0),
            "attached": self.settings.attach,
            "clock": self.settings.clock,
            "timing": self.timing,
            "nav_params": nav_params_record(self.settings.nav_params),
            "reproduce": reproduce_command(self.settings, self.extra_sim_args),
        }

    def _finish(self, monitor: RefereeMonitor, code: int, executive: Executive, *,
                profile: dict[str, Any] | None = None) -> None:
        fields = monitor.report_fields()
        status = ("completed" if fields["completed"] else
                  "interrupted" if code >= 128 else "failed")
        if self.traceback:
            (self.settings.out / TRACEBACK_NAME).write_text(self.traceback)
        report: dict[str, Any] = {
            **self._header(status),
            **fields,
            "wall_time_s": round(time.monotonic() - self.started_wall, 3),
            "task_timing": monitor.task_timing(),
            "exit_code": code,
            "failure": self.failure,
            # where a failed run stood: the phase and the running behaviour with its feedback
            "last_activity": (f"{executive.phase()}: {executive.activity()}"
                              if self.failure else None),
            "traceback": TRACEBACK_NAME if self.traceback else None,
            "ticks": getattr(executive, "ticks", None),
            "lockstep_stalls": self.lockstep.stalls if self.lockstep else None,
            "lockstep_dropped": self._lockstep_dropped(),
            **penalties_explained(profile),
        }
        write_report(self.settings.out / REPORT_NAME, report)
        try:
            write_run_report(self.settings.out, report)
        except Exception as error:  # the page is not worth losing the run's end for
            print(f"warning: could not write {self.settings.out / HTML_NAME}: {error}",
                  file=sys.stderr)
        verdict = "completed" if report["completed"] else f"failed ({self.failure})"
        print(f"mission {verdict}: score {report['score']:.1f}, "
              f"{report['sim_time_s']:.1f} s sim, {report['wall_time_s']:.1f} s wall; "
              f"report: {self.settings.out / REPORT_NAME}{_replay_warning(report)}")

    def _lockstep_dropped(self) -> dict[str, Any] | None:
        """Where the simulator went on without this run (it then ran free and will not
        replay): the first period it announced without waiting, and that period's sim time."""
        dropped = self.lockstep.dropped_at if self.lockstep else None
        if dropped is None:
            return None
        return {"period": int(dropped.period),
                "sim_time_s": dropped.sim_time.sec + dropped.sim_time.nanosec / 1e9}

    @staticmethod
    def _spin_for(executor: Spinner, seconds: float) -> None:
        MissionRun._spin_until(executor, lambda: False, seconds)

    @staticmethod
    def _spin_until(executor: Spinner, done: Callable[[], bool], seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while not done() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)


def _replay_warning(report: dict[str, Any]) -> str:
    """What the run's last line adds when the mission may not replay, though it joined lockstep."""
    caveat = replay_caveat(report) if report.get("timing") == "lockstep" else None
    return f" (may not replay: {caveat})" if caveat else ""


def outlived_time_limit(*, started_ns: int, now_ns: int, time_limit_s: float) -> bool:
    """Whether a mission that started at sim time ``started_ns`` has run
    :data:`SIM_TIME_BACKSTOP_S` past its time limit by ``now_ns``: the run's backstop, should
    the tree not end itself. Counted from the start, as the tree's own limits are: a backend's
    clock need not start at zero (Gazebo's runs from its launch, a robot's is system time)."""
    return now_ns - started_ns > int((time_limit_s + SIM_TIME_BACKSTOP_S) * 1e9)


def reproduce_command(settings: RunSettings, sim_args: tuple[str, ...]) -> str:
    """The run command that plays this run's mission again: in lockstep, exactly."""
    words = ["python -m bt_servicesim.run"]
    if settings.seed is not None:
        words.append(f"--seed {settings.seed}")
    if settings.world is not None:
        words.append(f"--world {settings.world}")
    words += [f"--tree {shown_path(settings.tree)}", f"--executive {settings.executive}",
              f"--speed {settings.speed:g}", f"--time-limit {settings.time_limit_s:g}"]
    if settings.nav_params is not None:
        words.append(f"--nav-params {shown_path(settings.nav_params)}")
    words += [f"--sim-arg={argument}" for argument in sim_args]
    if settings.free_running:
        words.append("--free-running")
    if settings.clock != "sim":
        words.append(f"--attach --clock {settings.clock}")
    return " ".join(words)


def events_executor() -> Executor:
    """rclpy's ``EventsExecutor``, leaving the process's signal handlers as they were."""
    handlers = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    executor = EventsExecutor()
    for number, handler in handlers.items():
        signal.signal(number, handler)
    return executor


def _keep_out_of_the_collector() -> None:
    """What lives when the mission starts lives for it: the cyclic garbage collector stops
    walking it (the simulator, profiled, spent about 5 % of its CPU collecting). A warm
    worker's last mission is unfrozen and collected first, so that nothing of it is kept."""
    gc.unfreeze()
    gc.collect()
    gc.freeze()

def _succeeded(executive: Executive) -> bool:
    return executive.outcome is not None and executive.outcome.name == "SUCCESS"


def _signal_name(stop: BaseException) -> str:
    return "SIGINT" if isinstance(stop, KeyboardInterrupt) else str(stop)
