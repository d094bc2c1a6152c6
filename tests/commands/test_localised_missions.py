"""Whole missions in which the executive knows its map pose only from localisation.

Odometry starts at zero where the robot spawned, so an executive that took it for a map pose
would be off by the whole start pose (on the shipped task 11.6 m and turned by pi). These runs
start far from the map's origin and turned, and must complete: the tree's pose reader composes
localisation's map -> odom with odometry, and its first pose is the start pose in the map.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from tests.commands.test_end_to_end import SHIPPED_TASK_GROUP, assert_completed, mission

POSE = re.compile(r"robot at \((-?[\d.]+), (-?[\d.]+), (-?[\d.]+)\)")


LAUNCH_POSE = (-24.469, 6.278)  # AMCL's estimate until the tree's initial pose arrives


def first_pose(out: Path) -> tuple[float, float, float]:
    """The first robot pose the tree's localised pose reader wrote (from its feedback) once
    its initial pose had arrived: before, localisation gives AMCL's launch pose, as the
    original's does."""
    for line in (out / "tree_log.jsonl").read_text().splitlines():
        row = json.loads(line)
        if row.get("kind") != "tick":
            continue
        for name, (_, feedback) in row["nodes"].items():
            found = POSE.fullmatch(feedback or "") if name.endswith("Pose2BB") else None
            if found:
                x, y, yaw = (float(value) for value in found.groups())
                if math.dist((x, y), LAUNCH_POSE) > 0.1:
                    return x, y, yaw
    raise AssertionError("the pose reader never wrote a pose")


@pytest.mark.parametrize(("arguments", "start"), [
    # the shipped task (PublicBathroomB, facing west): the end-to-end tests' run of it
    pytest.param((), (10.975, 3.75, 3.14), id="shipped-task",
                 marks=pytest.mark.xdist_group(SHIPPED_TASK_GROUP)),
    pytest.param(("--seed", "2", "--sim-arg=--odom-drift=0.02"), (18.4, 13.1, -2.88),
                 id="seed-2-with-odometry-drift"),  # 22.6 m out, turned
])
def test_a_mission_starting_far_from_the_origin_and_turned_completes_from_localisation(
        request: pytest.FixtureRequest, tmp_path: Path, arguments: tuple[str, ...],
        start: tuple[float, float, float]) -> None:
    if arguments:
        out = tmp_path
        code, report = mission(out, *arguments, "--trajectory", "never")
    else:
        shipped = request.getfixturevalue("shipped_task_run")
        out, code, report = shipped.out, shipped.code, shipped.report
    assert_completed(code, report)
    x, y, yaw = first_pose(out)
    assert math.dist((x, y), start[:2]) < 0.1
    assert abs(math.remainder(yaw - start[2], math.tau)) < 0.1
