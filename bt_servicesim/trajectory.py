"""``python -m bt_servicesim.trajectory DIR``: draw a recorded run's trajectory picture again.

The picture is drawn from the run's ``run.mcap`` (and the target areas from its tree log) by
:mod:`bt_servicesim.records.trajectory`, exactly as the run drew it when it ended.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from mcap.exceptions import McapError

from bt_servicesim.cli import EXIT_BAD_INPUT, EXIT_OK, OneLineArgumentParser, interruptible
from bt_servicesim.records.mcap import MCAP_NAME
from bt_servicesim.records.trajectory import (
    TRAJECTORY_NAME,
    boxes_from_tree_log,
    render_trajectory,
    trace_from_recording,
)
from bt_servicesim.records.tree_log import LOG_NAME, TreeLogError


def _title_from_report(run: Path) -> str:
    try:
        report = json.loads((run / "report.json").read_text())
        outcome = "completed" if report["completed"] else "not completed"
        return (f"{run.name}: {outcome}, score {float(report['score']):.1f}, "
                f"{float(report['sim_time_s']):.0f} s sim")
    except (OSError, ValueError, KeyError, TypeError):
        return run.name


def main(argv: list[str] | None = None) -> int:
    """``python -m bt_servicesim.trajectory DIR [--out FILE]``: redraw a recorded run."""
    parser = OneLineArgumentParser(
        prog="python -m bt_servicesim.trajectory",
        description="Draw a recorded run's trajectory picture again, from its run.mcap.")
    parser.add_argument("run", type=Path, help="run directory (with run.mcap)")
    parser.add_argument("--out", type=Path, help="PNG to write (default DIR/trajectory.png)")
    args = parser.parse_args(argv)
    prog = parser.prog
    recording, tree_log = args.run / MCAP_NAME, args.run / LOG_NAME
    try:
        if not recording.is_file():
            raise ValueError(f"{args.run}: no {MCAP_NAME} here (was the run given --out?)")
        trace = trace_from_recording(recording)
        boxes = boxes_from_tree_log(tree_log) if tree_log.is_file() else {}
    except (ValueError, McapError, TreeLogError) as error:
        print(f"{prog}: error: {' '.join(str(error).split())}", file=sys.stderr)
        return EXIT_BAD_INPUT
    render_trajectory(trace, path=args.out or args.run / TRAJECTORY_NAME, boxes=boxes,
                      title=_title_from_report(args.run))
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(interruptible("python -m bt_servicesim.trajectory", main))
