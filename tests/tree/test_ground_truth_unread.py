"""The mission tree decides from what a real robot has, never from the simulator's ground truth.

The simulator publishes extensions the original never had: the referee's books
(``/servicesim/referee``), where everyone stands (``/servicesim/actors``) and the robot's true
pose (``/servicesim/ground_truth/odom``). Records and reports
may read them; a behaviour, a tree file or a planning module that did would make the executive
depend on something only this simulator offers.
"""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
GROUND_TRUTH = ("/servicesim/referee", "/servicesim/actors", "/servicesim/ground_truth",
                "/servicesim/markers", "RefereeState", "ActorStates")
DECIDING = [*(REPO / "bt_servicesim" / package for package in ("behaviours", "tree", "planning")),
            REPO / "trees"]


def deciding_sources() -> list[Path]:
    return sorted(path for root in DECIDING for path in root.rglob("*")
                  if path.suffix in (".py", ".xml"))


def test_the_deciding_code_is_found() -> None:
    names = {path.name for path in deciding_sources()}
    assert {"servicesim_mission.xml", "navigate_to_pose.py", "rules.py", "loading.py"} <= names


@pytest.mark.parametrize("needle", GROUND_TRUTH)
def test_no_behaviour_or_tree_reads_the_simulators_ground_truth(needle: str) -> None:
    readers = [str(path.relative_to(REPO)) for path in deciding_sources()
               if needle in path.read_text()]
    assert readers == []
