"""The worked example in docs/architecture.md ("How to add a leaf") works as written.

The leaf and its test are taken from the page's two Python blocks and run in a child pytest,
the leaf as the module the page names: the example cannot go stale without this test failing.
The child keeps the new XML tag out of this process's registry of nodes.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PAGE = REPO / "docs" / "architecture.md"


def python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.DOTALL)


def test_the_worked_example_of_a_leaf_passes_its_own_test(tmp_path: Path) -> None:
    leaf, test = python_blocks(PAGE.read_text())
    package = tmp_path / "example"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "robot_near_pose.py").write_text(leaf)
    test = test.replace("bt_servicesim.behaviours.conditions.robot_near_pose",
                        "example.robot_near_pose")
    (tmp_path / "test_robot_near_pose.py").write_text(test)
    environment = {**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{REPO}"}
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
         "--rootdir", str(tmp_path), str(tmp_path / "test_robot_near_pose.py")],
        capture_output=True, text=True, cwd=tmp_path, env=environment, timeout=120)
    assert result.returncode == 0, result.stdout[-3000:]
    assert "1 passed" in result.stdout
