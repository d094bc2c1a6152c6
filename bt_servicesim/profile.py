"""``python -m bt_servicesim.profile DIR``: a recorded run's mission profile, ``profile.json``.

A run writes its profile as it ends (:mod:`bt_servicesim.records.profile` defines it); this
command builds it again from the run's records (``tree_log.jsonl`` and ``run.mcap``), for a
run recorded before or to add the kinematic bound: ``--bound`` asks the simulator's
``servicesim_sim.task_bound`` for the run's task (its seed and sim arguments, from
``report.json``) and adds each phase's share of the bound and its time over it. ``--print``
writes the profile to stdout instead of the file.

Bad input (no such run, a broken log or recording) is one line and exit 2.
"""

from __future__ import annotations

import json
import shlex
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError

from bt_servicesim.cli import EXIT_BAD_INPUT, EXIT_OK, OneLineArgumentParser, interruptible
from bt_servicesim.records.profile import add_bounds
from bt_servicesim.records.profile_inputs import profile_of_run, write_profile
from bt_servicesim.records.tree_log import TreeLogError

PROG = "python -m bt_servicesim.profile"


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description="Write a recorded run's profile.json.")
    parser.add_argument("run", type=Path, help="run directory (tree_log.jsonl and run.mcap)")
    parser.add_argument("--bound", action="store_true",
                        help="add each phase's share of the task's kinematic bound (asks "
                             "servicesim_sim.task_bound, a few seconds)")
    parser.add_argument("--print", action="store_true", dest="to_stdout",
                        help="print the profile instead of writing profile.json")
    return parser


def task_bound_legs(run: Path) -> list[dict[str, Any]]:
    """The bound's legs for the run's task, from the simulator's own command."""
    report = json.loads((run / "report.json").read_text())
    command = [sys.executable, "-m", "servicesim_sim.task_bound"]
    if report.get("seed") is not None:
        command += ["--seed", str(report["seed"])]
    for argument in _sim_args(str(report.get("reproduce") or "")):
        command.append(argument)
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise ValueError(f"task_bound failed: {result.stderr.strip()[:200]}")
    return list(json.loads(result.stdout)["legs"])


def _sim_args(reproduce: str) -> list[str]:
    """The ``--sim-arg=X`` arguments of the report's reproduce command, as task_bound takes them."""
    return [word.split("=", 1)[1] for word in shlex.split(reproduce)
            if word.startswith("--sim-arg=")]


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        profile = profile_of_run(args.run)
        if args.bound:
            profile = add_bounds(profile, task_bound_legs(args.run))
    except (TreeLogError, McapError, OSError, ValueError, KeyError) as error:
        print(f"{PROG}: error: {args.run}: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.to_stdout:
        sys.stdout.write(json.dumps(profile, indent=1) + "\n")
    else:
        print(write_profile(args.run, profile))
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(interruptible(PROG, main))
