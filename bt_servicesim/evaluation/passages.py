"""Where the people's approximation points were booked: in passages too narrow to pass anyone
outside the referee's zone, or where there was room.

Design intent: the referee books a person while their body lies within 0.75 m of the robot's
base, so the robot's centre must keep about 1.0 m from theirs. A corridor, a doorway or a gap
between furniture narrower than :data:`NARROW` (two such distances and a margin) leaves no way
past anyone in it outside the zone, whatever the tree does; in the open, navigation's berth
round people can keep the robot out. A tree's points mean different things in the two, and the
profiles (:mod:`bt_servicesim.records.situations`) do not tell them apart. This module does,
from the recordings: each booking of the people's approximation (the episode's
``profile.json`` timeline) is matched with the nearest person of the booked role at that sim
time (``/servicesim/actors``), the robot's true pose and speed (the ground truth's odometry),
and the width of the passage at the midpoint between them
(:func:`~bt_servicesim.planning.give_way.passage_width`, on the map the run recorded).

``python -m bt_servicesim.evaluation.passages DIR [--executive bt] [--set random] [--narrow
2.2]`` reads an evaluation's ``summary.json`` and each episode's records, and prints per role
the points an episode, the share booked in narrow passages, and how they split by who moved:
the robot driving past someone standing, both moving, the robot standing. Nothing in ``DIR``
is written. Bad input is one line on stderr and exit status 2.
"""

from __future__ import annotations

import bisect
import json
import math
import sys
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bt_servicesim.cli import EXIT_OK, interruptible
from bt_servicesim.evaluation.episode_set import episode_set_parser, rows_of_set
from bt_servicesim.planning.give_way import passage_width
from bt_servicesim.planning.occupancy import OccupancyGrid2D

PROG = "python -m bt_servicesim.evaluation.passages"
NARROW = 2.2
"""Metres: a passage narrower than this leaves no way past a person outside the zone."""
MOVING_M_S = 0.05
"""Slower than this (m/s, the ground truth's forward speed) the robot stands."""
WALKING_M = 0.15
"""Metres a person moves over :data:`WALK_WINDOW_S` either side of a booking to be walking."""
WALK_WINDOW_S = 0.5
APPROXIMATION = "approximation/"
"""The cause prefix of the people's and the walls' approximation bookings."""
KINDS = ("robot moving, person standing", "both moving", "robot standing")


@dataclass(frozen=True)
class Track:
    """What the recording says at each sample time: the robot's (x, y, forward speed) and,
    for the people, (role, x, y) by name, each list sorted by time."""

    robot_times: list[float]
    robot: list[tuple[float, float, float]]
    people_times: list[float]
    people: list[dict[str, tuple[str, float, float]]]

    def robot_at(self, t: float) -> tuple[float, float, float]:
        return self.robot[_nearest(self.robot_times, t)]

    def people_at(self, t: float) -> dict[str, tuple[str, float, float]]:
        return self.people[_nearest(self.people_times, t)]


@dataclass
class Tally:
    """Points by role: all, and in narrow passages by who moved."""

    episodes: int = 0
    points: defaultdict[str, float] = field(default_factory=lambda: defaultdict(float))
    narrow: defaultdict[tuple[str, str], float] = field(
        default_factory=lambda: defaultdict(float))


def _nearest(times: Sequence[float], t: float) -> int:
    index = bisect.bisect_left(times, t)
    if index == len(times) or (index > 0 and t - times[index - 1] <= times[index] - t):
        index -= 1
    return max(index, 0)


def classify(bookings: Iterable[tuple[float, str, float]], track: Track, grid: OccupancyGrid2D,
             tally: Tally, *, narrow: float = NARROW) -> None:
    """Add an episode's ``bookings`` (sim time, cause, points) of the people's approximation to
    ``tally``: by the booked role, and in passages narrower than ``narrow`` by who moved."""
    tally.episodes += 1
    if not track.robot or not track.people:
        return
    for t, cause, points in bookings:
        role = cause.removeprefix(APPROXIMATION)
        if not cause.startswith(APPROXIMATION) or role == "walls":
            continue
        tally.points[role] += points
        kind = _situation(t, role, track, grid, narrow)
        if kind is not None:
            tally.narrow[(role, kind)] += points


def _situation(t: float, role: str, track: Track, grid: OccupancyGrid2D,
               narrow: float) -> str | None:
    """Who moved, if the nearest person of ``role`` stood in a narrow passage with the robot."""
    x, y, speed = track.robot_at(t)
    people = {name: where for name, where in track.people_at(t).items() if where[0] == role}
    if not people:
        return None
    name = min(people, key=lambda n: math.hypot(people[n][1] - x, people[n][2] - y))
    _, px, py = people[name]
    if passage_width(grid, (x + px) / 2.0, (y + py) / 2.0) >= narrow:
        return None
    before, after = track.people_at(t - WALK_WINDOW_S), track.people_at(t + WALK_WINDOW_S)
    walking = (name in before and name in after and math.hypot(
        after[name][1] - before[name][1], after[name][2] - before[name][2]) >= WALKING_M)
    if abs(speed) < MOVING_M_S:
        return KINDS[2]
    return KINDS[1] if walking else KINDS[0]


def recorded_track(mcap_path: Path) -> tuple[Track, OccupancyGrid2D | None]:
    """The robot's and the people's samples in a run's recording, and the map it recorded."""
    from nav_msgs.msg import OccupancyGrid, Odometry
    from rclpy.serialization import deserialize_message

    from bt_servicesim.records.mcap import GROUND_TRUTH_TOPIC
    from bt_servicesim.records.recording import recorded_messages, recorded_people

    track = Track([], [], [], [])
    grid = None
    for channel, message in recorded_messages(mcap_path, topics=[
            GROUND_TRUTH_TOPIC, "/servicesim/actors", "/servicebot/map"]):
        t = message.log_time / 1e9
        if channel.topic == "/servicebot/map":
            grid = OccupancyGrid2D.from_message(deserialize_message(message.data, OccupancyGrid))
        elif channel.topic == GROUND_TRUTH_TOPIC:
            odometry = deserialize_message(message.data, Odometry)
            track.robot_times.append(t)
            track.robot.append((odometry.pose.pose.position.x, odometry.pose.pose.position.y,
                                odometry.twist.twist.linear.x))
        else:
            people = recorded_people(message.data)
            track.people_times.append(t)
            track.people.append({name: (role, px, py) for name, role, (px, py) in zip(
                people.names, people.roles, people.positions, strict=True)})
    return track, grid


def tally_of(rows: Iterable[dict[str, Any]], *, narrow: float = NARROW) -> Tally:
    """The tally over every row whose episode left a profile and a recording."""
    tally = Tally()
    for row in rows:
        out = Path(str(row.get("out", "")))
        try:
            timeline = json.loads((out / "profile.json").read_text())["timeline"]
        except (OSError, ValueError, KeyError):
            continue
        if not (out / "run.mcap").is_file():
            continue
        track, grid = recorded_track(out / "run.mcap")
        if grid is None:
            continue
        classify(((float(t), str(c), float(p)) for t, c, p in timeline["bookings"]),
                 track, grid, tally, narrow=narrow)
    return tally


def table_lines(tally: Tally, *, narrow: float) -> list[str]:
    """A table of the tally, per episode."""
    n = max(1, tally.episodes)
    lines = [f"{tally.episodes} episodes; points an episode; in passages under {narrow:g} m",
             "| role | points | in narrow passages | " + " | ".join(KINDS) + " |",
             "|---|---|---|" + "---|" * len(KINDS)]
    for role, points in sorted(tally.points.items(), key=lambda item: -item[1]):
        kinds = [tally.narrow.get((role, kind), 0.0) / n for kind in KINDS]
        share = sum(kinds) / (points / n) if points else 0.0
        lines.append(f"| {role} | {points / n:.1f} | {sum(kinds):.1f} ({share:.0%}) | "
                     + " | ".join(f"{value:.1f}" for value in kinds) + " |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = episode_set_parser(prog=PROG, description="Where the people's approximation "
                                "points were booked: narrow passages or room to pass.")
    parser.add_argument("--narrow", type=float, default=NARROW,
                        help=f"metres under which a passage is narrow (default {NARROW:g})")
    args = parser.parse_args(argv)
    if not 0.0 < args.narrow < 100.0:
        parser.error(f"--narrow {args.narrow:g}: must be more than 0 and less than 100 m")
    tally = tally_of(rows_of_set(parser, args), narrow=args.narrow)
    if not tally.episodes or not tally.points:
        parser.error(f"{args.directory / 'summary.json'}: no {args.executive} episode of the "
                     f"{args.scenario!r} set with a profile and a recording")
    print("\n".join(table_lines(tally, narrow=args.narrow)))
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(interruptible(PROG, main))
