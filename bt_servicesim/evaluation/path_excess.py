"""Where a mission's time over its kinematic bound goes: a longer path, or a slower drive.

Design intent: the time over the bound (:mod:`bt_servicesim.evaluation.kinematic_bound`) is one
ratio; tuning a tree needs to know which of its two factors to work on. A mission's time over
the bound is exactly

    (the path the robot drove / the bound's route length) x (top speed / its mean speed)

so this module measures the first from the robot's true trajectory in the episode's
``run.mcap`` (the simulator's ground truth, a topic the executive never reads; records may),
and the second follows. It also says what share of the mission the robot stood (slower than
:data:`STANDING_M_S`).

``python -m bt_servicesim.evaluation.path_excess DIR [--executive bt] [--set random]`` reads an
evaluation's ``summary.json`` (the rows with their bounds) and each completed episode's
recording, and prints the median, 10th and 90th percentile of each figure. Nothing in ``DIR``
is written. Bad input is one line on stderr and exit status 2.
"""

from __future__ import annotations

import itertools
import json
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bt_servicesim.cli import EXIT_OK, OneLineArgumentParser

PROG = "python -m bt_servicesim.evaluation.path_excess"
STANDING_M_S = 0.05
"""Slower than this (m/s, the odometry's forward speed) the robot counts as standing."""


@dataclass(frozen=True)
class Sample:
    """The robot's true pose and forward speed at a sim time (seconds)."""

    t: float
    x: float
    y: float
    v: float


@dataclass(frozen=True)
class PathFigures:
    """One completed mission against its bound."""

    time_over_bound: float
    path_over_bound: float
    mean_speed_m_s: float
    standing_share: float


def path_figures(samples: Sequence[Sample], *, sim_time_s: float,
                 bound_length_m: float, time_over_bound: float) -> PathFigures | None:
    """The figures of a mission of ``sim_time_s`` whose task starts at the first sample that
    moves; None if the samples never move or the bound is empty."""
    start = next((s.t for s in samples if abs(s.v) > STANDING_M_S / 5.0), None)
    if start is None or bound_length_m <= 0.0 or sim_time_s <= 0.0:
        return None
    mission = [s for s in samples if start <= s.t <= start + sim_time_s]
    driven = sum(math.hypot(b.x - a.x, b.y - a.y) for a, b in itertools.pairwise(mission))
    standing = sum(1 for s in mission if abs(s.v) < STANDING_M_S) / max(1, len(mission))
    return PathFigures(time_over_bound=time_over_bound,
                       path_over_bound=driven / bound_length_m,
                       mean_speed_m_s=driven / sim_time_s, standing_share=standing)


def recorded_samples(mcap_path: Path) -> list[Sample]:
    """The ground truth's samples in a run's recording, in the order written."""
    from mcap.reader import make_reader
    from nav_msgs.msg import Odometry
    from rclpy.serialization import deserialize_message

    from bt_servicesim.records.mcap import GROUND_TRUTH_TOPIC

    samples = []
    with mcap_path.open("rb") as stream:
        for _, _, message in make_reader(stream).iter_messages(topics=[GROUND_TRUTH_TOPIC],
                                                               log_time_order=False):
            odometry = deserialize_message(message.data, Odometry)
            position = odometry.pose.pose.position
            samples.append(Sample(t=message.log_time / 1e9, x=position.x, y=position.y,
                                  v=odometry.twist.twist.linear.x))
    return samples


def figures_of(rows: Iterable[dict[str, Any]]) -> list[PathFigures]:
    """The figures of every completed row that has a bound and a recording."""
    found = []
    for row in rows:
        legs = row.get("kinematic_bound_legs")
        recording = Path(str(row.get("out", ""))) / "run.mcap"
        if not (row.get("completed") and legs and row.get("time_over_bound")
                and recording.is_file()):
            continue
        figures = path_figures(recorded_samples(recording), sim_time_s=float(row["sim_time_s"]),
                               bound_length_m=sum(float(leg["length_m"]) for leg in legs),
                               time_over_bound=float(row["time_over_bound"]))
        if figures is not None:
            found.append(figures)
    return found


def summary_lines(figures: Sequence[PathFigures]) -> list[str]:
    """One line per figure: median (p10, p90) over the missions."""
    lines = [f"{len(figures)} completed missions with a bound and a recording"]
    for name in ("time_over_bound", "path_over_bound", "mean_speed_m_s", "standing_share"):
        values = np.array([getattr(f, name) for f in figures])
        p10, median, p90 = np.percentile(values, [10, 50, 90])
        lines.append(f"{name}: median {median:.3f} (p10 {p10:.3f}, p90 {p90:.3f})")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog=PROG, description="Where the time over the "
                                   "kinematic bound goes: path length or speed.")
    parser.add_argument("directory", type=Path, help="an evaluation's --out directory")
    parser.add_argument("--executive", default="bt", help="whose episodes (default bt)")
    parser.add_argument("--set", dest="scenario", default="random",
                        help="which scenario set (default random)")
    args = parser.parse_args(argv)
    summary_file = args.directory / "summary.json"
    try:
        summary = json.loads(summary_file.read_text())
        rows = summary[args.executive]["rows"]
    except (OSError, ValueError) as error:
        parser.error(f"{summary_file}: cannot read it ({error})")
    except (KeyError, TypeError):
        parser.error(f"{summary_file}: no rows of the {args.executive!r} executive")
    figures = figures_of(row for row in rows if row.get("scenario") == args.scenario)
    if not figures:
        parser.error(f"{summary_file}: no completed {args.executive} episode of the "
                     f"{args.scenario!r} set with a bound and a recording")
    print("\n".join(summary_lines(figures)))
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
