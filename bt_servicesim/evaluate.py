"""``python -m bt_servicesim.evaluate``: many seeded missions per executive, side by side.

The claim of this project is that the behaviour tree completes missions the seed's state machine
does not, faster and with a lower score. Evaluation checks that claim with numbers: for every
scenario set and episode number it runs *each* executive on the *same* seed, several episodes
at once, each in its own run directory. By default ``--jobs`` warm pairs play them: a simulator
and an executive process that stay alive from one episode to the next, the simulator reset to
each episode's world, seed and knobs, the executive building a fresh tree for each
(:mod:`bt_servicesim.warm_worker`); ``--cold`` makes each episode a ``python -m
bt_servicesim.run --headless`` subprocess of its own (its own simulator, a ROS domain the run
claims for itself). With ``--cluster tcp://HOST:PORT`` the workers of a Dask cluster play the
episodes, each cold, with the same results (:mod:`bt_servicesim.evaluation.cluster`). All write
the same reports, in lockstep the same for the same seed. It writes

* ``summary.json``: per executive, ``episodes``, ``success_rate``, ``mean_score``,
  ``median_score``, ``mean_sim_time_s``, ``penalties``, ``wall_time_s`` and ``rows`` (every
  episode's ``report.json``, with its scenario set and episode number added);
* ``report.html``: the same as a page to open, sort and click through, every episode in it
  (:mod:`bt_servicesim.evaluation.html_report`);
* ``results.md``: the tables (per executive and set; paired: scores where both completed,
  times to the drop-off where both got there; failure reasons), the plots and the exact
  command; ``results_*.png``: the plots.

An episode is never dropped: one that outlives its wall-time limit is stopped (SIGINT, so the
run stops its simulator and writes its report, then SIGKILL for whatever is left) and recorded
as failed with the reason; one that crashes is recorded with its exit code and last error line;
a report is counted only if it carries the episode's run id; a warm pair that crashed, hung or
answered garbage is stopped and replaced, its episode recorded as failed with the reason.
Ctrl-C, SIGTERM and SIGHUP all stop an evaluation the same way: the episodes under way are
stopped as above, none is left running or writing, the results of the episodes played are
written, and the exit status is 128 + the signal's number. Statistics are defined in
``docs/reference/evaluation.md``.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO, TypeVar

from bt_servicesim.cli import (
    EXIT_FAILED,
    EXIT_OK,
    OneLineArgumentParser,
    UsageError,
    error_line,
)
from bt_servicesim.evaluation.episodes import (
    EpisodeCommand,
    plan_episodes,
    planned_count,
    run_command,
    run_episodes,
)
from bt_servicesim.evaluation.progress import Progress, as_minutes
from bt_servicesim.evaluation.report import write_results
from bt_servicesim.evaluation.reproducibility import load_reproducibility
from bt_servicesim.evaluation.scenarios import SCENARIO_SETS
from bt_servicesim.evaluation.settings import (
    DEFAULT_SPEED,
    EVALUATION_TRAJECTORIES,
    MAX_EPISODE_TIMEOUT_S,
    MAX_JOBS,
    MAX_TIME_LIMIT_S,
    EvaluationSettings,
    load_warning,
)
from bt_servicesim.evaluation.throughput import load_throughput
from bt_servicesim.mission.settings import EXECUTIVES
from bt_servicesim.mission.stopping import StopSignals, Terminated, signal_of
from bt_servicesim.ros.environment import apply_localhost_defaults
from bt_servicesim.tree.files import DEFAULT_TREE, SERVICEBOT

if TYPE_CHECKING:  # the local pool imports no distributed engine
    from distributed import Client

Figures = TypeVar("Figures")

PROG = "python -m bt_servicesim.evaluate"
NAV_PARAMS_CHECK = (sys.executable, "-m", "servicesim_sim.nav_params")
"""The simulator's own check of a navigation parameters file (one line and status 2 if bad)."""
NAV_PARAMS_CHECK_S = 60.0
"""Wall seconds the check may take (it reads one small file)."""


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description=(
        "Run seeded missions for each executive on the same seeds and compare them."))
    parser.add_argument("--episodes", type=int, default=10, help="episodes per scenario set")
    parser.add_argument("--scenarios", default="default,random,hard",
                        help="comma list of scenario sets: default, random, hard, "
                        "original-guest (default: the first three)")
    parser.add_argument("--executive", default="bt,baseline",
                        help="comma list of executives: bt, baseline, and bt:FILE for a bt "
                             "playing tree FILE (named bt:STEM in every table), as many as "
                             "wanted, all on the same seeds")
    parser.add_argument("--jobs", type=int, default=2, help="episodes run at once")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the first episode; episode n plays seed+n")
    parser.add_argument("--out", type=Path, required=True, help="evaluation directory")
    parser.add_argument("--speed", type=float, default=DEFAULT_SPEED,
                        help=f"sim speed of every episode (default {DEFAULT_SPEED:g}: as fast as "
                             "possible; in lockstep a busy machine only makes episodes slower)")
    parser.add_argument("--episode-timeout", type=float, default=600.0,
                        help="wall seconds before an episode is stopped and failed (default 600)")
    parser.add_argument("--time-limit", type=float, default=900.0,
                        help="mission time limit in sim seconds (default 900)")
    parser.add_argument("--docs", type=Path,
                        help="also write results.md here, with the plots in <docs>/images/")
    parser.add_argument("--cold", action="store_true",
                        help="run every episode as a process of its own (simulator and "
                             "executive started and stopped per episode) instead of on warm "
                             "pairs kept alive between episodes")
    parser.add_argument("--resume", action="store_true",
                        help="keep the episodes an earlier evaluation in --out finished with "
                             "the same executive, scenario, seed, speed and time limit; run "
                             "only the rest")
    parser.add_argument("--tree", type=Path, default=None, metavar="FILE",
                        help="mission tree XML the bt executive plays (default: the shipped "
                             "trees/servicesim_mission.xml)")
    parser.add_argument("--reproducibility", type=Path, metavar="FILE",
                        help="state in results.md the share of seeds that replay, from the "
                             "figures of benchmarks/reproducibility.py --json FILE")
    parser.add_argument("--throughput", type=Path, metavar="FILE",
                        help="state in results.md the episodes per hour, warm and cold, from "
                             "the figures of benchmarks/throughput.py --json FILE")
    parser.add_argument("--nav-params", metavar="FILE",
                        help="the robot's navigation parameters (a Nav2 parameters file, or "
                             "'servicebot' for the original servicebot's configuration) every "
                             "episode's simulator is given, whatever the executive (default: "
                             "the shipped tree's trees/servicesim_nav2_params.yaml for bt and "
                             "bt:FILE, servicebot for baseline)")
    parser.add_argument("--trajectory", choices=EVALUATION_TRAJECTORIES, default="failed",
                        help="draw trajectory.png for each episode whose mission did not "
                             "complete (failed, the default) or for none (never: about a CPU "
                             "second saved per failed episode; python -m bt_servicesim.trajectory "
                             "DIR draws any episode's later)")
    parser.add_argument("--cluster", metavar="ADDRESS",
                        help="run the episodes on the Dask scheduler at tcp://HOST:PORT, each "
                             "worker as many at once as it has threads (needs the 'cluster' "
                             "extra); default: a local pool of --jobs")
    return parser


def settings_from(args: argparse.Namespace, argv: Sequence[str]) -> EvaluationSettings:
    """Check every argument before anything starts."""
    scenarios = _names(args.scenarios, "--scenarios", SCENARIO_SETS)
    executives, trees = _executives(args.executive)
    _check(args.episodes >= 1, f"--episodes {args.episodes}: must be 1 or more")
    _check(1 <= args.jobs <= MAX_JOBS, f"--jobs {args.jobs}: must be within 1..{MAX_JOBS} "
                                       "(each running episode claims a ROS domain of its own)")
    _check(args.seed >= 0, f"--seed {args.seed}: must be 0 or more")
    _check(math.isfinite(args.speed) and args.speed >= 0.0,
           f"--speed {args.speed}: must be a finite number, 0 or more")
    _check(math.isfinite(args.episode_timeout)
           and 0.0 < args.episode_timeout <= MAX_EPISODE_TIMEOUT_S,
           f"--episode-timeout {args.episode_timeout}: must be more than 0 and at most "
           f"{MAX_EPISODE_TIMEOUT_S:.0f} wall seconds")
    _check(math.isfinite(args.time_limit) and 0.0 < args.time_limit <= MAX_TIME_LIMIT_S,
           f"--time-limit {args.time_limit}: must be more than 0 and at most "
           f"{MAX_TIME_LIMIT_S:.0f} sim seconds")
    for flag, path in (("--out", args.out), ("--docs", args.docs)):
        _check(path is None or not path.exists() or path.is_dir(),
               f"{flag} {path}: exists and is not a directory")
    tree = _tree(args.tree, executives)
    nav_params = _nav_params(args.nav_params)
    reproducibility = _figures("--reproducibility", args.reproducibility, load_reproducibility)
    throughput = _figures("--throughput", args.throughput, load_throughput)
    _docs_place(args.docs)  # last: every other check passed
    return EvaluationSettings(
        episodes=args.episodes, scenarios=scenarios, executives=executives, jobs=args.jobs,
        seed=args.seed, out=args.out, speed=args.speed, episode_timeout_s=args.episode_timeout,
        time_limit_s=args.time_limit, docs=args.docs,
        command_line=" ".join([PROG, *(shlex.quote(arg) for arg in argv)]),
        resume=args.resume, cold=args.cold, reproducibility=reproducibility,
        throughput=throughput, tree=tree, trees=trees, nav_params=nav_params,
        trajectory=args.trajectory,
    )


def _docs_place(docs: Path | None) -> None:
    """Make ``--docs`` (and its ``images``) now: a place results.md cannot be written to is one
    line before the episodes, not a traceback after them."""
    if docs is None:
        return
    try:
        (docs / "images").mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UsageError(f"--docs {docs}: cannot make it a directory: "
                         f"{error.strerror or error}") from error


def _figures(flag: str, path: Path | None, load: Callable[[Path], Figures]) -> Figures | None:
    """A benchmark's figures for results.md, read before anything starts."""
    if path is None:
        return None
    try:
        return load(path)
    except ValueError as error:
        raise UsageError(f"{flag} {error}") from error


def _tree(path: Path | None, executives: tuple[str, ...]) -> Path:
    """The tree ``bt`` plays, absolute, loaded once here: a tree that cannot load is one line
    now, not a failure in every episode."""
    if path is None:
        return DEFAULT_TREE
    _check("bt" in executives, f"--tree {path}: only the bt executive plays a tree")
    from bt_servicesim.tree.loading import MissionTreeError, load_mission_tree

    try:
        load_mission_tree(path)
    except MissionTreeError as error:
        raise UsageError(f"--tree {error}") from error
    return path.resolve()


def _nav_params(argument: str | None) -> str | None:
    """The navigation parameters file, absolute, checked once here by the simulator's own
    reader (:data:`NAV_PARAMS_CHECK`, a process: the evaluation never imports the simulator):
    a file the simulator would refuse is one line now, not a failure in every episode."""
    if argument in (None, SERVICEBOT):
        return argument
    path = Path(argument)
    _check(path.is_file(), f"--nav-params {path}: "
                           f"{'is a directory' if path.is_dir() else 'no such file'}")
    try:
        checked = subprocess.run([*NAV_PARAMS_CHECK, str(path)], capture_output=True,
                                 text=True, timeout=NAV_PARAMS_CHECK_S, check=False)
    except (OSError, subprocess.TimeoutExpired) as error:
        raise UsageError(f"--nav-params {path}: could not be checked: {error}") from error
    if checked.returncode != 0:
        lines = checked.stderr.strip().splitlines() or [f"exit status {checked.returncode}"]
        raise UsageError(f"--nav-params {lines[-1].split(': error: ', 1)[-1]}")
    return str(path.resolve())


def _executives(value: str) -> tuple[tuple[str, ...], dict[str, Path]]:
    """The executives' names, and the tree of each ``bt:FILE`` (named ``bt:STEM``), each
    loaded once here: a tree that cannot load is one line now."""
    names: list[str] = []
    trees: dict[str, Path] = {}
    for entry in (part.strip() for part in value.split(",")):
        kind, _, file = entry.partition(":")
        _check(kind in EXECUTIVES and (not file or kind == "bt"),
               f"--executive {value}: unknown executive {entry!r} (choose from "
               f"{', '.join(EXECUTIVES)}, or bt:FILE for a tree of your own)")
        name = f"bt:{Path(file).stem}" if file else kind
        _check(name not in names, f"--executive {value}: {name} is named twice (two trees "
                                  "need files of different names)")
        names.append(name)
        if file:
            trees[name] = _loaded_tree(Path(file), f"--executive {entry}")
    return tuple(names), trees


def _loaded_tree(path: Path, flag: str) -> Path:
    from bt_servicesim.tree.loading import MissionTreeError, load_mission_tree

    try:
        load_mission_tree(path)
    except MissionTreeError as error:
        raise UsageError(f"{flag}: {error}") from error
    return path.resolve()


def _names(value: str, flag: str, known: Iterable[str]) -> tuple[str, ...]:
    names = tuple(name.strip() for name in value.split(","))
    for name in names:
        _check(name in known, f"{flag} {value}: unknown name {name!r} "
                              f"(choose from {', '.join(known)})")
    _check(len(set(names)) == len(names), f"{flag} {value}: a name is repeated")
    return names


def _check(condition: bool, message: str) -> None:
    if not condition:
        raise UsageError(message)


def evaluate(settings: EvaluationSettings, command: EpisodeCommand | None = None,
             stream: TextIO | None = None, cluster: Client | None = None,
             ) -> tuple[list[dict[str, Any]], int | None]:
    """Run the whole evaluation and write its results: the rows, in plan order, and the signal
    that stopped it, if one did (the results of a stopped evaluation are written all the same,
    for the episodes it played). The episodes run on ``cluster`` if given, else locally.

    ``command``: each episode a process made by it (tests give a stand-in); by default warm
    pairs locally, or :func:`run_command` processes with ``settings.cold`` or on a cluster.
    """
    progress = Progress(planned_count(settings), stream)
    started = time.monotonic()
    warm = command is None and not settings.cold
    with StopSignals() as stops:
        if cluster is None:
            rows = run_episodes(settings, plan_episodes(settings), command or run_command,
                                progress, stops, warm=warm)
        else:
            from bt_servicesim.evaluation.cluster import run_on_cluster

            rows = run_on_cluster(settings, plan_episodes(settings), cluster,
                                  command or run_command, progress, stops)
        progress.close()  # from here on a stop signal is only noted: the results are written
        write_results(settings, rows)
        stopped = f" (stopped by {signal.Signals(stops.first).name})" if stops.first else ""
        with contextlib.suppress(OSError, ValueError):  # the terminal may have hung up
            (stream or sys.stderr).write(
                f"{len(rows)} episodes in {as_minutes(time.monotonic() - started)}{stopped}; "
                f"results: {settings.out / 'results.md'}, "
                f"page: {settings.out / 'report.html'}\n")
    return rows, stops.first


def main(argv: Sequence[str] | None = None, command: EpisodeCommand | None = None) -> int:
    """The command; ``command`` makes each episode's command line (tests give a stand-in)."""
    with StopSignals():  # a stop before any episode started: nothing to clean up, one line
        try:
            return _main(argv, command)
        except (KeyboardInterrupt, Terminated) as stop:
            print(f"{PROG}: stopped by {signal.Signals(signal_of(stop)).name} while starting",
                  file=sys.stderr)
            return 128 + signal_of(stop)


def _main(argv: Sequence[str] | None, command: EpisodeCommand | None) -> int:
    arguments = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(arguments)
    try:
        settings = settings_from(args, arguments)
        cluster = None if args.cluster is None else _connect(args.cluster)
    except (UsageError, OSError) as error:
        return error_line(PROG, error)
    with cluster or contextlib.nullcontext():
        try:
            settings.out.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            return error_line(PROG, error)
        apply_localhost_defaults()
        warning = None if cluster is not None else load_warning(
            jobs=settings.jobs, speed=settings.speed, cores=os.cpu_count() or 1)
        if warning is not None:
            print(f"{PROG}: warning: {warning}", file=sys.stderr)
        _, stopped_by = evaluate(settings, command, cluster=cluster)
        if cluster is not None and stopped_by is None and _lost(cluster):
            print(f"{PROG}: error: --cluster {args.cluster}: the scheduler was lost during the "
                  "evaluation; the episodes under way are not_run, those not started were not "
                  "played", file=sys.stderr)
            return EXIT_FAILED
    return EXIT_OK if stopped_by is None else 128 + stopped_by


def _lost(cluster: Client) -> bool:
    from bt_servicesim.evaluation.cluster import lost

    return lost(cluster)


def _connect(address: str) -> Client:
    """The cluster's client; a :class:`UsageError` naming the problem if there is none."""
    try:
        from bt_servicesim.evaluation.cluster import ClusterError, cluster_address, connect
    except ImportError as error:
        raise UsageError(f"--cluster needs Dask distributed: pip install -e '.[cluster]' "
                         f"({error})") from None
    try:
        return connect(cluster_address(address))
    except ClusterError as error:
        raise UsageError(str(error)) from None


if __name__ == "__main__":
    sys.exit(main())
