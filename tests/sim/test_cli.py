"""``python -m servicesim_sim``: bad arguments and broken world files are one line, exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SIM = [sys.executable, "-m", "servicesim_sim"]


def simulator(*arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*SIM, *arguments], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        (["--speed", "-2"], "--speed"),
        (["--speed", "fast"], "--speed"),
        (["--seed", "-1"], "--seed"),
        (["--difficulty", "brutal"], "--difficulty"),
        (["--rfid-dropout", "1.5"], "--rfid-dropout"),
        (["--nav-abort-probability", "-0.1"], "--nav-abort-probability"),
        (["--camera-rate", "100"], "--camera-rate"),
        (["--world", "no/such/world.yaml"], "no/such/world.yaml"),
        (["--teleport"], "--teleport"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(arguments: list[str], named: str) -> None:
    result = simulator(*arguments)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and named in lines[0], result.stderr
    assert result.stdout == ""


def test_a_broken_world_file_is_named_in_one_line(tmp_path: Path) -> None:
    world = tmp_path / "world.yaml"
    world.write_text("name: broken\nmap: missing_map.yaml\n")
    result = simulator("--world", str(world))
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "world.yaml" in lines[0] and "missing_map.yaml" in lines[0]
