"""``python -m bt_servicesim.trajectory DIR``: draw a recorded run's trajectory picture again.

The picture is drawn from the run's ``run.mcap`` (and the target areas from its tree log) by
:mod:`bt_servicesim.records.trajectory`, exactly as the run drew it when it ended. A recording
cut short (the run was killed before it closed it) is drawn up to the cut, with a warning line
that says so; one with nothing before the cut, or no recording at all, is one error line and
exit 2.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from bt_servicesim.cli import EXIT_OK, OneLineArgumentParser, UsageError, error_line, interruptible
from bt_servicesim.records.mcap import MCAP_NAME
from bt_servicesim.records.trajectory import (
    TRAJECTORY_NAME,
    boxes_from_tree_log,
    render_trajectory,
    trace_from_recording,
)
from bt_servicesim.records.tree_log import LOG_NAME, TreeLogError

PROG = "python -m bt_servicesim.trajectory"


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
        prog=PROG,
        description="Draw a recorded run's trajectory picture again, from its run.mcap.")
    parser.add_argument("run", type=Path, help="run directory (with run.mcap)")
    parser.add_argument("--out", type=Path, help="PNG to write (default DIR/trajectory.png)")
    args = parser.parse_args(argv)
    recording, tree_log = args.run / MCAP_NAME, args.run / LOG_NAME
    out = args.out or args.run / TRAJECTORY_NAME
    try:
        _check_out(args.out)
        if not recording.is_file():
            raise ValueError(f"{args.run}: no {MCAP_NAME} here (was the run given --out?)")
        trace = trace_from_recording(recording)
        boxes = boxes_from_tree_log(tree_log) if tree_log.is_file() else {}
        if trace.cut_short is not None and trace.map_image is None and not trace.robot:
            raise ValueError(f"{trace.cut_short}: nothing to draw")
    except (ValueError, TreeLogError) as error:
        return error_line(PROG, error)
    try:
        render_trajectory(trace, path=out, boxes=boxes, title=_title_from_report(args.run))
    except OSError as error:
        where = f"--out {args.out}" if args.out else str(out)
        return error_line(PROG, f"{where}: {error.strerror or error}")
    if trace.cut_short is not None:
        print(f"{PROG}: warning: {trace.cut_short}; {out} shows the run up to the cut",
              file=sys.stderr)
    return EXIT_OK


def _check_out(out: Path | None) -> None:
    """``--out`` names a file that can be made: not a directory, in a directory that exists."""
    if out is None:
        return
    if out.is_dir():
        raise UsageError(f"--out {out}: is a directory; name the PNG file to write")
    if not out.parent.is_dir():
        raise UsageError(f"--out {out}: no directory {out.parent} to write it in")


if __name__ == "__main__":
    sys.exit(interruptible(PROG, main))
