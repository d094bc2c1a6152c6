"""Where a mission's time over its kinematic bound goes: a longer path, or a slower drive.

Design intent: the time over the bound (:mod:`bt_servicesim.evaluation.kinematic_bound`) is one
ratio; tuning a tree needs to know which of its two factors to work on. A mission's time over
the bound is exactly

    (the path the robot drove / the bound's route length) x (top speed / its mean speed)

so this module measures the first from the robot's true trajectory in the episode's
``run.mcap`` (the simulator's ground truth, a topic the executive never reads; records may),
over the task as the referee timed it (its recorded state's stamp less its task time), and the
second follows. It also says what share of the mission the robot stood (slower than
:data:`STANDING_M_S`).

``python -m bt_servicesim.evaluation.path_excess DIR [--executive bt] [--set random]`` reads an
evaluation's ``summary.json`` (the rows with their bounds) and each completed episode's
recording, and prints the median, 10th and 90th percentile of each figure. Nothing in ``DIR``
is written. Bad input is one line on stderr and exit status 2.
"""

from __future__ import annotations

import itertools
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bt_servicesim.cli import EXIT_OK, interruptible
from bt_servicesim.evaluation.episode_set import episode_set_parser, rows_of_set

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


def path_figures(samples: Sequence[Sample], *, task_start_s: float | None, sim_time_s: float,
                 bound_length_m: float, time_over_bound: float) -> PathFigures | None:
    """The figures of a mission of ``sim_time_s`` from ``task_start_s`` (sim time, the
    referee's); None if the start is unknown or the bound is empty."""
    start = task_start_s
    if start is None or bound_length_m <= 0.0 or sim_time_s <= 0.0:
        return None
    mission = [s for s in samples if start <= s.t <= start + sim_time_s]
    driven = sum(math.hypot(b.x - a.x, b.y - a.y) for a, b in itertools.pairwise(mission))
    standing = sum(1 for s in mission if abs(s.v) < STANDING_M_S) / max(1, len(mission))
    return PathFigures(time_over_bound=time_over_bound,
                       path_over_bound=driven / bound_length_m,
                       mean_speed_m_s=driven / sim_time_s, standing_share=standing)


def recorded_samples(mcap_path: Path) -> tuple[list[Sample], float | None]:
    """The ground truth's samples in a run's recording, in the order written, and the sim time
    the task started at by the referee's books (its stamp less its task time, from the first
    state of a running task); None if the recording has no such state."""
    from mcap.reader import make_reader
    from nav_msgs.msg import Odometry
    from rclpy.serialization import deserialize_message
    from servicesim_competition.msg import RefereeState

    from bt_servicesim.mission.referee_monitor import REFEREE_TOPIC
    from bt_servicesim.records.mcap import GROUND_TRUTH_TOPIC

    samples, task_start = [], None
    with mcap_path.open("rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(
                topics=[GROUND_TRUTH_TOPIC, REFEREE_TOPIC], log_time_order=False):
            if channel.topic == REFEREE_TOPIC:
                state = deserialize_message(message.data, RefereeState)
                if task_start is None and state.task_running:
                    stamp = state.stamp.sec + state.stamp.nanosec / 1e9
                    task_start = stamp - state.task_sim_time
                continue
            odometry = deserialize_message(message.data, Odometry)
            position = odometry.pose.pose.position
            samples.append(Sample(t=message.log_time / 1e9, x=position.x, y=position.y,
                                  v=odometry.twist.twist.linear.x))
    return samples, task_start


def figures_of(rows: Iterable[dict[str, Any]]) -> list[PathFigures]:
    """The figures of every completed row that has a bound and a recording."""
    found = []
    for row in rows:
        legs = row.get("kinematic_bound_legs")
        recording = Path(str(row.get("out", ""))) / "run.mcap"
        if not (row.get("completed") and legs and row.get("time_over_bound")
                and recording.is_file()):
            continue
        samples, task_start = recorded_samples(recording)
        figures = path_figures(samples, task_start_s=task_start,
                               sim_time_s=float(row["sim_time_s"]),
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
    parser = episode_set_parser(prog=PROG, description="Where the time over the kinematic "
                                "bound goes: path length or speed.")
    args = parser.parse_args(argv)
    figures = figures_of(rows_of_set(parser, args))
    if not figures:
        parser.error(f"{args.directory / 'summary.json'}: no completed {args.executive} "
                     f"episode of the {args.scenario!r} set with a bound and a recording")
    print("\n".join(summary_lines(figures)))
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(interruptible(PROG, main))
