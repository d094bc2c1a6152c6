"""Episodes per hour: warm pairs against a process pair per episode, on the same seeds.

``python benchmarks/throughput.py [--episodes N] [--jobs J] [--scenario random] [--speed S]
[--time-limit T] [--executive bt|baseline] [--first-seed F] [--out DIR] [--json FILE]`` plays
the same ``N``
episodes of one scenario set twice with the evaluation's own machinery
(:func:`~bt_servicesim.evaluation.episodes.run_episodes`), ``J`` at once: cold (each episode a
``python -m bt_servicesim.run`` process with its own simulator) and warm (``J`` warm pairs
kept alive between episodes). It prints, for each, the wall time, episodes per hour
and the share completed, how the episodes' sim time is spread (the longest episode's share: a
mission failing only at the time limit costs many others' worth), then the ratio warm/cold and
how many episodes' reports agree between the two on what lockstep makes replayable (completed,
checkpoint times, penalties, score). ``--json FILE`` also writes the figures there, whole or
not at all (``evaluate --throughput FILE`` states them in ``results.md``).

The default speed is 0 (flat out): in lockstep the simulator still waits for its executive, so
the missions are the same as at any speed and the figure measures what an episode costs the
machine, not a pace chosen for it. Wall-clock figures depend on the machine's load (say what
else ran); nothing here is asserted. Bad arguments give one line and exit status 2.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import shutil
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bt_servicesim.cli import EXIT_OK, OneLineArgumentParser
from bt_servicesim.evaluation.episodes import plan_episodes, run_episodes
from bt_servicesim.evaluation.figures_file import checkout_commit, write_figures
from bt_servicesim.evaluation.scenarios import SCENARIO_SETS
from bt_servicesim.evaluation.settings import EvaluationSettings
from bt_servicesim.ros.environment import apply_localhost_defaults

PROG = "benchmarks/throughput.py"
EPISODE_TIMEOUT_S = 600.0


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description=(
        "Episodes per hour, warm pairs against a process pair per episode, same seeds."))
    parser.add_argument("--episodes", type=int, default=20, help="episodes per mode (20)")
    parser.add_argument("--jobs", type=int, default=2, help="episodes at once (2)")
    parser.add_argument("--scenario", choices=tuple(SCENARIO_SETS), default="random")
    parser.add_argument("--speed", type=float, default=0.0, help="sim speed (0: flat out)")
    parser.add_argument("--time-limit", type=float, default=900.0,
                        help="mission time limit in sim seconds (900)")
    parser.add_argument("--executive", choices=("bt", "baseline"), default="bt")
    parser.add_argument("--first-seed", type=int, default=0, help="seeds F, F+1, ... (0)")
    parser.add_argument("--out", type=Path, help="keep the episodes here (default: a "
                        "temporary directory, removed afterwards)")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write the figures to FILE (for evaluate --throughput)")
    return parser


def settings_for(args: argparse.Namespace, out: Path) -> EvaluationSettings:
    return EvaluationSettings(
        episodes=args.episodes, scenarios=(args.scenario,), executives=(args.executive,),
        jobs=args.jobs, seed=args.first_seed, out=out, speed=args.speed,
        episode_timeout_s=EPISODE_TIMEOUT_S, time_limit_s=args.time_limit, docs=None,
        command_line=" ".join([PROG, *sys.argv[1:]]))


def judged(row: dict[str, Any]) -> tuple[Any, ...]:
    return (row.get("completed"),
            [(c.get("done"), c.get("sim_time_s")) for c in row.get("checkpoints") or []],
            row.get("penalties"), row.get("score"))


def timed(settings: EvaluationSettings, *, warm: bool) -> tuple[list[dict[str, Any]], float]:
    started = time.monotonic()
    rows = run_episodes(settings, plan_episodes(settings), warm=warm)
    return rows, time.monotonic() - started


def line(name: str, rows: list[dict[str, Any]], wall_s: float) -> str:
    done = sum(1 for row in rows if row["completed"])
    return (f"{name}: {len(rows)} episodes in {wall_s:.1f} s wall = "
            f"{len(rows) / wall_s * 3600.0:.0f} episodes/hour; {done}/{len(rows)} completed")


def sim_time_line(rows: list[dict[str, Any]]) -> str:
    """How the episodes' sim time is spread: the machine's cost follows it, so one long episode
    (a mission that fails only at the time limit) can weigh as much as many others."""
    times = [(float(row.get("sim_time_s") or 0.0), row.get("episode_seed")) for row in rows]
    total = sum(sim_s for sim_s, _ in times)
    longest, seed = max(times, default=(0.0, None))
    share = longest / total if total > 0.0 else 0.0
    return (f"sim time: {total:.0f} s in all, {total / max(len(times), 1):.0f} s an episode; "
            f"the longest, seed {seed}, {longest:.0f} s ({share:.0%} of it)")


def figures(args: argparse.Namespace, argv: Sequence[str], *, load_start: float,
            modes: dict[str, tuple[list[dict[str, Any]], float]]) -> dict[str, Any]:
    """What ``--json`` writes (read back by ``bt_servicesim.evaluation.throughput``)."""
    cold, warm = modes["cold"][0], modes["warm"][0]
    return {
        "command": shlex.join(["python", PROG, *argv]), "commit": checkout_commit(),
        "scenario": args.scenario, "executive": args.executive, "jobs": args.jobs,
        "cores": os.cpu_count(), "speed": args.speed,
        "load_average": [round(load_start, 2), round(os.getloadavg()[0], 2)],
        **{name: {"episodes": len(rows), "wall_s": round(wall_s, 1),
                  "completed": sum(1 for row in rows if row["completed"])}
           for name, (rows, wall_s) in modes.items()},
        "agreeing": sum(1 for a, b in zip(cold, warm, strict=True) if judged(a) == judged(b)),
    }


def keep(cold: dict[str, Any], warm: dict[str, Any], args: argparse.Namespace) -> str:
    """Where the two episodes that disagree are kept for a look (with ``--out`` they stay
    where they are; the temporary directory goes, so they are copied out of it)."""
    if args.out is not None:
        return f"kept in {cold['out']} and {warm['out']}"
    kept = Path(tempfile.mkdtemp(prefix=f"throughput-disagreed-seed{cold['episode_seed']}-",
                                 dir=Path.cwd()))
    for name, row in (("cold", cold), ("warm", warm)):
        shutil.copytree(row["out"], kept / name)
    return f"both kept in {kept}"


def check(args: argparse.Namespace, parser: OneLineArgumentParser) -> None:
    """Refuse bad arguments in one line before any episode starts."""
    if args.episodes < 1 or not 1 <= args.jobs <= 16:
        parser.error("--episodes must be 1 or more and --jobs within 1..16")
    if not (math.isfinite(args.speed) and args.speed >= 0.0) or args.first_seed < 0:
        parser.error("--speed must be a finite number, 0 or more; --first-seed 0 or more")
    if args.json is not None and not args.json.resolve().parent.is_dir():
        parser.error(f"--json {args.json}: its directory does not exist")
    if args.json is not None and args.json.is_dir():
        parser.error(f"--json {args.json}: is a directory")


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    check(args, parser)
    apply_localhost_defaults()
    load_start = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="throughput-") as scratch:
        out = args.out or Path(scratch)
        print(f"{args.episodes} {args.scenario} episodes ({args.executive}), --jobs "
              f"{args.jobs}, speed {args.speed:g}, time limit {args.time_limit:g} s; "
              f"{os.cpu_count()} cores, load average {load_start:.2f} at the start",
              flush=True)
        cold, cold_s = timed(settings_for(args, out / "cold"), warm=False)
        print(line("cold", cold, cold_s), flush=True)
        warm, warm_s = timed(settings_for(args, out / "warm"), warm=True)
        print(line("warm", warm, warm_s), flush=True)
        print(sim_time_line(warm), flush=True)
        agree = sum(1 for a, b in zip(cold, warm, strict=True) if judged(a) == judged(b))
        print(f"warm/cold: {cold_s / warm_s:.2f}x episodes per hour; reports agree on "
              f"{agree}/{len(cold)} episodes; load average {os.getloadavg()[0]:.2f} at the end")
        for a, b in zip(cold, warm, strict=True):
            if judged(a) != judged(b):
                print(f"  seed {a['episode_seed']}: cold {judged(a)} / warm {judged(b)} "
                      f"(warm failure: {b.get('failure')}); {keep(a, b, args)}")
    if args.json is not None:
        write_figures(args.json, figures(args, argv, load_start=load_start,
                                      modes={"cold": (cold, cold_s), "warm": (warm, warm_s)}))
        print(f"figures written to {args.json}")
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
