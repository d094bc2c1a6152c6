"""What a run's settings decide on their own: when the trajectory picture is drawn."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from bt_servicesim.mission.settings import TRAJECTORY_POLICIES, RunSettings

SETTINGS = RunSettings(world=None, seed=None, speed=0.0, tree=Path("tree.xml"), out=Path("run"),
                       time_limit_s=900.0, headless=True, executive="bt")


@pytest.mark.parametrize(("policy", "after_completed", "after_failed"), [
    ("always", True, True),
    ("failed", False, True),
    ("never", False, False),
])
def test_each_trajectory_policy_draws_the_picture_when_it_says(
        policy: str, after_completed: bool, after_failed: bool) -> None:
    settings = replace(SETTINGS, trajectory=policy)
    assert settings.draws_trajectory(completed=True) is after_completed
    assert settings.draws_trajectory(completed=False) is after_failed


def test_every_policy_is_covered_and_always_is_the_default() -> None:
    assert set(TRAJECTORY_POLICIES) == {"always", "failed", "never"}
    assert SETTINGS.trajectory == "always"
