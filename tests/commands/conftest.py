"""What the command tests share: the shipped task's mission, run once per test process.

Two modules judge that one run (the end-to-end tests, by the referee's report and the tree log;
the localisation tests, by the pose the tree first read), so it runs once for both: they are in
one pytest-xdist group (``SHIPPED_TASK_GROUP``), which ``make test`` (``--dist loadgroup``)
gives to one worker.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from tests.commands.test_end_to_end import mission


@dataclass(frozen=True)
class FinishedRun:
    out: Path
    code: int
    report: dict[str, Any]


@pytest.fixture(scope="session")
def shipped_task_run(tmp_path_factory: pytest.TempPathFactory) -> FinishedRun:
    """``python -m bt_servicesim.run`` on the shipped task, with no other argument."""
    out = tmp_path_factory.mktemp("shipped_task") / "run"
    code, report = mission(out)
    return FinishedRun(out=out, code=code, report=report)
