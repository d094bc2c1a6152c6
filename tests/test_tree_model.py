"""The mission tree's Groot2 model is generated from the code and kept in step with it."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from bt_servicesim.tree.loading import DEFAULT_TREE
from bt_servicesim.tree.model import model_for, with_model

COMMAND = [sys.executable, "-m", "bt_servicesim.tree_model"]


def test_the_committed_tree_has_an_up_to_date_model() -> None:
    result = subprocess.run([*COMMAND, "--check", str(DEFAULT_TREE)], capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr


def test_regenerating_is_idempotent_and_declares_every_custom_tag(tmp_path: Path) -> None:
    tree = tmp_path / "tree.xml"
    shutil.copy(DEFAULT_TREE, tree)
    model = model_for(tree)
    once = with_model(tree.read_text(), model)
    assert with_model(once, model) == once
    for tag in ("NavigateToPose", "PickUpGuest", "GuestInRange", "SimTimeout", "RobotInArea"):
        assert f'ID="{tag}"' in model
    assert '<output_port name="waypoints" type="list[Pose2D]"/>' in model


def test_a_stale_model_is_reported_and_rewritten(tmp_path: Path) -> None:
    tree = tmp_path / "tree.xml"
    tree.write_text(DEFAULT_TREE.read_text().replace('ID="RobotInArea"', 'ID="Gone"'))
    stale = subprocess.run([*COMMAND, "--check", str(tree)], capture_output=True, text=True,
                           timeout=120)
    assert stale.returncode == 1 and "stale" in stale.stderr
    assert subprocess.run([*COMMAND, str(tree)], timeout=120).returncode == 0
    assert subprocess.run([*COMMAND, "--check", str(tree)], timeout=120).returncode == 0
