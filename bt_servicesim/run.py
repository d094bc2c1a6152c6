"""``python -m bt_servicesim.run``: one mission, simulator and executive, start to report.

It starts the simulator in its own process (real DDS between them), runs the mission tree on
sim time, shows progress in the terminal, stops both cleanly on Ctrl-C and writes
``report.json`` with the score, checkpoints and penalties *as the referee counted them*, and
``report.html``, the same as a page with the mission's timeline
(:mod:`bt_servicesim.records.html_report`).

With ``--groot`` it serves the live tree to Groot2 and ``btview`` (:mod:`bt_servicesim.monitor`).

Exit status: 0 when the referee counted all four checkpoints, 1 when the mission failed,
2 on bad input (one line on stderr naming the problem), 130 on Ctrl-C.
"""

from __future__ import annotations

import argparse
import ipaddress
import math
import os
import signal
import sys
import uuid
from collections.abc import Callable, Sequence
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from bt_servicesim.cli import (
    EXIT_BAD_INPUT,
    EXIT_FAILED,
    OneLineArgumentParser,
    UsageError,
    error_line,
)
from bt_servicesim.mission.head_start import HeadStart
from bt_servicesim.mission.settings import (
    CLOCKS,
    DEFAULT_SPEED,
    DEFAULT_TIME_LIMIT_S,
    EXECUTIVES,
    REPORT_NAME,
    TRAJECTORY_POLICIES,
    RunSettings,
)
from bt_servicesim.mission.shutdown_limit import SHUTDOWN_LIMIT_S
from bt_servicesim.mission.stopping import StopSignals, Terminated, exit_code_for, signal_of
from bt_servicesim.monitor.groot2_protocol import DEFAULT_HOST, DEFAULT_PORT
from bt_servicesim.monitor.live_server import DEFAULT_PORT as FOXGLOVE_PORT
from bt_servicesim.monitor.live_server import (
    LiveAddress,
    LiveServer,
    LiveServerError,
    describe,
    open_live_server,
)
from bt_servicesim.ros.domain import NoFreeDomainError
from bt_servicesim.tree.files import DEFAULT_TREE, SERVICEBOT, nav_params_for

if TYPE_CHECKING:
    from rclpy.node import Node

    from bt_servicesim.mission.run import MissionRun
    from bt_servicesim.monitor.groot2_server import Groot2Server
    from bt_servicesim.tree.executive import Executive

PROG = "python -m bt_servicesim.run"
ExecutiveFactory = Callable[["Node"], "Executive"]



def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(
        prog=PROG,
        description="Run the ServiceSim mission: simulator + behaviour-tree executive.",
    )
    parser.add_argument("--world", type=Path, help="world file (default: the ServiceSim office)")
    parser.add_argument("--seed", type=int, help="randomise the task with this seed "
                        "(default: the world's shipped task)")
    parser.add_argument("--speed", type=float,
                        help="sim speed: 1 = real time, 0 = as fast as possible (default 10)")
    parser.add_argument("--tree", type=Path, default=DEFAULT_TREE, help="mission tree XML")
    parser.add_argument("--out", help="run directory (default runs/<timestamp>/); "
                        "an earlier run's is kept unless --overwrite")
    parser.add_argument("--overwrite", action="store_true",
                        help="let --out name a directory that holds an earlier run's report")
    parser.add_argument("--time-limit", type=float, default=DEFAULT_TIME_LIMIT_S,
                        help="mission time limit in sim seconds (default 900)")
    parser.add_argument("--headless", action="store_true",
                        help="plain log lines instead of a live view")
    parser.add_argument("--executive", choices=EXECUTIVES, default="bt",
                        help="which executive runs the mission: the behaviour tree (bt) or "
                        "the seed's state machine (baseline)")
    parser.add_argument("--sim-arg", action="append", default=[], metavar="ARG",
                        help="extra argument passed to the simulator (repeatable)")
    parser.add_argument("--nav-params", metavar="FILE",
                        help="the robot's navigation parameters, a Nav2 parameters file the "
                        "simulator's navigation takes, or 'servicebot' for the original "
                        "servicebot's configuration (default: the shipped tree's "
                        "trees/servicesim_nav2_params.yaml for bt, servicebot for baseline; "
                        "docs/reference/navigation.md)")
    parser.add_argument("--attach", action="store_true",
                        help="start no simulator: run against the backend already on this "
                        "shell's ROS_DOMAIN_ID (a simulator started alone, Gazebo, a robot)")
    parser.add_argument("--groot", nargs="?", const=str(DEFAULT_PORT), metavar="[ADDR:]PORT",
                        help="serve the live tree to Groot2 and btview (BehaviorTree.CPP v4's "
                        f"monitor protocol) on {DEFAULT_HOST}:{DEFAULT_PORT}, on PORT, or on "
                        "ADDR:PORT (an IPv4 address; 0.0.0.0 for every interface)")
    parser.add_argument("--foxglove", nargs="?", const=str(FOXGLOVE_PORT), metavar="[ADDR:]PORT",
                        help="serve the live topics to Foxglove over WebSocket on "
                        f"127.0.0.1:PORT (default {FOXGLOVE_PORT}), or on ADDR:PORT")
    parser.add_argument("--clock", choices=CLOCKS, default="sim",
                        help="keep time by the backend's /clock (sim, the default: a simulator, "
                        "Gazebo) or by the system clock (system: a real robot, which publishes "
                        "no /clock; only with --attach)")
    parser.add_argument("--free-running", action="store_true",
                        help="do not join the simulator's lockstep even where it offers it: "
                        "the tree ticks on /clock as it would on Gazebo (runs may not replay)")
    parser.add_argument("--trajectory", choices=TRAJECTORY_POLICIES, default="always",
                        help="draw trajectory.png after every run (always, the default), only "
                        "when the mission did not complete (failed), or not at all (never: "
                        "about a CPU second less a run); python -m "
                        "bt_servicesim.trajectory DIR draws any run's later from its run.mcap")
    parser.add_argument("--no-profile", action="store_false", dest="profile",
                        help="write no profile.json and count no node's ticks (to measure "
                             "what they cost: benchmarks/profile_cost.py)")
    parser.add_argument("--run-id", default=None,
                        help="an id the report carries, for tools that start runs "
                        "(default: a random one)")
    return parser


#: Simulator options the run sets itself; --sim-arg may not set them behind its back.
RUN_OWNED_SIM_OPTIONS = ("--speed", "--seed", "--world", "--await-lockstep", "--nav-params")
MAX_TIME_LIMIT_S = 1e6
"""The longest mission time limit, in sim seconds (eleven days): longer is a typo."""


def settings_from(args: argparse.Namespace) -> RunSettings:
    """Check every argument before anything starts."""
    _check_backend(args)
    if args.seed is not None and args.seed < 0:
        raise UsageError(f"--seed {args.seed}: must be 0 or more")
    speed = DEFAULT_SPEED if args.speed is None else args.speed
    if not (math.isfinite(speed) and speed >= 0.0):
        raise UsageError(f"--speed {speed}: must be a finite number, 0 or more")
    if not (math.isfinite(args.time_limit) and 0.0 < args.time_limit <= MAX_TIME_LIMIT_S):
        raise UsageError(f"--time-limit {args.time_limit}: must be more than 0 and at most "
                         f"{MAX_TIME_LIMIT_S:.0f} sim seconds")
    groot = None if args.groot is None else groot_address(args.groot)
    if args.clock == "system" and not args.attach:
        raise UsageError("--clock system: only with --attach; the run's own simulator keeps "
                         "sim time")
    if groot is not None and args.executive != "bt":
        raise UsageError(f"--groot shows a behaviour tree; the {args.executive} executive has none")
    if args.executive != "bt" and args.tree != DEFAULT_TREE:
        raise UsageError(f"--tree {args.tree}: only the bt executive plays a tree")
    if args.executive == "bt":
        _check_tree_structure(args.tree)
    return RunSettings(
        world=args.world, seed=args.seed, speed=speed, tree=args.tree,
        out=_run_directory(args.out, overwrite=args.overwrite),
        time_limit_s=args.time_limit, headless=args.headless, executive=args.executive,
        run_id=args.run_id or uuid.uuid4().hex, attach=args.attach, groot=groot,
        foxglove=_live_address(args.foxglove), free_running=args.free_running,
        trajectory=args.trajectory, clock=args.clock, profile=args.profile,
        nav_params=(None if args.attach else nav_params_for(args.executive, args.nav_params)),
    )


def _check_tree_structure(tree: Path) -> None:
    """The tree file's structure, which needs no behaviour imported (its nodes are checked
    while the simulator comes up, :func:`main`)."""
    from bt_servicesim.tree.structure import MissionTreeError, checked_tree_file

    try:
        checked_tree_file(tree)
    except MissionTreeError as error:
        raise UsageError(str(error)) from None


def _live_address(argument: str | None) -> LiveAddress | None:
    if argument is None:
        return None
    try:
        return LiveAddress.parse(argument)
    except ValueError as error:
        raise UsageError(f"--foxglove {error}") from None


def groot_address(argument: str) -> tuple[str, int]:
    """``--groot``'s ``PORT`` or ``ADDR:PORT`` as (IPv4 address, port); ``localhost`` is
    127.0.0.1."""
    host, _, port_text = argument.rpartition(":")
    host = host or DEFAULT_HOST
    if host == "localhost":
        host = "127.0.0.1"
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        address = None
    if not isinstance(address, ipaddress.IPv4Address):
        raise UsageError(f"--groot {argument}: {host} is not an IPv4 address")
    if not (port_text.isdigit() and 1 <= int(port_text) <= 65535):
        raise UsageError(f"--groot {argument}: the port must be a number from 1 to 65535")
    return host, int(port_text)


def _check_backend(args: argparse.Namespace) -> None:
    """The simulator's options: a world that exists, none of them with --attach."""
    nav_params = None if args.nav_params in (None, SERVICEBOT) else Path(args.nav_params)
    for flag, path, kind in (("--world", args.world, "a world file"),
                             ("--nav-params", nav_params, "a parameters file")):
        if path is not None and not path.is_file():
            what = f"is a directory, not {kind}" if path.is_dir() else "no such file"
            raise UsageError(f"{flag} {path}: {what}")
    for arg in args.sim_arg:
        option = arg.split("=", 1)[0]
        if option in RUN_OWNED_SIM_OPTIONS:
            raise UsageError(f"--sim-arg {arg}: the run sets {option} itself; use run's "
                             f"{option}")
    if args.attach:
        given = [flag for flag, value in (("--world", args.world), ("--seed", args.seed),
                                          ("--speed", args.speed), ("--sim-arg", args.sim_arg),
                                          ("--nav-params", args.nav_params))
                 if value not in (None, [])]
        if given:
            raise UsageError(f"--attach starts no simulator: {', '.join(given)} would not "
                             "reach the backend")


def _run_directory(argument: str | None, *, overwrite: bool) -> Path:
    """``--out`` checked, or a new timestamped directory under runs/."""
    if argument is None:
        return Path("runs") / datetime.now().strftime("%Y%m%d-%H%M%S-%f")
    if not argument.strip():
        raise UsageError("--out: an empty path; name a run directory")
    out = Path(argument)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out}: exists and is not a directory")
    existing = next(parent for parent in out.parents if parent.exists())
    if not existing.is_dir():
        raise UsageError(f"--out {out}: {existing} is not a directory to make it in")
    if (out / REPORT_NAME).exists() and not overwrite:
        raise UsageError(f"--out {out}: holds an earlier run (its {REPORT_NAME}); "
                         "choose another directory or add --overwrite")
    return out


def main(argv: Sequence[str] | None = None, *, shutdown_limit_s: float | None = None) -> int:
    """Check the input, start the simulator, then load the tree while it comes up.

    What needs only the arguments is checked first, the tree file's structure too. The
    simulator then gets a head start (:mod:`bt_servicesim.mission.head_start`): the tree's
    nodes need every behaviour and its libraries imported, and the simulator takes longer to
    come up. A tree, a monitor port or a Foxglove address refused after that takes the head
    start back, and so does a world or ``--sim-arg`` the simulator refused (the run waits for
    its word on them before it takes the directory), so bad input still leaves nothing but its
    one-line error. One :class:`StopSignals` covers the whole start-up, up to the run's own: a
    stop signal at any moment of it ends the run in one line.

    ``shutdown_limit_s``: the command's own process passes it, so that the process ends that
    many seconds after the report whatever its shut-down still does
    (:mod:`bt_servicesim.mission.shutdown_limit`); a caller in whose process the run plays
    leaves it out.
    """
    args = build_parser().parse_args(argv)
    try:
        settings = settings_from(args)
    except UsageError as error:
        return error_line(PROG, error)
    with StopSignals() as stops, HeadStart(settings, sim_args=tuple(args.sim_arg)) as head_start:
        started = _start(settings, head_start, args=args, stops=stops,
                         shutdown_limit_s=shutdown_limit_s)
        if isinstance(started, int):
            return started
        mission, monitor, live = started
        try:
            if live is not None:
                print(describe(live), flush=True)
            return stops.exit_status(mission.execute(noted=stops))
        finally:
            _close_servers(monitor, live)


def _start(settings: RunSettings, head_start: HeadStart, *, args: argparse.Namespace,
           stops: StopSignals, shutdown_limit_s: float | None
           ) -> tuple[MissionRun, Groot2Server | None, LiveServer | None] | int:
    """The head start, then the tree, the servers and the run, which takes the simulator over;
    an exit status if any was refused or a stop signal came meanwhile (everything taken back).

    Once the run is made, or the start given up, ``stops`` only notes a stop signal (the run
    raises one it noted in its own handlers' scope): no signal lands between the two, or cuts
    the clean-up short.
    """
    monitor: Groot2Server | None = None
    live: LiveServer | None = None
    try:
        head_start.begin(users_domain=_users_domain())
        from bt_servicesim.tree.structure import MissionTreeError

        try:
            make_executive = executive_factory(settings)
            monitor = _open_monitor(settings)
            live = _open_live_server(settings)
        except (MissionTreeError, LiveServerError) as error:
            raise UsageError(str(error)) from error
        from bt_servicesim.mission.run import MissionRun  # rclpy once the tree is good

        _check_simulator(head_start)  # meanwhile the simulator checked the world

        mission = MissionRun(
            settings=settings, make_executive=make_executive, extra_sim_args=tuple(args.sim_arg),
            monitor=monitor, live_server=live, simulator=head_start.hand_over(),
            shutdown_limit_s=shutdown_limit_s)
        stops.hold()
        return mission, monitor, live
    except (UsageError, OSError, NoFreeDomainError, SimulatorDiedError) as error:
        stops.hold()
        _close_servers(monitor, live)
        head_start.abandon()
        status = error_line(PROG, error)
        return EXIT_FAILED if isinstance(error, SimulatorDiedError) else status
    except (KeyboardInterrupt, Terminated) as stop:
        stops.hold(stop)
        _close_servers(monitor, live)
        head_start.abandon()
        print(f"{PROG}: stopped by {signal.Signals(signal_of(stop)).name} while starting",
              file=sys.stderr)
        return exit_code_for(stop)


class SimulatorDiedError(RuntimeError):
    """The run's simulator ended before it had checked its input, not refusing it."""


def _check_simulator(head_start: HeadStart) -> None:
    """Wait for the simulator's word on its input: :class:`UsageError` if it refused it (its
    exit status 2), :class:`SimulatorDiedError` if it ended otherwise."""
    refusal = head_start.simulator_refusal()
    if refusal is not None:
        code, how = refusal
        raise (UsageError if code == EXIT_BAD_INPUT else SimulatorDiedError)(how)


def _close_servers(monitor: Groot2Server | None, live: LiveServer | None) -> None:
    if monitor is not None:
        monitor.close()
    if live is not None:
        live.stop()


def _open_monitor(settings: RunSettings) -> Groot2Server | None:
    """The Groot2 server, listening before the run goes on, if the run was asked for one."""
    if settings.groot is None:
        return None
    from bt_servicesim.monitor.groot2_server import Groot2Server

    host, port = settings.groot
    return Groot2Server(host=host, port=port)


def _open_live_server(settings: RunSettings) -> LiveServer | None:
    """The Foxglove server with a channel for every recorded topic, listening, if the run was
    asked for one."""
    if settings.foxglove is None:
        return None
    from bt_servicesim.monitor.foxglove_bridge import live_channels

    return open_live_server(settings.foxglove, channels=live_channels())


def _users_domain() -> int | None:
    """The shell's ROS_DOMAIN_ID, which is the user's own graph, if it is a number."""
    value = os.environ.get("ROS_DOMAIN_ID", "")
    return int(value) if value.isdigit() else None


def executive_factory(settings: RunSettings) -> ExecutiveFactory:
    """Check what the chosen executive needs (the tree file) and say how to make it on a node.

    rclpy is imported only when the factory is called, after every input has been checked.
    """
    if settings.executive == "baseline":
        def make_baseline(node: Node) -> Executive:
            from bt_servicesim.evaluation.baseline import SeedStateMachine

            return SeedStateMachine(node=node, seed=settings.seed,
                                    time_limit_s=settings.time_limit_s)

        return make_baseline
    from bt_servicesim.tree.loading import load_mission_tree, phases_of

    root = load_mission_tree(settings.tree, time_limit_s=settings.time_limit_s)
    phases = phases_of(settings.tree)

    def make_tree(node: Node) -> Executive:
        from bt_servicesim.tree.executive import MissionExecutive

        return MissionExecutive(node=node, root=root, phases=phases, run_seed=settings.seed)

    return make_tree


if __name__ == "__main__":
    sys.exit(main(shutdown_limit_s=SHUTDOWN_LIMIT_S))
