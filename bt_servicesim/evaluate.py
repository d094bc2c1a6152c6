"""``python -m bt_servicesim.evaluate``: many seeded missions per executive, side by side.

The claim of this project is that the behaviour tree completes missions the seed's state machine
does not, faster and with a lower score. Evaluation checks that claim with numbers: for every
scenario set and episode number it runs *each* executive on the *same* seed, each episode a
``python -m bt_servicesim.run --headless`` subprocess (its own simulator, its own run directory)
with a ROS domain of its own, several at once. It writes

* ``summary.json``: per executive, ``episodes``, ``success_rate``, ``mean_score``,
  ``median_score``, ``mean_sim_time_s``, ``penalties``, ``wall_time_s`` and ``rows`` (every
  episode's ``report.json``, with its scenario set and episode number added);
* ``results.md``: the tables (per executive and set; paired: scores where both completed,
  times to the drop-off where both got there; failure reasons), the plots and the exact
  command; ``results_*.png``: the plots.

An episode is never dropped: one that outlives its wall-time limit is stopped (SIGINT, so the
run stops its simulator and writes its report, then SIGKILL for whatever is left) and recorded
as failed with the reason; one that crashes is recorded with its exit code and last error line.
Statistics are defined in ``docs/evaluation.md``.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, TextIO

from bt_servicesim.cli import (
    EXIT_BAD_INPUT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    OneLineArgumentParser,
    UsageError,
)
from bt_servicesim.evaluation.episodes import (
    EpisodeCommand,
    ProgressBar,
    as_minutes,
    plan_episodes,
    run_command,
    run_episodes,
)
from bt_servicesim.evaluation.report import write_results
from bt_servicesim.evaluation.scenarios import SCENARIO_SETS
from bt_servicesim.evaluation.settings import (
    DEFAULT_SPEED,
    DOMAIN_SPAN,
    EvaluationSettings,
    load_warning,
)
from bt_servicesim.mission.settings import EXECUTIVES
from bt_servicesim.ros.environment import apply_localhost_defaults

PROG = "python -m bt_servicesim.evaluate"








def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description=(
        "Run seeded missions for each executive on the same seeds and compare them."))
    parser.add_argument("--episodes", type=int, default=10, help="episodes per scenario set")
    parser.add_argument("--scenarios", default="default,random,hard",
                        help="comma list of scenario sets: default, random, hard")
    parser.add_argument("--executive", default="bt,baseline",
                        help="comma list of executives: bt, baseline")
    parser.add_argument("--jobs", type=int, default=2, help="episodes run at once")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the first episode; episode n plays seed+n")
    parser.add_argument("--out", type=Path, required=True, help="evaluation directory")
    parser.add_argument("--speed", type=float, default=DEFAULT_SPEED,
                        help=f"sim speed of every episode (default {DEFAULT_SPEED:g}; 0: as fast "
                             "as possible, which lets a busy executive fall behind)")
    parser.add_argument("--episode-timeout", type=float, default=600.0,
                        help="wall seconds before an episode is stopped and failed (default 600)")
    parser.add_argument("--time-limit", type=float, default=900.0,
                        help="mission time limit in sim seconds (default 900)")
    parser.add_argument("--docs", type=Path,
                        help="also write results.md here, with the plots in <docs>/images/")
    parser.add_argument("--resume", action="store_true",
                        help="keep the episodes an earlier evaluation in --out finished with "
                             "the same executive, scenario, seed, speed and time limit; run "
                             "only the rest")
    return parser


def settings_from(args: argparse.Namespace, argv: Sequence[str]) -> EvaluationSettings:
    """Check every argument before anything starts."""
    scenarios = _names(args.scenarios, "--scenarios", SCENARIO_SETS)
    executives = _names(args.executive, "--executive", EXECUTIVES)
    _check(args.episodes >= 1, f"--episodes {args.episodes}: must be 1 or more")
    _check(1 <= args.jobs <= DOMAIN_SPAN, f"--jobs {args.jobs}: must be within 1..{DOMAIN_SPAN}")
    _check(args.seed >= 0, f"--seed {args.seed}: must be 0 or more")
    _check(args.speed >= 0.0, f"--speed {args.speed}: must be 0 or more")
    _check(args.episode_timeout > 0.0,
           f"--episode-timeout {args.episode_timeout}: must be more than 0")
    _check(args.time_limit > 0.0, f"--time-limit {args.time_limit}: must be more than 0")
    for flag, path in (("--out", args.out), ("--docs", args.docs)):
        _check(path is None or not path.exists() or path.is_dir(),
               f"{flag} {path}: exists and is not a directory")
    return EvaluationSettings(
        episodes=args.episodes, scenarios=scenarios, executives=executives, jobs=args.jobs,
        seed=args.seed, out=args.out, speed=args.speed, episode_timeout_s=args.episode_timeout,
        time_limit_s=args.time_limit, docs=args.docs,
        command_line=" ".join([PROG, *(shlex.quote(arg) for arg in argv)]),
        resume=args.resume,
    )




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



































































































def evaluate(settings: EvaluationSettings, command: EpisodeCommand = run_command,
             stream: TextIO | None = None) -> tuple[list[dict[str, Any]], bool]:
    """Run the whole evaluation and write its results: the rows, in plan order, and whether
    it was interrupted (the results of an interrupted evaluation are written all the same)."""
    episodes = plan_episodes(settings)
    progress = ProgressBar(len(episodes), stream)
    started = time.monotonic()
    try:
        rows, interrupted = run_episodes(settings, episodes, command, progress)
    finally:
        progress.close()
    write_results(settings, rows)
    out = stream or sys.stderr
    out.write(f"{len(rows)} episodes in {as_minutes(time.monotonic() - started)}"
              f"{' (interrupted)' if interrupted else ''}; "
              f"results: {settings.out / 'results.md'}\n")
    return rows, interrupted


def main(argv: Sequence[str] | None = None) -> int:
    arguments = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(arguments)
    try:
        settings = settings_from(args, arguments)
        settings.out.mkdir(parents=True, exist_ok=True)
    except (UsageError, OSError) as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    apply_localhost_defaults()
    warning = load_warning(jobs=settings.jobs, speed=settings.speed, cores=os.cpu_count() or 1)
    if warning is not None:
        print(f"{PROG}: warning: {warning}", file=sys.stderr)
    _, interrupted = evaluate(settings)
    return EXIT_INTERRUPTED if interrupted else EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
